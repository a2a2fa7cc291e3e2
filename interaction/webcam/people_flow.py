"""Sampling the webcam's optical flow around the people: the boxes it is computed in, joined where they
overlap, and the median flow over a person's pixels near a point.

All in work pixels; nothing here knows the stage.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from interaction.people import Blob

__all__ = ["joined_boxes", "median_flow", "people_flow", "same_size"]

_FLOW_MARGIN = 24  # work pixels of context around the people for the optical flow


def joined_boxes(boxes: list[tuple[int, int, int, int]]) -> list[tuple[int, int, int, int]]:
    """Boxes (u0, v0, u1, v1), those that overlap joined into the box around both, until none do."""
    out = list(boxes)
    k = 0
    while k < len(out):
        p = out[k]
        hit = next((i for i, q in enumerate(out) if i != k and p[0] < q[2] and q[0] < p[2] and p[1] < q[3] and q[1] < p[3]),
                   None)
        if hit is None:
            k += 1
            continue
        q = out.pop(hit)
        out[k if hit > k else k - 1] = (min(p[0], q[0]), min(p[1], q[1]), max(p[2], q[2]), max(p[3], q[3]))
        k = 0
    return out


def median_flow(flow: np.ndarray, mask: np.ndarray, uv: np.ndarray, window: int) -> np.ndarray:
    """Per point (N, 2 int pixels), the median flow (N, 2) over the masked pixels of a window
    centred on it (the point's own flow if none of the window is masked)."""
    h, w = mask.shape
    r = window // 2
    offs = np.arange(-r, r + 1)
    du, dv = np.meshgrid(offs, offs)
    uu = np.clip(uv[:, 0:1] + du.reshape(1, -1), 0, w - 1)  # (N, window²)
    vv = np.clip(uv[:, 1:2] + dv.reshape(1, -1), 0, h - 1)
    inside = mask[vv, uu] > 0
    centre = du.size // 2
    inside[:, centre] |= ~inside.any(axis=1)  # no masked pixel near: the point's own flow
    count = inside.sum(axis=1)
    rows = np.arange(len(uv))
    lo, hi = (count - 1) // 2, count // 2
    out = np.empty((len(uv), 2), dtype=np.float64)
    for c in range(2):
        vals = np.where(inside, flow[vv, uu, c], np.inf)
        vals.sort(axis=1)  # the masked values first, in order
        out[:, c] = 0.5 * (vals[rows, lo] + vals[rows, hi])
    return out


def people_flow(dis: Any, grey: np.ndarray, prev_grey: np.ndarray, blobs: list[Blob], out: np.ndarray) -> np.ndarray:
    """Backward DIS flow (current → previous frame; ``dis`` a ``cv2.DISOpticalFlow``) into ``out``
    (h, w, 2) over the boxes around the people plus a margin, overlapping boxes joined (the rest is
    left 0: it is never sampled). People far apart cost two small boxes, not one as wide as the frame."""
    h, w = grey.shape
    m = _FLOW_MARGIN
    boxes = [(max(0, int(b.contour[:, 0].min()) - m), max(0, int(b.contour[:, 1].min()) - m),
              min(w, int(b.contour[:, 0].max()) + m + 1), min(h, int(b.contour[:, 1].max()) + m + 1))
             for b in blobs]
    out.fill(0.0)
    for u0, v0, u1, v1 in joined_boxes(boxes):
        now, before = np.ascontiguousarray(grey[v0:v1, u0:u1]), np.ascontiguousarray(prev_grey[v0:v1, u0:u1])
        # None: no initial flow (OpenCV's stubs demand an array, which DIS would take as one)
        out[v0:v1, u0:u1] = dis.calc(now, before, None)
    return out


def same_size(array: np.ndarray | None, shape: tuple[int, ...], dtype: type) -> np.ndarray:
    """``array`` when it has this shape (its contents are to be overwritten), else a new one that has."""
    if array is None or array.shape != shape:
        return np.empty(shape, dtype)
    return array
