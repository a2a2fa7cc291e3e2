"""A webcam person's feet from their silhouette, where a webcam can place them; pieces of one
person joined; people cut apart knowing which side is the cut.

:func:`interaction.people.outline_points` gives points along the outline and its extremities (head,
hands held out, the lowest point on each side). The lowest outline point is the sole's edge, not the
foot (the bench compares with the shoe's middle, ~4 cm higher and half a shoe along): here each foot
is the middle of a *leg end* instead (:func:`feet`): of the silhouette's pixels in the bottom
``_FEET_BAND`` of the person, one per piece of that band (two when a piece is as long as two shoes),
those within a shoe's height of the piece's sole; a sole narrower than ``_TOE_DOWN`` is a toe of a
shoe standing on its tip, whose middle is higher: the whole piece. No foot is reported where one
cannot be placed: from a piece wider than a pair of shoes, from a person shorter than
``_HEAD_TO_HEIGHT`` head widths (the background hid the legs: the bottom is the hips or the hands),
from a foot the frame or a cut between people runs through.

Legs like the floor split a person into a body and its shoes: :func:`join_fragments` joins a piece
under a body to it. People who walked into each other and were cut apart (:func:`split_people`) have
an outline side that is the cut, not their body (the observer takes no hands from them).

All in work pixels; nothing here knows the stage.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from interaction.people import Blob, split_merged

__all__ = ["PersonBlob", "feet", "join_fragments", "split_people"]

_SHOE = 0.05  # a shoe's height, as a fraction of the person's height in the image (8 cm of 1.6 m)
_FEET_BAND = 0.08  # the feet on the floor are in this bottom fraction of the person's height
_SHOE_LONG = 0.22  # a shoe's length seen side-on, fraction of the height: a piece wider is two feet...
_PAIR_WIDE = 0.40  # ... and one wider than this is no pair of feet at all
_TOE_DOWN = 0.10  # a shoe-high band at a sole narrower than this (fraction of the height) is a toe
_HEAD_TO_HEIGHT = 6.0  # a whole person is at least this many head widths tall
_HEAD_ROWS = (0.02, 0.07)  # the head's width is measured this far below the top (fractions of the height)
_MIN_HEIGHT_PX = 12  # smaller people get no feet (a few pixels cannot place one)


@dataclass(frozen=True, eq=False)
class PersonBlob:
    """One person's part of the silhouette. ``cut_left``/``cut_right``: that side of the outline is
    where a blob of several people was cut apart, not the person's own edge."""

    blob: Blob
    cut_left: bool = False
    cut_right: bool = False


def join_fragments(blobs: list[Blob]) -> list[Blob]:
    """Blobs that are pieces of the person above them joined to that person: a blob less than half as
    tall as a blob whose columns overlap it and whose bottom is above its top by less than half that
    blob's height (shoes seen under legs the background hid). The gap is filled upright, column by
    column, as legs would. Largest first, as :func:`interaction.people.find_blobs` gives them."""
    out = list(blobs)
    boxes: dict[int, _Box] = {id(b): _box(b) for b in blobs}
    for piece in sorted(blobs, key=lambda b: b.area):
        if not any(piece is b for b in out):
            continue
        px, py, pw, ph = boxes[id(piece)]
        best: Blob | None = None
        for body in out:
            bx, by, bw, bh = boxes[id(body)]
            gap = py - (by + bh)
            overlap = min(px + pw, bx + bw) - max(px, bx)
            if body is not piece and ph < 0.5 * bh and -0.25 * bh <= gap < 0.5 * bh and overlap > 0:
                if best is None or bh > boxes[id(best)][3]:
                    best = body
        if best is None:
            continue
        joined = _join(best, piece, boxes[id(best)], boxes[id(piece)])
        boxes[id(joined)] = _box(joined)
        out = [joined if b is best else b for b in out if b is not piece]
    out.sort(key=lambda b: -b.area)
    return out


_Box = tuple[int, int, int, int]  # x, y, width, height


def _box(blob: Blob) -> _Box:
    x, y = int(blob.contour[:, 0].min()), int(blob.contour[:, 1].min())
    return x, y, int(blob.contour[:, 0].max()) - x + 1, int(blob.contour[:, 1].max()) - y + 1


