"""Fusion: a person seen by the webcam and the depth camera at once is counted once."""

from __future__ import annotations

from pathlib import Path

import pytest

from interaction.depth import DepthObserver, DepthObserverConfig
from interaction.depth.calibration import calibrate_depth, fit_floor
from interaction.fusion import ID_STRIDE, FusionConfig, SensorFusion
from interaction.types import BodyObservation, Contactor, Impulse
from interaction.webcam import WebcamObserver, WebcamObserverConfig
from interaction.webcam.calibration import Calibration
from jostle.performer.truth import read_cameras
from sensors.base import DepthImage, Frame
from sensors.recording.source import iter_payloads


def _band(person: int, x: float, z: float) -> Contactor:
    return Contactor(person, "outline", (x, 0.0, z), (0.0, 0.0, 0.0), 0.05, half_depth=1.0)


def _sphere(person: int, x: float, y: float, part: str = "body") -> Contactor:
    return Contactor(person, part, (x, y, 1.0), (0.0, 0.0, 0.0), 0.2)


def test_the_webcam_copy_of_a_depth_person_is_dropped() -> None:
    webcam = BodyObservation(0.0, (_band(0, -0.2, 1.0), _band(0, 0.2, 0.5), _band(1, 2.0, 1.0)), people=2)
    depth = BodyObservation(0.0, (_sphere(0, 0.05, 0.3), _sphere(0, 0.1, 0.3, "hand")), people=1)
    pads = BodyObservation(0.0, impulses=(Impulse((0.0, 0.0, 0.0), (0.0, 0.0, -100.0), 0.05, "pads"),))
    fused = SensorFusion().merge(0.5, [webcam, depth, pads])
    assert fused.t == 0.5 and fused.people == 2  # the depth person and the webcam-only one at x = 2
    assert {c.person for c in fused.contactors} == {1, ID_STRIDE}
    assert [c.part for c in fused.contactors if c.person == ID_STRIDE] == ["body", "hand"]
    assert len(fused.impulses) == 1


def test_people_far_apart_or_outside_the_band_are_all_kept() -> None:
    webcam = BodyObservation(0.0, (_band(0, -1.0, 1.0), _band(0, -0.8, 1.0)), people=1)
    depth = BodyObservation(0.0, (_sphere(0, 1.0, 0.0), _sphere(1, -0.9, 1.8)), people=2)  # y 1.8: beyond the band
    fused = SensorFusion(FusionConfig(margin_m=0.1)).merge(0.0, [webcam, depth])
    assert fused.people == 3 and len(fused.contactors) == 4


def test_margin_is_checked() -> None:
    with pytest.raises(ValueError, match="^margin_m: "):
        FusionConfig(margin_m=-1.0)


@pytest.fixture(scope="module")
def crossing(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two people crossing, webcam 320×240 (the committed fixtures' 160×120 is too small for the webcam
    observer's defaults) and OAK 160×100, with truth; ~4 s to make."""
    from jostle.performer.config import DepthCameraConfig, PerformerConfig
    from jostle.performer.session import SynthSensors, record_performance

    path = tmp_path_factory.mktemp("fusion") / "crossing.mcap"
    config = PerformerConfig(width=320, height=240, fps=10.0, duration_s=5.5, seed=0, empty_s=1.0, people=2,
                             route="crossing")
    oak = DepthCameraConfig(width=160, height=100, fps=10.0, color=False)
    record_performance(config, SynthSensors(webcam=True, oak=oak, truth=True), path)
    return path


def test_both_cameras_on_a_recording_count_each_person_once(crossing: Path) -> None:
    """The webcam and the OAK of one recording, fused frame by frame: where both see someone, the
    webcam's people (one blob when the two overlap in its view) are the depth camera's people."""
    cameras = read_cameras(crossing)
    webcam_cal = Calibration(tuple(float(v) for v in cameras["webcam"].plane_homography(0.0).reshape(-1)),
                             0.0, 1.0, (320, 240))
    webcam = WebcamObserver(WebcamObserverConfig(), webcam_cal)
    depth_frames = [Frame("oak", t / 1e9, s, p) for t, s, p in iter_payloads(crossing, "oak")
                    if isinstance(p, DepthImage)]
    first = depth_frames[0].payload
    assert isinstance(first, DepthImage)
    pos = cameras["oak"].position
    cal = calibrate_depth(fit_floor(first.depth_mm, (first.fx, first.fy, first.cx, first.cy)), (pos[0], pos[1]))
    depth = DepthObserver(DepthObserverConfig(), cal)
    by_time = {round(t / 1e6): Frame("webcam", t / 1e9, s, p) for t, s, p in iter_payloads(crossing, "webcam")}
    fusion = SensorFusion()
    both = once = 0
    for frame in depth_frames:
        seen_by_webcam = webcam.observe(by_time[round(frame.t * 1000)])
        seen_by_depth = depth.observe(frame)
        fused = fusion.merge(frame.t, [seen_by_webcam, seen_by_depth])
        assert fused.people <= seen_by_webcam.people + seen_by_depth.people
        if seen_by_webcam.people >= 1 and seen_by_depth.people >= 1:
            both += 1
            once += int(fused.people == seen_by_depth.people and all(c.half_depth == 0 for c in fused.contactors))
    assert both > 20
    assert once >= 0.9 * both
