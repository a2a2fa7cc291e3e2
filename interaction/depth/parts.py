"""Hands and feet of one person in a depth frame, found coarse and measured fine.

An extremity is *found* on the observer's sampled points and *measured* on every pixel of the full
image near it (:class:`interaction.depth.fine_depth.FineDepth`): the points of its tip on the
depth's 3×3 median are averaged and moved back along the viewing ray from the surface seen to the
middle of the part.

- :func:`find_hands`: of the points above the hips, out from the torso, clear of the legs and with
  nothing right under them, the one farthest from its shoulder, when it is an arm's reach out
  (``min_arm_reach`` to ``MAX_ARM_REACH``) and not where the arm goes on behind something nearer
  (:meth:`FineDepth.hidden_beyond`); refined by :func:`interaction.depth.hand_fit.follow_hand`.
- :func:`find_feet`: the points 5–20 cm over the floor under the shins, split in two, each measured on
  a column over it; its height from a generic shoe's shape (:mod:`interaction.depth.shoe_fit`), then
  corrected by the shoe model (:mod:`interaction.depth.shoe_model`). A hidden or half-hidden shoe
  (``MAX_FOOT_BOTTOM_M``, ``MIN_SHOE_SEEN_M2``, ``HIDDEN_SHOE_SEEN_M2``) gives no foot.

Stage metres, floor at z = 0. Figures and what was tried and not kept: docs/notes/depth-parts.md.
"""

from __future__ import annotations

import math

import numpy as np

from interaction.depth.fine_depth import FineDepth
from interaction.depth.hand_fit import follow_hand
from interaction.depth.shoe_fit import SHOE_HEIGHT_M, one_per_shoe, shoe_middle_height
from interaction.depth.shoe_model import ShoeModel, column_features
from interaction.people import two_clusters

__all__ = ["find_feet", "find_hands"]

HIDDEN_REACH = 0.15  # beyond a hand's tip, this far on along the arm (per 1.6 m of height) …
HIDDEN_MARGIN_M = 0.1  # … nothing may be seen this much nearer than the arm's line (else it goes on behind)
HAND_RADIUS_M = 0.05  # a hand, as a sphere (per 1.6 m of body height)
LEG_CLEAR_M = 0.16  # no hand is this near a leg's line, foot to hips (per 1.6 m of body height)
MAX_ARM_REACH = 0.55  # no hand is farther than this from the shoulders (a fraction of the height)
FOOT_BAND_M = 0.2  # feet are looked for this low (the shins above them)
FOOT_TOP_M = 0.1  # a foot is measured on its points this far above its lowest (the shoe, the ankle)
FLOOR_CUT_M = 0.045  # feet are measured on points this high or higher (the floor's noise stays lower)
FOOT_ON_FLOOR_M = 0.06  # a foot whose lowest points seen are this low is followed (its velocity) on the floor
FOOT_HALF_HEIGHT_M = 0.04  # a shoe: its visible faces lie this far (on average) from its middle
FOOT_RECENTRE_M = 0.02  # the column is centred again on the shoe seen when that is this far off (less: kept)
MAX_FOOT_BOTTOM_M = 0.15  # a foot whose lowest points seen are higher is a shin whose shoe is hidden: none
MIN_SHOE_SEEN_M2 = 0.011  # a foot whose shoe is seen on less (m², per 1.6 m of height) is half hidden: none
HIDDEN_SHOE_SEEN_M2 = 0.016  # … and so is one seen on less than this where something nearer hides its surroundings:
HIDING_SHARE = 0.25  # this share of the pixels within HIDING_REACH_M of it (and over 5 cm high) …
HIDING_REACH_M = 0.15
HIDING_MARGIN_M = 0.15  # … that are this much nearer the camera


