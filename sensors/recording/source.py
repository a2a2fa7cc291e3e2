"""One open recording shared by every replay of it, and a sensor's frames decoded ahead of use.

:func:`open_recording` returns the :class:`SharedRecording` of a file, made on first use and shared
(reference counted) by every caller until the last one calls ``release()``: the file is described
once, and each chunk is decompressed once for all the sensors read from it (a small cache of
recently read chunks, bounded in bytes, serves the others; what the cache holds changes only how
much work is done, never what is read). The key is the file's identity (device, inode, size,
modification time), so a rewritten file is read afresh.

:func:`sensor_items` yields one sensor's payloads in file order, with a :class:`Damaged` item (one
line) wherever a damaged chunk or frame was skipped; reading goes on past it. :class:`SensorFeed` runs
it in a background thread into a bounded queue, so decoding (zstd and JPEG decoding release the
GIL) overlaps the caller's work and the other sensors' decoding. What a feed yields is a function of
the file alone — it never skips or reorders to keep up — so a replay stays deterministic.
:func:`iter_payloads` and :func:`iter_frames` read one channel in the caller's thread, warning once
on damage.
"""

from __future__ import annotations

import contextlib
import os
import queue
import threading
from collections import OrderedDict
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Final

from mcap.records import Channel, Schema

from sensors.base import Frame, Payload
from sensors.recording.codec import ChannelRoleInfo, CodecError, PayloadAssembler, classify_channel
from sensors.recording.index import ChunkRef, ChunkUnreadable, RecordingIndex, read_chunk, read_index
from sensors.recording.info import (
    RecordingInfo,
    describe_indexed,
    describe_recording,
    describe_scan,
    select_channel,
    warn_damage,
)
from sensors.recording.stream import RecordedMessage, RecordingDamage, RecordingStream, check_recording_file
from sensors.untrusted import Timeline

CHUNK_CACHE_BYTES = 64 * 1024 * 1024
MESSAGE_COST = 200  # bytes of Python objects per message held, besides its data (counted in the cache)
_SENSOR_ROLES = ("frame", "calibration", "aligned_color")


@dataclass(frozen=True, slots=True)
class Damaged:
    """What was skipped and where (one line, naming the file and the byte)."""

    text: str


class _Slot:
    """One chunk being read or read: the first asker reads it, the others wait for it."""

    def __init__(self, size: int) -> None:
        self.ready = threading.Event()
        self.messages: list[RecordedMessage] = []
        self.error = ""
        self.retry = False
        self.size = size


class SharedRecording:
    """A recording open for reading by any number of sensors (see the module docstring)."""

    def __init__(self, path: Path, key: tuple[int, int, int, int, str]) -> None:
        self.path = path
        self.key = key
        self.size_bytes = check_recording_file(path)
        self._file = path.open("rb")
        self._fd = self._file.fileno()
        self.index: RecordingIndex | None = read_index(self._fd, self.size_bytes)
        self._lock = threading.RLock()  # RLock: a dropped replay's finalizer may run in any thread
        self._cache: OrderedDict[int, _Slot] = OrderedDict()  # chunk offset → slot, oldest first
        self._cached_bytes = 0
        self._info: RecordingInfo | None = None
        self._users = 0
        self._roles: dict[int, ChannelRoleInfo] = {}
        self.chunks_read = 0  # chunk decompressions so far (a chunk read again after leaving the cache counts twice)

    @property
    def info(self) -> RecordingInfo:
        """What the file holds, described once (from the index when it has one)."""
        with self._lock:
            info = self._info
        if info is None:
            if self.index is not None:
                info = describe_indexed(self.path, self.index, self.chunk)
            info = info or describe_scan(self.path)
            with self._lock:
                self._info = info
        return info

    def role(self, channel: Channel, schema: Schema | None) -> ChannelRoleInfo:
        found = self._roles.get(channel.id)
        if found is None:
            found = self._roles[channel.id] = classify_channel(channel, schema)
        return found

    def chunk(self, ref: ChunkRef) -> list[RecordedMessage]:
        """The messages of one indexed chunk, read once while it stays in the cache."""
        if self.index is None:
            raise ValueError(f"{self.path}: has no usable index")
        while True:
            with self._lock:
                slot = self._cache.get(ref.offset)
                owner = slot is None
                if slot is None:
                    slot = self._cache[ref.offset] = _Slot(ref.uncompressed_size + MESSAGE_COST * ref.message_count)
                    self._cached_bytes += slot.size
                    self.chunks_read += 1
                    self._trim()
                else:
                    self._cache.move_to_end(ref.offset)
            if owner:
                try:
                    slot.messages = read_chunk(self._fd, ref, self.index.channels, self.index.schemas)
                except ChunkUnreadable as e:
                    slot.error = str(e)
                except BaseException:  # not the file's fault: forget the slot, waiters read it themselves
                    with self._lock:
                        if self._cache.get(ref.offset) is slot:
                            del self._cache[ref.offset]
                            self._cached_bytes -= slot.size
                    slot.retry = True
                    raise
                finally:
                    slot.ready.set()
            else:
                slot.ready.wait()
                if slot.retry:
                    continue
            if slot.error:
                raise ChunkUnreadable(slot.error)
            return slot.messages

    def _trim(self) -> None:
        while self._cached_bytes > CHUNK_CACHE_BYTES and len(self._cache) > 1:
            _, old = self._cache.popitem(last=False)
            self._cached_bytes -= old.size

    def release(self) -> None:
        """One user is done; the last one closes the file."""
        with _REGISTRY_LOCK:
            self._users -= 1
            if self._users > 0:
                return
            if _REGISTRY.get(self.key) is self:
                del _REGISTRY[self.key]
        self._file.close()
        with self._lock:
            self._cache.clear()
            self._cached_bytes = 0


