"""Virtual force pads under the virtual people: they fire when a foot is on them, carry a share of
the body's weight, and a hand coming down gives a short impulse."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from jostle.configtree import ConfigError
from jostle.performer.choreography import stage_joint_positions
from jostle.performer.config import PerformerConfig
from jostle.performer.pads import (
    GRAVITY,
    HandStrikes,
    PadBoardConfig,
    PadLayout,
    PadPlacement,
    PerformerPads,
    contact_points,
    default_pad_layout,
    grid_pad_forces,
    load_pad_layout,
)
from jostle.performer.scene import Performance
from sensors.base import Frame, PadSample, frame_digest
from sensors.clock import SimClock
from sim.motion.mocap import HUMANOID

_RIGHT_WRIST = HUMANOID.names.index("right_wrist")
CROSS = PerformerConfig(people=2, route="crossing", duration_s=6.0, empty_s=1.0, fps=5.0, width=96, height=72)


def _record(config: PerformerConfig, layout: PadLayout) -> tuple[Performance, list[Frame]]:
    performance = Performance(config)
    clock = SimClock()
    sensor = PerformerPads(performance, layout, clock)
    with sensor:
        clock.advance(config.duration_s)
        frames = []
        while (frame := sensor.read(0.0)) is not None:
            frames.append(frame)
    return performance, frames


def _newtons(frames: list[Frame]) -> np.ndarray:
    out = []
    for f in frames:
        assert isinstance(f.payload, PadSample)
        out.append(f.payload.newtons)
    return np.array(out)


@pytest.fixture(scope="module")
def crossing() -> tuple[Performance, list[Frame]]:
    return _record(CROSS, default_pad_layout())


def test_layout_file_is_read_strictly(tmp_path: Path) -> None:
    good = tmp_path / "pads.toml"
    good.write_text("rate_hz = 200.0\nnewtons_per_count = 0.5\n\n[[pad]]\nx = -1.0\ny = 0.2\n\n"
                    "[[pad]]\nx = 1.0\ny = -0.2\nwidth = 0.4\ndepth = 0.3\n", encoding="utf-8")
    layout = load_pad_layout(good)
    assert layout.board == PadBoardConfig(rate_hz=200.0, newtons_per_count=0.5)
    assert layout.pads == (PadPlacement(-1.0, 0.2), PadPlacement(1.0, -0.2, 0.4, 0.3))
    cases = {
        "[[pad]]\nx = 0.0\ny = 0.0\nheight = 1.0\n": "pad[0].height: unknown key",
        "rate_hz = -5.0\n[[pad]]\nx = 0.0\ny = 0.0\n": "rate_hz: expected",
        "[[pad]]\nx = 0.0\ny = 0.0\nwidth = 0.0\n": "pad[0].width: expected",
        "[[pad]]\nx = 'left'\ny = 0.0\n": "pad[0].x: expected a number",
        "rate_hz = 100.0\n": "pad: expected one or more",
        "[[pad]\n": "not valid TOML",
    }
    for i, (text, message) in enumerate(cases.items()):
        bad = tmp_path / f"bad{i}.toml"
        bad.write_text(text, encoding="utf-8")
        with pytest.raises(ConfigError, match=f"^{re.escape(str(bad))}: .*{re.escape(message)}"):
            load_pad_layout(bad)
    with pytest.raises(ConfigError, match="cannot read"):
        load_pad_layout(tmp_path / "missing.toml")


def test_passes_the_shared_sensor_check() -> None:
    from sensors.testing import check_sensor

    config = dataclasses.replace(CROSS, duration_s=0.3)
    check_sensor(lambda clock: PerformerPads(Performance(config), default_pad_layout(), clock), duration=0.5, step=0.02)


def test_counts_carry_the_noise_and_newtons_come_from_them() -> None:
    layout = PadLayout(PadBoardConfig(rate_hz=200.0, newtons_per_count=0.25, noise_counts=2.0, zero_counts=512),
                       default_pad_layout().pads)
    _, frames = _record(dataclasses.replace(CROSS, duration_s=1.0), layout)  # the empty stage: no load
    raw = np.array([f.payload.raw for f in frames if isinstance(f.payload, PadSample)])
    newtons = _newtons(frames)
    assert raw.shape == (200, 6)
    np.testing.assert_array_equal(newtons, (raw - 512) * 0.25)
    assert abs(raw.mean() - 512) < 0.3 and raw.std() == pytest.approx(2.0, rel=0.1)


def _feet(performance: Performance, times: np.ndarray) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """At each time: the (ankle, toe) stage positions of every foot on the stage (ground truth)."""
    ankles = [HUMANOID.names.index(f"{side}_ankle") for side in ("left", "right")]
    toes = [HUMANOID.names.index(f"{side}_toe") for side in ("left", "right")]
    out: list[list[tuple[np.ndarray, np.ndarray]]] = [[] for _ in times]
    for person in performance.cast:
        poses = [person.path.pose(float(t)) for t in times]
        on = [i for i, pose in enumerate(poses) if pose is not None]
        joints = stage_joint_positions([pose for pose in poses if pose is not None])
        for row, i in enumerate(on):
            out[i] += [(joints[row, a], joints[row, t]) for a, t in zip(ankles, toes, strict=True)]
    return out


def _inside(pad: PadPlacement, xy: np.ndarray, margin: float) -> bool:
    return abs(xy[0] - pad.x) <= pad.width / 2 + margin and abs(xy[1] - pad.y) <= pad.depth / 2 + margin


def test_pads_fire_exactly_when_a_foot_is_on_them(crossing: tuple[Performance, list[Frame]]) -> None:
    performance, frames = crossing
    newtons = _newtons(frames)
    layout = default_pad_layout()
    sizes = {s.id: s.size for s in performance.people_at(3.0)}
    noise = layout.board.noise_counts * layout.board.newtons_per_count
    on = off = 0
    all_feet = _feet(performance, np.array([f.t for f in frames]))
    for frame, forces, feet in zip(frames, newtons, all_feet, strict=True):
        for pad, force in zip(layout.pads, forces, strict=True):
            flat_on = any(_inside(pad, a, -0.05) and _inside(pad, t, -0.05) and a[2] < 0.07 and t[2] < 0.045
                          for a, t in feet)
            near = [(a, t) for a, t in feet if _inside(pad, a, 0.2) or _inside(pad, t, 0.2)]
            lifted = all(a[2] > 0.2 and t[2] > 0.11 for a, t in near)
            if flat_on:  # a flat foot on the pad carries a good share of someone's weight
                assert force > 0.15 * 45.0 * GRAVITY, (frame.t, pad)
                on += 1
            elif lifted:  # no foot on it or near it, or every foot near it is in the air
                assert abs(force) < 5 * noise, (frame.t, pad, force)
                off += 1
            if force > 20.0:  # and whatever it reads, a foot is there, down
                assert any(_inside(pad, a, 0.15) or _inside(pad, t, 0.15) for a, t in feet), (frame.t, pad)
    assert on > 100 and off > 1000
    assert len(set(sizes.values())) == 2


def test_force_is_the_body_weight_shared_among_the_feet(crossing: tuple[Performance, list[Frame]]) -> None:
    """Two pads as big as each person's lane: each reads that person's weight m·g on average (the
    body's up-and-down accelerations average out over the steps), more on landing, less on push-off."""
    performance, _ = crossing
    lanes = {p.plan.id: p.plan.start_xy[1] for p in performance.cast}
    layout = PadLayout(PadBoardConfig(rate_hz=50.0, noise_counts=0.0, newtons_per_count=0.01),
                       tuple(PadPlacement(0.0, lanes[i], 10.0, 0.55) for i in (0, 1)))
    _, frames = _record(CROSS, layout)
    newtons = _newtons(frames)
    times = np.array([f.t for f in frames])
    for i in (0, 1):
        present = np.array([performance.cast[i].path.pose(float(t)) is not None for t in times])
        weight = performance.cast[i].plan.mass_kg * GRAVITY
        walking = newtons[present, i]
        assert walking.mean() == pytest.approx(weight, rel=0.03)
        assert 0.6 * weight < walking.min() and walking.max() < 1.7 * weight  # brisk walking: up to ~1.5
        assert walking.max() > 1.1 * weight and walking.min() < 0.9 * weight
        assert np.all(newtons[~present, i] == 0)


def test_a_hand_coming_down_strikes_with_an_impulse() -> None:
    """The performer falls onto the hands (getup_facedown after walking): the pad under the right hand
    sees a sharp peak within the first 30 ms, then the hand's steadier share of the weight; the
    peak's extra is a half-sine whose area is the hand's momentum m_hand·v (m_hand = 2 kg)."""
    config = PerformerConfig(clips=("walk", "getup_facedown"), duration_s=6.0, fps=5.0, width=96, height=72)
    performance = Performance(config)
    path = performance.cast[0].path
    times = np.arange(4.0, 6.0, 0.002)
    wrist = stage_joint_positions([p for t in times if (p := path.pose(float(t))) is not None])[:, _RIGHT_WRIST]
    assert len(wrist) == len(times)
    landing = int(np.argmax(wrist[:, 2] < 0.085))  # the hand (6 cm around the wrist) reaches the floor
    assert wrist[landing, 2] < 0.085 and wrist[landing - 5, 2] > 0.09
    speed = -(wrist[landing, 2] - wrist[landing - 2, 2]) / 0.004
    assert speed > 0.5
    x, y = wrist[landing, :2]
    layout = PadLayout(PadBoardConfig(rate_hz=1000.0), (PadPlacement(float(x), float(y), 0.16, 0.16),))
    t = times[landing] - 0.1 + np.arange(300) * 0.001
    force = grid_pad_forces(performance, layout, float(t[0]), 0.001, 300)[:, 0]
    start = int(np.argmax(force > 1.0))
    assert abs(t[start] - times[landing]) < 0.01
    peak = start + int(np.argmax(force[start : start + 40]))
    assert t[peak] - t[start] < 0.03
    assert force[peak] > 1.5 * float(np.median(force[start + 40 : start + 140]))
    grid = [float(v) for v in np.arange(t[start] - 0.06, t[start] + 0.06, 0.001)]
    heights = contact_points([pose for g in grid if (pose := path.pose(g)) is not None])[1]
    strikes = HandStrikes(path, grid, heights)
    extra = np.array([strikes.force(e, 6) if heights[e, 6] < 0.025 else 0.0 for e in range(len(grid))])
    assert np.count_nonzero(extra) in (29, 30, 31)  # 30 ms
    assert float(extra.sum()) * 0.001 == pytest.approx(2.0 * speed, rel=0.15)


def test_same_seed_same_samples(crossing: tuple[Performance, list[Frame]]) -> None:
    _, frames = crossing
    _, again = _record(CROSS, default_pad_layout())
    _, other = _record(dataclasses.replace(CROSS, seed=5), default_pad_layout())
    assert [frame_digest(f) for f in again] == [frame_digest(f) for f in frames]
    assert [frame_digest(f) for f in other] != [frame_digest(f) for f in frames]
