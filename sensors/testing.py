"""``check_sensor``: the conformance check every Sensor implementation must pass.

One entry point made of small ``check_*`` functions (Gymnasium's ``check_env`` idea). A failed
check raises :class:`ContractError` with a message naming the sensor and what broke; nothing here
uses ``assert``, so the checks hold under ``python -O`` too. Only the public surface is used.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from sensors.base import (
    ColorImage,
    ContractError,
    DepthImage,
    Frame,
    PadSample,
    Sensor,
    SensorNotOpen,
    SensorSpec,
    SensorState,
    frame_digest,
)
from sensors.clock import SimClock

MakeSensor = Callable[[SimClock], Sensor]

_WALL_SLACK_S = 0.5  # generous: a shared machine may stall
_MAX_FRAMES_PER_INSTANT = 10_000
_KIND_OF = {ColorImage: "color", DepthImage: "depth", PadSample: "pads"}


@dataclass
class SensorRun:
    """What one drive of a sensor produced."""

    name: str
    frames: list[Frame] = field(default_factory=list)
    digests: list[str] = field(default_factory=list)


def _fail(name: str, what: str) -> ContractError:
    return ContractError(f"sensor {name!r}: {what}")


def check_read_before_open(make: MakeSensor, clock_start: float) -> None:
    sensor = make(SimClock(clock_start))
    name = type(sensor).__name__
    try:
        sensor.read(0.0)
    except SensorNotOpen:
        pass
    else:
        raise _fail(name, "read() before open() must raise SensorNotOpen")
    finally:
        sensor.close()
    if sensor.status.state is not SensorState.CLOSED:
        raise _fail(name, f"status before open / after close is {sensor.status.state}, expected CLOSED")


def check_spec(spec: SensorSpec) -> None:
    if spec.kind not in ("color", "depth", "pads"):
        raise _fail(spec.name, f"spec.kind is {spec.kind!r}, expected color, depth or pads")
    if not (math.isfinite(spec.rate_hz) and spec.rate_hz >= 0):
        raise _fail(spec.name, f"spec.rate_hz is {spec.rate_hz}, expected a finite rate >= 0")
    if spec.kind in ("color", "depth") and not (spec.width and spec.height and spec.width > 0 and spec.height > 0):
        raise _fail(spec.name, f"an image sensor's spec needs width and height > 0, got {spec.width}x{spec.height}")


def check_frame(frame: object, spec: SensorSpec, previous: Frame | None, now: float) -> Frame:
    """One frame against the spec and the frame before it."""
    if not isinstance(frame, Frame):
        raise _fail(spec.name, f"read() returned {type(frame).__name__}, expected Frame or None")
    if frame.sensor != spec.name:
        raise _fail(spec.name, f"frame.sensor is {frame.sensor!r}, expected the spec's name {spec.name!r}")
    kind = _KIND_OF.get(type(frame.payload))
    if kind != spec.kind:
        raise _fail(spec.name, f"payload is {type(frame.payload).__name__}, the spec says {spec.kind}")
    p = frame.payload
    if isinstance(p, ColorImage | DepthImage) and p.size != (spec.width, spec.height):
        raise _fail(spec.name, f"image is {p.size[0]}x{p.size[1]}, the spec says {spec.width}x{spec.height}")
    if isinstance(p, PadSample) and spec.pads is not None and len(p.newtons) != spec.pads:
        raise _fail(spec.name, f"pad sample has {len(p.newtons)} pads, the spec says {spec.pads}")
    if not isinstance(frame.t, float) or not math.isfinite(frame.t):
        raise _fail(spec.name, f"frame.t is {frame.t!r}, expected finite seconds (float)")
    if frame.t > now + 1e-6:
        raise _fail(spec.name, f"frame seq {frame.seq} has t={frame.t}, after the clock's now={now}")
    if previous is not None:
        if frame.seq <= previous.seq:
            raise _fail(spec.name, f"seq went from {previous.seq} to {frame.seq}; it must strictly increase")
        if frame.t < previous.t:
            raise _fail(spec.name, f"t went back from {previous.t} to {frame.t} (seq {frame.seq})")
    elif frame.seq < 0:
        raise _fail(spec.name, f"seq starts at {frame.seq}; it must be >= 0")
    return frame


def _timed_read(sensor: Sensor, timeout: float, name: str) -> Frame | None:
    start = time.monotonic()
    frame = sensor.read(timeout)
    took = time.monotonic() - start
    if took > timeout + _WALL_SLACK_S:
        raise _fail(name, f"read(timeout={timeout}) took {took:.3f} s of wall time on a SimClock")
    return frame


def drive(make: MakeSensor, *, clock_start: float, duration: float, step: float, read_timeout: float) -> SensorRun:
    """Open a fresh sensor, step a SimClock through ``duration``, read every frame, check each."""
    clock = SimClock(clock_start)
    sensor = make(clock)
    sensor.open()
    spec = sensor.spec
    check_spec(spec)
    run = SensorRun(spec.name)
    try:
        state = sensor.status.state
        if state not in (SensorState.CONNECTED, SensorState.RECONNECTING, SensorState.ENDED):
            raise _fail(spec.name, f"status after open() is {state}, expected CONNECTED")
        steps = max(1, round(duration / step))
        previous: Frame | None = None
        for i in range(steps + 1):
            if i:
                clock.advance(step)
            frame = _timed_read(sensor, read_timeout, spec.name)
            count = 0
            while frame is not None:
                previous = check_frame(frame, spec, previous, clock.now())
                run.frames.append(frame)
                run.digests.append(frame_digest(frame))
                count += 1
                if count > _MAX_FRAMES_PER_INSTANT:
                    raise _fail(spec.name, f"more than {_MAX_FRAMES_PER_INSTANT} frames due at one instant")
                frame = _timed_read(sensor, 0.0, spec.name)
        if not run.frames:
            raise _fail(spec.name, f"no frame in {duration} s of clock time")
        if sensor.status.frames != len(run.frames):
            raise _fail(spec.name, f"status.frames is {sensor.status.frames}, but {len(run.frames)} were read")
    finally:
        sensor.close()
    check_closed(sensor, spec.name)
    sensor.close()  # closing twice is fine
    check_closed(sensor, spec.name)
    return run


def check_closed(sensor: Sensor, name: str) -> None:
    if sensor.status.state is not SensorState.CLOSED:
        raise _fail(name, f"status after close() is {sensor.status.state}, expected CLOSED")
    try:
        sensor.read(0.0)
    except SensorNotOpen:
        return
    raise _fail(name, "read() after close() must raise SensorNotOpen")


def check_context_manager(make: MakeSensor, clock_start: float, step: float) -> None:
    clock = SimClock(clock_start)
    sensor = make(clock)
    with sensor as entered:
        name = sensor.spec.name
        if entered is not sensor:
            raise _fail(name, "__enter__ must return the sensor itself")
        clock.advance(step)
        try:
            sensor.read(0.0)
        except SensorNotOpen as e:
            raise _fail(name, "entering the context manager must open the sensor") from e
    check_closed(sensor, name)


def check_determinism(first: SensorRun, second: SensorRun) -> None:
    if first.digests == second.digests:
        return
    if len(first.digests) != len(second.digests):
        raise _fail(first.name, f"two fresh instances driven alike gave {len(first.digests)} and "
                                f"{len(second.digests)} frames")
    i = next(i for i, (a, b) in enumerate(zip(first.digests, second.digests, strict=True)) if a != b)
    raise _fail(first.name, f"two fresh instances driven alike differ at frame {i} "
                            f"(seq {first.frames[i].seq}, t {first.frames[i].t})")


def check_sensor(
    make: MakeSensor,
    *,
    clock_start: float = 0.0,
    duration: float = 2.0,
    step: float = 1 / 60,
    read_timeout: float = 0.05,
    deterministic: bool = True,
) -> None:
    """Run every contract check on sensors built by ``make(clock)``; raise ContractError on the first failure.

    ``make`` must return a fresh, unopened sensor on the given SimClock each time it is called.
    Pass ``deterministic=False`` for sensors fed by a live source (their frames cannot repeat).
    """
    if not step > 0 or not duration > 0:
        raise ValueError(f"step and duration must be > 0, got step={step}, duration={duration}")
    check_read_before_open(make, clock_start)
    first = drive(make, clock_start=clock_start, duration=duration, step=step, read_timeout=read_timeout)
    check_context_manager(make, clock_start, step)
    if deterministic:
        second = drive(make, clock_start=clock_start, duration=duration, step=step, read_timeout=read_timeout)
        check_determinism(first, second)
