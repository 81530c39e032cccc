"""armlab.detection.edges' batched helpers against straightforward per-row formulas, exactly (==, not approx): the
side refinement's profiles (finite rows, the least before a crossing, the greatest within a reach, interpolation)
and its line fits, on random profiles with NaN and inf, empty and one-row batches and rows whose crossing is at
either end."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.detection import edges as E

K = len(E._PROFILE_S)


def _profiles(rng, n: int, holes: bool = True) -> np.ndarray:
    """(n, K) float32 colour-distance-like profiles: low inside, rising past EDGE_LEVEL somewhere (or never, or at
    the first sample), with NaN and inf sprinkled in when `holes`."""
    p = (rng.random((n, K)) * 3.0).astype(np.float32)
    rise = rng.integers(0, K + 1, n)                       # K: never reaches the level
    p[np.arange(K) >= rise[:, None]] += np.float32(E.EDGE_LEVEL)
    if holes and n:
        p.ravel()[rng.choice(p.size, size=max(1, p.size // 40), replace=False)] = np.nan
        p.ravel()[rng.choice(p.size, size=max(1, p.size // 200), replace=False)] = np.inf
    return p


@pytest.mark.parametrize("n", [0, 1, 7, 500])
def test_finite_rows_is_whether_the_row_sum_is_finite(n):
    rng = np.random.default_rng(n)
    p = _profiles(rng, n)
    if n:
        p[0, 0], p[-1, -1] = np.nan, -np.inf                   # a hole at either end of a row
    got = E._finite_rows(p, E._row_starts(p))
    assert got.dtype == bool and got.shape == (n,)
    np.testing.assert_array_equal(got, np.isfinite(p.sum(axis=-1)))


@pytest.mark.parametrize("n", [0, 1, 7, 500])
def test_prefix_min_is_the_least_before_stop(n):
    rng = np.random.default_rng(10 + n)
    p = _profiles(rng, n, holes=False)
    stop = rng.integers(1, K + 1, n)
    if n:
        stop[0] = 1
        stop[-1] = K
    expected = np.array([row[:k].min() for row, k in zip(p, stop, strict=True)], np.float32)
    got = E._prefix_min(p, stop, E._row_starts(p))
    assert got.dtype == p.dtype
    np.testing.assert_array_equal(got, expected)
    # the formulation it replaces, for the record
    np.testing.assert_array_equal(got, np.where(np.arange(K) < stop[:, None], p, np.inf).min(axis=-1))


@pytest.mark.parametrize("reach", [0, 1, 3, K + 2])
def test_window_max_is_the_greatest_within_reach_cut_at_the_row_end(reach):
    rng = np.random.default_rng(reach)
    p = _profiles(rng, 300, holes=False)
    first = rng.integers(0, K, len(p))
    first[:3] = [0, K - 1, K - 2]
    expected = np.array([row[k:k + reach + 1].max() for row, k in zip(p, first, strict=True)], np.float32)
    got = E._window_max(p, first, reach, E._row_starts(p))
    assert got.dtype == p.dtype
    np.testing.assert_array_equal(got, expected)
    assert len(E._window_max(p[:0], first[:0], reach, E._row_starts(p[:0]))) == 0


def test_interpolate_and_crossings_match_the_per_row_formula():
    rng = np.random.default_rng(3)
    p = _profiles(rng, 200, holes=False)
    s = E._PROFILE_S
    x = rng.uniform(s[0] - 2.0, s[-1] + 2.0, (2, len(p)))   # off either end too: clipped
    x[0, :2] = s[0], s[-1]
    got = E._interpolate(p, s, x, E._row_starts(p))
    assert got.shape == x.shape
    np.testing.assert_array_equal(got, E._interpolate(p, s, x))       # starts only saves recomputing them
    for j in range(2):
        for r in range(len(p)):
            f = np.float64(min(max((x[j, r] - s[0]) / E.EDGE_STEP_MM, 0.0), K - 1.0))   # float64, as batched
            i = min(int(f), K - 2)
            assert got[j, r] == p[r, i] + (f - i) * (p[r, i + 1] - p[r, i])
    numpy_interp = [np.interp(v, s, row) for v, row in zip(x[0], p, strict=True)]
    np.testing.assert_allclose(got[0], numpy_interp, rtol=0, atol=1e-5)
    level = rng.uniform(0.0, 8.0, len(p))
    level[:2] = [-1.0, 100.0]                                 # reached at the first sample / never
    cross = E._crossings(p, s, level, E._row_starts(p))
    np.testing.assert_array_equal(cross, E._crossings(p, s, level))
    for r in range(len(p)):
        m = max(int(np.argmax(p[r] >= level[r])), 1)
        p0, p1 = p[r, m - 1], p[r, m]
        frac = np.minimum(np.maximum((level[r] - p0) / (p1 - p0 if p1 > p0 else 1.0), 0.0), 1.0)
        assert cross[r] == s[0] + E.EDGE_STEP_MM * (m - 1 + frac)


@pytest.mark.parametrize("n", [0, 1, 60])
def test_edge_offsets_of_any_batch(n):
    """Shapes and the found flags on empty, one-profile and NaN-holed batches; a NaN row is not found and its
    offsets are finite; a profile crossing at a known place is found there."""
    rng = np.random.default_rng(20 + n)
    p = _profiles(rng, n).reshape(n, 1, K) if n else np.zeros((0, 1, K), np.float32)
    edge, ok = E._edge_offsets(p, E._PROFILE_S, 0.6, 0.6)
    assert edge.shape == (n, 1, 2) and ok.shape == (n, 1)
    assert np.isfinite(edge).all()
    if n:
        assert not ok[~np.isfinite(p.sum(axis=-1))].any()
    step = np.where(E._PROFILE_S < 0.25, 0.0, 2 * E.EDGE_LEVEL).astype(np.float32)[None, None]
    edge, ok = E._edge_offsets(step, E._PROFILE_S, 1.0, 1.0)
    assert ok.all() and edge[0, 0, 0] == pytest.approx(0.0, abs=0.26)


@pytest.mark.parametrize("rows", [1, 5, 120])
def test_line_fits_with_shared_points_are_the_same_fits(rows):
    rng = np.random.default_rng(rows)
    t = np.sort(rng.uniform(-15, 15, (rows, 21)), axis=1)
    y = 0.3 + 0.02 * t + rng.normal(0, 0.1, t.shape)
    w = rng.random(t.shape) > 0.3
    w[0] = False                                              # a row with no points
    points = E._fit_points(t, w)
    b, a = E._line_fits(t, y, w)
    for got, want in zip(E._line_fits(t, y, w, points), (b, a), strict=True):
        np.testing.assert_array_equal(got, want)
    n = points[0]
    np.testing.assert_array_equal(n, w.sum(axis=1))
    spread = E._spread(t, w, n)
    assert spread[0] == 0.0 and b[0] == 0.0 and a[0] == 0.0
    for r in range(1, rows):
        if n[r] >= 2:
            assert spread[r] == t[r][w[r]].max() - t[r][w[r]].min()
            np.testing.assert_allclose([b[r], a[r]], np.polyfit(t[r][w[r]], y[r][w[r]], 1), rtol=1e-9, atol=1e-9)


def test_refine_yaws_of_no_faces():
    assert E.refine_yaws(None, []).shape == (0,)


def _square_outline(centre, edge: float, yaw: float, per_side: int = 30) -> np.ndarray:
    """(4 per_side, 2) mm: points along a square's sides, counterclockwise."""
    u = np.linspace(0.0, 1.0, per_side, endpoint=False)
    corners = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    local = np.concatenate([a + (b - a) * u[:, None] for a, b in zip(corners, np.roll(corners, -1, axis=0),
                                                                       strict=True)]) * edge
    c, s = np.cos(yaw), np.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + centre


