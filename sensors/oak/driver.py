"""OakSensor: a Luxonis OAK camera as a Sensor — stereo depth aligned to the colour camera.

- ``open()`` searches for the camera (bounded by ``search_timeout_s``: never depthai's ~11 s wait
  when nothing is attached), picks the configured one (id, IP or USB port name) or the first free
  one, and waits at most ``connect_timeout_s`` for it to boot and start. Anything wrong raises
  :class:`SensorUnavailable` naming the camera and what to check.
- A thread owns the connection (the device, its pipeline, its queue: depthai objects never leave
  it). Each message becomes ``Frame(DepthImage(depth_mm, fx, fy, cx, cy, color))`` in a small
  bounded queue (the oldest is dropped when it is full, and counted); ``read(timeout)`` waits at
  most ``timeout``. Intrinsics come from each frame, else from the device's calibration.
- Losing the camera never reaches the loop as an exception. depthai's own reconnection
  (``reconnect_attempts``) runs first and shows as RECONNECTING; when it gives up, or a queue read
  raises (``X_LINK_ERROR`` after a cable glitch, a stopped pipeline), or the camera sends nothing
  for ``stall_s``, the thread drops the connection and retries — search, pick, connect — after
  ``reconnect_s``, doubling up to ``reconnect_max_s`` (a closed device reboots and is briefly
  unavailable). ``give_up_after`` failed attempts (0 = never) turn the sensor FAILED; then ``read``
  raises :class:`OakFailed` with the reason.
"""

from __future__ import annotations

import time

from sensors.base import SensorError, SensorSpec, SensorState, SensorStatus, SensorUnavailable
from sensors.clock import Clock
from sensors.oak.config import OakConfig
from sensors.oak.frames import BadMessage, FrameNumbering, make_frame
from sensors.oak.link import Connector, LinkHealth, OakLink
from sensors.oak.search import DeviceSearch, FoundDevice, link_hint, pick_device
from sensors.threaded import Backoff, LinkLost, StartTimeout, ThreadedDriver

QUEUE_SIZE = 4  # frames waiting for read(): at 30 fps, 130 ms
READ_SLICE_S = 0.05  # the thread's longest wait in one queue read (bounds close())
_JOIN_S = 3.0


class OakFailed(SensorError):
    """The camera is gone for good (``give_up_after`` attempts failed): the message says why."""


def _default_connector(found: FoundDevice, config: OakConfig) -> OakLink:
    from sensors.oak.device import connect_device

    return connect_device(found, config)


