"""Recording: frames → an MCAP file (one channel per sensor), and the ``Recorder`` wrapper.

What "identical" means when a replay is recorded again (``record(replay(f))``):

- depth and pad frames, and colour recorded with ``color_format="png"``: bit-exact. Replaying the
  new file gives frames whose :func:`frame_digest` equals those of ``replay(f)``.
- colour recorded as JPEG (the default): sensor, time, sequence and image size are exact; the
  pixels are JPEG-decoded and re-encoded, which is lossy: compare them within a tolerance, or use
  PNG when a chain of re-recordings must stay exact. Figures: docs/notes/recording-jpeg.md.

Times: ``Frame.t`` (seconds) is stored as integer nanoseconds (MCAP log and publish time, and the
message's own timestamp), so it is rounded to 1 ns; a replayed time is ``ns / 1e9``.

Data that is not a sensor frame (the virtual performer's ground truth, annotations) goes in with
:meth:`RecordingWriter.write_json` on a channel of its own, which replays leave alone.
"""

from __future__ import annotations

import json
import threading
from datetime import UTC, datetime
from importlib import metadata as importlib_metadata
from pathlib import Path
from types import TracebackType
from typing import Any

from mcap.writer import CompressionType, Writer

from sensors.base import Frame, Sensor, SensorContext, SensorSpec, SensorStatus
from sensors.recording.codec import (
    META_KIND,
    META_ROLE,
    META_SENSOR,
    ColorFormat,
    EncodedMessage,
    encode_frame,
    schema_definition,
)
from sensors.recording.info import METADATA_NAME
from sensors.untrusted import check_owned

_RESERVED_METADATA = ("created", "jostle_version")
_UINT32 = 2**32


def jostle_version() -> str:
    try:
        return importlib_metadata.version("jostle")
    except importlib_metadata.PackageNotFoundError:
        return "unknown"


def seconds_to_ns(t: float) -> int:
    return round(t * 1e9)


