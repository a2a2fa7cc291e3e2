"""From the foreground mask to one blob per person, by the smallest person's height in pixels.

:func:`find_people` takes the blobs at least half as tall as the smallest person (a person partly
hidden by a table still counts), joins the two halves of a person a post cuts in two (side by side,
together no wider than one person), and cuts blobs of people standing side by side at the dip
between their head tops (the topmost foreground row per column has two or more peaks, a head wide,
each well above the dip; the cut is the column with the fewest foreground pixels between two heads).
:class:`PersonFinder` holds one observer's limits: it first joins a person's pieces (a closing sized by
the smallest person), counts crowds over ``max_people``, cuts blobs between people predicted in them
only into person-like parts, and tells ghosts (:class:`StillPeople`: still, with the background's edges
rather than the frame's). :func:`person_finder` sizes it from the config and the calibration.
All in work pixels; nothing here knows the stage.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Callable

import cv2
import numpy as np

from interaction.people import Blob, find_blobs
from interaction.webcam.calibration import Calibration
from interaction.webcam.config import WebcamObserverConfig
from interaction.webcam.silhouette_parts import PersonBlob, split_people

__all__ = ["PersonFinder", "StillPeople", "find_people", "person_finder", "split_at_heads"]

log = logging.getLogger("jostle.webcam")

_MIN_HEIGHT_SHARE = 0.5  # a blob at least this share of the smallest person's height may be a person
_MIN_AREA_PER_H2 = 0.04  # ... and at least this share of that height squared in pixels
_ONE_WIDE = 0.6  # one person (arms in) is at most this wide for their height: two halves no wider are one
_POST_GAP = 0.2  # the two halves of a person behind a post are at most this far apart (share of height)
_HEAD_DIP = 0.12  # two heads: each top at least this share of the blob's height above the lowest top between
_HEAD_APART = 0.25  # ... and at least this far apart (share of the height)
_HEAD_WIDE = 0.08  # a head is at least this wide half the dip below its top (a raised hand is narrower)
_JOIN_WIDE, _JOIN_TALL = 0.2, 0.33  # pieces this close (share of the smallest person's height) are one
_MOVED_LEVEL, _MOVED_SHARE = 12, 0.002  # a blob moved: this share of its area changed by more grey levels
_MIN_WIDE = 0.15  # a person is at least this wide for their height (narrower: an arm, a pole)
_SPLIT_UNSEEN_FRAMES = 5  # people unseen longer do not cut a blob in two...
_APART_S = 1.0  # ... nor people last found as a blob of their own longer ago (seconds)
_SIDE_BY_SIDE_WIDE = 0.45  # a blob narrower than this (share of its height) is never cut


def find_people(mask: np.ndarray, min_height_px: float, max_count: int, min_area_px: float = 0.0,
                original: np.ndarray | None = None) -> list[Blob]:
    """The people in a foreground mask (uint8 0/255), largest first, at most ``max_count`` of them
    (the caller counts the rest: pass a larger count to see them). ``min_height_px``: the smallest
    person's height; ``min_area_px``: a further area floor (the deprecated ``min_blob_area``).
    ``original``: the mask before pieces were joined; a person who is one piece of it keeps that
    piece's own outline (the joining closes the gaps between legs and arms too)."""
    floor = max(min_area_px, _MIN_AREA_PER_H2 * min_height_px * min_height_px, 1.0)
    blobs = find_blobs(mask, floor * 0.25, 4 * max_count + 8)
    blobs = _join_post_halves(blobs)
    out: list[Blob] = []
    for b in blobs:
        if _height(b) < _MIN_HEIGHT_SHARE * min_height_px or b.area < floor or _width(b) < _MIN_WIDE * _height(b):
            continue  # too small, or as thin as an arm
        own = _own_outline(b, original) if original is not None else b
        out.extend(split_at_heads(own, _MIN_HEIGHT_SHARE * min_height_px, floor))
    out.sort(key=lambda b: -b.area)
    return out[:max_count]


