"""The two benchmarks of issue B run and report what they promise (small sizes; timings are not judged)."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

from jostle.bench import identify_experiment as bench_identify
from jostle.bench import sim as bench
from jostle.bench.identify_experiment import THETA_DIR, THETA_POS, Trial, body_view, run_trials


def _args(module: object, argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    module.add_arguments(parser)  # type: ignore[attr-defined]
    return parser.parse_args(argv)


def test_bench_sim_reports_both_sides_of_the_same_run() -> None:
    out = bench.run(_args(bench, ["--characters", "12", "--seconds", "0.5"]))
    for key in ("characters", "physics_hz", "sim_seconds", "wall_seconds", "realtime_factor", "bare_step_us",
                "jostle_step_us", "overhead_ratio", "control_hz"):
        assert key in out, key
    assert out["characters"] == 12 and out["physics_hz"] == 240.0 and out["control_hz"] == 30.0
    assert out["sim_seconds"] == pytest.approx(0.5)
    assert out["bare_step_us"] > 0 and out["jostle_step_us"] > 0
    assert out["overhead_ratio"] == pytest.approx(out["jostle_step_us"] / out["bare_step_us"], rel=1e-2)
    assert out["realtime_factor"] == pytest.approx(out["sim_seconds"] / out["wall_seconds"], rel=1e-2)
    assert out["bare_still_upright"] == 12 and out["bare_upright"] == 12  # the baselines stayed upright bodies
    assert out["characters_upright_at_end"] == 12 and out["recovered_characters"] == 0


def test_bench_sim_control_rate_is_a_flag() -> None:
    out = bench.measure(4, 0.2, physics_hz=240.0, control_hz=60.0)
    assert out["control_hz"] == 60.0
    with pytest.raises(ValueError, match="control_dt"):
        bench.measure(4, 0.2, physics_hz=240.0, control_hz=50.0)


@pytest.fixture(scope="module")
def trials() -> list[Trial]:
    return run_trials(4, 15.0, 45.0, seed=3)


def test_identify_trials_cover_the_grid_and_record_only_the_view(trials: list[Trial]) -> None:
    assert len(trials) == 4 * 54
    cells = {t.label for t in trials}
    assert {c[0] for c in cells} == set(THETA_POS) and {c[1] for c in cells} == set(THETA_DIR)
    assert len({t.speed for t in trials}) > 1 and len({round(t.heading, 3) for t in trials}) > 50
    t = trials[0]
    pos, ang = body_view(t)
    samples = round((bench_identify.BEFORE_S + bench_identify.AFTER_S) * bench_identify.RATE_HZ) + 1
    assert pos.shape == (samples, 1, 3) and ang.shape == (samples, 3)
    push = round(bench_identify.BEFORE_S * bench_identify.RATE_HZ)
    assert np.allclose(pos[push, 0], 0.0) and abs(ang[push, 0]) < 1e-9  # the heading frame at the push
    assert np.all(pos[:push, 0, 0] < 0.0)  # before the push it was walking forward, toward the origin


def _strong_from_front(trials: list[Trial], h: float) -> Trial:
    return next(t for t in trials if t.label == (0, 0, h, True))


def test_identify_pushes_do_what_the_grid_says(trials: list[Trial]) -> None:
    # pushed from the front, straight at the axis: it goes back and does not turn
    pos, ang = body_view(_strong_from_front(trials, 1.0))
    push = round(bench_identify.BEFORE_S * bench_identify.RATE_HZ)
    after = push + 10
    t = _strong_from_front(trials, 1.0)
    assert pos[after, 0, 0] < t.speed * 10 / bench_identify.RATE_HZ - 0.1
    # off-centre pushes turn it the way the moment says: θdir > 0 turns it clockwise (yaw < 0)
    for sign in (1, -1):
        turned = [body_view(t)[1][push + 15, 0] for t in trials if t.label == (0, 45 * sign, 1.0, False)]
        assert all(math.copysign(1.0, y) == -sign for y in turned), turned


def test_bench_identify_reports_table_1() -> None:
    out = bench_identify.run(_args(bench_identify, ["--repetitions", "4"]))
    for key in ("theta_pos", "theta_dir_plus_pos", "h", "magnitude", "exact", "trials", "weak_impulse_ns",
                "strong_impulse_ns"):
        assert key in out, key
    assert out["trials"] == 216 and out["weak_impulse_ns"] == 15.0 and out["strong_impulse_ns"] == 45.0
    assert set(out["exact"]) == {"theta_pos", "theta_dir_plus_pos", "h", "magnitude"}
    # far above chance (1/3, 1/3, 1/3, 1/2) even with two training repetitions per cell
    assert min(out["exact"].values()) > 0.9
    assert out["magnitude"] > 0.9 and min(out[k] for k in ("theta_pos", "theta_dir_plus_pos", "h")) > 0.6


def test_the_drawn_figure_view_places_joints_on_the_body(trials: list[Trial]) -> None:
    """jostle's variant watches the keyframed figure: joints in the heading frame at the push."""
    from jostle.bench.identify import DEFAULT_SET, pose_view
    from render.keyframes import KeyframeSet
    from sim.motion.mocap import HUMANOID

    trial = trials[0]
    joints, angles = pose_view(KeyframeSet.load(DEFAULT_SET))(trial)
    assert joints.shape == (len(trial.track), len(HUMANOID.names), 3) and angles.shape == (len(trial.track), 0)
    push = round(bench_identify.BEFORE_S * bench_identify.RATE_HZ)
    head, toes = HUMANOID.names.index("head_top"), HUMANOID.names.index("left_toe")
    height = trial.track[0].height
    assert joints[push, head, 2] - joints[push, toes, 2] == pytest.approx(height, rel=0.15)  # upright, to scale
    assert np.hypot(*joints[push, :, :2].mean(axis=0)) < 0.3  # around the body's centre of mass