@pytest.mark.parametrize("n_blocked, complete", [(0, True), (2, True), (30, False), (110, True)])
def test_fit_square_by_the_blocked_share(n_blocked, complete):
    """No blocked outline, or under 2 % of it: the whole outline, complete; a side's worth: the free points and the
    hint, incomplete; more than 80 % blocked: too little to tell, measured whole again."""
    points = _square_outline([100.0, -50.0], 25.0, 0.2)
    blocked = np.zeros(len(points), bool)
    blocked[:n_blocked] = True
    centre, sides, theta, done = E.fit_square(points, blocked, 0.5, 25.0)
    assert done is complete
    np.testing.assert_allclose(centre, [100.0, -50.0], atol=0.3)
    np.testing.assert_allclose(sides, 25.0, atol=0.6)
    assert np.cos(4 * (theta - 0.2)) > np.cos(4 * np.radians(0.5))
    whole = E.fit_square(points, np.zeros(len(points), bool), 0.5, 25.0)
    if n_blocked == 110:
        for got, want in zip((centre, sides, theta, done), whole, strict=True):
            np.testing.assert_array_equal(got, want)


def _one_side_seen(centre, yaw: float, side: int) -> tuple[np.ndarray, np.ndarray]:
    """The outline (N, 2) mm and its blocked flags of a 25 mm face of which only a strip 8.5 mm wide is in view, the
    rest hidden behind an occluder (the arm in front of a block behind the base): the strip's one free outline is the
    face's side at local x = -side * 12.5 mm (side +1: the occluder on the +x side); its other sides touch it."""
    t = np.linspace(-12.5, 12.5, 21)
    xs = np.linspace(-side * 12.5, -side * 4.0, 8)[1:]
    seen = np.column_stack([np.full_like(t, -side * 12.5), t])
    rest = np.concatenate([np.column_stack([xs, np.full_like(xs, 12.5)]),
                           np.column_stack([np.full_like(t, -side * 4.0), t[::-1]]),
                           np.column_stack([xs[::-1], np.full_like(xs, -12.5)])])
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.concatenate([seen, rest])
    return local @ np.array([[c, s], [-s, c]]) + centre, np.r_[np.zeros(len(seen), bool), np.ones(len(rest), bool)]