def split_at_heads(blob: Blob, min_height_px: float, min_area_px: float) -> list[Blob]:
    """``blob`` cut into people standing side by side, one per head top (itself when one head)."""
    x, y, w, h = cv2.boundingRect(blob.contour.reshape(-1, 1, 2).astype(np.int32))
    if w < _SIDE_BY_SIDE_WIDE * h or h < 8:
        return [blob]
    mask = np.zeros((h, w), np.uint8)
    cv2.drawContours(mask, [(blob.contour - np.array([x, y])).reshape(-1, 1, 2).astype(np.int32)], -1, 255,
                     cv2.FILLED)
    filled = mask > 0
    has = filled.any(axis=0)
    top = np.where(has, np.argmax(filled, axis=0), h).astype(np.float64)
    k = max(1, int(round(0.03 * h))) | 1
    rise = h - np.convolve(np.pad(top, k // 2, mode="edge"), np.ones(k) / k, mode="valid")  # height per column
    heads = _head_columns(rise, h)
    if len(heads) < 2:
        return [blob]
    column_count = filled.sum(axis=0)
    cuts = [a + int(np.argmin(column_count[a:b + 1])) for a, b in zip(heads[:-1], heads[1:], strict=True)]
    parts: list[Blob] = []
    edges = [0, *cuts, w]
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        piece = np.zeros_like(mask)
        piece[:, lo:hi] = mask[:, lo:hi]
        if lo > 0:
            piece[:, lo] = 0  # one empty column between neighbours keeps their outlines apart
        found = find_blobs(piece, min_area_px * 0.5, 1)
        for f in found:
            if _height(f) >= min_height_px:
                parts.append(Blob(f.contour + np.array([x, y]), f.area, (f.centroid[0] + x, f.centroid[1] + y)))
    return parts if len(parts) >= 2 else [blob]


def _head_columns(rise: np.ndarray, h: int) -> list[int]:
    """Columns of head tops in a height profile: peaks standing ``_HEAD_DIP`` × h above the lowest
    point between them and their neighbour peaks, ``_HEAD_APART`` × h apart, a head wide."""
    dip, apart, wide = _HEAD_DIP * h, _HEAD_APART * h, _HEAD_WIDE * h
    order = np.argsort(-rise, kind="stable")
    peaks: list[int] = []
    for c in order.tolist():
        if rise[c] < 0.5 * rise.max():
            break
        if any(abs(c - p) < apart for p in peaks):
            continue
        if all(float(rise[min(c, p):max(c, p) + 1].min()) <= rise[c] - dip for p in peaks) and \
                _wide_enough(rise, c, dip, wide):
            peaks.append(c)
    return sorted(peaks)


def _wide_enough(rise: np.ndarray, c: int, dip: float, wide: float) -> bool:
    """The profile stays within half ``dip`` of its peak at ``c`` over at least ``wide`` columns."""
    above = rise >= rise[c] - 0.5 * dip
    lo = c
    while lo > 0 and above[lo - 1]:
        lo -= 1
    hi = c
    while hi < len(rise) - 1 and above[hi + 1]:
        hi += 1
    return hi - lo + 1 >= wide


def _join_post_halves(blobs: list[Blob]) -> list[Blob]:
    """Pairs of blobs side by side, overlapping in height, a narrow gap apart and together no wider
    than one person, joined into one (a person behind a post or a door frame)."""
    out = list(blobs)
    joined = True
    while joined:
        joined = False
        boxes = [cv2.boundingRect(b.contour.reshape(-1, 1, 2).astype(np.int32)) for b in out]
        for i in range(len(out)):
            for j in range(i + 1, len(out)):
                (xa, ya, wa, ha), (xb, yb, wb, hb) = boxes[i], boxes[j]
                hh = max(ha, hb)
                gap = max(xa, xb) - min(xa + wa, xb + wb)
                overlap = min(ya + ha, yb + hb) - max(ya, yb)
                width = max(xa + wa, xb + wb) - min(xa, xb)
                if 0 <= gap <= _POST_GAP * hh and overlap >= 0.6 * min(ha, hb) and width <= _ONE_WIDE * hh:
                    out[i] = _union(out[i], out[j], gap)
                    del out[j]
                    joined = True
                    break
            if joined:
                break
    return out


def _union(a: Blob, b: Blob, gap: int) -> Blob:
    """One blob of two, the gap between them bridged sideways."""
    pts = np.concatenate([a.contour, b.contour])
    x0, y0 = pts.min(axis=0) - (gap + 2)
    x1, y1 = pts.max(axis=0) + (gap + 2)
    mask = np.zeros((int(y1 - y0) + 1, int(x1 - x0) + 1), np.uint8)
    at = np.array([x0, y0])
    cv2.drawContours(mask, [(c - at).reshape(-1, 1, 2).astype(np.int32) for c in (a.contour, b.contour)], -1, 255,
                     cv2.FILLED)
    closed = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_RECT, (gap + 3, 1)))
    found = find_blobs(closed, 1.0, 1)
    if not found:
        return a
    f = found[0]
    return Blob(f.contour + at, f.area, (f.centroid[0] + x0, f.centroid[1] + y0))


