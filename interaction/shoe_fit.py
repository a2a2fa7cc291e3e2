"""The height of a shoe's middle, from the shape of what a depth camera sees of it.

A depth camera above the stage sees a shoe's top and the faces turned to it, not its sole: the points
seen lie above the shoe's middle when it stands flat on the floor (its lower part is lost in the floor's
noise), and at its toe when it hangs toe-down (a foot swung back at toe-off: the toe is its lowest part,
its middle half a shoe's length up along it). Where the middle is cannot be read off the points; a
generic shoe's shape puts it there from two things the column of points over a foot shows
(:func:`shoe_middle_height`):

- where its lowest points are (their 5th percentile: not a stray point). The floor's noise hides what
  is lower than the lowest height measured (``floor_cut``, 4.5 cm on the 3×3 median of an OAK's depth):
  lowest points within ``ON_FLOOR_M`` of that cut are a shoe standing on the floor, its middle half a
  shoe's height up; lowest points ``OFF_FLOOR_M`` or more over it are a shoe in the air;
- whether a shoe in the air hangs (:func:`hangs`): its points up to ``FOOTPRINT_BAND_M`` over its lowest
  (a shoe's height: a flat shoe's top is among them) span less than half a shoe's length *across the
  view* (the direction a stereo camera measures without its depth noise: a flat shoe seen side-on spans
  most of its length there, a hanging one its width), and their upper half is not ``TOP_BEHIND_M``
  farther along the view than their lower half (a flat shoe seen toe-on, as narrow across the view,
  shows its top behind its toe). Its middle is then half a shoe's length up from its lowest points
  along a shoe pitched ``HANGING_PITCH_DEG`` (a foot hanging pitches 45–90°: the least of it).

Any other shoe is measured where its points are (None). The sizes are a generic adult shoe's, not any
one performer's. What stays ambiguous: a flat shoe in the air seen heel-on, hidden behind its own shin,
shows no more than a hanging one would and is taken for one (put ≈ 6 cm high); and a foot on the floor
with its heel up, its lowest points between the two heights, is measured where its points are.

Measured on the virtual performer (``jostle bench interaction``, 15 fps, seeds 0 and 100; its shoe is a
26 × 10 × 8 cm box, its people cross the view): the feet more than 5 cm off went from 207 (203) of 817
(847) with neither rule to 153 (147) with the floor's and 110 (101) with both; those hanging toe-down
(pitched over 55°, 15 % of the feet: the p95's tail) from 60 % more than 5 cm off, 4.5 cm low on average,
to 25 %, 2 cm low; p95 of hands and feet 0.075 (0.072) → 0.074 (0.072) → 0.066 (0.066) m (seed 200,
not used to choose anything: 0.079 → 0.071 m with the hands' 3×3 median too). Across the view
under 11–13 cm does about as well, under 10 cm less (0.068); the spread along the widest horizontal
direction instead of across the view mixes in the depth's noise (p95 0.069–0.074), and a flat shoe in
the air seen toe-on is as narrow there. A floor rule at the cut + 1.3–1.7 cm also takes feet whose heel
is up (p95 0.072–0.076 before the hanging rule); the hanging test on shoes whose lowest points are
1.5 cm or less over the cut takes flat ones (p95 0.068–0.12).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SHOE_HEIGHT_M", "SHOE_LENGTH_M", "hangs", "shoe_middle_height"]

SHOE_HEIGHT_M = 0.08  # a generic adult shoe: sole to instep …
SHOE_LENGTH_M = 0.26  # … and heel to toe
ON_FLOOR_M = 0.01  # lowest points seen within this of the floor cut: the shoe stands on the floor
OFF_FLOOR_M = 0.025  # … this much or more over it: the shoe is in the air
FOOTPRINT_BAND_M = 0.08  # a shoe's shape is read on its points this high over its lowest
TOP_BEHIND_M = 0.03  # a flat shoe seen toe-on shows its top at least this much farther than its toe
HANGING_PITCH_DEG = 45.0  # a shoe hanging toe-down is pitched this much at least
_LOWEST_PERCENT = 5


def shoe_middle_height(column: np.ndarray, floor_cut: float, camera: np.ndarray) -> float | None:
    """The height over the floor of the middle of the shoe seen as the points ``column`` (N, 3) (the
    points over a foot from ``floor_cut`` up) from ``camera`` (stage metres), or None when its points
    seen are to be trusted (see the module's notes)."""
    if len(column) < 3:
        return None
    z = column[:, 2]
    k = len(z) * _LOWEST_PERCENT // 100
    lowest = float(np.partition(z, k)[k])
    if lowest < floor_cut + ON_FLOOR_M:
        return 0.5 * SHOE_HEIGHT_M  # standing on the floor
    if lowest >= floor_cut + OFF_FLOOR_M and hangs(column[z < lowest + FOOTPRINT_BAND_M], lowest, camera):
        return lowest + 0.5 * SHOE_LENGTH_M * math.sin(math.radians(HANGING_PITCH_DEG))
    return None


def hangs(band: np.ndarray, lowest: float, camera: np.ndarray) -> bool:
    """Whether the points ``band`` (N, 3) of a shoe in the air, from its lowest (at height ``lowest``)
    up by ``FOOTPRINT_BAND_M``, seen from ``camera``, are a shoe hanging toe-down: less than half a shoe's
    length across the view, and their upper half not ``TOP_BEHIND_M`` farther along it than their lower."""
    if len(band) < 6:
        return False
    middle = band[:, :2].sum(axis=0) / len(band)
    ray = middle - camera[:2]
    ray = ray / max(math.hypot(float(ray[0]), float(ray[1])), 1e-9)  # the view's horizontal direction
    off = band[:, :2] - middle
    across = off @ np.array([-ray[1], ray[0]])
    k = len(across) // 20  # the 5 % at either end left out
    ends = np.partition(across, (k, len(across) - 1 - k))
    if float(ends[len(across) - 1 - k] - ends[k]) >= 0.5 * SHOE_LENGTH_M:
        return False  # a shoe lying along the view's cross direction
    along = off @ ray
    upper = band[:, 2] >= lowest + 0.5 * FOOTPRINT_BAND_M
    n_up = int(np.count_nonzero(upper))
    if n_up < 3 or len(band) - n_up < 3:
        return False
    return float(along[upper].sum()) / n_up - float(along[~upper].sum()) / (len(band) - n_up) < TOP_BEHIND_M
