"""A systemd unit that keeps one installation running for weeks: ``Type=notify`` (the loop says READY
and pings the watchdog only while frames flow), ``Restart=always``, ``WatchdogSec``/``RestartSec``
from the config's ``[health]``, no limit on restarts, the display for a kiosk. Pure text; writing it
is ``jostle service install`` (``jostle.cli.service``)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Literal

OPERATOR_EXIT = 10  # `jostle run` exit status after the operator's exit keys: systemd leaves it stopped
Mode = Literal["kiosk", "window", "headless"]


def unit_name(config: Path, name: str | None = None) -> str:
    """``jostle-NAME.service``, NAME from ``name`` or the config's file name (letters, digits, - and _)."""
    base = (name if name is not None else config.stem).removesuffix(".service").removeprefix("jostle-")
    clean = re.sub(r"[^A-Za-z0-9_-]+", "-", base).strip("-")
    if not clean:
        raise ValueError(f"name: expected letters, digits, '-' or '_', got {base!r}")
    return f"jostle-{clean}.service"


def _arg(value: str | Path) -> str:
    """One ExecStart argument: double-quoted when needed, '%' doubled (systemd's specifier escape)."""
    text = str(value).replace("%", "%%")
    if re.fullmatch(r"[A-Za-z0-9_@%+=:,./-]+", text):
        return text
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


@dataclass(frozen=True)
class UnitSpec:
    """Everything a unit needs; paths absolute."""

    name: str  # jostle-NAME.service
    jostle: Path  # the venv's jostle command
    config: Path
    out_dir: Path
    mode: Mode = "kiosk"
    user_unit: bool = True  # systemctl --user (else a system unit run as ``run_as``)
    run_as: str = ""
    display: str = ":0"
    xauthority: str = ""
    watchdog_s: float = 30.0
    restart_s: float = 3.0

    def __post_init__(self) -> None:
        for field in ("jostle", "config", "out_dir"):
            if not getattr(self, field).is_absolute():
                raise ValueError(f"{field}: expected an absolute path, got {getattr(self, field)}")
        if not self.user_unit and not self.run_as:
            raise ValueError("run_as: a system unit needs the user to run as")


def unit_text(spec: UnitSpec) -> str:
    """The unit file's text."""
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    command = " ".join(_arg(a) for a in (spec.jostle, "run", spec.config, f"--{spec.mode}", "--no-video",
                                          "--quiet", "--out", spec.out_dir))
    graphical = spec.mode != "headless"
    after = "graphical-session.target" if spec.user_unit else ("graphical.target" if graphical else "network.target")
    lines = [
        f"# Written by `jostle service install` on {stamp}. Change the installation's config, not this",
        "# file; run `jostle service install` again to change how it is run.",
        "[Unit]",
        f"Description=jostle installation {spec.name.removesuffix('.service').removeprefix('jostle-')} "
        f"({spec.config.name})",
        f"After={after}",
        "StartLimitIntervalSec=0",  # never give up restarting
        "",
        "[Service]",
        "Type=notify",
        "NotifyAccess=main",
        f"ExecStart={command}",
        f"WorkingDirectory={_arg(spec.config.parent)}",
        "Environment=PYTHONUNBUFFERED=1",
    ]
    if graphical:
        lines.append(f"Environment=DISPLAY={spec.display}")
        if spec.xauthority:
            lines.append(f"Environment=XAUTHORITY={_arg(spec.xauthority)}")
    if not spec.user_unit:
        lines.append(f"User={spec.run_as}")
        if spec.out_dir.parent == Path("/var/lib/jostle"):
            lines.append(f"StateDirectory=jostle/{spec.out_dir.name}")  # created for, and owned by, User=
    lines += [
        "Restart=always",
        f"RestartSec={spec.restart_s:g}",
        f"WatchdogSec={spec.watchdog_s:g}",
        "TimeoutStartSec=120",
        "TimeoutStopSec=20",
        f"RestartPreventExitStatus={OPERATOR_EXIT}",  # the operator pressed the exit keys
        f"SuccessExitStatus={OPERATOR_EXIT}",
        "",
        "[Install]",
        f"WantedBy={'default.target' if spec.user_unit else ('graphical.target' if graphical else 'multi-user.target')}",
        "",
    ]
    return "\n".join(lines)


def default_unit_dir(user: bool, home: Path) -> Path:
    return home / ".config" / "systemd" / "user" if user else Path("/etc/systemd/system")


def default_out_dir(user: bool, home: Path, name: str) -> Path:
    short = name.removesuffix(".service").removeprefix("jostle-")
    return home / ".local" / "state" / "jostle" / short if user else Path("/var/lib/jostle") / short
