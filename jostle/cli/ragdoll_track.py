"""``jostle ragdoll track CLIP``: how well the articulated character walks a real capture, and how much
help from outside its joints it took.

The character is the DeepMimic humanoid (``configs/characters/ragdoll.toml``'s body and controller,
``sim.articulated``) tracking CLIP: a pybullet clip name, or a file (a BVH of any common rig,
retargeted, cut to its best loop and looped: ``sim.motion.clips``), or with ``--body bvh`` the BVH's
own body tracking its own motion (``sim.articulated.bvh_body.bvh_character``). It runs ``--seconds`` of simulated
time on the world's physics step; ``--push N`` pushes its root N times (150 N for 0.2 s, sideways,
alternating, evenly spaced); ``--no-assist`` sets every root assist of the spec to 0. Reported:
falls (entries into the fall state), get-ups (stand-ups that end walking), the tracking error (degrees,
sampled at 30 Hz while walking or staggering: mean and 95th percentile; null if it never walked), the realtime factor
(simulated ÷ wall seconds), and the root assist: walking torque mean and peak, peak force (any state).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

PUSH_N = 150.0
PUSH_S = 0.2
NO_ASSIST = ("assist_torque_max_nm", "assist_force_max_n", "getup_assist_force_max_n", "getup_assist_torque_max_nm",
             "getup_place_force_n", "walk_in_force_n", "walk_in_force_faceup_n", "recovery_assist_torque_max_nm")


def add(rs: Any, raw: type[argparse.HelpFormatter]) -> None:
    t = rs.add_parser(
        "track", help="walk a clip (a BVH of any rig) with the articulated character: falls, error, assist",
        formatter_class=raw, description=(__doc__ or "").split("\n\n", 1)[1],
        epilog="examples:\n  jostle ragdoll track walk --seconds 20 --json\n"
        "  jostle ragdoll track tests/fixtures/bvh/002_01_excerpt.bvh --seconds 20 --no-assist --json",
    )
    t.add_argument("clip", metavar="CLIP", help="a pybullet clip name (walk, run) or a .bvh/.txt file")
    t.add_argument("--seconds", type=float, default=20.0, metavar="S", help="simulated seconds (default 20)")
    t.add_argument("--push", type=int, default=0, metavar="N", help="push the character N times (default 0)")
    t.add_argument("--no-assist", action="store_true", help="no root assist at all (torque, force, get-up help)")
    t.add_argument("--body", choices=("humanoid", "bvh"), default="humanoid",
                   help="humanoid: the DeepMimic humanoid tracks the retargeted clip (default); bvh: the BVH "
                        "file's own body (every joint a link, sim.articulated.bvh_body) tracks its own motion")
    t.add_argument("--json", action="store_true", help="print the figures as JSON")
    t.set_defaults(func=cmd_track)


def cmd_track(args: argparse.Namespace) -> int:
    from jostle.errors import UsageError

    if not (math.isfinite(args.seconds) and 0 < args.seconds <= 3600):
        raise UsageError(f"--seconds: expected 0 < S <= 3600, got {args.seconds}")
    if not 0 <= args.push <= 1000:
        raise UsageError(f"--push: expected 0..1000 pushes, got {args.push}")
    if args.body == "bvh" and not args.clip.lower().endswith(".bvh"):
        raise UsageError(f"--body bvh: expected a .bvh CLIP, got {args.clip!r}")
    row = track(args.clip, args.seconds, args.push, not args.no_assist, args.body)
    if args.json:
        print(json.dumps(row, indent=2))
    else:
        print(" ".join(f"{k}={v}" for k, v in row.items()))
    return 0


def track(clip_ref: str, seconds: float, pushes: int, assist: bool, body: str = "humanoid") -> dict[str, Any]:
    """The figures of the module docstring for one run (see there); ``body``: see ``--body``."""
    from jostle.bench.ragdoll_baseline import BenchSim
    from jostle.bench.ragdoll_walk import run_steps
    from sim.articulated.character import ArticulatedCharacter
    from sim.articulated.skeleton import deepmimic_humanoid
    from sim.articulated.spec import ArticulatedSpec
    from sim.motion.clips import is_motion_file, load_motion

    if body == "bvh":
        from sim.articulated.bvh_body import bvh_character

        skeleton, clip = bvh_character(clip_ref)
    else:
        skeleton, clip = deepmimic_humanoid(), load_motion(clip_ref, "CLIP", cycle=True)
    height = _source_height(clip_ref) if is_motion_file(clip_ref) and clip_ref.lower().endswith(".bvh") else 1.65
    spec = ArticulatedSpec()
    if not assist:
        zero: dict[str, Any] = {k: 0.0 for k in NO_ASSIST}
        spec = dataclasses.replace(spec, **zero)
    sim = BenchSim.open()
    try:
        char = ArticulatedCharacter(sim.client, skeleton, spec, clip, (0.0, 0.0), 0.0)
        steps = round(seconds / sim.dt)
        every = max(1, round(1.0 / 30.0 / sim.dt))
        push_at = {round(steps * (k + 1) / (pushes + 1)): k for k in range(pushes)}
        errors: list[float] = []
        torques: list[float] = []
        states = [str(char.state)]
        falls = getups = 0

        def each(s: int) -> None:
            nonlocal falls, getups
            if s in push_at:
                side = 1.0 if push_at[s] % 2 == 0 else -1.0
                char.push(0, (0.0, side * PUSH_N, 0.0), PUSH_S)  # link 0: the pelvis
            now = str(char.state)
            if now != states[-1]:
                falls += now == "fall"
                getups += states[-1] == "stand_up" and now in ("walk", "stagger")
                states.append(now)
            if s % every == 0:
                if now in ("walk", "stagger"):
                    errors.append(char.tracking_error_deg())
                    torques.append(float(char.external_assist_nm))

        wall = time.perf_counter()
        run_steps(sim, [char], steps, each)
        wall = time.perf_counter() - wall
        err = np.asarray(errors) if errors else None  # None: never walking (JSON has no NaN)
        return {
            "clip": Path(clip_ref).name, "body": body, "seconds": round(steps * sim.dt, 3), "height_m": round(height, 3),
            "clip_loop_s": round(clip.duration, 3), "falls": falls, "getups": getups,
            "tracking_error_deg_mean": None if err is None else round(float(np.mean(err)), 2),
            "tracking_error_deg_p95": None if err is None else round(float(np.percentile(err, 95)), 2),
            "realtime_factor": round(steps * sim.dt / max(wall, 1e-9), 2),
            "assist_torque_nm_mean": round(float(np.mean(torques)) if torques else 0.0, 1),
            "assist_torque_nm_max": round(float(char.external_assist_peak_nm), 1),
            "assist_force_n_max": round(float(char.external_assist_peak_n), 1),
        }
    finally:
        sim.close()


def _source_height(ref: str) -> float:
    """The BVH's standing height in metres (``sim.motion.joint_map``)."""
    from sim.motion.bvh import read_bvh
    from sim.motion.joint_map import map_joints

    motion = read_bvh(ref)
    return map_joints(motion, source=ref).height_m
