"""``jostle bench ragdoll``: articulated characters (issue 9) against pybullet's own DeepMimic humanoid.

In one process, on the world's physics settings (``sim.physics.open_client``, 1/240 s):

1. walking (:mod:`jostle.bench.ragdoll_walk`): N characters walk the clip for ``--seconds``, timed turn
   about with N DeepMimic humanoids under pybullet's STABLE_PD_CONTROL (:mod:`jostle.bench.ragdoll_baseline`):
   ``realtime_factor``, ``cost_ratio_vs_baseline``, ``tracking_error_deg`` (degrees) and, with one walker
   kept recovering, ``recovery_cost_ratio``;
2. pushes (:mod:`jostle.bench.ragdoll_pushes`): forward and sideways, at ``--phases`` walking phases, of
   rising strength until it falls: ``max_survived_*_n`` (N), then ``getup_success`` and ``walkoff_success``
   (fractions), the largest external assist (``external_assist_n``, ``external_assist_nm``) and joint-limit
   excess (``joint_limit_excess_deg`` and ``joint_limit_excess_deg_<when>``, degrees).

Details (per phase, the baseline's fall time) go to stderr; the figures are ``KEYS`` and ``EXTRA_KEYS``.
What each figure means, step by step: docs/benches.md.
"""

from __future__ import annotations

import argparse
import copy
import math
from typing import Any

from jostle.bench.ragdoll_baseline import baseline_slices, log
from jostle.bench.ragdoll_pushes import EXCESS_WHEN, WALK_ON_M, WALK_ON_S, Worst, push_test
from jostle.bench.ragdoll_walk import interleaved, walking_slices

KEYS = ("characters", "physics_hz", "realtime_factor", "cost_ratio_vs_baseline", "tracking_error_deg",
        "max_survived_forward_n", "max_survived_side_n", "getup_success", "external_assist_n")
EXTRA_KEYS = ("external_assist_nm", "walkoff_success", "recovery_substeps", "recovery_cost_ratio",  # beyond the
              "joint_limit_excess_deg", *(f"joint_limit_excess_deg_{when}" for when in EXCESS_WHEN))  # issue's keys
SLICE_S = 1.0  # the walkers and the baseline run turn about, this many simulated seconds at a time


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--characters", type=int, default=4, metavar="N", help="walking characters (default 4)")
    parser.add_argument("--seconds", type=float, default=10.0, metavar="S", help="walking time (default 10)")
    parser.add_argument("--phases", type=int, default=4, metavar="K", help="walking phases pushed (default 4)")
    parser.add_argument("--warmup", type=float, default=2.0, metavar="S", help="walking before the first phase")
    parser.add_argument("--push-start", type=float, default=20.0, metavar="N", help="first push strength")
    parser.add_argument("--push-step", type=float, default=20.0, metavar="N", help="push strength step (20)")
    parser.add_argument("--push-max", type=float, default=1000.0, metavar="N", help="strongest push tried")
    parser.add_argument("--after", type=float, default=3.0, metavar="S", help="watch this long after a push")
    parser.add_argument("--getup-window", type=float, default=8.0, metavar="S", help="time to stand again")
    parser.add_argument("--recovery-substeps", type=int, default=None, metavar="N",
                        help="physics steps per step while a character recovers (default: the character's, 8, "
                             "which holds the joint limits; 1: never finer; sim.articulated.recovery)")
    parser.add_argument("--clip", default=None, metavar="CLIP",
                        help="the walk the characters track: a pybullet clip name or a file (.bvh of any common "
                             "rig, cut to its best loop; .txt) (default: walk; the stable-PD baseline keeps walk)")
    parser.add_argument("--quick", action="store_true",
                        help="tiny settings for tests: 1 character, 0.5 s, 1 phase, one 600 N push")


