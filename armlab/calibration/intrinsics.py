"""Intrinsic calibration from checkerboard images (Zhang's method through OpenCV).

Units: pixels for K and reprojection errors; the checkerboard's square size in mm sets the scale of the board
poses (which the result also reports, camera frame, mm).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from armlab.arguments import finite_float, int_in_range, plain
from armlab.images import check_gray_or_rgb
from armlab.repeatable import opencv_single_thread

__all__ = ["IntrinsicsResult", "calibrate_intrinsics", "find_checkerboard", "checkerboard_points",
           "compare_intrinsics", "check_pattern", "DUPLICATE_VIEW_PX"]

_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4)
DUPLICATE_VIEW_PX = 3.0      # two views whose corners agree to this RMS (px) show the board in one pose


@dataclass(frozen=True)
class IntrinsicsResult:
    """Camera matrix K (3, 3) px, distortion (5,) Brown-Conrady, overall RMS reprojection error (px), per-view RMS
    (px) of the views used, their indices in the input list, the views rejected with the reason, the image size
    (width, height), and each used view's board pose as rotation vectors / translations (camera frame, mm)."""

    K: np.ndarray
    dist: np.ndarray
    rms: float
    per_view_rms: np.ndarray
    used_views: list[int]
    rejected_views: dict[int, str]
    image_size: tuple[int, int]
    rvecs: list[np.ndarray] = field(repr=False, default_factory=list)
    tvecs: list[np.ndarray] = field(repr=False, default_factory=list)

    def summary(self) -> str:
        """One line: focal lengths, centre, RMS and how many views were used."""
        fx, fy, cx, cy = self.K[0, 0], self.K[1, 1], self.K[0, 2], self.K[1, 2]
        return (f"fx={fx:.1f} fy={fy:.1f} cx={cx:.1f} cy={cy:.1f} px, RMS {self.rms:.3f} px "
                f"over {len(self.used_views)} views ({len(self.rejected_views)} rejected)")


def check_pattern(pattern_size, square_mm) -> tuple[tuple[int, int], float]:
    """((columns, rows), square_mm) checked: the checkerboard's inner corners (2-1000 each way, integers) and its
    square edge (mm, positive and finite); ValueError naming the one that is wrong."""
    try:
        cols, rows = (int(n) for n in pattern_size)
        ok = (cols, rows) == tuple(pattern_size) and 2 <= cols <= 1000 and 2 <= rows <= 1000
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise ValueError(f"pattern_size must be two whole numbers of INNER corners (columns, rows), each from 2 to "
                         f"1000, got {plain(pattern_size)}")
    return (cols, rows), finite_float(square_mm, "square_mm", positive=True, what="mm")


def checkerboard_points(pattern_size: tuple[int, int], square_mm: float) -> np.ndarray:
    """Board-frame coordinates (N, 3) mm of the inner corners, row by row as OpenCV returns them (z = 0)."""
    (cols, rows), square_mm = check_pattern(pattern_size, square_mm)
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * float(square_mm)
    return np.column_stack([grid, np.zeros(len(grid))]).astype(np.float32)


def find_checkerboard(image, pattern_size: tuple[int, int] = (9, 6)) -> np.ndarray | None:
    """Sub-pixel inner-corner positions (N, 2) px of a checkerboard in a uint8 gray or RGB image, or None.
    """
    gray = check_gray_or_rgb(image)
    pattern_size, _ = check_pattern(pattern_size, 1.0)
    found, corners = cv2.findChessboardCorners(
        gray, pattern_size, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not found:
        return None
    corners = cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), _SUBPIX_CRITERIA)
    return corners.reshape(-1, 2)


