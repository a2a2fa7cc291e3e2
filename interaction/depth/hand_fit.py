"""Which of the points seen near an arm's tip are its hand, chosen across the view.

A hand is the part of an arm farthest out from its shoulder, a hand's size deep. Chosen on the points'
3D positions, the depth's noise chooses with it: along the viewing ray a point is off by the stereo
error (≈ 6 cm at 5 m for an OAK, a third of it on the 3×3 median), across it by a fraction of a pixel,
so where an arm points partly along the ray the points whose noise put them farther out along it are
taken, and their average is off along the ray by as much. :func:`hand_points` measures "out along the
arm" across the view only (the points and the arm's direction with their part along the ray through
the tip taken out), where a hand's size is foreshortened by the share of the arm seen across the view.
An arm pointing at the camera (less than ``MIN_ACROSS`` of it across the view) shows no length there:
its hand is chosen on the 3D positions.

Measured on the virtual performer (``jostle bench interaction``, 15 fps, seeds 0 and 100): hands more
than 5 cm off 21 → 20 and 15 → 11, hands' p95 0.055 → 0.054 and 0.047 → 0.044 m.

The arm's end found on the sampled points is not always its hand's: hands are looked for above half the
person's height and out of the torso, and a hand hanging by the hip is lower and nearer the body than
the forearm over it; its points are then out of reach of the points looked at around the tip (14 cm),
and the hand was put 6–32 cm up the forearm (9 (3) of the 20 (11) hands more than 5 cm off). So
:func:`follow_hand` looks again around the middle of the points chosen while that lies more than a
hand's radius from where it looked (the arm goes on past what was looked at), ``LOOKS`` times at most.
A look drawn within reach of a leg (the line from a foot up to the hips, where the arm's end is not
looked for either) is a thigh's surface, not the hand: the hand is the one found before it. On the performer a hand is looked for 1.7 times on average; hands more
than 5 cm off 20 → 9 (11 → 4; seed 200, not used to choose: 14 → 4), hands' p95 0.054 → 0.037
(0.044 → 0.033; 0.048 → 0.032) m, hands and feet 0.061 → 0.060 (0.061 → 0.058; 0.063 → 0.061) m,
found share and frame rate unchanged. Up to 2 / 3 looks: 0.060 / 0.060 (0.060 / 0.059) m; looking
again only when the hand found is 8 / 10 cm off: 0.060 / 0.061 (0.060 / 0.061); holding each look to
within 45–60° of the line from the shoulder instead of off the legs loses most of it (0.061 (0.060)).
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
