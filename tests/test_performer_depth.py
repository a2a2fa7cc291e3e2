"""The virtual OAK: real pybullet depth buffers, checked against the people's ground truth and the
stereo error model (noise growing with the square of the distance, holes where stereo fails)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from jostle.performer.config import DepthCameraConfig, PerformerConfig
from jostle.performer.depth import DepthTruth, PerformerDepth, occluded_in_second_view, sigma_depth_m
from jostle.performer.scene import Performance
from sensors.base import DepthImage, Frame, SensorState, frame_digest
from sensors.clock import SimClock
from sim.motion.mocap import HUMANOID

PEOPLE = PerformerConfig(people=2, route="crossing", duration_s=4.5, empty_s=0.5, fps=5.0, width=96, height=72)
OAK = DepthCameraConfig(width=320, height=200, fps=4.0)


@dataclass
class Run:
    sensor: PerformerDepth
    frames: list[Frame]
    truths: list[DepthTruth]


def _drive(people: PerformerConfig, oak: DepthCameraConfig) -> Run:
    clock = SimClock()
    sensor = PerformerDepth(Performance(people), oak, clock)
    frames, truths = [], []
    sensor.open()
    clock.advance(people.duration_s)
    while (frame := sensor.read(0.0)) is not None:
        frames.append(frame)
        truths.append(sensor.truth(frame.t))
    assert sensor.status.state is SensorState.ENDED
    return Run(sensor, frames, truths)


@pytest.fixture(scope="module")
def run() -> Iterator[Run]:
    r = _drive(PEOPLE, OAK)
    yield r
    r.sensor.close()


def _depth(frame: Frame) -> DepthImage:
    assert isinstance(frame.payload, DepthImage)
    return frame.payload


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"width": 8}, "width"),
        ({"fps": 0.0}, "fps"),
        ({"position": (0.0, -4.0)}, "position"),
        ({"position": (0.0, -4.0, 3.5)}, "position"),  # above the room's ceiling
        ({"baseline_m": -0.1}, "baseline_m"),
        ({"subpixel_bits": 12}, "subpixel_bits"),
        ({"min_depth_m": 5.0, "max_depth_m": 4.0}, "max_depth_m"),
        ({"edge_holes": 1.5}, "edge_holes"),
        ({"color": 1}, "color"),
    ],
)
def test_config_rejects_bad_values_naming_the_field(changes: dict[str, Any], field: str) -> None:
    with pytest.raises(ValueError, match=rf"^{field}: "):
        DepthCameraConfig(**changes)


def test_passes_the_shared_sensor_check() -> None:
    from sensors.testing import check_sensor

    people = dataclasses.replace(PEOPLE, duration_s=0.6)
    oak = dataclasses.replace(OAK, width=64, height=40, fps=5.0)
    check_sensor(lambda clock: PerformerDepth(Performance(people), oak, clock), duration=0.8, step=0.1)


def test_frames_are_oak_like_and_deterministic(run: Run) -> None:
    assert len(run.frames) == 18 and [f.seq for f in run.frames] == list(range(18))
    first = _depth(run.frames[0])
    k = run.sensor.camera.intrinsics
    assert (first.fx, first.fy, first.cx, first.cy) == (k[0, 0], k[1, 1], k[0, 2], k[1, 2])
    for f in run.frames:
        d = _depth(f)
        assert d.depth_mm.dtype == np.uint16 and d.size == (OAK.width, OAK.height)
        assert d.color is not None and d.color.shape == (OAK.height, OAK.width, 3) and d.color.dtype == np.uint8
    again = _drive(PEOPLE, OAK)
    other = _drive(dataclasses.replace(PEOPLE, seed=3), OAK)
    again.sensor.close()
    other.sensor.close()
    assert [frame_digest(f) for f in again.frames] == [frame_digest(f) for f in run.frames]
    assert frame_digest(other.frames[0]) != frame_digest(run.frames[0])  # the noise follows the seed


def test_valid_pixels_back_project_onto_the_floor_and_walls(run: Run) -> None:
    """The recorded intrinsics and millimetres put the empty stage's floor pixels at z = 0."""
    cam = run.sensor.camera
    d = _depth(run.frames[0])  # the empty stage
    v, u = np.nonzero(d.depth_mm)
    z = d.depth_mm[v, u] / 1000.0
    local = np.stack([(u - d.cx) / d.fx * z, (v - d.cy) / d.fy * z, z], axis=-1)
    stage = local @ cam.rotation + cam.centre
    floor = v > 0.75 * OAK.height  # the bottom quarter sees only the floor
    heights = stage[floor, 2]
    allowed = 4 * np.asarray(sigma_depth_m(z[floor], OAK)) + 0.02
    assert np.all(np.abs(heights) < allowed)
    assert abs(float(np.median(heights))) < 0.01


def _bone_links(name: str, link_names: tuple[str, ...]) -> set[int]:
    """The pybullet links whose surface lies around a bone's joint: its own and its parent's."""
    owner = {"head_top": "neck", "right_toe": "right_ankle", "left_toe": "left_ankle"}.get(name, name)
    parent = HUMANOID.names[HUMANOID.parents[HUMANOID.names.index(owner)]] if owner != "root" else "root"
    return {link_names.index(n) for n in (owner, parent) if n in link_names}


