"""``jostle bench interaction``: the observers against virtual-performer ground truth.

Records crossings of 1 to 4 people (:mod:`jostle.performer`: webcam, OAK depth and ground truth; 15 fps
unless ``--fps`` says otherwise) into a temporary folder, calibrates the depth camera from its own
empty-stage frames, runs the webcam and depth observers over every frame, fuses them and scores
against the truth (where hands and feet really are: :mod:`jostle.bench.truth`):

- ``*_fps``, ``latency_ms_p99``, ``page_faults_per_frame_*``: the cost of ``observe()`` and the fusion;
- ``depth_extremity_error_m_p95`` / ``webcam_extremity_error_m_p95`` (metres) and their
  ``*_found_share``: hand and foot contactors against the true hands and feet;
- ``velocity_direction_error_deg_p95`` (degrees) and its references ``_sampled_truth``,
  ``_vs_frame_step`` and ``_best_linear``: what the frame rate allows, and the tracker's own error;
- ``person_count_accuracy``: depth frames whose count of people is right.

``TARGETS`` are the issue's targets. What each figure measures, in full: docs/benches.md.
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from jostle.bench.truth import (
    MOVING_M_S,
    SAME_PART_M,
    LinearCeiling,
    angle_deg,
    part_centres,
    sampled_truth_angles,
    true_steps,
    visible_people,
)

TARGETS: dict[str, tuple[str, float]] = {
    "webcam_fps": (">=", 120.0), "webcam_pose_fps": (">=", 0.0), "depth_fps": (">=", 200.0),
    "latency_ms_p99": ("<", 10.0), "depth_extremity_error_m_p95": ("<=", 0.05),
    "webcam_extremity_error_m_p95": ("<=", 0.10), "velocity_direction_error_deg_p95": ("<=", 15.0),
    "person_count_accuracy": (">=", 0.99),
}
_SETUP_SETTLE_S = 0.3  # pause between the setup and the timed frames (see _settle)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true", help="small and short: 320×240 / 320×200, 1 and 2 people")
    parser.add_argument("--people", default="1,2,3,4", help="the crossings to record (default 1,2,3,4)")
    parser.add_argument("--duration", type=float, default=5.0, metavar="S", help="seconds per recording (default 5)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--fps", type=float, default=15.0,
                        help="frame rate the webcam and the depth camera are recorded at (default 15; installations "
                             "run the OAK at 30): it sets how far a hand moves between frames")
    parser.add_argument("--keep", type=Path, default=None, metavar="DIR", help="record into DIR and keep the files (recordings already there are reused)")
    parser.add_argument("--shoe-model", action=argparse.BooleanOptionalAction, default=True,
                        help="correct the depth observer's feet with the shipped shoe model (default); "
                             "--no-shoe-model: the shoe rules alone (interaction.depth.shoe_model)")


def run(args: argparse.Namespace) -> dict[str, Any]:
    import cv2

    cv2.setNumThreads(1)
    try:
        counts = [int(v) for v in str(args.people).split(",") if v.strip()]
    except ValueError:
        counts = []
    if not counts or not all(1 <= n <= 4 for n in counts):
        raise ValueError(f"--people: expected numbers 1..4 like 1,2,3,4, got {args.people!r}")
    if args.quick:
        counts = [n for n in counts if n <= 2][:2] or [1]
    if not (isinstance(args.fps, int | float) and 1.0 <= args.fps <= 120.0):
        raise ValueError(f"--fps: expected a frame rate from 1 to 120, got {args.fps!r}")
    size, depth_size = ((320, 240), (320, 200)) if args.quick else ((640, 480), (640, 400))
    duration = min(args.duration, 3.5) if args.quick else args.duration
    with tempfile.TemporaryDirectory(prefix="jostle-bench-") as tmp:
        folder = args.keep if args.keep is not None else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        scores = _Scores()
        for n in counts:
            # --keep: a folder's recordings are reused, so the name says all that made one
            path = folder / f"crossing{n}-seed{args.seed}-{args.fps:g}fps-{duration:g}s-{size[0]}x{size[1]}.mcap"
            if not (args.keep is not None and path.is_file()):
                _record(path, n, size, depth_size, duration, args.seed + n, args.fps)
            _score_recording(path, scores, pose=False, shoe_model=args.shoe_model)
            if n == 1:
                _score_recording(path, scores, pose=True, shoe_model=args.shoe_model)
    figures = scores.figures()
    figures["recordings"] = ",".join(f"{n} people" for n in counts)
    figures["sizes"] = f"webcam {size[0]}x{size[1]}, depth {depth_size[0]}x{depth_size[1]}"
    figures["frames_per_s"] = args.fps
    figures["shoe_model"] = bool(args.shoe_model)  # feet corrected by interaction.depth.shoe_model (else the rules alone)
    figures["targets_met"] = {k: _met(figures.get(k), *TARGETS[k]) for k in TARGETS if k != "webcam_pose_fps"}
    return figures


# ---------------------------------------------------------------- recording


def _record(path: Path, people: int, size: tuple[int, int], depth_size: tuple[int, int], duration: float,
            seed: int, fps: float) -> None:
    from jostle.performer.config import DepthCameraConfig, PerformerConfig
    from jostle.performer.session import SynthSensors, record_performance

    config = PerformerConfig(clips=("walk", "punch"), width=size[0], height=size[1], fps=fps,
                             duration_s=duration, seed=seed, empty_s=1.0, people=people, route="crossing")
    oak = DepthCameraConfig(width=depth_size[0], height=depth_size[1], fps=fps, color=False)
    record_performance(config, SynthSensors(webcam=True, oak=oak, truth=True), path)


# ---------------------------------------------------------------- scoring


class _Scores:
    def __init__(self) -> None:
        self.times: dict[str, list[float]] = {"webcam": [], "webcam_pose": [], "depth": []}
        self.latency: list[float] = []
        self.latency_depth: list[float] = []
        self.page_faults: list[int] = []  # minor page faults per frame, the frames of ``latency``
        self.depth_error: list[float] = []
        self.webcam_error: list[float] = []
        self.angle: list[float] = []
        self.angle_sampled_truth: list[float] = []  # the exact centres differenced at the depth frames' times
        self.angle_vs_step: list[float] = []  # the claimed velocities against the true part's last frame step
        self.ceiling = LinearCeiling()  # the best linear tracker on the exact centres
        self.count_right = 0
        self.count_frames = 0
        self.found = 0  # true hands/feet with a depth contactor of the part within SAME_PART_M
        self.truths = 0
        self.withheld = 0  # contactors at a moving hand/foot that claimed no velocity
        self.webcam_found = 0  # true hands/feet in the webcam's image with a contactor of the part within SAME_PART_M
        self.webcam_truths = 0

    def figures(self) -> dict[str, Any]:
        def fps(k: str) -> float | None:
            t = self.times[k]
            return round(len(t) / sum(t), 1) if t else None

        def p(v: list[float], q: float, digits: int) -> float | None:
            return round(float(np.percentile(v, q)), digits) if v else None

        best_linear = self.ceiling.angles()
        return {
            "webcam_fps": fps("webcam"), "webcam_pose_fps": fps("webcam_pose"), "depth_fps": fps("depth"),
            "latency_ms_p99": p(self.latency, 99, 2),
            "latency_ms_p99_depth": p(self.latency_depth, 99, 2),
            "latency_ms_p99_webcam": p([t * 1000 for t in self.times["webcam"]], 99, 2),
            "page_faults_per_frame_p99": p([float(f) for f in self.page_faults], 99, 1),
            "page_faults_per_frame_mean": (round(sum(self.page_faults) / len(self.page_faults), 1)
                                           if self.page_faults else None),
            "depth_extremity_error_m_p95": p(self.depth_error, 95, 3),
            "depth_extremity_error_m_p50": p(self.depth_error, 50, 3),
            "webcam_extremity_error_m_p95": p(self.webcam_error, 95, 3),
            "webcam_extremity_error_m_p50": p(self.webcam_error, 50, 3),
            "velocity_direction_error_deg_p95": p(self.angle, 95, 1),
            "velocity_direction_error_deg_p50": p(self.angle, 50, 1),
            "velocity_samples": len(self.angle),
            "velocity_direction_error_deg_p95_sampled_truth": p(self.angle_sampled_truth, 95, 1),
            "velocity_direction_error_deg_p50_sampled_truth": p(self.angle_sampled_truth, 50, 1),
            "velocity_samples_sampled_truth": len(self.angle_sampled_truth),
            "velocity_direction_error_deg_p95_best_linear": p(best_linear, 95, 1),
            "velocity_direction_error_deg_p50_best_linear": p(best_linear, 50, 1),
            "velocity_withheld": self.withheld,
            "velocity_direction_error_deg_p95_vs_frame_step": p(self.angle_vs_step, 95, 1),
            "velocity_direction_error_deg_p50_vs_frame_step": p(self.angle_vs_step, 50, 1),
            "depth_extremity_found_share": round(self.found / self.truths, 3) if self.truths else None,
            "webcam_extremity_found_share": (round(self.webcam_found / self.webcam_truths, 3)
                                             if self.webcam_truths else None),
            "person_count_accuracy": round(self.count_right / self.count_frames, 4) if self.count_frames else None,
            "person_count_frames": self.count_frames,
        }


def _score_recording(path: Path, scores: _Scores, *, pose: bool, shoe_model: bool = True) -> None:
    """Run the observers over one synthetic recording (channels webcam, oak, truth) and add up the scores."""
    from interaction.depth import DepthObserver, DepthObserverConfig
    from interaction.fusion import SensorFusion
    from interaction.types import BodyObservation
    from interaction.webcam import WebcamObserver, WebcamObserverConfig
    from interaction.webcam.calibration import Calibration
    from jostle.performer.truth import read_cameras, read_truth
    from sensors.base import DepthImage, Frame
    from sensors.recording.source import iter_payloads

    cameras = read_cameras(path)
    truth = {round(f.t * 1000): f for f in read_truth(path)}
    webcam_cam = cameras["webcam"]
    homography = webcam_cam.plane_homography(0.0)  # the exact calibration `jostle synth` writes beside it
    calibration = Calibration(tuple(float(v) for v in homography.reshape(-1)), 0.0, 1.0,
                              (webcam_cam.width, webcam_cam.height))
    webcam = WebcamObserver(WebcamObserverConfig(pose=pose, pose_sync=True), calibration)  # inline: its cost
    _settle()
    for t_ns, seq, payload in iter_payloads(path, "webcam"):
        frame = Frame("webcam", t_ns / 1e9, seq, payload)
        faults = _minor_faults()
        t0 = time.perf_counter()
        obs = webcam.observe(frame)
        took = time.perf_counter() - t0
        faults = _minor_faults() - faults
        scores.times["webcam_pose" if pose else "webcam"].append(took)
        if not pose:
            scores.latency.append(took * 1000)
            scores.page_faults.append(faults)
        if not pose and not webcam.learning:
            _webcam_errors(obs, truth.get(round(frame.t * 1000)), webcam_cam, homography, scores)
    webcam.close()
    if pose:
        return
    depth_frames = [(t_ns, seq, p) for t_ns, seq, p in iter_payloads(path, "oak") if isinstance(p, DepthImage)]
    depth = DepthObserver(DepthObserverConfig(shoe_model=shoe_model), _depth_calibration([p for _, _, p in depth_frames[:8]],
                                                                    cameras["oak"].position))
    _settle()
    fusion = SensorFusion()
    previous_truth = None
    scores.ceiling.new_recording()
    for t_ns, seq, payload in depth_frames:
        frame = Frame("oak", t_ns / 1e9, seq, payload)
        faults = _minor_faults()
        t0 = time.perf_counter()
        obs = depth.observe(frame)
        t1 = time.perf_counter()
        fusion.merge(frame.t, [BodyObservation(frame.t), obs])
        t2 = time.perf_counter()
        scores.page_faults.append(_minor_faults() - faults)
        scores.times["depth"].append(t1 - t0)
        scores.latency.append((t2 - t0) * 1000)
        scores.latency_depth.append(scores.latency[-1])
        frame_truth, last_truth = truth.get(round(frame.t * 1000)), previous_truth
        previous_truth = frame_truth
        if frame_truth is not None:
            scores.ceiling.add(frame_truth, score=not depth.learning)
        if depth.learning or frame_truth is None:
            continue
        _depth_errors(obs, frame_truth, last_truth, scores)
        if last_truth is not None:
            scores.angle_sampled_truth.extend(sampled_truth_angles(last_truth, frame_truth))
        expected = visible_people(frame_truth, cameras["oak"])
        if expected is not None:
            scores.count_frames += 1
            scores.count_right += int(obs.people == expected)


def _settle() -> None:
    """Pause before timed frames. numpy's BLAS threads (OpenBLAS) spin ~0.1 s (2^28 cycles) after large
    linear algebra before they sleep; after the depth calibration's floor fit (its SVD) a worker was
    measured busy through the first ~25 depth frames, on a loaded 2-core machine sharing the observer's
    core. The timed frames are to be the observer's alone (an installation loads its calibration)."""
    time.sleep(_SETUP_SETTLE_S)


