"""The virtual performer: real pybullet rendering, real pixels, checked against its own ground truth."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from jostle.performer.camera import apply_homography
from jostle.performer.dress import dressed_urdf
from jostle.performer.performer import PerformerConfig, PerformerSensor, PerformerTruth
from sensors.base import ColorImage, Frame, SensorNotOpen, SensorState, frame_digest
from sensors.clock import SimClock
from sim.motion.mocap import HUMANOID

SHORT = PerformerConfig(duration_s=4.0, fps=10.0)


@dataclass
class Run:
    sensor: PerformerSensor
    frames: list[Frame]
    truths: list[PerformerTruth]


def _drive(config: PerformerConfig, name: str = "webcam") -> Run:
    clock = SimClock()
    sensor = PerformerSensor(config, clock, name)
    frames: list[Frame] = []
    truths: list[PerformerTruth] = []
    sensor.open()
    while sensor.status.state is not SensorState.ENDED:
        frame = sensor.read(0.0)
        if frame is None:
            clock.advance(1.0 / config.fps)
            continue
        frames.append(frame)
        truths.append(sensor.truth(frame.t))
    return Run(sensor, frames, truths)


@pytest.fixture(scope="module")
def short_run() -> Iterator[Run]:
    run = _drive(SHORT)
    yield run
    run.sensor.close()


def _image(frame: Frame) -> np.ndarray:
    assert isinstance(frame.payload, ColorImage)
    return frame.payload.bgr


# ---------------------------------------------------------------- config


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"fps": -3.0}, "fps"),
        ({"clips": ("moonwalk",)}, "clips"),
        ({"clips": ("punch",)}, "clips"),  # the first clip must walk somewhere
        ({"clips": ()}, "clips"),
        ({"width": 0}, "width"),
        ({"noise_sigma": float("nan")}, "noise_sigma"),
        ({"light_change": 1.5}, "light_change"),
        ({"seed": -1}, "seed"),
    ],
)
def test_config_rejects_bad_values_naming_the_field(changes: dict[str, Any], field: str) -> None:
    with pytest.raises(ValueError, match=rf"^{field}: "):
        dataclasses.replace(PerformerConfig(), **changes)


# ---------------------------------------------------------------- the Sensor contract


def test_sensor_contract_open_read_close() -> None:
    config = dataclasses.replace(SHORT, duration_s=1.0, fps=5.0)
    clock = SimClock(10.0)
    sensor = PerformerSensor(config, clock, "cam")
    assert sensor.spec.kind == "color" and sensor.spec.rate_hz == 5.0
    assert sensor.status.state is SensorState.CLOSED
    with pytest.raises(SensorNotOpen):
        sensor.read(0.0)
    with pytest.raises(SensorNotOpen):
        sensor.truth(10.0)
    with sensor:
        first = sensor.read(0.0)  # frame 0 is due at the opening instant
        assert first is not None and first.seq == 0 and first.t == 10.0 and first.sensor == "cam"
        started = time.perf_counter()
        assert sensor.read(5.0) is None  # not due yet: returns at once, never sleeps
        assert time.perf_counter() - started < 0.5
        clock.advance(10.0)  # far ahead: the rest come in order, none skipped
        frames = [first]
        while (frame := sensor.read(0.0)) is not None:
            frames.append(frame)
        assert [f.seq for f in frames] == list(range(config.frame_count)) == [0, 1, 2, 3, 4]
        assert [f.t for f in frames] == [10.0 + k / 5.0 for k in range(5)]
        for f in frames:
            img = _image(f)
            assert img.dtype == np.uint8 and img.shape == (config.height, config.width, 3)
            assert f.kind == sensor.spec.kind
        assert sensor.status.state is SensorState.ENDED and sensor.status.frames == 5
        assert sensor.read(0.0) is None
    assert sensor.status.state is SensorState.CLOSED
    sensor.close()  # idempotent
    with pytest.raises(SensorNotOpen):
        sensor.read(0.0)
    sensor.open()  # reopening starts the performance again at the clock's present
    again = sensor.read(0.0)
    sensor.close()
    assert again is not None and again.seq == 0 and again.t == 20.0
    assert np.array_equal(_image(again), _image(first))


def test_passes_the_shared_sensor_check() -> None:
    testing = pytest.importorskip("sensors.testing")
    config = dataclasses.replace(SHORT, duration_s=0.6, fps=5.0, width=96, height=72)
    testing.check_sensor(lambda clock: PerformerSensor(config, clock), duration=1.0, step=0.1)


def test_same_config_and_seed_give_identical_frames(short_run: Run) -> None:
    again = _drive(SHORT)
    other_seed = _drive(dataclasses.replace(SHORT, seed=1))
    again.sensor.close()
    other_seed.sensor.close()
    assert [frame_digest(f) for f in again.frames] == [frame_digest(f) for f in short_run.frames]
    assert frame_digest(other_seed.frames[-1]) != frame_digest(short_run.frames[-1])


# ---------------------------------------------------------------- what is seen


def test_stage_is_empty_first_then_the_person_is_there(short_run: Run) -> None:
    empty = [tr for tr in short_run.truths if tr.t < SHORT.empty_s]
    assert len(empty) == 15
    assert all(not tr.present and not tr.silhouette.any() and not tr.joints for tr in empty)
    last, truth = short_run.frames[-1], short_run.truths[-1]
    assert truth.present and truth.silhouette.sum() > 300
    assert set(truth.joints) >= {"root", "head_top", "left_wrist", "right_toe"}
    # The frame shows the person where the mask is: compare with the empty stage of frame 0 brought to
    # the same brightness (elsewhere they differ only by noise and the soft shadow).
    gain = short_run.sensor.light_gain(last.t) / short_run.sensor.light_gain(0.0)
    background = _image(short_run.frames[0]).astype(float) * gain
    diff = np.abs(_image(last).astype(float) - background).mean(axis=-1)
    mask = truth.silhouette
    assert diff[mask].mean() > 25.0
    assert diff[mask].mean() > 5 * diff[~mask].mean()
    link_names = short_run.sensor.link_names
    seen = {link_names[i] for i in np.unique(truth.parts[mask])}
    assert {"chest", "neck", "right_knee", "left_knee"} <= seen


def test_truth_joints_project_into_the_silhouette(short_run: Run) -> None:
    cam = short_run.sensor.camera
    checked = 0
    for truth in short_run.truths:
        if not truth.present or truth.silhouette.sum() < 300:
            continue
        for name in ("root", "chest", "neck", "left_knee", "right_knee", "left_ankle", "right_ankle"):
            u, v = np.rint(cam.project(np.array(truth.joints[name]))).astype(int)
            if 1 <= u < cam.width - 1 and 1 <= v < cam.height - 1:
                assert truth.silhouette[v - 1 : v + 2, u - 1 : u + 2].any(), (truth.t, name)
                checked += 1
    assert checked >= 20


def test_velocities_match_the_motion(short_run: Run) -> None:
    walking = [tr for tr in short_run.truths if tr.joints]
    assert len(walking) >= 15
    for a, b in zip(walking, walking[1:], strict=False):
        dt = b.t - a.t
        fd = (np.array(b.joints["root"]) - np.array(a.joints["root"])) / dt
        mean_v = (np.array(a.velocities["root"]) + np.array(b.velocities["root"])) / 2
        assert np.linalg.norm(fd - mean_v) < 0.1
    speed = np.linalg.norm(np.array(walking[-1].velocities["root"])[:2])
    assert 0.8 < speed < 1.2  # the walk clip's own pace, ≈ 0.98 m/s along +x
    assert walking[-1].velocities["root"][0] > 0.8


def _fastest_fist(clips: tuple[str, ...]) -> tuple[float, float, np.ndarray, float]:
    """(speed m/s, time, position) of the fastest wrist over the round, and the largest |y| of the root."""
    choreography = PerformerSensor(dataclasses.replace(PerformerConfig(), clips=clips), SimClock()).choreography
    times = np.arange(0.0, choreography.period, 1.0 / 30.0)
    on_path = [(t, p.joint_positions()) for t in times if (p := choreography.pose(t)) is not None]
    wrists = [HUMANOID.names.index("right_wrist"), HUMANOID.names.index("left_wrist")]
    best = (0.0, 0.0, np.zeros(3))
    for (_, a), (t, b) in zip(on_path, on_path[1:], strict=False):
        for i in wrists:
            speed = float(np.linalg.norm(b[i] - a[i])) * 30.0
            if speed > best[0]:
                best = (speed, t, b[i])
    return (*best, max(abs(pos[0, 1]) for _, pos in on_path))


def test_a_punch_sweeps_a_fist_through_the_characters_band() -> None:
    walk_speed, _, _, walk_y = _fastest_fist(("walk",))
    punch_speed, t, where, punch_y = _fastest_fist(("walk", "punch"))
    assert walk_y < 1.0 and punch_y < 1.0  # the body stays in the characters' band |y| < 1 m
    assert walk_speed < 4.0 < 5.0 < punch_speed
    assert 4.0 < t < 8.0  # the punch comes early enough for a short recording
    assert abs(where[0]) < 3.0 and abs(where[1]) < 1.0 and 0.8 < where[2] < 1.6  # in the stage, chest high


# ---------------------------------------------------------------- the homography


def test_homography_is_exact_for_rendered_markers() -> None:
    """Squares drawn by pybullet's renderer at known places on the plane y = 0 land where H says."""
    import pybullet as pb

    sensor = PerformerSensor(SHORT, SimClock())
    cam, h = sensor.camera, sensor.homography()
    client = pb.connect(pb.DIRECT)
    try:
        shape = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[0.15, 0.001, 0.15], physicsClientId=client)
        centres = [(x, 0.0, z) for x in (-2.4, -0.8, 0.9, 2.5) for z in (0.2, 1.0, 1.9)]
        ids = [pb.createMultiBody(0, -1, shape, basePosition=c, physicsClientId=client) for c in centres]
        _, _, _, _, seg = pb.getCameraImage(
            cam.width, cam.height, cam.view_matrix(), cam.projection_matrix(),
            renderer=pb.ER_TINY_RENDERER, physicsClientId=client,
        )
    finally:
        pb.disconnect(client)
    seg = np.asarray(seg).reshape(cam.height, cam.width)
    for body, (x, _, z) in zip(ids, centres, strict=True):
        v, u = np.nonzero(seg == body)
        assert len(u) > 50
        got = apply_homography(h, np.array([u.mean(), v.mean()]))
        assert np.hypot(got[0] - x, got[1] - z) < 0.012, (x, z, got)
    # and H inverts the camera's projection on the plane exactly
    pts = np.array([[-3.0, 0.0, 0.0], [0.0, 0.0, 1.5], [2.2, 0.0, 0.7]])
    np.testing.assert_allclose(apply_homography(h, cam.project(pts)), pts[:, [0, 2]], atol=1e-9)


