"""A sensor that fails on a schedule, so the loop's recovery can be tested for every driver kind.

:class:`FaultySensor` wraps any Sensor (usually a :class:`sensors.recording.replay.Replay` of a
colour, depth or pads channel) and, on the times of a :class:`FaultSchedule` counted from
``open()`` on the sensor's clock, behaves as a live driver does when its device drops out:

- during an outage (``disconnect_at_s`` to ``disconnect_at_s + down_for_s``, repeated every
  ``repeat_every_s`` if set) the status is RECONNECTING with the reason, and the frames the
  wrapped sensor produces with ``t`` inside the outage are lost (counted in ``dropped``): ``read``
  returns None; afterwards the status is CONNECTED again and frames flow, ``seq`` showing the gap;
- with ``fail = true`` the first outage never ends: RECONNECTING for ``down_for_s``, then FAILED,
  and ``read`` raises :class:`SimulatedFailure` (as a driver does once it gives up);
- ``corrupt_every = N`` replaces the payload of every Nth delivered frame with well-formed garbage
  of the same shape ("noise": random values; "blank": zeros; "nan": pad forces NaN and ±inf,
  "noise" for images), a function of ``seed`` and the frame's ``seq``, so runs repeat exactly.

Everything is decided by times (the clock's and the frames'), so on a SimClock a faulty replay is
as deterministic as the replay it wraps. ``[sensors.<name>] type = "faulty-replay"`` builds one
from a config (:class:`FaultyReplayConfig`: the replay's keys plus the schedule's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from sensors.base import (
    ColorImage,
    DepthImage,
    Frame,
    PadSample,
    Payload,
    Sensor,
    SensorContext,
    SensorError,
    SensorNotOpen,
    SensorSpec,
    SensorState,
    SensorStatus,
)
from sensors.clock import Clock
from sensors.recording.replay import ReplayConfig

# noise: random values; blank: zeros (no depth, a black image, no force); nan: pad forces NaN and ±inf,
# the way a broken calibration or driver bug delivers them (images hold whole numbers: "noise" for them)
Corruption = Literal["noise", "blank", "nan"]
Phase = Literal["up", "down", "failed"]


class SimulatedFailure(SensorError):
    """A FaultySensor reached its scheduled permanent failure."""


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class FaultSchedule:
    """When a :class:`FaultySensor` drops out, for how long, and how it garbles payloads.

    Times are seconds after ``open()`` on the sensor's clock.
    """

    disconnect_at_s: float = 1.0
    down_for_s: float = 1.0
    repeat_every_s: float = 0.0  # 0 = one outage; else a new one every this many seconds
    fail: bool = False  # the first outage never ends: FAILED after down_for_s
    corrupt_every: int = 0  # every Nth delivered frame carries garbage (0 = never)
    corruption: Corruption = "noise"
    seed: int = 0

    def __post_init__(self) -> None:
        if not _number(self.disconnect_at_s) or self.disconnect_at_s < 0:
            raise ValueError(f"disconnect_at_s: expected seconds >= 0, got {self.disconnect_at_s!r}")
        if not _number(self.down_for_s) or self.down_for_s <= 0:
            raise ValueError(f"down_for_s: expected seconds > 0, got {self.down_for_s!r}")
        if not _number(self.repeat_every_s) or (self.repeat_every_s != 0 and self.repeat_every_s <= self.down_for_s):
            raise ValueError(f"repeat_every_s: expected 0 (once) or seconds > down_for_s ({self.down_for_s:g}), "
                             f"got {self.repeat_every_s!r}")
        if not isinstance(self.fail, bool):
            raise ValueError(f"fail: expected true or false, got {self.fail!r}")
        if isinstance(self.corrupt_every, bool) or not isinstance(self.corrupt_every, int) or self.corrupt_every < 0:
            raise ValueError(f"corrupt_every: expected a whole number >= 0 (0 = never), got {self.corrupt_every!r}")
        if self.corruption not in ("noise", "blank", "nan"):
            raise ValueError(f"corruption: expected 'noise', 'blank' or 'nan', got {self.corruption!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed: expected a whole number >= 0, got {self.seed!r}")

    def phase(self, t: float) -> tuple[Phase, float, float]:
        """(phase, outage start, outage end) at ``t`` seconds after open; the outage is the current
        one, or the next one while up (end = inf when there is none)."""
        at, down = self.disconnect_at_s, self.down_for_s
        if t < at:
            return "up", at, at + down
        if self.fail:
            return ("down" if t < at + down else "failed"), at, at + down
        start = at
        if self.repeat_every_s:
            start = at + math.floor((t - at) / self.repeat_every_s) * self.repeat_every_s
        if t < start + down:
            return "down", start, start + down
        if self.repeat_every_s:
            return "up", start + self.repeat_every_s, start + self.repeat_every_s + down
        return "up", math.inf, math.inf

    def outages_begun(self, t: float) -> int:
        """How many outages have started by ``t``."""
        if t < self.disconnect_at_s:
            return 0
        if self.fail or not self.repeat_every_s:
            return 1
        return 1 + math.floor((t - self.disconnect_at_s) / self.repeat_every_s)


def corrupt_payload(payload: Payload, kind: Corruption, rng: np.random.Generator) -> Payload:
    """Garbage of the same type and shape as ``payload``."""
    if isinstance(payload, ColorImage):
        shape = payload.bgr.shape
        return ColorImage(rng.integers(0, 256, shape, dtype=np.uint8) if kind != "blank" else np.zeros(shape, np.uint8))
    if isinstance(payload, DepthImage):
        shape = payload.depth_mm.shape
        depth = rng.integers(0, 65536, shape, dtype=np.uint16) if kind != "blank" else np.zeros(shape, np.uint16)
        color = None
        if payload.color is not None:
            cshape = payload.color.shape
            color = rng.integers(0, 256, cshape, dtype=np.uint8) if kind != "blank" else np.zeros(cshape, np.uint8)
        return replace(payload, depth_mm=depth, color=color)
    n = len(payload.newtons)
    if kind == "blank":
        return PadSample(newtons=(0.0,) * n, raw=(0,) * n)
    if kind == "nan":  # every pad non-finite: NaN, +inf, -inf in turn from a random start
        start = int(rng.integers(0, 3))
        bad = (math.nan, math.inf, -math.inf)
        return PadSample(newtons=tuple(bad[(start + i) % 3] for i in range(n)), raw=(0,) * n)
    newtons = tuple(float(v) for v in rng.uniform(-5000.0, 5000.0, n))
    return PadSample(newtons=newtons, raw=tuple(int(v) for v in rng.integers(-(2**31), 2**31, n)))


class FaultySensor(SensorContext):
    """``sensor``, failing on ``schedule`` (see the module docstring). ``clock`` must be the
    wrapped sensor's clock. Forwards everything else explicitly; closing it closes ``sensor``."""

    def __init__(self, sensor: Sensor, schedule: FaultSchedule, clock: Clock) -> None:
        if not isinstance(sensor, Sensor):
            raise TypeError(f"FaultySensor wraps a Sensor, got {type(sensor).__name__}")
        self.sensor = sensor
        self.schedule = schedule
        self._clock = clock
        self._open = False
        self._t_open = 0.0
        self._delivered = 0
        self._lost = 0
        self._corrupted = 0

    @property
    def spec(self) -> SensorSpec:
        return self.sensor.spec

    def _now(self) -> float:
        return self._clock.now() - self._t_open

    def _fault_reason(self, phase: Phase, start: float, end: float) -> str:
        name = self.sensor.spec.name
        if phase == "failed":
            return (f"{name}: simulated fault: disconnected at {start:g} s after open and never came back "
                    "(fail = true)")
        return f"{name}: simulated fault: disconnected at {start:g} s after open, back at {end:g} s"

    @property
    def status(self) -> SensorStatus:
        inner = self.sensor.status
        extra = {**inner.extra, "simulated_lost": float(self._lost), "simulated_corrupted": float(self._corrupted),
                 "simulated_outages": float(self.schedule.outages_begun(self._now()) if self._open else 0)}
        base = replace(inner, frames=self._delivered, dropped=inner.dropped + self._lost, extra=extra)
        if not self._open:
            return replace(base, state=SensorState.CLOSED, reason="")
        phase, start, end = self.schedule.phase(self._now())
        if phase == "failed":
            return replace(base, state=SensorState.FAILED, reason=self._fault_reason(phase, start, end))
        if phase == "down":
            return replace(base, state=SensorState.RECONNECTING, reason=self._fault_reason(phase, start, end))
        return base

    def open(self) -> None:
        if self._open:
            return
        self.sensor.open()
        self._t_open = self._clock.now()
        self._delivered = self._lost = self._corrupted = 0
        self._open = True

    def read(self, timeout: float) -> Frame | None:
        if not self._open:
            raise SensorNotOpen(f"{type(self.sensor).__name__} behind FaultySensor: read before open (or after close)")
        phase, start, end = self.schedule.phase(self._now())
        if phase == "failed":
            raise SimulatedFailure(self._fault_reason(phase, start, end))
        wait = timeout
        while True:
            frame = self.sensor.read(wait)
            wait = 0.0
            if frame is None:
                return None
            if self.schedule.phase(frame.t - self._t_open)[0] != "up":
                self._lost += 1  # produced while "unplugged": never delivered
                continue
            self._delivered += 1
            every = self.schedule.corrupt_every
            if every and self._delivered % every == 0:
                self._corrupted += 1
                rng = np.random.default_rng([self.schedule.seed, frame.seq])
                frame = replace(frame, payload=corrupt_payload(frame.payload, self.schedule.corruption, rng))
            return frame

    def close(self) -> None:
        self._open = False
        self.sensor.close()


@dataclass(frozen=True)
class FaultyReplayConfig(ReplayConfig):
    """``[sensors.<name>] type = "faulty-replay"``: a replay (``path``, ``channel``, ``loop``) that
    fails on a schedule (the fields of :class:`FaultSchedule`)."""

    disconnect_at_s: float = 1.0
    down_for_s: float = 1.0
    repeat_every_s: float = 0.0
    fail: bool = False
    corrupt_every: int = 0
    corruption: Corruption = "noise"
    seed: int = 0

    def __post_init__(self) -> None:
        super().__post_init__()
        _ = self.schedule  # validates the schedule's fields (errors name the field)

    @property
    def schedule(self) -> FaultSchedule:
        return FaultSchedule(disconnect_at_s=self.disconnect_at_s, down_for_s=self.down_for_s,
                             repeat_every_s=self.repeat_every_s, fail=self.fail, corrupt_every=self.corrupt_every,
                             corruption=self.corruption, seed=self.seed)
