"""``jostle bench soak``: the demo looped headless for minutes, watching memory and frame rate drift.

The config (default ``configs/demo.toml``) runs in the real :class:`jostle.app.App`, headless WITH
rendering (every frame drawn and read back, no video written), every replay sensor looped forever
(``loop = true``), for ``--minutes`` of wall time. The clock is the wall clock running free
(:class:`FreeRunningClock`): recordings play at their real rate, the world is stepped by the time
that really passed, and the loop never sleeps. ``--clock paced`` paces the loop to the render rate
as a kiosk does (the wall clock).

Windows from the first drawn frame (wall clock): a warm-up (``--warmup-s``; ``rss_start_mb`` at its
end), then ``fps_first_minute`` and ``fps_last_minute`` (``fps_cpu_*``: frames per CPU-second of the
process); ``errors`` and ``warnings`` count what was logged. In full: docs/benches.md.

Nothing per frame is kept (a few hundred samples at most), so the bench does not grow by itself.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import logging
import math
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

_SAMPLE_EVERY_S = 0.5
_DEMO = Path(__file__).resolve().parents[2] / "configs" / "demo.toml"
_MAX_MESSAGES = 5


class FreeRunningClock:
    """The wall clock (monotonic seconds since construction) whose ``sleep_until`` never sleeps:
    a loop on it runs as fast as it can while everything sees real time."""

    def __init__(self) -> None:
        self._t0 = time.monotonic()

    def now(self) -> float:
        return time.monotonic() - self._t0

    def sleep_until(self, t: float) -> None:
        return None


def rss_mb() -> float:
    """This process's resident memory now, in MB (from /proc; peak RSS where there is no /proc)."""
    try:
        with open("/proc/self/statm", "rb") as f:
            pages = int(f.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (OSError, ValueError, IndexError):
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3


class _ErrorCount(logging.Handler):
    """Counts records at ERROR and above, keeping the first few messages."""

    def __init__(self) -> None:
        super().__init__(level=logging.ERROR)
        self.count = 0
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.count += 1
        if len(self.messages) < _MAX_MESSAGES:
            self.messages.append(f"{record.name}: {record.getMessage()}".splitlines()[0][:300])


@dataclasses.dataclass(frozen=True, slots=True)
class _Sample:
    t: float  # wall seconds since the first frame
    cpu: float  # process CPU seconds
    frames: int
    rss_mb: float


class _Meter:
    """Called once per drawn frame; keeps the samples the figures need."""

    def __init__(self, total_s: float, warmup_s: float, window_s: float, progress: bool) -> None:
        self.total_s = total_s
        self.warmup_s = warmup_s
        self.window_s = window_s
        self.progress = progress
        self.frames = 0
        self.t0: float | None = None
        self.t_last = 0.0
        self.cpu0 = 0.0
        self.after_warmup: _Sample | None = None
        self.first_window_end: _Sample | None = None
        self.recent: collections.deque[_Sample] = collections.deque(
            maxlen=int(math.ceil(window_s / _SAMPLE_EVERY_S)) + 8)
        self.last: _Sample | None = None
        self.rss_max = 0.0
        self._next_sample = 0.0
        self._next_report = 60.0
        self._last_report: _Sample | None = None
        self.errors = lambda: 0

    def frame(self, *_: object) -> None:
        now = time.perf_counter()
        if self.t0 is None:
            self.t0 = now
            self.cpu0 = time.process_time()
        self.frames += 1
        t = self.t_last = now - self.t0
        if t < self._next_sample:
            return
        self._next_sample = t + _SAMPLE_EVERY_S
        sample = _Sample(t, time.process_time() - self.cpu0, self.frames, rss_mb())
        self.last = sample
        self.rss_max = max(self.rss_max, sample.rss_mb)
        self.recent.append(sample)
        if self.after_warmup is None and t >= self.warmup_s:
            self.after_warmup = sample
        if self.first_window_end is None and self.after_warmup is not None and t >= self.warmup_s + self.window_s:
            self.first_window_end = sample
        if t >= self._next_report:
            self._next_report += 60.0
            self._report(sample)

    def _report(self, s: _Sample) -> None:
        prev = self._last_report or _Sample(0.0, 0.0, 0, s.rss_mb)
        self._last_report = s
        span, cpu = s.t - prev.t, s.cpu - prev.cpu
        fps = (s.frames - prev.frames) / span if span > 0 else 0.0
        fps_cpu = (s.frames - prev.frames) / cpu if cpu > 0 else 0.0
        if self.progress:
            print(f"jostle soak: {s.t / 60:.1f}/{self.total_s / 60:.1f} min, {s.frames} frames, fps {fps:.2f} "
                  f"(per CPU-s {fps_cpu:.2f}), rss {s.rss_mb:.1f} MB, errors {self.errors()}",
                  file=sys.stderr, flush=True)

    def last_window_start(self) -> _Sample | None:
        """The latest sample at least ``window_s`` before the last one."""
        if self.last is None:
            return None
        found = None
        for s in self.recent:
            if s.t <= self.last.t - self.window_s + 1e-9:
                found = s
        return found


def _rate(a: _Sample | None, b: _Sample | None) -> tuple[float | None, float | None]:
    if a is None or b is None or b.t <= a.t:
        return None, None
    n = b.frames - a.frames
    cpu = b.cpu - a.cpu
    return round(n / (b.t - a.t), 3), (round(n / cpu, 3) if cpu > 0 else None)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--minutes", type=float, default=60.0, help="wall minutes to run, fractions allowed (default 60)")
    parser.add_argument("--config", type=Path, default=_DEMO,
                        help="config to loop (default: the repository's configs/demo.toml)")
    parser.add_argument("--warmup-s", type=float, default=30.0,
                        help="seconds before rss_start_mb is taken (default 30; a quarter of a shorter run)")
    parser.add_argument("--clock", choices=("free", "paced"), default="free",
                        help="free: wall clock, the loop never sleeps (default); paced: to the render rate, as a kiosk")
    parser.add_argument("--width", type=int, default=None, help="render width (default: the config's)")
    parser.add_argument("--height", type=int, default=None, help="render height (default: the config's)")
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--quiet", action="store_true", help="no progress line on stderr each minute")


def looped(config: Any) -> Any:
    """``config`` with every replay sensor (faulty or not) set to loop forever."""
    from sensors.recording.replay import ReplayConfig

    entries = tuple(dataclasses.replace(e, config=dataclasses.replace(e.config, loop=True))
                    if isinstance(e.config, ReplayConfig) else e for e in config.sensors)
    return dataclasses.replace(config, sensors=entries)


def run(args: argparse.Namespace) -> dict[str, Any]:
    from jostle.app import App, RunOptions
    from jostle.config import load_config
    from sensors.clock import Clock, WallClock

    if not (args.minutes > 0 and math.isfinite(args.minutes)):
        raise ValueError(f"--minutes: expected a number > 0, got {args.minutes}")
    if not args.warmup_s >= 0:
        raise ValueError(f"--warmup-s: expected seconds >= 0, got {args.warmup_s}")
    config = looped(load_config(args.config))
    render = config.render
    if args.width or args.height:
        render = dataclasses.replace(render, width=args.width or render.width, height=args.height or render.height)
        config = dataclasses.replace(config, render=render)
    total_s = args.minutes * 60.0
    warmup_s = min(args.warmup_s, total_s / 4)
    window_s = min(60.0, (total_s - warmup_s) / 2)
    meter = _Meter(total_s, warmup_s, window_s, progress=not args.quiet)
    clock: Clock = FreeRunningClock() if args.clock == "free" else WallClock()
    app = App(config, RunOptions(mode="headless", out_dir=None, seed=args.seed, speed="realtime",
                                 duration_s=total_s, video=False, progress=False), clock=clock)
    app.on_frame = meter.frame

    counter = _ErrorCount()
    meter.errors = lambda: counter.count + len(exceptions)
    exceptions: list[str] = []
    warned = [0]
    root = logging.getLogger()
    root.addHandler(counter)
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        shown = warnings.showwarning

        def count_warning(*a: Any, **k: Any) -> None:
            warned[0] += 1
            if warned[0] <= _MAX_MESSAGES:
                shown(*a, **k)

        warnings.showwarning = count_warning
        try:
            summary = app.run()
            stopped = summary.stopped_because
        except Exception as e:  # the soak reports it; the figures up to here still count
            logging.getLogger("jostle.bench.soak").debug("the run ended with an exception", exc_info=True)
            exceptions.append(f"{type(e).__name__}: {e}".splitlines()[0][:300])
            summary = app.summary
            stopped = f"exception: {exceptions[-1]}"
        finally:
            root.removeHandler(counter)
    wall = time.perf_counter() - started

    last = meter.last
    start = meter.after_warmup
    fps_first, cpu_first = _rate(start, meter.first_window_end)
    fps_last, cpu_last = _rate(meter.last_window_start(), last)
    rss_start = start.rss_mb if start else None
    rss_end = last.rss_mb if last else None
    growth = round(100.0 * (rss_end - rss_start) / rss_start, 3) if rss_start and rss_end else None
    return {
        "minutes": round(meter.t_last / 60.0, 4),
        "minutes_asked": args.minutes,
        "frames": meter.frames,
        "rss_start_mb": round(rss_start, 1) if rss_start else None,
        "rss_end_mb": round(rss_end, 1) if rss_end else None,
        "rss_max_mb": round(meter.rss_max, 1),
        "rss_growth_pct": growth,
        "fps_first_minute": fps_first,
        "fps_last_minute": fps_last,
        "fps_drift_pct": round(100.0 * (fps_last - fps_first) / fps_first, 3) if fps_first and fps_last else None,
        "fps_cpu_first_minute": cpu_first,
        "fps_cpu_last_minute": cpu_last,
        "fps_cpu_drift_pct": round(100.0 * (cpu_last - cpu_first) / cpu_first, 3) if cpu_first and cpu_last else None,
        "errors": counter.count + len(exceptions),
        "error_messages": counter.messages + exceptions,
        "warnings": warned[0],
        "observer_crashes": sum(g.health().crashes for g in app.observer_guards.values()),
        "warmup_s": round(warmup_s, 3),
        "window_s": round(window_s, 3),
        "clock": args.clock,
        "config": str(args.config),
        "width": render.width,
        "height": render.height,
        "wall_seconds": round(wall, 3),
        "sim_seconds": round(summary.sim_seconds, 3),
        "dropped_sim_seconds": round(summary.dropped_sim_seconds, 3),
        "sensor_frames": summary.sensor_frames,
        "stopped_because": stopped,
    }
