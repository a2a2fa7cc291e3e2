"""What a recording holds (``jostle info``), and which channel a replay plays.

A complete file is described from its summary section and message indexes
(:mod:`sensors.recording.index`); a cut or damaged one, or one written without indexes, by reading
every record (:class:`sensors.recording.stream.RecordingStream`). Damaged chunks are skipped and
counted (``RecordingInfo.losses``); stamps that go back or jump beyond the sane gap are not counted.

Damage is reported with ``warnings.warn`` and the category :class:`RecordingDamaged` (a
``UserWarning``): what is readable is kept, the user is told once which file broke, at which byte
and at which time, and tests can catch it with ``pytest.warns``.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from sensors.base import (
    ColorImage,
    DepthImage,
    PadSample,
    Payload,
    RecordingCorrupt,
    SensorUnavailable,
)
from sensors.recording.codec import ChannelRoleInfo, CodecError, PayloadAssembler, classify_channel
from sensors.recording.index import ChunkRef, ChunkUnreadable, RecordingIndex, read_chunk, read_index
from sensors.recording.stream import (
    Losses,
    RecordedMessage,
    RecordingDamage,
    RecordingStream,
    check_recording_file,
)
from sensors.untrusted import Timeline

FRAME_KINDS = ("color", "depth", "pads")
METADATA_NAME = "jostle"


class RecordingDamaged(UserWarning):
    """A recording is truncated or corrupt; the frames before the damage are still played."""


def warn_damage(text: str) -> None:
    warnings.warn(text, RecordingDamaged, stacklevel=3)


@dataclass(frozen=True, slots=True)
class ChannelInfo:
    """One channel of a recording. ``kind`` is the payload kind for sensor channels ("color",
    "depth", "pads"), else the channel's role ("calibration", "aligned_color", "other")."""

    topic: str
    kind: str
    schema_name: str
    message_count: int
    first_ns: int
    last_ns: int
    rate_hz: float
    width: int | None = None
    height: int | None = None
    pads: int | None = None
    bad_times: int = 0  # messages skipped: their stamp went back or jumped beyond the sane gap

    @property
    def first_t(self) -> float:
        return self.first_ns / 1e9

    @property
    def last_t(self) -> float:
        return self.last_ns / 1e9

    @property
    def is_sensor(self) -> bool:
        """True for channels that replay as a sensor (not calibration or aligned colour)."""
        return self.kind in FRAME_KINDS


@dataclass(frozen=True, slots=True)
class RecordingInfo:
    path: Path
    channels: tuple[ChannelInfo, ...]
    duration: float  # seconds from the first to the last sensor message
    size_bytes: int
    metadata: dict[str, str]  # the "jostle" metadata record; other records as "name.key"
    truncated: bool  # damaged or cut short: only the messages before the damage are counted
    damage: str = ""  # where and why, when truncated
    first_ns: int = 0  # first sensor message time, ns (Replay's time origin)
    last_ns: int = 0
    complete: bool = True  # footer and closing magic present
    checked: bool = True  # every record was read (False: described from the summary, chunks not read)
    losses: Losses = field(default_factory=Losses)  # what was skipped (damaged chunks, frames, appended bytes)

    @property
    def sensor_channels(self) -> tuple[ChannelInfo, ...]:
        return tuple(c for c in self.channels if c.is_sensor)


@dataclass
class _Tally:
    role: ChannelRoleInfo
    schema_name: str
    count: int = 0
    first_ns: int = 0
    last_ns: int = 0
    size: tuple[int, int] | None = None
    pads: int | None = None
    refused: int = 0  # messages whose stamp went back or jumped beyond the sane gap
    timeline: Timeline = field(default_factory=lambda: Timeline("channel"))

    def size_from(self, payload: Payload | None) -> None:
        if isinstance(payload, ColorImage | DepthImage):
            self.size = payload.size
        elif isinstance(payload, PadSample):
            self.pads = len(payload.newtons)


def describe_recording(path: Path, *, verify: bool = False) -> RecordingInfo:
    """What a recording holds. Raises SensorUnavailable if the file is missing, RecordingCorrupt if
    it is not MCAP. Damage does not raise: ``truncated`` is set, ``damage`` says where the first is
    and ``losses`` how much was skipped (reading goes on past a damaged chunk).

    A complete file is described from its summary and message indexes (decompressing only a chunk
    holding each sensor's first frame, for its size); chunk contents are then not checked
    (``checked`` is False). ``verify=True`` reads every chunk; a file without a usable summary is
    read record by record.
    """
    path = Path(path)
    size = check_recording_file(path)
    with path.open("rb") as f:
        index = read_index(f.fileno(), size)
        if index is not None:
            fd = f.fileno()
            return describe_indexed(path, index, lambda ref: read_chunk(fd, ref, index.channels, index.schemas),
                                    verify=verify)
    return describe_scan(path)