def _minor_faults() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def _depth_calibration(images: list[Any], camera_position: tuple[float, float, float]) -> Any:
    """The calibration a user would make: the floor from the first (empty) frames, the foot point given."""
    import warnings

    from interaction.depth.calibration import calibrate_depth, fit_floor

    stack = np.stack([im.depth_mm for im in images]).astype(np.float32)
    stack[stack == 0] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        median = np.nan_to_num(np.nanmedian(stack, axis=0)).astype(np.uint16)
    im = images[0]
    fit = fit_floor(median, (im.fx, im.fy, im.cx, im.cy))
    return calibrate_depth(fit, (camera_position[0], camera_position[1]), 0.0, im.size)


def _depth_errors(obs: Any, frame_truth: Any, last_truth: Any, scores: _Scores) -> None:
    for part in ("hand", "foot"):
        joints = part_centres(frame_truth, part)
        if not joints:
            continue
        steps = true_steps(last_truth, frame_truth, part) if last_truth is not None else {}
        pos = np.array([j[1] for j in joints])
        mine = [c for c in obs.contactors if c.part == part]
        if mine:
            near = np.min(np.linalg.norm(pos[:, None, :] - np.array([c.position for c in mine])[None], axis=2), axis=1)
            scores.found += int(np.count_nonzero(near <= SAME_PART_M))
        scores.truths += len(joints)
        for c in mine:
            d = np.linalg.norm(pos - np.array(c.position), axis=1)
            k = int(np.argmin(d))
            scores.depth_error.append(float(d[k]))
            key, true_v, v = joints[k][0], joints[k][2], np.array(c.velocity)
            if np.linalg.norm(true_v) <= MOVING_M_S or d[k] > SAME_PART_M:
                continue  # velocity: only for a contactor that is at a moving hand (foot)
            angle = angle_deg(v, true_v)
            if angle is None:
                scores.withheld += 1
                continue
            scores.angle.append(angle)
            step = steps.get(key)
            step_angle = angle_deg(v, step) if step is not None else None
            if step_angle is not None:
                scores.angle_vs_step.append(step_angle)


def _webcam_errors(obs: Any, frame_truth: Any, camera: Any, homography: np.ndarray, scores: _Scores) -> None:
    from jostle.performer.camera import apply_homography

    if frame_truth is None:
        return
    for part in ("hand", "foot"):
        joints = part_centres(frame_truth, part)
        if not joints:
            continue
        uv = camera.project(np.array([j[1] for j in joints]))
        on_plane = apply_homography(homography, uv)
        mine = np.array([[c.position[0], c.position[2]] for c in obs.contactors if c.part == part]).reshape(-1, 2)
        for xz in mine:
            d = np.linalg.norm(on_plane - xz, axis=1)
            scores.webcam_error.append(float(d.min()))
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < camera.width) & (uv[:, 1] >= 0) & (uv[:, 1] < camera.height)
        scores.webcam_truths += int(np.count_nonzero(inside))
        if len(mine):
            near = np.min(np.linalg.norm(on_plane[:, None, :] - mine[None], axis=2), axis=1)
            scores.webcam_found += int(np.count_nonzero(inside & (near <= SAME_PART_M)))


def _met(value: Any, op: str, target: float) -> bool | None:
    if not isinstance(value, int | float):
        return None
    return {"<": value < target, "<=": value <= target, ">=": value >= target}[op]
