"""Health figures from a real replay with a real outage, the error ring, the JSON file (atomic) and
the HTTP endpoint (a real socket), and the whole loop serving the same figures everywhere."""

from __future__ import annotations

import dataclasses
import json
import logging
import socket
import threading
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from interaction.types import BodyObservation
from jostle.app import App, RunOptions
from jostle.config import load_config
from jostle.health import ErrorRing, Health
from jostle.health_report import HealthFile, HealthServer
from sensors.clock import SimClock
from sensors.faults import FaultSchedule, FaultySensor
from sensors.recording.info import describe_recording
from sensors.recording.replay import Replay
from sim.config import CharacterSpec, WorldConfig
from sim.world import World

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "configs" / "recordings" / "demo.mcap"
FPS = 30.0


def _world(n: int = 3) -> World:
    world = World(WorldConfig(), np.random.default_rng(0))
    for k in range(n):
        world.add_character(CharacterSpec(), (k - 1.0, 0.0), 0.0, intent="idle")
    return world


def test_figures_follow_a_replay_through_an_outage() -> None:
    rate = next(c.rate_hz for c in describe_recording(DEMO).sensor_channels if c.topic == "webcam")
    clock = SimClock()
    sensor = FaultySensor(Replay(DEMO, clock, channel="webcam"), FaultSchedule(disconnect_at_s=2.0, down_for_s=2.5),
                          clock)
    health = Health(FPS, live=False, stall_s=1.0, errors=ErrorRing())
    assert health.report()["status"] == "starting"
    world = _world()
    reports: dict[float, dict[str, Any]] = {}
    last_read = 0.0  # loop time of the last frame read before the check during the outage
    sensor.open()
    try:
        for k in range(int(5.5 * FPS) + 1):
            now = k / FPS
            clock.advance(now - clock.now())
            while sensor.read(0.0) is not None:
                if now < 4.4:
                    last_read = now
            snap = world.step(None, 1 / FPS)
            health.update(now, snap, BodyObservation(t=now), {"webcam": sensor}, wall=now)
            if k in (int(1.9 * FPS), int(4.4 * FPS), int(5.5 * FPS)):
                reports[round(now, 1)] = health.report()
    finally:
        sensor.close()
        world.close()
    up, down, back = reports[1.9], reports[4.4], reports[5.5]
    assert up["status"] == "ok" and up["problems"] == []
    assert up["sensors"]["webcam"]["state"] == "connected"
    assert up["sensors"]["webcam"]["rate_hz"] == pytest.approx(rate, rel=0.15)
    assert up["fps"] == pytest.approx(FPS, rel=0.05)  # (wall = loop time here)
    assert up["characters"] == {"total": 3, "by_state": {"walk": 3}}
    assert down["status"] == "degraded"
    assert down["sensors"]["webcam"]["state"] == "reconnecting"
    assert any(p.startswith("sensor webcam is reconnecting: webcam: simulated fault") for p in down["problems"])
    assert 1.9 < last_read < 2.0  # (the outage begins at 2 s)
    assert f"no sensor frames for {round(4.4 - last_read, 3):.1f} s" in down["problems"]
    assert down["sensors"]["webcam"]["rate_hz"] == 0.0
    assert back["status"] == "ok" and back["sensors"]["webcam"]["state"] == "connected"
    lost = sensor.status.dropped
    assert lost > 10 and back["dropped"]["sensor_frames"] == lost  # what the outage took, as the sensor counts it
    lines = Health.lines(back)
    assert any(line.startswith("sensor webcam: connected") and f"dropped {lost}" in line for line in lines)


def test_the_error_ring_keeps_the_last_five_and_errors_degrade_the_status() -> None:
    ring = ErrorRing()
    logger = logging.getLogger("jostle.test_health")
    logger.addHandler(ring)
    try:
        logger.warning("only a warning")
        for k in range(7):
            logger.error("observer %d crashed\nwith a second line", k)
    finally:
        logger.removeHandler(ring)
    assert (ring.errors, ring.warnings) == (7, 1)
    assert [r["message"] for r in ring.recent] == [f"observer {k} crashed with a second line" for k in range(2, 7)]
    health = Health(FPS, live=False, errors=ring)
    with _world(1) as world:
        health.update(0.0, world.snapshot(), None, {}, wall=0.0)
    report = health.report()
    assert report["status"] == "degraded" and report["problems"] == ["7 errors logged in the last 60 s"]
    assert report["errors"]["recent"][-1]["level"] == "error"


def test_a_slow_live_loop_counts_late_frames_and_a_low_frame_rate() -> None:
    health = Health(FPS, live=True, errors=ErrorRing())
    with _world(1) as world:
        snap = world.snapshot()
        for k in range(100):  # 10 frames a second where 30 were asked for
            health.update(k * 0.1, snap, None, {}, wall=k * 0.1)
    report = health.report()
    assert report["dropped"]["late_frames"] == 99
    assert report["fps"] == pytest.approx(10.0, rel=0.05)
    assert report["problems"] == ["frame rate 10.0 fps, below half of 30"]


