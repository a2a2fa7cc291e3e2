"""Hostile input to the operations side: systemd units, the health file, serial pads.

``jostle service install`` gets config paths with a space, quote, ``$``, ``;``, backslash, a
non-ASCII letter (each must give a unit ``systemd-analyze verify`` accepts) or a newline, and flag
values that try to inject lines (``--display``, ``--run-as``, ``--out``) or name nothing (``--name
'!!!'``), which must each be refused in one line. ``[health] json_path`` naming a ``/dev/full``
twin or a FIFO must leave that node in place. Force pads speaking CSV on a real pty send Python
number syntax (``1_000``), nan, inf, ``1e999`` and int32 extremes, each of which must be said once.
"""

from __future__ import annotations

import json
import shutil
import socket
import struct
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

from jostle.bench.hostile_run import Case, Expect
from jostle.bench.hostile_workspace import REPO, Workspace, is_char_device, is_fifo

Pairs = list[tuple[Case, bool]]
MARK = "HOSTILE_INJECTED"


def _minimal_config(ws: Workspace, path: Path) -> Path:
    """A valid config with absolute paths only, so it can live in any folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'[sensors.webcam]\ntype = "replay"\npath = {json.dumps(str(REPO / "configs/recordings/demo.mcap"))}\n'
                    f'channel = "webcam"\n[render]\nkeyframes = '
                    f'{json.dumps(str(ws.configs / "keyframes/humanoid/keyframes.toml"))}\n')
    return path


def _unit_sound(unit_dir: Path) -> Callable[[int | None], str | None]:
    """A check: no written unit has an injected line, and ``systemd-analyze verify`` finds no fatal
    error in any (skipped where systemd-analyze is missing)."""
    def check(exit_code: int | None) -> str | None:
        for unit in sorted(unit_dir.glob("*.service")):
            text = unit.read_text(errors="replace")
            if any(MARK in ln and not ln.startswith(("ExecStart=", "WorkingDirectory=", "Description=", "#"))
                   for ln in text.splitlines()) or "\nExecStartPre=" in text:
                return f"{unit.name}: a value injected a line"
            tool = shutil.which("systemd-analyze")
            if tool is None:
                continue
            try:
                r = subprocess.run([tool, "verify", str(unit)], capture_output=True, text=True, timeout=20)
            except subprocess.TimeoutExpired:
                return f"{unit.name}: systemd-analyze verify hung"
            bad = [ln for ln in r.stderr.splitlines() if "fatal error" in ln or "not absolute" in ln
                   or "bad unit file setting" in ln or "Invalid" in ln]
            if bad:
                return f"{unit.name}: systemd-analyze: {bad[0][:200]}"
        return None
    return check


def service_cases(ws: Workspace, sample: bool) -> Pairs:
    cases: Pairs = []
    folders = {"space": "with space", "quote": 'with"quote', "dollar": "with$HOME", "semicolon": "with;semi",
               "backslash": "with\\back", "non_ascii": "scène", "newline": "with\nnewline"}
    for name, folder in folders.items():
        cfg = _minimal_config(ws, ws.root / "in" / "svc" / folder / "demo.toml")
        units = ws.out(f"service-path_{name}") / "units"
        units.mkdir(exist_ok=True)
        expect: Expect = "error" if name == "newline" else "ok"
        argv = ("service", "install", str(cfg), "--unit-dir", str(units), "--name", f"p{name}", "--mode", "headless")
        cases.append((Case("service", f"path_{name}", argv, expect, checks=(_unit_sound(units),)),
                      name in ("space", "newline")))
    cfg = _minimal_config(ws, ws.root / "in" / "svc" / "plain" / "demo.toml")
    flags = {"display_injection": ("--display", f":0\nExecStartPre=/bin/touch /tmp/{MARK}"),
             "run_as_injection": ("--run-as", f"nobody\nExecStartPre=/bin/touch /tmp/{MARK}"),
             "out_newline": ("--out", f"/tmp/x\nExecStartPre=/bin/touch /tmp/{MARK}"),
             "name_bang": ("--name", "!!!")}
    for name, flag in flags.items():
        units = ws.out(f"service-{name}") / "units"
        units.mkdir(exist_ok=True)
        argv = ("service", "install", str(cfg), "--unit-dir", str(units), *(("--name", "x") if name != "name_bang"
                                                                            else ()), *flag)
        cases.append((Case("service", name, argv, "error", checks=(_unit_sound(units),)), True))
    return cases


def health_cases(ws: Workspace, sample: bool) -> Pairs:
    """``[health] json_path`` naming a special file: refused or warned, the node left in place."""
    cases: Pairs = []
    targets: list[tuple[str, Path | None, Callable[[Path], str | None]]] = [
        ("dev_full_twin", ws.device_twin("health.full", 7), is_char_device),
        ("fifo", ws.fifo("health.fifo"), is_fifo)]
    demo = (ws.configs / "demo.toml").read_text()
    for name, path, intact in targets:
        if path is None:
            ws.skipped.append(f"health-{name} (mknod refused)")
            continue
        cfg = ws.config(f"health-{name}", demo + f"\n[health]\njson_path = {json.dumps(str(path))}\ninterval_s = 0.1\n")
        argv = ws.run_argv(cfg, f"health-{name}")
        cases.append((Case("health", name, argv, "line", checks=(_still(intact, path),)), True))
    return cases


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


class _RudeClients:
    """Wait (≤ 8 s) for the endpoint on 127.0.0.1:port, then connect ``clients`` times: half reset at
    once (SO_LINGER 0), half send half a request and close before reading. ``connected`` counts the
    connections made; the check fails when there were none (nothing was tested)."""

    def __init__(self, port: int, clients: int = 20) -> None:
        self.port, self.clients, self.connected = port, clients, 0

    def __call__(self) -> None:
        deadline = time.monotonic() + 8.0
        while time.monotonic() < deadline:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.5).close()
                break
            except OSError:
                time.sleep(0.1)
        for i in range(self.clients):
            try:
                c = socket.create_connection(("127.0.0.1", self.port), timeout=0.5)
                self.connected += 1
                if i % 2:
                    c.sendall(b"GET /health HTTP/1.1\r\nHost: 127.0.0.1\r\n")
                c.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                c.close()
            except OSError:
                pass

    def check(self, exit_code: int | None) -> str | None:
        return None if self.connected else f"the endpoint on 127.0.0.1:{self.port} never accepted a client"


def endpoint_cases(ws: Workspace, sample: bool) -> Pairs:
    """The health endpoint (127.0.0.1 only) with clients that reset or leave before reading."""
    port = _free_port()
    demo = (ws.configs / "demo.toml").read_text()
    cfg = ws.config("health-endpoint", demo + f"\n[health]\nhttp_port = {port}\ninterval_s = 0.2\n")
    argv = ws.run_argv(cfg, "health-rude_clients")[:-4] + ("--duration", "3", "--speed", "realtime",
                                                           "--out", str(ws.out("health-rude_clients")))
    rude = _RudeClients(port)
    return [(Case("health", "rude_clients", argv, "ok", during=rude, checks=(rude.check,)), True)]


def _still(intact: Callable[[Path], str | None], path: Path) -> Callable[[int | None], str | None]:
    return lambda exit_code: intact(path)


def pads_cases(ws: Workspace, sample: bool) -> Pairs:
    """CSV pad lines that are numbers only to Python, or out of any sensor's range, on a real pty."""
    good = b"512,512,512,512\n"
    feeds = {"underscore_1_000": b"1_000,512,512,512\n", "underscore_2_2": b"2_2,512,512,512\n",
             "nan": b"nan,512,512,512\n", "inf": b"inf,512,512,512\n", "1e999": b"1e999,512,512,512\n",
             "int32_max": b"2147483647,512,512,512\n", "int32_min": b"-2147483648,512,512,512\n"}
    cases: Pairs = []
    for i, (name, line) in enumerate(feeds.items()):
        cfg = ws.configs / f"pads-{name}.toml"
        text = ('[sensors.pads]\ntype = "pads"\nport = "{pty}"\nframing = "csv"\npads = 4\ntare_samples = 5\n'
                '[observers.pads]\ntype = "pads"\nsensor = "pads"\n'
                "positions = [-2.0,0.0,1.0, -0.7,0.0,1.0, 0.7,0.0,1.0, 2.0,0.0,1.0]\n"
                "directions = [0.0,1.0,0.0, 0.0,1.0,0.0, 0.0,1.0,0.0, 0.0,1.0,0.0]\n"
                '[render]\nkeyframes = "keyframes/humanoid/keyframes.toml"\n')
        out = ws.out(f"pads-{name}")
        argv = ("run", str(cfg), "--headless", "--no-video", "--quiet", "--duration", "1.5", "--out", str(out))
        cases.append((Case("pads", name, argv, "line", pty_config=(cfg, text), pty_feed=good * 20 + line + good * 20,
                           checks=(_frames_read(out / "summary.json"),)), i in (0, 2, 5)))
    return cases


def _frames_read(summary: Path) -> Callable[[int | None], str | None]:
    """A check: a run that went through read pad frames from the pty (else nothing was tested)."""
    def check(exit_code: int | None) -> str | None:
        if exit_code != 0:
            return None
        try:
            frames = json.loads(summary.read_text()).get("sensor_frames", 0)
        except (OSError, ValueError):
            return f"{summary}: missing after a run that exited 0"
        return None if frames else "no pad frame was read from the pty"
    return check
