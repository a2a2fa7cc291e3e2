"""The motion models' body keyframes (He, Tsai, Ko, Lu, Figs. 5–8) and their seamless joins.

Each model is one gait cycle of body offsets, keyframed over the cycle phase u ∈ [0, 1): chassis height
``dz`` (m, before the terrain adjustment), ``pitch`` and ``roll`` (rad). The terrain part of the body's
pose (its height over the feet, the pitch between front and rear feet on different cube heights) comes
from the feet themselves (``sim.quadruped.gait``); these keyframes are the style on top: the crouch that
makes room before a climb (Fig. 7(a)), the lean into a turn (Fig. 8), the bob of the walk.
Switching model joins the outgoing model's remaining keyframes to the incoming one's first ones with
dynamic time warping (``legs.dtw_blend``), so the body never jumps.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sim.quadruped.footsteps import MotionModel
from sim.quadruped.legs import dtw_blend

Array = NDArray[np.float64]

# phase u, dz, pitch, roll — per model, scaled by the body size (``dz`` × scale) where used
_KEYS: dict[MotionModel, tuple[tuple[float, float, float, float], ...]] = {
    MotionModel.WALK: ((0.0, 0.0, 0.0, 0.0), (0.25, -0.008, 0.0, 0.0), (0.5, 0.0, 0.0, 0.0),
                       (0.75, -0.008, 0.0, 0.0)),
    MotionModel.CLIMB_UP: ((0.0, -0.03, 0.06, 0.0), (0.5, -0.04, 0.08, 0.0)),
    MotionModel.CLIMB_DOWN: ((0.0, -0.02, -0.05, 0.0), (0.5, -0.03, -0.06, 0.0)),
    MotionModel.TURN_LEFT: ((0.0, -0.01, 0.0, 0.04), (0.5, -0.015, 0.0, 0.05)),
    MotionModel.TURN_RIGHT: ((0.0, -0.01, 0.0, -0.04), (0.5, -0.015, 0.0, -0.05)),
    MotionModel.TURN_BACK: ((0.0, -0.03, 0.0, 0.0), (0.5, -0.035, 0.0, 0.0)),
    MotionModel.STAND: ((0.0, 0.0, 0.0, 0.0),),
}


def keyframe(model: MotionModel, u: float) -> Array:
    """(dz, pitch, roll) of ``model`` at cycle phase ``u`` (periodic, piecewise linear between keys)."""
    keys = np.array(_KEYS[model])
    phase = np.append(keys[:, 0], 1.0)
    values = np.vstack([keys[:, 1:], keys[:1, 1:]])
    u = u % 1.0
    out: Array = np.array([np.interp(u, phase, values[:, c]) for c in range(3)])
    return out


class BodyStyle:
    """The current model's keyframes over time, with DTW joins of ``join_s`` seconds at each switch."""

    def __init__(self, cycle_s: float, scale: float, join_s: float = 0.5, samples: int = 16) -> None:
        self.cycle_s = cycle_s
        self.scale = scale
        self.join_s = join_s
        self.samples = samples
        self.model = MotionModel.STAND
        self.since = 0.0
        self._join: Array | None = None
        self._join_t0 = 0.0

    def _curve(self, model: MotionModel, t0: float, since: float) -> Array:
        ts = t0 + np.linspace(0.0, self.join_s, self.samples)
        return np.array([keyframe(model, (t - since) / self.cycle_s) for t in ts])

    def switch(self, model: MotionModel, t: float) -> None:
        """From time ``t`` on, ``model``: blended in from what the body is doing now."""
        if model == self.model:
            return
        outgoing = self._join_rest(t) if self._join is not None else self._curve(self.model, t, self.since)
        incoming = self._curve(model, t, t)
        self._join = dtw_blend(outgoing, incoming, self.samples)
        self._join_t0 = t
        self.model, self.since = model, t

    def _join_rest(self, t: float) -> Array:
        assert self._join is not None
        now = self.value(t)
        return np.vstack([now[None, :] / np.array([self.scale, 1.0, 1.0]),
                          self._curve(self.model, t, self.since)[1:]])

    def value(self, t: float) -> Array:
        """(dz m, pitch rad, roll rad) now."""
        if self._join is not None:
            k = (t - self._join_t0) / self.join_s
            if k < 1.0:
                x = max(k, 0.0) * (self.samples - 1)
                out = np.array([np.interp(x, np.arange(self.samples), self._join[:, c]) for c in range(3)])
                out[0] *= self.scale
                return out
            self._join = None
        out = keyframe(self.model, (t - self.since) / self.cycle_s)
        out[0] *= self.scale
        return out
