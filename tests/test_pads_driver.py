"""PadsSensor on real pseudo-terminals: the driver opens the slave's path, the test writes to the master.

Nothing here sleeps for a fixed time: every wait is a loop on a condition with a deadline.
"""

from __future__ import annotations

import errno
import os
import pty
import random
import re
import threading
import time
import tty
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from sensors.base import Frame, PadSample, Sensor, SensorState, SensorUnavailable
from sensors.clock import SimClock, WallClock
from sensors.pads.config import PadsConfig
from sensors.pads.driver import QUEUE_SIZE, PadsFailed, PadsSensor, port_open_hint
from sensors.pads.protocol import StreamParser, encode_binary, encode_csv
from sensors.recording.replay import Replay
from sensors.recording.writer import Recorder, RecordingWriter
from sensors.testing import check_sensor

DEADLINE_S = 5.0


class Board:
    """A pseudo-terminal pair standing in for a pad board."""

    def __init__(self) -> None:
        self.master, self.slave = pty.openpty()
        tty.setraw(self.slave)  # no line editing or echo before the driver configures the port
        self.path = os.ttyname(self.slave)
        self._closed = False

    def send(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.master, view) :]

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            os.close(self.master)
            os.close(self.slave)


@pytest.fixture
def board() -> Iterator[Board]:
    b = Board()
    yield b
    b.close()


def pads(port: str, **changes: object) -> PadsConfig:
    fields: dict[str, object] = {"port": port, "pads": 2, "tare_samples": 0, "reconnect_s": 0.05, **changes}
    return PadsConfig(**fields)  # type: ignore[arg-type]


def collect(sensor: PadsSensor, n: int, deadline_s: float = DEADLINE_S) -> list[Frame]:
    frames: list[Frame] = []
    end = time.monotonic() + deadline_s
    while len(frames) < n and time.monotonic() < end:
        frame = sensor.read(0.05)
        if frame is not None:
            frames.append(frame)
    return frames


def wait_until(condition: Callable[[], bool], deadline_s: float = DEADLINE_S) -> bool:
    end = time.monotonic() + deadline_s
    pause = threading.Event()
    while time.monotonic() < end:
        if condition():
            return True
        pause.wait(0.005)
    return condition()


def payload(frame: Frame) -> PadSample:
    assert isinstance(frame.payload, PadSample)
    return frame.payload


def test_binary_stream_arrives_in_order_with_counts_and_newtons(board: Board) -> None:
    sensor = PadsSensor(pads(board.path, pads=3, newtons_per_count=(0.5,)), SimClock(7.0), name="floor")
    sensor.open()
    assert sensor.spec.kind == "pads" and sensor.spec.pads == 3 and sensor.spec.name == "floor"
    assert sensor.status.state is SensorState.CONNECTED
    counts = [(i, -3 * i, 100_000 + i) for i in range(20)]
    board.send(b"".join(encode_binary(i, c) for i, c in enumerate(counts)))
    frames = collect(sensor, 20)
    status = sensor.status
    sensor.close()
    assert [f.seq for f in frames] == list(range(20))
    assert [payload(f).raw for f in frames] == counts
    assert [payload(f).newtons for f in frames] == [tuple(0.5 * v for v in c) for c in counts]
    assert {f.t for f in frames} == {7.0} and {f.sensor for f in frames} == {"floor"}
    assert (status.frames, status.bad, status.dropped) == (20, 0, 0)


def test_csv_lines_with_crlf_comments_and_a_bad_line(board: Board) -> None:
    sensor = PadsSensor(pads(board.path, framing="csv", newtons_per_count=(2.0, -1.0)), SimClock())
    sensor.open()
    board.send(b"# hx711 board ready\r\n0,10,20\r\n\r\n1,11,21\n2 12 22\r\nnan,1,2\r\n" + encode_csv(3, [13, 23]))
    frames = collect(sensor, 4)
    status = sensor.status
    sensor.close()
    assert [payload(f).raw for f in frames] == [(10, 20), (11, 21), (12, 22), (13, 23)]
    assert [payload(f).newtons for f in frames] == [(20.0, -20.0), (22.0, -21.0), (24.0, -22.0), (26.0, -23.0)]
    assert (status.bad, status.extra["ignored"], status.dropped) == (1, 2.0, 0)