@pytest.mark.parametrize("side", [1, -1])
@pytest.mark.parametrize("yaw", [0.0, 0.1, -0.1, 0.7, 1.5, -1.45])
def test_a_mostly_hidden_face_goes_on_under_what_hides_it(side, yaw):
    """Only one side of the face is free outline: the face's centre is half an edge from it towards the occluder,
    never out over the board that is seen bare (the fuzz test's seed 242: a block behind the robot's base, seen as a
    strip beside the arm, was placed 21.7 mm off towards the free board; the side was chosen by which end of the
    free outline had more points near it, a tie for a single straight side)."""
    points, blocked = _one_side_seen([-40.0, -140.0], yaw, side)
    centre, sides, _, done = E.fit_square(points, blocked, 1.2, 25.0)
    assert not done
    np.testing.assert_allclose(centre, [-40.0, -140.0], atol=1.0)
    np.testing.assert_allclose(sides, 25.0, atol=1.25)   # a side seen whole: + pixel_mm (1.2)


def test_edge_direction_of_a_turned_square_and_its_free_chords():
    points = _square_outline([0.0, 0.0], 38.0, -0.3)
    assert E.edge_direction(points, -0.28) == pytest.approx(-0.3, abs=1e-9)
    free = np.ones(len(points), bool)
    assert E.edge_direction(points, -0.28, free=free) == E.edge_direction(points, -0.28)
    assert E.edge_direction(points, -0.28, free=~free) == -0.28      # no free chord: the hint stays
    assert E.edge_direction(points[:10], 0.1) == 0.1                  # too few points
