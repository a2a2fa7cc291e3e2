"""Raw counts → newtons: a tare (zero) per pad, a scale per pad, and a deadband.

``newtons[i] = (raw[i] − zero[i]) × newtons_per_count[i]``, then 0 when ``|newtons[i]| <
deadband_n``. The zero is the mean of the first ``tare_samples`` samples (0 when no tare is asked
for). :func:`scale_from_known_load` finds ``newtons_per_count`` from a reading with a known load.
"""

from __future__ import annotations

from collections.abc import Sequence

STANDARD_GRAVITY = 9.80665  # m/s², to turn a known mass into newtons


class PadCalibration:
    """The zero, scale and deadband of every pad of one board (mutable: it learns the zero)."""

    def __init__(self, scales: Sequence[float], tare_samples: int = 0, deadband_n: float = 0.0) -> None:
        if not scales:
            raise ValueError("scales: expected one newtons-per-count value per pad, got none")
        if tare_samples < 0:
            raise ValueError(f"tare_samples: expected a whole number >= 0, got {tare_samples}")
        if deadband_n < 0:
            raise ValueError(f"deadband_n: expected newtons >= 0, got {deadband_n}")
        self.scales = tuple(float(s) for s in scales)
        self.pads = len(self.scales)
        self.tare_samples = tare_samples
        self.deadband_n = float(deadband_n)
        self._sums = [0] * self.pads
        self._seen = 0
        self.zero: tuple[float, ...] | None = None
        self.reset()

    def reset(self) -> None:
        """Forget the zero and tare again from the next samples (after a reconnect)."""
        self._sums = [0] * self.pads
        self._seen = 0
        self.zero = (0.0,) * self.pads if self.tare_samples == 0 else None

    @property
    def taring(self) -> bool:
        return self.zero is None

    @property
    def tare_progress(self) -> tuple[int, int]:
        """(samples averaged so far, samples needed)."""
        return self._seen, self.tare_samples

    def add_tare(self, raw: Sequence[int]) -> bool:
        """Add one sample to the zero being learned; True once the zero is known."""
        if self.zero is not None:
            return True
        if len(raw) != self.pads:
            raise ValueError(f"raw: expected {self.pads} counts, got {len(raw)}")
        for i, v in enumerate(raw):
            self._sums[i] += v
        self._seen += 1
        if self._seen >= self.tare_samples:
            self.zero = tuple(s / self._seen for s in self._sums)
        return self.zero is not None

    def newtons(self, raw: Sequence[int]) -> tuple[float, ...]:
        """Calibrated force of every pad; raises if the zero is still being learned."""
        zero = self.zero
        if zero is None:
            raise ValueError(f"tare: {self._seen} of {self.tare_samples} samples seen, the zero is not known yet")
        if len(raw) != self.pads:
            raise ValueError(f"raw: expected {self.pads} counts, got {len(raw)}")
        band = self.deadband_n
        out = [(r - z) * s for r, z, s in zip(raw, zero, self.scales, strict=True)]
        return tuple(0.0 if -band < f < band else f for f in out)


def scale_from_known_load(unloaded: Sequence[float], loaded: Sequence[float], load_n: float) -> tuple[float, ...]:
    """``newtons_per_count`` for each pad from mean counts without and with a known load on it.

    E.g. a 20 kg mass on each pad in turn: ``load_n = 20 * STANDARD_GRAVITY``.
    """
    if len(unloaded) != len(loaded) or not unloaded:
        raise ValueError(f"loaded: expected as many pads as unloaded ({len(unloaded)}), got {len(loaded)}")
    if not load_n > 0:
        raise ValueError(f"load_n: expected newtons > 0, got {load_n}")
    scales = []
    for i, (u, w) in enumerate(zip(unloaded, loaded, strict=True)):
        if w == u:
            raise ValueError(f"loaded: pad {i} reads {w} counts with and without the load (is it wired?)")
        scales.append(load_n / (w - u))
    return tuple(scales)
