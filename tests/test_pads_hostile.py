"""Pad boards that send what no pad can say, through the real driver on a pty: CSV numbers in
Python's syntax (``1_000``, ``2_2``, ``0x10``, other scripts' digits) are bad lines, not 1000 or 22;
int32 extremes (5.4e8 N at 0.25 N/count) reach the observer guard, which skips them with one line."""

from __future__ import annotations

import logging
import os
import pty
import time
import tty
from collections.abc import Iterator

import pytest

from interaction.pads import PadsObserver, PadsObserverConfig
from jostle.observer_guard import ObserverGuard
from sensors.base import Frame, PadSample
from sensors.clock import SimClock
from sensors.pads.config import PadsConfig
from sensors.pads.driver import PadsSensor
from sensors.pads.protocol import StreamParser, WireSample, encode_binary


class Board:
    """A pseudo-terminal pair standing in for a pad board."""

    def __init__(self) -> None:
        self.master, self.slave = pty.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)

    def send(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.master, view) :]

    def close(self) -> None:
        os.close(self.master)
        os.close(self.slave)


@pytest.fixture
def board() -> Iterator[Board]:
    b = Board()
    yield b
    b.close()


def collect(sensor: PadsSensor, n: int, deadline_s: float = 5.0) -> list[Frame]:
    frames: list[Frame] = []
    end = time.monotonic() + deadline_s
    while len(frames) < n and time.monotonic() < end:
        frame = sensor.read(0.05)
        if frame is not None:
            frames.append(frame)
    return frames


def test_csv_takes_plain_decimal_numbers_only(board: Board) -> None:
    config = PadsConfig(port=board.path, framing="csv", pads=2, tare_samples=0, reconnect_s=0.05)
    sensor = PadsSensor(config, SimClock())
    sensor.open()
    bad = [b"0,1_000,5", b"1,2_2,5", b"2,0x10,5", "3,\u0661,5".encode(), b"4,1e3,5", b"5,5.0,5", b"6,--1,5"]
    board.send(b"\n" + b"\n".join(bad) + b"\n7,+7, 8\n8 -10 20\n")  # (a first part is a frame opened midway)
    frames = collect(sensor, 2)
    time.sleep(0.1)
    status = sensor.status
    sensor.close()
    raw = [f.payload.raw for f in frames if isinstance(f.payload, PadSample)]
    assert raw == [(7, 8), (-10, 20)]  # never (1000, 5) nor (22, 5)
    assert status.bad == len(bad)


def test_the_parser_names_what_is_wrong_with_python_number_syntax() -> None:
    parser = StreamParser("csv", 1)
    assert parser.feed(b"0,1\n1,2_2\n") == [WireSample(0, (1,))] and parser.bad == 1
    assert "plain decimal" in parser.last_bad
    assert parser.feed(b"2, 22 \n") == [WireSample(2, (22,))]


def test_int32_extremes_from_a_board_are_skipped_by_the_guard_with_one_line(
    board: Board, caplog: pytest.LogCaptureFixture
) -> None:
    config = PadsConfig(port=board.path, framing="binary", pads=2, tare_samples=0, reconnect_s=0.05,
                        newtons_per_count=(0.25,))
    sensor = PadsSensor(config, SimClock())
    sensor.open()
    counts = [(100, 0)] * 5 + [(2**31 - 1, 0), (-(2**31), 7)] * 5 + [(200, 0)] * 5
    board.send(b"".join(encode_binary(i, c) for i, c in enumerate(counts)))
    frames = collect(sensor, len(counts))
    sensor.close()
    assert len(frames) == len(counts)
    clock = SimClock()
    cfg = PadsObserverConfig(positions=(0.0, 0.0, 1.0) * 2, directions=(0.0, 1.0, 0.0) * 2)
    guard = ObserverGuard("floor", lambda: PadsObserver(cfg), clock)
    caplog.set_level(logging.INFO, "jostle.observers")
    for f in frames:
        clock.advance(0.0125)
        guard.observe(f)
    h = guard.health()
    assert (h.bad_frames, h.observations, h.crashes) == (10, 10, 0)
    lines = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(lines) == 1 and "5.37e+08 N" in lines[0], lines
