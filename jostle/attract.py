"""Attract mode: when nobody has been in front of the sensors for a while, the characters wander and a
call to action pulses on screen; the moment a person appears, play resumes.

:class:`Attract` is a pure state machine over (loop time, people seen): no clock, no world, no
drawing. The main loop feeds it every frame and acts on the transitions it returns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum


class Phase(StrEnum):
    PLAY = "play"  # someone is (or was recently) there: the characters follow their own intents
    ATTRACT = "attract"  # nobody for attract_after_s: characters wander, call to action on screen


@dataclass(frozen=True, slots=True)
class Transition:
    """A change of phase at loop time ``t``."""

    t: float
    before: Phase
    after: Phase


class Attract:
    """PLAY → ATTRACT once no person has been seen for ``after_s`` seconds (counted from the first
    update, so a fresh start waits too); ATTRACT → PLAY on the first observation with ≥ 1 person.

    ``after_s = 0`` turns attract mode off (always PLAY). ``period_s``: one pulse of the call to
    action; ``fade_s``: it fades in over this long after ATTRACT begins. Time must not run backwards
    (an earlier ``t`` is taken as the last one).
    """

    def __init__(self, after_s: float, period_s: float = 2.0, fade_s: float = 0.5) -> None:
        if not (math.isfinite(after_s) and after_s >= 0):
            raise ValueError(f"after_s: expected seconds ≥ 0 (0 = off), got {after_s!r}")
        if not (math.isfinite(period_s) and period_s > 0):
            raise ValueError(f"period_s: expected seconds > 0, got {period_s!r}")
        if not (math.isfinite(fade_s) and fade_s >= 0):
            raise ValueError(f"fade_s: expected seconds ≥ 0, got {fade_s!r}")
        self.after_s, self.period_s, self.fade_s = after_s, period_s, fade_s
        self.phase = Phase.PLAY
        self._last_seen: float | None = None  # loop time of the last observation with people
        self._t: float | None = None
        self._since = 0.0  # loop time the current phase began

    @property
    def enabled(self) -> bool:
        return self.after_s > 0

    @property
    def since(self) -> float:
        """Loop time at which the current phase began."""
        return self._since

    def update(self, t: float, people: int) -> Transition | None:
        """Feed one frame: loop time ``t`` and the number of people seen. Returns the transition it
        causes, if any."""
        if not math.isfinite(t):
            return None
        if self._t is not None and t < self._t:
            t = self._t
        if self._t is None:
            self._since = t
            self._last_seen = t  # a fresh start counts as "just seen": wait after_s before attracting
        self._t = t
        if people > 0:
            self._last_seen = t
        if not self.enabled:
            return None
        before = self.phase
        if before is Phase.ATTRACT and people > 0:
            self.phase = Phase.PLAY
        elif before is Phase.PLAY and self._last_seen is not None and t - self._last_seen >= self.after_s - 1e-9:
            self.phase = Phase.ATTRACT
        if self.phase is before:
            return None
        self._since = t
        return Transition(t, before, self.phase)

    def idle_for(self, t: float) -> float:
        """Seconds since a person was last seen (0 before the first update)."""
        return 0.0 if self._last_seen is None else max(0.0, t - self._last_seen)

    def strength(self, t: float) -> float:
        """How strongly to draw the call to action at ``t``: 0 in PLAY; in ATTRACT a pulse between
        0.35 and 1 with period ``period_s``, faded in over ``fade_s`` from the start of ATTRACT."""
        if self.phase is not Phase.ATTRACT:
            return 0.0
        age = max(0.0, t - self._since)
        fade = 1.0 if self.fade_s == 0 else min(1.0, age / self.fade_s)
        pulse = 0.675 + 0.325 * math.cos(2.0 * math.pi * age / self.period_s)
        return fade * pulse
