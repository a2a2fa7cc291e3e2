"""The installation's health figures, in one object the main loop updates every frame.

The diagnostics overlay (``Health.lines``), the JSON file and the HTTP endpoint
(``jostle.health_report``) and systemd's STATUS line (``Health.status_line``) all read the same
:class:`Health`, so they always agree. Figures: frame rate, each sensor's state and frame rate,
people seen, characters by state, dropped frames, the world's repair counters, recent warnings and
errors (from :class:`ErrorRing`, a logging handler), attract/play, and whether the watchdog is fed.

Status: ``"starting"`` before the first frame, ``"ok"``, or ``"degraded"`` with the problems listed
(a sensor not connected, no sensor frames for ``stall_s``, an observer that skipped frames and
observed none for ``stall_s``, errors logged in the last minute, the frame rate below half its
target on a live display).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import Counter, deque
from collections.abc import Mapping
from datetime import UTC, datetime
from typing import Any

from interaction.types import BodyObservation
from sensors.base import Sensor, SensorState
from sim.snapshot import WorldSnapshot

ERROR_WINDOW_S = 60.0  # errors logged this recently make the status "degraded"
RATE_WINDOW_S = 2.0  # rates are measured over about this long
_OK_STATES = (SensorState.CONNECTED, SensorState.ENDED)


def _iso(wall: float) -> str:
    return datetime.fromtimestamp(wall, UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


class ErrorRing(logging.Handler):
    """Keeps the last ``size`` warnings and errors logged (one line each) and counts them all."""

    def __init__(self, size: int = 5) -> None:
        super().__init__(level=logging.WARNING)
        self.recent: deque[dict[str, Any]] = deque(maxlen=size)
        self.errors = 0
        self.warnings = 0
        self.error_times: deque[float] = deque(maxlen=1000)  # time.time() of recent ERROR records

    def emit(self, record: logging.LogRecord) -> None:
        try:
            message = record.getMessage()
        except Exception:  # a bad format string must not break the logger
            message = str(record.msg)
        line = " ".join(message.split())[:240]
        if record.exc_info and record.exc_info[1] is not None:
            line = f"{line} ({type(record.exc_info[1]).__name__}: {record.exc_info[1]})"[:300]
        if record.levelno >= logging.ERROR:
            self.errors += 1
            self.error_times.append(record.created)
        else:
            self.warnings += 1
        self.recent.append({"time": _iso(record.created), "level": record.levelname.lower(),
                            "logger": record.name, "message": line})

    def errors_since(self, wall: float) -> int:
        with self.lock or threading.Lock():  # (emit runs under the handler's lock, from any thread)
            return sum(1 for t in self.error_times if t >= wall)

    def snapshot(self) -> dict[str, Any]:
        """Counts and the recent records, copied under the handler's lock."""
        with self.lock or threading.Lock():
            return {"errors": self.errors, "warnings": self.warnings, "recent": list(self.recent)}


class RateWindow:
    """Events per second from a running count sampled at times ``t`` (kept for about ``window_s``)."""

    def __init__(self, window_s: float = RATE_WINDOW_S) -> None:
        self.window_s = window_s
        self._samples: deque[tuple[float, int]] = deque()

    def add(self, t: float, count: int) -> None:
        s = self._samples
        if s and t - s[-1][0] < self.window_s / 8:  # enough resolution; keep the deque short
            return
        s.append((t, count))
        while len(s) > 2 and t - s[1][0] >= self.window_s:
            s.popleft()

    def rate(self, t: float, count: int) -> float:
        s = self._samples
        if not s or t - s[0][0] <= 0:
            return 0.0
        return max(0.0, (count - s[0][1]) / (t - s[0][0]))