def test_depth_at_each_joint_is_its_distance_along_the_axis(run: Run) -> None:
    """Where the picture shows a joint's own body part, the true depth is the joint's distance along
    the optical axis less the part's thickness (the surface faces the camera), and the recorded
    depth is that within the stereo noise."""
    cam = run.sensor.camera
    link_names = run.sensor.performance.puppet().link_names
    offsets: list[float] = []
    for frame, truth in zip(run.frames, run.truths, strict=True):
        measured = _depth(frame).depth_mm / 1000.0
        for state in truth.people:
            if not state.present:
                continue
            along = cam.to_camera(state.joints)[:, 2]
            for b, (u, v) in enumerate(np.rint(cam.project(state.joints)).astype(int)):
                if not (0 <= u < OAK.width and 0 <= v < OAK.height) or truth.person[v, u] != state.id:
                    continue
                if truth.parts[v, u] not in _bone_links(HUMANOID.names[b], link_names):
                    continue
                clean = float(truth.depth_m[v, u])
                offsets.append(clean - along[b])
                # in front by up to the part's thickness (a hip seen through the pelvis from above:
                # up to 0.23 m), or at most grazing the surface just behind a joint on it (shoulder):
                # the pixel's ray passes up to half a pixel beside the joint
                assert -0.25 < clean - along[b] < 0.05, (frame.t, state.id, HUMANOID.names[b])
                if measured[v, u] > 0:
                    quantum = clean**2 / (OAK.stereo_focal_px() * OAK.baseline_m) / 2**OAK.subpixel_bits
                    assert abs(measured[v, u] - clean) < 4.5 * float(sigma_depth_m(clean, OAK)) + quantum
    assert len(offsets) > 150
    assert -0.1 < float(np.median(offsets)) < -0.02  # limbs and trunk: a few centimetres thick


def test_noise_grows_with_the_square_of_distance(run: Run) -> None:
    errors, depths = [], []
    for frame, truth in zip(run.frames, run.truths, strict=True):
        measured = _depth(frame).depth_mm / 1000.0
        ok = (measured > 0) & np.isfinite(truth.depth_m)
        errors.append(measured[ok] - truth.depth_m[ok])
        depths.append(truth.depth_m[ok])
    err, z = np.concatenate(errors), np.concatenate(depths)
    scale = []
    for lo, hi in ((2.5, 3.5), (4.0, 5.0), (5.5, 6.5), (7.0, 8.0)):
        sel = (z >= lo) & (z < hi)
        assert sel.sum() > 2000
        assert abs(float(err[sel].mean())) < 0.2 * float(err[sel].std())  # unbiased
        scale.append(float(err[sel].std()) / float(np.mean(z[sel] ** 2)))
    # std / z² is the same at every distance (within sampling), and the model's: quantisation
    # to 1/8 px adds (1/8)²/12 px² of variance to the disparity noise
    np.testing.assert_allclose(scale, np.mean(scale), rtol=0.12)
    fb = OAK.stereo_focal_px() * OAK.baseline_m
    model = np.hypot(OAK.disparity_noise_px, 2.0**-OAK.subpixel_bits / np.sqrt(12)) / fb
    assert np.mean(scale) == pytest.approx(model, rel=0.15)


def test_holes_are_a_minority_where_stereo_fails(run: Run) -> None:
    fractions, left_of_people, right_of_people = [], 0, 0
    for frame, truth in zip(run.frames, run.truths, strict=True):
        missing = _depth(frame).depth_mm == 0
        fractions.append(missing.mean())
        person = truth.person >= 0
        if not person.any():
            continue
        occluded = occluded_in_second_view(truth.depth_m, run.sensor.camera.focal_px, OAK.baseline_m)
        assert np.all(missing[occluded])  # what the second camera cannot see has no depth
        # that band lies left of each person (the depth is the left camera's), not on their right
        left, right = np.zeros_like(person), np.zeros_like(person)
        for gap in (1, 2, 3, 4):
            left[:, :-gap] |= person[:, gap:]
            right[:, gap:] |= person[:, :-gap]
        left_of_people += int((occluded & left & ~person).sum())
        right_of_people += int((occluded & right & ~person & ~left).sum())
    assert 0.001 < float(np.mean(fractions)) < 0.1
    assert max(fractions) < 0.15
    assert fractions[0] > 0  # even the empty room has a few (random blobs, furniture edges)
    assert left_of_people > 100 and right_of_people < 0.1 * left_of_people


def test_the_aligned_colour_shows_the_people_where_the_depth_does(run: Run) -> None:
    i = max(range(len(run.truths)), key=lambda j: int((run.truths[j].person >= 0).sum()))
    truth, colour = run.truths[i], _depth(run.frames[i]).color
    empty = _depth(run.frames[0]).color
    assert colour is not None and empty is not None
    diff = np.abs(colour.astype(float) - empty.astype(float)).mean(axis=-1)
    person = truth.person >= 0
    assert person.sum() > 500
    assert diff[person].mean() > 4 * diff[~person].mean()
    plain = _drive(dataclasses.replace(PEOPLE, duration_s=0.5), dataclasses.replace(OAK, color=False))
    plain.sensor.close()
    assert _depth(plain.frames[0]).color is None
