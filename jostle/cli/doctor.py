"""``jostle doctor``: what this machine offers jostle, each check bounded in time (never hangs)."""

from __future__ import annotations

import glob
import json
import shutil
import subprocess
import sys
from dataclasses import asdict, dataclass
from importlib import metadata

PACKAGES = ("numpy", "pybullet", "pyglet", "opencv-contrib-python-headless", "depthai", "pyserial", "mcap")

_GL_PROBE = """
import pyglet
pyglet.options['headless'] = True
pyglet.options['debug_gl'] = False
import pyglet.window
from pyglet import gl
w = pyglet.window.Window(width=16, height=16, visible=False,
    config=gl.Config(red_size=8, green_size=8, blue_size=8, alpha_size=8, double_buffer=False))
print(gl.gl_info.get_renderer(), '| OpenGL', '.'.join(map(str, gl.gl_info.get_version())))
w.close()
"""

_DAI_PROBE = """
import depthai as dai
devs = dai.Device.getAllAvailableDevices()
print("JOSTLE-DEVICES", len(devs))
for d in devs:
    print("JOSTLE-DEVICE", d.getDeviceId(), d.state)
"""

_CAM_PROBE = """
import sys, cv2
cap = cv2.VideoCapture(sys.argv[1])
ok = cap.isOpened() and cap.read()[0]
print('ok' if ok else 'no-frames')
"""


@dataclass(frozen=True)
class Check:
    name: str
    status: str  # ok | warn | fail
    detail: str
    advice: str = ""


def _probe(code: str, *args: str, timeout: float) -> tuple[bool, str]:
    try:
        r = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return False, f"no answer within {timeout:g} s"
    if r.returncode != 0:
        last = (r.stderr.strip().splitlines() or ["failed"])[-1]
        return False, last[:200]
    return True, r.stdout.strip()


def run_checks(timeout: float = 15.0) -> list[Check]:
    checks: list[Check] = []
    checks.append(Check("python", "ok" if sys.version_info >= (3, 11) else "fail", sys.version.split()[0]))
    for pkg in PACKAGES:
        try:
            checks.append(Check(f"package {pkg}", "ok", metadata.version(pkg)))
        except metadata.PackageNotFoundError:
            checks.append(Check(f"package {pkg}", "fail", "not installed", "run: make setup"))

    ok, out = _probe(_GL_PROBE, timeout=timeout)
    checks.append(
        Check("headless OpenGL (EGL)", "ok" if ok else "fail", out,
              "" if ok else "install Debian packages: apt-get install libegl1 libgl1 libgl1-mesa-dri")
    )

    videos = sorted(glob.glob("/dev/video*"))
    if not videos:
        checks.append(Check("cameras", "warn", "no /dev/video* devices", "plug in a webcam for live runs"))
    for dev in videos[:4]:
        ok, out = _probe(_CAM_PROBE, dev, timeout=8.0)
        checks.append(Check(f"camera {dev}", "ok" if ok and out == "ok" else "warn", out,
                            "" if ok and out == "ok" else "is another program using it? (fuser " + dev + ")"))

    try:
        from serial.tools import list_ports

        ports = [p.device for p in list_ports.comports()]
        checks.append(Check("serial ports", "ok" if ports else "warn", ", ".join(ports) or "none found",
                            "" if ports else "force pads connect over USB serial (/dev/ttyUSB*, /dev/ttyACM*)"))
    except Exception as e:  # pyserial missing or broken: say so, go on
        checks.append(Check("serial ports", "fail", f"{type(e).__name__}: {e}", "run: make setup"))

    ok, out = _probe(_DAI_PROBE, timeout=timeout)
    if ok:
        lines = out.splitlines()
        counts = [ln.split()[1] for ln in lines if ln.startswith("JOSTLE-DEVICES ")]
        n = int(counts[0]) if counts and counts[0].isdigit() else 0
        found = "; ".join(ln.removeprefix("JOSTLE-DEVICE ") for ln in lines if ln.startswith("JOSTLE-DEVICE "))
        checks.append(Check("DepthAI devices", "ok" if n else "warn", found if n else "none found",
                            "" if n else "plug in an OAK camera (USB3 cable, or PoE on the same network)"))
    else:
        checks.append(Check("DepthAI devices", "warn", out, "is depthai installed? (make setup)"))

    free = shutil.disk_usage(".").free / 1e9
    checks.append(Check("disk space here", "ok" if free > 1 else "warn", f"{free:.1f} GB free",
                        "" if free > 1 else "recordings and videos need space"))
    return checks


def print_checks(checks: list[Check], as_json: bool) -> int:
    if as_json:
        print(json.dumps([asdict(c) for c in checks], indent=2))
    else:
        mark = {"ok": "  ok ", "warn": " warn", "fail": " FAIL"}
        for c in checks:
            line = f"{mark[c.status]}  {c.name}: {c.detail}"
            if c.advice:
                line += f"  → {c.advice}"
            print(line)
    return 1 if any(c.status == "fail" for c in checks) else 0
