"""Where the virtual performer's hands and feet really are, for ``jostle bench interaction``.

The hand is a sphere 2 cm beyond the wrist along the forearm; the shoe a box whose centre is 46.6 %
of the way from the ankle to the toe and 1.2 cm below that line, toward the sole (``jostle.performer.dress``,
per metre of body size). Contactors are compared with these centres, not with the wrist and ankle
joints they hang from.

Two velocity references are kept apart here, so that the bench can tell the tracker's own error from
what its frame rate allows (:func:`sampled_truth_angles`, :func:`true_steps`): the true velocity at the
frame's instant, and the true part's motion over the last frame interval (what any tracker that sees
only the frames can know). :class:`LinearCeiling` goes one step further: the best any tracker that
combines the last few exact positions linearly could claim (an optimistic bound: no depth noise, and its
weights fitted to the very velocities it is scored against).

What was tried to get under those ceilings, with the figures: docs/notes/bench-truth.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

SAME_PART_M = 0.10  # a contactor this near a true hand (foot) is that hand: its velocity is compared
MOVING_M_S = 0.5  # velocities are compared for parts moving faster than this
CEILING_TAPS = 4  # LinearCeiling: positions combined (3 to 6 measured within 3° of each other at 15-60 fps)
_HAND_BEYOND_WRIST_M = 0.02
_FOOT_ALONG = 0.4658
_FOOT_BELOW_M = 0.01225

PartKey = tuple[int, str, int]  # (person id, "hand" or "foot", side: 0 right, 1 left)


def body_part_centres(person: Any, part: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """(position, velocity) of one person's two hands (hand-sphere centres) or feet (shoe centres),
    right then left."""
    from sim.motion.mocap import HUMANOID

    j, v = person.joints, person.velocities
    out = []
    for side in ("right", "left"):
        if part == "hand":
            w, e = HUMANOID.names.index(f"{side}_wrist"), HUMANOID.names.index(f"{side}_elbow")
            fore = j[w] - j[e]
            length = max(float(np.linalg.norm(fore)), 1e-9)
            out.append((j[w] + fore / length * _HAND_BEYOND_WRIST_M * person.size, v[w]))
        else:
            a, t = HUMANOID.names.index(f"{side}_ankle"), HUMANOID.names.index(f"{side}_toe")
            along = j[t] - j[a]
            up = np.array([0.0, 0.0, 1.0]) - along * (along[2] / max(float(along @ along), 1e-12))
            up /= max(float(np.linalg.norm(up)), 1e-9)
            centre = j[a] + _FOOT_ALONG * along - up * _FOOT_BELOW_M * person.size
            out.append((centre, v[a] + _FOOT_ALONG * (v[t] - v[a])))
    return out


def part_centres(frame_truth: Any, part: str) -> list[tuple[PartKey, np.ndarray, np.ndarray]]:
    """(key, position, velocity) of every true hand or foot centre of everyone on the stage."""
    return [((person.id, part, side), pos, vel)
            for person in frame_truth.people if person.present
            for side, (pos, vel) in enumerate(body_part_centres(person, part))]


def true_steps(before: Any, now: Any, part: str) -> dict[PartKey, np.ndarray]:
    """Each true hand (foot) centre's motion from the frame ``before`` to ``now``, over the time between
    them (m/s): what a tracker that sees only those two frames can know of its velocity."""
    dt = now.t - before.t
    if dt <= 0:
        return {}
    earlier = {key: pos for key, pos, _ in part_centres(before, part)}
    return {key: (pos - earlier[key]) / dt for key, pos, _ in part_centres(now, part) if key in earlier}


def angle_deg(a: np.ndarray, b: np.ndarray) -> float | None:
    """The angle between two vectors (degrees), None when either is zero."""
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if na <= 1e-9 or nb <= 1e-9:
        return None
    return math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b) / (na * nb)))))


def sampled_truth_angles(before: Any, now: Any) -> list[float]:
    """The velocity direction error of a perfect tracker at the depth frame rate: for each true hand
    and foot centre moving faster than 0.5 m/s in ``now``, the angle between its step from ``before``
    (the previous depth frame's truth, same person and side) over the time between them and its true
    velocity (degrees)."""
    out = []
    for part in ("hand", "foot"):
        steps = true_steps(before, now, part)
        for key, _, true_v in part_centres(now, part):
            step = steps.get(key)
            if step is None or float(np.linalg.norm(true_v)) <= MOVING_M_S:
                continue
            angle = angle_deg(step, true_v)
            if angle is not None:
                out.append(angle)
    return out


def visible_people(frame_truth: Any, camera: Any) -> int | None:
    """How many pelvises are inside the view; None when one is within 0.4 m of its edge (ambiguous)."""
    from sim.motion.mocap import HUMANOID

    root = HUMANOID.names.index("root")
    seen = 0
    for person in frame_truth.people:
        if not person.present:
            continue
        p = person.joints[root]
        depth = float(camera.to_camera(p)[2])
        margin = 0.4 * camera.focal_px / max(depth, 0.1)
        u, v = camera.project(p)
        inside = 0 <= u < camera.width and 0 <= v < camera.height
        near_edge = -margin <= u < camera.width + margin and not (margin <= u < camera.width - margin)
        if near_edge:
            return None
        seen += int(inside)
    return seen


class LinearCeiling:
    """The velocity direction error of the best *linear* tracker at the depth frame rate.

    For each true hand and foot centre moving faster than ``MOVING_M_S``, the exact centres at the last
    ``taps`` depth frames (this one first) are kept with its true velocity now. ``angles`` fits, by least
    squares over every sample of the run at once, the one set of weights a such that
    Σ aⱼ·(xₜ₋ⱼ − xₜ₋ⱼ₋₁) / Δt is nearest the true velocities (weights on the steps, not on the positions,
    so that where the stage's origin lies cannot matter), and returns each sample's angle to its true
    velocity. Every causal tracker
    that differences positions (frame steps, alpha-beta, constant-acceleration fits, Kalman filters in
    their steady state) is such a weighting: none does better on these parts at this rate, even before
    any noise, unless it knows more than the positions (a body model). Samples whose frames are not evenly
    spaced (a dropped frame) are left out."""

    def __init__(self, taps: int = CEILING_TAPS) -> None:
        if taps < 2:
            raise ValueError(f"taps: expected >= 2, got {taps}")
        self.taps = taps
        self._window: list[Any] = []
        self._x: list[np.ndarray] = []  # (taps - 1, 3) frame steps / Δt, newest first
        self._v: list[np.ndarray] = []

    def new_recording(self) -> None:
        """The next frame starts another recording: no history is carried over."""
        self._window = []

    def add(self, frame_truth: Any, score: bool = True) -> None:
        """The truth of the next depth frame (every frame, in order); ``score``: take its samples (False:
        only remember it, e.g. while the observer is still learning the empty stage)."""
        self._window = [*self._window[-(self.taps - 1):], frame_truth]
        if not score or len(self._window) < self.taps:
            return
        times = np.array([f.t for f in self._window])
        gaps = np.diff(times)
        dt = float(gaps.mean())
        if dt <= 0 or float(np.abs(gaps - dt).max()) > 0.1 * dt:
            return
        for part in ("hand", "foot"):
            history = [{key: pos for key, pos, _ in part_centres(f, part)} for f in reversed(self._window)]
            for key, _, true_v in part_centres(frame_truth, part):
                if float(np.linalg.norm(true_v)) <= MOVING_M_S or any(key not in h for h in history):
                    continue
                positions = np.stack([h[key] for h in history])
                self._x.append((positions[:-1] - positions[1:]) / dt)
                self._v.append(np.asarray(true_v, dtype=float))

    def angles(self) -> list[float]:
        """Each sample's angle (degrees) under the best weights (none: fewer samples than taps)."""
        if len(self._v) < self.taps:
            return []
        x = np.stack(self._x)  # (N, taps - 1, 3)
        v = np.stack(self._v)  # (N, 3)
        design = x.transpose(0, 2, 1).reshape(-1, self.taps - 1)  # each axis of each sample is one equation
        weights, *_ = np.linalg.lstsq(design, v.reshape(-1), rcond=None)
        claimed = (design @ weights).reshape(-1, 3)
        return [a for a in (angle_deg(c, t) for c, t in zip(claimed, v, strict=True)) if a is not None]
