"""``jostle record``: every sensor of a config, wrapped in a Recorder, into one MCAP file."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from jostle.config import load_config
from sensors.base import Sensor, SensorState
from sensors.clock import Clock, SimClock, WallClock
from sensors.recording.writer import Recorder, RecordingWriter
from sensors.registry import SENSOR_TYPES


def record_config(config_path: Path, out: Path, *, duration: float | None, force: bool = False) -> int:
    from jostle.errors import UsageError
    from sensors.recording.replay import ReplayConfig

    config = load_config(config_path)
    if out.exists() and not force:
        raise UsageError(f"{out}: exists already; choose another --out or add --force")
    if out.suffix != ".mcap":
        raise UsageError(f"{out}: a recording's name must end in .mcap")
    out.parent.mkdir(parents=True, exist_ok=True)
    replay_only = all(isinstance(e.config, ReplayConfig) for e in config.sensors)
    clock: Clock = SimClock() if replay_only else WallClock()
    writer = RecordingWriter(out, metadata={"config": str(config_path)})
    sensors: list[Sensor] = []
    frames = 0
    started = time.perf_counter()
    step = 1.0 / 120.0
    try:
        for e in config.sensors:
            sensors.append(Recorder(SENSOR_TYPES[e.type].load(e.config, e.name, clock), writer))
        for s in sensors:
            s.open()
        print(f"jostle: recording {len(sensors)} sensor(s) to {out}; Ctrl-C stops", file=sys.stderr)
        last_report = 0.0
        while True:
            if isinstance(clock, SimClock):
                clock.advance(step)
            got = 0
            for s in sensors:
                frame = s.read(0.0 if isinstance(clock, SimClock) else 0.01)
                while frame is not None:
                    got += 1
                    frame = s.read(0.0)
            frames += got
            now = clock.now()
            if now - last_report >= 1.0 or (duration and now >= duration):
                last_report = now
                size = out.stat().st_size / 1e6 if out.exists() else 0.0
                rate = frames / max(now, 1e-9)
                tty = sys.stderr.isatty()
                line = f"jostle: {now:6.1f} s  {frames} frames  {size:.1f} MB  {rate:.1f} frames/s"
                print(("\r" + line) if tty else line, end="" if tty else "\n", file=sys.stderr)
            if duration and now >= duration:
                break
            if all(s.status.state is SensorState.ENDED for s in sensors):
                break
            failed = [s for s in sensors if s.status.state is SensorState.FAILED]
            if failed:
                raise RuntimeError(f"sensor {failed[0].spec.name!r} failed: {failed[0].status.reason}")
    except KeyboardInterrupt:
        pass
    finally:
        for s in sensors:
            s.close()
        writer.close()
    if sys.stderr.isatty():
        print(file=sys.stderr)
    print(f"jostle: wrote {out} ({frames} frames, {out.stat().st_size / 1e6:.1f} MB, "
          f"{time.perf_counter() - started:.1f} s)", file=sys.stderr)
    return 0
