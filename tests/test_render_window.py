"""Window and kiosk modes on a real X display: a virtual one (Xvfb), when the machine has it
(Debian: apt-get install xvfb); skipped otherwise. Each run is its own process (pyglet cannot mix
headless and window modes in one)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = r"""
import sys, numpy as np
from pyglet import gl
from jostle.bench.render import scene
from render.gl.renderer import Renderer
from jostle.bench.render import scene
from render.gl.renderer import Renderer
from render.keyframes import KeyframeSet

kset = KeyframeSet.load(sys.argv[1])
snap, person = scene(6, 0, 0.0)
with Renderer(320, 180, headless=False, fullscreen=sys.argv[2] == "kiosk") as r:
    grabbed = {}
    flip = r._window.flip
    def grab_then_flip():
        w, h = r._window.get_framebuffer_size()
        buf = (gl.GLubyte * (w * h * 4))()
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, 0)
        gl.glReadBuffer(gl.GL_BACK)
        gl.glReadPixels(0, 0, w, h, gl.GL_RGBA, gl.GL_UNSIGNED_BYTE, buf)
        grabbed["window"] = np.frombuffer(buf, np.uint8).reshape(h, w, 4)[::-1, :, :3]
        flip()
    r._window.flip = grab_then_flip
    frame = r.draw(snap, person, kset)
    win = grabbed["window"]
    h, w = win.shape[:2]
    k = min(w / 320, h / 180)
    dw, dh = int(320 * k), int(180 * k)
    x0, y0 = (w - dw) // 2, (h - dh) // 2
    inner = win[y0:y0 + dh, x0:x0 + dw]
    import cv2
    shown = cv2.resize(inner, (320, 180), interpolation=cv2.INTER_AREA)[..., ::-1]  # RGB on screen -> BGR
    print("size", w, h, "bars", int(win[: max(y0 - 1, 0)].max(initial=0)), "diff", float(np.abs(shown.astype(int) - frame.astype(int)).mean()))
    print("closing", r.should_close)
    r._window.dispatch_event("on_close")
    r.present()
    print("closed", r.should_close)
"""




@pytest.mark.parametrize("mode", ["window", "kiosk"])
def test_a_window_shows_the_frame_and_closes_when_asked(display: str, mode: str) -> None:
    root = Path(__file__).resolve().parent.parent
    env = dict(os.environ, DISPLAY=display)
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(root / "configs" / "keyframes" / "humanoid" / "keyframes.toml"), mode],
        env=env, capture_output=True, text=True, timeout=120, cwd=root,
    )
    assert out.returncode == 0, out.stderr
    lines = dict(line.split(" ", 1) for line in out.stdout.strip().splitlines())
    size = tuple(int(v) for v in lines["size"].split()[:2])
    assert size == ((800, 600) if mode == "kiosk" else (320, 180))  # the kiosk fills the screen
    assert float(lines["size"].split("diff")[1]) < 12  # the window shows the frame draw() returned
    assert lines["closing"] == "False" and lines["closed"] == "True"
