"""Stack arithmetic: how many blocks high a stack is, and every height a top face can have, from the lab's block
edges (lab.json). Units: mm.
"""

from __future__ import annotations

import functools

import numpy as np

from armlab.lab import lab_config

__all__ = ["stack_levels", "stack_heights"]


def stack_levels(top_z: float, edge_mm: float, edges=None, max_levels: int = 6) -> int:
    """How many blocks high a stack is whose top block (edge `edge_mm`) has its top face at `top_z` (mm).

    The stack is the top block over blocks at least as large (the lab stacks larger blocks below): the count of
    large and small blocks whose heights add up closest to top_z, the fewer blocks on a near tie (< 1.5 mm)."""
    edges = tuple(sorted((edges or lab_config().block_edges_mm).values(), reverse=True))
    below = top_z - edge_mm
    large_top = edge_mm > edges[-1] + 0.5 * (edges[0] - edges[-1])
    best_err, best_levels = np.inf, 1
    for height, levels in _stack_candidates(edges, max_levels, large_top):
        err = abs(below - height)
        if err < best_err - 1.5 or (abs(err - best_err) <= 1.5 and levels < best_levels):
            best_err, best_levels = err, levels
    return best_levels


@functools.lru_cache(maxsize=16)
def _stack_candidates(edges: tuple, max_levels: int, large_top: bool) -> tuple[tuple[float, int], ...]:
    """The (height below the top block, levels) of every stack stack_levels weighs, in its order of trial: large
    edges[0] and small edges[-1] blocks under the top one (no small one under a large top)."""
    return tuple((n_big * edges[0] + n_small * edges[-1], 1 + n_big + n_small)
                 for n_big in range(max_levels) for n_small in range(max_levels - n_big)
                 if not (n_small and large_top))


@functools.lru_cache(maxsize=4)
def stack_heights(max_levels: int = 6, include_zero: bool = False) -> np.ndarray:
    """Every height (mm) a top face can have: sums of 1..max_levels of the lab's block edges (and 0 if asked: the
    heights a block can stand on)."""
    a, b = lab_config().block_edges_mm.values()
    return np.array(sorted({i * a + j * b for i in range(max_levels + 1) for j in range(max_levels + 1 - i)
                            if i + j > 0 or include_zero}))