class Health:
    """What the loop knows about itself. ``update`` once per frame (loop thread); every reader
    (``report``, ``lines``, ``status_line``) may run on another thread.

    ``target_fps``: the render rate asked for; ``live``: frames are paced by the wall clock (a
    window or kiosk, or a live sensor), so a low frame rate is a problem; ``stall_s``: no sensor frame
    for this long (loop time) counts as stalled.
    """

    def __init__(self, target_fps: float, *, live: bool, stall_s: float = 5.0,
                 errors: ErrorRing | None = None) -> None:
        self.target_fps, self.live, self.stall_s = target_fps, live, stall_s
        self.errors = errors or ErrorRing()
        self._lock = threading.Lock()
        self._wall0 = time.time()
        self._fps = RateWindow()
        self._rates: dict[str, RateWindow] = {}
        self._seen_frames: dict[str, int] = {}
        self.newest_frame_t: float | None = None  # loop time at which any sensor last delivered
        self._newest: dict[str, float] = {}
        self._sensors: dict[str, dict[str, Any]] = {}
        self._frames = 0
        self._late = 0
        self._dropped_sim = 0.0
        self._last_now: float | None = None
        self._t_start: float | None = None
        self._now = 0.0
        self._fps_value = 0.0
        self._people = 0
        self._states: dict[str, int] = {}
        self._characters = 0
        self._phase = "play"
        self._counters: dict[str, int] = {}
        self._observers: dict[str, dict[str, Any]] = {}
        self._changed: dict[tuple[str, str], float] = {}  # (observer, "observations" | "bad_frames") → loop time
        self._watchdog: dict[str, Any] = {"flowing": False, "pings": 0}

    # ------------------------------------------------------------------ the loop's side
    def update(self, now: float, snapshot: WorldSnapshot, observation: BodyObservation | None,
               sensors: Mapping[str, Sensor], *, phase: str = "play", counters: Mapping[str, int] | None = None,
               observers: Mapping[str, Mapping[str, Any]] | None = None, wall: float | None = None) -> None:
        """One frame: loop time ``now``, what the world and the sensors look like after it.
        ``observers``: per guarded observer its figures (``state``, ``crashes``, ``restarts``, …)."""
        wall = time.perf_counter() if wall is None else wall
        statuses = {name: s.status for name, s in sensors.items()}
        states = Counter(str(c.state) for c in snapshot.characters)
        with self._lock:
            if self._last_now is not None and self.live and now - self._last_now > 1.5 / self.target_fps:
                self._late += 1  # a live loop fell more than half a frame behind
            self._last_now = self._now = now
            if self._t_start is None:
                self._t_start = now
            self._frames += 1
            self._fps.add(wall, self._frames)
            self._fps_value = self._fps.rate(wall, self._frames)
            self._dropped_sim += snapshot.dropped_time
            self._people = observation.people if observation is not None else 0
            self._states = dict(sorted(states.items()))
            self._characters = len(snapshot.characters)
            self._phase = phase
            if counters is not None:
                self._counters = dict(counters)
            if observers is not None:
                for k, v in observers.items():
                    self._note_skips(k, now, v)
                self._observers = {k: dict(v) for k, v in observers.items()}
            for name, st in statuses.items():
                if st.frames != self._seen_frames.get(name, 0):  # frames arrived during this frame
                    self._newest[name] = now
                    self.newest_frame_t = now
                    self._seen_frames[name] = st.frames
                window = self._rates.setdefault(name, RateWindow())
                window.add(now, st.frames)
                age = now - self._newest[name] if name in self._newest else None
                self._sensors[name] = {
                    "state": str(st.state), "reason": st.reason, "frames": st.frames,
                    "rate_hz": round(window.rate(now, st.frames), 2), "dropped": st.dropped, "bad": st.bad,
                    "last_frame_age_s": None if age is None else round(age, 3),
                }

    def _note_skips(self, name: str, now: float, figures: Mapping[str, Any]) -> None:
        """When an observer last observed a frame and last skipped one (loop time)."""
        before = self._observers.get(name, {})
        for key in ("observations", "bad_frames"):
            if figures.get(key, 0) != before.get(key, 0) or (name, key) not in self._changed:
                self._changed[(name, key)] = now if figures.get(key, 0) else -math.inf

    def set_watchdog(self, flowing: bool, pings: int) -> None:
        with self._lock:
            self._watchdog = {"flowing": flowing, "pings": pings}

    # ------------------------------------------------------------------ readers
    def problems(self) -> list[str]:
        with self._lock:
            return self._problems()

    def _problems(self) -> list[str]:
        out = []
        for name, s in self._sensors.items():
            if s["state"] not in _OK_STATES:
                out.append(f"sensor {name} is {s['state']}" + (f": {s['reason']}" if s["reason"] else ""))
        for name, o in self._observers.items():
            if o.get("state", "running") != "running":
                out.append(f"observer {name} is {o['state']}" + (f": {o['last_error']}" if o.get("last_error") else ""))
            elif (self._now - self._changed.get((name, "bad_frames"), -math.inf) <= self.stall_s
                  and self._now - self._changed.get((name, "observations"), -math.inf) > self.stall_s):
                kinds = ", ".join(o.get("bad_kinds", ())) or "bad data"
                out.append(f"observer {name} skips its frames ({kinds}; bad frames {o.get('bad_frames', 0)})")
        ended = bool(self._sensors) and all(s["state"] == SensorState.ENDED for s in self._sensors.values())
        since = self.newest_frame_t if self.newest_frame_t is not None else self._t_start
        waited = self._now - (self._now if since is None else since)
        if self._sensors and not ended and waited > self.stall_s + 1e-9:
            out.append(f"no sensor frames for {waited:.1f} s")
        recent = self.errors.errors_since(time.time() - ERROR_WINDOW_S)
        if recent:
            out.append(f"{recent} error{'s' if recent > 1 else ''} logged in the last {ERROR_WINDOW_S:g} s")
        fps = self._fps_value
        if self.live and self._frames > 2 * self.target_fps and fps < 0.5 * self.target_fps:
            out.append(f"frame rate {fps:.1f} fps, below half of {self.target_fps:g}")
        return out

    @property
    def status(self) -> str:
        """"starting", "ok" or "degraded" (as in the report)."""
        with self._lock:
            return "starting" if self._frames == 0 else ("degraded" if self._problems() else "ok")

    def report(self) -> dict[str, Any]:
        """Every figure as a JSON-ready dict (``status`` "starting" | "ok" | "degraded")."""
        with self._lock:
            problems = self._problems()
            status = "starting" if self._frames == 0 else ("degraded" if problems else "ok")
            wall = time.time()
            sensor_dropped = sum(int(s["dropped"]) for s in self._sensors.values())
            return {
                "status": status,
                "problems": problems,
                "time": _iso(wall),
                "uptime_s": round(wall - self._wall0, 1),
                "loop_t": round(self._now, 3),
                "frames": self._frames,
                "fps": round(self._fps_value, 2),
                "target_fps": self.target_fps,
                "mode": self._phase,
                "people": self._people,
                "characters": {"total": self._characters, "by_state": dict(self._states)},
                "sensors": {k: dict(v) for k, v in self._sensors.items()},
                "observers": {k: dict(v) for k, v in self._observers.items()},
                "dropped": {"sensor_frames": sensor_dropped, "late_frames": self._late,
                            "sim_seconds": round(self._dropped_sim, 3)},
                "world": dict(self._counters),
                "errors": self.errors.snapshot(),
                "watchdog": dict(self._watchdog),
            }

    @staticmethod
    def lines(report: Mapping[str, Any]) -> list[str]:
        """The diagnostics overlay's text, from a ``report()`` (ASCII only: the overlay font has no more)."""
        up = int(report["uptime_s"])
        head = (f"jostle {report['status'].upper()}  {report['fps']:.1f} fps (target {report['target_fps']:g})  "
                f"{report['mode']}  up {up // 3600}h{up % 3600 // 60:02d}m  watchdog "
                f"{'fed' if report['watchdog']['flowing'] else 'STARVED'}")
        chars = report["characters"]
        by_state = "  ".join(f"{k} {v}" for k, v in chars["by_state"].items())
        out = [head, f"people {report['people']}   characters {chars['total']}: {by_state or '-'}"]
        for name, s in report["sensors"].items():
            age = s["last_frame_age_s"]
            out.append(f"sensor {name}: {s['state']}  {s['rate_hz']:.1f} Hz  frames {s['frames']}  "
                       f"dropped {s['dropped']}  bad {s['bad']}  last {'-' if age is None else f'{age:.1f} s'} ago")
        for name, o in report.get("observers", {}).items():
            out.append(f"observer {name}: {o.get('state', '?')}  crashes {o.get('crashes', 0)}  "
                       f"restarts {o.get('restarts', 0)}  dropped non-finite {o.get('dropped_non_finite', 0)}  "
                       f"bad frames {o.get('bad_frames', 0)}")
        d = report["dropped"]
        out.append(f"dropped: sensor frames {d['sensor_frames']}  late frames {d['late_frames']}  "
                   f"sim {d['sim_seconds']:.2f} s")
        repairs = "  ".join(f"{k} {v}" for k, v in report["world"].items() if v)
        if repairs:
            out.append(f"world repairs: {repairs}")
        for p in report["problems"]:
            out.append(f"! {p}")
        e = report["errors"]
        out.append(f"errors {e['errors']}  warnings {e['warnings']}" + (":" if e["recent"] else ""))
        for r in e["recent"]:
            out.append(f"  {r['time'][11:19]} {r['level']} {r['logger']}: {r['message']}"[:150])
        return [line.encode("ascii", "replace").decode("ascii") for line in out]

    def status_line(self) -> str:
        """A short summary for systemd's STATUS= (shown by ``systemctl status``)."""
        r = self.report()
        sensors = ", ".join(f"{k} {v['state']} {v['rate_hz']:.0f} Hz" for k, v in r["sensors"].items())
        line = f"{r['status']}: {r['mode']}, {r['fps']:.0f} fps, {r['people']} people, {sensors}"
        if r["problems"]:
            line += f"; {r['problems'][0]}"
        return line[:200]
