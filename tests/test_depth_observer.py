"""The depth observer on the virtual performer's OAK recordings, against their ground truth."""

from __future__ import annotations

import collections
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from interaction.depth import DepthObserver, DepthObserverConfig
from interaction.depth.calibration import DepthCalibration, calibrate_depth, fit_floor
from interaction.types import BodyObservation
from jostle.bench.truth import visible_people
from jostle.performer.truth import TruthFrame, read_cameras, read_truth
from sensors.base import ColorImage, DepthImage, Frame
from sensors.recording.source import iter_payloads

FIXTURES = Path(__file__).parent / "fixtures"


def _frames(path: Path) -> list[Frame]:
    return [Frame("oak", t / 1e9, seq, p) for t, seq, p in iter_payloads(path, "oak") if isinstance(p, DepthImage)]


def _calibration(path: Path, frames: list[Frame]) -> DepthCalibration:
    """As a user makes it: the floor from the first (empty-stage) frame, the camera's foot point given."""
    first = frames[0].payload
    assert isinstance(first, DepthImage)
    fit = fit_floor(first.depth_mm, (first.fx, first.fy, first.cx, first.cy))
    pos = read_cameras(path)["oak"].position
    return calibrate_depth(fit, (pos[0], pos[1]), 0.0, first.size)


def _run(name: str) -> tuple[DepthObserver, list[tuple[Frame, BodyObservation, TruthFrame]]]:
    path = FIXTURES / f"{name}.mcap"
    frames = _frames(path)
    observer = DepthObserver(DepthObserverConfig(), _calibration(path, frames))
    truth = {round(f.t * 1000): f for f in read_truth(path)}
    return observer, [(f, observer.observe(f), truth[round(f.t * 1000)]) for f in frames]


def test_two_people_crossing_keep_their_ids() -> None:
    _, run = _run("crossing2")
    seen: dict[int, collections.Counter[int]] = collections.defaultdict(collections.Counter)
    for _, obs, truth in run:
        for c in obs.contactors:
            if c.part == "head":
                dist = [(float(np.linalg.norm(np.array(c.position[:2]) - p.joint("head_top")[:2])), p.id)
                        for p in truth.people if p.present]
                seen[c.person][min(dist)[1]] += 1
    assert len(seen) == 2, f"expected 2 ids for 2 people, got {dict(seen)}"
    owners = {pid: counts.most_common(1)[0][0] for pid, counts in seen.items()}
    assert sorted(owners.values()) == [0, 1]
    for pid, counts in seen.items():
        assert counts[owners[pid]] >= 0.97 * sum(counts.values()), f"id {pid} swapped people: {counts}"
    assert sum(seen[pid][owners[pid]] for pid in seen) > 60  # both were seen for most of the crossing


def test_people_count_and_heads_of_a_group() -> None:
    path = FIXTURES / "group3.mcap"
    camera = read_cameras(path)["oak"]
    _, run = _run("group3")
    right = counted = 0
    head_error: list[float] = []
    for _, obs, truth in run[5:]:  # after learning
        expected = visible_people(truth, camera)
        if expected is not None:
            counted += 1
            right += int(obs.people == expected)
        for c in obs.contactors:
            if c.part == "head":
                head_error.append(min(float(np.linalg.norm(np.array(c.position) - p.joint("head_top")))
                                      for p in truth.people if p.present))
    assert counted > 30
    assert right >= 0.9 * counted
    assert len(head_error) > 60 and float(np.percentile(head_error, 90)) < 0.15


def test_velocities_follow_the_walk() -> None:
    """Each person's hull (the torso spheres) moves as the true pelvis does, once tracked a few frames."""
    _, run = _run("crossing2")
    errors: list[float] = []
    for _, obs, truth in run:
        for c in obs.contactors:
            if c.part != "body" or c.velocity == (0.0, 0.0, 0.0):
                continue
            nearest = min((p for p in truth.people if p.present),
                          key=lambda p: float(np.linalg.norm(p.joint("root")[:2] - np.array(c.position[:2]))))
            true_v = nearest.velocities[0][:2]
            if np.linalg.norm(true_v) > 0.5:
                errors.append(float(np.linalg.norm(np.array(c.velocity[:2]) - true_v)))
    assert len(errors) > 100
    assert float(np.median(errors)) < 0.35


