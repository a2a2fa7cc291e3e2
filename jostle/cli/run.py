"""``jostle run``, ``replay``, ``info`` and ``record``: each adds its parser and names the function that runs it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

Sub = Any  # argparse's _SubParsersAction is private

RAW = argparse.RawDescriptionHelpFormatter


# ------------------------------------------------------------------------------------------ run


def _mode_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--headless", dest="mode", action="store_const", const="headless",
                   help="draw off screen (EGL); write a video to --out (the default)")
    g.add_argument("--window", dest="mode", action="store_const", const="window",
                   help="draw in a window on the desktop")
    g.add_argument("--kiosk", dest="mode", action="store_const", const="kiosk",
                   help="full screen, hidden cursor, for an installation")
    p.set_defaults(mode="headless")


def _run_flags(p: argparse.ArgumentParser, default_out: str) -> None:
    _mode_flags(p)
    p.add_argument("--out", type=Path, default=Path(default_out), metavar="DIR",
                   help=f"folder for the video and summary.json (default: {default_out})")
    p.add_argument("--seed", type=int, default=None, metavar="N",
                   help="seed for every random choice (default: [run] seed of the config)")
    p.add_argument("--speed", choices=("realtime", "max"), default=None,
                   help="recordings and video files: as fast as the CPU allows (max, default headless) "
                   "or at wall-clock speed")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="stop after S simulated seconds (default: when the recordings end)")
    p.add_argument("--no-video", action="store_true", help="do not write the MP4 (still renders)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def add_run(sub: Sub) -> None:
    p = sub.add_parser(
        "run",
        help="run an installation config (live sensors or recordings)",
        formatter_class=RAW,
        description="Run the installation described by CONFIG: sensors → people → physics → drawing.\n\n"
        "With recordings or video files as sensors ([sensors.x] type = \"replay\", or type = \"webcam\"\n"
        "with a video file as source) the run is on simulated time:\n"
        "deterministic for a seed, and as fast as the CPU allows when headless.",
        epilog="examples:\n"
        "  jostle run configs/demo.toml --headless --out out/demo\n"
        "  jostle run configs/webcam.toml --window\n"
        "  jostle run configs/demo.toml --seed 3 --duration 5 --out /tmp/try",
    )
    p.add_argument("config", type=Path, help="installation config (TOML), e.g. configs/demo.toml")
    _run_flags(p, "out/run")
    p.set_defaults(func=cmd_run)


def _execute(config_path: Path, args: argparse.Namespace, *, override_recording: Path | None = None) -> int:
    from jostle.app import App
    from jostle.config import load_config
    from jostle.run_setup import RunOptions, Speed

    config = load_config(config_path)
    if override_recording is not None:
        from jostle.cli.replay_config import replace_sensors_with_recording

        config = replace_sensors_with_recording(config, override_recording)
    if args.mode != "headless":
        from render.gl.renderer import display_available

        if not display_available():
            from jostle.errors import UsageError

            raise UsageError(f"--{args.mode} needs a display (none found: DISPLAY is not set); use --headless")
    speed: Speed = args.speed or ("max" if args.mode == "headless" else "realtime")
    options = RunOptions(
        mode=args.mode,
        out_dir=args.out,
        seed=args.seed,
        speed=speed,
        duration_s=args.duration,
        video=not args.no_video,
        progress=not args.quiet,
    )
    print(f"jostle: running {config_path} ({args.mode}, speed {speed}) …", file=sys.stderr)
    app = App(config, options)
    summary = app.run()
    out = args.out
    print(
        f"jostle: {summary.characters} characters, {summary.sim_seconds:.1f} s simulated in "
        f"{summary.wall_seconds:.1f} s: {summary.contacts} contacts, {summary.pushes} pushes, "
        f"{summary.falls} falls, {summary.getups} get-ups ({summary.stopped_because})",
        file=sys.stderr,
    )
    if summary.video:
        print(f"jostle: video:   {summary.video}")
    print(f"jostle: summary: {out / 'summary.json'}")
    if app.operations.exit_requested:  # the operator's exit keys: systemd must not start it again
        from jostle.cli.service import OPERATOR_EXIT

        return OPERATOR_EXIT
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    return _execute(args.config, args)


# --------------------------------------------------------------------------------------- replay


def add_replay(sub: Sub) -> None:
    p = sub.add_parser(
        "replay",
        help="run a recorded session again through an installation config",
        formatter_class=RAW,
        description="Replay RECORDING through CONFIG: every sensor of the config whose name is a channel\n"
        "of the recording reads from it instead of hardware. Deterministic for a seed.",
        epilog="examples:\n"
        "  jostle replay configs/recordings/demo.mcap\n"
        "  jostle replay session.mcap --config configs/webcam.toml --out out/session --seed 2",
    )
    p.add_argument("recording", type=Path, help="an MCAP recording made by 'jostle record' or 'jostle synth'")
    p.add_argument("--config", type=Path, default=Path("configs/demo.toml"),
                   help="installation config to replay through (default: configs/demo.toml)")
    _run_flags(p, "out/replay")
    p.set_defaults(func=cmd_replay)


def cmd_replay(args: argparse.Namespace) -> int:
    return _execute(args.config, args, override_recording=args.recording)


# ----------------------------------------------------------------------------------------- info


def add_info(sub: Sub) -> None:
    p = sub.add_parser(
        "info",
        help="summarise a recording: channels, message counts, duration",
        formatter_class=RAW,
        description="Print what an MCAP recording holds: each channel (sensor) with its kind, schema,\n"
        "message count, rate and image size; the duration; whether the file is damaged and how much\n"
        "was lost (every chunk is read and checked; --quick describes it from its summary alone).",
        epilog="example:\n  jostle info configs/recordings/demo.mcap\n  jostle info session.mcap --json",
    )
    p.add_argument("recording", type=Path)
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--quick", action="store_true", help="describe from the summary, without reading the chunks")
    p.set_defaults(func=cmd_info)


def cmd_info(args: argparse.Namespace) -> int:
    import dataclasses
    import json

    from sensors.recording.info import describe_recording, format_info

    info = describe_recording(args.recording, verify=not args.quick)
    if args.json:
        print(json.dumps(dataclasses.asdict(info), indent=2, default=str))
    else:
        print(format_info(info))
    return 0


# --------------------------------------------------------------------------------------- record


def add_record(sub: Sub) -> None:
    p = sub.add_parser(
        "record",
        help="record the sensors of a config into an MCAP file",
        formatter_class=RAW,
        description="Open every sensor of CONFIG and write what they produce into one MCAP recording\n"
        "(one channel per sensor; opens in Foxglove Studio). Shows frames, size and rate as it goes.\n"
        "Stop with Ctrl-C or --duration; the file is always closed cleanly.",
        epilog="examples:\n"
        "  jostle record configs/webcam.toml --out session.mcap --duration 30\n"
        "  jostle replay session.mcap --config configs/webcam.toml",
    )
    p.add_argument("config", type=Path)
    p.add_argument("--out", type=Path, required=True, metavar="FILE.mcap")
    p.add_argument("--duration", type=float, default=None, metavar="S", help="stop after S seconds")
    p.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    p.set_defaults(func=cmd_record)


def cmd_record(args: argparse.Namespace) -> int:
    from jostle.cli.record import record_config

    return record_config(args.config, args.out, duration=args.duration, force=args.force)
