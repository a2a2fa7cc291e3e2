"""``jostle synth``: make recordings from virtual performers, so demos and tests need no hardware."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

RAW = argparse.RawDescriptionHelpFormatter


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
        help="a webcam filming a motion-captured person walking through the stage",
        formatter_class=RAW,
        description="Render a person from pybullet's DeepMimic motion capture walking across the stage in\n"
        "front of a virtual webcam (noise and slow light change included), record it as MCAP,\n"
        "and write the camera's exact calibration beside it. The first 1.5 s show the empty\n"
        "stage so an observer can learn the background.",
        epilog="examples:\n"
        "  jostle synth performer --clip walk --out configs/recordings/demo.mcap\n"
        "  jostle synth performer --clip walk --clip punch --duration 8 --out /tmp/shove.mcap",
    )
    perf.add_argument("--clip", action="append", default=None, metavar="NAME",
                      help="DeepMimic clip from pybullet_data (walk, run, punch, kick, …); repeat to sequence "
                      "(default: walk)")
    perf.add_argument("--out", type=Path, required=True, metavar="FILE.mcap")
    perf.add_argument("--duration", type=float, default=None, metavar="S", help="seconds of recording")
    perf.add_argument("--seed", type=int, default=0, help="seed of the noise and light change (default 0)")
    perf.add_argument("--fps", type=float, default=None, help="frames per second")
    perf.add_argument("--size", default=None, metavar="WxH", help="image size, e.g. 320x240")
    perf.add_argument("--sensor", default="webcam", help="channel name in the recording (default: webcam)")
    perf.add_argument("--calibration-out", type=Path, default=None, metavar="FILE.toml",
                      help="where to write the camera calibration (default: FILE.calibration.toml)")
    perf.add_argument("--png", action="store_true", help="store frames losslessly (PNG) instead of JPEG")
    perf.add_argument("--jpeg-quality", type=int, default=85, metavar="Q", help="JPEG quality 1-100 (default 85)")
    perf.set_defaults(func=cmd_synth_performer)


def cmd_synth_performer(args: argparse.Namespace) -> int:
    import dataclasses

    from interaction.calibration import Calibration
    from jostle.cli import UsageError
    from jostle.progress import Progress
    from jostle.synth.performer import PerformerConfig, PerformerSensor
    from sensors.base import SensorState
    from sensors.clock import SimClock
    from sensors.record import Recorder, RecordingWriter

    changes: dict[str, Any] = {"seed": args.seed}
    if args.clip:
        changes["clips"] = tuple(args.clip)
    if args.duration is not None:
        changes["duration_s"] = args.duration
    if args.fps is not None:
        changes["fps"] = args.fps
    if args.size:
        try:
            w, h = (int(v) for v in args.size.lower().split("x"))
        except ValueError:
            raise UsageError(f"--size: expected WIDTHxHEIGHT like 320x240, got {args.size!r}") from None
        changes["width"], changes["height"] = w, h
    try:
        config = dataclasses.replace(PerformerConfig(), **changes)
    except ValueError as e:
        raise UsageError(f"synth performer: {e}") from None
    if args.out.suffix != ".mcap":
        raise UsageError(f"{args.out}: a recording's name must end in .mcap")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    calib_path = args.calibration_out or args.out.with_suffix(".calibration.toml")

    clock = SimClock()
    performer = PerformerSensor(config, clock, name=args.sensor)
    total = config.frame_count
    tmp = args.out.with_suffix(".mcap.part")
    with RecordingWriter(tmp, metadata={"synth": "performer", "clips": ",".join(config.clips),
                                        "seed": str(config.seed)},
                         jpeg_quality=args.jpeg_quality, color_format="png" if args.png else "jpeg") as writer:
        rec = Recorder(performer, writer)
        rec.open()
        with Progress(total, "synth performer", "frames") as bar:
            while rec.status.state is not SensorState.ENDED:
                clock.advance(1.0 / config.fps)
                while rec.read(0.0) is not None:
                    bar.update(1)
        homography = performer.homography()
        rec.close()
    tmp.replace(args.out)
    Calibration(homography=tuple(float(v) for v in homography.reshape(-1)), plane_y=0.0).save(calib_path)
    size = args.out.stat().st_size / 1e6
    print(f"jostle: wrote {args.out} ({total} frames, {config.duration_s:g} s, {size:.1f} MB)", file=sys.stderr)
    print(f"jostle: wrote {calib_path} (the virtual camera's exact image → stage calibration)", file=sys.stderr)
    return 0
