"""Hands and feet followed from frame to frame: gating, a constant-velocity prediction, confirmation.

Each person has up to two tracks per part (``hand``, ``foot``). A frame's detections of a part are
given to that person's tracks of the part by the cheapest assignment of detections to predicted
positions (constant velocity) within ``gate_m``; a detection beyond the gate of every track starts a
new one (replacing the track unseen the longest when both slots are taken). A track is *reported*
once it has been found in ``confirm_frames`` frames in a row (a hand seen in one frame only — most
often a knee or a noise blob taken for one — never becomes a contactor); ``confirm_by_part`` sets
other counts for some parts (the depth observer's feet: 1, a foot found is a foot). Its position is
the frame's own measurement (no lag).

Its *velocity* is the frame-to-frame one (the last two positions; it lags half a frame), not
smoothed: it is *claimed* only when it can be backed — the track has followed its prediction within
``steady_m`` for ``steady_frames`` frames, and its last two steps agree in direction (within
``consistent_deg``) at ``min_speed`` or more; otherwise the contactor carries a zero velocity.
Why not smoothed: docs/notes/depth.md.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["LimbTracker"]


@dataclass
class _Track:
    position: np.ndarray  # the last position found
    t: float
    velocity: np.ndarray | None = None  # the last frame-to-frame velocity (m/s)
    previous: np.ndarray | None = None  # the one before
    hits: int = 1  # frames found in a row
    steady: int = 1  # frames in a row that followed the prediction
    unseen: int = 0


class LimbTracker:
    """Tracks of hands and feet, keyed by (person, part, slot 0/1)."""

    def __init__(self, *, gate_m: float, steady_m: float, confirm_frames: int, steady_frames: int,
                 memory_frames: int, consistent_deg: float, min_speed: float,
                 confirm_by_part: dict[str, int] | None = None) -> None:
        self._gate, self._steady_m = gate_m, steady_m
        self._confirm_by_part = dict(confirm_by_part or {})  # parts confirmed after other counts of frames
        self._confirm, self._steady_frames, self._memory = confirm_frames, steady_frames, memory_frames
        self._tracks: dict[tuple[int, str, int], _Track] = {}
        self._cos_consistent = math.cos(math.radians(consistent_deg))
        self._min_speed = min_speed

    def clear(self) -> None:
        self._tracks.clear()

    def update(self, person: int, part: str, found: list[np.ndarray], t: float, born: bool,
               moving: list[np.ndarray] | None = None) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """Give one person's detections of one part (at most two) to its tracks; returns the reported
        ones as (slot, position, velocity). ``moving``: the points the tracks follow, one per detection
        (default ``found``), when a detection's position is had from a model that changes from frame to
        frame (a foot's height from a shoe's shape) and the points it was measured at move smoothly: the
        gate, the steadiness and the velocity are taken on them, the position reported is ``found``'s."""
        reported, found = found, (found if moving is None else moving)
        slots = [self._tracks.get((person, part, s)) for s in (0, 1)]
        if born:
            slots = [None, None]
        predicted = [None if tr is None else _predict(tr, t) for tr in slots]
        dist = [[math.inf if pred is None else math.dist(pos, pred) for pred in predicted] for pos in found]
        best: tuple[float, tuple[int | None, ...]] = (math.inf, ())
        for choice in itertools.permutations((0, 1, None, None), len(found)):
            if choice.count(0) > 1 or choice.count(1) > 1:
                continue
            cost = 0.0
            for i, maybe in enumerate(choice):
                d = self._gate if maybe is None else dist[i][maybe]
                if d > self._gate:
                    cost = math.inf
                    break
                cost += d
            if cost < best[0]:
                best = (cost, choice)
        taken = {o for o in best[1] if o is not None}
        order: list[int] = []
        for maybe in best[1]:  # new tracks: into an empty slot, else the one unseen longest
            if maybe is None:
                free = [s for s in (0, 1) if s not in taken]
                maybe = min(free, key=lambda s: (0, 0) if slots[s] is None else (1, -slots[s].unseen))  # type: ignore[union-attr]
                taken.add(maybe)
                slots[maybe] = None
            order.append(maybe)
        out: list[tuple[int, np.ndarray, np.ndarray]] = []
        confirm = self._confirm_by_part.get(part, self._confirm)
        for pos, shown, slot in zip(found, reported, order, strict=True):
            track = self._follow(slots[slot], pos, t)
            self._tracks[(person, part, slot)] = track
            if track.hits >= confirm:
                steady = track.steady >= self._steady_frames and self._consistent(track)
                velocity = track.velocity if steady and track.velocity is not None else np.zeros(3)
                out.append((slot, shown.copy(), velocity.copy()))
        for slot in (0, 1):
            if slot not in taken:
                key = (person, part, slot)
                left = self._tracks.get(key)
                if left is not None:
                    left.unseen += 1
                    left.hits = 0
                    if left.unseen > self._memory:
                        del self._tracks[key]
        return out

    def forget_people(self, present: set[int]) -> None:
        """Drop the tracks of people no longer tracked."""
        for key in [k for k in self._tracks if k[0] not in present]:
            del self._tracks[key]

    def _consistent(self, track: _Track) -> bool:
        """The last two frame-to-frame velocities agree in direction (within ``consistent_deg``) and the
        track is moving (``min_speed``): below that, the depth's noise decides the direction."""
        a, b = track.velocity, track.previous
        if a is None or b is None:
            return False
        na, nb = math.sqrt(float(a.dot(a))), math.sqrt(float(b.dot(b)))  # the norms
        if min(na, nb) < self._min_speed:
            return False
        return float(a @ b) >= self._cos_consistent * na * nb

    def _follow(self, track: _Track | None, pos: np.ndarray, t: float) -> _Track:
        if track is None or t <= track.t:
            return _Track(pos.copy(), t)
        fresh = track.unseen > 0
        off = pos - _predict(track, t)
        residual = math.sqrt(float(off.dot(off)))
        track.previous = None if fresh else track.velocity
        track.velocity = (pos - track.position) / (t - track.t)
        track.position, track.t = pos.copy(), t
        track.hits = 1 if fresh else track.hits + 1
        track.steady = track.steady + 1 if residual <= self._steady_m and not fresh else 1
        track.unseen = 0
        return track


def _predict(track: _Track, t: float) -> np.ndarray:
    if track.velocity is None or track.unseen > 0:
        return track.position
    return np.asarray(track.position + track.velocity * max(t - track.t, 0.0))
