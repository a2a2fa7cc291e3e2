"""Hostile recordings, configs and command-line flags, each as a :class:`Case` to run.

Recordings are replayed (``jostle replay``) through a config of three replay sensors with no
observer, so what is measured is the reader: a damaged recording must give one warning and keep
every intact frame (``Case.intact``, counted from the file before it was damaged); a lying image
header, a decompression bomb or a wild time stamp must cost bounded memory and time. Configs and
flags must each give one error line. ``sample=True`` builds one case per kind (the pytest run);
otherwise every variant (the bench).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from jostle.bench.hostile_recordings import (
    chunk_spans,
    drawn_frames,
    header_only_bomb,
    intact_frames,
    jpeg_with_size,
    png_with_size,
    raw_image_with_size,
    write_messages,
    zstd_bomb_chunk,
)
from jostle.bench.hostile_run import Case, Expect
from jostle.bench.hostile_workspace import Workspace
from sensors.base import ColorImage, Frame, PadSample
from sensors.recording.codec import EncodedMessage

GB = 1_000_000_000


def _replay_config(ws: Workspace, recording: Path) -> Path:
    lines = ["[run]", "tail_s = 0.0"]
    for sensor in ("cam", "depth", "pads"):
        lines += [f"[sensors.{sensor}]", 'type = "replay"', f'path = "{recording}"', f'channel = "{sensor}"']
    lines += ["[render]", f'keyframes = "{ws.configs / "keyframes/humanoid/keyframes.toml"}"']
    return ws.config("replay-" + recording.stem, "\n".join(lines) + "\n")


def _replay_case(ws: Workspace, name: str, path: Path, expect: Expect = "warning", intact: int | None = None,
                 sample: bool = False) -> tuple[Case, bool]:
    out = ws.out("recording-" + name)
    argv = ("replay", str(path), "--config", str(_replay_config(ws, path)), "--headless", "--no-video",
            "--quiet", "--out", str(out))
    return Case("recording", name, argv, expect, path.stat().st_size, intact, out / "summary.json"), sample


def recording_cases(ws: Workspace, sample: bool) -> list[tuple[Case, bool]]:
    """Damaged, bombed, lying and mis-timed recordings (see the module docstring)."""
    d = ws.root / "rec"
    d.mkdir(parents=True, exist_ok=True)
    frames = drawn_frames()
    good = write_messages(d / "good.mcap", frames)
    data = good.read_bytes()
    spans = chunk_spans(good)
    cases: list[tuple[Case, bool]] = [_replay_case(ws, "sound", good, "ok", intact_frames(spans, []), True)]

    def damaged(name: str, blob: bytes, ranges: list[tuple[int, int]], in_sample: bool = False) -> None:
        path = d / f"{name}.mcap"
        path.write_bytes(blob)
        intact = intact_frames(spans, ranges)
        cases.append(_replay_case(ws, name, path, "warning" if intact else "line", intact, in_sample))

    c0, c1, c3 = spans[0], spans[1], spans[3]
    zero_at = c1.start + 64
    damaged("zeroed_block_chunk1", data[:zero_at] + bytes(4096) + data[zero_at + 4096:], [(zero_at, zero_at + 4096)],
            True)
    mid = (c0.start + c0.end) // 2
    damaged("corrupt_chunk0", data[:mid] + bytes(b ^ 0xFF for b in data[mid:mid + 64]) + data[mid + 64:],
            [(mid, mid + 64)], True)
    cut = len(data) * 55 // 100
    damaged("truncated_55pct", data[:cut], [(cut, len(data))], True)
    bomb = zstd_bomb_chunk(2_400_000_000 if not sample else GB)
    damaged("bomb_in_chunk3", data[:c3.start] + bomb + data[c3.end:], [(c3.start, c3.end)])
    if not sample:
        for k in (2, len(spans) // 2, len(spans) - 2):
            s = spans[k]
            damaged(f"zeroed_chunk{k}", data[:s.start] + bytes(s.end - s.start) + data[s.end:], [(s.start, s.end)])
        damaged("truncated_header", data[:40], [(0, len(data))])
        cut = len(data) - 100
        damaged("truncated_summary", data[:cut], [(cut, len(data))])
    path = header_only_bomb(d / "zstd_bomb.mcap", 2_400_000_000 if not sample else GB)
    cases.append((Case("recording", "zstd_bomb_info", ("info", str(path)), "any", path.stat().st_size), True))
    cases.append(_replay_case(ws, "zstd_bomb_replay", path, "line"))
    empty = d / "empty.mcap"
    empty.write_bytes(b"")
    cases.append(_replay_case(ws, "empty_file", empty, "error"))
    cases.append(_replay_case(ws, "concatenated", _write(d / "concatenated.mcap", data + data), "warning", None, True))

    def lying(name: str, fn: Callable[[EncodedMessage], bytes | None], in_sample: bool = False) -> None:
        done: list[int] = []

        def tamper(index: int, m: EncodedMessage) -> bytes | None:
            """The first message ``fn`` changes at or after frame 30 (one lying image in the file)."""
            if index < 30 or done:
                return None
            data = fn(m)
            if data is not None:
                done.append(index)
            return data

        path = write_messages(d / f"{name}.mcap", frames, tamper=tamper)
        cases.append(_replay_case(ws, name, path, "line", None, in_sample))

    lying("jpeg_30000x30000", lambda m: _jpeg_claiming(m.data, 30000, 30000) if m.topic == "cam" else None, True)
    lying("jpeg_65000x65000", lambda m: _jpeg_claiming(m.data, 65000, 65000) if m.topic == "cam" else None)
    if not sample:
        lying("png_20000x20000", lambda m: _as_png(m, 20000, 20000) if m.topic == "cam" else None)
        lying("raw_8000x6000", lambda m: raw_image_with_size(m.data, 8000, 6000) if m.topic == "depth" else None)
    jump = write_messages(d / "time_jump.mcap", frames, stamp=lambda i, t: 10**19 - 1 if i == 10 else t)
    cases.append(_replay_case(ws, "time_jump_1e19ns", jump, "line", None, True))
    return cases


def _write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def _jpeg_claiming(message: bytes, width: int, height: int) -> bytes:
    """A CompressedImage message whose JPEG's frame header claims another size (same length)."""
    start = message.index(b"\xff\xd8\xff")
    return message[:start] + jpeg_with_size(message[start:], width, height)


