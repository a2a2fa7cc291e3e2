"""From a foreground mask to people: blobs, stable ids, and the points on each outline.

All in image pixels; nothing here knows the stage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Blob", "PeopleTracker", "find_blobs", "outline_points"]

_FEET_BAND = 0.08  # feet are the lowest points within this fraction of the blob's height from its bottom


@dataclass(frozen=True, eq=False)
class Blob:
    """One person-sized region of the mask: its outer outline (M, 2) as (u, v) pixels, in order."""

    contour: np.ndarray
    area: float
    centroid: tuple[float, float]


def find_blobs(mask: np.ndarray, min_area_px: float, max_count: int) -> list[Blob]:
    """The largest ``max_count`` outer outlines enclosing at least ``min_area_px`` pixels, largest first."""
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    blobs: list[Blob] = []
    for c in contours:
        m = cv2.moments(c)
        area = m["m00"]
        if area < min_area_px or area <= 0:
            continue
        blobs.append(Blob(c.reshape(-1, 2), float(area), (m["m10"] / area, m["m01"] / area)))
    blobs.sort(key=lambda b: -b.area)
    return blobs[:max_count]


class PeopleTracker:
    """Keeps a person's id from frame to frame: greedy nearest-centroid matching.

    A blob takes the id of the nearest remembered person within ``max_distance`` pixels (closest
    pairs first); others get new ids (0, 1, 2, … never reused). A person unseen for more than
    ``memory_frames`` frames is forgotten.
    """

    def __init__(self, max_distance: float, memory_frames: int) -> None:
        self._max_distance = max_distance
        self._memory = memory_frames
        self._tracks: dict[int, tuple[tuple[float, float], int]] = {}  # id → (centroid, frames unseen)
        self._next_id = 0
        self._born: frozenset[int] = frozenset()

    @property
    def born(self) -> frozenset[int]:
        """The ids first given out by the last :meth:`assign` (people not seen before)."""
        return self._born

    def clear(self) -> None:
        self._tracks.clear()
        self._born = frozenset()

    def assign(self, centroids: list[tuple[float, float]]) -> list[int]:
        pairs = sorted(
            (math.dist(c, tc), bi, tid)
            for bi, c in enumerate(centroids)
            for tid, (tc, _) in self._tracks.items()
        )
        ids: list[int | None] = [None] * len(centroids)
        taken: set[int] = set()
        for d, bi, tid in pairs:
            if d > self._max_distance:
                break
            if ids[bi] is None and tid not in taken:
                ids[bi] = tid
                taken.add(tid)
        out: list[int] = []
        born: set[int] = set()
        for i in ids:
            if i is None:
                i = self._next_id
                self._next_id += 1
                born.add(i)
            out.append(i)
        self._born = frozenset(born)
        seen = dict(zip(out, centroids, strict=True))
        tracks = {tid: (c, 0) for tid, c in seen.items()}
        for tid, (c, unseen) in self._tracks.items():
            if tid not in seen and unseen < self._memory:
                tracks[tid] = (c, unseen + 1)
        self._tracks = tracks
        return out


def outline_points(
    contour: np.ndarray, spacing: float, image_size: tuple[int, int]
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Points every ``spacing`` pixels along a closed outline, then its extremities: the top (head),
    the extreme left and right (hands) and the lowest point on each side of the centre (feet).
    Points on the image border are left out: there the frame cuts the person, it is no body edge.

    Returns the points (K, 2) as int (u, v) pixels on the outline and their parts
    ("outline", "head", "hand", "foot").
    """
    pts = contour.reshape(-1, 2)
    steps = np.linalg.norm(np.diff(pts, axis=0, append=pts[:1]).astype(np.float64), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(steps)[:-1]])  # arc length at each vertex
    total = float(arc[-1] + steps[-1])
    n = max(1, int(total // spacing))
    idx = np.unique(np.clip(np.searchsorted(arc, np.arange(n) * spacing, side="left"), 0, len(pts) - 1))
    chosen = [pts[idx]]
    parts = ["outline"] * len(idx)

    u, v = pts[:, 0], pts[:, 1]
    extremes = [("head", v == v.min(), 0), ("hand", u == u.min(), 1), ("hand", u == u.max(), 1)]
    band = v >= v.max() - max(2, int(_FEET_BAND * int(v.max() - v.min())))
    cu = float(u[band].mean())
    for side in (band & (u < cu), band & (u >= cu)):
        if np.any(side):
            extremes.append(("foot", side & (v == v[side].max()), 0))
    for part, sel, axis in extremes:
        chosen.append(_middle_of(pts, sel, axis)[None, :])
        parts.append(part)
    uv = np.concatenate(chosen).astype(np.intp)
    w, h = image_size
    inside = (uv[:, 0] > 0) & (uv[:, 0] < w - 1) & (uv[:, 1] > 0) & (uv[:, 1] < h - 1)
    return uv[inside], tuple(p for p, keep in zip(parts, inside.tolist(), strict=True) if keep)


def _middle_of(pts: np.ndarray, sel: np.ndarray, axis: int) -> np.ndarray:
    """Of the selected outline points, the one at the median along ``axis`` (0 = u, 1 = v)."""
    cand = pts[sel]
    order = np.argsort(cand[:, axis], kind="stable")
    return np.asarray(cand[order[len(order) // 2]])