class OakSensor(ThreadedDriver[OakLink]):
    driver = "oak"

    def __init__(self, config: OakConfig, clock: Clock, name: str = "oak", *, search: DeviceSearch | None = None,
                 connect: Connector | None = None) -> None:
        super().__init__(SensorSpec(name=name, kind="depth", rate_hz=float(config.fps), width=config.width,
                                    height=config.height), clock, QUEUE_SIZE, _JOIN_S)
        self.config = config
        self._search = search if search is not None else DeviceSearch()
        self._connect = connect if connect is not None else _default_connector
        self._last_frame = time.monotonic()
        self._reset_counts()

    def _reset_counts(self) -> None:
        self._frames = 0
        self._queue.reset()
        self._bad = 0
        self._reconnects = 0
        self._sources = {"frame": 0, "calibration": 0, "none": 0}
        self._numbering = FrameNumbering()
        self.device_id = ""

    @property
    def status(self) -> SensorStatus:
        with self._lock:
            reason = self._reason
            if self._state is SensorState.CONNECTED and not reason and self._sources["none"]:
                reason = (f"{self._label()}: frames carry no intrinsics and the device has no calibration; depth "
                          "is usable, 3D positions are not (recalibrate the camera)")
            queue_dropped = self._queue.dropped
            return SensorStatus(
                state=self._state, reason=reason, frames=self._frames,
                dropped=queue_dropped + self._numbering.skipped, bad=self._bad,
                extra={"reconnects": float(self._reconnects), "dropped_in_queue": float(queue_dropped),
                       "dropped_on_device": float(self._numbering.skipped),
                       "intrinsics_from_frame": float(self._sources["frame"]),
                       "intrinsics_from_calibration": float(self._sources["calibration"]),
                       "uncalibrated": float(self._sources["none"])},
            )

    def _label(self) -> str:
        return f"oak {self.name!r} (OAK {self.device_id or self.config.device or '?'})"

    # -------------------------------------------------------------- opening

    def _find(self) -> FoundDevice:
        found = self._search.find(self.config.search_timeout_s)  # SensorUnavailable on timeout / failure
        return pick_device(found, self.config.device, self.name)

    def open(self) -> None:
        if self._open:
            return
        try:
            found = self._find()
        except SensorUnavailable as e:
            text = str(e)
            raise SensorUnavailable(text if text.startswith("oak ") else f"oak {self.name!r}: {text}") from e
        with self._lock:
            self._reset_counts()
            self._numbering = FrameNumbering(start_t=self._clock.now())
            self.device_id = found.device_id or found.name
            self._state, self._reason = SensorState.RECONNECTING, f"connecting to {found.describe()}"

        def connect_first() -> OakLink:  # in the thread, which owns the connection: depthai objects never leave it
            link = self._connect(found, self.config)
            self._last_frame = time.monotonic()
            return link

        try:
            self._start_reader(connect_first, self.config.connect_timeout_s)
        except StartTimeout:  # stuck in depthai's connect: the thread closes what it gets, then ends
            raise SensorUnavailable(f"{self._label()}: did not start within {self.config.connect_timeout_s:g} s "
                                    f"(connect_timeout_s); {link_hint('TIMEOUT')}") from None
        except Exception as error:
            raise SensorUnavailable(f"{self._label()}: cannot start: {error}; {link_hint(str(error))}") from error

    # -------------------------------------------------------------- the thread that owns the camera

    def _backoff(self) -> Backoff:
        c = self.config
        return Backoff(c.reconnect_s, c.reconnect_max_s, c.give_up_after)

    def _retry_note(self, attempt: int, delay: float) -> str:
        return f"retry {attempt} in {delay:g} s"

    def _crash_reason(self, error: Exception) -> str:
        return f"{self._label()}: the camera thread stopped: {error!r}"

    def _failure(self, reason: str) -> SensorError:
        return OakFailed(reason)

    def _close_link(self, link: OakLink) -> None:
        link.close()

    def _read_one(self, link: OakLink) -> bool:
        c = self.config
        try:
            got = link.read(READ_SLICE_S)
        except Exception as e:  # X_LINK_ERROR, QueueException: a lost link, never a crash of the loop
            raise LinkLost(f"{self._label()}: lost the camera ({e}); {link_hint(str(e))}") from e
        health, detail = link.health()
        if health is LinkHealth.FAILED:
            raise LinkLost(f"{self._label()}: depthai could not reconnect ({detail}); {link_hint('X_LINK_ERROR')}")
        if health is LinkHealth.RECONNECTING:
            if self._state is not SensorState.RECONNECTING:
                self._set_state(SensorState.RECONNECTING, f"{self._label()}: link lost, depthai is reconnecting "
                                                          f"({detail}); {link_hint('X_LINK_ERROR')}")
            if time.monotonic() - self._last_frame > c.connect_timeout_s:
                raise LinkLost(f"{self._label()}: depthai's reconnection took over {c.connect_timeout_s:g} s")
            return True
        if self._state is not SensorState.CONNECTED:  # depthai reconnected by itself
            self._numbering.restart_device_numbering()
            with self._lock:
                self._reconnects += 1
            self._set_state(SensorState.CONNECTED, "")
        if got is None:
            if time.monotonic() - self._last_frame > c.stall_s:
                raise LinkLost(f"{self._label()}: no frame for {c.stall_s:g} s (stall_s); the pipeline hung")
            return True
        self._last_frame = time.monotonic()
        self._deliver(link, got.message, got.age_s)
        return True

    def _reconnect(self) -> tuple[OakLink | None, str]:
        try:
            found = self._find()
        except SensorUnavailable as e:
            return None, f"{self._label()}: {e}"
        try:
            link = self._connect(found, self.config)
        except Exception as e:  # the camera is rebooting, or still in use: try again later
            return None, f"{self._label()}: cannot reconnect to {found.describe()}: {e}; {link_hint(str(e))}"
        with self._lock:
            self.device_id = found.device_id or found.name
        return link, ""

    def _reconnected(self, link: OakLink) -> None:
        self._numbering.restart_device_numbering()
        self._last_frame = time.monotonic()

    def _deliver(self, link: OakLink, message: object, age_s: float) -> None:
        now = self._clock.now()
        with self._lock:
            try:
                frame, source = make_frame(self.name, message, self._numbering, now=now, age_s=age_s,
                                           size=self.config.size, fallback=link.calibration)
            except BadMessage as e:
                self._bad += 1
                self._reason = f"{self._label()}: bad message ({e})"
                return
            self._sources[source] += 1
            self._queue.put(frame)