def describe_indexed(path: Path, index: RecordingIndex, chunk: Callable[[ChunkRef], list[RecordedMessage]],
                     *, verify: bool = False) -> RecordingInfo:
    """Describe a recording from its index; ``chunk`` reads one chunk. Without ``verify`` only a
    chunk holding each sensor's first frame is read (for its size; the next one if it is damaged);
    with it every chunk is read and the description is that of the messages read."""
    if verify:
        return _verified(path, index, chunk)
    tallies: dict[int, _Tally] = {}
    for cid, stats in sorted(index.channel_stats.items()):
        channel = index.channels[cid]
        schema = index.schemas.get(channel.schema_id) if channel.schema_id else None
        tallies[cid] = _Tally(classify_channel(channel, schema), schema.name if schema else "", stats.count,
                              stats.first_ns, stats.last_ns, refused=stats.refused)
    for cid, t in tallies.items():
        if t.role.role != "frame":
            continue
        for ref in (c for c in index.chunks if cid in c.channel_ids):
            try:
                msg = next((m for m in chunk(ref) if m.channel.id == cid), None)
            except ChunkUnreadable:
                continue  # left for Replay to report; the size comes from the next chunk
            if msg is None:
                continue
            try:
                t.size_from(PayloadAssembler().feed(t.role, msg.channel, msg.schema, msg.sequence, msg.log_time_ns,
                                                    msg.data))
            except CodecError:  # left for Replay to report
                continue
            break
    losses = Losses(frames=sum(t.refused for t in tallies.values() if t.role.role == "frame"))
    return _info(path, index.size_bytes, tallies, {cid: index.channels[cid].topic for cid in tallies},
                 index.metadata, damage=None, losses=losses, complete=True, checked=False)


def _verified(path: Path, index: RecordingIndex, chunk: Callable[[ChunkRef], list[RecordedMessage]]) -> RecordingInfo:
    losses = Losses()
    damage: list[RecordingDamage] = []
    good, last_ns = 0, None

    def messages() -> Iterator[RecordedMessage]:
        nonlocal good, last_ns
        for ref in index.chunks:
            try:
                found = chunk(ref)
            except ChunkUnreadable as e:
                if not damage:
                    damage.append(RecordingDamage(ref.offset, index.size_bytes, f"chunk record unreadable: {e}",
                                                  good, last_ns))
                losses.chunks += 1
                losses.bytes += ref.length
                losses.messages += ref.message_count
                continue
            for msg in found:
                good += 1
                last_ns = msg.log_time_ns
                yield msg

    tallies = _tally(messages())
    losses.frames = sum(t.refused for t in tallies.values() if t.role.role == "frame")
    return _info(path, index.size_bytes, tallies, {cid: index.channels[cid].topic for cid in tallies},
                 index.metadata, damage=damage[0] if damage else None, losses=losses, complete=True, checked=True)


def describe_scan(path: Path) -> RecordingInfo:
    """Read the whole recording once (decoding only the first frame of each sensor, for its size)."""
    stream = RecordingStream(Path(path))
    tallies = _tally(stream.messages())
    stream.losses.frames = sum(t.refused for t in tallies.values() if t.role.role == "frame")
    return _info(stream.path, stream.size_bytes, tallies, {cid: stream.channels[cid].topic for cid in tallies},
                 stream.metadata, damage=stream.damage, losses=stream.losses, complete=stream.complete, checked=True)


def _tally(messages: Iterable[RecordedMessage]) -> dict[int, _Tally]:
    """Per channel: count, first and last of the stamps a ``Timeline`` takes (the others counted as
    refused), and the size of each sensor's first frame that decodes."""
    tallies: dict[int, _Tally] = {}
    assemblers: dict[str, PayloadAssembler] = {}
    sized: set[str] = set()  # sensors whose first frame was decoded for its size
    for msg in messages:
        t = tallies.get(msg.channel.id)
        if t is None:
            role = classify_channel(msg.channel, msg.schema)
            t = tallies[msg.channel.id] = _Tally(role, msg.schema.name if msg.schema else "")
        if t.timeline.flag(msg.log_time_ns) is not None:
            t.refused += 1
            continue
        t.count += 1
        t.first_ns = msg.log_time_ns if t.count == 1 else t.first_ns
        t.last_ns = msg.log_time_ns
        sensor = t.role.sensor
        if t.role.role in ("frame", "calibration", "aligned_color") and sensor not in sized:
            assembler = assemblers.setdefault(sensor, PayloadAssembler())
            try:
                payload = assembler.feed(t.role, msg.channel, msg.schema, msg.sequence, msg.log_time_ns, msg.data)
            except CodecError:  # left for Replay to report; the size comes from the next frame
                continue
            if t.role.role == "frame":
                sized.add(sensor)
            t.size_from(payload)
    return dict(sorted(tallies.items()))