def test_the_json_file_is_replaced_atomically_and_a_failing_disk_never_raises(tmp_path: Path,
                                                                               caplog: pytest.LogCaptureFixture) -> None:
    counter = {"n": 0}

    def report() -> dict[str, Any]:
        counter["n"] += 1
        return {"status": "ok", "n": counter["n"], "padding": "x" * 50_000}

    path = tmp_path / "health" / "health.json"
    f = HealthFile(path, 1.0, report)
    assert f.due(0.0) and not f.due(0.5) and f.due(1.0)
    assert json.loads(path.read_text())["n"] == 2
    seen, bad = [], []
    stop = threading.Event()

    def reader() -> None:
        while not stop.is_set():
            text = path.read_text()
            try:
                seen.append(json.loads(text)["n"])
            except ValueError:
                bad.append(len(text))

    t = threading.Thread(target=reader)
    t.start()
    for _ in range(200):
        f.write()
    stop.set()
    t.join()
    assert len(seen) > 20 and bad == []  # a reader never sees half a file
    assert sorted(p.name for p in path.parent.iterdir()) == ["health.json"]  # no temporary file left behind
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    broken = HealthFile(blocked / "health.json", 1.0, report)
    with caplog.at_level(logging.WARNING, logger="jostle.health"):
        assert broken.write() is False and broken.write() is False
    assert len([r for r in caplog.records if "cannot write" in r.getMessage()]) == 1  # logged once


def _get(url: str) -> tuple[int, dict[str, Any]]:
    try:
        with urllib.request.urlopen(url, timeout=5) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def test_the_http_endpoint_answers_200_when_ok_and_503_when_degraded() -> None:
    state = {"status": "ok", "problems": []}
    with HealthServer(lambda: dict(state), 0) as server:
        assert server._server.server_address[0] == "127.0.0.1"  # local only
        assert _get(server.url) == (200, state)
        state.update(status="degraded", problems=["sensor webcam is reconnecting"])
        code, body = _get(server.url)
        assert code == 503 and body["problems"] == ["sensor webcam is reconnecting"]
        state["status"] = "starting"
        assert _get(server.url)[0] == 503
        assert _get(server.url.replace("/health", "/nothing"))[0] == 404
        port = server.port
    with pytest.raises(OSError), socket.create_connection(("127.0.0.1", port), timeout=1):
        pass  # closed


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_the_loop_serves_the_same_figures_on_file_http_and_overlay(tmp_path: Path) -> None:
    cfg = load_config(ROOT / "configs" / "demo.toml")
    port = _free_port()
    cfg = dataclasses.replace(
        cfg, render=dataclasses.replace(cfg.render, width=320, height=180),
        kiosk=dataclasses.replace(cfg.kiosk, show_diagnostics=True),
        health=dataclasses.replace(cfg.health, json_path=tmp_path / "health.json", http_port=port))
    app = App(cfg, RunOptions(out_dir=None, seed=7, duration_s=2.5, video=False, progress=False))
    got: list[tuple[int, dict[str, Any], list[str]]] = []

    def on_frame(snap, obs, image) -> None:  # type: ignore[no-untyped-def]
        if app.summary.frames_rendered in (10, 70):
            code, body = _get(f"http://127.0.0.1:{port}/health")
            got.append((code, body, Health.lines(app.operations.health.report())))

    app.on_frame = on_frame
    summary = app.run()
    for code, body, overlay in got:
        assert code == (200 if body["status"] == "ok" else 503)
        assert Health.lines(body) == overlay  # the panel shows what the endpoint serves
    assert [body["frames"] for _, body, _ in got] == [10, 70]
    final = json.loads((tmp_path / "health.json").read_text())
    assert final["frames"] == summary.frames_rendered
    assert final["sensors"]["webcam"]["frames"] == summary.sensor_frames
    with pytest.raises(OSError), socket.create_connection(("127.0.0.1", port), timeout=1):
        pass  # the endpoint closes with the run


def test_a_restarting_observer_is_a_problem_and_shows_on_the_panel() -> None:
    health = Health(FPS, live=False, errors=ErrorRing())
    crashed = {"state": "restarting", "crashes": 2, "restarts": 1, "dropped_non_finite": 0,
               "last_error": "ValueError: bad blob"}
    with _world(1) as world:
        health.update(0.0, world.snapshot(), None, {}, observers={"webcam": crashed}, wall=0.0)
        report = health.report()
        assert report["problems"] == ["observer webcam is restarting: ValueError: bad blob"]
        assert "observer webcam: restarting  crashes 2  restarts 1  dropped non-finite 0  bad frames 0" in Health.lines(report)
        health.update(0.1, world.snapshot(), None, {}, observers={"webcam": {**crashed, "state": "running"}},
                      wall=0.1)
    assert health.report()["status"] == "ok"
