"""Which of the points seen near an arm's tip are its hand, chosen across the view.

A hand is the part of an arm farthest out from its shoulder, a hand's size deep. Along the viewing
ray a depth point is off by the stereo error, across it by a fraction of a pixel, so
:func:`hand_points` measures "out along the arm" across the view only (the points' and the arm's
part along the ray through the tip taken out); an arm pointing at the camera (less than
``MIN_ACROSS`` of it across the view) has its hand chosen on the 3D positions.

The arm's end found on the sampled points is not always its hand's (a hand hanging by the hip lies
lower and nearer the body than the forearm over it), so :func:`follow_hand` looks again around the
middle of the points chosen while that lies more than a hand's radius from where it looked,
``LOOKS`` times at most; a look within reach of a leg is a thigh, not the hand. Stage metres.

Figures and what was tried: docs/notes/depth-parts.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["LOOKS", "MIN_ACROSS", "follow_hand", "hand_points"]

MIN_ACROSS = 0.3  # an arm seen across the view on less than this share of its length points at the camera
LOOKS = 4  # follow_hand: a hand is looked for this many times at most, each around the last one found


def hand_points(pts: np.ndarray, tip: np.ndarray, shoulder: np.ndarray, camera: np.ndarray,
                depth: float) -> np.ndarray:
    """Of the points ``pts`` (N, 3) near an arm's ``tip`` (its shoulder at ``shoulder``, seen from
    ``camera``), those within ``depth`` (a hand's size, along the arm) of the farthest out from the shoulder (its 95th
    percentile: not a stray point), measured across the view (see the module's notes)."""
    direction = (tip - shoulder) / max(float(np.linalg.norm(tip - shoulder)), 1e-9)
    ray = (tip - camera) / max(float(np.linalg.norm(tip - camera)), 1e-9)
    across = direction - float(direction @ ray) * ray
    share = math.sqrt(float(across @ across))
    out = pts - shoulder
    if share >= MIN_ACROSS:
        out = out - np.outer(out @ ray, ray)  # seen across the view
        along, depth = out @ (across / share), depth * share
    else:
        along = out @ direction
    k = (len(along) * 19) // 20
    far = float(np.partition(along, k)[k])
    return np.asarray(pts[along > far - depth])


def follow_hand(points_near: Callable[[np.ndarray], np.ndarray], tip: np.ndarray, shoulder: np.ndarray,
                camera: np.ndarray, depth: float, moved: float,
                legs: Sequence[tuple[np.ndarray, np.ndarray]] = (), leg_reach: float = 0.0) -> np.ndarray | None:
    """The middle of the hand's points seen (:func:`hand_points`, ``depth`` deep) of the arm found to
    end at ``tip``, looked for in ``points_near(centre)`` (the points within reach of ``centre``) around
    the tip, then again around the middle found while that lies more than ``moved`` (a hand's radius)
    from where it was looked for, ``LOOKS`` times at most, and not within ``leg_reach`` of a leg (each
    ``legs`` a segment, foot to hips; see the module's notes). None when fewer than 3 points are a hand."""
    centre, middle = tip, None
    for _ in range(LOOKS):
        pts = points_near(centre)
        if len(pts) < 4:
            return middle
        hand = hand_points(pts, centre, shoulder, camera, depth)
        if len(hand) < 3:
            return middle
        found = hand.sum(axis=0) / len(hand)
        if middle is not None and any(_to_segment(found, a, b) < leg_reach for a, b in legs):
            return middle  # drawn on down a leg beside the hand: the hand is where it was found
        middle = found
        if float(np.linalg.norm(found - centre)) < moved:
            break
        centre = middle
    return middle


def _to_segment(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """The distance from ``point`` to the segment from ``a`` to ``b``."""
    ab = b - a
    s = min(max(float((point - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0), 1.0)
    return float(np.linalg.norm(point - a - s * ab))
