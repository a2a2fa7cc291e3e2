"""``jostle bench sensors``: the pad parser under fuzz, and how fast a recording replays.

Figures (``--json``):

- ``fuzz_bytes``, ``crashes``, ``bad_frames_accepted``, ``pad_frames_per_s``: from
  :func:`jostle.bench.pad_fuzz.fuzz_parser` (binary framing, 8 pads): random and corrupted bytes fed
  to the parser in random chunks, and the decode rate of a clean stream.
- ``replay_speed``: a recording of depth, colour and 8 force pads, written with
  :class:`sensors.recording.writer.RecordingWriter`, replayed as the app does (one :class:`sensors.recording.replay.Replay`
  per channel on a SimClock, every due frame decoded) as fast as possible: recorded s / wall s.
- ``replay_speed_one_pass`` (one thread), ``replay_cpu_s``, ``replay_wall_s``, ``replay_open_s``,
  ``jpeg_decode_ms``, ``zstd_decompress_s``, ``recording_mb``, ``write_s``, ``cpus``, ``load_average``.

What each figure measures, in full: docs/benches.md.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

PADS = 8
PADS_HZ = 100.0
DEPTH_SIZE = (640, 400)
COLOR_SIZE = (640, 480)
INTRINSICS = (452.5, 452.5, 319.5, 199.5)  # fx, fy, cx, cy of the depth image
TARGETS = {"crashes": 0, "bad_frames_accepted": 0, "pad_frames_per_s": 50_000.0, "replay_speed": 50.0}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fuzz-bytes", type=int, default=1_000_000, metavar="N",
                        help="random and corrupted bytes fed to the pad parser (default 1,000,000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the fuzz stream and the recording (default 0)")
    parser.add_argument("--replay-seconds", type=float, default=10.0, metavar="S",
                        help="length of the depth + colour + pads recording replayed (default 10)")
    parser.add_argument("--fps", type=float, default=30.0, help="depth and colour rate of that recording (default 30)")


class _Scene:
    """Depth and colour of a room with a person walking across, with sensor noise (seeded)."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        w, h = DEPTH_SIZE
        y, x = np.mgrid[0:h, 0:w]
        self.room = (3500.0 - 2.5 * y + 0.3 * x).astype(np.float32)  # floor rising to a back wall
        self.x = x
        self.y = y
        cw, ch = COLOR_SIZE
        cy, cx = np.mgrid[0:ch, 0:cw]
        self.backdrop = np.stack([cx * 200 // cw + 20, cy * 180 // ch + 30, np.full_like(cx, 90)], -1).astype(np.uint8)

    def depth(self, i: int) -> np.ndarray:
        centre = 60 + (7 * i) % (DEPTH_SIZE[0] - 120)
        d = self.room.copy()
        body = (np.abs(self.x - centre) < 40) & (self.y > 60)
        d[body] = 1800.0 + 0.5 * (self.y[body] - 60)
        d += self.rng.normal(0.0, 4.0, d.shape).astype(np.float32)  # stereo noise, a few mm
        d[self.rng.random(d.shape) < 0.02] = 0.0  # holes: no data
        return np.clip(d, 0, 65535).astype(np.uint16)

    def color(self, i: int) -> np.ndarray:
        import cv2

        img = self.backdrop.copy()
        centre = 60 + (7 * i) % (COLOR_SIZE[0] - 120)
        cv2.rectangle(img, (centre - 40, 80), (centre + 40, 470), (40, 60, 200), -1)
        cv2.circle(img, (centre, 60), 30, (150, 180, 230), -1)
        noise = self.rng.integers(-6, 7, img.shape, dtype=np.int16)
        return np.clip(img.astype(np.int16) + noise, 0, 255).astype(np.uint8)


def write_recording(path: Path, seconds: float, fps: float, seed: int) -> dict[str, int]:
    """The bench recording (channels "depth", "color", "pads"); returns frames per channel."""
    from sensors.base import ColorImage, DepthImage, Frame, PadSample
    from sensors.recording.writer import RecordingWriter

    scene = _Scene(seed)
    n_images, n_pads = round(seconds * fps), round(seconds * PADS_HZ)
    events = sorted([(round(i * 1e9 / fps), 0, i) for i in range(n_images)]
                    + [(round(i * 1e9 / PADS_HZ), 1, i) for i in range(n_pads)])
    with RecordingWriter(path) as writer:
        for t_ns, what, i in events:
            t = t_ns / 1e9
            if what == 0:
                writer.write(Frame("depth", t, i, DepthImage(scene.depth(i), *INTRINSICS)))
                writer.write(Frame("color", t, i, ColorImage(scene.color(i))))
            else:
                raw = scene.rng.integers(0, 1 << 17, PADS)
                writer.write(Frame("pads", t, i, PadSample(tuple(float(v) * 0.01 for v in raw),
                                                           tuple(int(v) for v in raw))))
    return {"depth": n_images, "color": n_images, "pads": n_pads}


def replay_all(path: Path, fps: float) -> tuple[int, float, float]:
    """Replay every channel as the app does; (frames, open seconds, total wall seconds)."""
    from sensors.base import SensorState
    from sensors.clock import SimClock
    from sensors.recording.replay import Replay

    clock = SimClock()
    replays = [Replay(path, clock, channel=c) for c in ("depth", "color", "pads")]
    start = time.perf_counter()
    for r in replays:
        r.open()
    opened = time.perf_counter()
    frames = 0
    try:
        while True:
            clock.advance(1.0 / fps)
            for r in replays:
                while r.read(0.0) is not None:
                    frames += 1
            if all(r.status.state is SensorState.ENDED for r in replays):
                break
    finally:
        for r in replays:
            r.close()
    end = time.perf_counter()
    return frames, opened - start, end - start


def decode_one_pass(path: Path) -> tuple[int, float]:
    """Every payload of the file in one thread: the sensors' payloads interleaved by time from one
    shared reader (so each chunk is decompressed once); (payloads, seconds)."""
    import heapq

    from sensors.recording.source import Damaged, open_recording, sensor_items

    start = time.perf_counter()
    recording = open_recording(path)
    payloads = 0
    try:
        def times(sensor: str, order: int) -> Iterator[tuple[int, int]]:
            for item in sensor_items(recording, sensor):
                if not isinstance(item, Damaged):
                    yield item[0], order

        for _ in heapq.merge(*(times(c.topic, i) for i, c in enumerate(recording.info.sensor_channels))):
            payloads += 1
    finally:
        recording.release()
    return payloads, time.perf_counter() - start


def zstd_decompress_s(path: Path) -> float:
    """Every chunk of the file read and decompressed once (CRC checked), in one thread."""
    from sensors.recording.index import read_chunk, read_index

    with path.open("rb") as f:
        index = read_index(f.fileno(), path.stat().st_size)
        if index is None:
            raise RuntimeError(f"{path}: the bench recording has no usable summary")
        start = time.perf_counter()
        for ref in index.chunks:
            read_chunk(f.fileno(), ref, index.channels, index.schemas)
        return time.perf_counter() - start


def jpeg_decode_ms(seed: int, repeats: int = 50) -> float:
    import cv2

    ok, buf = cv2.imencode(".jpg", _Scene(seed).color(0), [cv2.IMWRITE_JPEG_QUALITY, 85])
    if not ok:
        raise RuntimeError("OpenCV cannot encode JPEG")
    start = time.perf_counter()
    for _ in range(repeats):
        cv2.imdecode(buf, cv2.IMREAD_COLOR)
    return (time.perf_counter() - start) / repeats * 1e3


def run(args: argparse.Namespace) -> dict[str, Any]:
    from jostle.bench.pad_fuzz import fuzz_parser

    if args.fuzz_bytes <= 0:
        raise ValueError(f"--fuzz-bytes: expected bytes > 0, got {args.fuzz_bytes}")
    if not args.replay_seconds > 0 or not args.fps > 0:
        raise ValueError(f"--replay-seconds and --fps: expected numbers > 0, got {args.replay_seconds}, {args.fps}")
    fuzz = fuzz_parser(args.fuzz_bytes, args.seed)
    with tempfile.TemporaryDirectory(prefix="jostle-bench-sensors-") as tmp:
        path = Path(tmp) / "depth_color_pads.mcap"
        start = time.perf_counter()
        counts = write_recording(path, args.replay_seconds, args.fps, args.seed)
        write_s = time.perf_counter() - start
        expected = sum(counts.values())
        load = os.getloadavg()[0]
        cpu_start = time.process_time()
        frames, open_s, wall_s = replay_all(path, args.fps)
        cpu_s = time.process_time() - cpu_start
        if frames != expected:
            raise RuntimeError(f"the replay gave {frames} frames of the {expected} recorded")
        payloads, one_pass_s = decode_one_pass(path)
        if payloads != expected:
            raise RuntimeError(f"one pass decoded {payloads} payloads of the {expected} recorded")
        zstd_s = zstd_decompress_s(path)
        size_mb = path.stat().st_size / 1e6
    recorded_s = max(counts["depth"] / args.fps, counts["pads"] / PADS_HZ)
    figures: dict[str, Any] = {
        "fuzz_bytes": fuzz["fuzz_bytes"],
        "crashes": fuzz["crashes"],
        "bad_frames_accepted": fuzz["bad_frames_accepted"],
        "pad_frames_per_s": fuzz["pad_frames_per_s"],
        "replay_speed": round(recorded_s / wall_s, 2),
        "replay_speed_one_pass": round(recorded_s / one_pass_s, 2),
        "replay_seconds": recorded_s,
        "replay_frames": frames,
        "replay_open_s": round(open_s, 4),
        "replay_wall_s": round(wall_s, 4),
        "replay_cpu_s": round(cpu_s, 3),
        "cpus": os.cpu_count(),
        "load_average": round(load, 2),
        "jpeg_decode_ms": round(jpeg_decode_ms(args.seed), 3),
        "zstd_decompress_s": round(zstd_s, 3),
        "recording_mb": round(size_mb, 2),
        "write_s": round(write_s, 2),
        "good_frames_accepted": fuzz["good_frames_accepted"],
        "good_frames_sent": fuzz["good_frames_sent"],
        "bad_counted": fuzz["bad_counted"],
        "first_crash": fuzz["first_crash"],
    }
    figures["targets_met"] = (figures["crashes"] == 0 and figures["bad_frames_accepted"] == 0
                              and figures["pad_frames_per_s"] >= TARGETS["pad_frames_per_s"]
                              and figures["replay_speed"] >= TARGETS["replay_speed"])
    return figures
