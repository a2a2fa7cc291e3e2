"""systemd's notify protocol over real AF_UNIX datagram sockets (a path and the abstract namespace),
the heartbeat's rules, and the main loop on a stalling faulty replay: watchdog pings stop when the
frames stop and come back with them."""

from __future__ import annotations

import dataclasses
import logging
import os
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from jostle.app import App, RunOptions
from jostle.config import SensorEntry, load_config
from jostle.sdnotify import Heartbeat, Notifier, socket_address, watchdog_interval
from sensors.faults import FaultyReplayConfig
from sensors.recording.replay import ReplayConfig

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def listener(tmp_path: Path) -> Iterator[tuple[str, socket.socket]]:
    path = tmp_path / "notify"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(path))
    sock.settimeout(2.0)
    yield str(path), sock
    sock.close()


def _drain(sock: socket.socket) -> list[str]:
    out = []
    sock.setblocking(False)
    try:
        while True:
            out.append(sock.recv(4096).decode())
    except BlockingIOError:
        pass
    finally:
        sock.settimeout(2.0)
    return out


def test_messages_reach_a_socket_path_as_one_datagram_each(listener: tuple[str, socket.socket]) -> None:
    address, sock = listener
    n = Notifier(address)
    assert n.enabled
    assert n.send(READY=1, STATUS="running\nsecond line")
    assert n.send(WATCHDOG=1)
    assert sock.recv(4096) == b"READY=1\nSTATUS=running second line"
    assert sock.recv(4096) == b"WATCHDOG=1"
    n.close()


def test_the_abstract_namespace_is_supported() -> None:
    name = f"jostle-test-{os.getpid()}"
    assert socket_address(f"@{name}") == b"\0" + name.encode()
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind(b"\0" + name.encode())
        sock.settimeout(2.0)
        n = Notifier(f"@{name}")
        assert n.send(READY=1)
        assert sock.recv(4096) == b"READY=1"
        n.close()


def test_without_systemd_nothing_is_sent_and_a_vanished_socket_is_logged_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.delenv("NOTIFY_SOCKET", raising=False)
    assert not Notifier().enabled and Notifier().send(READY=1) is False
    gone = Notifier(str(tmp_path / "nobody-listens"))
    with caplog.at_level(logging.WARNING, logger="jostle.sdnotify"):
        assert gone.send(READY=1) is False and gone.send(WATCHDOG=1) is False
    assert len(caplog.records) == 1 and "nobody-listens" in caplog.records[0].getMessage()


def test_the_watchdog_interval_is_half_of_what_systemd_asks_and_only_for_this_process() -> None:
    assert watchdog_interval({}) is None
    assert watchdog_interval({"WATCHDOG_USEC": "30000000"}) == 15.0
    assert watchdog_interval({"WATCHDOG_USEC": "30000000", "WATCHDOG_PID": str(os.getpid())}) == 15.0
    assert watchdog_interval({"WATCHDOG_USEC": "30000000", "WATCHDOG_PID": "1"}) is None
    assert watchdog_interval({"WATCHDOG_USEC": "0"}) is None
    assert watchdog_interval({"WATCHDOG_USEC": "soon"}) is None


def test_the_heartbeat_pings_only_while_frames_flow_and_the_loop_advances(
    listener: tuple[str, socket.socket],
) -> None:
    address, sock = listener
    wall = [0.0]
    beat = Heartbeat(Notifier(address), interval_s=1.0, stall_s=2.0, wall=lambda: wall[0])
    assert not beat.beat(0.0, None)  # no frame yet
    assert beat.beat(0.1, 0.1)
    wall[0] = 0.5
    assert not beat.beat(0.2, 0.2)  # too soon after the last ping
    wall[0] = 1.5
    assert not beat.beat(0.2, 0.2)  # the loop clock did not move: a hung loop
    assert beat.beat(0.3, 0.2)
    wall[0] = 3.0
    assert not beat.beat(2.5, 0.2) and not beat.flowing  # the newest frame is 2.3 s old
    assert beat.beat(2.6, 2.6)  # frames again
    assert _drain(sock) == ["WATCHDOG=1"] * 3
    assert Heartbeat(Notifier(address), None, 2.0).beat(1.0, 1.0) is False  # systemd asked for no pings


def test_the_loop_stops_feeding_the_watchdog_while_its_only_sensor_stalls(
    listener: tuple[str, socket.socket], monkeypatch: pytest.MonkeyPatch
) -> None:
    address, sock = listener
    monkeypatch.setenv("NOTIFY_SOCKET", address)
    monkeypatch.setenv("WATCHDOG_USEC", "1")  # a ping every frame that may have one
    monkeypatch.delenv("WATCHDOG_PID", raising=False)
    cfg = load_config(ROOT / "configs" / "demo.toml")
    entry = cfg.sensors[0]
    assert isinstance(entry.config, ReplayConfig)
    faulty = FaultyReplayConfig(path=entry.config.path, channel=entry.config.channel,
                                disconnect_at_s=1.0, down_for_s=2.0)
    cfg = dataclasses.replace(cfg, sensors=(SensorEntry(entry.name, "faulty-replay", faulty),),
                              render=dataclasses.replace(cfg.render, width=160, height=90),
                              health=dataclasses.replace(cfg.health, stall_s=0.5))
    app = App(cfg, RunOptions(out_dir=None, seed=7, duration_s=4.0, video=False, progress=False))
    by_frame: list[tuple[float, list[str], int]] = []
    app.on_frame = lambda snap, obs, image: by_frame.append((app.clock.now(), _drain(sock), app.summary.sensor_frames))
    app.run()
    after = _drain(sock)
    messages = [m for _, ms, _ in by_frame for m in ms] + after
    assert messages[0].startswith("READY=1\nSTATUS=")
    assert after and after[-1].startswith("STOPPING=1\nSTATUS=stopping: duration 4 s reached")
    pinged = [t for t, ms, _ in by_frame if "WATCHDOG=1" in ms]
    arrived = [t for (t, _, n), (_, _, before) in zip(by_frame[1:], by_frame[:-1], strict=True) if n > before]
    last = max(t for t in arrived if t < 1.0)  # the last frame before the outage (1.0 to 3.0 s)
    assert 0.9 < last < 1.0 and not [t for t in arrived if 1.0 <= t < 2.99]
    flowing = [t for t, _, _ in by_frame if 0.2 < t <= last + 0.5 + 1e-9]
    starved = [t for t, _, _ in by_frame if last + 0.5 + 1e-9 < t < 2.99]
    assert len(starved) > 30
    assert [t for t in pinged if 0.2 < t < 2.99] == flowing  # every frame while frames flow, none after stall_s
    assert [t for t in pinged if t > 2.99] == [t for t, _, _ in by_frame if t >= min(t for t in arrived if t > 2.99)]
    statuses = [m for m in messages if m.startswith("STATUS=")]
    assert any("degraded" in m and "webcam reconnecting" in m for m in statuses)
