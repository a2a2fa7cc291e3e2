"""``jostle doctor`` and ``jostle keyframes``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
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

    k = sub.add_parser(
        "keyframes",
        help="build and inspect keyframe sets",
        formatter_class=RAW,
        description="Keyframe sets: poses placed in the space of tilt, walking phase and behaviour.",
    )
    ks = k.add_subparsers(dest="action", metavar="ACTION", required=True)
    b = ks.add_parser(
        "build-default",
        help="rebuild the shipped humanoid set from pybullet's motion capture",
        formatter_class=RAW,
        description="Rebuild configs/keyframes/humanoid/ from the DeepMimic clips in pybullet_data\n"
        "(walk cycle, get-ups) and the fall poses. Deterministic.",
        epilog="example:\n  jostle keyframes build-default --out configs/keyframes/humanoid",
    )
    b.add_argument("--out", type=Path, default=Path("configs/keyframes/humanoid"), metavar="DIR")
    b.set_defaults(func=cmd_keyframes_build_default)


def cmd_doctor(args: argparse.Namespace) -> int:
    from jostle.doctor import print_checks, run_checks

    return print_checks(run_checks(timeout=args.timeout), args.json)


def cmd_keyframes_build_default(args: argparse.Namespace) -> int:
    from render.default_set import build_default_set

    manifest = build_default_set(args.out)
    print(f"jostle: wrote {manifest}", file=sys.stderr)
    return 0
