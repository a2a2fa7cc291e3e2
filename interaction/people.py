"""From a foreground mask to people: blobs, stable ids, and the points on each outline.

All in image pixels; nothing here knows the stage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Blob", "PeopleTracker", "find_blobs", "outline_points", "split_merged", "two_clusters"]

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


def split_merged(blobs: list[Blob], predicted: list[tuple[float, float]], min_area_px: float) -> list[Blob]:
    """Blobs that hold the predicted centroids of two or more people (who walked into each other) cut
    between them: each column of the blob goes to the nearest predicted centroid (people stand side by
    side or overlap in the image; the cut is upright, halfway between them). A blob whose parts would
    be smaller than ``min_area_px`` is left whole."""
    out: list[Blob] = []
    contours = [b.contour.reshape(-1, 1, 2).astype(np.int32) for b in blobs]
    # signed distance of every prediction to every outline (> 0 inside)
    near = np.array([[cv2.pointPolygonTest(c, (float(p[0]), float(p[1])), True) for c in contours] for p in predicted])
    for i, (blob, contour) in enumerate(zip(blobs, contours, strict=True)):
        x, y, w, h = cv2.boundingRect(contour)
        # a centroid may lie just outside a walker's outline (between the legs): 8 % of the height
        mine = [k for k in range(len(predicted))
                if near[k, i] >= -0.08 * h and (near[k, i] >= 0 or not (near[k] >= 0).any())]
        inside = sorted(predicted[k][0] for k in mine)
        if len(inside) < 2:
            out.append(blob)
            continue
        mask = np.zeros((h, w), np.uint8)
        cv2.drawContours(mask, [contour - np.array([x, y], np.int32)], -1, 255, cv2.FILLED)
        owner = np.argmin(np.abs(np.arange(w, dtype=np.float64)[:, None] + x - np.array(inside)[None, :]), axis=1)
        parts: list[Blob] = []
        for k in range(len(inside)):
            found = find_blobs(np.where(owner[None, :] == k, mask, 0).astype(np.uint8), min_area_px, 1)
            parts.extend(Blob(b.contour + np.array([x, y]), b.area, (b.centroid[0] + x, b.centroid[1] + y))
                         for b in found)
        out.extend(parts if len(parts) >= 2 else [blob])
    out.sort(key=lambda b: -b.area)
    return out


class PeopleTracker:
    """Keeps a person's id from frame to frame: greedy nearest matching to where each is predicted.

    A person is predicted to keep the step it made last (per frame, halved each frame it is not
    seen). A blob takes the id of the nearest predicted person within ``max_distance`` (closest pairs
    first), then a blob left over takes the id of a person unseen in the last frame within twice that
    (people hidden for a while reappear away from where they were predicted); others get new ids
    (0, 1, 2, … never reused). A person unseen for more than
    ``memory_frames`` frames is forgotten.
    """

    def __init__(self, max_distance: float, memory_frames: int) -> None:
        self._max_distance = max_distance
        self._memory = memory_frames
        # id → (centroid, frames unseen, step per frame)
        self._tracks: dict[int, tuple[tuple[float, float], int, tuple[float, float]]] = {}
        self._next_id = 0
        self._born: frozenset[int] = frozenset()

    @property
    def born(self) -> frozenset[int]:
        """The ids first given out by the last :meth:`assign` (people not seen before)."""
        return self._born

    def clear(self) -> None:
        self._tracks.clear()
        self._born = frozenset()

    def predicted(self) -> dict[int, tuple[tuple[float, float], int]]:
        """Every remembered person's predicted centroid for the next frame, and frames unseen."""
        return {tid: (_ahead(c, unseen, step), unseen) for tid, (c, unseen, step) in self._tracks.items()}

    def assign(self, centroids: list[tuple[float, float]]) -> list[int]:
        ahead = {tid: _ahead(c, unseen, step) for tid, (c, unseen, step) in self._tracks.items()}
        pairs = sorted(
            (math.dist(c, ahead[tid]), bi, tid)
            for bi, c in enumerate(centroids)
            for tid in self._tracks
        )
        ids: list[int | None] = [None] * len(centroids)
        taken: set[int] = set()
        for d, bi, tid in pairs:
            if d > self._max_distance:
                break
            if ids[bi] is None and tid not in taken:
                ids[bi] = tid
                taken.add(tid)
        # a person that was out of sight (hidden behind, or merged with, someone) comes back farther
        # from where it was predicted: blobs left over take such ids within twice the distance
        for d, bi, tid in pairs:
            if d > 2 * self._max_distance:
                break
            if ids[bi] is None and tid not in taken and self._tracks[tid][1] > 0:
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
        tracks: dict[int, tuple[tuple[float, float], int, tuple[float, float]]] = {}
        for tid, c in zip(out, centroids, strict=True):
            step = (0.0, 0.0)
            if tid in self._tracks:
                (px, py), unseen, _ = self._tracks[tid]
                step = ((c[0] - px) / (unseen + 1), (c[1] - py) / (unseen + 1))
            tracks[tid] = (c, 0, step)
        for tid, (c, unseen, step) in self._tracks.items():
            if tid not in tracks and unseen < self._memory:
                tracks[tid] = (c, unseen + 1, step)
        self._tracks = tracks
        return out


