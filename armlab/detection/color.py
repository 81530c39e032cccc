"""Block colour classification: white balance from the board, then nearest class in chromaticity space.

Why not HSV thresholds (the lab report's Table IV)? Their ranges overlap (blue 96-130 and violet 110-141), red wraps
around hue 0 and is missed below 140, and dark blocks (green, blue) have weak saturation that noise scatters. Here:
1. white balance: the board is neutral, so per-channel gains that make the board grey remove the lighting's tint;
2. features: chromaticity (r, g) = (R, G) / (R + G + B) of the face's mean colour, which ignores brightness (shading
   and lighting level), plus a small weight on log brightness to split colours of equal chroma but different
   lightness;
3. a nearest-class rule with per-class spread (a diagonal Mahalanobis distance), calibrated from labelled samples.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armlab.blocks import COLORS, LAB_RGB

__all__ = ["ColorModel", "color_features", "white_balance_gains"]

_BRIGHTNESS_WEIGHT = 0.08


def white_balance_gains(board_rgb_mean) -> np.ndarray:
    """Per-channel gains (3,) that turn the board's mean colour (3,) into a neutral grey of the same brightness."""
    m = np.asarray(board_rgb_mean, float)
    if m.shape != (3,) or not np.all(np.isfinite(m)) or np.any(m <= 0):
        return np.ones(3)
    return m.mean() / m


def color_features(rgb_mean) -> np.ndarray:
    """Features (N, 3): chromaticity r, g and weighted log brightness of mean colours (N, 3) (white-balanced RGB)."""
    c = np.asarray(rgb_mean, float).reshape(-1, 3) + 1.0
    s = c.sum(axis=1, keepdims=True)
    return np.column_stack([c[:, :2] / s, _BRIGHTNESS_WEIGHT * np.log(s[:, 0])])


@dataclass(frozen=True)
class ColorModel:
    """Class means (K, 3) and standard deviations (K, 3) of color_features for the class names (K,)."""

    names: tuple[str, ...]
    means: np.ndarray
    stds: np.ndarray

    @staticmethod
    def from_reference(rgb: dict[str, tuple[int, int, int]] | None = None, std: float = 0.03) -> ColorModel:
        """A prior model from reference colours (default: the lab's measured block colours), equal spreads."""
        rgb = rgb or LAB_RGB
        names = tuple(c for c in COLORS if c in rgb)
        means = color_features(np.array([rgb[n] for n in names]))
        return ColorModel(names, means, np.full_like(means, std))

    @staticmethod
    def fit(rgb_means, labels, min_std: float = 0.01) -> ColorModel:
        """Calibrate from labelled samples: mean colours (N, 3) of block faces (white-balanced) and their names."""
        X = color_features(rgb_means)
        labels = np.asarray(labels)
        names = tuple(c for c in COLORS if np.any(labels == c))
        if len(names) < 2:
            raise ValueError("fitting a colour model needs labelled samples of at least two colours")
        means = np.array([X[labels == n].mean(axis=0) for n in names])
        stds = np.array([np.maximum(X[labels == n].std(axis=0), min_std) for n in names])
        return ColorModel(names, means, stds)

    def distances(self, rgb_means) -> np.ndarray:
        """Normalised distances (N, K) of mean colours (N, 3) to every class."""
        X = color_features(rgb_means)
        return np.sqrt((((X[:, None, :] - self.means[None]) / self.stds[None]) ** 2).sum(-1))

    def classify(self, rgb_means) -> tuple[list[str], np.ndarray]:
        """Nearest class name per mean colour (N, 3), and the margin (N,): second-best minus best distance."""
        # BEGIN SOLUTION
        d = self.distances(rgb_means)
        order = np.argsort(d, axis=1)
        best = [self.names[i] for i in order[:, 0]]
        rows = np.arange(len(d))
        margin = d[rows, order[:, 1]] - d[rows, order[:, 0]] if d.shape[1] > 1 else np.full(len(d), np.inf)
        # END SOLUTION
        return best, margin

    def save(self, path) -> None:
        """Write the model as JSON (atomic)."""
        path = Path(path)
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(json.dumps({"names": list(self.names), "means": self.means.tolist(),
                                   "stds": self.stds.tolist()}, indent=1))
        tmp.replace(path)

    @staticmethod
    def load(path) -> ColorModel:
        """Read a model saved by save(); raises ValueError naming the file and problem."""
        path = Path(path)
        try:
            raw = json.loads(path.read_text())
            model = ColorModel(tuple(raw["names"]), np.array(raw["means"], float), np.array(raw["stds"], float))
        except FileNotFoundError:
            raise ValueError(f"{path}: colour model file not found") from None
        except (json.JSONDecodeError, KeyError, TypeError, ValueError) as e:
            raise ValueError(f"{path}: corrupt colour model ({e})") from None
        k = len(model.names)
        if model.means.shape != (k, 3) or model.stds.shape != (k, 3) or np.any(model.stds <= 0):
            raise ValueError(f"{path}: colour model arrays must be ({k}, 3) with positive spreads")
        return model
