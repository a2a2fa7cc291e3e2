"""``jostle keyframes``: build, check, preview, import and export keyframe sets (tools for animators)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

RAW = argparse.RawDescriptionHelpFormatter
AXES_HELP = "theta_x | theta_z | dx | dz (or a dimension the set adds)"


def add(sub: Any) -> None:
    k = sub.add_parser(
        "keyframes",
        help="build, check, preview, import and export keyframe sets",
        formatter_class=RAW,
        description="Keyframe sets: poses placed in the space Q of tilt (theta_x, theta_z), walking phase\n"
        "(dx, dz) and behaviour B, blended wherever a character's rigid body is (Mitake et al. 2009).\n"
        "The format is described in configs/keyframes/humanoid/README.md.",
        epilog="examples:\n"
        "  jostle keyframes check configs/keyframes/humanoid\n"
        "  jostle keyframes preview configs/keyframes/humanoid --out out/preview\n"
        "  jostle keyframes export configs/keyframes/humanoid --out humanoid.gltf\n"
        "  jostle keyframes import walk.bvh --into my_set --name walk --axis dz --at theta_x=0,theta_z=0,dx=0",
    )
    ks = k.add_subparsers(dest="action", metavar="ACTION", required=True)

    b = ks.add_parser(
        "build-default", help="rebuild the shipped sets from pybullet's motion capture", formatter_class=RAW,
        description="Rebuild configs/keyframes/humanoid/ and configs/keyframes/critter/ from the DeepMimic\n"
        "clips in pybullet_data (walk and run cycles, a side step, get-ups) and the hand-made stagger and\n"
        "fall poses. Deterministic: the same files every time.",
        epilog="example:\n  jostle keyframes build-default --out configs/keyframes",
    )
    b.add_argument("--out", type=Path, default=Path("configs/keyframes"), metavar="DIR",
                   help="folder that holds the sets (default: configs/keyframes)")
    b.add_argument("--set", choices=("all", "humanoid", "critter"), default="all", help="which set (default: all)")
    b.set_defaults(func=cmd_build_default)

    c = ks.add_parser(
        "check", help="list every problem of a set (unknown joints, ranges, duplicates, gaps)", formatter_class=RAW,
        description="Check a keyframe set and list every problem, each with its file and animation:\n"
        "unknown joints, coordinates outside Q, duplicates, gaps in coverage, and whatever the loader\n"
        "refuses. Exit status 1 when there are errors (warnings alone exit 0).",
        epilog="examples:\n  jostle keyframes check configs/keyframes/humanoid\n"
        "  jostle keyframes check my_set/keyframes.toml --json",
    )
    c.add_argument("set", type=Path, metavar="SET", help="the set's folder or its keyframes.toml")
    c.add_argument("--json", action="store_true", help="print the report as JSON")
    c.set_defaults(func=cmd_check)

    p = ks.add_parser(
        "preview", help="contact sheet of every keyframe and a video sweeping each axis", formatter_class=RAW,
        description="Render a set: contact_sheet.png (every keyframe, labelled with its point of Q) and\n"
        "sweep.mp4 + sweep.gif (each axis of each behaviour swept over its range), headless.",
        epilog="example:\n  jostle keyframes preview configs/keyframes/humanoid --out out/preview",
    )
    p.add_argument("set", type=Path, metavar="SET")
    p.add_argument("--out", type=Path, required=True, metavar="DIR")
    p.add_argument("--frames", type=int, default=60, metavar="N", help="frames per swept axis (default 60)")
    p.set_defaults(func=cmd_preview)

    i = ks.add_parser(
        "import", help="add animations from glTF, BVH or DeepMimic JSON to a set", formatter_class=RAW,
        description="Add animations to the set in --into (made when missing).\n\n"
        "glTF (.gltf/.glb): every animation with extras.jostle, which says where it lies in Q\n"
        "(see 'jostle keyframes export' for the layout). BVH and DeepMimic JSON: one animation; say\n"
        "where it lies with --name, --behaviour, --axis and --at, and which frames become keys:\n"
        "--keys N (evenly spaced; along dx/dz at k/N, along theta over --range) or --frames with --coords.",
        epilog="examples:\n"
        "  jostle keyframes import humanoid.gltf --into my_set\n"
        "  jostle keyframes import walk.bvh --into my_set --name walk --axis dz --at theta_x=0,theta_z=0,dx=0 --keys 8\n"
        "  jostle keyframes import fall.txt --into my_set --name fall --axis theta_x --at theta_z=0,dx=any,dz=any \\\n"
        "      --keys 5 --range 0 1.57",
    )
    i.add_argument("files", type=Path, nargs="+", metavar="FILE")
    i.add_argument("--into", type=Path, required=True, metavar="DIR", help="the set's folder")
    i.add_argument("--name", help="animation name (default: the file's name)")
    i.add_argument("--behaviour", default="walk", help="B of the animation (default: walk)")
    i.add_argument("--axis", default="dz", help=f"the axis the keys run along: {AXES_HELP} (default dz)")
    i.add_argument("--at", default="", metavar="C=V,…", help='the other coordinates, each a number or "any"')
    i.add_argument("--family", default="", help="family to join (parallel animations blended across)")
    i.add_argument("--keys", type=int, default=None, metavar="N", help="N evenly spaced keys (default 8)")
    i.add_argument("--frames", default=None, metavar="F,…", help="frame numbers to take as keys")
    i.add_argument("--coords", default=None, metavar="X,…", help="each key's coordinate along --axis")
    i.add_argument("--range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="coordinates of the first and last key along a theta axis")
    i.add_argument("--joint-map", type=Path, default=None, metavar="FILE.toml",
                   help="BVH: name the joints of a rig that is not recognised (configs/joint_maps/README.md)")
    i.add_argument("--unit", choices=("m", "cm", "in", "mm"), default=None,
                   help="BVH: the file's length unit (default: detected from the standing height)")
    i.add_argument("--height", type=float, default=None, metavar="M",
                   help="BVH: the standing height in metres (instead of --unit)")
    i.set_defaults(func=cmd_import)

    e = ks.add_parser(
        "export", help="write a set as glTF 2.0 for animators' tools", formatter_class=RAW,
        description="Write SET as glTF (.gltf with the data inside, or .glb): the skeleton as nodes, one\n"
        "glTF animation per animation of the set, each key's point of Q in the animation's extras.",
        epilog="example:\n  jostle keyframes export configs/keyframes/humanoid --out humanoid.gltf",
    )
    e.add_argument("set", type=Path, metavar="SET")
    e.add_argument("--out", type=Path, required=True, metavar="FILE")
    e.set_defaults(func=cmd_export)


def _manifest(path: Path) -> Path:
    return path / "keyframes.toml" if path.is_dir() else path


def cmd_build_default(args: argparse.Namespace) -> int:
    from render.keyframes.default_set import SETS, build_set

    for name, (figure, cycle) in SETS.items():
        if args.set in ("all", name):
            print(f"jostle: wrote {build_set(args.out / name, figure, cycle)}", file=sys.stderr)
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from render.keyframes.set_check import check_set

    report = check_set(args.set)
    if args.json:
        print(json.dumps(report.as_dict(), indent=2))
    else:
        for p in report.problems:
            print(p.line())
        errors = sum(p.severity == "error" for p in report.problems)
        print(f"{report.set}: {report.animations} animations, {report.keyframes} keyframes, {report.poses} poses; "
              f"{errors} errors, {len(report.problems) - errors} warnings")
    return 0 if report.ok else 1


def cmd_preview(args: argparse.Namespace) -> int:
    from render.gl.preview import contact_sheet, sweep
    from render.keyframes import KeyframeSet

    kset = KeyframeSet.load(_manifest(args.set))
    tiles = contact_sheet(kset, args.out / "contact_sheet.png")
    frames = sweep(kset, args.out / "sweep.mp4", frames_per_axis=args.frames)
    print(f"jostle: {args.out / 'contact_sheet.png'} ({tiles} keyframes), {args.out / 'sweep.mp4'} and "
          f"sweep.gif ({frames} frames)")
    return 0


def _floats(text: str | None, what: str) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        from jostle.errors import UsageError

        raise UsageError(f"--{what}: expected numbers separated by commas, got {text!r}") from None


def _at(text: str) -> dict[str, float | str]:
    from jostle.errors import UsageError

    out: dict[str, float | str] = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        name, eq, value = part.partition("=")
        if not eq:
            raise UsageError(f"--at: expected coordinate=value pairs like theta_x=0,dx=any, got {part!r}")
        try:
            out[name.strip()] = "any" if value.strip() == "any" else float(value)
        except ValueError:
            raise UsageError(f'--at: {name.strip()}: expected a number or "any", got {value!r}') from None
    return out


def bvh_options(args: argparse.Namespace) -> Any:
    """The BvhOptions of ``--joint-map``, ``--unit`` and ``--height`` (checked: a height in 0.3-3 m, not both)."""
    from jostle.errors import UsageError
    from render.keyframes.clip_import import BvhOptions
    from sim.motion.joint_map import load_joint_map

    if args.height is not None and not 0.3 <= args.height <= 3.0:
        raise UsageError(f"--height: expected a standing height in metres (0.3-3), got {args.height}")
    if args.height is not None and args.unit is not None:
        raise UsageError("--height and --unit: give one of them (the height sets the unit)")
    return BvhOptions(load_joint_map(args.joint_map) if args.joint_map else None, args.unit, args.height)


def cmd_import(args: argparse.Namespace) -> int:
    from render.keyframes.clip_import import Placement, import_clip

    bvh = bvh_options(args)
    manifest = None
    for f in args.files:
        if f.suffix.lower() in (".gltf", ".glb"):
            from render.keyframes.gltf_io import import_gltf

            manifest = import_gltf(f, args.into)
        else:
            placement = Placement(args.name or f.stem, args.behaviour, args.axis, _at(args.at), args.family)
            frames = _floats(args.frames, "frames")
            manifest, recognised = import_clip(
                f, args.into, placement, keys=args.keys, frames=[int(x) for x in frames] if frames else None,
                coords=_floats(args.coords, "coords"), span=tuple(args.range) if args.range else None, bvh=bvh,
            )
            if recognised:
                print(f"jostle: {f}: {recognised}", file=sys.stderr)
        print(f"jostle: imported {f} into {manifest}", file=sys.stderr)
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from render.keyframes import KeyframeSet
    from render.keyframes.gltf_io import export_gltf

    path = export_gltf(KeyframeSet.load(_manifest(args.set)), args.out)
    print(f"jostle: wrote {path}", file=sys.stderr)
    return 0
