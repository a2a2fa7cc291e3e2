"""The pads observer on real pad frames: half-sine hits with noise, a chattering push, a pure-noise
stage, and one hit sent as CSV bytes through a pseudo-terminal into the real pads driver.

A half-sine hit of peak A newtons lasting T seconds carries the impulse 2AT/π exactly; the samples
are drawn from that formula, so the expected sizes are derived, not guessed.
"""

from __future__ import annotations

import math
import os
import pty
import time
import tty

import numpy as np
import pytest

from interaction.pads import PadsObserver, PadsObserverConfig
from interaction.types import Impulse
from sensors.base import ColorImage, Frame, PadSample
from sensors.clock import WallClock
from sensors.pads.config import PadsConfig
from sensors.pads.driver import PadsSensor
from sensors.pads.protocol import encode_csv

TWO_PADS = PadsObserverConfig(
    positions=(-1.0, 0.0, 1.2, 1.5, 0.2, 0.9),
    directions=(0.0, 2.0, 0.0, -1.0, 1.0, 0.0),
)


def half_sine(t: np.ndarray, start: float, peak: float, length: float) -> np.ndarray:
    u = (t - start) / length
    return np.where((u >= 0) & (u <= 1), peak * np.sin(np.pi * np.clip(u, 0, 1)), 0.0)


def frames(forces: np.ndarray, rate: float, t0: float = 0.0, sensor: str = "pads") -> list[Frame]:
    """Frames of PadSample, one per row of ``forces`` (samples × pads)."""
    return [
        Frame(sensor, t0 + k / rate, k, PadSample(tuple(float(f) for f in row), tuple(int(f) for f in row)))
        for k, row in enumerate(forces)
    ]


def run(observer: PadsObserver, fs: list[Frame]) -> list[tuple[float, Impulse]]:
    out = []
    for f in fs:
        for imp in observer.observe(f).impulses:
            out.append((f.t, imp))
    return out


@pytest.mark.parametrize("emit", ["peak", "release"])
@pytest.mark.parametrize("rate", [80.0, 500.0])
def test_one_hit_is_exactly_one_impulse_of_the_right_size(emit: str, rate: float) -> None:
    peak, length, start = 300.0, 0.12, 0.5
    t = np.arange(0, 1.5, 1 / rate)
    rng = np.random.default_rng(1)
    f = np.zeros((len(t), 2))
    f[:, 1] = half_sine(t, start, peak, length) + rng.normal(0, 3.0, len(t))
    f[:, 0] = rng.normal(0, 3.0, len(t))
    obs = PadsObserver(PadsObserverConfig(TWO_PADS.positions, TWO_PADS.directions, emit=emit))  # type: ignore[arg-type]
    got = run(obs, frames(f, rate))
    assert len(got) == 1
    t_sent, imp = got[0]
    true_j = 2 * peak * length / math.pi
    size = math.hypot(*imp.force)
    tol = 0.06 if rate == 80.0 else 0.03  # 80 Hz: a 120 ms hit is ten samples
    assert size * imp.duration == pytest.approx(true_j, rel=tol)
    assert size == pytest.approx(peak, rel=tol)
    assert imp.source == "pads:1"
    assert imp.position == (1.5, 0.2, 0.9)
    d = np.array(imp.force) / size
    assert d == pytest.approx([-1 / math.sqrt(2), 1 / math.sqrt(2), 0.0])
    if emit == "peak":  # as soon as the peak is known: a few samples after it, long before the end
        assert start + length / 2 <= t_sent <= start + length / 2 + 3 / rate + 0.02
    else:
        assert start + length - 2 / rate <= t_sent <= start + length + 2 / rate
    (hit,) = obs.hits
    assert hit.impulse_ns == pytest.approx(true_j, rel=tol)
    assert hit.t_onset < hit.t_peak < hit.t_release


def test_a_push_that_chatters_across_the_onset_is_still_one_hit() -> None:
    """A slow push hovering around the onset threshold (noise ±15 N) is one impulse, not several."""
    rate = 200.0
    t = np.arange(0, 3.0, 1 / rate)
    rng = np.random.default_rng(2)
    cfg = PadsObserverConfig((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), onset_n=40.0, release_n=20.0)
    plateau = np.where((t > 0.5) & (t < 2.0), 42.0, 0.0)
    f = (plateau + rng.uniform(-15, 15, len(t)))[:, None]
    got = run(PadsObserver(cfg), frames(f, rate))
    assert len(got) == 1
    assert got[0][1].duration <= cfg.max_duration_s


def test_noise_alone_gives_no_impulse() -> None:
    """Ten seconds of sensor noise, drift and small knocks below the onset: nothing."""
    rate = 80.0
    t = np.arange(0, 10.0, 1 / rate)
    rng = np.random.default_rng(3)
    f = rng.uniform(-10.0, 10.0, (len(t), 2)) + 8.0 * np.sin(t / 3.0)[:, None]
    f[::37] += 15.0  # knocks: everything stays below the 40 N onset, but crosses the 20 N release
    obs = PadsObserver(TWO_PADS)
    assert run(obs, frames(f, rate)) == []
    assert obs.hits == []


