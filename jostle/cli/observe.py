"""``jostle observe``: the webcam observer on a video file, a camera or a recording, uncalibrated.

Runs :class:`interaction.webcam.observer.WebcamObserver` without a calibration (people in image
space, no stage positions), so an installer can tune detection before calibrating: ``--config``
takes the ``[observers.webcam]`` settings of an installation config, ``--out DIR`` writes the
annotated video (outlines, people ids, contactors, keypoints) as MP4, ``--json`` prints
``{"frames", "observe_fps", "people", "pose_updates_per_person_s", "crowd_frames"}``: frames
observed, frames observed per second of CPU wall time, people per frame, keypoint refreshes per
second of each person's time in view (video time), frames with more people than ``max_people``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

EXAMPLES = """\
examples:
  jostle observe street.mp4 --no-pose --json              people per frame, as JSON
  jostle observe street.mp4 --frames 100:400 --out out/   the annotated video out/street-observed.mp4
  jostle observe street.mp4 --min-person-px 60 --json     people as small as 60 pixels tall
  jostle observe 0 --config configs/webcam.toml --out out/   a live camera with an installation's settings
  jostle observe session.mcap --pose                      a recording's colour channel, with keypoints
"""

_PROGRESS_S = 2.0  # a progress line on stderr at most this often (wall seconds)


def add(sub: Any) -> None:
    p = sub.add_parser(
        "observe", help="find people in a video, camera or recording (uncalibrated), to tune detection",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EXAMPLES,
        description="Run the webcam observer without a calibration: people in image space, counted per frame.",
    )
    p.add_argument("source", help='a video file, a camera index like "0", or an MCAP recording (.mcap)')
    p.add_argument("--config", type=Path, help="take [observers.webcam]'s settings from this installation config")
    p.add_argument("--frames", default=":", metavar="A:B", help="observe frames A to B-1 only (0-based; A: or :B)")
    pose = p.add_mutually_exclusive_group()
    pose.add_argument("--pose", dest="pose", action="store_true", default=None, help="body keypoints on")
    pose.add_argument("--no-pose", dest="pose", action="store_false", help="body keypoints off")
    p.add_argument("--min-person-px", type=int, metavar="PX",
                   help="the smallest person's height in the frame's pixels (overrides the config's min_person_px)")
    p.add_argument("--json", action="store_true", help="print the figures as one JSON object on stdout")
    p.add_argument("--out", type=Path, metavar="DIR", help="write the annotated video DIR/<source>-observed.mp4")
    p.set_defaults(func=_run)


def frame_range(text: str) -> tuple[int, int | None]:
    """``A:B`` → (A, B) with B None when open; a one-line UsageError for anything else."""
    from jostle.errors import UsageError

    a, sep, b = text.partition(":")
    try:
        lo, hi = (int(a) if a.strip() else 0), (int(b) if b.strip() else None)
    except ValueError:
        lo, hi = -1, None
    if not sep or lo < 0 or (hi is not None and hi <= lo):
        raise UsageError(f"--frames: expected A:B with 0 ≤ A < B (whole frame numbers; A: or :B), got {text!r}")
    return lo, hi


def _run(args: argparse.Namespace) -> int:
    from interaction.webcam.config import WebcamObserverConfig
    from interaction.webcam.observer import WebcamObserver

    first, last = frame_range(args.frames)
    cfg = _observer_config(args.config) if args.config else WebcamObserverConfig()
    if args.pose is not None:
        cfg = dataclasses.replace(cfg, pose=args.pose)
    if args.min_person_px is not None:
        cfg = _replaced(cfg, min_person_px=args.min_person_px)
    observer = WebcamObserver(cfg)
    frames, fps = _frames(args.source)
    counts: list[int] = []
    in_view: dict[int, int] = {}
    video = None
    spent = 0.0
    last_report = time.perf_counter()
    try:
        for index, frame in enumerate(frames):
            if index < first:
                continue
            if last is not None and index >= last:
                break
            started = time.perf_counter()
            observation = observer.observe(frame)
            spent += time.perf_counter() - started
            counts.append(observation.people)
            for pid in observer.people:
                in_view[pid] = in_view.get(pid, 0) + 1
            if args.out is not None:
                video = video or _writer(args.out, args.source, frame.payload.bgr.shape, fps)
                video.write(_annotated(frame.payload.bgr, observer))
            if time.perf_counter() - last_report >= _PROGRESS_S:
                last_report = time.perf_counter()
                print(f"jostle: observe: frame {index}, {len(counts) / max(spent, 1e-9):.1f} frames/s, "
                      f"{observation.people} people", file=sys.stderr)
    except BrokenPipeError:
        return 0
    finally:
        if video is not None:
            video.release()
    rates = {str(pid): round(n / (in_view[pid] / fps), 2) for pid, n in sorted(observer.pose_updates.items())
             if in_view.get(pid)}
    figures = {"frames": len(counts), "observe_fps": round(len(counts) / max(spent, 1e-9), 1), "people": counts,
               "pose_updates_per_person_s": rates, "crowd_frames": observer.crowd_frames}
    if args.json:
        print(json.dumps(figures))
    else:
        seen = sum(1 for c in counts if c)
        print(f"jostle: observed {len(counts)} frames at {figures['observe_fps']} frames/s; people in {seen} of them, "
              f"at most {max(counts, default=0)}", file=sys.stderr)
    return 0


def _replaced(cfg: Any, **changes: Any) -> Any:
    from jostle.errors import UsageError

    try:
        return dataclasses.replace(cfg, **changes)
    except ValueError as e:
        raise UsageError(f"--{next(iter(changes)).replace('_', '-')}: {e}") from None


def _observer_config(path: Path) -> Any:
    """The ``[observers.*]`` table with ``type = "webcam"`` of an installation config."""
    from interaction.webcam.config import WebcamObserverConfig
    from jostle.config import load_config
    from jostle.errors import UsageError

    found = [o.config for o in load_config(path).observers if isinstance(o.config, WebcamObserverConfig)]
    if not found:
        raise UsageError(f"{path}: --config: the config has no [observers.*] table with type = \"webcam\"")
    return found[0]


def _frames(source: str) -> tuple[Iterator[Any], float]:
    """The frames of a source in order, and its frame rate (frames per second)."""
    from sensors.webcam.config import source_kind

    if source.endswith(".mcap"):
        return _recording_frames(Path(source))
    from sensors.base import SensorState
    from sensors.clock import SimClock, WallClock
    from sensors.webcam.config import WebcamConfig
    from sensors.webcam.driver import WebcamSensor

    live = source_kind(source) != "file"
    clock = WallClock() if live else SimClock()
    sensor = WebcamSensor(WebcamConfig(source=source), clock, name="observe")
    sensor.open()
    fps = sensor.spec.rate_hz

    def read() -> Iterator[Any]:
        try:
            while True:
                if isinstance(clock, SimClock):
                    clock.advance(1.0 / fps)
                frame = sensor.read(1.0)
                if frame is not None:
                    yield frame
                elif sensor.status.state in (SensorState.ENDED, SensorState.FAILED):
                    return
        finally:
            sensor.close()

    return read(), fps


def _recording_frames(path: Path) -> tuple[Iterator[Any], float]:
    from sensors.base import SensorUnavailable
    from sensors.recording.info import describe_recording
    from sensors.recording.source import iter_frames

    info = describe_recording(path)
    colour = [c for c in info.sensor_channels if c.kind == "color"]
    if len(colour) != 1:
        there = ", ".join(f"{c.topic} ({c.kind})" for c in info.sensor_channels) or "no sensor channels"
        raise SensorUnavailable(f"{path}: expected one colour channel to observe, the recording holds {there}")
    return iter_frames(path, colour[0].topic), colour[0].rate_hz if colour[0].rate_hz > 0 else 30.0


def _writer(out: Path, source: str, shape: tuple[int, ...], fps: float) -> Any:
    import cv2

    from render.gl.video import VideoError

    out.mkdir(parents=True, exist_ok=True)
    name = out / f"{Path(source).stem or 'camera'}-observed.mp4"
    video = cv2.VideoWriter(str(name), cv2.VideoWriter.fourcc(*"mp4v"), fps, (shape[1], shape[0]))
    if not video.isOpened():
        raise VideoError(f"{name}: OpenCV cannot write an mp4v video here")
    return video


_PART_COLOURS = {"head": (0, 255, 255), "hand": (255, 0, 255), "foot": (255, 128, 0)}


def _annotated(bgr: Any, observer: Any) -> Any:
    """The frame with each person's outline and id, its contactors and its keypoints drawn on."""
    import cv2
    import numpy as np

    out = bgr.copy()
    for pid, outline in observer.people.items():
        pts = np.rint(outline).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(out, [pts], True, (0, 255, 0), 2)
        x, y = int(outline[:, 0].min()), int(outline[:, 1].min())
        cv2.putText(out, str(pid), (x, max(12, y - 4)), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 255, 0), 2)
    for c in observer.image_contactors:
        colour = _PART_COLOURS.get(c.part.split("_")[-1], (0, 200, 255))
        cv2.circle(out, (int(c.position[0]), int(c.position[2])), max(2, int(c.radius)), colour, 1)
    for kp in observer.keypoints.values():
        for u, v in np.rint(kp.uv[:33]).astype(np.int32):
            cv2.circle(out, (int(u), int(v)), 3, (0, 0, 255), -1)
    return out