class RecordingWriter:
    """Writes frames to an MCAP file; a context manager; ``close()`` is idempotent.

    Chunks are zstd-compressed and flushed at least every ``flush_interval_s`` of recorded time, so
    a process that dies loses at most that much. Thread-safe (one lock around each write).
    """

    def __init__(
        self,
        path: Path,
        *,
        metadata: dict[str, str] | None = None,
        jpeg_quality: int = 85,
        color_format: ColorFormat = "jpeg",
        chunk_size: int = 512 * 1024,
        flush_interval_s: float = 2.0,
    ) -> None:
        if not 1 <= jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality: expected 1..100, got {jpeg_quality}")
        if color_format not in ("jpeg", "png"):
            raise ValueError(f"color_format: expected 'jpeg' or 'png', got {color_format!r}")
        if chunk_size <= 0:
            raise ValueError(f"chunk_size: expected bytes > 0, got {chunk_size}")
        if not flush_interval_s > 0:
            raise ValueError(f"flush_interval_s: expected seconds > 0, got {flush_interval_s}")
        extra = dict(metadata or {})
        for key, value in extra.items():
            if key in _RESERVED_METADATA:
                raise ValueError(f"metadata: key {key!r} is written by jostle itself")
            if not isinstance(key, str) or not isinstance(value, str):
                raise ValueError(f"metadata: keys and values must be strings, got {key!r}: {value!r}")
        self.path = check_owned(path)  # a FIFO, device or symlink there is refused by name, never opened
        self._jpeg_quality = jpeg_quality
        self._color_format: ColorFormat = color_format
        self._flush_ns = seconds_to_ns(flush_interval_s)
        self._lock = threading.Lock()
        self._file = self.path.open("wb")
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library=f"jostle/{jostle_version()}")
        created = datetime.now(UTC).isoformat(timespec="seconds")
        self._writer.add_metadata(METADATA_NAME, {"created": created, "jostle_version": jostle_version(), **extra})
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, tuple[int, str]] = {}  # topic → (channel id, schema name)
        self._sensor_kind: dict[str, str] = {}
        self._sensor_last_ns: dict[str, int] = {}
        self._json_seq: dict[str, int] = {}
        self._json_last_ns: dict[str, int] = {}
        self._last_flush_ns: int | None = None
        self._closed = False
        self.frames_written = 0

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def _channel(self, m: EncodedMessage) -> int:
        known = self._channels.get(m.topic)
        if known is not None:
            if known[1] != m.schema_name:
                raise ValueError(f"sensor {m.sensor!r}: channel {m.topic!r} already holds {known[1]}, "
                                 f"cannot write {m.schema_name} to it (rename one of the sensors)")
            return known[0]
        schema_id = self._schemas.get(m.schema_name)
        if schema_id is None:
            d = schema_definition(m.schema_name)
            schema_id = self._writer.register_schema(name=d.name, encoding=d.encoding, data=d.data)
            self._schemas[m.schema_name] = schema_id
        channel_id = self._writer.register_channel(
            topic=m.topic, message_encoding=m.message_encoding, schema_id=schema_id,
            metadata={META_SENSOR: m.sensor, META_ROLE: m.role, META_KIND: m.kind},
        )
        self._channels[m.topic] = (channel_id, m.schema_name)
        return channel_id

    def write(self, frame: Frame) -> None:
        """Append one frame to the channel named ``frame.sensor`` (created on first use)."""
        t_ns = seconds_to_ns(frame.t)
        if t_ns < 0:
            raise ValueError(f"sensor {frame.sensor!r}: t={frame.t} s; MCAP times cannot be negative")
        if not 0 <= frame.seq < _UINT32:
            raise ValueError(f"sensor {frame.sensor!r}: seq={frame.seq} does not fit MCAP's 32-bit sequence")
        with self._lock:
            if self._closed:
                raise ValueError(f"{self.path}: recording is closed")
            kind = self._sensor_kind.setdefault(frame.sensor, frame.kind)
            if kind != frame.kind:
                raise ValueError(f"sensor {frame.sensor!r}: recorded {kind} frames so far, got a {frame.kind} frame")
            last = self._sensor_last_ns.get(frame.sensor)
            if last is not None and t_ns < last:
                raise ValueError(f"sensor {frame.sensor!r}: time went back from {last / 1e9} s to {frame.t} s")
            messages = encode_frame(frame, t_ns, color_format=self._color_format, jpeg_quality=self._jpeg_quality)
            for m in messages:
                self._writer.add_message(channel_id=self._channel(m), log_time=t_ns, data=m.data,
                                         publish_time=t_ns, sequence=frame.seq)
            self._sensor_last_ns[frame.sensor] = t_ns
            self.frames_written += 1
            if self._last_flush_ns is None:
                self._last_flush_ns = t_ns
            elif t_ns - self._last_flush_ns >= self._flush_ns:
                self._writer.flush()
                self._last_flush_ns = t_ns

    def write_json(
        self, topic: str, schema_name: str, schema: dict[str, Any], t: float, obj: Any, *, seq: int | None = None
    ) -> None:
        """Append one JSON message that is not a sensor frame (ground truth, annotations) to ``topic``.

        The channel is made on first use with ``schema`` (a JSON Schema, stored as MCAP
        ``jsonschema`` under ``schema_name``) and channel metadata ``jostle.role = "other"``, so
        ``Replay`` and ``describe_recording`` leave it alone (listed as kind "other"). ``seq`` counts
        up from 0 per topic unless given; times on one topic must not go back. ``obj`` is written
        with ``json.dumps`` (finite numbers only).
        """
        t_ns = seconds_to_ns(t)
        if t_ns < 0:
            raise ValueError(f"topic {topic!r}: t={t} s; MCAP times cannot be negative")
        data = json.dumps(obj, allow_nan=False, separators=(",", ":")).encode()
        with self._lock:
            if self._closed:
                raise ValueError(f"{self.path}: recording is closed")
            known = self._channels.get(topic)
            if (known is not None or topic in self._sensor_kind) and topic not in self._json_seq:
                raise ValueError(f"topic {topic!r}: already a sensor's channel")
            if known is None:
                schema_id = self._schemas.get(schema_name)
                if schema_id is None:
                    schema_id = self._writer.register_schema(name=schema_name, encoding="jsonschema",
                                                             data=json.dumps(schema).encode())
                    self._schemas[schema_name] = schema_id
                channel_id = self._writer.register_channel(topic=topic, message_encoding="json", schema_id=schema_id,
                                                           metadata={META_ROLE: "other"})
                known = self._channels[topic] = (channel_id, schema_name)
                self._json_seq[topic] = 0
            elif known[1] != schema_name:
                raise ValueError(f"topic {topic!r}: channel holds {known[1]}, cannot write {schema_name} to it")
            last = self._json_last_ns.get(topic)
            if last is not None and t_ns < last:
                raise ValueError(f"topic {topic!r}: time went back from {last / 1e9} s to {t} s")
            sequence = self._json_seq[topic] if seq is None else seq
            if not 0 <= sequence < _UINT32:
                raise ValueError(f"topic {topic!r}: seq={sequence} does not fit MCAP's 32-bit sequence")
            self._writer.add_message(channel_id=known[0], log_time=t_ns, data=data, publish_time=t_ns,
                                     sequence=sequence)
            self._json_seq[topic] = sequence + 1
            self._json_last_ns[topic] = t_ns

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            try:
                self._writer.finish()
            finally:
                self._file.close()


class Recorder(SensorContext):
    """A Sensor that wraps another and writes every frame ``read`` returns to a RecordingWriter.

    Everything is forwarded explicitly. Closing the recorder closes the wrapped sensor; the writer
    is shared by all recorders of a run and closed by its owner, unless ``owns_writer`` is set.
    """

    def __init__(self, sensor: Sensor, writer: RecordingWriter, *, owns_writer: bool = False) -> None:
        if not isinstance(sensor, Sensor):
            raise TypeError(f"Recorder wraps a Sensor, got {type(sensor).__name__}")
        self.sensor = sensor
        self.writer = writer
        self._owns_writer = owns_writer

    @property
    def spec(self) -> SensorSpec:
        return self.sensor.spec

    @property
    def status(self) -> SensorStatus:
        return self.sensor.status

    def open(self) -> None:
        self.sensor.open()

    def read(self, timeout: float) -> Frame | None:
        frame = self.sensor.read(timeout)
        if frame is not None:
            self.writer.write(frame)
        return frame

    def close(self) -> None:
        try:
            self.sensor.close()
        finally:
            if self._owns_writer:
                self.writer.close()
