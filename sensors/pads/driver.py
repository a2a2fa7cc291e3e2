"""PadsSensor: a force-pad board on a serial port (pyserial), binary or CSV framing.

- ``open()`` opens the port at once (so nothing the board sends afterwards is flushed away by
  pyserial's open) and raises :class:`SensorUnavailable` naming the port and what to check.
- A reader thread feeds every byte to a :class:`StreamParser`. Each decoded sample becomes a
  ``Frame(payload=PadSample(newtons, raw))`` with ``t = clock.now()`` at its arrival, in a small
  bounded queue (the oldest is dropped when it is full, and counted). ``read(timeout)`` waits at
  most ``timeout``.
- ``seq`` starts at 0 with the first delivered frame and steps over the frames the board numbered
  but that never arrived (and over frames dropped from the queue), so losses show as gaps.
- The first ``tare_samples`` samples (at start and after each reconnect) set the zero and are not
  delivered.
- Bad bytes are normal on serial lines: they are counted (``status.bad`` messages, ``extra``
  ``bad_bytes``), never delivered; more than ``max_bad_per_s`` bad messages within one second
  (measured on the wall clock, since it judges the line) means a wrong baudrate, framing or pad
  count: the sensor turns FAILED, closes the port, and ``read`` raises :class:`PadsFailed`.
- When the port vanishes (unplugged), the status turns RECONNECTING with the reason, the thread
  tries to reopen it every ``reconnect_s``, and the status is CONNECTED again once it opens.
"""

from __future__ import annotations

import errno
import logging
import math
import os
import time
from collections import deque
from typing import Any

import serial

from sensors.base import (
    Frame,
    PadSample,
    SensorError,
    SensorSpec,
    SensorState,
    SensorStatus,
    SensorUnavailable,
)
from sensors.clock import Clock
from sensors.pads.calibration import PadCalibration
from sensors.pads.config import PadsConfig
from sensors.pads.protocol import FRAMINGS, SequenceTracker, StreamParser
from sensors.threaded import Backoff, LinkLost, ThreadedDriver

log = logging.getLogger("jostle.pads")

QUEUE_SIZE = 32  # frames waiting for read(); at 100 Hz a third of a second
_READ_SLICE_S = 0.05  # the reader thread's longest wait in one serial read (bounds close())
_JOIN_S = 2.0
_SILENT_S = 1.0  # a connected port with no sample for this long (or 10 periods) says so in the reason


class PadsFailed(SensorError):
    """The pad stream is unusable (too many bad frames): the message says what to check."""


def port_open_hint(err: int | None) -> str:
    """What the user should check when a serial port will not open, by errno."""
    if err == errno.ENOENT:
        return "is the board plugged in? (ls /dev/ttyUSB* /dev/ttyACM*; `jostle doctor` lists serial ports)"
    if err in (errno.EACCES, errno.EPERM):
        return ("this user may not use it: add it to the dialout group (sudo usermod -aG dialout $USER) "
                "and log in again")
    if err in (errno.EBUSY, errno.EAGAIN, errno.EWOULDBLOCK):
        return "another program holds it (close the Arduino serial monitor; see `fuser <port>`)"
    return ("check it is a serial port, the board is plugged in, and this user is in the dialout group")


def _error_text(e: BaseException) -> str:
    err = getattr(e, "errno", None)
    if isinstance(err, int):
        return f"{errno.errorcode.get(err, str(err))} ({os.strerror(err)})"
    return f"{type(e).__name__}: {e}"


