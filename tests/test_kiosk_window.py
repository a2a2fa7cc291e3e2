"""Kiosk mode on a real X server (Xvfb; skipped when it is not installed): real key events through
the XTEST extension, the cursor image read back through XFIXES. Esc does not close a kiosk, the
configured combination does, F1 reaches the loop, the cursor is hidden over the kiosk; and a whole
`jostle run --kiosk` stops on the exit keys with the exit status that tells systemd not to restart it."""

from __future__ import annotations

import ctypes
import ctypes.util
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from jostle.cli.service_unit import OPERATOR_EXIT

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, sys, time
from jostle.bench.render import scene
from render.gl.renderer import Renderer
from jostle.bench.render import scene
from render.gl.renderer import Renderer
from render.keyframes import KeyframeSet

kset = KeyframeSet.load(sys.argv[1])
snap, person = scene(3, 0, 0.0)
with Renderer(320, 180, headless=False, fullscreen=sys.argv[2] == "kiosk", exit_keys="ctrl+shift+q") as r:
    r.draw(snap, person, kset)
    x, y = r._window.get_location()
    print(json.dumps({"ready": True, "x": x, "y": y}), flush=True)
    for line in sys.stdin:
        keys = []
        for _ in range(8):  # pump the window's events (draw() presents and dispatches them)
            r.draw(snap, person, kset)
            keys += r.take_keys()
            time.sleep(0.02)
        print(json.dumps({"should_close": r.should_close, "keys": keys}), flush=True)