def _own_outline(group: Blob, original: np.ndarray) -> Blob:
    """The one piece of ``original`` that makes up (90 % or more of) ``group``, else ``group``."""
    x, y, w, h = cv2.boundingRect(group.contour.reshape(-1, 1, 2).astype(np.int32))
    inside = np.zeros((h, w), np.uint8)
    cv2.drawContours(inside, [(group.contour - np.array([x, y])).reshape(-1, 1, 2).astype(np.int32)], -1, 255,
                     cv2.FILLED)
    np.bitwise_and(inside, original[y:y + h, x:x + w], out=inside)
    pieces = find_blobs(inside, 1.0, 2)
    total = float(np.count_nonzero(inside))
    if not pieces or pieces[0].area < 0.9 * total:
        return group
    f = pieces[0]
    return Blob(f.contour + np.array([x, y]), f.area, (f.centroid[0] + x, f.centroid[1] + y))


def _width(b: Blob) -> int:
    return int(b.contour[:, 0].max()) - int(b.contour[:, 0].min()) + 1


def _height(b: Blob) -> int:
    return int(b.contour[:, 1].max()) - int(b.contour[:, 1].min()) + 1


class PersonFinder:
    """:func:`find_people` with the limits of one observer: the smallest person's height in work
    pixels, ``max_people``, and a count of the frames that held more people than that (said once);
    ``still`` tells the people who have not moved for ``still_s`` seconds."""

    def __init__(self, min_height_px: float, max_people: int, min_area_px: float = 0.0, still_s: float = 0.0) -> None:
        self.min_height_px = min_height_px
        self.min_area_px = max(min_area_px, _MIN_AREA_PER_H2 * min_height_px * min_height_px)
        self._max = max_people
        self.crowd_frames = 0  # frames with more people in view than max_people
        self.still = StillPeople(still_s)  # people who never move: ghosts
        self._whole: dict[int, float] = {}  # person id → when last found as a blob of their own (s)
        k = max(3, round(_JOIN_WIDE * min_height_px)) | 1
        self._round = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
        self._upright = cv2.getStructuringElement(cv2.MORPH_RECT, (1, max(3, round(_JOIN_TALL * min_height_px)) | 1))
        self._closed: np.ndarray | None = None
        self._work: np.ndarray | None = None
        self.most_seen = 0  # the most people found in one frame, before the cap

    def find(self, mask: np.ndarray) -> list[Blob]:
        """The people in the mask, at most ``max_people`` (the largest); more are counted, and the
        first time said as a warning. The pieces of one person (a head, a torso, legs the background
        hid in between) are first joined by a closing a tenth of the smallest person wide and a third
        of them tall (into arrays kept from frame to frame)."""
        if self._closed is None or self._work is None or self._closed.shape != mask.shape:
            self._closed, self._work = np.empty_like(mask), np.empty_like(mask)
        work = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, self._round, dst=self._work)
        closed = cv2.morphologyEx(work, cv2.MORPH_CLOSE, self._upright, dst=self._closed)
        people = find_people(closed, self.min_height_px, 2 * self._max + 8, self.min_area_px, mask)
        self.most_seen = max(self.most_seen, len(people))
        if len(people) > self._max:
            if self.crowd_frames == 0:
                log.warning("webcam observer: %d people in view, more than max_people = %d: the smallest are "
                            "not reported (raise max_people in [observers.webcam])", len(people), self._max)
            self.crowd_frames += 1
        return people[: self._max]

    def cut(self, found: list[Blob], predicted: list[tuple[float, float]]) -> list[PersonBlob]:
        """Each blob cut between the people predicted in it (:func:`split_people`) when every part is
        person-like (half the smallest person tall, ``_MIN_WIDE`` of that wide), else left whole."""
        out: list[PersonBlob] = []
        for blob in found:
            parts = split_people([blob], predicted, self.min_area_px) if predicted else [PersonBlob(blob)]
            if len(parts) > 1 and not all(_height(p.blob) >= _MIN_HEIGHT_SHARE * self.min_height_px
                                          and _width(p.blob) >= _MIN_WIDE * _height(p.blob) for p in parts):
                parts = [PersonBlob(blob)]
            out.extend(parts)
        out.sort(key=lambda p: -p.blob.area)
        return out

    def apart(self, predicted: dict[int, tuple[tuple[float, float], int]], t: float) -> list[tuple[float, float]]:
        """The predicted centroids of the people (id → (centroid, frames unseen)) who may cut a blob in
        two: seen lately, and found as a blob of their own within ``_APART_S`` (else two pieces of one
        person, found apart once, would keep cutting that person in two)."""
        return [c for pid, (c, unseen) in predicted.items()
                if unseen <= _SPLIT_UNSEEN_FRAMES and t - self._whole.get(pid, t) <= _APART_S]

    def seen(self, ids: list[int], persons: list[PersonBlob], found: list[Blob], t: float) -> None:
        """Note which people (``ids`` of ``persons``) were found whole this frame (one of the blobs
        ``found``), not cut from others."""
        whole = {id(b) for b in found}
        for pid, p in zip(ids, persons, strict=True):
            if id(p.blob) in whole or pid not in self._whole:
                self._whole[pid] = t
        self._whole = {pid: self._whole[pid] for pid in ids if pid in self._whole} | {
            pid: w for pid, w in self._whole.items() if t - w <= _APART_S}