def test_separate_hits_on_both_pads_each_give_one_impulse() -> None:
    rate = 200.0
    t = np.arange(0, 2.0, 1 / rate)
    f = np.zeros((len(t), 2))
    f[:, 0] = half_sine(t, 0.2, 200.0, 0.08) + half_sine(t, 1.0, 500.0, 0.1)
    f[:, 1] = half_sine(t, 0.6, 150.0, 0.2)
    got = run(PadsObserver(TWO_PADS), frames(f, rate))
    assert [imp.source for _, imp in got] == ["pads:0", "pads:1", "pads:0"]
    sizes = [math.hypot(*imp.force) for _, imp in got]
    assert sizes == pytest.approx([200.0, 150.0, 500.0], rel=0.03)
    assert got[0][1].force[1] > 0 and got[0][1].position == (-1.0, 0.0, 1.2)


def test_rearm_time_keeps_a_bounce_from_counting_twice() -> None:
    rate = 500.0
    t = np.arange(0, 1.0, 1 / rate)
    f = (half_sine(t, 0.2, 300.0, 0.05) + half_sine(t, 0.255, 120.0, 0.03))[:, None]  # rebound 5 ms later
    cfg = PadsObserverConfig((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), rearm_s=0.05)
    assert len(run(PadsObserver(cfg), frames(f, rate))) == 1
    cfg0 = PadsObserverConfig((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), rearm_s=0.0)
    assert len(run(PadsObserver(cfg0), frames(f, rate))) == 2


def test_wrong_frames_are_refused_with_a_clear_message() -> None:
    obs = PadsObserver(TWO_PADS)
    with pytest.raises(ValueError, match="has 3 pads, but the observer's positions name 2"):
        obs.observe(Frame("pads", 0.0, 0, PadSample((1.0, 2.0, 3.0), (1, 2, 3))))
    with pytest.raises(ValueError, match="expected pad samples"):
        obs.observe(Frame("cam", 0.0, 0, ColorImage(np.zeros((4, 4, 3), np.uint8))))


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"positions": (0.0, 1.0)}, "positions"),
        ({"directions": (0.0, 0.0, 0.0, 0.0, 1.0, 0.0)}, "directions"),
        ({"directions": (0.0, 1.0, 0.0)}, "directions"),
        ({"release_n": 50.0}, "release_n"),
        ({"onset_n": -1.0}, "onset_n"),
        ({"peak_drop": 1.0}, "peak_drop"),
        ({"emit": "later"}, "emit"),
        ({"sample_rate_hz": -5.0}, "sample_rate_hz"),
    ],
)
def test_config_errors_name_the_field(changes: dict[str, object], field: str) -> None:
    kwargs: dict[str, object] = {"positions": TWO_PADS.positions, "directions": TWO_PADS.directions, **changes}
    with pytest.raises(ValueError, match=f"^{field}: "):
        PadsObserverConfig(**kwargs)  # type: ignore[arg-type]


def test_a_hit_through_the_real_driver_on_a_pty() -> None:
    """CSV lines written to a pseudo-terminal in one burst → PadsSensor (tare, scale) → the observer,
    timing the samples by their sequence numbers: one impulse of the hit's size."""
    master, slave = pty.openpty()
    tty.setraw(slave)
    rate, scale, zero = 100.0, 0.5, 1000
    cfg = PadsConfig(port=os.ttyname(slave), framing="csv", pads=1, newtons_per_count=(scale,),
                     tare_samples=10, rate_hz=rate)
    t = np.arange(0, 1.0, 1 / rate)
    newtons = half_sine(t, 0.4, 250.0, 0.15)
    counts = np.round(zero + newtons / scale).astype(int)
    obs = PadsObserver(PadsObserverConfig((0.5, 0.0, 1.0), (1.0, 0.0, 0.0), sample_rate_hz=rate))
    got: list[Impulse] = []
    try:
        with PadsSensor(cfg, WallClock(), "pads") as sensor:
            lines = [encode_csv(k, [zero]) for k in range(10)]
            lines += [encode_csv(10 + k, [int(c)]) for k, c in enumerate(counts)]
            seen, end = 0, time.monotonic() + 5.0
            for k in range(0, len(lines), 8):  # bursts of 8 samples: arrival times say nothing of timing
                os.write(master, b"".join(lines[k:k + 8]))
                while seen < min(len(counts), k + 8 - 10) and time.monotonic() < end:
                    frame = sensor.read(0.05)
                    if frame is not None:
                        seen += 1
                        got.extend(obs.observe(frame).impulses)
    finally:
        os.close(master)
        os.close(slave)
    assert seen == len(counts)
    assert len(got) == 1
    j = 2 * 250.0 * 0.15 / math.pi
    assert got[0].force[0] * got[0].duration == pytest.approx(j, rel=0.05)
    assert got[0].source == "pads:0"


def test_built_from_a_config_table() -> None:
    """The config builder of jostle/ makes it from TOML values (flat lists), and names bad keys."""
    from pathlib import Path

    from jostle.configtree import ConfigError, build

    table = {"positions": [-1.0, 0.0, 1.2, 1, 0, 1.2], "directions": [0, 1, 0, 0, 1, 0], "emit": "release",
             "sample_rate_hz": 80}
    cfg = build(PadsObserverConfig, table, source="x.toml", key="observers.pads", base_dir=Path("."))
    assert cfg.pads == 2 and cfg.emit == "release" and cfg.position(1) == (1.0, 0.0, 1.2)
    with pytest.raises(ConfigError, match=r"^x.toml: observers.pads.release_n: expected newtons"):
        build(PadsObserverConfig, {**table, "release_n": 100.0}, source="x.toml", key="observers.pads",
              base_dir=Path("."))
