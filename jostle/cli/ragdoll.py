"""``jostle ragdoll``: the articulated characters' motion, saved for animators (BVH, glTF).

``jostle ragdoll export RUN --out FILE`` runs RUN — an installation config (TOML) or a recording
(MCAP, replayed through ``--config``) — headless on simulated time, exactly as ``jostle run`` /
``jostle replay`` would for the same seed, collects every articulated character's link poses once per
frame, and writes each character's motion as BVH (``.bvh``: ZYX Euler channels, centimetres, Y up) or
glTF 2.0 (``.gltf`` / ``.glb``: a node per link, rotation and root translation channels, metres).

The run goes through ``jostle.app.App`` (the one main loop) at a small frame size with no video: the
renderer's cost is negligible there and the simulation is the same as a full run's.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import Any

RAW = argparse.RawDescriptionHelpFormatter
_SMALL = (64, 36)  # the frame size the export runs at (nothing is drawn that anyone sees)


def add(sub: Any) -> None:
    r = sub.add_parser(
        "ragdoll",
        help="articulated characters: export what they did as BVH or glTF",
        formatter_class=RAW,
        description="Tools for the articulated (PD-tracked, physically simulated) characters.",
        epilog="example:\n  jostle ragdoll export configs/ragdoll.toml --seconds 10 --out out/ragdoll.bvh",
    )
    rs = r.add_subparsers(dest="action", metavar="ACTION", required=True)
    e = rs.add_parser(
        "export",
        help="run or replay headless and write the articulated characters' motion (.bvh, .gltf, .glb)",
        formatter_class=RAW,
        description="Run RUN headless on simulated time (a config), or replay it (a recording, through\n"
        "--config), and write what each articulated character did: BVH (Blender, MotionBuilder, Maya\n"
        "import it) or glTF 2.0, chosen by the extension of --out. With several articulated characters\n"
        "and no --character, one file per character: FILE's name + _NAME.",
        epilog="examples:\n"
        "  jostle ragdoll export configs/ragdoll.toml --seconds 10 --out out/ragdoll.bvh\n"
        "  jostle ragdoll export session.mcap --config configs/ragdoll.toml --out out/take.glb --character ragdoll_1",
    )
    e.add_argument("run", type=Path, metavar="RUN",
                   help="an installation config (.toml) to run, or a recording (.mcap) to replay through --config")
    e.add_argument("--out", type=Path, required=True, metavar="FILE", help="FILE.bvh, FILE.gltf or FILE.glb")
    e.add_argument("--config", type=Path, default=Path("configs/demo.toml"),
                   help="for a recording: the installation config to replay it through (default: configs/demo.toml)")
    e.add_argument("--character", metavar="NAME", help="only this character (default: every articulated one)")
    e.add_argument("--seconds", type=float, default=None, metavar="S",
                   help="simulated seconds (default: the config's duration, or until the recordings end)")
    e.add_argument("--seed", type=int, default=None, metavar="N", help="seed (default: [run] seed of the config)")
    e.add_argument("--fps", type=float, default=None, metavar="F",
                   help="frames per second written (default: the config's [render] fps)")
    e.add_argument("--units", choices=("cm", "m"), default="cm", help="BVH length unit (default: cm)")
    e.add_argument("--quiet", action="store_true", help="no progress bar")
    e.set_defaults(func=cmd_export)
    b = rs.add_parser(
        "body",
        help="show the articulated body a BVH file makes: links, joints, limits, masses, shapes",
        formatter_class=RAW,
        description="Build the articulated body of a BVH file (sim.articulated.bvh_body) and list its links:\n"
        "joint kind and limits, motion channel, mass (the seed's table scaled to --mass) and shape.",
        epilog="example:\n  jostle ragdoll body walk.bvh --mass 70",
    )
    b.add_argument("bvh", type=Path, metavar="FILE.bvh")
    b.add_argument("--mass", type=float, default=70.0, metavar="KG", help="total mass (default 70 kg)")
    b.add_argument("--json", action="store_true", help="print the links as JSON")
    b.add_argument("--joint-map", type=Path, default=None, metavar="FILE.toml",
                   help="name the joints of a rig that is not recognised (configs/joint_maps/README.md)")
    b.add_argument("--unit", choices=("m", "cm", "in", "mm"), default=None,
                   help="the file's length unit (default: detected from the standing height)")
    b.add_argument("--height", type=float, default=None, metavar="M", help="the standing height in metres")
    b.set_defaults(func=cmd_body)
    from jostle.cli import ragdoll_track

    ragdoll_track.add(rs, RAW)


def _fail(message: str) -> Exception:
    from jostle.errors import UsageError

    return UsageError(message)


def cmd_export(args: argparse.Namespace) -> int:
    from jostle.quiet import import_pybullet_quietly

    import_pybullet_quietly()
    from sim.articulated.export import (
        ExportError,
        articulated_names,
        shape_ends,
        track_from_snapshots,
        write_track,
    )
    from sim.articulated.skeleton import deepmimic_humanoid

    out = Path(args.out)
    if out.suffix.lower() not in (".bvh", ".gltf", ".glb"):
        raise _fail(f"--out: expected a .bvh, .gltf or .glb file name, got {out}")
    if args.seconds is not None and not args.seconds > 0:
        raise _fail(f"--seconds: expected a number > 0, got {args.seconds}")
    snapshots = collect(args)
    names = articulated_names(snapshots)
    if not names:
        raise _fail(f"{args.run}: the run has no articulated characters (give a character group body = \"articulated\")")
    if args.character is not None:
        if args.character not in names:
            raise _fail(f"--character: no articulated character {args.character!r}; the run has {', '.join(names)}")
        names = [args.character]
    written = []
    for name in names:
        path = out if len(names) == 1 else out.with_name(f"{out.stem}_{name}{out.suffix}")
        try:
            parents = known_parents(snapshots, name)
            track = track_from_snapshots(snapshots, name, parents)
            ends = shape_ends(deepmimic_humanoid()) if parents is not None else None
            written.append(write_track(track, path, units=args.units, ends=ends))
        except ExportError as e:
            raise _fail(str(e)) from None
        print(f"jostle: {name}: {len(track.times)} frames, {len(track.names)} links → {path}")
    return 0


def collect(args: argparse.Namespace) -> list[Any]:
    """Every snapshot of the run (one per frame), from the real main loop."""
    from jostle.app import App, RunOptions, expected_duration
    from jostle.config import load_config

    run = Path(args.run)
    if run.suffix.lower() == ".mcap":
        from jostle.cli.replay_config import replace_sensors_with_recording

        config = replace_sensors_with_recording(load_config(args.config), run)
    else:
        config = load_config(run)
    render = dataclasses.replace(config.render, width=_SMALL[0], height=_SMALL[1],
                                 fps=config.render.fps if args.fps is None else args.fps)
    config = dataclasses.replace(config, render=render)
    options = RunOptions(mode="headless", out_dir=None, seed=args.seed, speed="max", duration_s=args.seconds,
                         video=False, progress=not args.quiet)
    if expected_duration(config, options) is None:
        raise _fail(f"{run}: has live sensors; give --seconds (or [run] duration_s) to say when the export ends")
    app = App(config, options)
    snapshots: list[Any] = []
    app.on_frame = lambda snap, _obs, _image: snapshots.append(snap)
    print(f"jostle: running {run} headless for the export …", file=sys.stderr)
    app.run()
    return snapshots


def known_parents(snapshots: list[Any], name: str) -> dict[str, str | None] | None:
    """The link hierarchy of a known skeleton with these link names (the DeepMimic humanoid), else None
    (the export then infers it from the motion)."""
    from sim.articulated.skeleton import deepmimic_humanoid

    links = next(c.links for s in snapshots for c in s.characters if c.name == name and c.links)
    sk = deepmimic_humanoid()
    if tuple(link.name for link in links) != sk.names:
        return None
    return {link.name: (None if link.parent < 0 else sk.links[link.parent].name) for link in sk.links}


def cmd_body(args: argparse.Namespace) -> int:
    import dataclasses as dc
    import json
    import math

    from jostle.cli.keyframes import bvh_options
    from sim.articulated.bvh_body import bvh_body
    from sim.motion.bvh import read_bvh
    from sim.motion.joint_map import beside, map_joints

    if not (math.isfinite(args.mass) and args.mass > 0):
        raise _fail(f"--mass: expected a number > 0, got {args.mass}")
    o = bvh_options(args)
    motion = read_bvh(args.bvh)
    joints = o.joints if o.joints is not None else beside(Path(args.bvh))
    jm = map_joints(motion, joints, unit=o.unit, height=o.height, source=str(args.bvh))
    body = bvh_body(motion, total_mass=args.mass, name=Path(args.bvh).stem, joint_map=jm)
    sk = body.skeleton
    if args.json:
        print(json.dumps({"scale_m_per_unit": body.scale, "height_m": jm.height_m, "unit": jm.unit, "rig": jm.rig,
                          "frames": len(body.clip.times), "links": [dc.asdict(link) for link in sk.links]}, indent=2))
        return 0
    print(f"{args.bvh}: {jm.describe()}; {len(sk.links)} links, {sk.total_mass:.1f} kg, {len(body.clip.times)} "
          f"frames, {body.scale:g} m per file unit")
    for link, part in zip(sk.links, body.parts, strict=True):
        limits = ""
        if link.kind == "hinge":
            limits = f"{link.lower:+.2f}..{link.upper:+.2f} rad"
        elif link.kind in ("ball", "universal"):
            limits = (f"swing ±{math.degrees(link.swing_limit):.0f}° twist ±{math.degrees(link.twist_limit):.0f}° "
                      f"side ±{math.degrees(link.side_limit):.0f}°")
        size = "×".join(f"{v:.3f}" for v in link.size)
        print(f"  {link.name:<16} {part:<12} {link.kind:<9} {link.motion_channel or '-':<15} {link.mass:6.2f} kg "
              f"{link.shape:<7} {size:<20} {limits}".rstrip())
    return 0
