"""Several virtual people at once: who they are, how big, where they walk, and that the puppets
pybullet draws are the bodies the ground truth describes."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

from jostle.performer.cast import plan_cast
from jostle.performer.config import PerformerConfig
from jostle.performer.performer import PerformerSensor
from jostle.performer.scene import Performance
from sensors.clock import SimClock
from sim.motion.mocap import HUMANOID

CROSS = PerformerConfig(people=2, route="crossing", duration_s=6.0, empty_s=1.0, fps=5.0, width=160, height=120)


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"people": 0}, "people"),
        ({"people": 5, "route": "crossing"}, "people"),
        ({"people": 2}, "route"),  # the round is one person's
        ({"route": "zigzag"}, "route"),
        ({"people": 2, "route": "crossing", "sizes": (1.0,)}, "sizes"),
        ({"sizes": (3.0,)}, "sizes"),
        ({"people": 2, "route": "crossing", "person_clips": ("walk",)}, "person_clips"),
        ({"person_clips": ("walk+moonwalk",)}, "person_clips"),
        ({"person_clips": ("punch+walk",)}, "person_clips"),  # the first clip must travel
        ({"person_clips": ("walk++punch",)}, "person_clips"),
    ],
)
def test_config_rejects_bad_people_naming_the_field(changes: dict[str, Any], field: str) -> None:
    with pytest.raises(ValueError, match=rf"^{field}: "):
        dataclasses.replace(PerformerConfig(), **changes)


@pytest.mark.parametrize("people", [1, 2, 3, 4])
def test_people_have_distinct_ids_sizes_and_lanes_from_the_seed(people: int) -> None:
    config = dataclasses.replace(CROSS, people=people)
    plans = plan_cast(config)
    assert plans == plan_cast(config)  # deterministic
    assert plans != plan_cast(dataclasses.replace(config, seed=1))
    assert [p.id for p in plans] == list(range(people))
    sizes = [p.size for p in plans]
    assert all(0.8 <= s <= 1.1 for s in sizes) and len(set(sizes)) == people
    assert min(sizes) < max(sizes) or people == 1
    for p in plans:
        assert p.mass_kg == pytest.approx(70.0 * p.size**2)
        assert 0.7 < p.speed < 1.6  # a walking pace, m/s
    lanes = sorted(p.start_xy[1] for p in plans)
    assert all(b - a >= 0.5 for a, b in zip(lanes, lanes[1:], strict=False))  # room to pass each other
    headings = {p.heading_deg for p in plans}
    assert headings == ({0.0} if people == 1 else {0.0, 180.0})


def test_given_sizes_and_clips_are_used() -> None:
    config = dataclasses.replace(CROSS, sizes=(0.85, 1.05), person_clips=("walk+punch", "run"))
    plans = plan_cast(config)
    assert [p.size for p in plans] == [0.85, 1.05]
    assert [p.clips for p in plans] == [("walk", "punch"), ("run",)]
    default = plan_cast(dataclasses.replace(CROSS, clips=("walk", "punch", "kick")))
    assert [p.clips for p in default] == [("walk", "punch", "kick"), ("walk", "kick", "punch")]


def _root_track(performance: Performance, times: np.ndarray) -> np.ndarray:
    """(T, people, 3) root positions, nan while a person is off the stage."""
    out = np.full((len(times), len(performance.cast), 3), np.nan)
    for i, t in enumerate(times):
        for state in performance.people_at(float(t)):
            if state.present:
                out[i, state.id] = state.joint("root")
    return out


def test_two_people_cross_on_their_lanes_without_touching() -> None:
    performance = Performance(CROSS)
    times = np.arange(0.0, CROSS.duration_s, 0.05)
    roots = _root_track(performance, times)
    assert np.all(np.isnan(roots[times < CROSS.empty_s]))  # the empty stage first
    both = ~np.isnan(roots[:, :, 0]).any(axis=1)
    gap = roots[both, 0, 0] - roots[both, 1, 0]
    assert np.all(np.isfinite(gap)) and len(gap) > 60
    assert np.count_nonzero(np.diff(np.sign(gap))) == 1  # they pass each other exactly once
    crossing = times[both][np.argmin(np.abs(gap))]
    assert 3.5 < crossing < 5.5  # in from out of view, they meet about 3.5 s after the empty start
    closest = np.inf
    for t in times[both]:
        a, b = (s.joints for s in performance.people_at(float(t)))
        closest = min(closest, float(np.min(np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1))))
    assert closest > 0.1  # separate lanes: bodies never meet (hands are spheres of 0.048 m)
    for k, plan in enumerate(p.plan for p in performance.cast):  # each keeps to its lane and pace
        lane = roots[both, k, 1]
        assert np.all(np.abs(lane - plan.start_xy[1]) < 0.1)
        step = np.diff(roots[both, k, :2], axis=0) / 0.05
        assert np.median(np.linalg.norm(step, axis=1)) == pytest.approx(plan.speed, rel=0.1)


def test_scaled_puppets_are_the_bodies_of_the_truth() -> None:
    """pybullet's links (the drawn bodies, loaded at each person's scale) sit where the truth says,
    heads are as tall as the sizes say, and the feet stay on the floor for every size."""
    config = dataclasses.replace(CROSS, people=3, sizes=(0.85, 1.0, 1.1))
    performance = Performance(config)
    performance.acquire()
    try:
        puppet = performance.puppet()
        heights: dict[int, list[float]] = {0: [], 1: [], 2: []}
        soles: dict[int, list[float]] = {0: [], 1: [], 2: []}
        for t in np.arange(2.0, 5.0, 0.25):
            for state in performance.people_at(float(t)):
                if state.pose is None:
                    continue
                puppet.set_pose(state.pose, state.id)
                links = puppet.link_positions(state.id)
                for name, pos in links.items():
                    if name in HUMANOID.names:
                        assert np.linalg.norm(pos - state.joint(name)) < 1e-5, (state.id, name)
                heights[state.id].append(float(state.joint("head_top")[2]))
                soles[state.id].append(min(float(state.joint(n)[2]) for n in ("left_toe", "right_toe")))
    finally:
        performance.release()
    tallest = [max(heights[i]) for i in range(3)]
    np.testing.assert_allclose(np.array(tallest) / tallest[1], [0.85, 1.0, 1.1], rtol=0.03)
    for i, size in enumerate((0.85, 1.0, 1.1)):
        assert min(soles[i]) == pytest.approx(0.036 * size, abs=0.01)  # a toe down at every size


def test_the_webcam_sees_each_person_under_their_id() -> None:
    clock = SimClock()
    sensor = PerformerSensor(CROSS, clock)
    seen: set[int] = set()
    checked = 0
    with sensor:
        clock.advance(CROSS.duration_s)
        while (frame := sensor.read(0.0)) is not None:
            truth = sensor.truth(frame.t)
            assert truth.person is not None
            ids = set(np.unique(truth.person[truth.person >= 0]).tolist())
            seen |= ids
            assert truth.silhouette.sum() == (truth.person >= 0).sum()
            for state in truth.people:
                if not state.present or state.id not in ids:
                    continue
                u, v = np.rint(sensor.camera.project(state.joint("chest"))).astype(int)
                if 1 <= u < CROSS.width - 1 and 1 <= v < CROSS.height - 1:
                    window = truth.person[v - 1 : v + 2, u - 1 : u + 2]
                    assert (window == state.id).any() or (window >= 0).all()  # theirs, or someone in front
                    checked += 1
    assert seen == {0, 1} and checked >= 15
