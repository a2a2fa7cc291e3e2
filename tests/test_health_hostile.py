"""The health report against what is not its own and clients that misbehave, on real files and real
sockets on 127.0.0.1: a device or FIFO at ``json_path`` refused by name and left as it is; clients
that reset or close before reading leave no traceback; the backlog takes a burst of connections;
the ``Server:`` header names no Python version."""

from __future__ import annotations

import json
import logging
import os
import socket
import stat
import struct
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from jostle.health import ErrorRing, Health
from jostle.health_report import LISTEN_BACKLOG, HealthFile, HealthServer
from sim.config import WorldConfig
from sim.world import World


def _report() -> dict[str, Any]:
    return {"status": "ok", "padding": "x" * 400_000}  # big enough that the answer is still being sent


@pytest.mark.parametrize("kind", ["device", "fifo", "symlink"])
def test_a_special_file_at_the_json_path_is_refused_and_left(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, kind: str
) -> None:
    if kind == "device":
        path = Path("/dev/full")
    elif kind == "fifo":
        path = tmp_path / "health.json"
        os.mkfifo(path)
    else:
        target = tmp_path / "elsewhere.txt"
        target.write_text("not ours\n")
        path = tmp_path / "health.json"
        path.symlink_to(target)
    before = os.lstat(path)
    f = HealthFile(path, 1.0, _report)
    with caplog.at_level(logging.WARNING, logger="jostle.health"):
        assert f.write() is False and f.write() is False and f.due(10.0) is False
    lines = [r.getMessage() for r in caplog.records if r.name == "jostle.health"]
    assert len(lines) == 1 and str(path) in lines[0] and "\n" not in lines[0], lines
    assert {"device": "character device", "fifo": "FIFO", "symlink": "symbolic link"}[kind] in lines[0]
    after = os.lstat(path)
    assert (after.st_ino, stat.S_IFMT(after.st_mode)) == (before.st_ino, stat.S_IFMT(before.st_mode))
    if kind == "symlink":
        assert (tmp_path / "elsewhere.txt").read_text() == "not ours\n"
    if kind != "device":
        assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".part")] == []  # no temporary file left


def _get(port: int) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(b"GET /health HTTP/1.0\r\nHost: x\r\n\r\n")
        chunks = []
        while chunk := s.recv(65536):
            chunks.append(chunk)
    return b"".join(chunks)


def _reset(s: socket.socket) -> None:
    s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # close sends RST
    s.close()


def test_clients_that_reset_or_close_early_leave_no_traceback(capfd: pytest.CaptureFixture[str]) -> None:
    with HealthServer(_report, 0) as server:
        port = server.port
        for i in range(20):
            s = socket.create_connection(("127.0.0.1", port), timeout=5)
            if i % 4 == 0:
                _reset(s)  # before sending anything
            elif i % 4 == 1:
                s.sendall(b"GET /health HTTP/1.1\r\n")  # half a request, then gone
                _reset(s)
            elif i % 4 == 2:
                s.sendall(b"GET /health HTTP/1.0\r\n\r\n")
                time.sleep(0.01)
                _reset(s)  # while the answer is being sent
            else:
                s.sendall(b"GET /health HTTP/1.0\r\n\r\n")
                s.shutdown(socket.SHUT_RDWR)
                s.close()
        time.sleep(0.3)
        answer = _get(port)
        assert answer.startswith(b"HTTP/1.0 200") and json.loads(answer.split(b"\r\n\r\n", 1)[1])["status"] == "ok"
    err = capfd.readouterr().err
    assert "Traceback" not in err and "Exception occurred" not in err, err


def test_the_server_header_names_no_python_version() -> None:
    with HealthServer(lambda: {"status": "ok"}, 0) as server:
        head = _get(server.port).split(b"\r\n\r\n", 1)[0].decode()
    server_lines = [line for line in head.split("\r\n") if line.lower().startswith("server:")]
    assert server_lines == ["Server: jostle-health"]
    assert "Python" not in head


def test_a_burst_of_connections_waits_in_the_backlog() -> None:
    server = HealthServer(lambda: {"status": "ok"}, 0)  # listening, not yet accepting
    burst = 60
    assert LISTEN_BACKLOG > burst
    waiting: list[socket.socket] = []
    try:
        for _ in range(burst):  # with socketserver's backlog of 5 the 7th connect times out
            s = socket.create_connection(("127.0.0.1", server.port), timeout=0.5)
            s.sendall(b"GET /health HTTP/1.0\r\n\r\n")
            waiting.append(s)
        server.start()
        for s in waiting:
            s.settimeout(5)
            assert s.recv(12) == b"HTTP/1.0 200"
    finally:
        for s in waiting:
            s.close()
        server.close()


def test_an_observer_that_skips_its_frames_is_a_problem_until_it_observes_again() -> None:
    health = Health(30.0, live=False, stall_s=1.0, errors=ErrorRing())
    observed, bad = 0, 0
    problems = []
    with World(WorldConfig(), np.random.default_rng(0)) as world:
        snap = world.snapshot()
        for i in range(90):  # 3 s at 30 fps: observing for 1 s, skipping for 1.5 s, observing again
            t = i / 30
            if t < 1.0 or t >= 2.5:
                observed += 1
            else:
                bad += 1
            fig = {"state": "running", "observations": observed, "bad_frames": bad,
                   "bad_kinds": ("frame size",) if bad else ()}
            health.update(t, snap, None, {}, observers={"webcam": fig}, wall=t)
            problems.append((t, health.report()["problems"]))
    skipping = [t for t, p in problems if p]
    assert all(p[0].startswith("observer webcam skips its frames (frame size; bad frames ") for t, p in problems if p)
    assert skipping and 2.0 <= skipping[0] <= 2.05 and skipping[-1] < 2.5  # after stall_s of skipping only
    assert health.report()["status"] == "ok"  # observing again