def test_an_empty_stage_gives_no_contactors() -> None:
    """The recording's empty second, then the same frames again and again with fresh stereo noise and
    holes: never a person, never a contactor."""
    path = FIXTURES / "crossing2.mcap"
    frames = _frames(path)[:10]
    observer = DepthObserver(DepthObserverConfig(), _calibration(path, frames))
    rng = np.random.default_rng(7)
    t = 0.0
    for k in range(200):
        source = frames[k % len(frames)].payload
        assert isinstance(source, DepthImage)
        depth = source.depth_mm.astype(np.float64)
        depth *= 1 + rng.normal(0, 0.01, depth.shape)  # 1 % more noise than the stereo model's
        depth[rng.random(depth.shape) < 0.05] = 0
        noisy = dataclasses.replace(source, depth_mm=np.clip(depth, 0, 65535).astype(np.uint16))
        obs = observer.observe(Frame("oak", t, k, noisy))
        t += 0.1
        assert obs.contactors == () and obs.people == 0, f"frame {k}: a ghost {obs}"


def test_refuses_frames_that_are_not_depth() -> None:
    path = FIXTURES / "crossing2.mcap"
    frames = _frames(path)
    observer = DepthObserver(DepthObserverConfig(), _calibration(path, frames))
    with pytest.raises(ValueError, match="expected a depth image"):
        observer.observe(Frame("webcam", 0.0, 0, ColorImage(np.zeros((8, 8, 3), np.uint8))))


@pytest.mark.parametrize(("field", "value"), [("work_width", 3), ("stage_x", (1.0, -1.0)), ("cell_m", 0.0),
                                                ("alpha", 0.0), ("learn_frames", -1)])
def test_config_is_checked(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=f"^{field}: "):
        DepthObserverConfig(**{field: value})  # type: ignore[arg-type]


def _with_box(empty: DepthImage, cal: DepthCalibration, lo: np.ndarray, hi: np.ndarray) -> DepthImage:
    """The empty-stage frame with an upright box (stage corners lo, hi) drawn in by ray casting."""
    h, w = empty.depth_mm.shape
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    rays = np.stack([(u - empty.cx) / empty.fx, (v - empty.cy) / empty.fy, np.ones_like(u)], axis=-1) @ cal.matrix.T
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (lo - cal.centre) / rays
        t1 = (hi - cal.centre) / rays
    near = np.nanmax(np.minimum(t0, t1), axis=-1)  # depth along the optical axis: rays have camera z = 1
    far = np.nanmin(np.maximum(t0, t1), axis=-1)
    hit = (near <= far) & (near > 0)
    depth = empty.depth_mm.copy()
    box_mm = np.rint(near * 1000)
    closer = hit & ((depth == 0) | (box_mm < depth))
    depth[closer] = box_mm[closer].astype(np.uint16)
    return dataclasses.replace(empty, depth_mm=depth)


def test_velocity_of_a_moving_box_has_the_stated_latency() -> None:
    """A 1.7 m box standing still, then moving at 1 m/s along x: the hull's velocity follows as the
    module states (40 % of the change on the first frame, 80 % on the second, then within 15 %)."""
    path = FIXTURES / "crossing2.mcap"
    frames = _frames(path)[:6]
    cal = _calibration(path, frames)
    empty = frames[0].payload
    assert isinstance(empty, DepthImage)
    observer = DepthObserver(DepthObserverConfig(learn_frames=5), cal)
    for f in frames[:5]:
        observer.observe(f)
    dt, x, speeds = 0.1, -1.0, []
    for k in range(14):
        if k >= 6:
            x += 1.0 * dt
        box = _with_box(empty, cal, np.array([x - 0.2, -0.15, 0.0]), np.array([x + 0.2, 0.15, 1.7]))
        obs = observer.observe(Frame("oak", 1.0 + k * dt, 10 + k, box))
        assert obs.people == 1
        hull = [c for c in obs.contactors if c.part == "body"]
        speeds.append(float(np.mean([c.velocity[0] for c in hull])))
    assert all(abs(s) < 0.1 for s in speeds[1:6])  # standing still: no velocity
    assert speeds[6] == pytest.approx(0.4, abs=0.15)
    assert speeds[7] == pytest.approx(0.8, abs=0.15)
    assert all(abs(s - 1.0) < 0.2 for s in speeds[9:])


def test_the_observer_table_builds_a_depth_observer(tmp_path: Path) -> None:
    from interaction.observers import observer_types

    path = FIXTURES / "crossing2.mcap"
    frames = _frames(path)
    calibration = tmp_path / "depth.toml"
    _calibration(path, frames).save(calibration)
    row = observer_types()["depth"]
    assert row.config is DepthObserverConfig and row.needs_calibration
    observer = row.build(DepthObserverConfig(), calibration, "oak")
    assert isinstance(observer, DepthObserver)
    assert observer.observe(frames[0]).contactors == ()