"""


class _CursorImage(ctypes.Structure):
    _fields_ = [("x", ctypes.c_short), ("y", ctypes.c_short), ("width", ctypes.c_ushort),
                ("height", ctypes.c_ushort), ("xhot", ctypes.c_ushort), ("yhot", ctypes.c_ushort),
                ("cursor_serial", ctypes.c_ulong), ("pixels", ctypes.POINTER(ctypes.c_ulong)),
                ("atom", ctypes.c_ulong), ("name", ctypes.c_char_p)]


class XClient:
    """A second X client that presses keys (XTEST) and reads the cursor image (XFIXES)."""

    def __init__(self, display: str) -> None:
        names = {lib: ctypes.util.find_library(lib) for lib in ("X11", "Xtst", "Xfixes")}
        if not all(names.values()):
            pytest.skip(f"X client libraries missing: {[k for k, v in names.items() if not v]}")
        self.x11 = ctypes.CDLL(names["X11"])
        self.xtst = ctypes.CDLL(names["Xtst"])
        self.xfixes = ctypes.CDLL(names["Xfixes"])
        self.x11.XOpenDisplay.restype = ctypes.c_void_p
        self.x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
        self.dpy = self.x11.XOpenDisplay(display.encode())
        if not self.dpy:
            pytest.skip(f"cannot open X display {display}")
        self.x11.XStringToKeysym.restype = ctypes.c_ulong
        self.x11.XStringToKeysym.argtypes = [ctypes.c_char_p]
        self.x11.XKeysymToKeycode.restype = ctypes.c_ubyte
        self.x11.XKeysymToKeycode.argtypes = [ctypes.c_void_p, ctypes.c_ulong]
        self.x11.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]
        self.x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
        self.xtst.XTestFakeKeyEvent.argtypes = [ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_ulong]
        self.xtst.XTestFakeMotionEvent.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                                   ctypes.c_ulong]
        self.xfixes.XFixesGetCursorImage.restype = ctypes.POINTER(_CursorImage)
        self.xfixes.XFixesGetCursorImage.argtypes = [ctypes.c_void_p]

    def press(self, *keysyms: str) -> None:
        """Hold each key in turn, then release them in reverse (a combination)."""
        codes = [self.x11.XKeysymToKeycode(self.dpy, self.x11.XStringToKeysym(k.encode())) for k in keysyms]
        assert all(codes), keysyms
        for c in codes:
            self.xtst.XTestFakeKeyEvent(self.dpy, c, 1, 0)
        for c in reversed(codes):
            self.xtst.XTestFakeKeyEvent(self.dpy, c, 0, 0)
        self.x11.XSync(self.dpy, 0)

    def move(self, x: int, y: int) -> None:
        self.xtst.XTestFakeMotionEvent(self.dpy, -1, x, y, 0)
        self.x11.XSync(self.dpy, 0)

    def cursor_alpha(self) -> int:
        """The highest alpha of the cursor image shown now (0: an invisible cursor)."""
        img = self.xfixes.XFixesGetCursorImage(self.dpy).contents
        n = img.width * img.height
        return max(((img.pixels[i] >> 24) & 0xFF) for i in range(n)) if n else 0

    def close(self) -> None:
        self.x11.XCloseDisplay(self.dpy)




def _child(display: str, mode: str) -> tuple[subprocess.Popen[str], dict[str, Any]]:
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(ROOT / "configs/keyframes/humanoid/keyframes.toml"), mode],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
        env=dict(os.environ, DISPLAY=display))
    assert proc.stdout is not None
    first = proc.stdout.readline()
    if not first:
        raise AssertionError(proc.stderr.read() if proc.stderr else "child died")
    return proc, json.loads(first)


def _pump(proc: subprocess.Popen[str]) -> dict[str, Any]:
    assert proc.stdin is not None and proc.stdout is not None
    proc.stdin.write("pump\n")
    proc.stdin.flush()
    return dict(json.loads(proc.stdout.readline()))


def test_a_kiosk_ignores_esc_hides_the_cursor_and_closes_on_its_exit_keys(display: str) -> None:
    x = XClient(display)
    proc, ready = _child(display, "kiosk")
    try:
        x.move(400, 300)
        assert _pump(proc) == {"should_close": False, "keys": []}
        assert x.cursor_alpha() == 0  # over the kiosk the cursor is invisible
        x.press("Escape")
        assert _pump(proc) == {"should_close": False, "keys": ["escape"]}  # a visitor's Esc does nothing
        x.press("F1")
        x.press("Control_L", "q")  # not the combination
        assert _pump(proc) == {"should_close": False, "keys": ["f1", "ctrl+q"]}
        x.press("Control_L", "Shift_L", "q")
        assert _pump(proc) == {"should_close": True, "keys": ["ctrl+shift+q"]}
    finally:
        proc.kill()
        proc.wait(timeout=10)
        x.close()


def test_a_desktop_window_keeps_its_cursor_and_closes_on_esc(display: str) -> None:
    x = XClient(display)
    proc, ready = _child(display, "window")
    try:
        x.move(ready["x"] + 100, ready["y"] + 90)
        _pump(proc)
        assert x.cursor_alpha() > 0
        x.press("Escape")
        assert _pump(proc)["should_close"] is True
    finally:
        proc.kill()
        proc.wait(timeout=10)
        x.close()


def test_jostle_run_kiosk_stops_on_the_exit_keys_with_the_operator_exit_status(display: str, tmp_path: Path) -> None:
    config = tmp_path / "kiosk.toml"
    text = (ROOT / "configs" / "demo.toml").read_text()
    for folder in ("recordings", "characters", "keyframes"):
        text = text.replace(f'"{folder}/', f'"{ROOT}/configs/{folder}/')
    health = tmp_path / "health.json"
    config.write_text(text.replace("width = 1280\nheight = 720", "width = 320\nheight = 180")
                      + f'\n[health]\njson_path = "{health}"\ninterval_s = 0.2\n')
    x = XClient(display)
    proc = subprocess.Popen(
        [str(Path(os.path.abspath(sys.executable)).parent / "jostle"), "run", str(config), "--kiosk", "--duration",
         "60", "--no-video", "--quiet", "--out", str(tmp_path / "out")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ, DISPLAY=display))
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if health.exists() and json.loads(health.read_text())["frames"] >= 10:
                break
            time.sleep(0.2)
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
        x.move(400, 300)
        x.press("Escape")
        time.sleep(1.0)
        assert proc.poll() is None  # still running
        x.press("Control_L", "Shift_L", "q")
        rc = proc.wait(timeout=30)
        assert rc == OPERATOR_EXIT
        summary = json.loads((tmp_path / "out" / "summary.json").read_text())
        assert summary["stopped_because"] == "window closed" and summary["sim_seconds"] < 50
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        x.close()
