"""The timeline every virtual sensor shares: sample k of a sensor at ``rate_hz`` has
``t = t_open + k / rate_hz`` on the injected clock and ``read`` returns it once the clock has reached
that time — never sleeping, never skipping — until ``duration_s`` is over (then ENDED).

A subclass says what it produces (:attr:`spec`) and makes sample k at performance time tau
(:meth:`_payload`, a pure function of the config and k). Opening takes hold of the shared
:class:`~jostle.performer.scene.Performance` (its puppets) and closing lets go of it.
"""

from __future__ import annotations

import time

from jostle.performer.config import frame_count
from jostle.performer.scene import Performance
from sensors.base import Frame, Payload, SensorContext, SensorNotOpen, SensorSpec, SensorState, SensorStatus
from sensors.clock import Clock


class TimelineSensor(SensorContext):
    """Base of the virtual sensors. See the module doc."""

    uses_puppets = True  # False for sensors that need only the poses (no rendering)

    def __init__(self, performance: Performance, clock: Clock, name: str, rate_hz: float) -> None:
        self.performance = performance
        self.name = name
        self.rate_hz = rate_hz
        self._clock = clock
        self._open = False
        self._t_open = 0.0
        self._next = 0
        self._state = SensorState.CLOSED
        self._reason = ""
        self._work_s = 0.0

    # ------------------------------------------------------------ for subclasses

    @property
    def spec(self) -> SensorSpec:
        raise NotImplementedError

    def _payload(self, k: int, tau: float) -> Payload:
        raise NotImplementedError

    def _on_open(self) -> None:
        """Called after the performance is held and the timeline reset."""

    def _on_close(self) -> None:
        """Called before the performance is let go."""

    # ------------------------------------------------------------ Sensor

    @property
    def frame_count(self) -> int:
        return frame_count(self.performance.config.duration_s, self.rate_hz)

    @property
    def t_open(self) -> float:
        """Clock time of the opening (performance time 0)."""
        return self._t_open

    @property
    def status(self) -> SensorStatus:
        ms = 1000.0 * self._work_s / self._next if self._next else 0.0
        return SensorStatus(self._state, self._reason, frames=self._next, extra={"ms_per_frame": ms})

    def open(self) -> None:
        if self._open:
            return
        if self.uses_puppets:
            self.performance.acquire()
        self._open = True
        self._t_open = self._clock.now()
        self._next = 0
        self._work_s = 0.0
        self._state = SensorState.CONNECTED if self.frame_count > 0 else SensorState.ENDED
        self._reason = ""
        self._on_open()

    def read(self, timeout: float) -> Frame | None:
        """The next sample once the clock has reached its time, else None at once (never sleeps)."""
        if not self._open:
            raise SensorNotOpen(f"{self.name}: read() before open() (or after close())")
        if self._next >= self.frame_count:
            return None
        k = self._next
        tau = k / self.rate_hz
        t = self._t_open + tau
        if self._clock.now() < t:
            return None
        start = time.perf_counter()
        payload = self._payload(k, tau)
        self._work_s += time.perf_counter() - start
        self._next += 1
        if self._next >= self.frame_count:
            self._state = SensorState.ENDED
            self._reason = f"the performance ends after {self.performance.config.duration_s} s"
        return Frame(self.name, t, k, payload)

    def close(self) -> None:
        if self._open:
            self._on_close()
            if self.uses_puppets:
                self.performance.release()
            self._open = False
        self._state = SensorState.CLOSED
