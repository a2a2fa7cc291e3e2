"""One clock drives everything: injected, never global.

Live runs use :class:`WallClock`; replays, headless runs and tests use :class:`SimClock`, whose
time moves only when the loop moves it. The main loop paces itself with ``sleep_until`` on either,
so the same loop code runs live and on simulated time.
"""

from __future__ import annotations

import time
from typing import Protocol, runtime_checkable


@runtime_checkable
class Clock(Protocol):
    def now(self) -> float:
        """Seconds since the clock started."""
        ...

    def sleep_until(self, t: float) -> None:
        """Return once ``now() >= t`` (at once if it already is)."""
        ...


class WallClock:
    """Real time, seconds since construction (monotonic)."""

    def __init__(self) -> None:
        self._t0 = time.monotonic()

    def now(self) -> float:
        return time.monotonic() - self._t0

    def sleep_until(self, t: float) -> None:
        delay = t - self.now()
        if delay > 0:
            time.sleep(delay)


class SimClock:
    """Simulated time: starts at ``start`` and moves only by ``advance`` or ``sleep_until``."""

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)

    def now(self) -> float:
        return self._t

    def advance(self, dt: float) -> None:
        if dt < 0:
            raise ValueError(f"SimClock cannot go back in time (dt={dt})")
        self._t += dt

    def sleep_until(self, t: float) -> None:
        if t > self._t:
            self._t = float(t)
