"""``jostle bench render``: headless frame rate (with read-back) and pose evaluation cost for N characters.

The characters stand on the stage at seeded random places, headings, tilts (walking, staggering,
some fallen) and phases, all moving between frames, one person's contactors among them; every
frame is the whole ``Renderer.draw`` — pose evaluation, forward kinematics, upload, drawing and the
read-back of the BGR frame. ``pose_eval_us_per_character`` times ``KeyframeSet.evaluate`` alone (the
keyframe weights and the quaternion blend). ``frame_ms_*`` are over the measured frames; the machine is
shared, so the median is the figure to trust. ``baseline_empty_ms`` is an empty stage drawn in the same
run (the fixed cost of copying the stage and reading the frame back).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

DEFAULT_SET = Path(__file__).resolve().parents[2] / "configs" / "keyframes" / "humanoid" / "keyframes.toml"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--characters", type=int, default=50, metavar="N", help="characters on stage (default 50)")
    parser.add_argument("--width", type=int, default=1280, help="frame width in pixels (default 1280)")
    parser.add_argument("--height", type=int, default=720, help="frame height in pixels (default 720)")
    parser.add_argument("--frames", type=int, default=120, metavar="F", help="frames to time (default 120)")
    parser.add_argument("--keyframes", type=Path, default=DEFAULT_SET, metavar="SET",
                        help="keyframe set manifest (default: the shipped humanoid set)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scale", type=float, default=1.0, metavar="S",
                        help="render_scale: draw at S × the size and scale up (default 1)")


def scene(n: int, seed: int, t: float) -> tuple[Any, Any]:
    """A snapshot of n characters and one person's observation at time t (deterministic)."""
    from interaction.types import BodyObservation, Contactor
    from sim.snapshot import CharacterSnapshot, CharacterState, WorldSnapshot

    rng = np.random.default_rng(seed)
    chars = []
    for i in range(n):
        x, y = rng.uniform(-2.8, 2.8), rng.uniform(-1.0, 1.0)
        heading = rng.uniform(-math.pi, math.pi)
        fallen = i % 10 == 9
        tx = (1.45 if i % 20 == 9 else -1.45) if fallen else 0.25 * math.sin(1.3 * t + i)
        tz = 0.0 if fallen else 0.2 * math.sin(0.7 * t + 2 * i)
        body = _tilted(heading, tx, tz)
        chars.append(CharacterSnapshot(
            name=f"c{i}", position=(x, y, 0.25 if fallen else 0.75), orientation=body,
            velocity=(0.6 * math.cos(heading), 0.6 * math.sin(heading), 0.0), angular_velocity=(0.0, 0.0, 0.0),
            heading=heading, tilt=(tx, tz), d_front=0.8 * t + rng.uniform(0, 1), d_side=0.1 * t,
            state=CharacterState.LIE if fallen else CharacterState.WALK, behaviour="walk", intent="wander",
            face_up=(tx < 0) if fallen else None, contact_force_n=60.0 if i == 0 else 0.0, height=1.5,
        ))
    person = BodyObservation(t, (Contactor(0, "outline", (0.3 * math.sin(t), 0.0, 1.0), (0.0, 0.0, 0.0), 0.25, 1.0),
                                 Contactor(0, "hand", (0.6 * math.sin(t), 0.0, 1.3), (0.0, 0.0, 0.0), 0.1, 1.0)), (), 1)
    return WorldSnapshot(t=t, steps=0, characters=tuple(chars)), person


def _tilted(heading: float, tx: float, tz: float) -> tuple[float, float, float, float]:
    """Body orientation (x y z w): yaw by heading about z, then lean forward by tx and right by tz."""
    from sim.motion import quaternion as quat

    yaw = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), heading)
    pitch = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), tx)  # forward: +x tips down about body +y
    roll = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), tz)  # right: about +x (y is left)
    q = quat.multiply(yaw, quat.multiply(pitch, roll))
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def run(args: argparse.Namespace) -> dict[str, Any]:
    from render.gl.renderer import Renderer
    from render.keyframes import KeyframeSet

    n, frames = int(args.characters), int(args.frames)
    if n < 0 or frames < 1:
        raise ValueError("characters: expected ≥ 0 and frames ≥ 1")
    kset = KeyframeSet.load(args.keyframes)
    snaps = [scene(n, args.seed, 0.05 * i) for i in range(8)]
    from render.gl.style import Look, RenderStyle

    style = RenderStyle(look=Look(render_scale=float(args.scale)))
    with Renderer(args.width, args.height, headless=True, style=style) as renderer:
        empty, _ = scene(0, args.seed, 0.0)
        for _ in range(5):
            renderer.draw(empty, None, kset)
        base = []
        for _ in range(min(frames, 30)):
            t0 = time.perf_counter()
            renderer.draw(empty, None, kset)
            base.append(time.perf_counter() - t0)
        for s, obs in snaps:
            renderer.draw(s, obs, kset)
        times = []
        for i in range(frames):
            s, obs = snaps[i % len(snaps)]
            t0 = time.perf_counter()
            renderer.draw(s, obs, kset)
            times.append(time.perf_counter() - t0)
    qs = [kset.snapshot_array(s.characters) for s, _ in snaps]
    behaviours = [c.behaviour for c in snaps[0][0].characters]
    pose = []
    for i in range(max(20, frames // 2)):
        t0 = time.perf_counter()
        kset.evaluate(qs[i % len(qs)], behaviours)
        pose.append(time.perf_counter() - t0)
    ms = np.array(times) * 1e3
    return {
        "characters": n,
        "width": int(args.width),
        "height": int(args.height),
        "frames": frames,
        "render_scale": float(args.scale),
        "fps": round(1000.0 / float(np.median(ms)), 1),
        "frame_ms_p50": round(float(np.percentile(ms, 50)), 3),
        "frame_ms_p99": round(float(np.percentile(ms, 99)), 3),
        "baseline_empty_ms": round(float(np.median(base)) * 1e3, 3),
        "pose_eval_us_per_character": round(float(np.median(pose)) * 1e6 / max(n, 1), 2),
    }
