"""The pads observer: calibrated pad forces → one :class:`Impulse` per hit.

A hit on a pad is an **onset** (the force rises to ``onset_n``), a **peak** and a **release** (the
force falls below ``release_n`` < ``onset_n``: hysteresis, so noise around one threshold cannot
split a hit or start a new one). A pad is re-armed only after its release and ``rearm_s`` of rest.

When the impulse leaves (``emit``):
- ``"peak"`` (default): as soon as the peak is known — the force has fallen ``peak_drop`` (a
  fraction) below the highest value so far, or the hit was released. Latency is the rise time plus
  about one sample, which is what a shove needs. The size is estimated assuming the pulse falls as
  it rose: impulse J ≈ 2 × ∫ F dt from the onset to the peak, the peak's time found between the
  samples by a parabola through the highest sample and its two neighbours.
- ``"release"``: at the release, with the whole pulse measured (J = ∫ F dt, trapezoids over the
  samples, the ramp from and back to the last sample below ``release_n`` included). Exact, but late
  by the whole contact time.

Either way the impulse carries the peak force (newtons) along the pad's direction and the duration
J / peak (seconds), so force × duration is the hit's impulse; each pad is mapped in the config to a
stage position (the sim pushes the character nearest to it) and a push direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from interaction.types import BodyObservation, Impulse, Vec3
from sensors.base import Frame, PadSample

__all__ = ["HitRecord", "PadsObserver", "PadsObserverConfig"]

EmitAt = Literal["peak", "release"]


@dataclass(frozen=True)
class PadsObserverConfig:
    """Where each pad is and how hits on it are found.

    ``positions``: x, y, z stage metres of every pad, flattened (3 numbers per pad, pad 0 first).
    ``directions``: the push of every pad, flattened (3 numbers per pad; normalised here), e.g.
    ``[0, 1, 0]`` pushes into the screen. ``onset_n`` / ``release_n``: the hysteresis thresholds in
    calibrated newtons. ``peak_drop``: the fraction below the highest force that declares the peak.
    ``rearm_s``: rest after a release before the pad can start another hit. ``max_duration_s``: the
    longest duration an impulse may carry (a lean on a pad is not a hit forever).
    ``sample_rate_hz``: the board's sampling rate, to time the samples by their sequence numbers
    (``seq / rate``: immune to samples arriving in bursts over USB); 0 times them by ``frame.t``.
    """

    positions: tuple[float, ...]
    directions: tuple[float, ...]
    onset_n: float = 40.0
    release_n: float = 20.0
    peak_drop: float = 0.15
    rearm_s: float = 0.05
    emit: EmitAt = "peak"
    max_duration_s: float = 0.5
    sample_rate_hz: float = 0.0

    def __post_init__(self) -> None:
        for name in ("positions", "directions"):
            v = getattr(self, name)
            if not (isinstance(v, tuple) and len(v) >= 3 and len(v) % 3 == 0 and all(_finite(x) for x in v)):
                raise ValueError(f"{name}: expected 3 numbers (x, y, z) per pad, got {v!r}")
        if len(self.positions) != len(self.directions):
            raise ValueError(f"directions: expected 3 numbers for each of the {self.pads} pads, "
                             f"got {len(self.directions)} numbers")
        for i in range(len(self.directions) // 3):
            if math.hypot(*self.directions[3 * i: 3 * i + 3]) < 1e-9:
                raise ValueError(f"directions: pad {i} has a zero direction; expected a vector like [0, 1, 0]")
        if not (_finite(self.onset_n) and self.onset_n > 0):
            raise ValueError(f"onset_n: expected newtons > 0, got {self.onset_n!r}")
        if not (_finite(self.release_n) and 0 <= self.release_n < self.onset_n):
            raise ValueError(f"release_n: expected newtons ≥ 0 and below onset_n ({self.onset_n}), got {self.release_n!r}")
        if not (_finite(self.peak_drop) and 0 < self.peak_drop < 1):
            raise ValueError(f"peak_drop: expected a fraction between 0 and 1, got {self.peak_drop!r}")
        if not (_finite(self.rearm_s) and self.rearm_s >= 0):
            raise ValueError(f"rearm_s: expected seconds ≥ 0, got {self.rearm_s!r}")
        if self.emit not in ("peak", "release"):
            raise ValueError(f"emit: expected 'peak' or 'release', got {self.emit!r}")
        if not (_finite(self.max_duration_s) and self.max_duration_s > 0):
            raise ValueError(f"max_duration_s: expected seconds > 0, got {self.max_duration_s!r}")
        if not (_finite(self.sample_rate_hz) and 0 <= self.sample_rate_hz <= 100000):
            raise ValueError(f"sample_rate_hz: expected 0 (use the frames' times) or the board's rate in Hz, "
                             f"got {self.sample_rate_hz!r}")

    @property
    def pads(self) -> int:
        return len(self.positions) // 3

    def position(self, pad: int) -> Vec3:
        p = self.positions[3 * pad: 3 * pad + 3]
        return (float(p[0]), float(p[1]), float(p[2]))

    def direction(self, pad: int) -> Vec3:
        d = self.directions[3 * pad: 3 * pad + 3]
        n = math.hypot(*d)
        return (d[0] / n, d[1] / n, d[2] / n)


@dataclass(frozen=True)
class HitRecord:
    """One finished hit on one pad, as measured (for traces and benchmarks). Times are the observer's
    (``frame.t``, or ``seq / sample_rate_hz`` when that is set)."""

    pad: int
    t_onset: float
    t_peak: float
    t_release: float
    peak_n: float
    impulse_ns: float  # ∫ F dt over the whole pulse
    sent_ns: float  # what the emitted impulse carried (force × duration)
    t_sent: float


class _PadState:
    """One pad's hit detector."""

    def __init__(self) -> None:
        self.active = False
        self.sent = False
        self.t_onset = 0.0
        self.t_peak = 0.0
        self.t_sent = 0.0
        self.peak = 0.0
        self.area = 0.0  # ∫ F dt since the last rest sample
        self.area_at_peak = 0.0
        self.before_peak = (0.0, 0.0)  # (dt, force) of the sample before the highest one
        self.after_peak: float | None = None  # the force of the sample after the highest one
        self.sent_ns = 0.0
        self.last_t: float | None = None
        self.last_f = 0.0
        self.rest_since = -math.inf  # when the last hit was released