def _settings(args: argparse.Namespace) -> argparse.Namespace:
    s = copy.copy(args)
    if args.quick:
        s.characters, s.seconds, s.phases, s.warmup = 1, 0.5, 1, 0.3
        s.push_start = s.push_max = 600.0
        s.after, s.getup_window = 0.5, 0.5
    for name in ("characters", "phases"):
        if getattr(s, name) < 1:
            raise ValueError(f"--{name}: expected a whole number >= 1, got {getattr(s, name)}")
    for name in ("seconds", "push_step", "after", "getup_window"):
        v = getattr(s, name)
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"--{name.replace('_', '-')}: expected a number > 0, got {v}")
    if not 0 <= s.push_start <= s.push_max or s.warmup < 0:
        raise ValueError(f"--push-start: expected 0 <= start <= --push-max={s.push_max}, got {s.push_start}")
    s.spec = character_spec(s)
    return s


def character_spec(args: argparse.Namespace) -> Any:
    """The characters' spec: the default one, with ``--recovery-substeps`` and ``--clip`` when given."""
    from sim.articulated.spec import ArticulatedSpec
    from sim.motion.clips import load_motion

    given: dict[str, Any] = {}
    if getattr(args, "clip", None):
        load_motion(args.clip, "--clip", cycle=True)  # a MotionFileError naming the flag and the file
        given["walk_clip"] = args.clip
    try:
        if args.recovery_substeps is not None:
            given["recovery_substeps"] = args.recovery_substeps
        return ArticulatedSpec(**given)
    except ValueError as e:  # "recovery_substeps: expected …" said as the flag
        raise ValueError("--" + str(e).replace("recovery_substeps", "recovery-substeps", 1)) from None


def run(args: argparse.Namespace) -> dict[str, object]:
    from jostle.quiet import import_pybullet_quietly

    import_pybullet_quietly()
    s = _settings(args)
    from sim.config import WorldConfig

    hz = 1.0 / WorldConfig().physics_dt
    worst = Worst()
    slices = max(1, math.ceil(s.seconds / SLICE_S))
    runs = [walking_slices(s.characters, s.seconds, slices, s.spec), baseline_slices(s.characters, s.seconds, slices)]
    if s.spec.recovery_substeps > 1:  # what recovering costs: the same walkers, one of them kept recovering
        runs.append(walking_slices(s.characters, s.seconds, slices, s.spec, recovering=True))
    timed = interleaved(runs)
    (wall, simulated, error, assist_n, assist_nm), base = timed[0][1], timed[1][0]
    forward, per_fwd, up_fwd, on_fwd, peak_fwd = push_test(s, side=False, worst=worst)
    sideways, per_side, up_side, on_side, peak_side = push_test(s, side=True, worst=worst)
    assist_n = max(assist_n, peak_fwd[0], peak_side[0])
    assist_nm = max(assist_nm, peak_fwd[1], peak_side[1])
    log(f"pushes survived per phase (N): forward {per_fwd}, sideways {per_side}; the figures are the minimum")
    getups, walkoffs = up_fwd + up_side, on_fwd + on_side
    log(f"falls {len(getups)}, stood again within {s.getup_window:g} s: {sum(getups)}, then walked on "
        f"{WALK_ON_M:g} m in {WALK_ON_S:g} s: {sum(walkoffs)}; peak assist torque {assist_nm:.1f} N·m")
    figures: dict[str, object] = {
        "characters": s.characters,
        "physics_hz": round(hz, 3),
        "realtime_factor": round(simulated / wall, 3) if wall > 0 else None,
        "cost_ratio_vs_baseline": round(wall / base, 3) if base > 0 else None,
        "tracking_error_deg": round(error, 2) if math.isfinite(error) else None,
        "max_survived_forward_n": forward,
        "max_survived_side_n": sideways,
        "getup_success": round(sum(getups) / len(getups), 3) if getups else None,
        "external_assist_n": round(assist_n, 1),
        "external_assist_nm": round(assist_nm, 1),
        "walkoff_success": round(sum(walkoffs) / len(walkoffs), 3) if walkoffs else None,
        "recovery_substeps": s.spec.recovery_substeps,
        "recovery_cost_ratio": round(timed[2][0] / timed[0][0], 3) if len(timed) > 2 and timed[0][0] > 0 else None,
        "joint_limit_excess_deg": round(math.degrees(worst.rad), 2),
        **{f"joint_limit_excess_deg_{when}": round(math.degrees(rad), 2) for when, rad in worst.by_when.items()},
    }
    return figures
