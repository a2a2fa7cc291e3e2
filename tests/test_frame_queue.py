"""FrameQueue: drop-oldest counting, bounded waits, wake-ups from another thread; SensorContext."""

from __future__ import annotations

import threading

import pytest

from sensors.base import Frame, PadSample, SensorContext
from sensors.frame_queue import FrameQueue


def _frame(seq: int) -> Frame:
    return Frame(sensor="pads", t=seq * 0.01, seq=seq, payload=PadSample(newtons=(0.0, 0.0), raw=(0, 0)))


def test_full_queue_drops_the_oldest_and_counts_it() -> None:
    q = FrameQueue(2)
    assert [q.put(_frame(i)) for i in range(5)] == [True, True, False, False, False]
    assert q.dropped == 3
    assert len(q) == 2
    first, second = q.get(0.0), q.get(0.0)
    assert first is not None and second is not None
    assert (first.seq, second.seq) == (3, 4)
    assert q.get(0.0) is None


def test_clear_keeps_the_dropped_count_and_reset_zeroes_it() -> None:
    q = FrameQueue(1)
    q.put(_frame(0))
    q.put(_frame(1))
    q.clear()
    assert (len(q), q.dropped) == (0, 1)
    q.put(_frame(2))
    q.reset()
    assert (len(q), q.dropped) == (0, 0)


def test_get_returns_none_when_nothing_arrives() -> None:
    q = FrameQueue(3)
    assert q.get(0.02) is None
    assert q.get(-1.0) is None  # a negative timeout is no wait, not an error


def test_get_wakes_when_another_thread_puts() -> None:
    q = FrameQueue(3)
    got: list[Frame | None] = []
    reader = threading.Thread(target=lambda: got.append(q.get(10.0)))
    reader.start()
    q.put(_frame(7))
    reader.join(10.0)
    assert not reader.is_alive()
    assert got[0] is not None and got[0].seq == 7


def test_wake_ends_the_wait_once_until_is_true() -> None:
    q = FrameQueue(3)
    failed = threading.Event()
    got: list[Frame | None] = [_frame(0)]
    reader = threading.Thread(target=lambda: got.__setitem__(0, q.get(10.0, until=failed.is_set)))
    reader.start()
    failed.set()
    q.wake()
    reader.join(10.0)
    assert not reader.is_alive()
    assert got[0] is None


def test_maxlen_must_be_positive() -> None:
    with pytest.raises(ValueError, match="^maxlen:"):
        FrameQueue(0)


class _Counted(SensorContext):
    def __init__(self) -> None:
        self.calls: list[str] = []

    def open(self) -> None:
        self.calls.append("open")

    def close(self) -> None:
        self.calls.append("close")


def test_sensor_context_opens_returns_itself_and_closes_on_error() -> None:
    sensor = _Counted()
    with pytest.raises(RuntimeError), sensor as entered:
        assert entered is sensor
        assert sensor.calls == ["open"]
        raise RuntimeError("boom")
    assert sensor.calls == ["open", "close"]
