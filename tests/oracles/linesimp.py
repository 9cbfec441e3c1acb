"""Independent reference implementations used as test oracles.

Written from the papers' definitions in plain Python, sharing no code with rperc.
"""

from __future__ import annotations

import itertools
import math

import numpy as np


def line_distance(p, a, b) -> float:
    """Distance from p to the infinite line through a and b (to a when a == b)."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    norm = math.hypot(dx, dy)
    if norm == 0.0:
        return math.hypot(p[0] - a[0], p[1] - a[1])
    return abs(dx * (p[1] - a[1]) - dy * (p[0] - a[0])) / norm


def douglas_peucker(points: np.ndarray, epsilon: float) -> list[int]:
    """Table 1 of the seed with the line metric, first-of-ties rule, explicit stack."""
    n = len(points)
    if n < 3:
        return list(range(n))
    keep = {0, n - 1}
    stack = [(0, n - 1)]
    while stack:
        i, j = stack.pop()
        best, split = -1.0, -1
        for k in range(i + 1, j):
            d = line_distance(points[k], points[i], points[j])
            if d > best:
                best, split = d, k
        if split >= 0 and best > epsilon:
            keep.add(split)
            stack += [(i, split), (split, j)]
    return sorted(keep)


def is_valid(points: np.ndarray, kept: np.ndarray, epsilon: float) -> bool:
    """Every dropped vertex lies within epsilon of the chord replacing it."""
    if len(points) < 2:
        return list(kept) == list(range(len(points)))
    if kept[0] != 0 or kept[-1] != len(points) - 1:
        return False
    scale = 1.0 + float(np.abs(points).max())
    for a, b in itertools.pairwise(kept):
        for k in range(a + 1, b):
            if line_distance(points[k], points[a], points[b]) > epsilon + 1e-9 * scale:
                return False
    return True
