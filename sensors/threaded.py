"""ThreadedDriver: the skeleton every live driver shares — one reader thread feeding a FrameQueue.

A driver supplies its connection ("link": a serial port, a capture, a depthai pipeline) and four
hooks: ``_read_one(link)`` reads once and queues what it decoded (raising :class:`LinkLost` when
the device is gone), ``_reconnect()`` opens a fresh link, ``_close_link(link)`` and ``_backoff()``.
The base runs the thread, the status transitions (CONNECTED, RECONNECTING with the reason and the
next wait, FAILED when the back-off gives up or the thread crashes, CLOSED), the bounded queue, and
``read(timeout)``, which waits at most ``timeout`` s and raises the driver's failure once FAILED.
``close()`` stops the thread and waits for it at most ``join_s`` s.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Generic, TypeVar

from sensors.base import (
    Frame,
    SensorContext,
    SensorError,
    SensorNotOpen,
    SensorSpec,
    SensorState,
    SensorStatus,
)
from sensors.clock import Clock
from sensors.frame_queue import FrameQueue

Link = TypeVar("Link")


class LinkLost(Exception):
    """Raised by ``_read_one`` when the device is gone; the message is the reason shown while retrying."""


class StartTimeout(Exception):
    """The reader thread's first connection did not come within the time ``open()`` allows."""


class Backoff:
    """The retry schedule: waits of ``first_s``, doubling, at most ``max_s``; None once
    ``give_up_after`` attempts (> 0) have failed. ``reset()`` after a success."""

    def __init__(self, first_s: float, max_s: float, give_up_after: int = 0, factor: float = 2.0) -> None:
        if not 0 < first_s <= max_s:
            raise ValueError(f"first_s: expected 0 < first_s <= max_s, got {first_s}, {max_s}")
        if factor < 1:
            raise ValueError(f"factor: expected >= 1, got {factor}")
        self.first_s = first_s
        self.max_s = max_s
        self.give_up_after = give_up_after
        self.factor = factor
        self.attempts = 0

    def next_delay(self) -> float | None:
        """The wait before the next attempt (and count it), or None when it is time to give up."""
        if self.give_up_after and self.attempts >= self.give_up_after:
            return None
        delay = min(self.max_s, self.first_s * self.factor ** self.attempts)
        self.attempts += 1
        return delay

    def reset(self) -> None:
        self.attempts = 0


class _Start:
    """The handshake between ``open()`` and the thread's first connection (one per open)."""

    def __init__(self) -> None:
        self.done = threading.Event()
        self.error: BaseException | None = None


