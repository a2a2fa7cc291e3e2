"""The bench's two velocity references (jostle.bench.truth, jostle.bench.interaction): a contactor's
velocity is scored against the part's true velocity at the frame's instant and, apart, against the
part's true motion over the last frame interval, so the tracker's own error shows beside the frame
rate's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interaction.types import BodyObservation, Contactor
from jostle.bench import interaction as bench_interaction
from jostle.bench.truth import LinearCeiling, body_part_centres, true_steps
from jostle.performer.truth import PersonTruth, TruthFrame
from sim.motion.mocap import HUMANOID

OMEGA, DT = 0.5, 1 / 15  # a rigid body turning about a vertical axis 10 m away: parts move ≈ 5 m/s


def _turning_body(t: float, pid: int = 7) -> TruthFrame:
    body = np.random.default_rng(3).normal(0.0, 0.3, (len(HUMANOID.names), 3))
    body[:, 0] += 10.0
    c, s = math.cos(OMEGA * t), math.sin(OMEGA * t)
    joints = body @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T
    velocities = OMEGA * np.stack([-joints[:, 1], joints[:, 0], np.zeros(len(joints))], axis=1)
    return TruthFrame(t=t, seq=round(t * 15), people=(PersonTruth(pid, 1.0, 70.0, True, joints, velocities),))


def _observation(now: TruthFrame, velocity_of: dict[str, list[np.ndarray]]) -> BodyObservation:
    """A contactor exactly at each true hand and foot, moving as ``velocity_of[part][side]`` says."""
    contactors = []
    for part in ("hand", "foot"):
        for side, (pos, _) in enumerate(body_part_centres(now.people[0], part)):
            v = velocity_of[part][side]
            contactors.append(Contactor(7, part, tuple(pos), tuple(v), 0.05))
    return BodyObservation(now.t, tuple(contactors), (), 1)


def test_true_steps_are_each_parts_chord_over_the_frame_interval() -> None:
    before, now = _turning_body(1.0), _turning_body(1.0 + DT)
    steps = true_steps(before, now, "hand")
    assert set(steps) == {(7, "hand", 0), (7, "hand", 1)}
    for side, ((p1, _), (p0, _)) in enumerate(zip(body_part_centres(now.people[0], "hand"),
                                                 body_part_centres(before.people[0], "hand"), strict=True)):
        assert np.allclose(steps[(7, "hand", side)], (p1 - p0) / DT)
    assert true_steps(_turning_body(1.0, pid=8), now, "hand") == {}  # someone else before: no step
    assert true_steps(now, now, "foot") == {}  # no time between


def test_a_tracker_that_claims_the_frame_step_is_exact_against_it_and_off_by_the_turn_against_the_instant() -> None:
    before, now = _turning_body(1.0), _turning_body(1.0 + DT)
    claims = {part: [true_steps(before, now, part)[(7, part, side)] for side in (0, 1)] for part in ("hand", "foot")}
    scores = bench_interaction._Scores()
    bench_interaction._depth_errors(_observation(now, claims), now, before, scores)
    assert len(scores.angle) == len(scores.angle_vs_step) == 4
    assert max(scores.angle_vs_step) < 1e-3
    # a chord is off the tangent at its end by half the angle it spans (+ ≈ 0.1° for the hand's 2 cm offset)
    assert np.allclose(scores.angle, math.degrees(OMEGA * DT / 2), atol=0.2)
    assert max(scores.depth_error) < 1e-9


def test_withheld_velocities_are_counted_not_scored() -> None:
    before, now = _turning_body(1.0), _turning_body(1.0 + DT)
    zero = {part: [np.zeros(3), np.zeros(3)] for part in ("hand", "foot")}
    scores = bench_interaction._Scores()
    bench_interaction._depth_errors(_observation(now, zero), now, before, scores)
    assert scores.withheld == 4 and scores.angle == [] and scores.angle_vs_step == []
    figures = scores.figures()
    assert figures["velocity_direction_error_deg_p95_vs_frame_step"] is None and figures["velocity_withheld"] == 4


def test_the_best_linear_weighting_follows_a_steady_turn_exactly_where_a_frame_step_is_off_by_half_of_it() -> None:
    """On a body turning steadily, three or more past positions weighted right give the tangent exactly
    (the ceiling is 0), while two (the frame step) lag half the turn of a frame; a dropped frame and a new
    recording break the history, and samples not scored (learning) are not counted."""
    frames = [_turning_body(1.0 + i * DT) for i in range(12)]
    ceiling = LinearCeiling(taps=4)
    for f in frames:
        ceiling.add(f)
    four = ceiling.angles()
    assert len(four) == (12 - 3) * 4 and max(four) < 0.1  # (the chord: 0.95°)
    chord = LinearCeiling(taps=2)
    for f in frames:
        chord.add(f)
    assert np.allclose(chord.angles(), math.degrees(OMEGA * DT / 2), atol=0.2)

    gappy = LinearCeiling(taps=4)
    for i, f in enumerate(frames):
        if i != 6:  # frame 6 dropped: the windows that span the gap are uneven and left out
            gappy.add(f)
    assert len(gappy.angles()) == 4 * (12 - 1 - 3 - 3)
    split = LinearCeiling(taps=4)
    for i, f in enumerate(frames):
        if i == 6:
            split.new_recording()
        split.add(f, score=i % 2 == 0)
    assert len(split.angles()) == 4 * 2  # frames 4 and 10 are scored with three before them in their recording
    with pytest.raises(ValueError, match="taps: expected >= 2, got 1"):
        LinearCeiling(taps=1)


def test_the_bench_reports_the_linear_ceiling() -> None:
    scores = bench_interaction._Scores()
    for i in range(6):
        scores.ceiling.add(_turning_body(1.0 + i * DT))
    figures = scores.figures()
    assert figures["velocity_direction_error_deg_p95_best_linear"] == 0.0
    assert bench_interaction._Scores().figures()["velocity_direction_error_deg_p95_best_linear"] is None
