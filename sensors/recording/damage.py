"""Damaged copies of a sound recording, and the share of their intact frames a reader keeps.

:func:`damage_cases` writes copies of a recording that has a usable summary, each damaged one way
byte-wise (a zeroed 4 KB block inside chunk 1, a corrupt chunk 0, a zeroed chunk header, bytes
flipped in the middle chunk, the last chunk cut short), each with its summary kept (read through the
index) and cut off (read record by record). A frame is *intact* when the chunk holding it is
untouched. :func:`recovered_share` plays every sensor channel of every copy and gives frames kept
over frames intact (the hostile bench's ``recovered_share``; the target is ≥ 0.99).
"""

from __future__ import annotations

import os
import random
import struct
from dataclasses import dataclass
from pathlib import Path

from sensors.recording.codec import classify_channel
from sensors.recording.index import ChunkRef, RecordingIndex, read_chunk, read_index
from sensors.recording.source import iter_payloads
from sensors.recording.stream import MCAP_MAGIC

BLOCK = 4096  # bytes zeroed in one go: one disk block


@dataclass(frozen=True, slots=True)
class DamageCase:
    """One damaged copy: what was done, where it is, and how many sensor frames it still holds intact."""

    name: str
    path: Path
    intact_frames: int


@dataclass(frozen=True, slots=True)
class Recovery:
    """Frames kept and intact over every case, and per case as (name, kept, intact)."""

    kept: int
    intact: int
    cases: tuple[tuple[str, int, int], ...]

    @property
    def share(self) -> float:
        """Frames kept over frames intact (1.0 when nothing was intact)."""
        return self.kept / self.intact if self.intact else 1.0


def _frame_channels(index: RecordingIndex) -> dict[int, str]:
    """Channel id → topic of every sensor frame channel."""
    out = {}
    for cid, channel in index.channels.items():
        schema = index.schemas.get(channel.schema_id) if channel.schema_id else None
        role = classify_channel(channel, schema)
        if role.role == "frame" and role.kind in ("color", "depth", "pads"):
            out[cid] = channel.topic
    return out


def _frames_per_chunk(fd: int, index: RecordingIndex) -> list[int]:
    frames = _frame_channels(index)
    return [sum(m.channel.id in frames for m in read_chunk(fd, ref, index.channels, index.schemas))
            for ref in index.chunks]


def _intact(chunks: tuple[ChunkRef, ...], per_chunk: list[int], start: int, end: int) -> int:
    """Frames in the chunks that bytes ``start`` … ``end`` (exclusive) do not touch."""
    return sum(n for ref, n in zip(chunks, per_chunk, strict=True)
               if ref.offset + ref.length <= start or ref.offset >= end)


def damage_cases(source: Path, out_dir: Path, seed: int = 0) -> list[DamageCase]:
    """Damaged copies of ``source`` (a sound recording with a usable summary and ≥ 2 chunks) in
    ``out_dir``. Raises ValueError if ``source`` is not such a recording."""
    data = Path(source).read_bytes()
    with Path(source).open("rb") as f:
        index = read_index(f.fileno(), len(data))
        if index is None or len(index.chunks) < 2:
            raise ValueError(f"{source}: expected a sound recording with a summary and at least 2 chunks")
        per_chunk = _frames_per_chunk(f.fileno(), index)
    chunks = index.chunks
    (summary_start,) = struct.unpack_from("<Q", data, len(data) - len(MCAP_MAGIC) - 20)
    rng = random.Random(seed)
    first, second, middle, last = chunks[0], chunks[1], chunks[len(chunks) // 2], chunks[-1]
    # (name, start, end, new bytes or None to cut the file at start)
    edits: list[tuple[str, int, int, bytes | None]] = [
        ("zeroed 4 KB in chunk 1", second.offset + 64, second.offset + 64 + BLOCK, bytes(BLOCK)),
        ("corrupt chunk 0", first.offset + 80, first.offset + 144, bytes(rng.randrange(256) for _ in range(64))),
        ("zeroed chunk header", middle.offset, middle.offset + 48, bytes(48)),
        ("bytes flipped in a chunk", middle.offset + middle.length // 2, middle.offset + middle.length // 2 + 16,
         bytes(b ^ 0xFF for b in data[middle.offset + middle.length // 2:middle.offset + middle.length // 2 + 16])),
        ("last chunk cut short", last.offset + last.length // 2, len(data), None),
    ]
    out_dir.mkdir(parents=True, exist_ok=True)
    cases = []
    for name, start, end, new in edits:
        damaged = data[:start] if new is None else data[:start] + new + data[end:]
        intact = _intact(chunks, per_chunk, start, end)
        variants = [("summary kept", damaged)] if new is not None else []
        if name != "corrupt chunk 0":  # without a summary, chunk 0 alone declares the channels
            variants.append(("no summary", damaged[:min(summary_start, len(damaged))]))
        for variant, content in variants:
            path = out_dir / f"{name.replace(' ', '_')}.{variant.replace(' ', '_')}.mcap"
            path.write_bytes(content)
            cases.append(DamageCase(f"{name}, {variant}", path, intact))
    return cases


def frames_kept(path: Path) -> int:
    """Sensor frames a reader plays from ``path`` (every sensor channel, damage skipped silently)."""
    from sensors.recording.info import describe_recording

    info = describe_recording(path)
    return sum(sum(1 for _ in iter_payloads(path, c.topic, on_damage=None)) for c in info.sensor_channels)


def recovered_share(source: Path, out_dir: Path, seed: int = 0) -> Recovery:
    """Frames kept over frames intact, over every :func:`damage_cases` copy of ``source`` (written to
    ``out_dir`` and removed again)."""
    results = []
    for case in damage_cases(source, out_dir, seed):
        try:
            results.append((case.name, frames_kept(case.path), case.intact_frames))
        finally:
            os.unlink(case.path)
    return Recovery(sum(k for _, k, _ in results), sum(n for _, _, n in results), tuple(results))
