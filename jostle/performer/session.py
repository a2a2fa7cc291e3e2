"""Recording a performance: every chosen virtual sensor on one simulated clock, into one MCAP file.

The sensors share one :class:`~jostle.performer.scene.Performance`, are opened at clock time 0 and
read as the clock steps at the fastest sensor's rate; each frame goes to its channel (a Recorder
per sensor). With ``truth`` the ground-truth channel gets a message at the time of every camera
frame (``jostle.performer.truth``), or with pads alone, of every n-th pad sample (about ``fps`` a second). The file is written as ``<out>.part`` and renamed when complete.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from jostle.performer.config import DepthCameraConfig, PerformerConfig
from jostle.performer.depth import PerformerDepth
from jostle.performer.pads import PadLayout, PerformerPads, pad_forces
from jostle.performer.performer import PerformerSensor
from jostle.performer.scene import Performance
from jostle.performer.timeline import TimelineSensor
from jostle.performer.truth import (
    CAMERAS_KEY,
    PADS_KEY,
    TRUTH_SCHEMA,
    TRUTH_SCHEMA_NAME,
    TRUTH_TOPIC,
    camera_description,
    pad_layout_description,
    truth_message,
)
from sensors.base import SensorState
from sensors.clock import SimClock
from sensors.recording.codec import ColorFormat
from sensors.recording.writer import Recorder, RecordingWriter


@dataclass(frozen=True)
class SynthSensors:
    """Which virtual sensors to record, and under which channel names."""

    webcam: bool = True
    webcam_name: str = "webcam"
    oak: DepthCameraConfig | None = None
    oak_name: str = "oak"
    pads: PadLayout | None = None
    pads_name: str = "pads"
    truth: bool = False

    def __post_init__(self) -> None:
        if not (self.webcam or self.oak or self.pads):
            raise ValueError("sensors: expected at least one of webcam, oak, pads")
        names = [n for n, on in ((self.webcam_name, self.webcam), (self.oak_name, self.oak is not None),
                                 (self.pads_name, self.pads is not None), (TRUTH_TOPIC, self.truth)) if on]
        if len(set(names)) != len(names):
            raise ValueError(f"sensors: channel names must differ, got {names}")


@dataclass
class SynthSummary:
    """What was written: frames per channel and the time each sensor took per frame."""

    path: Path
    frames: dict[str, int] = field(default_factory=dict)
    ms_per_frame: dict[str, float] = field(default_factory=dict)
    truth_messages: int = 0
    homography: tuple[float, ...] = ()  # the webcam's pixel → stage-plane map, when recorded


def record_performance(
    config: PerformerConfig,
    sensors: SynthSensors,
    out: Path,
    *,
    jpeg_quality: int = 85,
    color_format: ColorFormat = "jpeg",
    metadata: dict[str, str] | None = None,
    on_frame: Callable[[float], None] | None = None,
) -> SynthSummary:
    """Record ``duration_s`` of the performance to ``out``; ``on_frame(t)`` after each clock step."""
    clock = SimClock()
    performance = Performance(config)
    chosen: list[TimelineSensor] = []
    cameras = {}
    webcam = None
    if sensors.webcam:
        webcam = PerformerSensor(config, clock, sensors.webcam_name, performance=performance)
        chosen.append(webcam)
        cameras[sensors.webcam_name] = camera_description(webcam.camera)
    if sensors.oak is not None:
        oak = PerformerDepth(performance, sensors.oak, clock, sensors.oak_name)
        chosen.append(oak)
        cameras[sensors.oak_name] = camera_description(oak.camera)
    if sensors.pads is not None:
        chosen.append(PerformerPads(performance, sensors.pads, clock, sensors.pads_name))
    meta = {"synth": "performer", "clips": ",".join(config.clips), "seed": str(config.seed),
            "people": str(config.people), "route": config.route, CAMERAS_KEY: json.dumps(cameras)}
    if sensors.pads is not None:
        meta[PADS_KEY] = json.dumps(pad_layout_description(sensors.pads))
    meta.update(metadata or {})
    cameras_on = {s.name for s in chosen if s.spec.kind in ("color", "depth")}
    # with no camera, the truth goes with every n-th pad sample, about at the webcam's frame rate
    pads_per_truth = max(1, round(max(s.rate_hz for s in chosen) / config.fps))
    step = 1.0 / max(s.rate_hz for s in chosen)
    summary = SynthSummary(Path(out))
    tmp = Path(out).with_suffix(".mcap.part")
    with RecordingWriter(tmp, metadata=meta, jpeg_quality=jpeg_quality, color_format=color_format) as writer:
        recorders = [Recorder(s, writer) for s in chosen]
        try:
            for rec in recorders:
                rec.open()
            clock_start = clock.now()  # performance time 0
            while any(rec.status.state is not SensorState.ENDED for rec in recorders):
                truth_times: dict[int, float] = {}  # ns → the frame's own t (its exact scene)
                for rec in recorders:
                    while (frame := rec.read(0.0)) is not None:
                        summary.frames[frame.sensor] = summary.frames.get(frame.sensor, 0) + 1
                        if frame.sensor in cameras_on or (not cameras_on and frame.seq % pads_per_truth == 0):
                            truth_times.setdefault(round(frame.t * 1e9), frame.t)
                if sensors.truth:
                    for t_ns in sorted(truth_times):
                        t = truth_times[t_ns]
                        tau = t - clock_start
                        forces = pad_forces(performance, sensors.pads, tau) if sensors.pads is not None else None
                        writer.write_json(TRUTH_TOPIC, TRUTH_SCHEMA_NAME, TRUTH_SCHEMA, t,
                                          truth_message(performance.people_at(tau), forces))
                        summary.truth_messages += 1
                if on_frame is not None:
                    on_frame(clock.now())
                clock.advance(step)
            for s in chosen:
                summary.ms_per_frame[s.name] = s.status.extra.get("ms_per_frame", 0.0)
            if webcam is not None:
                summary.homography = tuple(float(v) for v in webcam.homography().reshape(-1))
        finally:
            for rec in recorders:
                rec.close()
    tmp.replace(out)
    return summary
