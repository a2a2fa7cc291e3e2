"""``jostle bench pipeline``: where the demo's time goes, stage by stage, in one run.

Runs the demo config headless (video encoding included) and reports each stage's wall time per
rendered frame and its share of the loop, and the real-time factor (simulated seconds per wall
second). Shares are ratios within one run, so they stay meaningful on a loaded machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path
from typing import Any


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", type=Path, default=Path("configs/demo.toml"),
                        help="config to run (default: configs/demo.toml)")
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds (default 10)")
    parser.add_argument("--width", type=int, default=None, help="render width (default: the config's)")
    parser.add_argument("--height", type=int, default=None, help="render height (default: the config's)")
    parser.add_argument("--seed", type=int, default=None)


def run(args: argparse.Namespace) -> dict[str, Any]:
    from jostle.app import App, RunOptions
    from jostle.config import load_config

    config = load_config(args.config)
    render = config.render
    if args.width or args.height:
        render = dataclasses.replace(render, width=args.width or render.width, height=args.height or render.height)
        config = dataclasses.replace(config, render=render)
    with tempfile.TemporaryDirectory() as tmp:
        app = App(config, RunOptions(out_dir=Path(tmp), seed=args.seed, duration_s=args.seconds, progress=False))
        start = time.perf_counter()
        summary = app.run()
        wall = time.perf_counter() - start
    frames = max(summary.frames_rendered, 1)
    loop = sum(app.stage_seconds.values())
    figures: dict[str, Any] = {
        "config": str(args.config),
        "characters": summary.characters,
        "width": render.width,
        "height": render.height,
        "sim_seconds": round(summary.sim_seconds, 3),
        "wall_seconds": round(wall, 3),
        "realtime_factor": round(summary.sim_seconds / wall, 3) if wall > 0 else None,
        "frames": summary.frames_rendered,
        "sensor_frames": summary.sensor_frames,
        "setup_seconds": round(wall - loop, 3),
    }
    for stage, seconds in app.stage_seconds.items():
        figures[f"{stage}_ms_per_frame"] = round(1000.0 * seconds / frames, 3)
    for stage, seconds in app.stage_seconds.items():
        figures[f"{stage}_share"] = round(seconds / loop, 3) if loop > 0 else None
    figures["pushes"] = summary.pushes
    figures["falls"] = summary.falls
    return figures
