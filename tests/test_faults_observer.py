"""A crash inside one observer: logged once with its traceback, the observer rebuilt after a back-off
that doubles (capped), the others going on — unit-tested on a SimClock and end to end in the App."""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from interaction.observers import Observer, ObserverType, observer_types
from interaction.pads import PadsObserver, PadsObserverConfig
from interaction.types import BodyObservation, Contactor
from jostle import run_setup
from jostle.app import App, RunOptions
from jostle.config import JostleConfig, ObserverEntry, SensorEntry, load_config
from jostle.observer_guard import ObserverGuard
from sensors.base import Frame, PadSample
from sensors.clock import SimClock

ROOT = Path(__file__).resolve().parent.parent
PADS = PadsObserverConfig(positions=(0.0, 0.0, 1.0), directions=(0.0, 1.0, 0.0))


class Crashing:
    """The fault injected: a real observer that raises when ``crash(frame)`` says so."""

    def __init__(self, inner: Observer, crash: Callable[[Frame], bool]) -> None:
        self.inner = inner
        self.crash = crash

    def observe(self, frame: Frame) -> BodyObservation:
        if self.crash(frame):
            raise RuntimeError(f"injected crash at t={frame.t:.3f}")
        return self.inner.observe(frame)

    def __getattr__(self, name: str) -> Any:  # calibration, silhouette: the real observer's
        return getattr(self.inner, name)


def pad_frame(i: int, t: float, newtons: float = 0.0) -> Frame:
    return Frame("pads", t, i, PadSample((newtons,), (0,)))


def drive(guard: ObserverGuard, clock: SimClock, seconds: float, step: float = 0.05) -> list[BodyObservation]:
    out = []
    for i in range(round(seconds / step)):
        clock.advance(step)
        out.append(guard.observe(pad_frame(i, clock.now())))
    return out


def test_repeated_crashes_back_off_exponentially_up_to_the_cap(caplog: pytest.LogCaptureFixture) -> None:
    clock = SimClock()
    builds: list[float] = []

    def build() -> Observer:
        builds.append(clock.now())
        return Crashing(PadsObserver(PADS), lambda f: True)  # crashes on every frame it is given

    guard = ObserverGuard("floor", build, clock, first_backoff_s=1.0, max_backoff_s=30.0)
    with caplog.at_level(logging.INFO, logger="jostle.observers"):
        observations = drive(guard, clock, 200.0)
    assert all(o == BodyObservation(t=o.t) for o in observations)  # never anything from a crashed observer
    # each rebuild crashes on its first frame: the gaps between rebuilds are the back-offs
    gaps = [b - a for a, b in zip(builds, builds[1:], strict=False)]
    expected = [1.0, 2.0, 4.0, 8.0, 16.0, 30.0, 30.0, 30.0, 30.0]
    assert len(gaps) >= len(expected)
    for gap, want in zip(gaps, expected, strict=False):
        assert want <= gap < want + 0.05 + 1e-9
    health = guard.health()
    assert health.crashes == len(builds) and health.restarts == len(builds) - 1
    assert health.state == "restarting" and 0 < health.retry_in_s <= 30.0
    assert health.last_error.startswith("RuntimeError: injected crash at t=")
    errors = [r for r in caplog.records if r.levelno == logging.ERROR]
    assert len(errors) == health.crashes  # every crash is one error line …
    assert sum(r.exc_info is not None for r in errors) == 1  # … and the traceback comes once
    assert "'floor' crashed" in errors[0].getMessage() and "rebuilding it in 1 s" in errors[0].getMessage()


