"""Replay: a recording played back as a Sensor, on an injected clock.

At ``open()`` the replay notes ``clock.now()``; a recorded frame is due at
``recorded t − first t of the recording + that open time`` and ``read`` returns due frames one per
call, oldest first. ``read`` never sleeps (``timeout`` is accepted and ignored) and returns None
when nothing is due, so on a SimClock a replay is deterministic and runs as fast as the loop.
"First t" is the earliest sensor message of the whole file, so several replays of one file on one
clock stay in step. Times are kept in integer nanoseconds, so recording a replay again and
replaying that gives the very same times.

Every replay of one file shares one reader (:func:`sensors.recording.source.open_recording`), and
each decodes its frames in its own thread, at most :data:`LOOKAHEAD` frames ahead of ``read``;
``read`` waits for a frame that is due but not decoded yet, so what a replay returns, and when,
does not depend on how fast the machine is. Damage (a cut or corrupt file, a damaged chunk or
frame) is reported once per replay with ``warnings.warn`` (:class:`sensors.recording.info.RecordingDamaged`);
what is damaged is skipped and the rest played (``status.bad`` counts the parts skipped).
Out-of-order times and looping: see :class:`Replay`.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from pathlib import Path

from sensors.base import (
    Frame,
    Payload,
    PayloadKind,
    SensorContext,
    SensorNotOpen,
    SensorSpec,
    SensorState,
    SensorStatus,
)
from sensors.clock import Clock
from sensors.recording.info import ChannelInfo, select_channel, warn_damage
from sensors.recording.source import END, PASS_END, Damaged, SensorFeed, SharedRecording, open_recording

_DUE_TOLERANCE_S = 1e-9  # times are whole nanoseconds; the clock is a float
# frames decoded ahead of the reader, per sensor: images ~0.5-1 MB each, pad samples tiny
LOOKAHEAD = {"color": 8, "depth": 8, "pads": 128}


@dataclass(frozen=True)
class ReplayConfig:
    """``[sensors.<name>] type = "replay"``: play ``path``; ``channel`` picks one sensor of a
    multi-sensor recording ("" = the only one); ``loop`` repeats it forever."""

    path: Path
    channel: str = ""
    loop: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.path, Path) or str(self.path) in ("", "."):
            raise ValueError(f"path: expected the path of an .mcap recording, got {self.path!r}")
        if not isinstance(self.channel, str):
            raise ValueError(f"channel: expected a channel name (text), got {self.channel!r}")
        if not isinstance(self.loop, bool):
            raise ValueError(f"loop: expected true or false, got {self.loop!r}")


def _stop_reading(feed: SensorFeed, recording: SharedRecording) -> None:
    feed.stop()
    recording.release()


def _spec(name: str, info: ChannelInfo) -> SensorSpec:
    kind: PayloadKind = "color" if info.kind == "color" else "depth" if info.kind == "depth" else "pads"
    return SensorSpec(name=name, kind=kind, rate_hz=info.rate_hz, width=info.width, height=info.height,
                      pads=info.pads)


class Replay(SensorContext):
    """A recorded sensor channel, played on ``clock``. See the module docstring for the timing rule.

    A recording whose own times go back, or whose sequence numbers do not increase (some writers
    leave them at 0), is played with t held and seq counted on, so the Sensor contract still holds.
    With ``loop=True`` the good part repeats; each pass shifts t by the recording's span plus one
    interval of its fastest sensor (the same for every channel of the file, so they stay in step)
    and seq by the number of sequence numbers in a pass, so both keep increasing.
    """

    def __init__(
        self, path: Path, clock: Clock, *, channel: str | None = None, name: str | None = None, loop: bool = False
    ) -> None:
        self.path = Path(path)
        self._clock = clock
        self._channel_choice = channel or None
        self._name = name
        self._loop = loop
        self._channel: ChannelInfo | None = None
        self._topic = ""
        self._spec: SensorSpec | None = None
        self._first_ns = 0
        self._cycle_ns = 0
        self._open = False
        self._warned = False
        self._damage = ""
        self._bad = 0  # damaged parts skipped (chunks, frames), reported once
        self._state = SensorState.CLOSED
        self._frames = 0
        self._recording: SharedRecording | None = None
        self._feed: SensorFeed | None = None
        self._stop_reading: weakref.finalize | None = None
        self._next: tuple[int, int, Payload] | None = None
        self._t_open_ns = 0
        self._pass = 0
        self._pass_seq_span = 0
        self._seq_first: int | None = None
        self._seq_last = 0
        self._last_t_ns: int | None = None
        self._last_seq: int | None = None

    # -------------------------------------------------------------- recording facts

    def _load(self) -> tuple[ChannelInfo, SensorSpec]:
        if self._channel is None or self._spec is None:
            recording = self._recording or open_recording(self.path)
            try:
                info = recording.info
            finally:
                if recording is not self._recording:
                    recording.release()
            channel = select_channel(info, self._channel_choice)
            if info.truncated:
                self._report_damage(info.damage)
            self._channel = channel
            self._first_ns = info.first_ns
            # one cycle for every channel of the file, so looped channels stay in step: the
            # recording's span plus one interval of its fastest sensor (1 s if none repeats)
            intervals = [(c.last_ns - c.first_ns) // (c.message_count - 1)
                         for c in info.sensor_channels if c.message_count > 1 and c.last_ns > c.first_ns]
            self._cycle_ns = (info.last_ns - info.first_ns) + min(intervals, default=1_000_000_000)
            self._spec = _spec(self._name or channel.topic, channel)
        return self._channel, self._spec

    @property
    def spec(self) -> SensorSpec:
        """From the recording: kind, size, rate estimated from the timestamps. Reads the file on
        first use (raising SensorUnavailable / RecordingCorrupt if it cannot)."""
        return self._load()[1]

    @property
    def status(self) -> SensorStatus:
        reason = self._damage or ("end of the recording" if self._state is SensorState.ENDED else "")
        return SensorStatus(state=self._state, reason=reason, frames=self._frames, bad=self._bad)

    def _report_damage(self, text: str) -> None:
        self._damage = self._damage or text
        self._bad += 1
        if not self._warned:
            self._warned = True
            warn_damage(text)

    # -------------------------------------------------------------- sensor

    def open(self) -> None:
        """Find the channel (from the file's summary, or by reading the whole file if it has none)
        and start decoding its frames ahead, in a thread of this replay's own."""
        if self._open:
            return
        recording = open_recording(self.path)
        self._recording = recording
        try:
            channel, spec = self._load()
            feed = SensorFeed(recording, channel.topic, loop=self._loop, lookahead=LOOKAHEAD[spec.kind])
        except BaseException:
            self._recording = None
            recording.release()
            raise
        self._feed = feed
        # close() runs this; so does the collector if a replay is dropped open (its thread then stops)
        self._stop_reading = weakref.finalize(self, _stop_reading, feed, recording)
        self._topic = channel.topic
        self._t_open_ns = round(self._clock.now() * 1e9)
        self._pass = 0
        self._pass_seq_span = 0
        self._seq_first = None
        self._last_t_ns = None
        self._last_seq = None
        self._frames = 0
        self._open = True
        self._state = SensorState.CONNECTED
        self._advance()

    def _advance(self) -> None:
        """Take the next decoded frame (counting passes when looping), or mark the end."""
        if self._feed is None:
            return
        while True:
            item = self._feed.get()
            if isinstance(item, Damaged):
                self._report_damage(item.text)
            elif item is PASS_END:
                first = self._seq_first if self._seq_first is not None else self._seq_last
                self._pass += 1
                self._pass_seq_span += self._seq_last - first + 1
                self._seq_first = None
            elif item is END:
                self._next = None
                self._state = SensorState.ENDED
                return
            elif isinstance(item, tuple):
                self._next = item
                return

    def read(self, timeout: float) -> Frame | None:
        """The oldest due frame, or None. Never waits: ``timeout`` is not needed on recorded time."""
        if not self._open:
            raise SensorNotOpen(f"replay {self.path}: read before open (or after close)")
        if self._next is None:
            return None
        t_ns_rec, seq, payload = self._next
        t_ns = t_ns_rec - self._first_ns + self._t_open_ns + self._pass * self._cycle_ns
        if self._last_t_ns is not None and t_ns < self._last_t_ns:
            t_ns = self._last_t_ns  # a recording whose times go back: keep the contract, t never decreases
        t = t_ns / 1e9
        if t > self._clock.now() + _DUE_TOLERANCE_S:
            return None
        if self._seq_first is None:
            self._seq_first = seq
        self._seq_last = seq
        out_seq = seq + self._pass_seq_span
        if self._last_seq is not None and out_seq <= self._last_seq:
            out_seq = self._last_seq + 1  # files whose writer left sequence at 0: keep seq increasing
        self._last_seq = out_seq
        self._last_t_ns = t_ns
        self._frames += 1
        frame = Frame(sensor=self.spec.name, t=t, seq=out_seq, payload=payload)
        self._advance()
        return frame

    def close(self) -> None:
        if self._stop_reading is not None:
            self._stop_reading()
            self._stop_reading = None
        self._feed = None
        self._recording = None
        self._next = None
        self._open = False
        self._state = SensorState.CLOSED
