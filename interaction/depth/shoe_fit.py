"""The height of a shoe's middle, from the shape of what a depth camera sees of it.

A depth camera above the stage sees a shoe's top and the faces turned to it, not its sole: the points seen
lie above the shoe's middle when it stands flat on the floor (its lower part is lost in the floor's noise),
and at its toe when it hangs toe-down (a foot swung back at toe-off: the toe is its lowest part, its middle
half a shoe's length up along it). Where the middle is cannot be read off the points; a generic shoe's shape
puts it there from what the column of points over a foot shows (:func:`shoe_middle_height`):

- where its lowest points are (their 5th percentile: not a stray point). The floor's noise hides what is
  lower than the lowest height measured (``floor_cut``, 4.5 cm on the 3×3 median of an OAK's depth): lowest
  points within ``ON_FLOOR_M`` of that cut are a shoe standing on the floor, its middle half a shoe's height
  up; lowest points ``OFF_FLOOR_M`` or more over it are a shoe in the air;
- whether a shoe a little over that cut (its lowest points 1–2.5 cm over it) lies flat (:func:`lies_flat`):
  then it stands on the floor and shows only its top (its sides lost in the floor's noise or turned away). A
  flat shoe's top runs from the heel, under the leg, to the toe: its lowest points seen (up to
  ``FLAT_TOP_BAND_M`` over the lowest) have their middle more than ``FLAT_OFF_LEG_M`` (a quarter of a shoe's
  length) across from the leg's (the points 12–20 cm over them); a shoe pitched toe-down has its toe, its
  lowest, nearer under the leg;
- whether a shoe in the air, or one a little over the cut that does not lie flat (its lowest points
  ``HANGING_FROM_M`` or more over the cut), hangs (:func:`hangs`): its points up to ``FOOTPRINT_BAND_M`` over its lowest (a
  shoe's height: a flat shoe's top is among them) span less than half a shoe's length *across the view* (the
  direction a stereo camera measures without its depth noise: a flat shoe seen side-on spans most of its
  length there, a hanging one its width), and their upper half is not ``TOP_BEHIND_M`` farther along the
  view than their lower half (a flat shoe seen toe-on, as narrow across the view, shows its top behind its
  toe). Its middle is then half a shoe's length up from its lowest points along a shoe pitched
  ``HANGING_PITCH_DEG`` (a foot hanging pitches 45–90°: the least of it).

Any other shoe is measured where its points are (None). What these rules leave (a heel up, a toe hanging
at a pitch the points do not tell) the shoe model then corrects (:mod:`interaction.depth.shoe_model`). Two feet found on one person nearer than a shoe's
width (``SHOE_WIDTH_M``) are one shoe (:func:`one_per_shoe`): a shoe seen alone, its other foot hidden, is
as long as two feet side by side are wide, and its low points are split heel from toe. The sizes are a
generic adult shoe's, not any one performer's. What stays ambiguous: a flat shoe in the air seen heel-on,
hidden behind its own shin, shows no more than a hanging one would and is taken for one (put ≈ 6 cm high);
and a foot on the floor with its heel up, its lowest points between the two heights, is measured where its
points are.

Measured on the virtual performer (``jostle bench interaction``, 15 fps, seeds 0 and 100; its shoe is a 26 ×
10 × 8 cm box, its people cross the view): the feet more than 5 cm off went from 207 (203) of 817 (847) with
neither rule to 153 (147) with the floor's and 110 (101) with both; those hanging toe-down (pitched over
55°, 15 % of the feet: the p95's tail) from 60 % more than 5 cm off, 4.5 cm low on average, to 25 %, 2 cm
low; p95 of hands and feet 0.075 (0.072) → 0.074 (0.072) → 0.066 (0.066) m (seed 200, not used to choose
anything: 0.079 → 0.071 m with the hands' 3×3 median too). Across the view under 11–13 cm does about as
well, under 10 cm less (0.068); the spread along the widest horizontal direction instead of across the view
mixes in the depth's noise (p95 0.069–0.074), and a flat shoe in the air seen toe-on is as narrow there. A
floor rule at the cut + 1.3–1.7 cm also takes feet whose heel is up (p95 0.072–0.076 before the hanging
rule); the hanging test on shoes whose lowest points are 1.5 cm or less over the cut takes flat ones (p95
0.068–0.12).

Then (same seeds): of the shoes 1–2.5 cm over the cut measured where their points are, those flat on the
floor (their true middle under 4.5 cm) were 5–6 cm high, 29 (27) of 31 (32) more than 5 cm off;
:func:`lies_flat` takes 22 (20) of them (3 (2) left more than 5 cm off), and 6 (8) hanging ones, 19 (15)
heel-up ones and 11 (9) flat ones in the air with them, for about as many more than 5 cm off among those as
before: p95 of hands and feet 0.066 (0.066) → 0.064 (0.063) m, 131 (116) → 110 (102) more than 5 cm off (its
offset at 5.5 / 6 / 7 / 8 cm: 0.067 / 0.065 / 0.065 / 0.065 (0.065 / 0.063 / 0.063 / 0.063) m).
:func:`one_per_shoe` leaves 36 (34) of 1137 (1205) contactors out, feet found twice on one shoe (both
nearest the same true foot; 10 (16) of them more than 5 cm off); feet found on two true feet were nearer
than 10 cm 2 (4) times in 317 (338): p95 0.064 (0.063) → 0.063 (0.062) m, found share unchanged. Tried and
not kept: telling the hanging shoes at the cut + 1–2.5 cm from the others by the shin's slope (from the
person's points 20–45 cm up: p50 44° hanging, 25° flat, 30° heel up) and putting them up as hanging over 36
/ 44 / 48 °: p95 0.072 / 0.066 / 0.063 (0.071 / 0.066 / 0.063) m; or by how narrow their lowest 4 cm are
against the leg's: 0.062–0.067 (0.062–0.070) against 0.063 (0.062). Even knowing which hang (from the
truth), putting them up as hanging takes 7 (5) of the 5 cm misses off and nothing off the p95: their middle
is 3–11 cm (p10–p90) over their lowest points. A standing shoe measured on its points under 8–10 cm only
(without its ankle): p95 0.066–0.068 (0.062) m. A shoe on the cut with few of its points in its lowest 3 cm
(a heel up) measured where its points are: 0.062 (0.061) m under 15 %, 0.065 (0.065) under 18 %.
With the shoes that lie flat told first, the hanging test from the cut + 1.5 cm (not 2.5) takes hanging
toes nearer the floor: p95 0.062 (0.062) → 0.061 (0.061) m, 103 (92) → 97 (84) more than 5 cm off (from
2 / 1.75 / 1.25 cm: 0.062 / 0.062 / 0.062 (0.062 / 0.061 / 0.062) m, 98 / 98 / 96 (89 / 87 / 85)): a small
gain, of the size of the p95's noise from one threshold to the next; the count more than 5 cm off falls
at each.
Tried and not kept (then 0.061 (0.061) m; seed 200 0.063): a shoe on the floor put up by as much as
its points seen (up to 10 cm over their lowest) average over a flat one's (cut + half a shoe's height:
p50 8.7 cm on flat feet; their true middle ≈ that mean less the cut, least squares slope 0.99): 0.060
(0.060) m, but seed 200 0.0629 → 0.0635 m, as many flat feet put over 5 cm high (9 / 11 / 14) as
heel-up ones brought under (9 / 9 / 5), the same gated on few points in the lowest 3 cm; telling heel-up
shoes by their share of points in their lowest 3 cm (AUC ≈ 0.9 against flat ones), by the spread of
those points, their area, the slope of the points ahead of the shin or where the column leaves the
shin's line (AUC 0.6–0.8): none apart enough; leaving out of a foot's column the points nearer the
other foot's middle (staggered feet): 0.066 (0.061) m, 0.061 (0.060) beyond a 4–8 cm margin.
Learnt from the column instead: fitted on two seeds and scored on the third, a ridge regression of the true
middle's height on 17 features of the column (its lowest points, the percentiles of its heights over them,
the shares under 2–16 cm, its spread across and along the view, how far its lowest points lie from the
leg's, how far back its top is) and of its motion since the frame before was no better than these rules
(p95 of hands and feet 0.0617 / 0.0573 / 0.0583 m on seeds 0 / 100 / 200, the rules 0.0603 / 0.058 /
0.0609), and nearest neighbours on them only a little (0.055–0.058 / 0.051–0.054 / 0.057–0.059 m). The
raised feet are the misses (truth 6 cm or more over the floor: 45 of seed 0's 86 over 5 cm; their height
exactly would make it 0.048 m). What did better: the shape of the column slice by slice (how wide each 3 cm
is and where its middle lies), many more feet (from 18, then 48 other seeds), and the whole correction
(along the view, across it and up), not the height alone: :mod:`interaction.depth.shoe_model`, which corrects
each foot after these rules.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SHOE_HEIGHT_M", "SHOE_LENGTH_M", "hangs", "lies_flat", "one_per_shoe", "shoe_middle_height"]

SHOE_HEIGHT_M = 0.08  # a generic adult shoe: sole to instep …
SHOE_LENGTH_M = 0.26  # … and heel to toe
SHOE_WIDTH_M = 0.1  # … and across: two shoes' middles are at least this far apart
ON_FLOOR_M = 0.01  # lowest points seen within this of the floor cut: the shoe stands on the floor
OFF_FLOOR_M = 0.025  # … this much or more over it: the shoe is in the air (under it: flat or not, lies_flat)
HANGING_FROM_M = 0.015  # a shoe not flat whose lowest points are this much over the cut or more may hang
FOOTPRINT_BAND_M = 0.08  # a shoe's shape is read on its points this high over its lowest
TOP_BEHIND_M = 0.03  # a flat shoe seen toe-on shows its top at least this much farther than its toe
HANGING_PITCH_DEG = 45.0  # a shoe hanging toe-down is pitched this much at least
FLAT_TOP_BAND_M = 0.03  # a flat shoe's top: its points this high over its lowest …
FLAT_OFF_LEG_M = 0.25 * SHOE_LENGTH_M  # … lie this far across from its leg's (its ankle is over its heel)
LEG_LOW_M = 0.12  # the leg over a shoe: its points this high …
LEG_HIGH_M = 0.2  # … to this high over the shoe's lowest
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
    if lowest < floor_cut + ON_FLOOR_M or (lowest < floor_cut + OFF_FLOOR_M and lies_flat(column, lowest)):
        return 0.5 * SHOE_HEIGHT_M  # standing on the floor
    if lowest >= floor_cut + HANGING_FROM_M and hangs(column[z < lowest + FOOTPRINT_BAND_M], lowest, camera):
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


def lies_flat(column: np.ndarray, lowest: float) -> bool:
    """Whether the points ``column`` (N, 3) over a foot, whose lowest are at height ``lowest``, are a shoe
    lying flat: its lowest points seen (up to ``FLAT_TOP_BAND_M`` over the lowest: a flat shoe's top,
    toe to heel) lie more than ``FLAT_OFF_LEG_M`` across from its leg (the points ``LEG_LOW_M`` to
    ``LEG_HIGH_M`` over them: the ankle at its heel, the shin) — a shoe pitched, its toe lowest, has them
    nearer under its leg."""
    z = column[:, 2]
    low = column[z < lowest + FLAT_TOP_BAND_M, :2]
    leg = column[(z > lowest + LEG_LOW_M) & (z < lowest + LEG_HIGH_M), :2]
    if len(low) < 3 or len(leg) < 3:
        return False
    off = low.sum(axis=0) / len(low) - leg.sum(axis=0) / len(leg)
    return math.hypot(float(off[0]), float(off[1])) > FLAT_OFF_LEG_M


def one_per_shoe(feet: list[np.ndarray], measured: list[np.ndarray] | None = None) -> list[np.ndarray]:
    """The feet ``feet`` of one person, one where two were found on one shoe: two shoes' middles are at
    least ``SHOE_WIDTH_M`` apart across, so two feet nearer (a shoe seen alone, its other foot hidden, split
    heel from toe) are that shoe's, at their middle (and so are the last two of ``measured``: the same
    feet as measured on their points seen)."""
    if len(feet) != 2:
        return feet
    a, b = feet
    if math.hypot(float(a[0] - b[0]), float(a[1] - b[1])) >= SHOE_WIDTH_M:
        return feet
    if measured is not None and len(measured) >= 2:
        measured[-2:] = [0.5 * (measured[-2] + measured[-1])]
    return [0.5 * (a + b)]