def calibrate_intrinsics(images, pattern_size: tuple[int, int] = (9, 6), square_mm: float = 25.0,
                         fix_k3: bool = False, min_views: int = 3) -> IntrinsicsResult:
    """Calibrate K and distortion from checkerboard views.

    Args:
        images: list of uint8 grayscale (H, W) or RGB (H, W, 3) images, all the same size.
        pattern_size: inner corners (columns, rows).
        square_mm: edge of one square (mm).
        fix_k3: keep k3 = 0. Only for a lens with little distortion or too few views (k3 can over-fit); the
            simulated L515 lens has k3 = 0.2, and fixing it leaves ~10 px of model error in the image corners.
        min_views: fewest views in which the board must be found (at least 3).

    Near-duplicate views (the board in one pose twice, corners within DUPLICATE_VIEW_PX RMS) are rejected (see
    rejected_views): they add no information, and copies of one view make the fit absurd.
    Raises ValueError for bad images, mixed sizes, or too few distinct views with a board.
    """
    pattern_size, square_mm = check_pattern(pattern_size, square_mm)
    if isinstance(images, np.ndarray) and (images.ndim == 2 or (images.ndim == 3 and images.shape[2] == 3)):
        raise ValueError(f"images must be a list of images, got one array of shape {images.shape}")
    try:
        images = list(images)
    except TypeError:
        raise TypeError(f"images must be a list of checkerboard images, got {type(images).__name__}") from None
    if len(images) == 0:
        raise ValueError("calibrate_intrinsics needs a list of checkerboard images, got none")
    min_views = int_in_range(min_views, "min_views", 3, 10_000, "Zhang's method needs 3 views of a plane")
    object_points = checkerboard_points(pattern_size, square_mm)
    size = None
    obj, img, used, rejected = [], [], [], {}
    for i, image in enumerate(images):
        gray = check_gray_or_rgb(image, f"images[{i}]")
        if size is None:
            size = gray.shape[::-1]
        elif gray.shape[::-1] != size:
            raise ValueError(f"images[{i}] is {gray.shape[1]}x{gray.shape[0]}, the first is {size[0]}x{size[1]}")
        corners = find_checkerboard(gray, pattern_size)
        if corners is None:
            rejected[i] = f"no {pattern_size[0]}x{pattern_size[1]} checkerboard found"
            continue
        obj.append(object_points)
        img.append(corners.astype(np.float32))
        used.append(i)
    found = len(used)
    for k, earlier in _near_duplicates(img).items():
        rejected[used[k]] = (f"a near-duplicate of images[{used[earlier]}] (corners within {DUPLICATE_VIEW_PX} px "
                             f"RMS): it adds no new pose")
    keep = [k for k in range(found) if used[k] not in rejected]
    obj, img, used = [obj[k] for k in keep], [img[k] for k in keep], [used[k] for k in keep]
    if len(used) < min_views:
        twins = (f", {found - len(used)} of them near-duplicates of another view, which leaves {len(used)} distinct"
                 if found > len(used) else "")
        raise ValueError(f"the checkerboard was found in {found} of {len(images)} images{twins}; at least "
                         f"{min_views} views of the board in different poses are needed (check "
                         f"pattern_size={tuple(pattern_size)} counts INNER corners)")
    flags = cv2.CALIB_FIX_K3 if fix_k3 else 0
    with opencv_single_thread():          # the threaded solver's sums are not repeatable (armlab.repeatable)
        rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(obj, img, size, None, None, flags=flags)
    per_view = []
    for o, m, r, t in zip(obj, img, rvecs, tvecs):
        proj, _ = cv2.projectPoints(o, r, t, K, dist)
        per_view.append(float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - m) ** 2, axis=1)))))
    return IntrinsicsResult(K=K, dist=dist.ravel()[:5], rms=float(rms), per_view_rms=np.array(per_view),
                            used_views=used, rejected_views=rejected, image_size=tuple(size),
                            rvecs=[r.ravel() for r in rvecs], tvecs=[t.ravel() for t in tvecs])


def _near_duplicates(corners: list[np.ndarray]) -> dict[int, int]:
    """{view: the earlier view it nearly repeats} for views whose corners (N, 2) px lie within DUPLICATE_VIEW_PX
    RMS of an earlier kept view's, in the same or the reversed corner order (OpenCV may number a turned board from
    the other end). Copies of one view make Zhang's method fit noise: five copies gave fx 955 / fy 1022 px where
    the truth is 893."""
    if len(corners) < 2:
        return {}
    c = np.stack([np.asarray(x, float) for x in corners])                   # (V, N, 2)
    same = np.sqrt(((c[:, None] - c[None]) ** 2).sum(-1).mean(-1))           # (V, V) RMS px
    turned = np.sqrt(((c[:, None] - c[None, :, ::-1]) ** 2).sum(-1).mean(-1))
    close = np.minimum(same, turned) < DUPLICATE_VIEW_PX
    out: dict[int, int] = {}
    for j in range(1, len(c)):
        earlier = [i for i in np.flatnonzero(close[j, :j]) if i not in out]
        if earlier:
            out[j] = int(earlier[0])
    return out


def compare_intrinsics(K_a, K_b) -> dict[str, float]:
    """Differences K_a - K_b in fx, fy, cx, cy (px) and the relative focal-length difference (%)."""
    K_a, K_b = np.asarray(K_a, float), np.asarray(K_b, float)
    return {"dfx_px": K_a[0, 0] - K_b[0, 0], "dfy_px": K_a[1, 1] - K_b[1, 1],
            "dcx_px": K_a[0, 2] - K_b[0, 2], "dcy_px": K_a[1, 2] - K_b[1, 2],
            "focal_rel_pct": 100 * float(np.mean([(K_a[0, 0] - K_b[0, 0]) / K_b[0, 0],
                                                   (K_a[1, 1] - K_b[1, 1]) / K_b[1, 1]]))}
