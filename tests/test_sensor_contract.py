"""Every Sensor implementation that can run here goes through the same contract check."""

from __future__ import annotations

import itertools
import random
from collections.abc import Callable
from pathlib import Path

import pytest
from recording_fixtures import sample_frames, write_recording, write_video

from sensors.base import (
    ContractError,
    Frame,
    PadSample,
    Sensor,
    SensorNotOpen,
    SensorSpec,
    SensorState,
    SensorStatus,
)
from sensors.clock import SimClock
from sensors.recording.replay import Replay
from sensors.recording.writer import Recorder, RecordingWriter
from sensors.testing import check_sensor
from sensors.webcam.config import WebcamConfig
from sensors.webcam.driver import WebcamSensor


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("contract") / "three_sensors.mcap"
    return write_recording(path, sample_frames(seconds=1.0), chunk_size=64 * 1024)


@pytest.fixture(scope="module")
def video(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_video(tmp_path_factory.mktemp("contract") / "drawn.mp4", frames=30, fps=30.0)


Maker = Callable[[SimClock], Sensor]


def makers(recording: Path, video: Path, out: Path) -> dict[str, Maker]:
    counter = itertools.count()

    def recorder(clock: SimClock) -> Sensor:
        writer = RecordingWriter(out / f"rerecord_{next(counter)}.mcap")
        return Recorder(Replay(recording, clock, channel="depth"), writer, owns_writer=True)

    return {
        "replay-color": lambda clock: Replay(recording, clock, channel="cam"),
        "replay-depth": lambda clock: Replay(recording, clock, channel="depth"),
        "replay-pads": lambda clock: Replay(recording, clock, channel="pads", name="floor_pads"),
        "replay-pads-looping": lambda clock: Replay(recording, clock, channel="pads", loop=True),
        "recorder-of-replay": recorder,
        "webcam-file": lambda clock: WebcamSensor(WebcamConfig(source=str(video)), clock, name="cam"),
    }


CASES = ["replay-color", "replay-depth", "replay-pads", "replay-pads-looping", "recorder-of-replay", "webcam-file"]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("clock_start", [0.0, 12.5])
def test_contract(case: str, clock_start: float, recording: Path, video: Path, tmp_path: Path) -> None:
    make = makers(recording, video, tmp_path)[case]
    check_sensor(make, clock_start=clock_start, duration=2.5, step=1 / 60)


class _ScriptedPads:
    """A small pad sensor that can break one rule of the contract on purpose."""

    def __init__(self, clock: SimClock, flaw: str) -> None:
        self._clock = clock
        self._flaw = flaw
        self._open = False
        self._n = 0
        self._noise = random.Random()

    @property
    def spec(self) -> SensorSpec:
        return SensorSpec(name="pads", kind="pads", rate_hz=60.0, pads=2)

    @property
    def status(self) -> SensorStatus:
        return SensorStatus(SensorState.CONNECTED if self._open else SensorState.CLOSED, frames=self._n)

    def open(self) -> None:
        self._open = True

    def read(self, timeout: float) -> Frame | None:
        if not self._open and self._flaw != "reads-before-open":
            raise SensorNotOpen("pads: not open")
        if self._n >= 5 or self._clock.now() < self._n / 60:
            return None
        self._n += 1
        seq = 10 - self._n if self._flaw == "seq-goes-back" else self._n
        newtons: tuple[float, ...] = (self._noise.random(), 1.0) if self._flaw == "random" else (float(self._n), 1.0)
        if self._flaw == "wrong-pad-count":
            newtons = (1.0,)
        return Frame("pads", self._clock.now(), seq, PadSample(newtons, (1,) * len(newtons)))

    def close(self) -> None:
        self._open = False

    def __enter__(self) -> _ScriptedPads:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@pytest.mark.parametrize(
    ("flaw", "message"),
    [
        ("none", None),
        ("seq-goes-back", "seq went from 9 to 8"),
        ("random", "two fresh instances driven alike differ at frame 0"),
        ("reads-before-open", r"read\(\) before open\(\) must raise SensorNotOpen"),
        ("wrong-pad-count", "pad sample has 1 pads, the spec says 2"),
    ],
)
def test_checker_catches_each_broken_rule(flaw: str, message: str | None) -> None:
    def make(clock: SimClock) -> Sensor:
        return _ScriptedPads(clock, flaw)

    if message is None:
        check_sensor(make, duration=0.2)
        return
    with pytest.raises(ContractError, match=message):
        check_sensor(make, duration=0.2)