def test_a_healthy_stretch_resets_the_back_off_and_others_are_untouched() -> None:
    clock = SimClock()
    crash_at = [0.5, 1.6, 100.0]  # twice in a row, then a long healthy run, then once more

    def crash(frame: Frame) -> bool:
        if crash_at and frame.t >= crash_at[0]:
            crash_at.pop(0)
            return True
        return False

    flaky = ObserverGuard("flaky", lambda: Crashing(PadsObserver(PADS), crash), clock, healthy_after_s=60.0)
    steady = ObserverGuard("steady", lambda: PadsObserver(PADS), clock)
    crashes_at = []
    for i in range(round(110 / 0.05)):
        clock.advance(0.05)
        before = flaky.health().crashes
        flaky.observe(pad_frame(i, clock.now()))
        steady.observe(pad_frame(i, clock.now()))
        if flaky.health().crashes > before:
            crashes_at.append(clock.now())
    assert len(crashes_at) == 3
    restarts = flaky.restart_times
    assert len(restarts) == 3
    assert restarts[0] - crashes_at[0] == pytest.approx(1.0, abs=0.051)
    assert restarts[1] - crashes_at[1] == pytest.approx(2.0, abs=0.051)  # second in a row: doubled
    assert restarts[2] - crashes_at[2] == pytest.approx(1.0, abs=0.051)  # after 60 s healthy: from the start
    assert steady.health() == dataclasses.replace(steady.health(), crashes=0, restarts=0, state="running")


def test_a_rebuild_that_fails_counts_and_backs_off_further() -> None:
    clock = SimClock()
    attempts = [0]

    def build() -> Observer:
        attempts[0] += 1
        if attempts[0] in (2, 3):  # the first rebuilds find the device config unusable
            raise OSError("calibration file unreadable")
        return Crashing(PadsObserver(PADS), lambda f: attempts[0] == 1 and f.t >= 1.0)

    guard = ObserverGuard("floor", build, clock)
    drive(guard, clock, 12.0)
    h = guard.health()
    assert (h.crashes, h.failed_restarts, h.restarts, h.state) == (1, 2, 1, "running")
    # crash at 1.0 → try 1 s later (fails) → 2 s later, at 4 (fails) → 4 s later, at 8: built
    assert guard.restart_times == [pytest.approx(8.0, abs=0.11)]


def test_non_finite_contactors_and_pad_forces_are_dropped_and_counted() -> None:
    clock = SimClock()

    class NanEvery3rd:
        def __init__(self) -> None:
            self.n = 0

        def observe(self, frame: Frame) -> BodyObservation:
            self.n += 1
            bad = self.n % 3 == 0
            c = Contactor(0, "hand", (math.nan if bad else 0.5, 0.0, 1.0), (0.0, 0.0, 0.0), 0.1)
            ok = Contactor(0, "head", (0.0, 0.0, 1.6), (0.0, math.inf if bad else 0.0, 0.0), 0.1)
            return BodyObservation(frame.t, (c, ok), (), 1)

    guard = ObserverGuard("cam", NanEvery3rd, clock)
    seen = drive(guard, clock, 3.0)
    assert len(seen) == 60
    assert guard.health().dropped_non_finite == 2 * 20
    for obs in seen:
        assert obs.people == 1
        for c in obs.contactors:
            assert all(math.isfinite(v) for v in (*c.position, *c.velocity, c.radius))
    pads = ObserverGuard("pads", lambda: PadsObserver(PADS), clock)
    for i, f in enumerate((10.0, math.nan, math.inf, 5.0)):
        obs = pads.observe(pad_frame(i, clock.now() + i * 0.01, f))
        assert obs.impulses == ()
    assert pads.health().non_finite_inputs == 2


# ------------------------------------------------------------------ end to end: the App


def _two_cameras() -> JostleConfig:
    """The demo with a second webcam replay of the same recording and an observer on each."""
    cfg = load_config(ROOT / "configs" / "demo.toml")
    cfg = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=160, height=90))
    cam, ob = cfg.sensors[0], cfg.observers[0]
    return dataclasses.replace(
        cfg,
        sensors=(cam, SensorEntry("side", cam.type, cam.config)),
        observers=(ob, ObserverEntry("side", ob.type, "side", ob.calibration, ob.config)),
    )


