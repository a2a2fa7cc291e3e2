"""How long the virtual sensors take per frame (for ``jostle bench``: ``add_arguments`` and ``run``).

People cross the stage; each virtual sensor is read over the same stretch of the performance
(people in view) and timed. The baseline is pybullet's TINY renderer drawing an empty scene at
the same size in the same run, so the figures can be compared between machines as ratios.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from typing import Any


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--width", type=int, default=640, help="image width of both cameras (default 640)")
    parser.add_argument("--height", type=int, default=400, help="image height of both cameras (default 400)")
    parser.add_argument("--people", type=int, default=2, help="people crossing the stage, 1-4 (default 2)")
    parser.add_argument("--frames", type=int, default=20, help="frames timed per sensor (default 20)")


def _per_frame_ms(sensor: Any, clock: Any, start_s: float, frames: int) -> float:
    with sensor:
        clock.advance(start_s)
        while sensor.read(0.0) is not None:  # skip to the stretch with people in view
            pass
        began = time.perf_counter()
        done = 0
        while done < frames:
            clock.advance(1.0 / sensor.rate_hz)
            if sensor.read(0.0) is not None:
                done += 1
        return 1000.0 * (time.perf_counter() - began) / frames


def run(args: argparse.Namespace) -> dict[str, object]:
    import pybullet as pb

    from jostle.performer.config import DepthCameraConfig, PerformerConfig
    from jostle.performer.depth import PerformerDepth
    from jostle.performer.pads import PerformerPads, default_pad_layout
    from jostle.performer.performer import PerformerSensor
    from jostle.performer.scene import Performance
    from sensors.clock import SimClock

    w, h, n = args.width, args.height, args.frames
    people = PerformerConfig(people=args.people, route="crossing" if args.people > 1 else "round",
                             duration_s=60.0, empty_s=1.0, width=w, height=h, fps=15.0)
    start = 3.0 if args.people > 1 else 6.0
    oak = DepthCameraConfig(width=w, height=h, fps=15.0)
    client = pb.connect(pb.DIRECT)
    try:
        began = time.perf_counter()
        for _ in range(n):
            pb.getCameraImage(w, h, renderer=pb.ER_TINY_RENDERER, physicsClientId=client)
        empty_ms = 1000.0 * (time.perf_counter() - began) / n
    finally:
        pb.disconnect(client)
    figures: dict[str, object] = {"size": f"{w}x{h}", "people": args.people, "tiny_renderer_empty_ms": empty_ms}
    clock = SimClock()
    figures["webcam_ms_per_frame"] = _per_frame_ms(PerformerSensor(people, clock), clock, start, n)
    clock = SimClock()
    depth = PerformerDepth(Performance(people), dataclasses.replace(oak, color=False), clock)
    figures["oak_depth_ms_per_frame"] = _per_frame_ms(depth, clock, start, n)
    clock = SimClock()
    figures["oak_depth_and_colour_ms_per_frame"] = _per_frame_ms(PerformerDepth(Performance(people), oak, clock),
                                                                 clock, start, n)
    clock = SimClock()
    pads = PerformerPads(Performance(people), default_pad_layout(), clock)
    figures["pads_ms_per_sample"] = _per_frame_ms(pads, clock, start, 10 * n)
    figures["oak_depth_and_colour_vs_empty_render"] = float(figures["oak_depth_and_colour_ms_per_frame"]) / empty_ms  # type: ignore[arg-type]
    return figures
