"""`jostle bench sensors`, run small: the figures are there and mean what they say."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from jostle.bench.sensors import DEPTH_SIZE, INTRINSICS, PADS, write_recording
from jostle.cli.bench import main_json
from sensors.recording.info import describe_recording
from sensors.recording.source import iter_frames

KEYS = {"fuzz_bytes", "crashes", "bad_frames_accepted", "pad_frames_per_s", "replay_speed"}


def test_the_bench_reports_every_figure() -> None:
    figures = main_json("sensors", ["--fuzz-bytes", "20000", "--replay-seconds", "1", "--fps", "10", "--seed", "3"])
    assert KEYS <= set(figures)
    assert figures["fuzz_bytes"] >= 20_000
    assert figures["crashes"] == 0 and figures["bad_frames_accepted"] == 0
    assert figures["good_frames_accepted"] == figures["good_frames_sent"] > 0
    assert figures["pad_frames_per_s"] > 0
    # 1 s: 10 depth + 10 colour frames and 100 pad samples, every one replayed
    assert figures["replay_frames"] == 120 and figures["replay_seconds"] == 1.0
    assert figures["replay_speed"] > 0 and figures["replay_speed_one_pass"] > 0
    assert 0 <= figures["replay_open_s"] <= figures["replay_wall_s"]
    # replay_speed is recorded s / wall s; both figures are rounded (wall to 0.1 ms, speed to 0.01)
    wall = figures["replay_wall_s"]
    assert 1.0 / (wall + 5e-5) - 0.005 <= figures["replay_speed"] <= 1.0 / (wall - 5e-5) + 0.005
    assert isinstance(figures["targets_met"], bool)


def test_the_bench_recording_is_what_it_claims() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.mcap"
        counts = write_recording(path, 0.5, 10.0, seed=1)
        info = describe_recording(path)
        assert {c.topic: c.message_count for c in info.sensor_channels} == counts == {"depth": 5, "color": 5,
                                                                                      "pads": 50}
        depth = [f.payload for f in iter_frames(path, "depth")]
        pads = [f.payload for f in iter_frames(path, "pads")]
    d = depth[1].depth_mm  # type: ignore[union-attr]
    assert d.dtype == np.uint16 and (d.shape[1], d.shape[0]) == DEPTH_SIZE
    assert (depth[1].fx, depth[1].fy, depth[1].cx, depth[1].cy) == INTRINSICS  # type: ignore[union-attr]
    assert (d == 0).mean() > 0.01 and np.diff(d.astype(np.int32), axis=1).std() > 1  # holes and noise
    assert not np.array_equal(depth[0].depth_mm, depth[1].depth_mm)  # type: ignore[union-attr]
    assert all(len(p.newtons) == PADS for p in pads)  # type: ignore[union-attr]