def find_hands(q: np.ndarray, top: float, axis: np.ndarray, torso_r: float, feet: list[np.ndarray],
               fine: FineDepth, *, band_low: float, min_reach: float, min_arm_reach: float) -> list[np.ndarray]:
    """Up to two hands of one person (points ``q``, head at height ``top``, torso axis ``axis`` (x, y),
    chest RMS radius ``torso_r``, feet found ``feet``), each the middle of its hand in stage metres.
    Points near a leg (the line from a foot up to the hips) or over a shin are no hands."""
    scale = top / 1.6
    arm = q[q[:, 2] > band_low * top]
    out = max(min_reach, torso_r + 0.1)
    arm = arm[np.add.reduce(np.square(arm[:, :2] - axis), axis=1) >= out * out]  # out of the torso
    hips = np.array([axis[0], axis[1], 0.5 * top])
    for foot in feet:
        arm = arm[_distance_to_segment(arm, foot, hips) > LEG_CLEAR_M * scale]
    if not len(arm):
        return []
    shoulders = _shoulders(q, top, axis, scale)
    to_shoulder = np.sqrt(np.add.reduce(np.square(arm[:, None, :] - shoulders[None]), axis=2))
    nearer = np.argmin(to_shoulder, axis=1)
    along = to_shoulder[np.arange(len(arm)), nearer]
    along = np.where(along < MAX_ARM_REACH * top, along, -1.0)  # farther: legs
    reaching = np.flatnonzero(along >= min_arm_reach * top)  # the only points that can be a hand's tip
    along[reaching[_over_a_shin(arm[reaching], q, scale)]] = -1.0
    hands: list[np.ndarray] = []
    for _ in range(2):
        k = int(np.argmax(along))
        if along[k] < min_arm_reach * top:
            break
        tip, shoulder = arm[k], shoulders[nearer[k]]
        hand = _hand_middle(tip, shoulder, fine, scale, [(foot, hips) for foot in feet])
        reach = tip - shoulder
        if hand is not None and fine.hidden_beyond(tip, reach / max(float(np.linalg.norm(reach)), 1e-9),
                                                    HIDDEN_REACH * scale, HIDDEN_MARGIN_M):
            hand = None  # the arm goes on behind something nearer: what is seen is no hand's end
        if hand is not None:
            hands.append(hand)
        # the second hand: not on this arm (near the line from its shoulder to its tip)
        elsewhere = (np.add.reduce(np.square(arm - tip), axis=1) > (0.3 * scale) ** 2) \
            & (_distance_to_segment(arm, shoulder, tip) > 0.15 * scale)
        along = np.where(elsewhere, along, -1.0)
    return hands


def _over_a_shin(tips: np.ndarray, q: np.ndarray, scale: float) -> np.ndarray:
    """Which of the points ``tips`` have something right under them, as a knee or a thigh has its shin
    and a hand has not: more than two of the body's points ``q`` within 7 cm across and 10–35 cm below."""
    if not len(tips):
        return np.zeros(0, dtype=bool)
    lo, hi = tips[:, :2].min(axis=0) - 0.07 * scale, tips[:, :2].max(axis=0) + 0.07 * scale
    below = q[(q[:, 2] < float(tips[:, 2].max()) - 0.1 * scale) & np.logical_and.reduce((q[:, :2] > lo) & (q[:, :2] < hi), axis=1)]
    if not len(below):
        return np.zeros(len(tips), dtype=bool)
    dxy = np.add.reduce(np.square(tips[:, None, :2] - below[None, :, :2]), axis=2) < (0.07 * scale) ** 2
    dz = tips[:, None, 2] - below[None, :, 2]
    return np.asarray(np.count_nonzero(dxy & (dz > 0.1 * scale) & (dz < 0.35 * scale), axis=1) > 2)


def _shoulders(q: np.ndarray, top: float, axis: np.ndarray, scale: float) -> np.ndarray:
    """Both shoulders (2, 3): at 82 % of the height, 0.17 m (per 1.6 m of height) either side of the
    torso's axis along the chest's widest horizontal direction."""
    z = q[:, 2]
    chest = q[(z > 0.55 * top) & (z < 0.75 * top), :2] - axis
    chest = chest[np.add.reduce(np.square(chest), axis=1) < (0.25 * scale) ** 2]
    if len(chest) < 6:
        centre = np.array([axis[0], axis[1], 0.82 * top])
        return np.stack([centre, centre])
    cov = chest.T @ chest
    angle = 0.5 * math.atan2(2 * cov[0, 1], cov[0, 0] - cov[1, 1])
    side = np.array([math.cos(angle), math.sin(angle)]) * 0.17 * scale
    return np.array([[axis[0] + side[0], axis[1] + side[1], 0.82 * top],
                     [axis[0] - side[0], axis[1] - side[1], 0.82 * top]])


