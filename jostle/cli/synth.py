"""``jostle synth``: make recordings from virtual performers, so demos and tests need no hardware."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

RAW = argparse.RawDescriptionHelpFormatter
SENSOR_CHOICES = ("webcam", "oak", "pads")


def add(sub: Any) -> None:
    p = sub.add_parser(
        "synth",
        help="make recordings of virtual performers (no hardware needed)",
        formatter_class=RAW,
        description="Make sensor recordings from motion capture, rendered by a virtual camera.",
    )
    kinds = p.add_subparsers(dest="kind", metavar="KIND", required=True)
    perf = kinds.add_parser(
        "performer",
        help="motion-captured people filmed by a virtual webcam and OAK, and stepping on virtual pads",
        formatter_class=RAW,
        description="Render people from pybullet's DeepMimic motion capture on the stage in front of a\n"
        "virtual webcam (noise and slow light change included), a virtual OAK depth camera (stereo\n"
        "noise growing with distance, holes) and force pads on the floor; record it as MCAP, with\n"
        "an optional ground-truth channel ('truth': every joint of every person in stage metres),\n"
        "and write the webcam's exact calibration beside it. The recording starts with the empty\n"
        "stage so an observer can learn the background.\n\n"
        "One person (default) walks the demo's round: in from the left, the action clips, a turn,\n"
        "out again. Two to four people (--people) cross the stage on their own lanes, from both\n"
        "sides, passing each other near the middle; their sizes, paces and lanes come from --seed.",
        epilog="examples:\n"
        "  jostle synth performer --clip walk --out configs/recordings/demo.mcap\n"
        "  jostle synth performer --clip walk --clip punch --duration 8 --out /tmp/shove.mcap\n"
        "  jostle synth performer --people 2 --sensors webcam,oak,pads --truth --duration 6 --out /tmp/cross.mcap\n"
        "  jostle synth performer --people 3 --person-clips walk --person-clips walk+punch \\\n"
        "      --person-clips run --sensors oak --depth-size 320x200 --truth --out /tmp/three.mcap",
    )
    perf.add_argument("--clip", action="append", default=None, metavar="NAME",
                      help="DeepMimic clip from pybullet_data (walk, run, punch, kick, …) or a file (.bvh of any common "
                      "rig, DeepMimic .txt/.json; a BVH walk is cut to its best loop); repeat to sequence "
                      "(default: walk)")
    perf.add_argument("--out", type=Path, required=True, metavar="FILE.mcap")
    perf.add_argument("--duration", type=float, default=None, metavar="S", help="seconds of recording")
    perf.add_argument("--seed", type=int, default=0,
                      help="seed of the noise, the light change and the people's sizes, lanes and paces (default 0)")
    perf.add_argument("--fps", type=float, default=None, help="webcam frames per second")
    perf.add_argument("--size", default=None, metavar="WxH", help="webcam image size, e.g. 320x240")
    perf.add_argument("--sensor", default="webcam", help="the webcam's channel name in the recording (default: webcam)")
    perf.add_argument("--calibration-out", type=Path, default=None, metavar="FILE.toml",
                      help="where to write the webcam calibration (default: FILE.calibration.toml)")
    perf.add_argument("--png", action="store_true", help="store webcam frames losslessly (PNG) instead of JPEG")
    perf.add_argument("--jpeg-quality", type=int, default=85, metavar="Q", help="JPEG quality 1-100 (default 85)")
    who = perf.add_argument_group("people")
    who.add_argument("--people", type=int, default=1, metavar="N", help="how many people, 1-4 (default 1)")
    who.add_argument("--route", choices=("round", "crossing"), default=None,
                     help="round: one person's walk in, act, turn, out (default for one person); "
                     "crossing: everyone crosses on their own lane (default for several)")
    who.add_argument("--person-clips", action="append", default=None, metavar="SEQ",
                     help="one person's clips, like walk+punch; repeat once per person (default: --clip for all)")
    who.add_argument("--sizes", default=None, metavar="S,S,…",
                     help="body scale per person, e.g. 0.85,1.05 (1.0 = 1.6 m; default: from the seed, 0.8-1.1)")
    who.add_argument("--empty", type=float, default=None, metavar="S",
                     help="seconds of empty stage at the start (default 1.5)")
    rec = perf.add_argument_group("sensors")
    rec.add_argument("--sensors", default="webcam", metavar="LIST",
                     help="which to record, comma-separated: webcam, oak, pads (default: webcam)")
    rec.add_argument("--truth", action="store_true", help="add the ground-truth channel 'truth'")
    rec.add_argument("--depth-size", default=None, metavar="WxH", help="OAK depth size (default 640x400)")
    rec.add_argument("--depth-fps", type=float, default=None, help="OAK frames per second (default 15)")
    rec.add_argument("--no-depth-color", action="store_true", help="record the OAK's depth without its aligned colour")
    rec.add_argument("--pads", type=Path, default=None, metavar="LAYOUT.toml",
                     help="pad layout (top: rate_hz, newtons_per_count, noise_counts, zero_counts; then [[pad]] "
                     "tables with x, y, width, depth). Default: six 0.6 m pads at x = -1.2, 0, 1.2 and y = ±0.3")
    perf.set_defaults(func=cmd_synth_performer)
    shoes = kinds.add_parser(
        "shoe-model",
        help="make the depth observer's shoe model from virtual performers with known truth",
        formatter_class=RAW,
        description="Record virtual performers crossing the stage (the recordings `jostle bench interaction`\n"
        "makes, for other seeds), run the depth observer over them with the shoe rules alone, and keep\n"
        "every foot it finds with the correction that would have put it at the true foot's middle. The\n"
        "depth observer then corrects each foot by the mean of its k most similar feet\n"
        "(interaction.depth.shoe_model). Seeds 0, 100 and 200 are the bench's: they, and seeds within 3 of them\n"
        "(which share performers with them), are refused. The same seeds make the same model (the same\n"
        "arrays). About 25 s of one core per seed.",
        epilog="examples:\n"
        "  jostle synth shoe-model --seeds 300:5000:100 --jobs 2      # the shipped model\n"
        "  jostle synth shoe-model --seeds 300,400 --out /tmp/shoes.npz",
    )
    shoes.add_argument("--seeds", default="300:5000:100", metavar="A:B:STEP|A,B,…",
                       help="bench seeds to record (default 300:5000:100, B included)")
    shoes.add_argument("--k", type=int, default=10, help="feet averaged per correction (default 10)")
    shoes.add_argument("--jobs", type=int, default=1, metavar="N", help="seeds recorded at once (default 1)")
    shoes.add_argument("--out", type=Path, default=None, metavar="FILE.npz",
                       help="where to write it (default: the shipped interaction/depth/data/shoe_model.npz)")
    shoes.add_argument("--json", action="store_true", help="print the summary as JSON")
    shoes.set_defaults(func=cmd_synth_shoe_model)


def cmd_synth_shoe_model(args: argparse.Namespace) -> int:
    from interaction.depth.shoe_model import default_model_path
    from jostle.bench.shoe_model_fit import check_k, fit, parse_seeds
    from jostle.errors import UsageError
    from jostle.progress import Progress

    try:
        seeds = parse_seeds(args.seeds)
        k = check_k(args.k)
    except ValueError as e:
        raise UsageError(str(e)) from None
    if not 1 <= args.jobs <= 64:
        raise UsageError(f"--jobs: expected 1..64, got {args.jobs}")
    out = args.out if args.out is not None else default_model_path()
    try:  # found out now, not after minutes of recording
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UsageError(f"--out {out}: cannot make its folder ({e.strerror})") from None
    if not os.access(out.parent, os.W_OK) or out.is_dir():
        raise UsageError(f"--out {out}: cannot be written here")
    with Progress(len(seeds), "shoe model", "seeds") as bar:
        def step(done: int, total: int, rows: int) -> None:
            bar.update(1)

        try:
            summary = fit(seeds, out, k, args.jobs, step)
        except ValueError as e:
            raise UsageError(f"synth shoe-model: {e}") from None
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"shoe model: {summary['rows']} feet from {len(seeds)} seeds, k={k} -> {summary['out']}")
    return 0


def _size(option: str, text: str) -> tuple[int, int]:
    from jostle.errors import UsageError

    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise UsageError(f"{option}: expected WIDTHxHEIGHT like 320x240, got {text!r}") from None
    return w, h


def _performer_changes(args: argparse.Namespace) -> dict[str, Any]:
    from jostle.errors import UsageError

    changes: dict[str, Any] = {"seed": args.seed}
    if args.clip:
        changes["clips"] = tuple(args.clip)
    if args.duration is not None:
        changes["duration_s"] = args.duration
    if args.fps is not None:
        changes["fps"] = args.fps
    if args.size:
        changes["width"], changes["height"] = _size("--size", args.size)
    if args.people != 1 or args.route is not None:
        changes["people"] = args.people
        changes["route"] = args.route or ("round" if args.people == 1 else "crossing")
    if args.person_clips:
        changes["person_clips"] = tuple(args.person_clips)
    if args.sizes:
        try:
            changes["sizes"] = tuple(float(v) for v in args.sizes.split(","))
        except ValueError:
            raise UsageError(f"--sizes: expected numbers separated by commas like 0.85,1.05, got {args.sizes!r}") from None
    if args.empty is not None:
        changes["empty_s"] = args.empty
    return changes


def cmd_synth_performer(args: argparse.Namespace) -> int:
    import dataclasses

    from interaction.webcam.calibration import Calibration
    from jostle.errors import UsageError
    from jostle.performer.config import DepthCameraConfig, PerformerConfig
    from jostle.performer.pads import default_pad_layout, load_pad_layout
    from jostle.performer.session import SynthSensors, record_performance
    from jostle.progress import Progress

    chosen = [s.strip() for s in args.sensors.split(",") if s.strip()]
    unknown = [s for s in chosen if s not in SENSOR_CHOICES]
    if unknown or not chosen:
        raise UsageError(f"--sensors: expected a comma-separated list of {', '.join(SENSOR_CHOICES)}, got {args.sensors!r}")
    try:
        config = dataclasses.replace(PerformerConfig(), **_performer_changes(args))
    except ValueError as e:
        raise UsageError(f"synth performer: {e}") from None
    oak = None
    if "oak" in chosen:
        depth: dict[str, Any] = {"color": not args.no_depth_color}
        if args.depth_size:
            depth["width"], depth["height"] = _size("--depth-size", args.depth_size)
        if args.depth_fps is not None:
            depth["fps"] = args.depth_fps
        try:
            oak = DepthCameraConfig(**depth)
        except ValueError as e:
            raise UsageError(f"synth performer: depth camera: {e}") from None
    elif args.depth_size or args.depth_fps is not None or args.no_depth_color:
        raise UsageError("--depth-size/--depth-fps/--no-depth-color: the OAK is not recorded (add oak to --sensors)")
    layout = None
    if "pads" in chosen:
        layout = load_pad_layout(args.pads) if args.pads is not None else default_pad_layout()
    elif args.pads is not None:
        raise UsageError("--pads: the pads are not recorded (add pads to --sensors)")
    if args.out.suffix != ".mcap":
        raise UsageError(f"{args.out}: a recording's name must end in .mcap")
    if not 1 <= args.jpeg_quality <= 100:
        raise UsageError(f"--jpeg-quality: expected 1..100, got {args.jpeg_quality}")
    try:
        sensors = SynthSensors(webcam="webcam" in chosen, webcam_name=args.sensor, oak=oak, pads=layout,
                               truth=args.truth)
    except ValueError as e:
        raise UsageError(f"synth performer: {e}") from None
    args.out.parent.mkdir(parents=True, exist_ok=True)
    calib_path = args.calibration_out or args.out.with_suffix(".calibration.toml")

    duration = config.duration_s
    metadata = {"synth.args": json.dumps(_replay_args(args))}
    with Progress(duration, "synth performer", "s") as bar:
        done = [0.0]

        def advance(t: float) -> None:
            step = min(t, duration) - done[0]
            if step > 0:
                bar.update(step)
                done[0] += step

        summary = record_performance(config, sensors, args.out, jpeg_quality=args.jpeg_quality,
                                     color_format="png" if args.png else "jpeg", metadata=metadata, on_frame=advance)
    size = args.out.stat().st_size / 1e6
    counts = ", ".join(f"{n} {name}" for name, n in summary.frames.items())
    if summary.truth_messages:
        counts += f", {summary.truth_messages} truth"
    print(f"jostle: wrote {args.out} ({counts}; {duration:g} s, {size:.1f} MB)", file=sys.stderr)
    if summary.homography:
        Calibration(homography=summary.homography, plane_y=0.0).save(calib_path)
        print(f"jostle: wrote {calib_path} (the virtual camera's exact image → stage calibration)", file=sys.stderr)
    return 0


def _replay_args(args: argparse.Namespace) -> list[str]:
    """The options that decide the recording's content, as a command line (kept in the file's
    metadata, so a test can rebuild it and compare)."""
    out: list[str] = []
    for clip in args.clip or []:
        out += ["--clip", clip]
    for option, value in (("--duration", args.duration), ("--fps", args.fps), ("--size", args.size),
                          ("--sizes", args.sizes), ("--empty", args.empty), ("--depth-size", args.depth_size),
                          ("--depth-fps", args.depth_fps), ("--route", args.route)):
        if value is not None:
            out += [option, str(value)]
    for seq in args.person_clips or []:
        out += ["--person-clips", seq]
    out += ["--seed", str(args.seed), "--people", str(args.people), "--sensors", args.sensors,
            "--sensor", args.sensor, "--jpeg-quality", str(args.jpeg_quality)]
    if args.pads is not None:
        out += ["--pads", str(args.pads)]
    for flag, on in (("--truth", args.truth), ("--png", args.png), ("--no-depth-color", args.no_depth_color)):
        if on:
            out.append(flag)
    return out