def person_finder(cfg: WebcamObserverConfig, scale: float, work_size: tuple[int, int],
                  calibration: Calibration | None, input_size: tuple[int, int] | None) -> PersonFinder:
    """The people's limits in work pixels (``scale`` work pixels per input pixel) for frames of this
    work size: ``min_person_px``, else ``min_person_m`` at the calibration's largest metres per pixel
    (the far edge), else an eighth of the frame's height."""
    w, h = work_size
    if cfg.min_person_px > 0:
        tall = cfg.min_person_px * scale
    elif calibration is not None and input_size is not None:
        iw, ih = input_size
        grid = np.array([(u, v) for u in np.linspace(0, iw - 1, 9) for v in np.linspace(0, ih - 1, 9)])
        tall = cfg.min_person_m / float(calibration.metres_per_pixel(grid).max()) * scale
    else:
        tall = h / 4.0
    area = 0.0
    if cfg.min_blob_area is not None:
        area = cfg.min_blob_area * w * h
        warnings.warn("observers.webcam.min_blob_area (a fraction of the image) is deprecated: set min_person_px, "
                      "the smallest person's height in pixels, instead (still applied this run)", FutureWarning,
                      stacklevel=3)
    return PersonFinder(tall, cfg.max_people, area, cfg.still_to_background_s)


class StillPeople:
    """Ghosts: "people" who have not moved for ``after_s`` seconds and whose outline is an edge of the
    learned background rather than of the frame (what stood there while it was learned, and left). A
    person standing still keeps their own edges in the frame and stays. Motion is a grey-level change
    above ``_MOVED_LEVEL`` between frames in at least ``_MOVED_SHARE`` of the blob."""

    def __init__(self, after_s: float) -> None:
        self._after = after_s
        self._moved: dict[int, float] = {}  # person id → when it last moved (frame time, s)

    def still(self, ids: list[int], blobs: list[Blob], grey: np.ndarray, prev: np.ndarray | None, t: float,
              background: Callable[[], np.ndarray | None]) -> list[Blob]:
        """The ghosts among the blobs (of people ``ids``; none when ``after_s`` is 0); ``background``
        gives the learned background, grey, the size of ``grey`` (asked only when a blob is still)."""
        if self._after <= 0 or prev is None or prev.shape != grey.shape:
            return []
        out: list[Blob] = []
        moved: dict[int, float] = {}
        bg: np.ndarray | None = None
        for pid, b in zip(ids, blobs, strict=True):
            x0, y0 = b.contour.min(axis=0)
            x1, y1 = b.contour.max(axis=0) + 1
            changed = cv2.absdiff(grey[y0:y1, x0:x1], prev[y0:y1, x0:x1]) > _MOVED_LEVEL
            moved[pid] = t if np.count_nonzero(changed) >= _MOVED_SHARE * b.area else self._moved.get(pid, t)
            if t - moved[pid] < self._after:
                continue
            bg = background() if bg is None else bg
            if bg is not None and _edge_along(bg, b.contour) > _edge_along(grey, b.contour):
                out.append(b)
        self._moved = moved
        return out


def _edge_along(grey: np.ndarray, contour: np.ndarray) -> float:
    """The mean grey-level gradient (Sobel, magnitude) of an image at the points of an outline."""
    x0, y0 = np.maximum(contour.min(axis=0) - 2, 0)
    x1, y1 = contour.max(axis=0) + 3
    crop = grey[y0:y1, x0:x1].astype(np.float32)
    gx, gy = cv2.Sobel(crop, cv2.CV_32F, 1, 0), cv2.Sobel(crop, cv2.CV_32F, 0, 1)
    u, v = contour[:, 0] - x0, contour[:, 1] - y0
    return float(np.hypot(gx[v, u], gy[v, u]).mean())