_REGISTRY: dict[tuple[int, int, int, int, str], SharedRecording] = {}
_REGISTRY_LOCK: Final = threading.RLock()


def open_recording(path: Path) -> SharedRecording:
    """The shared reader of ``path`` (one more user: call ``release()`` when done). Raises
    SensorUnavailable if the file is missing, RecordingCorrupt if it is not MCAP."""
    path = Path(path)
    check_recording_file(path)
    st = path.stat()
    key = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, os.path.realpath(path))
    with _REGISTRY_LOCK:
        recording = _REGISTRY.get(key)
        if recording is None:
            recording = _REGISTRY[key] = SharedRecording(path, key)
        recording._users += 1
        return recording


# ---------------------------------------------------------------- one sensor's frames


def _sensor_messages(recording: SharedRecording, sensor: str) -> Generator[RecordedMessage | Damaged, None, None]:
    """The messages of one sensor's channels (frame and companions) in file order; a Damaged item
    where a damaged part was skipped (reading goes on past it)."""
    index = recording.index
    if index is None:  # no usable summary: walk the file record by record
        stream = RecordingStream(recording.path)
        reported: RecordingDamage | None = None
        for msg in stream.messages():
            if stream.damage is not reported:
                reported = stream.damage
                yield Damaged(_resumed(recording.path, reported))
            role = recording.role(msg.channel, msg.schema)
            if role.sensor == sensor and role.role in _SENSOR_ROLES:
                yield msg
        if stream.damage is not reported and stream.damage is not None:
            yield Damaged(stream.damage.describe(recording.path))
        if stream.losses.appended:
            yield Damaged(f"{recording.path}: {stream.losses.describe()}")
        return
    wanted = {cid for cid, c in index.channels.items()
              if (r := recording.role(c, index.schemas.get(c.schema_id))).sensor == sensor and r.role in _SENSOR_ROLES}
    good, last_ns = 0, None
    for ref in index.chunks:  # every chunk, as a walk would; a damaged one is skipped
        try:
            messages = recording.chunk(ref)
        except ChunkUnreadable as e:
            damage = RecordingDamage(ref.offset, index.size_bytes, f"chunk record unreadable: {e}", good, last_ns)
            yield Damaged(_resumed(recording.path, damage, ref.message_count))
            continue
        for msg in messages:
            if msg.channel.id in wanted:
                yield msg
        good += ref.message_count
        last_ns = ref.last_ns if ref.message_count else last_ns


def _resumed(path: Path, damage: RecordingDamage | None, lost: int | None = None) -> str:
    assert damage is not None
    what = f"its {lost} messages skipped" if lost is not None else "skipped"
    return f"{damage.describe(path)}; {what}, reading goes on at the next good chunk"