class ThreadedDriver(SensorContext, Generic[Link]):
    """The shared state of a threaded driver; see the module docstring for the hooks."""

    driver = "sensor"  # the word that starts this driver's messages ("pads", "oak", "webcam")

    def __init__(self, spec: SensorSpec, clock: Clock, queue_size: int, join_s: float) -> None:
        self.name = spec.name
        self._spec = spec
        self._clock = clock
        self._join_s = join_s
        self._lock = threading.Lock()
        self._queue = FrameQueue(queue_size)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._open = False
        self._state = SensorState.CLOSED
        self._reason = ""
        self._frames = 0  # frames returned by read()
        self._reconnects = 0

    @property
    def spec(self) -> SensorSpec:
        return self._spec

    @property
    def status(self) -> SensorStatus:
        """State, reason, frames read, frames dropped from the queue, and ``extra["reconnects"]``."""
        with self._lock:
            return SensorStatus(state=self._state, reason=self._reason, frames=self._frames,
                                dropped=self._queue.dropped, extra={"reconnects": float(self._reconnects)})

    # -------------------------------------------------------------- hooks

    def _read_one(self, link: Link) -> bool:
        """Read once and queue what came; False once the driver turned itself FAILED."""
        raise NotImplementedError

    def _reconnect(self) -> tuple[Link | None, str]:
        """A fresh link, or None and why not."""
        raise NotImplementedError

    def _close_link(self, link: Link) -> None:
        raise NotImplementedError

    def _backoff(self) -> Backoff:
        raise NotImplementedError

    def _reconnected(self, link: Link) -> None:
        """Called in the thread after a reconnect, before the state turns CONNECTED."""

    def _retry_note(self, attempt: int, delay: float) -> str:
        return f"retrying every {delay:g} s"

    def _crash_reason(self, error: Exception) -> str:
        return f"{self.driver} {self.name!r}: the reader thread stopped: {error!r}"

    def _failure(self, reason: str) -> SensorError:
        """The error ``read`` raises once the sensor is FAILED."""
        return SensorError(f"{self.driver} {self.name!r}: {reason}")

    # -------------------------------------------------------------- state

    def _set_state(self, state: SensorState, reason: str) -> None:
        with self._lock:
            self._state, self._reason = state, reason
        self._queue.wake()  # a reader waiting for a frame also stops waiting on FAILED

    # -------------------------------------------------------------- the thread

    def _start_reader(self, connect: Callable[[], Link], wait_s: float | None = None) -> None:
        """Start the thread, which calls ``connect`` first; return once it is CONNECTED.

        Raises :class:`StartTimeout` if that takes over ``wait_s`` s (the thread is left to wind
        down and close what it gets), or what ``connect`` raised.
        """
        self._stop = stop = threading.Event()  # a fresh one: a thread of an earlier open may still be ending
        start = _Start()
        self._thread = threading.Thread(target=self._run, args=(connect, start, stop),
                                        name=f"{self.driver}-{self.name}", daemon=True)
        self._thread.start()
        if not start.done.wait(wait_s):
            self._halt(join=False)
            raise StartTimeout(f"{self.driver} {self.name!r}: not connected within {wait_s:g} s")
        if start.error is not None:
            error = start.error
            self._halt()
            raise error
        self._open = True

    def _run(self, connect: Callable[[], Link], start: _Start, stop: threading.Event) -> None:
        link: Link | None = None
        try:
            try:
                link = connect()
            except Exception as e:  # reported by open()
                start.error = e
                return
            finally:
                if link is not None:
                    with self._lock:
                        if not stop.is_set():
                            self._state, self._reason = SensorState.CONNECTED, ""
                start.done.set()
            if stop.is_set():
                return
            link = self._serve(link, stop)
        except Exception as e:  # a bug, not a device fault: say so in the status, and let it be printed
            self._set_state(SensorState.FAILED, self._crash_reason(e))
            raise
        finally:
            if link is not None:
                self._close_link(link)

    def _serve(self, link: Link | None, stop: threading.Event) -> Link | None:
        """Read until stopped, reconnecting on the back-off; returns the link still open at the end."""
        backoff = self._backoff()
        lost = ""
        while not stop.is_set():
            if link is None:
                delay = backoff.next_delay()
                if delay is None:
                    self._set_state(SensorState.FAILED, f"{lost}; gave up after {backoff.give_up_after} attempts "
                                                        "(give_up_after)")
                    return None
                self._set_state(SensorState.RECONNECTING, f"{lost}; {self._retry_note(backoff.attempts, delay)}")
                if stop.wait(delay):
                    return None
                link, why = self._reconnect()
                if stop.is_set():  # closed while reconnecting: leave the state to close()
                    return link
                if link is None:
                    lost = why
                    continue
                backoff.reset()
                self._reconnected(link)
                with self._lock:
                    self._reconnects += 1
                self._set_state(SensorState.CONNECTED, "")
                continue
            try:
                if not self._read_one(link):
                    return link  # FAILED, set by the driver
            except LinkLost as e:
                lost = str(e)
                self._close_link(link)
                link = None
        return link

    # -------------------------------------------------------------- reading and closing

    def _check_open(self) -> None:
        if not self._open:
            raise SensorNotOpen(f"{self.driver} {self.name!r}: read before open (or after close)")

    def read(self, timeout: float) -> Frame | None:
        self._check_open()
        frame = self._queue.get(timeout, until=lambda: self._state is SensorState.FAILED)
        with self._lock:
            if frame is not None:
                self._frames += 1
                return frame
            if self._state is SensorState.FAILED:
                raise self._failure(self._reason)
            return None

    def _halt(self, join: bool = True) -> None:
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None and join:
            thread.join(self._join_s)  # a read returns within the driver's read slice; a hung connect is left
        self._queue.clear()
        with self._lock:
            self._state, self._reason = SensorState.CLOSED, ""

    def close(self) -> None:
        self._halt()
        self._open = False