def _join(body: Blob, piece: Blob, body_box: _Box, piece_box: _Box) -> Blob:
    """One blob of both, the gap between them bridged column by column."""
    gap = max(1, piece_box[1] - (body_box[1] + body_box[3]))
    pad = gap + 2  # room for the closing to work in (the crop's edge would erode what touches it)
    x0, y0 = min(body_box[0], piece_box[0]) - pad, min(body_box[1], piece_box[1]) - pad
    x1 = max(body_box[0] + body_box[2], piece_box[0] + piece_box[2]) + pad
    y1 = max(body_box[1] + body_box[3], piece_box[1] + piece_box[3]) + pad
    mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
    at = np.array([x0, y0], np.int32)
    cv2.drawContours(mask, [(b.contour - at).reshape(-1, 1, 2).astype(np.int32) for b in (body, piece)], -1, 255,
                     cv2.FILLED)
    bridge = cv2.getStructuringElement(cv2.MORPH_RECT, (1, 2 * gap + 3))
    closed = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, bridge)
    contours, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if len(contours) > 1:  # no column holds both (a leg slanting out): a leg from the piece's top to the body
        top = piece.contour[np.argmin(piece.contour[:, 1])] - at
        body_pts = body.contour - at
        near = body_pts[np.argmin(np.hypot(*(body_pts - top).T))]
        width = max(3, piece_box[2] // 3)
        cv2.line(closed, (int(top[0]), int(top[1])), (int(near[0]), int(near[1])), 255, width)
        contours, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(contours, key=cv2.contourArea)
    m = cv2.moments(outline)
    if m["m00"] <= 0:
        return body
    area = float(m["m00"])
    return Blob(outline.reshape(-1, 2) + at, area, (m["m10"] / area + x0, m["m01"] / area + y0))


def split_people(blobs: list[Blob], predicted: list[tuple[float, float]], min_area_px: float) -> list[PersonBlob]:
    """:func:`interaction.people.split_merged`, saying which side of each part is a cut."""
    parts = split_merged(blobs, predicted, min_area_px) if predicted else blobs
    whole = {id(b) for b in blobs}
    out: list[PersonBlob] = []
    cut = [p for p in parts if id(p) not in whole]
    for p in parts:
        if id(p) in whole:
            out.append(PersonBlob(p))
            continue
        x0, x1 = float(p.contour[:, 0].min()), float(p.contour[:, 0].max())
        # a neighbour from the same cut touches this part's side (parts of one blob share the cut column)
        left = any(q is not p and abs(float(q.contour[:, 0].max()) + 1 - x0) <= 1.5 for q in cut)
        right = any(q is not p and abs(float(q.contour[:, 0].min()) - 1 - x1) <= 1.5 for q in cut)
        out.append(PersonBlob(p, left, right))
    return out


def feet(contour: np.ndarray, image_size: tuple[int, int], cut_left: bool = False, cut_right: bool = False) -> np.ndarray:
    """The feet (K, 2) float (u, v) pixels of the person outlined by ``contour`` (M, 2): the middle of
    the silhouette's lowest shoe-high band in each leg end near the bottom. None where the bottom is
    cut by the frame (K = 0), nor from a leg end that a cut between people (``cut_left``/``cut_right``)
    runs through: only part of it is there."""
    pts = contour.reshape(-1, 2)
    x, y = int(pts[:, 0].min()), int(pts[:, 1].min())
    w, h = int(pts[:, 0].max()) - x + 1, int(pts[:, 1].max()) - y + 1
    if h < _MIN_HEIGHT_PX or y + h >= image_size[1]:
        return np.zeros((0, 2))
    if h < _HEAD_TO_HEIGHT * _head_width(pts, y, h):
        return np.zeros((0, 2))  # too short for its head: the legs are hidden (like the background), no feet
    band = max(2, round(_FEET_BAND * h))
    top = h - band
    mask = np.zeros((band, w), np.uint8)
    cv2.drawContours(mask, [(pts - np.array([x, y + top])).reshape(-1, 1, 2).astype(np.int32)], -1, 255, cv2.FILLED)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    shoe = max(1.0, _SHOE * h)
    out: list[tuple[float, float]] = []
    for k in range(1, count):
        cx, cw = int(stats[k, cv2.CC_STAT_LEFT]), int(stats[k, cv2.CC_STAT_WIDTH])
        if cw > _PAIR_WIDE * h or x + cx <= 0 or x + cx + cw >= image_size[0]:
            continue  # no pair of feet (hips over hidden legs), or a foot the frame cuts
        if (cut_left and cx <= 0) or (cut_right and cx + cw >= w):
            continue  # a leg end the cut between people runs through
        piece = labels == k
        pieces = [piece]
        if cw > _SHOE_LONG * h:  # two feet side by side: cut where the piece is thinnest
            cols = np.count_nonzero(piece, axis=0)
            lo, hi = cx + cw // 4, cx + cw - cw // 4
            gap = lo + int(np.argmin(cols[lo:hi])) if hi > lo else cx + cw // 2
            left = np.zeros_like(piece)
            left[:, :gap] = True
            pieces = [piece & left, piece & ~left]
        for p in pieces:
            rows, cols = np.nonzero(p)
            if len(rows) == 0:
                continue
            sole = int(rows.max())
            near = rows > sole - shoe
            if int(np.ptp(cols[near])) + 1 < _TOE_DOWN * h:  # a sole this narrow is a toe: the shoe stands
                near = rows >= 0  # upright, its middle higher up: the whole leg end in the band
            out.append((float(cols[near].mean()) + x, float(rows[near].mean()) + y + top))
    return np.array(out, dtype=np.float64).reshape(-1, 2)


def _head_width(pts: np.ndarray, top: int, h: int) -> float:
    """The outline's widest extent across the rows just below its top (the head), pixels."""
    v = pts[:, 1]
    lo, hi = top + max(1, round(_HEAD_ROWS[0] * h)), top + max(2, round(_HEAD_ROWS[1] * h))
    widths = []
    for row in range(lo, hi + 1):
        u = pts[v == row, 0]
        if len(u):
            widths.append(int(u.max()) - int(u.min()) + 1)
    return float(max(widths)) if widths else 0.0