def _as_png(m: EncodedMessage, width: int, height: int) -> bytes:
    """The colour message re-encoded as PNG whose header claims ``width × height``."""
    import cv2
    import numpy as np
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage

    msg = CompressedImage()
    msg.ParseFromString(m.data)
    image = cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError("the colour message does not decode")
    ok, png = cv2.imencode(".png", image)
    msg.data, msg.format = png_with_size(png.tobytes(), width, height), "png"
    return bytes(msg.SerializeToString())


def observer_cases(ws: Workspace, sample: bool) -> list[tuple[Case, bool]]:
    """Data that changes under a running observer: the webcam's frame size (from frame 20 on), the
    number of pads (in one pad frame: 3, 0 or 10⁶)."""
    import numpy as np

    d = ws.root / "rec"
    d.mkdir(parents=True, exist_ok=True)

    def changed(f: Frame, resize: bool, pads: int | None) -> Frame:
        if resize and f.sensor == "cam" and f.seq >= 20:
            return Frame(f.sensor, f.t, f.seq, ColorImage(np.full((150, 200, 3), 90, np.uint8)))
        if pads is not None and f.sensor == "pads" and f.seq == 60:
            return Frame(f.sensor, f.t, f.seq, PadSample((1.0,) * pads, (512,) * pads))
        return f

    cases: list[tuple[Case, bool]] = []
    variants = [("frame_size", True, None), ("pads_3", False, 3), ("pads_0", False, 0), ("pads_1e6", False, 10**6)]
    for name, resize, pads in variants[:2] if sample else variants:
        frames = [changed(f, resize, pads) for f in drawn_frames() if f.sensor != "depth"]
        path = write_messages(d / f"{name}.mcap", frames)
        cfg = ws.config(f"observers-{name}", f"""[run]\ntail_s = 0.0
[sensors.cam]\ntype = "replay"\npath = "{path}"\nchannel = "cam"
[sensors.pads]\ntype = "replay"\npath = "{path}"\nchannel = "pads"
[observers.webcam]\ntype = "webcam"\nsensor = "cam"\ncalibration = "recordings/demo.calibration.toml"
learn_frames = 5
[observers.pads]\ntype = "pads"\nsensor = "pads"
positions = [-2.0,0.0,1.0, -0.7,0.0,1.0, 0.7,0.0,1.0, 2.0,0.0,1.0]
directions = [0.0,1.0,0.0, 0.0,1.0,0.0, 0.0,1.0,0.0, 0.0,1.0,0.0]
[render]\nkeyframes = "keyframes/humanoid/keyframes.toml"\n""")
        out = ws.out(f"observers-{name}")
        argv = ("run", str(cfg), "--headless", "--no-video", "--quiet", "--out", str(out))
        cases.append((Case("observers", name, argv, "line", path.stat().st_size), True))
    return cases