def sensor_items(
    recording: SharedRecording, sensor: str
) -> Generator[tuple[int, int, Payload] | Damaged, None, None]:
    """(log time ns, sequence, payload) of one sensor in file order. Damage does not end it: a
    Damaged item says what was skipped — a damaged chunk, or one frame whose time goes back or
    jumps beyond the sane gap (``Timeline``), or whose payload does not decode — and reading goes on."""
    assembler = PayloadAssembler()
    timeline = Timeline(f"{recording.path}: {sensor}")
    with contextlib.closing(_sensor_messages(recording, sensor)) as messages:
        for msg in messages:
            if isinstance(msg, Damaged):
                yield msg
                continue
            role = recording.role(msg.channel, msg.schema)
            where = f"{recording.path}: frame on {msg.channel.topic!r} in the record at byte {msg.offset}"
            if role.role == "frame":
                problem = timeline.flag(msg.log_time_ns)
                if problem is not None:
                    yield Damaged(f"{where} skipped: {problem}")
                    continue
            try:
                payload = assembler.feed(role, msg.channel, msg.schema, msg.sequence, msg.log_time_ns, msg.data)
            except CodecError as e:
                yield Damaged(f"{where} skipped: it cannot be decoded ({e})")
                continue
            if payload is not None:
                yield msg.log_time_ns, msg.sequence, payload


def iter_payloads(
    path: Path, channel: str, on_damage: Callable[[str], None] | None = warn_damage
) -> Iterator[tuple[int, int, Payload]]:
    """(log time ns, sequence, payload) of one sensor channel, in file order.

    Damaged parts are skipped (see :func:`sensor_items`); ``on_damage`` is called once, with the
    first one's one-line description.
    """
    recording = open_recording(Path(path))
    warned = False
    try:
        for item in sensor_items(recording, channel):
            if isinstance(item, Damaged):
                if on_damage is not None and not warned:
                    on_damage(item.text)
                warned = True
                continue
            yield item
    finally:
        recording.release()


def iter_frames(path: Path, channel: str | None = None) -> Iterator[Frame]:
    """The frames of one sensor channel (the only one if ``channel`` is None), times in seconds."""
    topic = channel or select_channel(describe_recording(Path(path)), None).topic
    for t_ns, seq, payload in iter_payloads(Path(path), topic):
        yield Frame(sensor=topic, t=t_ns / 1e9, seq=seq, payload=payload)


class _Marker:
    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return self.name


PASS_END: Final = _Marker("PASS_END")  # a looping feed starts the recording again after this
END: Final = _Marker("END")  # nothing more will come


@dataclass(frozen=True, slots=True)
class _Failed:
    error: BaseException


FeedItem = tuple[int, int, Payload] | Damaged | _Marker


class SensorFeed:
    """:func:`sensor_items` of one sensor, decoded ahead in a thread, at most ``lookahead`` items.

    ``get()`` returns the items in order: frames (with Damaged items where parts were skipped), PASS_END
    between passes when looping (only after a pass that had frames), END last. An error in the
    thread is raised by ``get()``. ``stop()`` ends the thread; it is idempotent.
    """

    def __init__(self, recording: SharedRecording, sensor: str, *, loop: bool, lookahead: int) -> None:
        if lookahead < 1:
            raise ValueError(f"lookahead: expected items >= 1, got {lookahead}")
        self._recording = recording
        self._sensor = sensor
        self._loop = loop
        self._queue: queue.Queue[FeedItem | _Failed] = queue.Queue(maxsize=lookahead)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"replay {recording.path.name}:{sensor}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while True:
                frames = 0
                with contextlib.closing(sensor_items(self._recording, self._sensor)) as items:
                    for item in items:
                        if not self._put(item):
                            return
                        frames += not isinstance(item, Damaged)
                if not (self._loop and frames):
                    break
                if not self._put(PASS_END):
                    return
            self._put(END)
        except BaseException as e:  # handed to the reader, raised there
            self._put(_Failed(e))

    def _put(self, item: FeedItem | _Failed) -> bool:
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def get(self) -> FeedItem:
        """The next item, waiting for the thread to decode it."""
        while True:
            try:
                item = self._queue.get(timeout=0.5)
            except queue.Empty:
                if self._thread.is_alive() or not self._queue.empty():
                    continue
                raise RuntimeError(f"{self._recording.path}: the reader of {self._sensor!r} stopped") from None
            if isinstance(item, _Failed):
                raise item.error
            return item

    def stop(self) -> None:
        self._stop.set()
        if threading.current_thread() is not self._thread:  # a finalizer may run in the thread itself
            self._thread.join()