def _info(path: Path, size_bytes: int, tallies: dict[int, _Tally], topics: dict[int, str],
          records: dict[str, dict[str, str]], *, damage: RecordingDamage | None, losses: Losses, complete: bool,
          checked: bool) -> RecordingInfo:
    channels = []
    for cid, t in tallies.items():
        kind = t.role.kind if t.role.role == "frame" and t.role.kind in FRAME_KINDS else t.role.role
        span = (t.last_ns - t.first_ns) / 1e9
        rate = (t.count - 1) / span if t.count > 1 and span > 0 else 0.0
        w, h = t.size if t.size else (None, None)
        channels.append(ChannelInfo(topics[cid], kind, t.schema_name, t.count, t.first_ns, t.last_ns, rate, w, h,
                                    t.pads, t.refused))
    sensors = [c for c in channels if c.is_sensor and c.message_count] or [c for c in channels if c.message_count]
    first = min((c.first_ns for c in sensors), default=0)
    last = max((c.last_ns for c in sensors), default=0)
    metadata: dict[str, str] = {}
    for name, record in records.items():
        for key, value in record.items():
            metadata[key if name == METADATA_NAME else f"{name}.{key}"] = value
    return RecordingInfo(
        path=path, channels=tuple(channels), duration=(last - first) / 1e9, size_bytes=size_bytes,
        metadata=metadata, truncated=damage is not None, damage=damage.describe(path) if damage else "",
        first_ns=first, last_ns=last, complete=complete, checked=checked, losses=losses,
    )


def select_channel(info: RecordingInfo, channel: str | None) -> ChannelInfo:
    """The sensor channel to replay: the named one, or the only one. Errors list what is there."""
    sensors = info.sensor_channels
    listing = ", ".join(f"{c.topic} ({c.kind})" for c in sensors)
    if not sensors:
        why = f"; {info.damage}" if info.truncated else ""
        error = RecordingCorrupt if info.truncated else SensorUnavailable
        raise error(f"{info.path}: the recording holds no sensor frames{why}")
    if channel:
        for c in sensors:
            if c.topic == channel:
                return c
        raise SensorUnavailable(f"{info.path}: no sensor channel {channel!r}; it holds {listing}")
    if len(sensors) > 1:
        raise SensorUnavailable(f"{info.path}: the recording holds {len(sensors)} sensor channels ({listing}); "
                                "choose one with channel = \"<name>\"")
    return sensors[0]


def format_info(info: RecordingInfo) -> str:
    """A readable multi-line summary for ``jostle info``."""
    lines = [
        f"recording  {info.path}",
        f"size       {info.size_bytes / 1e6:.2f} MB, {len(info.channels)} channels, "
        f"{info.duration:.3f} s (t {info.first_ns / 1e9:.3f} to {info.last_ns / 1e9:.3f} s)",
    ]
    if info.metadata:
        lines.append("metadata   " + ", ".join(f"{k}={v}" for k, v in sorted(info.metadata.items())))
    lines.append("channels")
    width = max((len(c.topic) for c in info.channels), default=5)
    for c in info.channels:
        shape = f"{c.width}x{c.height}" if c.width is not None else (f"{c.pads} pads" if c.pads is not None else "")
        lines.append(f"  {c.topic:<{width}}  {c.kind:<13} {c.schema_name:<26} {c.message_count:>7} msgs "
                     f"{c.rate_hz:7.2f} Hz  {shape:<9} t {c.first_t:.3f} to {c.last_t:.3f} s")
    status = "complete" if info.checked else "complete (from its summary; chunk contents not read)"
    if info.truncated:
        status = f"DAMAGED: {info.damage}"
    elif info.losses:
        status = "complete, with losses"
    lines.append(f"status     {status}")
    if info.losses:
        lines.append(f"lost       {info.losses.describe()}")
    return "\n".join(lines)