def _distance_to_segment(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    s = np.clip((pts - a) @ ab / max(float(ab @ ab), 1e-12), 0.0, 1.0)
    return np.asarray(np.sqrt(np.add.reduce(np.square(pts - (a + s[:, None] * ab)), axis=1)))


def _hand_middle(tip: np.ndarray, shoulders: np.ndarray, fine: FineDepth, scale: float,
                 legs: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray | None:
    """The hand at a coarse tip: of the full-resolution points near it, those within a hand's size of
    the farthest one out from the shoulders (across the view), again around them while the arm goes on
    past the points looked at (:mod:`interaction.depth.hand_fit`), averaged and moved back into the hand."""
    # on the 3×3 median (a third of the noise); looked for again around the hand found while it moves
    middle = follow_hand(lambda centre: fine.points_near(centre, 0.14 * scale, 0.05, smooth=True),
                         tip, shoulders, fine.camera, 2 * HAND_RADIUS_M * scale, HAND_RADIUS_M * scale, legs,
                         LEG_CLEAR_M * scale)
    return None if middle is None else fine.inset(middle, 2.0 / 3.0 * HAND_RADIUS_M * scale)


def find_feet(q: np.ndarray, fine: FineDepth, measured: list[np.ndarray] | None = None,
              shoes: ShoeModel | None = None,
              shoe_rows: list[tuple[np.ndarray, np.ndarray]] | None = None) -> list[np.ndarray]:
    """The feet of one person (points ``q``): its points low over the floor (5–20 cm) that are under
    or beside its shins (20–45 cm; stray low points under a hand or beside the person are no foot),
    split in two (one when close together), each measured on the full image (see the module's
    notes). ``measured`` gets each foot as measured on its points seen, before a shoe's shape sets its height;
    ``shoes`` corrects each foot (:mod:`interaction.depth.shoe_model`); ``shoe_rows`` gets each foot's
    (features, position before that correction), except two found on one shoe."""
    z = q[:, 2]
    low, shins = q[(z > 0.05) & (z < FOOT_BAND_M)], q[(z > FOOT_BAND_M) & (z < FOOT_BAND_M + 0.25), :2]
    if len(low) < 4 or not len(shins):
        return []
    shins = shins[:: max(1, len(shins) // 16)]
    d2 = np.minimum.reduce(np.add.reduce(np.square(low[:, None, :2] - shins[None]), axis=2), axis=1)
    low = low[d2 < 0.2 * 0.2]
    if len(low) < 4:
        return []
    size = (float(z.max()) / 1.6) ** 2  # a shoe's area goes with the person's height squared
    out: list[np.ndarray] = []
    found: list[tuple[np.ndarray, np.ndarray]] = []
    for members in two_clusters(low):
        centre = members.sum(axis=0) / len(members)
        column = fine.column_near(centre, 0.12, FLOOR_CUT_M, 0.3, smooth=True)
        if len(column) < 4:
            continue
        bottom = _lowest(column)  # a raised foot is measured where it is
        if bottom > MAX_FOOT_BOTTOM_M:
            continue  # only a shin is seen there: its shoe is hidden, and not guessed
        shoe = column[column[:, 2] < bottom + FOOT_TOP_M]
        # once more, centred on the shoe seen: the coarse points' middle can be anywhere on a shoe, and a
        # column off its middle cuts off a heel or a toe (a shoe is about as long as the column is wide)
        middle = shoe.sum(axis=0) / len(shoe)
        if math.hypot(float(middle[0] - centre[0]), float(middle[1] - centre[1])) > FOOT_RECENTRE_M:
            again = fine.column_near(middle, 0.12, FLOOR_CUT_M, 0.3, smooth=True)
            if len(again) >= 4:
                column, bottom = again, _lowest(again)
                shoe = again[again[:, 2] < bottom + FOOT_TOP_M]
        middle = shoe.sum(axis=0) / len(shoe)
        seen = len(shoe) * fine.pixel_area(middle) / size  # as if the person were 1.6 m tall
        if seen < MIN_SHOE_SEEN_M2 or (seen < HIDDEN_SHOE_SEEN_M2 and fine.nearer_share(
                np.array([middle[0], middle[1], 0.1]), HIDING_REACH_M, HIDING_MARGIN_M, 0.05) > HIDING_SHARE):
            continue  # a shoe half hidden (behind the other leg, someone nearer) is not measured
        foot = fine.inset(middle, FOOT_HALF_HEIGHT_M)
        height = shoe_middle_height(column, FLOOR_CUT_M, fine.camera)  # standing, or hanging toe-down: a shoe's shape
        if measured is not None:  # followed on the floor while it stands there: its height's noise is no velocity
            measured.append(np.array([foot[0], foot[1], 0.5 * SHOE_HEIGHT_M]) if bottom < FOOT_ON_FLOOR_M else foot.copy())
        if height is not None:
            foot[2] = height
        if shoes is not None or shoe_rows is not None:
            features = column_features(column, fine.camera, height, float(shoe[:, 2].mean()))
            found.append((features, foot.copy()))
            if shoes is not None:
                foot = shoes.corrected(foot, features, fine.camera)
        out.append(foot)
    feet = one_per_shoe(out, measured)  # a shoe seen alone can be split in two (heel, toe)
    if shoe_rows is not None and len(feet) == len(out):
        shoe_rows.extend(found)
    return feet


def _lowest(column: np.ndarray) -> float:
    """The height of a column's lowest points seen (its 10th percentile: not a stray point)."""
    k = len(column) // 10
    return float(np.partition(column[:, 2], k)[k])