def test_garbage_bit_flips_and_truncations_are_counted_never_delivered(board: Board) -> None:
    rng = random.Random(3)
    sensor = PadsSensor(pads(board.path, pads=4), SimClock())
    sensor.open()
    sent: list[tuple[int, ...]] = []
    stream = bytearray()
    damaged = 0
    for i in range(30):
        counts = tuple(rng.randrange(-50_000, 50_000) for _ in range(4))
        sent.append(counts)
        stream += encode_binary(i, counts)
        other = bytearray(encode_binary(1000 + i, [rng.randrange(1 << 20) for _ in range(4)]))
        if i % 3 == 0:
            stream += rng.randbytes(rng.randint(1, 60))  # noise
        elif i % 3 == 1:
            bit = rng.randrange(8, (len(other) - 1) * 8)  # one bit inside the frame body
            other[bit // 8] ^= 1 << (bit % 8)
            stream += other
            damaged += 1
        else:
            stream += other[: rng.randrange(2, len(other) - 2)]  # truncated
            damaged += 1
    stream += encode_binary(30, [0, 0, 0, 0])
    sent.append((0, 0, 0, 0))
    board.send(bytes(stream))
    frames = collect(sensor, len(sent))
    assert sensor.read(0.05) is None  # nothing else came through
    status = sensor.status
    sensor.close()
    assert [payload(f).raw for f in frames] == sent
    assert [f.seq for f in frames] == list(range(31)) and status.dropped == 0
    reference = StreamParser("binary", 4)  # the same bytes through the parser alone
    reference.feed(bytes(stream))
    assert status.bad == reference.bad >= damaged
    assert status.extra["bad_bytes"] == reference.bad_bytes > 0


def test_gaps_in_the_board_sequence_are_dropped_frames_and_show_in_seq(board: Board) -> None:
    sensor = PadsSensor(pads(board.path), SimClock())
    sensor.open()
    board_seqs = [65533, 65534, 65535, 0, 3, 4, 4, 5]  # 1 and 2 lost across the wrap, 4 repeated
    board.send(b"".join(encode_binary(s, [s, 0]) for s in board_seqs))
    frames = collect(sensor, 7)
    status = sensor.status
    sensor.close()
    assert [payload(f).raw[0] for f in frames] == [65533, 65534, 65535, 0, 3, 4, 5]
    assert [f.seq for f in frames] == [0, 1, 2, 3, 6, 7, 8]
    assert status.dropped == 2 and status.extra["repeats"] == 1.0


def test_tare_averages_the_first_samples_then_calibrates(board: Board) -> None:
    sensor = PadsSensor(pads(board.path, tare_samples=4, newtons_per_count=(0.01, -0.02)), SimClock())
    sensor.open()
    assert sensor.status.extra["taring"] == 1.0 and "taring: 0 of 4" in sensor.status.reason
    tare = [(1000 + i, 5000 - 2 * i) for i in range(4)]  # zero = (1001.5, 4997)
    loaded = [(1001, 4997), (3001, 4997), (1001, 2997), (-999, 7997)]
    board.send(b"".join(encode_binary(i, c) for i, c in enumerate(tare + loaded)))
    frames = collect(sensor, 4)
    status = sensor.status
    sensor.close()
    zero = (sum(c[0] for c in tare) / 4, sum(c[1] for c in tare) / 4)
    assert [f.seq for f in frames] == [0, 1, 2, 3]  # the tare samples are not delivered
    assert [payload(f).raw for f in frames] == loaded
    expected = [((a - zero[0]) * 0.01, (b - zero[1]) * -0.02) for a, b in loaded]
    assert [payload(f).newtons for f in frames] == expected
    assert expected[1] == pytest.approx((19.995, 0.0)) and expected[3] == pytest.approx((-20.005, -60.0))
    assert status.extra["taring"] == 0.0 and status.reason == ""


def test_deadband_zeroes_small_forces_of_either_sign(board: Board) -> None:
    sensor = PadsSensor(pads(board.path, deadband_n=0.5, newtons_per_count=(0.1,)), SimClock())
    sensor.open()
    counts = [(4, -4), (5, -5), (6, 40)]
    board.send(b"".join(encode_binary(i, c) for i, c in enumerate(counts)))
    frames = collect(sensor, 3)
    sensor.close()
    assert [payload(f).newtons for f in frames] == [(0.0, 0.0), (5 * 0.1, -5 * 0.1), (6 * 0.1, 40 * 0.1)]


def test_a_full_queue_drops_the_oldest_frames(board: Board) -> None:
    sensor = PadsSensor(pads(board.path), SimClock())
    sensor.open()
    board.send(b"".join(encode_binary(i, [i, i]) for i in range(100)))
    assert wait_until(lambda: sensor.status.extra["samples"] == 100)
    frames = collect(sensor, QUEUE_SIZE)
    assert sensor.read(0.0) is None
    status = sensor.status
    sensor.close()
    assert [f.seq for f in frames] == list(range(100 - QUEUE_SIZE, 100))
    assert status.dropped == 100 - QUEUE_SIZE == status.extra["dropped_in_queue"]


def test_read_never_waits_longer_than_asked(board: Board) -> None:
    sensor = PadsSensor(pads(board.path), SimClock())
    sensor.open()
    for timeout in (0.0, 0.1):
        start = time.monotonic()
        assert sensor.read(timeout) is None
        assert time.monotonic() - start < timeout + 0.25
    sensor.close()


def test_too_many_bad_frames_fail_loudly(board: Board) -> None:
    sensor = PadsSensor(pads(board.path, pads=2, max_bad_per_s=10, baudrate=57600), SimClock())
    sensor.open()
    board.send(b"".join(encode_binary(i, [i, i, i]) for i in range(40)))  # the board has 3 pads, not 2
    assert wait_until(lambda: sensor.status.state is SensorState.FAILED)
    with pytest.raises(PadsFailed, match=r"more than 10 bad frames within 1 s .*sends 3 pads, the config says pads = 2"
                                         r".*baudrate \(57600\), framing \(binary\) and pad count \(2\)"):
        sensor.read(1.0)
    assert "more than 10 bad frames" in sensor.status.reason
    sensor.close()
    assert sensor.status.state is SensorState.CLOSED


def test_open_errors_name_the_port_and_what_to_check(tmp_path: Path) -> None:
    missing = tmp_path / "ttyUSB9"
    with pytest.raises(SensorUnavailable, match=rf"pads 'pads': cannot open serial port {re.escape(str(missing))}: "
                                                 r"ENOENT \(No such file or directory\); is the board plugged in"):
        PadsSensor(pads(str(missing)), SimClock()).open()
    not_a_tty = tmp_path / "notes.txt"
    not_a_tty.write_text("hello\n")
    with pytest.raises(SensorUnavailable, match=rf"cannot open serial port {re.escape(str(not_a_tty))}: .*serial port"):
        PadsSensor(pads(str(not_a_tty)), SimClock()).open()
    with pytest.raises(SensorUnavailable, match=r"cannot open 'nope://board'.*pyserial URL"):
        PadsSensor(pads("nope://board"), SimClock()).open()
    # tests run as root here, so a port without permission cannot be made: check the hint itself
    assert "dialout" in port_open_hint(errno.EACCES) and "another program" in port_open_hint(errno.EBUSY)


def test_a_pyserial_url_opens() -> None:
    sensor = PadsSensor(pads("loop://"), SimClock())
    with sensor:
        assert sensor.status.state is SensorState.CONNECTED
        assert sensor.read(0.02) is None
    assert sensor.status.state is SensorState.CLOSED


def test_port_that_vanishes_and_returns_reconnects(tmp_path: Path) -> None:
    first = Board()
    link = tmp_path / "pads-port"
    os.symlink(first.path, link)
    sensor = PadsSensor(pads(str(link), tare_samples=2), WallClock())
    second: Board | None = None
    try:
        sensor.open()
        first.send(b"".join(encode_binary(i, [i, 10]) for i in range(7)))
        before = collect(sensor, 5)
        assert [payload(f).raw for f in before] == [(i, 10) for i in range(2, 7)]

        unplugged = tmp_path / "unplugged"  # like /dev/ttyUSB0, the device node goes away with the board
        os.symlink(tmp_path / "no-such-device", unplugged)
        os.replace(unplugged, link)
        first.close()
        assert wait_until(lambda: sensor.status.state is SensorState.RECONNECTING)
        assert str(link) in sensor.status.reason
        assert wait_until(lambda: "ENOENT" in sensor.status.reason)  # retrying, the port is not there
        assert str(link) in sensor.status.reason and "retrying every 0.05 s" in sensor.status.reason

        second = Board()  # plugged in again: the same path now leads to a new pty
        staged = tmp_path / "staged"
        os.symlink(second.path, staged)
        os.replace(staged, link)
        assert wait_until(lambda: sensor.status.state is SensorState.CONNECTED)
        assert sensor.status.extra["reconnects"] == 1.0 and sensor.status.extra["taring"] == 1.0
        second.send(b"".join(encode_binary(i, [100 + i, 20]) for i in range(6)))  # a restarted board
        after = collect(sensor, 4)
        assert [payload(f).raw for f in after] == [(100 + i, 20) for i in range(2, 6)]  # tared again
        assert [payload(f).newtons for f in after] == [(float(i) - 0.5, 0.0) for i in range(2, 6)]
        assert [f.seq for f in before + after] == list(range(9))
    finally:
        sensor.close()
        first.close()
        if second is not None:
            second.close()


# ---------------------------------------------------------------- the contract


class StreamingBoard:
    """A board that keeps sending 4-pad binary frames every ``period`` seconds from its own thread."""

    def __init__(self, period: float = 0.004) -> None:
        self.board = Board()
        os.set_blocking(self.board.master, False)
        self._period = period
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        seq = 0
        while not self._stop.wait(self._period):
            try:
                os.write(self.board.master, encode_binary(seq & 0xFFFF, [seq, 2 * seq, -seq, 7]))
            except BlockingIOError:
                pass  # nobody reads the port between sensors: the pty is full, this frame is lost
            seq += 1

    def __enter__(self) -> StreamingBoard:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.board.close()


def test_contract_on_a_live_pty() -> None:
    with StreamingBoard() as streaming:
        config = PadsConfig(port=streaming.board.path, pads=4, tare_samples=3, rate_hz=250.0)

        def make(clock: SimClock) -> Sensor:
            return PadsSensor(config, clock, name="pads")

        check_sensor(make, duration=0.5, step=1 / 60, deterministic=False)


def test_a_recording_of_the_live_pads_passes_the_full_contract(tmp_path: Path) -> None:
    path = tmp_path / "pads.mcap"
    clock = SimClock(3.0)
    recorded: list[Frame] = []
    with StreamingBoard() as streaming:
        config = PadsConfig(port=streaming.board.path, pads=4, tare_samples=0, rate_hz=250.0, newtons_per_count=(0.25,))
        writer = RecordingWriter(path)
        with Recorder(PadsSensor(config, clock), writer, owns_writer=True) as sensor:
            end = time.monotonic() + DEADLINE_S
            while len(recorded) < 40 and time.monotonic() < end:
                clock.advance(1 / 60)
                frame = sensor.read(0.05)
                while frame is not None:
                    recorded.append(frame)
                    frame = sensor.read(0.0)
    assert len(recorded) >= 40
    assert all(payload(f).newtons == tuple(0.25 * v for v in payload(f).raw) for f in recorded)

    def make(c: SimClock) -> Sensor:
        return Replay(path, c)

    check_sensor(make, clock_start=recorded[0].t, duration=recorded[-1].t - recorded[0].t + 0.1)
    replay_clock = SimClock(recorded[0].t)
    with Replay(path, replay_clock) as replay:
        replay_clock.advance(recorded[-1].t - recorded[0].t)
        replayed = []
        frame = replay.read(0.0)
        while frame is not None:
            replayed.append(frame)
            frame = replay.read(0.0)
    # times are stored as whole nanoseconds
    assert [(round(f.t * 1e9), f.seq, f.payload) for f in replayed] == [
        (round(f.t * 1e9), f.seq, f.payload) for f in recorded]
