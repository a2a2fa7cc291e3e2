"""``jostle doctor``."""

from __future__ import annotations

import argparse
from typing import Any

RAW = argparse.RawDescriptionHelpFormatter


def add(sub: Any) -> None:
    d = sub.add_parser(
        "doctor",
        help="check OpenGL, cameras, serial ports and DepthAI devices (bounded in time)",
        formatter_class=RAW,
        description="Check what this machine offers jostle: packages, headless OpenGL, cameras,\n"
        "serial ports, DepthAI devices, disk space. Every probe runs in a subprocess with a time\n"
        "limit, so a missing or wedged device never hangs it. Exit status 1 if anything failed.",
        epilog="example:\n  jostle doctor\n  jostle doctor --json --timeout 5",
    )
    d.add_argument("--json", action="store_true", help="machine-readable output")
    d.add_argument("--timeout", type=float, default=15.0, metavar="S", help="time limit per probe (default 15)")
    d.set_defaults(func=cmd_doctor)


def cmd_doctor(args: argparse.Namespace) -> int:
    from jostle.cli.doctor import print_checks, run_checks

    return print_checks(run_checks(timeout=args.timeout), args.json)
