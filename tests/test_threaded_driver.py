"""ThreadedDriver: the skeleton of the live drivers, driven by a fake device with scripted faults."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest

from sensors.base import Frame, PadSample, SensorError, SensorNotOpen, SensorSpec, SensorState
from sensors.clock import Clock, WallClock
from sensors.testing import check_sensor
from sensors.threaded import Backoff, LinkLost, ThreadedDriver


class FakeLink:
    """A device that sends ``count`` samples, then is lost (``lose()``) or stays quiet."""

    def __init__(self, count: int) -> None:
        self.count = count
        self.sent = 0
        self.lost = threading.Event()
        self.closed = False

    def close(self) -> None:
        self.closed = True


class FakeDriver(ThreadedDriver[FakeLink]):
    driver = "fake"

    def __init__(self, reconnects_allowed: int = 99, give_up_after: int = 0, count: int = 3,
                 clock: Clock | None = None) -> None:
        super().__init__(SensorSpec("board", "pads", 100.0, pads=1), clock if clock is not None else WallClock(),
                         queue_size=8, join_s=2.0)
        self.reconnects_allowed = reconnects_allowed
        self.give_up_after = give_up_after
        self.count = count
        self.links: list[FakeLink] = []
        self.seq = 0
        self.crash = False

    def open(self) -> None:
        if self._open:
            return
        link = FakeLink(self.count)
        self.links.append(link)
        self._start_reader(lambda: link)

    def _backoff(self) -> Backoff:
        return Backoff(0.02, 0.02, self.give_up_after)

    def _read_one(self, link: FakeLink) -> bool:
        if self.crash:
            raise RuntimeError("a bug")
        if link.lost.is_set():
            raise LinkLost("board unplugged")
        if link.sent < link.count:
            link.sent += 1
            self._queue.put(Frame(self.name, self._clock.now(), self.seq, PadSample((0.0,), (0,))))
            self.seq += 1
        else:
            time.sleep(0.005)
        return True

    def _reconnect(self) -> tuple[FakeLink | None, str]:
        if len(self.links) > self.reconnects_allowed:
            return None, "board not found"
        link = FakeLink(self.count)
        self.links.append(link)
        return link, ""

    def _close_link(self, link: FakeLink) -> None:
        link.close()


def wait_until(cond: Callable[[], bool], timeout: float = 3.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.005)
    return cond()


def collect(sensor: FakeDriver, n: int) -> list[Frame]:
    frames: list[Frame] = []
    deadline = time.monotonic() + 3.0
    while len(frames) < n and time.monotonic() < deadline:
        frame = sensor.read(0.02)
        if frame is not None:
            frames.append(frame)
    return frames


def test_read_before_open_raises_and_read_waits_no_longer_than_asked() -> None:
    sensor = FakeDriver(count=0)
    with pytest.raises(SensorNotOpen, match="fake 'board': read before open"):
        sensor.read(0.0)
    with sensor:
        assert sensor.status.state is SensorState.CONNECTED
        start = time.monotonic()
        assert sensor.read(0.05) is None
        assert time.monotonic() - start < 0.5
    assert sensor.status.state is SensorState.CLOSED
    assert sensor.links[0].closed


def test_a_lost_link_reconnects_with_the_reason_shown_meanwhile() -> None:
    sensor = FakeDriver(reconnects_allowed=2)
    with sensor:
        assert [f.seq for f in collect(sensor, 3)] == [0, 1, 2]
        sensor.reconnects_allowed = 0  # the first reopen fails
        sensor.links[0].lost.set()
        assert wait_until(lambda: sensor.status.state is SensorState.RECONNECTING)
        assert wait_until(lambda: sensor.status.reason == "board not found; retrying every 0.02 s")
        assert sensor.links[0].closed
        sensor.reconnects_allowed = 2
        assert wait_until(lambda: sensor.status.state is SensorState.CONNECTED)
        assert sensor.status.extra["reconnects"] == 1.0
        assert [f.seq for f in collect(sensor, 3)] == [3, 4, 5]


def test_the_backoff_giving_up_turns_the_sensor_failed() -> None:
    sensor = FakeDriver(reconnects_allowed=0, give_up_after=2)
    with sensor:
        collect(sensor, 3)
        sensor.links[0].lost.set()
        with pytest.raises(SensorError, match=r"board unplugged|board not found") as info:
            deadline = time.monotonic() + 3.0
            while time.monotonic() < deadline:
                sensor.read(0.05)
        assert "gave up after 2 attempts" in str(info.value)
        assert sensor.status.state is SensorState.FAILED


def test_a_crash_in_the_thread_is_reported_as_failed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(threading, "excepthook", lambda args: None)
    sensor = FakeDriver(count=0)
    with sensor:
        sensor.crash = True
        with pytest.raises(SensorError, match=r"the reader thread stopped: RuntimeError\('a bug'\)"):
            sensor.read(2.0)
        assert sensor.links[0].closed


def test_close_during_a_long_backoff_returns_at_once() -> None:
    sensor = FakeDriver(reconnects_allowed=0)
    sensor._backoff = lambda: Backoff(30.0, 30.0)  # type: ignore[method-assign]
    sensor.open()
    sensor.links[0].lost.set()
    assert wait_until(lambda: sensor.status.state is SensorState.RECONNECTING)
    start = time.monotonic()
    sensor.close()
    assert time.monotonic() - start < 1.0
    assert sensor.status.state is SensorState.CLOSED


def test_the_fake_driver_passes_the_sensor_contract() -> None:
    check_sensor(lambda clock: FakeDriver(count=5, clock=clock), duration=0.5,
                 deterministic=False)