def _ahead(c: tuple[float, float], unseen: int, step: tuple[float, float]) -> tuple[float, float]:
    """Where a person last at ``c``, moving ``step`` per frame, is expected the next frame after
    ``unseen`` frames unseen (the step fades by half each frame unseen: people stop and turn)."""
    k = 2.0 - 0.5**unseen  # 1 + 1/2 + … + 1/2^unseen: the fading steps (1 when just seen)
    return (c[0] + step[0] * k, c[1] + step[1] * k)


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
    extremes = [("head", v == v.min(), 0), *(("hand", sel, 1) for sel in _hands(pts))]
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


def _hands(pts: np.ndarray) -> list[np.ndarray]:
    """Outline points of the hands (one selection per side, left then right): of the outline in the
    top half of the blob (down to the hips: not the legs), the points out from the torso's column by more than half its width plus 6 % of the height; of
    those, the one farthest from that side's shoulder, if it is a forearm's length from it (a quarter of
    the height). An arm held against the body, or an elbow out with the hand in front of the body,
    gives no hand on that side (the outline covers it)."""
    u, v = pts[:, 0].astype(np.float64), pts[:, 1].astype(np.float64)
    top, height = float(v.min()), float(v.max() - v.min())
    if height < 8:
        return []
    rel = (v - top) / height
    torso = (rel > 0.22) & (rel < 0.42)
    if not torso.any():
        return []
    rows = np.round(v[torso]).astype(np.int64)
    lo = np.full(rows.max() - rows.min() + 1, np.inf)
    hi = np.full_like(lo, -np.inf)
    np.minimum.at(lo, rows - rows.min(), u[torso])
    np.maximum.at(hi, rows - rows.min(), u[torso])
    ok = np.isfinite(lo)
    middle, width = float(np.median((lo[ok] + hi[ok]) / 2)), float(np.median(hi[ok] - lo[ok]))
    band = rel < 0.5
    out = []
    for side in (-1.0, 1.0):
        shoulder = np.array([middle + side * 0.4 * width, top + 0.18 * height])
        beyond = band & (side * (u - middle) > 0.5 * width + 0.06 * height)
        if not beyond.any():
            continue
        idx = np.flatnonzero(beyond)  # a thigh or a knee has the leg's outline right under it, a hand not
        du = np.abs(u[idx, None] - u[None, :]) < 0.03 * height
        dv = v[None, :] - v[idx, None]
        legs = np.count_nonzero(du & (dv > 0.08 * height) & (dv < 0.25 * height), axis=1) >= 2
        beyond[idx[legs]] = False
        reach = np.where(beyond, np.hypot(u - shoulder[0], v - shoulder[1]), -1.0)
        if float(reach.max()) < 0.25 * height:
            continue  # an elbow out, no forearm beyond it
        out.append(reach == reach.max())
    return out


