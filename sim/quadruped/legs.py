"""Leg trajectories and blending (He, Tsai, Ko, Lu): the swing foot on a Bezier curve of 5 control points,
lifted where it would cut the terrain, and dynamic time warping to join one motion model to the next.

Pure numpy; the terrain is asked through ``TerrainGrid.ground_z_max`` (the highest surface within the
foot's radius), so "clear of the terrain" means the foot's sphere is above every column it passes over.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from sim.terrain import TerrainGrid

Array = NDArray[np.float64]

_BINOMIAL = np.array([1.0, 4.0, 6.0, 4.0, 1.0])
_KNOTS = np.linspace(0.0, 1.0, 65)
_SAMPLES = 0.5 * (_KNOTS[1:] + _KNOTS[:-1])  # one per piece of the curve between two knots


def bezier(control: Array, t: Array | float) -> Array:
    """Points of the degree-4 Bezier curve with ``control`` (5, 3) at parameters ``t`` (→ (len(t), 3))."""
    tt = np.atleast_1d(np.asarray(t, dtype=np.float64))[:, None]
    k = np.arange(5)[None, :]
    weights = _BINOMIAL[None, :] * tt**k * (1.0 - tt) ** (4 - k)
    out: Array = weights @ control
    return out


def _inner_weight(t: Array) -> Array:
    """How much raising the three inner control points by 1 raises the curve at ``t``."""
    out: Array = 1.0 - (1.0 - t) ** 4 - t**4
    return out


def clearance_deficit(grid: TerrainGrid, points: Array, radius: float, clearance: float) -> Array:
    """Per piece between consecutive ``points``: how far (m) its lower end is below the height that keeps
    a sphere of ``radius`` plus ``clearance`` above every column under the piece (≤ 0 when clear).
    Pieces, not points: a column's edge between two samples is not missed."""
    mid = 0.5 * (points[1:] + points[:-1])
    half = 0.5 * np.hypot(*(points[1:, :2] - points[:-1, :2]).T)
    need = np.array([grid.ground_z_max(float(m[0]), float(m[1]), radius + float(h)) for m, h in zip(mid, half, strict=True)])
    out: Array = need + radius + clearance - np.minimum(points[1:, 2], points[:-1, 2])
    return out


def swing_control_points(grid: TerrainGrid, start: Array, end: Array, lift: float, radius: float,
                         clearance: float = 0.01, max_rounds: int = 12) -> Array:
    """The 5 control points of a swing from foot centre ``start`` to ``end`` (stage metres).

    The paper's choice: start, first quartile, midpoint, third quartile, end of the step, the inner three
    lifted by ``lift`` above the higher end. Where the curve would cut the terrain (the foot's sphere
    under a column's top plus ``clearance``), the inner points are raised by just enough; where the cut
    is so close to an end that raising cannot help, the quartile point on that side moves over its end
    (the paper's "revise t": the foot lifts or lands vertically there) and the raise is tried again.
    """
    start = np.asarray(start, dtype=np.float64)
    end = np.asarray(end, dtype=np.float64)
    top = max(start[2], end[2]) + lift
    fractions = np.array([0.25, 0.5, 0.75])
    control = np.empty((5, 3))
    control[0], control[4] = start, end
    for _ in range(max_rounds):
        for i, f in enumerate(fractions, start=1):
            control[i, :2] = start[:2] + f * (end[:2] - start[:2])
            control[i, 2] = top
        w = _inner_weight(_SAMPLES)
        # full clearance in the middle of the swing, none needed right at lift-off and touch-down
        deficit = clearance_deficit(grid, bezier(control, _KNOTS), radius, 0.0) + clearance * (w >= 0.35)
        if deficit.max() <= 1e-9:
            return control
        worst = int(np.argmax(deficit))
        if w[worst] > 0.35:
            top += float(np.max(np.where(deficit > 0, deficit / np.maximum(w, 1e-6), 0.0)[w > 0.35]))
            continue
        if _SAMPLES[worst] < 0.5 and fractions[0] > 0.0:  # cut near the start: lift off more steeply
            fractions[0] = max(fractions[0] - 0.125, 0.0)
        elif _SAMPLES[worst] >= 0.5 and fractions[2] < 1.0:  # near the end: land more steeply
            fractions[2] = min(fractions[2] + 0.125, 1.0)
        else:
            top += float(deficit.max()) / max(float(w[worst]), 0.05)
    return control


def swing_position(control: Array, s: float) -> Array:
    """The swing foot at swing progress ``s`` ∈ [0, 1], eased so it leaves and lands with zero speed."""
    u = min(max(s, 0.0), 1.0)
    eased = u * u * (3.0 - 2.0 * u)
    out: Array = bezier(control, eased)[0]
    return out


# ---------------------------------------------------------------------- dynamic time warping
def dtw_path(a: Array, b: Array) -> list[tuple[int, int]]:
    """The dynamic-time-warping alignment of sequences ``a`` (n, d) and ``b`` (m, d): index pairs from
    (0, 0) to (n-1, m-1), each step advancing one or both, minimising the summed Euclidean distances."""
    a = np.asarray(a, dtype=np.float64).reshape(len(a), -1)
    b = np.asarray(b, dtype=np.float64).reshape(len(b), -1)
    n, m = len(a), len(b)
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    acc = np.full((n + 1, m + 1), math.inf)
    acc[0, 0] = 0.0
    for i in range(1, n + 1):
        row = acc[i]
        prev = acc[i - 1]
        di = d[i - 1]
        for j in range(1, m + 1):
            best = prev[j - 1]
            if prev[j] < best:
                best = prev[j]
            if row[j - 1] < best:
                best = row[j - 1]
            row[j] = di[j - 1] + best
    i, j = n, m
    out = [(n - 1, m - 1)]
    while (i, j) != (1, 1):
        options = ((acc[i - 1, j - 1], i - 1, j - 1), (acc[i - 1, j], i - 1, j), (acc[i, j - 1], i, j - 1))
        _, i, j = min(options, key=lambda o: o[0])
        out.append((i - 1, j - 1))
    out.reverse()
    return out


def dtw_blend(a: Array, b: Array, length: int) -> Array:
    """``length`` samples that run from the start of ``a`` (the outgoing motion's remaining keyframes) to
    the end of ``b`` (the incoming one's first keyframes), each the DTW-aligned pair of samples mixed
    with a weight rising smoothly from 0 to 1: no jump at either end or in between (a seamless join)."""
    a = np.asarray(a, dtype=np.float64).reshape(len(a), -1)
    b = np.asarray(b, dtype=np.float64).reshape(len(b), -1)
    path = np.array(dtw_path(a, b), dtype=np.float64)
    u = np.linspace(0.0, 1.0, length)
    k = u * (len(path) - 1)
    ia = np.interp(k, np.arange(len(path)), path[:, 0])
    ib = np.interp(k, np.arange(len(path)), path[:, 1])
    sa = np.stack([np.interp(ia, np.arange(len(a)), a[:, c]) for c in range(a.shape[1])], axis=1)
    sb = np.stack([np.interp(ib, np.arange(len(b)), b[:, c]) for c in range(b.shape[1])], axis=1)
    w = (u * u * (3.0 - 2.0 * u))[:, None]
    out: Array = (1.0 - w) * sa + w * sb
    return out
