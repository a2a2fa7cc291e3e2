"""``jostle service install|uninstall``: run an installation under systemd (see jostle.cli.service_unit)."""

from __future__ import annotations

import argparse
import getpass
import os
import sys
from pathlib import Path
from typing import Any

from jostle.cli.service_unit import (
    OPERATOR_EXIT,
    UnitSpec,
    default_out_dir,
    default_unit_dir,
    unit_name,
    unit_text,
)
from sensors.untrusted import UntrustedInput, read_bytes, systemd_text, write_owned

__all__ = ["OPERATOR_EXIT", "add", "cmd_install", "cmd_uninstall"]

RAW = argparse.RawDescriptionHelpFormatter


def add(sub: Any) -> None:
    p = sub.add_parser(
        "service",
        help="install or remove a systemd unit that keeps an installation running",
        formatter_class=RAW,
        description="Write (or remove) a systemd unit for an installation config: started at login or boot,\n"
        "restarted whenever it stops or hangs (the watchdog is fed only while sensor frames flow),\n"
        "logging to the journal. Prints the systemctl commands to run; runs none itself.",
        epilog="examples:\n"
        "  jostle service install configs/webcam.toml --user\n"
        "  jostle service install configs/webcam.toml --user --dry-run\n"
        "  jostle service uninstall configs/webcam.toml --user\n"
        "then:  journalctl --user -u jostle-webcam -f",
    )
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    i = verbs.add_parser("install", help="write the unit file", formatter_class=RAW,
                         description="Write jostle-NAME.service for CONFIG (NAME: the config's file name).",
                         epilog="example:\n  jostle service install configs/webcam.toml --user")
    i.add_argument("config", type=Path, help="installation config (TOML)")
    _common(i)
    i.add_argument("--mode", choices=("kiosk", "window", "headless"), default="kiosk",
                   help="how the installation runs (default: kiosk)")
    i.add_argument("--display", default=None, metavar=":N",
                   help="X display for kiosk/window (default: $DISPLAY, else :0)")
    i.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="folder for summary.json (default: ~/.local/state/jostle/NAME, or /var/lib/jostle/NAME)")
    i.add_argument("--run-as", default=None, metavar="USER",
                   help="system unit (no --user): the user it runs as (default: $SUDO_USER or you)")
    i.add_argument("--force", action="store_true", help="overwrite an existing unit file")
    i.set_defaults(func=cmd_install)
    u = verbs.add_parser("uninstall", help="remove the unit file", formatter_class=RAW,
                         description="Remove jostle-NAME.service (and its enable links) for CONFIG or NAME.",
                         epilog="example:\n  jostle service uninstall webcam --user")
    u.add_argument("config", help="the installation config, or just NAME")
    _common(u)
    u.set_defaults(func=cmd_uninstall)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--user", action="store_true",
                   help="a user unit (~/.config/systemd/user; systemctl --user) — right for a kiosk")
    p.add_argument("--unit-dir", type=Path, default=None, metavar="DIR",
                   help="where unit files go (default: ~/.config/systemd/user with --user, else /etc/systemd/system)")
    p.add_argument("--name", default=None, help="NAME in jostle-NAME.service (default: the config's file name)")
    p.add_argument("--dry-run", action="store_true", help="print what would be written or removed; change nothing")


def _jostle_command() -> Path:
    """The ``jostle`` script beside this Python (the virtual environment's), as an absolute path."""
    here = Path(os.path.abspath(sys.executable)).parent  # not resolved: a venv's python is a symlink
    found = here / "jostle"
    if not found.exists():
        from jostle.errors import UsageError

        raise UsageError(f"{found}: no jostle command beside {sys.executable}; install jostle into this "
                         "environment (make setup, or pip install -e .)")
    return found


def _systemctl(user: bool) -> str:
    return "systemctl --user" if user else "sudo systemctl"


def _refused(e: UntrustedInput) -> Exception:
    """A value the unit cannot hold, as the command line's one-line user error."""
    from jostle.errors import UsageError

    return UsageError(str(e))


def cmd_install(args: argparse.Namespace) -> int:
    try:
        return _install(args)
    except UntrustedInput as e:
        raise _refused(e) from None


def _install(args: argparse.Namespace) -> int:
    from jostle.config import load_config

    config_path = Path(os.path.abspath(args.config))
    systemd_text(str(config_path), "config")  # a newline in the path: refused before the file is read
    config = load_config(config_path)  # a unit for a config that does not load would only crash-loop
    home = Path.home()
    name = unit_name(config_path, args.name)
    unit_dir = args.unit_dir or default_unit_dir(args.user, home)
    out_dir = Path(os.path.abspath(args.out)) if args.out else default_out_dir(args.user, home, name)
    spec = UnitSpec(
        name=name, jostle=_jostle_command(), config=config_path, out_dir=out_dir, mode=args.mode,
        user_unit=args.user, run_as="" if args.user else (args.run_as or os.environ.get("SUDO_USER") or getpass.getuser()),
        display=args.display or os.environ.get("DISPLAY") or ":0", xauthority=os.environ.get("XAUTHORITY", ""),
        watchdog_s=config.health.watchdog_s, restart_s=config.health.restart_s,
    )
    text = unit_text(spec)
    target = unit_dir / name
    if args.dry_run:
        print(f"# would write {target}:")
        print(text, end="")
    else:
        if os.path.lexists(target) and not args.force and read_bytes(target, 1 << 20, "unit file") != text.encode():
            from jostle.errors import UsageError

            raise UsageError(f"{target}: a unit of that name exists; use --force to replace it (or --name)")
        try:
            unit_dir.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise UntrustedInput(unit_dir, f"cannot make the folder for the unit: {e.strerror or type(e).__name__}") from None
        write_owned(target, text)  # a FIFO, device or symlink there is refused, never replaced
        print(f"jostle: wrote {target}")
    short = name.removesuffix(".service")
    ctl = _systemctl(args.user)
    print("then run:")
    print(f"  {ctl} daemon-reload && {ctl} enable --now {short}")
    if args.user:
        print(f"  loginctl enable-linger {getpass.getuser()}    # start at boot, not only at login")
        print(f"logs:   journalctl --user -u {short} -f      (structured: -o json)")
    else:
        print(f"logs:   journalctl -u {short} -f      (structured: -o json)")
    print(f"status: {ctl.removeprefix('sudo ')} status {short}")
    return 0


def cmd_uninstall(args: argparse.Namespace) -> int:
    given = Path(args.config)
    try:
        name = unit_name(given, args.name if args.name is not None else (None if given.suffix == ".toml" else args.config))
    except UntrustedInput as e:
        raise _refused(e) from None
    unit_dir = args.unit_dir or default_unit_dir(args.user, Path.home())
    target = unit_dir / name
    links = [p for p in unit_dir.glob(f"*.wants/{name}") if p.is_symlink() or p.exists()]
    if not target.exists() and not links:
        from jostle.errors import UsageError

        raise UsageError(f"{target}: no such unit (installed with --user? see --unit-dir)")
    short = name.removesuffix(".service")
    ctl = _systemctl(args.user)
    for path in [*links, target]:
        if not path.exists() and not path.is_symlink():
            continue
        if args.dry_run:
            print(f"jostle: would remove {path}")
        else:
            path.unlink()
            print(f"jostle: removed {path}")
    print("then run:")
    print(f"  {ctl} stop {short}; {ctl} daemon-reload")
    return 0
