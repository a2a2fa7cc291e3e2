"""A systemd unit that keeps one installation running for weeks: ``Type=notify`` (the loop says READY
and pings the watchdog only while frames flow), ``Restart=always``, ``WatchdogSec``/``RestartSec``
from the config's ``[health]``, no limit on restarts, the display for a kiosk. Pure text; writing it
is ``jostle service install`` (``jostle.cli.service``). Every value is written by systemd's own
quoting rules for its position (``sensors.untrusted``'s ``systemd_*``); a value that cannot be said
exactly (a newline, a control character) raises ``UntrustedInput`` naming the flag."""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Literal

from sensors.untrusted import (
    UntrustedInput,
    shorten,
    systemd_environment,
    systemd_exec_argument,
    systemd_exec_path,
    systemd_path,
    systemd_text,
    systemd_user,
)

OPERATOR_EXIT = 10  # `jostle run` exit status after the operator's exit keys: systemd leaves it stopped
Mode = Literal["kiosk", "window", "headless"]


def unit_name(config: Path, name: str | None = None) -> str:
    """``jostle-NAME.service``, NAME from ``name`` (``--name``) or the config's file name, every run of
    other characters than letters, digits, - and _ made one '-'. A name with a control character, or
    none of those characters left, is refused (``UntrustedInput`` naming ``--name`` or the config)."""
    what = "--name" if name is not None else str(config)
    given = name if name is not None else config.stem
    systemd_text(given, what)  # refuses newlines and other control characters by name
    base = given.removesuffix(".service").removeprefix("jostle-")
    clean = re.sub(r"[^A-Za-z0-9_-]+", "-", base).strip("-")[:200]
    if not clean:
        raise UntrustedInput(what, f"{shorten(base)} leaves no letters, digits, '-' or '_' for the unit's name"
                                   + ("" if name is not None else "; give one with --name"))
    return f"jostle-{clean}.service"


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
        _settings(self)  # every value checked now: a spec that exists can be written


def _settings(spec: UnitSpec) -> dict[str, str]:
    """Every value the unit takes from outside, quoted for its setting; ``UntrustedInput`` names the
    flag of the first that cannot be written."""
    short = spec.name.removesuffix(".service").removeprefix("jostle-")
    command = [systemd_exec_path(spec.jostle, "jostle command"), "run",
               systemd_exec_argument(spec.config, "config"), f"--{spec.mode}", "--no-video", "--quiet",
               "--out", systemd_exec_argument(spec.out_dir, "--out")]
    out = {
        "Description": systemd_text(f"jostle installation {short} ({spec.config.name})", "config"),
        "ExecStart": " ".join(command),
        "WorkingDirectory": systemd_path(spec.config.parent, "config"),
        "DISPLAY": systemd_environment("DISPLAY", spec.display, "--display (or $DISPLAY)"),
        "XAUTHORITY": systemd_environment("XAUTHORITY", spec.xauthority, "$XAUTHORITY"),
        "User": "" if spec.user_unit else systemd_user(spec.run_as, "--run-as"),
        "StateDirectory": "",
    }
    if not spec.user_unit and spec.out_dir.parent == Path("/var/lib/jostle"):
        if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", spec.out_dir.name):
            raise UntrustedInput("--out", f"{shorten(str(spec.out_dir), 80)}: a folder in /var/lib/jostle is named "
                                          "with letters, digits, '.', '_' or '-' (systemd's StateDirectory=)")
        out["StateDirectory"] = f"jostle/{spec.out_dir.name}"  # created for, and owned by, User=
    return out


def unit_text(spec: UnitSpec) -> str:
    """The unit file's text."""
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    v = _settings(spec)
    graphical = spec.mode != "headless"
    after = "graphical-session.target" if spec.user_unit else ("graphical.target" if graphical else "network.target")
    lines = [
        f"# Written by `jostle service install` on {stamp}. Change the installation's config, not this",
        "# file; run `jostle service install` again to change how it is run.",
        "[Unit]",
        f"Description={v['Description']}",
        f"After={after}",
        "StartLimitIntervalSec=0",  # never give up restarting
        "",
        "[Service]",
        "Type=notify",
        "NotifyAccess=main",
        f"ExecStart={v['ExecStart']}",
        f"WorkingDirectory={v['WorkingDirectory']}",
        "Environment=PYTHONUNBUFFERED=1",
    ]
    if graphical:
        lines.append(f"Environment={v['DISPLAY']}")
        if spec.xauthority:
            lines.append(f"Environment={v['XAUTHORITY']}")
    if not spec.user_unit:
        lines.append(f"User={v['User']}")
        if v["StateDirectory"]:
            lines.append(f"StateDirectory={v['StateDirectory']}")
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
