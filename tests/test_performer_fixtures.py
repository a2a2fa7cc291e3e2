"""The committed synthetic recordings in tests/fixtures/ (made by ``make fixtures``): they are what
the command builds, every channel replays as a sensor, and their ground truth agrees with their
depth pixels and pad forces. Also the ground-truth channel's writer and reader."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from interaction.webcam.calibration import Calibration
from jostle.cli import main
from jostle.performer.pads import default_pad_layout
from jostle.performer.truth import (
    TRUTH_SCHEMA,
    TRUTH_SCHEMA_NAME,
    TruthFrame,
    read_cameras,
    read_pad_layout,
    read_truth,
)
from sensors.base import ColorImage, DepthImage, Frame, PadSample, RecordingCorrupt, frame_digest
from sensors.clock import SimClock
from sensors.recording.info import describe_recording
from sensors.recording.replay import Replay
from sensors.recording.source import iter_frames
from sensors.recording.writer import RecordingWriter
from sensors.testing import check_sensor
from sim.motion.mocap import HUMANOID

FIXTURES = Path(__file__).parent / "fixtures"
PEOPLE = {"crossing2.mcap": 2, "group3.mcap": 3}
CHANNELS = {"webcam": "color", "oak": "depth", "pads": "pads"}


@pytest.fixture(params=sorted(PEOPLE))
def fixture(request: pytest.FixtureRequest) -> Path:
    return FIXTURES / str(request.param)


def test_fixtures_are_there_and_small() -> None:
    for name in PEOPLE:
        path = FIXTURES / name
        assert path.is_file(), f"{path}: missing (run `make fixtures`)"
        assert path.stat().st_size < 1_000_000


@pytest.mark.parametrize("channel", sorted(CHANNELS))
def test_every_channel_replays_and_passes_the_sensor_contract(fixture: Path, channel: str) -> None:
    check_sensor(lambda clock: Replay(fixture, clock, channel=channel), duration=6.6, step=0.05)


def test_channels_metadata_and_times(fixture: Path) -> None:
    info = describe_recording(fixture)
    kinds = {c.topic: c.kind for c in info.channels}
    assert kinds == {"webcam": "color", "oak/calibration": "calibration", "oak": "depth", "pads": "pads",
                     "truth": "other"}
    counts = {c.topic: c.message_count for c in info.channels}
    assert counts == {"webcam": 65, "oak/calibration": 65, "oak": 65, "pads": 650, "truth": 65}
    truth = read_truth(fixture)
    webcam = list(iter_frames(fixture, "webcam"))
    oak = list(iter_frames(fixture, "oak"))
    assert [round(f.t * 1e9) for f in truth] == [round(f.t * 1e9) for f in oak] == [round(f.t * 1e9) for f in webcam]
    cameras = read_cameras(fixture)
    depth = oak[0].payload
    assert isinstance(depth, DepthImage) and depth.color is None and depth.size == (160, 100)
    k = cameras["oak"].intrinsics
    assert (depth.fx, depth.fy, depth.cx, depth.cy) == (k[0, 0], k[1, 1], k[0, 2], k[1, 2])
    assert isinstance(webcam[0].payload, ColorImage) and webcam[0].payload.size == (160, 120)
    assert read_pad_layout(fixture) == default_pad_layout()
    calibration = Calibration.load(fixture.with_suffix(".calibration.toml"))
    # floats from another machine: a tolerance, never bit for bit (entries that are zero to round-off
    # are written as 0 and differ in their last bits between CPUs; tests/README.md)
    np.testing.assert_allclose(calibration.matrix, cameras["webcam"].plane_homography(), rtol=1e-9, atol=1e-12)


def test_truth_keeps_each_persons_id_size_and_path(fixture: Path) -> None:
    truth = read_truth(fixture)
    n = PEOPLE[fixture.name]
    sizes = {p.size for p in truth[0].people}
    assert len(sizes) == n and all(0.8 <= s <= 1.1 for s in sizes)
    for frame in truth:
        assert [p.id for p in frame.people] == list(range(n))
        assert {p.size for p in frame.people} == sizes
        assert all(p.mass_kg == pytest.approx(70.0 * p.size**2, rel=1e-3) for p in frame.people)
    assert not any(p.present for p in truth[0].people)  # the empty stage first
    root = HUMANOID.names.index("root")
    for a, b in zip(truth, truth[1:], strict=False):  # no id ever jumps to another body (lanes: 0.6 m apart)
        for pa, pb in zip(a.people, b.people, strict=True):
            if pa.present and pb.present:
                moved = pb.joints[root] - pa.joints[root]
                expected = (pa.velocities[root] + pb.velocities[root]) / 2 * (b.t - a.t)
                assert np.linalg.norm(moved - expected) < 0.1, (b.t, pa.id)  # (starting to walk after a punch: 0.07)
    both = [f for f in truth if f.people[0].present and f.people[1].present]
    gap = np.array([f.people[0].joint("root")[0] - f.people[1].joint("root")[0] for f in both])
    assert np.count_nonzero(np.diff(np.sign(gap))) == 1  # persons 0 and 1 walk past each other


def _agreement(oak: list[Frame], truth: list[TruthFrame], shift: int, path: Path) -> float:
    """The fraction of visible joints that have a depth pixel near them (3×3) between 0.25 m in
    front of the joint and 0.1 m behind it, with the truth shifted by ``shift`` frames."""
    cam = read_cameras(path)["oak"]
    ok = n = 0
    for i, frame in enumerate(oak):
        if not 0 <= i + shift < len(truth):
            continue
        assert isinstance(frame.payload, DepthImage)
        depth = frame.payload.depth_mm / 1000.0
        for person in truth[i + shift].people:
            if not person.present:
                continue
            along = cam.to_camera(person.joints)[:, 2]
            for b, (u, v) in enumerate(np.rint(cam.project(person.joints)).astype(int)):
                if 1 <= u < cam.width - 1 and 1 <= v < cam.height - 1:
                    window = depth[v - 1 : v + 2, u - 1 : u + 2]
                    ok += bool(np.any((window > along[b] - 0.25) & (window < along[b] + 0.1)))
                    n += 1
    assert n > 500
    return ok / n


def test_truth_agrees_with_the_depth_pixels(fixture: Path) -> None:
    oak = list(iter_frames(fixture, "oak"))
    truth = read_truth(fixture)
    assert _agreement(oak, truth, 0, fixture) > 0.88
    assert _agreement(oak, truth, 1, fixture) < 0.8  # one frame off (0.1 s) already shows


def test_pads_read_the_true_forces(fixture: Path) -> None:
    layout = read_pad_layout(fixture)
    truth = {round(f.t * 1e9): f for f in read_truth(fixture)}
    noise = layout.board.noise_counts * layout.board.newtons_per_count
    compared = loaded = 0
    for frame in iter_frames(fixture, "pads"):
        at = truth.get(round(frame.t * 1e9))
        if at is None:
            continue
        assert isinstance(frame.payload, PadSample)
        np.testing.assert_allclose(frame.payload.newtons, at.pads, atol=6 * noise + layout.board.newtons_per_count)
        compared += 1
        for pad, force in zip(layout.pads, at.pads, strict=True):
            if force > 50.0:  # someone's foot is down on it
                feet = [p.joint(f"{side}_{part}") for p in at.people if p.present
                        for side in ("left", "right") for part in ("ankle", "toe")]
                assert any(abs(f[0] - pad.x) < pad.width / 2 + 0.15 and abs(f[1] - pad.y) < pad.depth / 2 + 0.15
                           and f[2] < 0.2 for f in feet)
                loaded += 1
    assert compared == 65 and loaded > 10


def _assert_same_recording(built: Path, committed: Path) -> None:
    """Equal frame for frame, up to the last bit of floating point: a machine with other SIMD paths
    (numpy's exp and sin, OpenCV's blur, libjpeg) may round a few values the other way. Here, where
    the fixtures were made, they are bit-exact."""
    for channel in CHANNELS:
        a, b = list(iter_frames(built, channel)), list(iter_frames(committed, channel))
        assert [(f.t, f.seq) for f in a] == [(f.t, f.seq) for f in b], channel
        exact = sum(frame_digest(x) == frame_digest(y) for x, y in zip(a, b, strict=True))
        for x, y in zip(a, b, strict=True):
            p, q = x.payload, y.payload
            if isinstance(p, ColorImage) and isinstance(q, ColorImage):
                assert np.abs(p.bgr.astype(int) - q.bgr.astype(int)).mean() < 0.5
            elif isinstance(p, DepthImage) and isinstance(q, DepthImage):
                np.testing.assert_allclose((p.fx, p.fy, p.cx, p.cy), (q.fx, q.fy, q.cx, q.cy), rtol=1e-12)
                assert np.mean(p.depth_mm != q.depth_mm) < 0.002
            elif isinstance(p, PadSample) and isinstance(q, PadSample):
                np.testing.assert_allclose(p.newtons, q.newtons, atol=0.26)
            else:
                raise AssertionError(f"{channel}: payloads of different kinds")
        assert exact >= 0.9 * len(a), channel
    for tx, ty in zip(read_truth(built), read_truth(committed), strict=True):
        assert tx.t == ty.t and len(tx.people) == len(ty.people)
        for px, py in zip(tx.people, ty.people, strict=True):
            assert (px.id, px.size, px.present) == (py.id, py.size, py.present)
            np.testing.assert_allclose(px.joints, py.joints, atol=2e-6)
        np.testing.assert_allclose(tx.pads, ty.pads, atol=1e-3)


def test_the_committed_fixture_is_what_the_command_builds(fixture: Path, tmp_path: Path) -> None:
    args = json.loads(describe_recording(fixture).metadata["synth.args"])
    out = tmp_path / fixture.name
    assert main(["synth", "performer", *args, "--out", str(out)]) == 0
    _assert_same_recording(out, fixture)
    built = Calibration.load(out.with_suffix(".calibration.toml"))
    committed = Calibration.load(fixture.with_suffix(".calibration.toml")).matrix
    np.testing.assert_allclose(built.matrix, committed, rtol=1e-9, atol=1e-12)


# ---------------------------------------------------------------- the truth channel's writer and reader


def test_json_channels_sit_beside_the_sensors(tmp_path: Path) -> None:
    path = tmp_path / "mixed.mcap"
    body = {"people": [{"id": 0, "size": 1.0, "mass_kg": 70.0, "present": False, "joints": {}, "velocities": {}}]}
    with RecordingWriter(path) as writer:
        writer.write(Frame("pads", 0.0, 0, PadSample((1.0,), (4,))))
        writer.write_json("truth", TRUTH_SCHEMA_NAME, TRUTH_SCHEMA, 0.0, body)
        writer.write_json("truth", TRUTH_SCHEMA_NAME, TRUTH_SCHEMA, 0.5, body)
        with pytest.raises(ValueError, match="time went back"):
            writer.write_json("truth", TRUTH_SCHEMA_NAME, TRUTH_SCHEMA, 0.25, body)
        with pytest.raises(ValueError, match="already a sensor's channel"):
            writer.write_json("pads", TRUTH_SCHEMA_NAME, TRUTH_SCHEMA, 1.0, body)
        with pytest.raises(ValueError, match="channel 'truth' already holds"):
            writer.write(Frame("truth", 1.0, 0, PadSample((1.0,), (4,))))
        with pytest.raises(ValueError):
            writer.write_json("truth", TRUTH_SCHEMA_NAME, TRUTH_SCHEMA, 1.0, {"people": [], "x": float("nan")})
    info = describe_recording(path)
    assert [(c.topic, c.kind, c.message_count) for c in info.channels] == [("pads", "pads", 1), ("truth", "other", 2)]
    with Replay(path, SimClock()) as replay:  # the only sensor channel, the truth left aside
        assert replay.spec.name == "pads" and replay.read(0.0) is not None
    frames = read_truth(path)
    assert [(f.t, f.seq, len(f.people), f.people[0].present) for f in frames] == [(0.0, 0, 1, False), (0.5, 1, 1, False)]
    assert frames[0].people[0].joints.shape == (0, 3)


def test_reading_truth_refuses_what_is_not_there(tmp_path: Path) -> None:
    plain = tmp_path / "plain.mcap"
    with RecordingWriter(plain) as writer:
        writer.write(Frame("pads", 0.0, 0, PadSample((1.0,), (4,))))
    with pytest.raises(RecordingCorrupt, match=r"plain\.mcap: truth channel: not in the recording"):
        read_truth(plain)
    with pytest.raises(RecordingCorrupt, match="synth.cameras"):
        read_cameras(plain)
    odd = tmp_path / "odd.mcap"
    with RecordingWriter(odd) as writer:
        writer.write_json("truth", TRUTH_SCHEMA_NAME, TRUTH_SCHEMA, 0.0,
                          {"people": [{"id": 0, "size": 1.0, "mass_kg": 70.0, "present": True,
                                       "joints": {"root": [0, 0]}, "velocities": {}}]})
    with pytest.raises(RecordingCorrupt, match=r"joints\.root: expected \[x, y, z\]"):
        read_truth(odd)


def test_command_line_mistakes_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / "x.mcap")
    cases = [
        (["--sensors", "webcam,lidar"], "--sensors: expected"),
        (["--depth-size", "160x100"], "the OAK is not recorded"),
        (["--sensors", "oak", "--depth-size", "160by100"], "--depth-size: expected WIDTHxHEIGHT"),
        (["--people", "5"], "people: expected a whole number 1..4"),
        (["--people", "2", "--route", "round"], "route: 'round' is one person's walk"),
        (["--sizes", "0.9,big"], "--sizes: expected numbers"),
        (["--sensors", "pads", "--pads", str(tmp_path / "none.toml")], "cannot read the pad layout"),
    ]
    for extra, message in cases:
        assert main(["synth", "performer", "--duration", "0.2", *extra, "--out", out]) == 2
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "x.mcap").exists()
