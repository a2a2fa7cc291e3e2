"""The unattended side of a run, kept out of the main loop's body: attract mode, the health figures and
their reports (overlay, JSON file, HTTP), the diagnostics key, and systemd supervision (READY,
WATCHDOG only while frames flow, STATUS, STOPPING).

The loop calls ``start()`` once, then every frame ``frame(...)``, ``keys(...)`` and ``captions(...)``,
and ``close(...)`` at the end. Nothing here can stop the installation: a report that cannot be
written or a supervisor that went away is logged and the show goes on.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from collections.abc import Mapping
from typing import Any

from interaction.types import BodyObservation
from jostle.attract import Attract, Phase
from jostle.config import JostleConfig
from jostle.health import ErrorRing, Health
from jostle.health_report import HealthFile, HealthServer
from jostle.operations_config import Mode
from jostle.sdnotify import Heartbeat, Notifier, watchdog_interval
from render.gl.overlays import Captions
from sensors.base import Sensor
from sim.snapshot import WorldSnapshot
from sim.world import World

log = logging.getLogger("jostle.operations")

STATUS_EVERY_S = 2.0  # systemd STATUS= at most this often
LINES_EVERY_S = 0.25  # the diagnostics panel's text is refreshed at most this often


class Operations:
    """Everything an installation does besides sensing, simulating and drawing (see the module doc).

    ``live``: the loop runs on the wall clock (a low frame rate is then a problem). ``env``: where
    $NOTIFY_SOCKET / $WATCHDOG_USEC are read (the process environment by default).
    """

    def __init__(self, config: JostleConfig, mode: Mode, *, live: bool, env: Mapping[str, str] | None = None) -> None:
        env = os.environ if env is None else env
        kiosk, health = config.kiosk, config.health
        self.kiosk = kiosk
        self.attract = Attract(kiosk.attract_after_s if mode in kiosk.attract_modes else 0.0, kiosk.pulse_period_s)
        self.errors = ErrorRing()
        self.health = Health(config.render.fps, live=live, stall_s=health.stall_s, errors=self.errors)
        self.notifier = Notifier(env.get("NOTIFY_SOCKET") or None)
        self.heartbeat = Heartbeat(self.notifier, watchdog_interval(env), health.stall_s)
        self.show_diagnostics = kiosk.show_diagnostics
        self.exit_requested = False  # the exit keys were pressed
        self.http_port = health.http_port
        self.file = HealthFile(health.json_file, health.interval_s, self.health.report) if health.json_file else None
        self.server: HealthServer | None = None
        self._status_at: float | None = None
        self._status_key: tuple[str, Phase] | None = None
        self._lines: tuple[str, ...] = ()
        self._lines_at: float | None = None
        self._started = False
        self.intent_all: str | None = None  # every character's intent in attract mode (World.step's input)

    def start(self) -> None:
        """Collect warnings and errors, open the HTTP endpoint, tell systemd the installation is up."""
        if self._started:
            return
        self._started = True
        logging.getLogger().addHandler(self.errors)
        if self.http_port:
            try:
                self.server = HealthServer(self.health.report, self.http_port).start()
                log.info("health report on %s", self.server.url)
            except OSError as e:
                log.error("health report: cannot listen on 127.0.0.1:%d: %s", self.http_port, e)
        if self.file is not None:
            self.file.write()
        self.notifier.send(READY=1, STATUS="running: waiting for the first frame")

    def frame(self, now: float, snapshot: WorldSnapshot, observation: BodyObservation | None,
              sensors: Mapping[str, Sensor], world: World, observers: Mapping[str, Any] | None = None) -> None:
        """After the world stepped to loop time ``now``: attract mode, health figures, heartbeat, reports.
        ``observers``: the guarded observers (anything with ``health()`` returning a dataclass)."""
        people = observation.people if observation is not None else 0
        change = self.attract.update(now, people)
        if change is not None:
            self.intent_all = self.kiosk.attract_intent if change.after is Phase.ATTRACT else None
            log.info("%s at %.1f s (%s)", "attract mode" if change.after is Phase.ATTRACT else "play",
                     now, "nobody seen" if change.after is Phase.ATTRACT else f"{people} people seen")
        figures = {name: _fields(g.health()) for name, g in (observers or {}).items()
                   if callable(getattr(g, "health", None))}
        self.health.update(now, snapshot, observation, sensors, phase=str(self.attract.phase),
                           counters=_fields(world.counters), observers=figures)
        self.heartbeat.beat(now, self.health.newest_frame_t)
        self.health.set_watchdog(self.heartbeat.flowing, self.heartbeat.pings)
        wall = time.monotonic()
        if self.file is not None:
            self.file.due(wall)
        if self.notifier.enabled:
            key = (self.health.status, self.attract.phase)  # at once when either changes, else now and then
            if key != self._status_key or self._status_at is None or wall - self._status_at >= STATUS_EVERY_S:
                self._status_at, self._status_key = wall, key
                self.notifier.send(STATUS=self.health.status_line())

    def keys(self, pressed: tuple[str, ...]) -> None:
        """Key combinations pressed in the window: the diagnostics key toggles the panel."""
        for combo in pressed:
            if combo == self.kiosk.diagnostics_key:
                self.show_diagnostics = not self.show_diagnostics
                self._lines_at = None
            elif combo == self.kiosk.exit_keys:
                self.exit_requested = True
                log.info("exit keys (%s) pressed", combo)

    def captions(self, now: float) -> Captions | None:
        """What to draw over the scene at loop time ``now`` (None: nothing)."""
        strength = self.attract.strength(now) if self.kiosk.call_to_action else 0.0
        lines: tuple[str, ...] = ()
        if self.show_diagnostics:
            wall = time.monotonic()
            if self._lines_at is None or wall - self._lines_at >= LINES_EVERY_S:
                self._lines_at = wall
                self._lines = tuple(Health.lines(self.health.report()))
            lines = self._lines
        if strength <= 0.0 and not lines:
            return None
        return Captions(self.kiosk.call_to_action, strength, lines)

    def close(self, reason: str = "") -> None:
        """The run ends: a last report, STOPPING=1, the endpoint and the log handler go."""
        if not self._started:
            return
        self._started = False
        self.notifier.send(STOPPING=1, STATUS=f"stopping: {reason or 'done'}")
        if self.file is not None:
            self.file.write()
        if self.server is not None:
            self.server.close()
            self.server = None
        logging.getLogger().removeHandler(self.errors)
        self.notifier.close()


def _fields(record: Any) -> dict[str, Any]:
    """A flat dataclass's fields by name (``dataclasses.asdict`` deep-copies: ~20× slower per frame)."""
    return {f.name: getattr(record, f.name) for f in dataclasses.fields(record)}
