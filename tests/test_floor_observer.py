"""The webcam observer on a floor calibration, against the virtual performer's ground truth: two
people crossing in front of a webcam 3 m high looking 30° down (320×240, 15 fps, 5 s, made in
the test). Feet are compared with the true shoe centres (``jostle.bench.truth``), heads with the
true head tops; the upright-plane calibration of the same camera is run beside them for contrast.
Figures and what limits them: docs/notes/floor-calibration.md."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from interaction.observers import observer_types
from interaction.webcam import WebcamObserver, WebcamObserverConfig
from interaction.webcam.calibration import Calibration
from interaction.webcam.floor_calibration import FOOT_MIDDLE_M, FloorCalibration
from interaction.webcam.floor_points import fit_floor_points
from jostle.bench.truth import body_part_centres
from jostle.performer.config import PerformerConfig
from jostle.performer.performer import PerformerSensor
from sensors.base import ColorImage, Frame
from sensors.clock import SimClock

W, H = 320, 240
CONFIG = PerformerConfig(width=W, height=H, fps=15.0, duration_s=5.0, empty_s=1.0, people=2, route="crossing",
                         camera_distance_m=3.5, camera_height_m=3.0, camera_pitch_deg=30.0, seed=1)
MARKS = np.array([[-2.5, -1.0], [2.5, -1.0], [2.0, 2.5], [-2.0, 2.5], [0.0, 0.5], [1.0, 1.5]])
ON_FLOOR_M = 0.06  # a true shoe centre this low is a foot on the floor (standing: 0.04)


def calibrations() -> dict[str, Calibration | FloorCalibration]:
    cam = CONFIG.camera()
    uv = np.round(cam.project(np.column_stack([MARKS, np.zeros(len(MARKS))])))  # typed as whole pixels
    return {
        "exact": FloorCalibration(tuple(cam.camera_matrix().ravel().tolist()), 0.25, (W, H)),
        "typed": fit_floor_points(uv, MARKS, (W, H)).calibration,
        "upright": Calibration(tuple(cam.plane_homography(0.0).ravel().tolist()), 0.0, 1.0, (W, H)),
    }


def run(observers: dict[str, WebcamObserver]) -> dict[str, dict[str, list[float]]]:
    """Each observer's foot errors (on the floor, all) and head errors over the recording, metres."""
    out: dict[str, dict[str, list[float]]] = {n: {"on_floor": [], "feet": [], "heads": [], "foot_z": []} for n in observers}
    clock = SimClock()
    sensor = PerformerSensor(CONFIG, clock)
    with sensor:
        while clock.now() <= CONFIG.duration_s:
            frame = sensor.read(0.0)
            if frame is None:
                clock.advance(1.0 / CONFIG.fps)
                continue
            truth = sensor.truth(frame.t)
            feet = np.array([c for p in truth.people if p.present for c, _ in body_part_centres(p, "foot")]).reshape(-1, 3)
            heads = np.array([p.joint("head_top") for p in truth.people if p.present]).reshape(-1, 3)
            for name, observer in observers.items():
                for c in observer.observe(frame).contactors:
                    at = np.array(c.position)
                    if c.part == "foot" and len(feet):
                        d = np.linalg.norm(feet - at, axis=1)
                        k = int(np.argmin(d))
                        out[name]["feet"].append(float(d[k]))
                        out[name]["foot_z"].append(float(at[2]))
                        if feet[k, 2] < ON_FLOOR_M:
                            out[name]["on_floor"].append(float(d[k]))
                    elif c.part == "head" and len(heads):
                        out[name]["heads"].append(float(np.min(np.linalg.norm(heads - at, axis=1))))
    return out


@pytest.fixture(scope="module")
def errors() -> dict[str, dict[str, list[float]]]:
    config = WebcamObserverConfig(pose=False, learn_frames=10)
    return run({name: WebcamObserver(config, cal) for name, cal in calibrations().items()})


def _p(values: list[float], q: float) -> float:
    return float(np.percentile(values, q))


@pytest.mark.parametrize("name", ["exact", "typed"])
def test_feet_on_a_floor_calibration_are_where_they_stand(errors: dict[str, Any], name: str) -> None:
    e = errors[name]
    assert len(e["on_floor"]) >= 30 and len(e["feet"]) >= 50  # feet were found: the figures mean something
    # measured (this machine, exact / typed): on the floor median 0.041 / 0.043 m, p95 0.111 / 0.122 m
    # (the target: 0.10; 0.099 / 0.109 before the adapting background of the real-footage work);
    # all feet p95 0.166 / 0.173 m (a lifted foot is put on the floor). The limit is the silhouette's
    # foot at 320×240 (1–3 px; docs/notes/floor-calibration.md): bounds hold a margin
    assert _p(e["on_floor"], 50) <= 0.06 and _p(e["on_floor"], 95) <= 0.135
    assert _p(e["feet"], 95) <= 0.19
    assert np.allclose(e["foot_z"], FOOT_MIDDLE_M)  # on the floor, at a shoe's middle
    assert _p(e["heads"], 50) <= 0.12  # the head along the vertical above the feet (measured 0.08 m)


def test_the_upright_plane_misplaces_the_same_feet(errors: dict[str, Any]) -> None:
    # the people cross on lanes off the plane y = 0: the upright calibration puts their feet 0.4–0.5 m off
    # (measured median 0.47 m), the floor calibration 10× nearer
    assert _p(errors["upright"]["on_floor"], 50) >= 0.3
    assert _p(errors["upright"]["on_floor"], 50) >= 5 * _p(errors["exact"]["on_floor"], 50)


def test_the_observer_table_builds_a_floor_observer_from_its_file(tmp_path: Path) -> None:
    path = tmp_path / "webcam.calibration.toml"
    floor = calibrations()["exact"]
    assert isinstance(floor, FloorCalibration)
    floor.save(path)
    observer = observer_types()["webcam"].build(WebcamObserverConfig(pose=False), path, "webcam")
    assert isinstance(observer, WebcamObserver)
    # what the silhouette is drawn with: the floor calibration's upright plane, of the same size
    assert isinstance(observer.calibration, Calibration) and observer.calibration.image_size == (W, H)


def test_a_frame_of_another_size_than_the_floor_calibration_is_refused() -> None:
    observer = WebcamObserver(WebcamObserverConfig(pose=False), calibrations()["exact"])
    frame = Frame("webcam", 0.0, 0, ColorImage(np.zeros((120, 160, 3), np.uint8)))
    with pytest.raises(ValueError, match="is 160×120, but the calibration was made for 320×240"):
        observer.observe(frame)


@pytest.mark.slow
def test_keypoint_limbs_on_a_floor_calibration() -> None:
    observer = WebcamObserver(WebcamObserverConfig(pose=True, learn_frames=10), calibrations()["exact"])
    if not observer.pose_active:
        pytest.skip("no pose model files (python -m interaction.webcam.pose_models fetches them)")
    found: list[Any] = []
    clock = SimClock()
    with PerformerSensor(CONFIG, clock) as sensor:
        while clock.now() <= CONFIG.duration_s:
            frame = sensor.read(0.0)
            if frame is None:
                clock.advance(1.0 / CONFIG.fps)
                continue
            found.extend(c for c in observer.observe(frame).contactors if c.part.endswith(("_foot", "_hand")))
    feet = [c for c in found if c.part.endswith("_foot")]
    assert len(feet) >= 50 and all(c.position[2] == pytest.approx(FOOT_MIDDLE_M) for c in feet)
    assert all(np.isfinite(c.velocity).all() for c in found)