def _middle_of(pts: np.ndarray, sel: np.ndarray, axis: int) -> np.ndarray:
    """Of the selected outline points, the one at the median along ``axis`` (0 = u, 1 = v)."""
    cand = pts[sel]
    order = np.argsort(cand[:, axis], kind="stable")
    return np.asarray(cand[order[len(order) // 2]])


_WAIST_SHARE = 0.15
_HEAD_ABOVE_M = 0.03


def split_side_by_side(q: np.ndarray, separation: float, depth: int = 0) -> list[np.ndarray]:
    """A blob that is two people close together (side by side, or one behind the other): 2-means of
    its points above the knees (0.65 m) on the floor plane, started from the two points farthest
    apart, gives two halves, each with a fifth of those points or more, whose middles are at least
    ``separation`` apart (one person's halves are ~0.2–0.3 m apart), each standing on the floor and each
    with a waist (``_WAIST_SHARE`` of its points above the knees between 0.75 and 1.15 m) or else a head
    above the other half's top (someone behind, their middle hidden): an arm held or thrown out is no
    person, even with a lunging leg under it (figures: docs/notes/depth.md). Split again per half (up
    to 4)."""
    upper = q[q[:, 2] > 0.65, :2]
    if depth >= 2 or len(upper) < 40:
        return [q]
    sample = upper[:: max(1, len(upper) // 200)]
    if float(np.hypot(*np.ptp(sample, axis=0))) < separation:
        return [q]  # two halves' middles lie within the points' box: no two of them that far apart
    spread = sample - sample.sum(axis=0) / len(sample)
    if float(np.einsum("ij,ij->", spread, spread)) / len(sample) < 0.16 * separation * separation:
        return [q]  # two halves (shares p, 1 - p ≥ 0.2) that far apart spread the points by ≥ p(1 - p)·separation²
    a = sample[int(np.argmax(np.add.reduce(np.square(spread), axis=1)))]
    b = sample[int(np.argmax(np.add.reduce(np.square(sample - a), axis=1)))]
    near_a = np.ones(len(sample), dtype=bool)
    total, n = sample.sum(axis=0), len(sample)
    for _ in range(6):
        was = near_a
        near_a = sample @ (b - a) < 0.5 * (float(b @ b) - float(a @ a))  # nearer a than b
        k = int(np.count_nonzero(near_a))
        if k == 0 or k == n:
            return [q]
        sum_a = sample[near_a].sum(axis=0)
        a, b = sum_a / k, (total - sum_a) / (n - k)
        if bool((was == near_a).all()):
            break
    share = k / n
    if min(share, 1 - share) < 0.2 or math.sqrt(float((a - b).dot(a - b))) < separation:
        return [q]
    side = np.add.reduce(np.square(q[:, :2] - a), axis=1) < np.add.reduce(np.square(q[:, :2] - b), axis=1)
    halves = (q[side], q[~side])
    tops = [float(h[:, 2].max()) for h in halves]
    for k, half in enumerate(halves):
        z = half[:, 2]
        if np.count_nonzero(z < 0.5) < 5:
            return [q]
        waist = np.count_nonzero((z > 0.75) & (z < 1.15)) >= _WAIST_SHARE * np.count_nonzero(z > 0.65)
        if not waist and tops[k] < tops[1 - k] + _HEAD_ABOVE_M:
            return [q]  # no waist and no head above the rest: an arm thrown forward, not a second body
    return [*split_side_by_side(q[side], separation, depth + 1), *split_side_by_side(q[~side], separation, depth + 1)]


def two_clusters(pts: np.ndarray) -> list[np.ndarray]:
    """Points split in two along their widest horizontal direction by 2-means on that direction (one
    group when the two middles are closer than 12 cm): the groups' points."""
    xy = pts[:, :2] - pts[:, :2].sum(axis=0) / len(pts)
    cov = xy.T @ xy
    angle = 0.5 * math.atan2(2 * cov[0, 1], cov[0, 0] - cov[1, 1])  # the widest direction
    s = xy @ np.array([math.cos(angle), math.sin(angle)])
    cut = 0.0
    for _ in range(4):
        to_left = s < cut
        left, right = s[to_left], s[~to_left]
        if len(left) < 2 or len(right) < 2:
            return [pts]
        cut = 0.5 * (float(left.sum()) / len(left) + float(right.sum()) / len(right))  # the means
    to_a = s < cut
    if to_a.sum() < 2 or (~to_a).sum() < 2:
        return [pts]
    a, b = pts[to_a], pts[~to_a]
    gap = a[:, :2].sum(axis=0) / len(a) - b[:, :2].sum(axis=0) / len(b)
    if math.sqrt(float(gap.dot(gap))) < 0.12:
        return [pts]
    return [a, b]