def test_in_the_app_a_crashing_observer_is_rebuilt_while_the_other_goes_on(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    table = observer_types()
    real = table["webcam"]
    crash_at = [5.0]  # the first frame of the "side" camera at or after 5 s raises, once

    def build(config: Any, calibration: Path | None, sensor: str) -> Observer:
        inner = real.build(config, calibration, sensor)
        if sensor != "side":
            return inner

        def crash(frame: Frame) -> bool:
            if crash_at and frame.t >= crash_at[0]:
                crash_at.pop()
                return True
            return False

        return Crashing(inner, crash)

    table["webcam"] = ObserverType(real.config, build, real.needs_calibration, real.description)
    monkeypatch.setattr(run_setup, "observer_types", lambda: table)
    app = App(_two_cameras(), RunOptions(out_dir=None, seed=7, duration_s=9.0, video=False, progress=False))
    trace: list[tuple[float, str, int]] = []
    app.on_frame = lambda snap, obs, image: trace.append(
        (snap.t, app.observer_guards["side"].health().state, obs.people))
    with caplog.at_level(logging.INFO, logger="jostle.observers"):
        summary = app.run()
    assert summary.stopped_because == "duration 9 s reached"
    assert len(trace) == summary.frames_rendered == 270
    side, main = app.observer_guards["side"].health(), app.observer_guards["webcam"].health()
    assert (side.crashes, side.restarts, side.state) == (1, 1, "running")
    assert (main.crashes, main.restarts) == (0, 0)
    down = [(t, people) for t, state, people in trace if state == "restarting"]
    assert 0.9 <= down[-1][0] - down[0][0] <= 1.1  # restarted after the first back-off, 1 s
    assert all(people >= 1 for _, people in down)  # the other camera still saw the person meanwhile
    assert max(p for t, _, p in trace if 4.0 <= t < 5.0) == 2  # both saw them before …
    # … and after the rebuilt one relearned with the person in view: found at once, where they stood while it
    # learned a still "ghost" for still_to_background_s (1 s) before it is taken into the background
    assert max(p for t, _, p in trace if t >= down[-1][0] + 2.5) == 2
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(errors) == 1 and errors[0].exc_info is not None
    assert "injected crash at t=5.000" in errors[0].getMessage()


class NanContactors:
    """The fault injected: a real observer whose every 3rd observation gets a NaN / inf contactor."""

    def __init__(self, inner: Observer) -> None:
        self.inner = inner
        self.n = 0

    def observe(self, frame: Frame) -> BodyObservation:
        obs = self.inner.observe(frame)
        self.n += 1
        if self.n % 3:
            return obs
        bad = (Contactor(9, "hand", (math.nan, 0.0, 1.0), (0.0, 0.0, 0.0), 0.1),
               Contactor(9, "foot", (0.0, 0.0, 0.1), (math.inf, 0.0, 0.0), 0.1))
        return dataclasses.replace(obs, contactors=obs.contactors + bad)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


def test_in_the_app_nan_contactors_are_dropped_counted_and_never_reach_the_physics(
        monkeypatch: pytest.MonkeyPatch) -> None:
    table = observer_types()
    real = table["webcam"]
    table["webcam"] = ObserverType(real.config, lambda c, cal, s: NanContactors(real.build(c, cal, s)),
                                   real.needs_calibration, real.description)
    monkeypatch.setattr(run_setup, "observer_types", lambda: table)
    cfg = load_config(ROOT / "configs" / "demo.toml")
    cfg = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=160, height=90))
    app = App(cfg, RunOptions(out_dir=None, seed=7, duration_s=5.0, video=False, progress=False))
    finite: list[bool] = []
    contactors: list[int] = []

    def on_frame(snap: Any, obs: BodyObservation, image: Any) -> None:
        finite.append(all(math.isfinite(v) for c in snap.characters
                          for v in (*c.position, *c.orientation, *c.velocity, *c.angular_velocity)))
        contactors.append(sum(c.person == 9 for c in obs.contactors))

    app.on_frame = on_frame
    summary = app.run()
    health = app.observer_guards["webcam"].health()
    assert health.dropped_non_finite == 2 * (summary.sensor_frames // 3) > 0
    assert health.crashes == 0 and max(contactors) == 0  # none got past the guard …
    assert all(finite) and len(finite) == 150  # … and pybullet's bodies stayed finite
    assert summary.pushes > 0  # the real person still pushed
