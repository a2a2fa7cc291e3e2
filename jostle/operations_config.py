"""The ``[kiosk]`` and ``[health]`` tables of an installation config: how an unattended installation
behaves (exit keys, attract mode, diagnostics overlay) and how it reports on itself (health file,
local HTTP endpoint, systemd watchdog)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

MODIFIERS = ("ctrl", "shift", "alt", "super")
_NAMED_KEYS = ("escape", "space", "tab", "return", "enter", "backspace", "delete", "insert", "home", "end",
               "pageup", "pagedown", "left", "right", "up", "down", "pause", "scrolllock", "print")
_KEY = re.compile(r"^(?:[a-z0-9]|f(?:[1-9]|1[0-9]|2[0-4])|" + "|".join(_NAMED_KEYS) + r")$")
Mode = Literal["headless", "window", "kiosk"]


def parse_combo(text: str) -> str:
    """A key combination like "Ctrl+Shift+Q" in canonical form ("ctrl+shift+q": modifiers in the
    order ctrl, shift, alt, super, then one key). ValueError (without a field name) when malformed."""
    parts = [p.strip().lower() for p in text.split("+")]
    if not parts or any(not p for p in parts):
        raise ValueError(f"expected keys joined by '+', like 'ctrl+shift+q', got {text!r}")
    *mods, key = parts
    unknown = [m for m in mods if m not in MODIFIERS]
    if unknown or len(set(mods)) != len(mods):
        raise ValueError(f"expected modifiers from {', '.join(MODIFIERS)} (each once), got {text!r}")
    key = {"esc": "escape", "enter": "return"}.get(key, key)
    if not _KEY.match(key):
        raise ValueError(f"expected a letter, digit, f1..f24 or a named key ({', '.join(_NAMED_KEYS)}), "
                         f"got {key!r} in {text!r}")
    return "+".join([*(m for m in MODIFIERS if m in mods), key])


def _seconds(name: str, value: float, *, zero_ok: bool) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and (value >= 0 if zero_ok else value > 0)):
        raise ValueError(f"{name}: expected seconds {'≥ 0' if zero_ok else '> 0'}, got {value!r}")


@dataclass(frozen=True)
class KioskConfig:
    """``[kiosk]``: exit keys, attract mode and the diagnostics overlay."""

    exit_keys: str = "ctrl+shift+q"  # the only way out from the keyboard in kiosk mode (Esc does nothing)
    diagnostics_key: str = "f1"  # shows/hides the diagnostics overlay (window and kiosk)
    show_diagnostics: bool = False  # the overlay's state at start
    attract_after_s: float = 20.0  # nobody seen this long → attract mode (0 = never)
    attract_intent: Literal["idle", "wander", "approach", "flee", "follow"] = "wander"
    attract_modes: tuple[Mode, ...] = ("kiosk",)  # run modes in which attract mode is on
    call_to_action: str = "Push them!"  # drawn, pulsing, in attract mode ("" = nothing drawn)
    pulse_period_s: float = 2.0

    def __post_init__(self) -> None:
        for name in ("exit_keys", "diagnostics_key"):
            try:
                object.__setattr__(self, name, parse_combo(getattr(self, name)))
            except ValueError as e:
                raise ValueError(f"{name}: {e}") from None
        if self.exit_keys == self.diagnostics_key:
            raise ValueError(f"diagnostics_key: expected a key other than exit_keys, got {self.diagnostics_key!r}")
        if self.exit_keys in ("escape", "q", "f4"):
            raise ValueError(f"exit_keys: expected a combination a visitor cannot press by chance, "
                             f"like 'ctrl+shift+q', got {self.exit_keys!r}")
        _seconds("attract_after_s", self.attract_after_s, zero_ok=True)
        _seconds("pulse_period_s", self.pulse_period_s, zero_ok=False)
        if not (self.call_to_action.isascii() and self.call_to_action.isprintable() and len(self.call_to_action) <= 60):
            raise ValueError(f"call_to_action: expected up to 60 printable ASCII characters (the overlay font "
                             f"has no others), got {self.call_to_action!r}")


@dataclass(frozen=True)
class HealthConfig:
    """``[health]``: the health report and systemd supervision."""

    json_path: Path = field(default_factory=Path)  # "" = no file; rewritten atomically every interval_s
    interval_s: float = 5.0
    http_port: int = 0  # 0 = no endpoint; else GET http://127.0.0.1:PORT/health
    stall_s: float = 5.0  # no sensor frame for this long (loop time): degraded, watchdog not fed
    watchdog_s: float = 30.0  # WatchdogSec of the systemd unit (`jostle service install`)
    restart_s: float = 3.0  # RestartSec of the systemd unit

    def __post_init__(self) -> None:
        _seconds("interval_s", self.interval_s, zero_ok=False)
        _seconds("stall_s", self.stall_s, zero_ok=False)
        _seconds("watchdog_s", self.watchdog_s, zero_ok=False)
        _seconds("restart_s", self.restart_s, zero_ok=True)
        if isinstance(self.http_port, bool) or not isinstance(self.http_port, int) or not 0 <= self.http_port <= 65535:
            raise ValueError(f"http_port: expected 0 (off) or a port 1..65535, got {self.http_port!r}")
        if self.json_path != Path() and self.json_path.is_dir():
            raise ValueError(f"json_path: expected a file path, got the folder {self.json_path}")

    @property
    def json_file(self) -> Path | None:
        return None if self.json_path == Path() else self.json_path
