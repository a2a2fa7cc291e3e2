"""The replay twin that fails on a schedule, for every payload kind, alone and in configs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from recording_fixtures import sample_frames, write_recording

from sensors.base import DepthImage, Frame, PadSample, SensorState, frame_digest
from sensors.clock import SimClock
from sensors.faults import Corruption, FaultSchedule, FaultyReplayConfig, FaultySensor, SimulatedFailure
from sensors.recording.replay import Replay
from sensors.registry import SENSOR_TYPES
from sensors.testing import check_sensor

ROOT = Path(__file__).resolve().parent.parent
CHANNELS = {"cam": "color", "depth": "depth", "pads": "pads"}
STEP = 1 / 60


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("faults") / "three_sensors.mcap"
    return write_recording(path, sample_frames(seconds=1.5), color_format="png")


def drive(sensor: FaultySensor | Replay, clock: SimClock, seconds: float) -> list[tuple[float, SensorState, str,
                                                                                       list[Frame]]]:
    """Open, then step the clock; per step: (time, state, reason, frames read)."""
    out = []
    sensor.open()
    for i in range(round(seconds / STEP) + 1):
        if i:
            clock.advance(STEP)
        frames = []
        while (f := sensor.read(0.0)) is not None:
            frames.append(f)
        s = sensor.status
        out.append((clock.now(), s.state, s.reason, frames))
    return out


def test_the_schedule_says_up_down_or_failed() -> None:
    once = FaultSchedule(disconnect_at_s=2.0, down_for_s=1.5)
    assert once.phase(1.99)[0] == "up" and once.phase(2.0) == ("down", 2.0, 3.5)
    assert once.phase(3.5)[0] == "up" and once.phase(100.0)[0] == "up"
    assert [once.outages_begun(t) for t in (0.0, 2.0, 50.0)] == [0, 1, 1]
    every = FaultSchedule(disconnect_at_s=1.0, down_for_s=0.5, repeat_every_s=2.0)
    assert [every.phase(t)[0] for t in (0.9, 1.2, 1.6, 3.1, 3.6, 5.4)] == ["up", "down", "up", "down", "up", "down"]
    assert every.phase(1.6) == ("up", 3.0, 3.5)  # while up: the next outage
    assert every.outages_begun(5.4) == 3
    dead = FaultSchedule(disconnect_at_s=1.0, down_for_s=0.5, fail=True)
    assert [dead.phase(t)[0] for t in (0.5, 1.2, 1.5, 99.0)] == ["up", "down", "failed", "failed"]


@pytest.mark.parametrize("channel", list(CHANNELS))
def test_an_outage_loses_its_frames_and_recovers(recording: Path, channel: str) -> None:
    schedule = FaultSchedule(disconnect_at_s=0.405, down_for_s=0.5)  # edges between frames and steps
    clock = SimClock(5.0)
    steps = drive(FaultySensor(Replay(recording, clock, channel=channel), schedule, clock), clock, 1.5)
    plain_clock = SimClock(5.0)
    plain = [f for *_, fs in drive(Replay(recording, plain_clock, channel=channel), plain_clock, 1.5) for f in fs]

    in_outage = [f for f in plain if 0.405 <= f.t - 5.0 < 0.905]
    expected = [f for f in plain if f not in in_outage]
    got = [f for *_, fs in steps for f in fs]
    assert in_outage and [frame_digest(f) for f in got] == [frame_digest(f) for f in expected]
    first_after = next(i for i, f in enumerate(got) if f.t - 5.0 >= 0.905)
    assert got[first_after].seq - got[first_after - 1].seq == len(in_outage) + 1  # the gap shows

    for t, state, reason, frames in steps:
        rel = t - 5.0
        if 0.405 <= rel < 0.905:
            assert state is SensorState.RECONNECTING and frames == []
            assert reason.endswith("simulated fault: disconnected at 0.405 s after open, back at 0.905 s")
        elif t < plain[-1].t - 1e-6:  # the last frame is due (to 1 ns) at the step that reaches it
            assert state is SensorState.CONNECTED and reason == ""
    assert steps[-1][1] is SensorState.ENDED  # the recording ran out after the outage


def test_status_counts_what_was_lost(recording: Path) -> None:
    clock = SimClock()
    sensor = FaultySensor(Replay(recording, clock, channel="pads"), FaultSchedule(0.2, 0.3, repeat_every_s=0.6), clock)
    frames = [f for *_, fs in drive(sensor, clock, 1.5) for f in fs]
    s = sensor.status
    assert s.frames == len(frames) and s.extra["simulated_outages"] == 3
    assert s.dropped == s.extra["simulated_lost"] == 150 - len(frames)
    sensor.close()
    assert sensor.status.state is SensorState.CLOSED


def test_a_permanent_failure_fails_loudly(recording: Path) -> None:
    clock = SimClock()
    sensor = FaultySensor(Replay(recording, clock, channel="depth"), FaultSchedule(0.5, 0.25, fail=True), clock)
    sensor.open()
    clock.advance(0.6)
    while sensor.read(0.0) is not None:
        pass
    assert sensor.status.state is SensorState.RECONNECTING
    clock.advance(0.2)
    status = sensor.status
    assert status.state is SensorState.FAILED
    assert status.reason == "depth: simulated fault: disconnected at 0.5 s after open and never came back (fail = true)"
    with pytest.raises(SimulatedFailure, match="never came back"):
        sensor.read(0.0)
    sensor.close()


@pytest.mark.parametrize("corruption", ["noise", "blank"])
@pytest.mark.parametrize("channel", list(CHANNELS))
def test_every_nth_frame_is_well_formed_garbage(recording: Path, channel: str, corruption: Corruption) -> None:
    def run() -> list[Frame]:
        clock = SimClock()
        schedule = FaultSchedule(disconnect_at_s=100.0, corrupt_every=3, corruption=corruption, seed=9)
        return [f for *_, fs in drive(FaultySensor(Replay(recording, clock, channel=channel), schedule, clock),
                                      clock, 1.5) for f in fs]

    clock = SimClock()
    plain = [f for *_, fs in drive(Replay(recording, clock, channel=channel), clock, 1.5) for f in fs]
    got = run()
    assert len(got) == len(plain) > 10
    for i, (g, p) in enumerate(zip(got, plain, strict=True)):
        assert (g.seq, g.t, g.kind) == (p.seq, p.t, p.kind)
        if i % 3 != 2:
            assert frame_digest(g) == frame_digest(p)
            continue
        assert frame_digest(g) != frame_digest(p)
        if isinstance(g.payload, PadSample):
            assert len(g.payload.newtons) == len(p.payload.newtons)  # type: ignore[union-attr]
            values = np.array(g.payload.newtons)
        elif isinstance(g.payload, DepthImage):
            assert g.payload.depth_mm.shape == p.payload.depth_mm.shape and g.payload.depth_mm.dtype == np.uint16  # type: ignore[union-attr]
            values = g.payload.depth_mm
        else:
            assert g.payload.bgr.shape == p.payload.bgr.shape  # type: ignore[union-attr]
            values = g.payload.bgr
        assert (not values.any()) if corruption == "blank" else values.std() > 0
    assert [frame_digest(f) for f in run()] == [frame_digest(f) for f in got]  # the garbage repeats exactly


def test_nan_garbage_makes_every_pad_force_non_finite_and_images_noise(recording: Path) -> None:
    schedule = FaultSchedule(disconnect_at_s=100.0, corrupt_every=2, corruption="nan", seed=3)
    for channel in CHANNELS:
        clock = SimClock()
        frames = [f for *_, fs in drive(FaultySensor(Replay(recording, clock, channel=channel), schedule, clock),
                                        clock, 0.5) for f in fs]
        bad = frames[1::2]
        assert len(bad) >= 5
        for f in bad:
            if isinstance(f.payload, PadSample):
                assert not any(np.isfinite(f.payload.newtons))
                assert {repr(v) for v in f.payload.newtons} <= {"nan", "inf", "-inf"}
            elif isinstance(f.payload, DepthImage):
                assert f.payload.depth_mm.std() > 0
            else:
                assert f.payload.bgr.std() > 0
        if channel == "pads":
            assert all(np.isfinite(f.payload.newtons).all() for f in frames[0::2])  # type: ignore[union-attr]


@pytest.mark.parametrize("channel", list(CHANNELS))
@pytest.mark.parametrize("clock_start", [0.0, 12.5])
def test_faulty_replays_keep_the_contract(recording: Path, channel: str, clock_start: float) -> None:
    schedule = FaultSchedule(disconnect_at_s=0.3, down_for_s=0.4, repeat_every_s=0.9, corrupt_every=4)

    def make(clock: SimClock) -> FaultySensor:
        return FaultySensor(Replay(recording, clock, channel=channel, loop=True), schedule, clock)

    check_sensor(make, clock_start=clock_start, duration=2.5, step=STEP)


def test_the_registry_builds_one_from_a_config_table(recording: Path) -> None:
    row = SENSOR_TYPES["faulty-replay"]
    config = row.config(path=recording, channel="pads", disconnect_at_s=0.51, down_for_s=0.25)
    clock = SimClock()
    sensor = row.loader(config, "floor", clock)
    assert isinstance(sensor, FaultySensor) and sensor.spec.name == "floor"
    steps = drive(sensor, clock, 1.0)
    assert [s for t, s, *_ in steps if 0.51 <= t < 0.76] == [SensorState.RECONNECTING] * 15
    sensor.close()


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("down_for_s", 0.0, "down_for_s: expected seconds > 0, got 0.0"),
        ("disconnect_at_s", -1.0, "disconnect_at_s: expected seconds >= 0"),
        ("repeat_every_s", 0.5, r"repeat_every_s: expected 0 \(once\) or seconds > down_for_s \(1\)"),
        ("corrupt_every", -2, "corrupt_every: expected a whole number >= 0"),
        ("corruption", "static", "corruption: expected 'noise', 'blank' or 'nan'"),
        ("path", Path(""), "path: expected the path of an .mcap recording"),
    ],
)
def test_config_errors_start_with_the_field(field: str, value: object, message: str) -> None:
    fields: dict[str, object] = {"path": Path("x.mcap"), field: value}
    with pytest.raises(ValueError, match=message):
        FaultyReplayConfig(**fields)  # type: ignore[arg-type]


def test_a_config_file_with_a_faulty_replay_loads(tmp_path: Path, recording: Path) -> None:
    from jostle.config import ConfigError, load_config

    keyframes = ROOT / "configs" / "keyframes" / "humanoid" / "keyframes.toml"
    (tmp_path / "rec.mcap").write_bytes(recording.read_bytes())
    toml = tmp_path / "faulty.toml"
    render = f'[render]\nkeyframes = "{keyframes}"\n'
    toml.write_text('[sensors.cam]\ntype = "faulty-replay"\npath = "rec.mcap"\nchannel = "cam"\n'
                    "disconnect_at_s = 0.5\ndown_for_s = 2.0\nfail = true\n" + render)
    entry = load_config(toml).sensors[0]
    assert entry.type == "faulty-replay" and entry.config.path == tmp_path / "rec.mcap"
    assert entry.config.schedule == FaultSchedule(disconnect_at_s=0.5, down_for_s=2.0, fail=True)
    toml.write_text('[sensors.cam]\ntype = "faulty-replay"\npath = "rec.mcap"\ndown_for_s = -1\n' + render)
    with pytest.raises(ConfigError, match=r"faulty\.toml: sensors\.cam\.down_for_s: expected seconds > 0"):
        load_config(toml)