class PadsObserver:
    """Turns frames of :class:`PadSample` into impulses, one per hit (see the module's notes).

    ``sensor`` names the source in each impulse (``"<sensor>:<pad>"``). :attr:`hits` keeps the
    finished hits (the last ``keep_hits``).
    """

    def __init__(self, config: PadsObserverConfig, sensor: str = "pads", keep_hits: int = 256) -> None:
        self._cfg = config
        self._sensor = sensor
        self._pads = [_PadState() for _ in range(config.pads)]
        self._keep = keep_hits
        self.hits: list[HitRecord] = []

    @property
    def config(self) -> PadsObserverConfig:
        return self._cfg

    def observe(self, frame: Frame) -> BodyObservation:
        """The impulses whose hits reached their emission point in this sample (usually none)."""
        sample = frame.payload
        if not isinstance(sample, PadSample):
            raise ValueError(
                f"PadsObserver: frame {frame.seq} from sensor {frame.sensor!r} carries a {frame.kind} payload; "
                "expected pad samples"
            )
        if len(sample.newtons) != self._cfg.pads:
            raise ValueError(
                f"PadsObserver: frame {frame.seq} from sensor {frame.sensor!r} has {len(sample.newtons)} pads, "
                f"but the observer's positions name {self._cfg.pads}"
            )
        rate = self._cfg.sample_rate_hz
        t = frame.seq / rate if rate > 0 else frame.t
        impulses: list[Impulse] = []
        for i, f in enumerate(sample.newtons):
            imp = self._step(i, t, float(f) if math.isfinite(f) else 0.0)
            if imp is not None:
                impulses.append(imp)
        return BodyObservation(t=frame.t, impulses=tuple(impulses))

    # ------------------------------------------------------------ internals

    def _step(self, i: int, t: float, f: float) -> Impulse | None:
        cfg, s = self._cfg, self._pads[i]
        prev_t, prev_f = s.last_t, s.last_f
        s.last_t, s.last_f = t, f
        dt = t - prev_t if prev_t is not None and t > prev_t else 0.0
        out: Impulse | None = None
        if not s.active:
            if f >= cfg.onset_n and t - s.rest_since >= cfg.rearm_s - 1e-12:
                s.active, s.sent = True, False
                s.t_onset, s.t_peak, s.peak = t, t, f
                s.area = 0.5 * (prev_f + f) * dt if prev_f < cfg.onset_n else 0.0  # the ramp up from rest
                s.area_at_peak, s.before_peak, s.after_peak = s.area, (dt, prev_f), None
            return None
        s.area += 0.5 * (prev_f + f) * dt
        if f > s.peak:
            s.peak, s.t_peak, s.area_at_peak = f, t, s.area
            s.before_peak, s.after_peak = (dt, prev_f), None
        elif s.after_peak is None:
            s.after_peak = f
        released = f < cfg.release_n
        if not s.sent and cfg.emit == "peak" and (released or f <= s.peak * (1.0 - cfg.peak_drop)):
            out = self._emit(i, t, 2.0 * (s.area_at_peak + _past_the_sample(s)))
        if released:
            if not s.sent:  # emit == "release"
                out = self._emit(i, t, s.area)
            s.active, s.rest_since = False, t
            self.hits.append(HitRecord(i, s.t_onset, s.t_peak, t, s.peak, s.area, s.sent_ns, s.t_sent))
            del self.hits[: -self._keep]
        return out

    def _emit(self, i: int, t: float, impulse_ns: float) -> Impulse:
        s, cfg = self._pads[i], self._cfg
        duration = min(max(impulse_ns / s.peak, 1e-3), cfg.max_duration_s)
        d = cfg.direction(i)
        s.sent, s.t_sent, s.sent_ns = True, t, s.peak * duration
        return Impulse(
            position=cfg.position(i),
            force=(s.peak * d[0], s.peak * d[1], s.peak * d[2]),
            duration=duration,
            source=f"{self._sensor}:{i}",
        )


def _past_the_sample(s: _PadState) -> float:
    """∫ F dt from the highest sample to the true peak (negative if the peak came before it): the
    vertex of the parabola through the highest sample and its neighbours, assumed evenly spaced."""
    step, f_before = s.before_peak
    f_after = s.after_peak
    if f_after is None or step <= 0:
        return 0.0
    curve = f_before - 2.0 * s.peak + f_after
    if curve >= 0:
        return 0.0
    offset = min(max(0.5 * (f_before - f_after) / curve, -0.5), 0.5)  # in samples
    return s.peak * offset * step


def _finite(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
