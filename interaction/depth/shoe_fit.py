"""The height of a shoe's middle, from the shape of what a depth camera sees of it.

A depth camera above the stage sees a shoe's top and the faces turned to it, not its sole: the points
seen lie above the middle of a shoe standing flat on the floor, and at the toe of one hanging
toe-down. :func:`shoe_middle_height` puts the middle (stage metres) from a generic adult shoe's shape
(``SHOE_HEIGHT_M``, ``SHOE_LENGTH_M``), given the column of points over a foot and the floor cut:

- lowest points within ``ON_FLOOR_M`` of the cut: standing, its middle half a shoe's height up;
- lowest points a little over the cut, lying flat (:func:`lies_flat`): standing, only its top seen;
- in the air, or a little over the cut and not flat, and hanging (:func:`hangs`: narrow across the
  view): its middle half a shoe's length up a shoe pitched ``HANGING_PITCH_DEG``;
- anything else: None, measured where its points are.

Two feet found on one person nearer than ``SHOE_WIDTH_M`` are one shoe (:func:`one_per_shoe`). What
these rules leave (a heel up, a toe hanging at a pitch the points do not tell) the shoe model
corrects (:mod:`interaction.depth.shoe_model`).

The rules in full, their figures and what was tried and not kept: docs/notes/shoe-fit.md.
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
