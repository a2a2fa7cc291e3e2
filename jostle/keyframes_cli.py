"""``jostle keyframes``: build, check, preview and import keyframe sets (tools for animators)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

RAW = argparse.RawDescriptionHelpFormatter


def add(sub: Any) -> None:
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


def cmd_keyframes_build_default(args: argparse.Namespace) -> int:
    from render.default_set import build_default_set

    manifest = build_default_set(args.out)
    print(f"jostle: wrote {manifest}", file=sys.stderr)
    return 0