def test_homography_maps_the_persons_feet_and_head_onto_the_stage(short_run: Run) -> None:
    cam, h = short_run.sensor.camera, short_run.sensor.homography()
    checked = 0
    for truth in short_run.truths:
        if not truth.present or abs(truth.joints["root"][1]) > 0.02:
            continue
        v, u = np.nonzero(truth.silhouette)
        if u.min() <= 0 or u.max() >= cam.width - 1:
            continue  # partly outside the picture
        head = np.array(truth.joints["head_top"])
        feet_z = min(truth.joints[n][2] for n in ("left_ankle", "right_ankle", "left_toe", "right_toe"))
        top = apply_homography(h, np.array([u[v == v.min()].mean(), v.min() - 0.5]))
        bottom = apply_homography(h, np.array([u[v == v.max()].mean(), v.max() + 0.5]))
        assert abs(top[1] - head[2]) < 0.05 and abs(top[0] - head[0]) < 0.06, (truth.t, top, head)
        assert abs(bottom[1] - 0.0) < 0.05 and feet_z < 0.06, (truth.t, bottom)
        projected = apply_homography(h, cam.project(head))
        assert np.hypot(projected[0] - head[0], projected[1] - head[2]) < 0.03
        checked += 1
    assert checked >= 10


# ---------------------------------------------------------------- camera realism