def config_cases(ws: Workspace, sample: bool) -> list[tuple[Case, bool]]:
    """Configs that are not files, that nest or repeat without end, and numbers out of range."""
    cases: list[tuple[Case, bool]] = []

    def add(name: str, path: Path | None, expect: Expect = "error", in_sample: bool = False, *extra: str) -> None:
        if path is None:
            ws.skipped.append(f"config-{name} (mknod refused)")
            return
        size = path.stat().st_size if path.is_file() else 0
        cases.append((Case("config", name, ws.run_argv(path, "config-" + name, *extra), expect, size), in_sample))

    add("fifo", ws.fifo("config.fifo.toml"), in_sample=True)
    add("dev_zero_twin", ws.device_twin("zero.toml", 5), in_sample=True)
    folder = ws.root / "in" / "folder.toml"
    folder.mkdir(parents=True, exist_ok=True)
    add("folder", folder)
    loop_a, loop_b = ws.root / "in" / "loop_a.toml", ws.root / "in" / "loop_b.toml"
    if not loop_a.is_symlink():
        loop_a.symlink_to(loop_b)
        loop_b.symlink_to(loop_a)
    cases.append((Case("config", "symlink_loop", ws.run_argv(loop_a, "config-symlink_loop"), "error"), True))
    add("nested_3000", ws.config("nested", "[run]\nseed = " + "[" * 3000 + "]" * 3000 + "\n"), in_sample=True)
    add("dotted_20000", ws.config("dotted", "a" + ".a" * 19999 + " = 1\n"), in_sample=True)
    sensors = "".join(f'[sensors.s{i}]\ntype = "replay"\npath = "recordings/demo.mcap"\nchannel = "webcam"\n'
                      for i in range(10_000))
    add("sensors_10000", ws.config("sensors10000", sensors + '[render]\nkeyframes = "keyframes/humanoid/keyframes.toml"\n'),
        in_sample=True)
    numbers = [("tail_nan", "tail_s = 3.0", "tail_s = nan"), ("tail_inf", "tail_s = 3.0", "tail_s = inf"),
               ("duration_nan", "tail_s = 3.0", "tail_s = 3.0\nduration_s = nan"),
               ("duration_1e308", "tail_s = 3.0", "tail_s = 3.0\nduration_s = 1e308"),
               ("seed_minus1", "seed = 7", "seed = -1"), ("fps_1e308", "fps = 30", "fps = 1e308"),
               ("world_inf", "x_max = 3.0", "x_max = inf"), ("unknown_key", "[render]", "[render]\nfsp = 30"),
               ("string_10mb", "seed = 7", 'seed = "' + "A" * 10_000_000 + '"')]
    for name, old, new in numbers:
        if sample and name not in ("tail_nan", "duration_1e308", "seed_minus1", "string_10mb"):
            continue
        path = ws.demo_with("config-" + name, old, new)
        argv = ws.run_argv(path, "config-" + name)
        if name in ("tail_nan", "tail_inf", "duration_nan", "duration_1e308"):
            argv = argv[:-4] + argv[-2:]  # without --duration: the config's own numbers decide
        cases.append((Case("config", name, argv, "error", path.stat().st_size, max_line_chars=1000), True))
    return cases


def cli_cases(ws: Workspace, sample: bool) -> list[tuple[Case, bool]]:
    """``--duration`` not a finite number ≥ 0, and a seed out of range."""
    demo = ws.configs / "demo.toml"
    cases = []
    for name, flag in (("duration_nan", ("--duration", "nan")), ("duration_inf", ("--duration", "inf")),
                       ("duration_minus1", ("--duration=-1",)), ("seed_minus1", ("--seed=-1",))):
        argv = ("run", str(demo), "--headless", "--no-video", "--quiet", "--out", str(ws.out("cli-" + name)), *flag)
        cases.append((Case("cli", name, argv, "error"), name != "seed_minus1"))
    return cases
