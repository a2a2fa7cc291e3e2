"""``jostle bench identify``: the observer experiment, watching the *drawn* character.

The experiment and the observer are ``jostle.bench.identify_experiment``'s; this module (jostle may import render)
gives the observer what a viewer of the installation sees: the joint positions of the figure the
keyframe set draws for each snapshot — the correspondence function ``render.keyframes
.query_from_snapshot``, the set's pose, forward kinematics of ``sim.motion.mocap.HUMANOID``, scaled to the
character's height and placed with the body's position and orientation — in the heading frame at the
push. The viewer's eye adds 2 cm of noise to every joint position of every sample. The rigid body's own
position and orientation are scored too (``body``), so the two views can be compared in one run.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from jostle.bench import identify_experiment as bench_identify

if TYPE_CHECKING:
    import numpy as np

    from jostle.bench.identify_experiment import Trial
    from render.keyframes import KeyframeSet

DEFAULT_SET = Path(__file__).resolve().parents[2] / "configs" / "keyframes" / "humanoid" / "keyframes.toml"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    bench_identify.add_arguments(parser)
    parser.add_argument("--keyframes", type=Path, default=DEFAULT_SET,
                        help="keyframe set drawing the character (default: the shipped humanoid)")


def pose_view(keyframes: KeyframeSet) -> Any:
    """A ``jostle.bench.identify_experiment.View``: the drawn figure's joint positions (T, joints, 3), no angles."""
    import math

    import numpy as np

    from render.keyframes import query_from_snapshot
    from sim.frames import frames
    from sim.motion.mocap import HUMANOID

    # skeleton axes (x forward, y up, z right) → body axes (x forward, y left, z up)
    skeleton_to_body = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

    def view(trial: Trial) -> tuple[np.ndarray, np.ndarray]:
        track = trial.track
        poses = keyframes.poses([query_from_snapshot(c) for c in track])
        joints, _ = HUMANOID.forward_kinematics(poses.root_offset, poses.root_rotation, poses.joint_rotations)
        scale = track[0].height / keyframes.height
        local = scale * joints @ skeleton_to_body.T  # (T, B, 3) body frame, from the centre of mass
        rot = frames(np.array([c.orientation for c in track])).rotation()  # (T, 3, 3) body → stage
        stage = np.array([c.position for c in track])[:, None, :] + np.einsum("tij,tbj->tbi", rot, local)
        c, s = math.cos(trial.heading), math.sin(trial.heading)
        rel = stage - np.asarray(trial.origin)
        out = np.stack([c * rel[..., 0] + s * rel[..., 1], -s * rel[..., 0] + c * rel[..., 1], rel[..., 2]],
                       axis=-1)
        return out, np.zeros((len(track), 0))

    return view


def run(args: argparse.Namespace) -> dict[str, Any]:
    import math

    from render.keyframes import KeyframeSet

    try:
        keyframes = KeyframeSet.load(args.keyframes)
        spec = bench_identify.load_spec(args.character)
        trials = bench_identify.run_trials(args.repetitions, args.weak, args.strong, args.seed, spec)
    except ValueError as e:  # a bad flag or file (KeyframeError is one): one line, not a traceback
        raise SystemExit(f"jostle bench identify: {e}") from None
    noise_m, noise_rad = args.noise_cm / 100.0, math.radians(args.noise_deg)
    figures = bench_identify.score(trials, pose_view(keyframes), noise_m, noise_rad, args.seed, weak=args.weak,
                                   strong=args.strong, view_name=f"joint positions of the figure drawn by {args.keyframes.name}")
    body = bench_identify.accuracies(trials, bench_identify.body_view, noise_m, noise_rad, args.seed)
    return {**figures, "body": body}