def _empty_frames(config: PerformerConfig) -> list[np.ndarray]:
    run = _drive(dataclasses.replace(config, duration_s=config.empty_s, fps=5.0))
    run.sensor.close()
    return [_image(f).astype(float) for f in run.frames]


def test_frames_carry_camera_noise() -> None:
    clean = dataclasses.replace(SHORT, light_change=0.0, noise_sigma=0.0)
    still = _empty_frames(clean)
    assert all(np.array_equal(still[0], f) for f in still[1:])
    noisy = _empty_frames(dataclasses.replace(clean, noise_sigma=3.0))
    diff = noisy[1] - noisy[0]
    assert abs(diff.mean()) < 0.1
    assert 3.0 * math.sqrt(2) * 0.85 < diff.std() < 3.0 * math.sqrt(2) * 1.15


def test_light_drifts_slowly_and_globally() -> None:
    config = dataclasses.replace(SHORT, noise_sigma=0.0, light_change=0.2, light_period_s=2.0, empty_s=1.0)
    frames = _empty_frames(config)
    assert len(frames) == 5
    means = np.array([f.mean() for f in frames])
    assert means.max() / means.min() > 1.2
    sensor = PerformerSensor(config, SimClock())
    gains = np.array([sensor.light_gain(k / 5.0) for k in range(len(frames))])
    np.testing.assert_allclose(means / means[0], gains / gains[0], rtol=0.02)


def test_clothes_keep_the_humanoids_links_and_joints(tmp_path: Path) -> None:
    """The dressed URDF is the same robot as pybullet's (links, joints, parents, frames): poses and
    link indices mean the same on both; only what is drawn differs."""
    import pybullet as pb
    import pybullet_data

    source = Path(pybullet_data.getDataPath()) / "humanoid" / "humanoid.urdf"
    dressed = tmp_path / "dressed.urdf"
    dressed.write_text(dressed_urdf(source), encoding="utf-8")
    client = pb.connect(pb.DIRECT)
    try:
        bodies = [pb.loadURDF(str(p), globalScaling=0.25, physicsClientId=client) for p in (source, dressed)]
        infos = [
            [pb.getJointInfo(b, j, physicsClientId=client)[:3] + pb.getJointInfo(b, j, physicsClientId=client)[12:]
             for j in range(pb.getNumJoints(b, physicsClientId=client))]
            for b in bodies
        ]
        shapes = [len(pb.getVisualShapeData(b, physicsClientId=client)) for b in bodies]
    finally:
        pb.disconnect(client)
    assert len(infos[0]) == 15 and infos[0] == infos[1]
    assert shapes[1] > shapes[0]