class PadsSensor(ThreadedDriver[Any]):  # the link is a pyserial port
    driver = "pads"

    def __init__(self, config: PadsConfig, clock: Clock, name: str = "pads") -> None:
        super().__init__(SensorSpec(name=name, kind="pads", rate_hz=float(config.rate_hz), pads=config.pads), clock,
                         QUEUE_SIZE, _JOIN_S)
        self.config = config
        self._framing = FRAMINGS[config.framing]
        self._new_parts()

    def _new_parts(self) -> None:
        """Fresh parser, sequence tracker, calibration and counters (at every open)."""
        c = self.config
        self._parser = StreamParser(self._framing, c.pads)
        self._tracker = SequenceTracker(self._framing.seq_modulus)
        self._calibration = PadCalibration(c.scales, c.tare_samples, c.deadband_n)
        self._bad_times: deque[float] = deque(maxlen=c.max_bad_per_s + 1)
        self._bad_seen = 0
        self._bad_said = False  # the first bad message is said once; the rest are counted
        self._frames = 0
        self._reconnects = 0
        self._next_seq: int | None = None  # the seq of the next frame; None before the first
        self._last_sample_wall: float | None = None
        self._opened_wall = time.monotonic()

    @property
    def status(self) -> SensorStatus:
        with self._lock:
            p, tr = self._parser, self._tracker
            reason = self._reason
            if self._state is SensorState.CONNECTED and not reason:
                reason = self._connected_note()
            queue_dropped = self._queue.dropped
            return SensorStatus(
                state=self._state, reason=reason, frames=self._frames, dropped=tr.dropped + queue_dropped,
                bad=p.bad,
                extra={
                    "bad_bytes": float(p.bad_bytes), "skipped_bytes": float(p.skipped_bytes),
                    "ignored": float(p.ignored), "samples": float(p.samples),
                    "dropped_on_wire": float(tr.dropped), "dropped_in_queue": float(queue_dropped),
                    "restarts": float(tr.restarts), "repeats": float(tr.repeats),
                    "reconnects": float(self._reconnects), "taring": float(self._calibration.taring),
                },
            )

    def _connected_note(self) -> str:
        if self._calibration.taring:
            seen, needed = self._calibration.tare_progress
            return f"taring: {seen} of {needed} samples (keep the pads unloaded)"
        since = self._last_sample_wall if self._last_sample_wall is not None else self._opened_wall
        silent = time.monotonic() - since
        if silent > max(_SILENT_S, 10.0 / self.config.rate_hz):
            return (f"no pad sample for {silent:.1f} s (expected {self.config.rate_hz:g} Hz); check the board "
                    f"runs and sends {self.config.framing} at {self.config.baudrate} baud")
        return ""

    # -------------------------------------------------------------- opening

    def _open_port(self) -> Any:
        """The opened pyserial port; raises SensorUnavailable naming the port and what to check."""
        c = self.config
        try:
            return serial.serial_for_url(c.port, baudrate=c.baudrate, timeout=_READ_SLICE_S, exclusive=True)
        except ValueError as e:  # a malformed URL or setting
            raise SensorUnavailable(f"pads {self.name!r}: cannot open {c.port!r}: {e} (a port is a device path "
                                    "like /dev/ttyUSB0 or a pyserial URL like loop://)") from e
        except OSError as e:  # serial.SerialException is an OSError
            err = e.errno if isinstance(e.errno, int) else None
            raise SensorUnavailable(f"pads {self.name!r}: cannot open serial port {c.port}: {_error_text(e)}; "
                                    f"{port_open_hint(err)}") from e

    def open(self) -> None:
        if self._open:
            return
        port = self._open_port()
        with self._lock:
            self._queue.reset()
            self._new_parts()
        self._start_reader(lambda: port)

    # -------------------------------------------------------------- reader thread

    def _backoff(self) -> Backoff:
        return Backoff(self.config.reconnect_s, self.config.reconnect_s)

    def _crash_reason(self, error: Exception) -> str:
        return f"the reader thread of {self.config.port} stopped: {error!r}"

    def _failure(self, reason: str) -> SensorError:
        return PadsFailed(f"pads {self.name!r}: {reason}")

    def _read_one(self, port: Any) -> bool:
        try:
            data = port.read(port.in_waiting or 1)
        except OSError as e:  # unplugged: EIO, or "readiness to read but returned no data"
            raise LinkLost(f"lost serial port {self.config.port}: {_error_text(e)}") from e
        return not data or self._ingest(data)

    def _reconnect(self) -> tuple[Any, str]:
        try:
            port = self._open_port()
        except SensorUnavailable as e:
            return None, str(e)
        with self._lock:
            self._parser.reset()
            self._tracker.reset()
            self._calibration.reset()  # the board may have restarted: learn its zero again
            self._last_sample_wall = None
            self._opened_wall = time.monotonic()
        return port, ""

    def _close_link(self, port: Any) -> None:
        try:
            port.close()
        except OSError:
            pass  # the device is already gone; its file descriptor is released either way

    def _max_gap(self, wall: float) -> int | None:
        """The most frames the board can have sent since the last sample (gaps beyond mean a restart)."""
        if self._last_sample_wall is None:
            return None
        return math.ceil((wall - self._last_sample_wall) * self.config.rate_hz * 2.0) + 8

    def _ingest(self, data: bytes) -> bool:
        """Parse bytes, queue their frames; False once the bad-message limit is passed (FAILED)."""
        t = self._clock.now()
        wall = time.monotonic()
        with self._lock:
            samples = self._parser.feed(data)
            for sample in samples:
                gap = self._tracker.advance(sample.seq, self._max_gap(wall))
                self._last_sample_wall = wall
                if gap is None:
                    continue  # a repeated frame
                if self._calibration.taring:
                    self._calibration.add_tare(sample.counts)
                    continue
                seq = 0 if self._next_seq is None else self._next_seq + gap
                frame = Frame(sensor=self.name, t=t, seq=seq,
                              payload=PadSample(newtons=self._calibration.newtons(sample.counts), raw=sample.counts))
                self._next_seq = seq + 1
                self._queue.put(frame)
            fresh_bad = self._parser.bad - self._bad_seen
            self._bad_seen = self._parser.bad
            if fresh_bad and not self._bad_said:
                self._bad_said = True
                log.warning("pads %r on %s: a bad %s skipped (%s); more are counted in its status", self.name,
                            self.config.port, self._framing.message, self._parser.last_bad)
            if fresh_bad and self._too_many_bad(fresh_bad, wall):
                c = self.config
                self._state = SensorState.FAILED
                self._reason = (f"more than {c.max_bad_per_s} bad {self._framing.message}s within 1 s on {c.port} "
                                f"(last: {self._parser.last_bad}); check the board's baudrate ({c.baudrate}), "
                                f"framing ({c.framing}) and pad count ({c.pads}) match the config")
                self._queue.wake()
                return False
        return True

    def _too_many_bad(self, count: int, wall: float) -> bool:
        times = self._bad_times
        for _ in range(min(count, times.maxlen or 1)):
            times.append(wall)
        return len(times) == times.maxlen and wall - times[0] < 1.0
