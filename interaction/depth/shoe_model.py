"""Where a foot's middle is, corrected by the shoes most like it among feet seen with their truth known.

:func:`interaction.depth.parts.find_feet` measures a foot on the column of depth points over it and
puts its height from a generic shoe's shape (:mod:`interaction.depth.shoe_fit`). What those rules
cannot tell from one column (a heel up, a toe hanging, a shoe half seen) a :class:`ShoeModel`
corrects: each foot moves by the mean correction of the ``k`` feet most like it (nearest neighbours,
on :func:`column_features` scaled to unit spread) among feet of virtual performers whose true middles
are known — along the camera's view, across it, and up (metres). The model is those feet's features
and corrections (``interaction/depth/data/shoe_model.npz``, made by ``jostle synth shoe-model``:
performer recordings with truth, ``jostle.bench.shoe_model_fit``); nothing is learnt at run time.

It knows the virtual performer's shoe (a 26 × 10 × 8 cm box), its gait (two mocap clips) and its
depth camera's noise, not a real shoe: on real people it can only be as right as those are like
theirs. It looks at one frame's column only (no motion). Figures: docs/notes/shoe-fit.md.
"""

from __future__ import annotations

import functools
import logging
import math
from pathlib import Path

import numpy as np

from sensors.untrusted import open_regular

__all__ = ["FEATURES", "ShoeModel", "column_features", "default_model_path", "shipped_shoe_model"]

log = logging.getLogger("jostle.depth")

FEATURES = 34  # column_features' length
_SLICES = ((0.0, 0.03), (0.03, 0.06), (0.06, 0.09), (0.09, 0.12), (0.12, 0.15))  # heights over the lowest
_SLICE_EDGES = np.array([lo for lo, _ in _SLICES] + [_SLICES[-1][1]])
_SHARES = (0.02, 0.04, 0.06, 0.08, 0.12, 0.16)
MAX_CORRECTION_M = 0.3  # a model whose corrections are larger than this is refused (not a shoe's)
LEVELS = 6  # the feet are split into up to 2^LEVELS boxes …
PROBED = 8  # … and a foot's nearest are looked for in this many of them, those whose middles are nearest


def default_model_path() -> Path:
    return Path(__file__).resolve().parent / "data" / "shoe_model.npz"


@functools.cache
def shipped_shoe_model() -> ShoeModel | None:
    """The shipped model (loaded once), or None, said once, when it is missing or unreadable: the depth
    observer then places feet by the shoe rules alone."""
    path = default_model_path()
    if not path.is_file():
        log.warning("depth observer: no shoe model at %s (make it with `jostle synth shoe-model`); feet are "
                    "placed by the shoe rules alone", path)
        return None
    try:
        return ShoeModel.load(path)
    except ValueError as e:
        log.warning("depth observer: %s; feet are placed by the shoe rules alone", e)
        return None


def _quantile(ordered: np.ndarray, q: float) -> float:
    """``np.percentile(values, q)`` (linear) of values already sorted, without its overhead."""
    at = q / 100.0 * (len(ordered) - 1)
    lo = int(at)
    hi = min(lo + 1, len(ordered) - 1)
    return float(ordered[lo] + (ordered[hi] - ordered[lo]) * (at - lo))


def column_features(column: np.ndarray, camera: np.ndarray, rule_height: float | None,
                    shoe_mean_z: float) -> np.ndarray:
    """The features (FEATURES,) of the points ``column`` (N, 3) over a foot, seen from ``camera``:
    its lowest points' height (their 5th percentile); the percentiles 10–90 of the heights over them;
    the shares of points under 2–16 cm over them; the spread of its lowest 8 cm across and along the view;
    how far its lowest 3 cm lie from the leg over them (12–20 cm; −1 when either is missing); how much
    farther along the view its top is than its bottom; for five 3 cm slices over the lowest, how wide
    the slice is, how far its middle is from the leg's (15–25 cm) and its share of the points; whether
    the shoe rules (:func:`interaction.depth.shoe_fit.shoe_middle_height`) put it on the floor, hanging, or
    neither; and the mean height of its shoe's points."""
    z = column[:, 2]
    ordered = np.sort(z)
    lowest = float(ordered[len(z) * 5 // 100])
    over = z - lowest
    ordered -= lowest
    out = [lowest, *(_quantile(ordered, q) for q in (10, 25, 50, 75, 90))]
    out += (np.searchsorted(ordered, _SHARES, side="left") / len(z)).tolist()
    band = column[over < 0.08]
    middle = band[:, :2].sum(axis=0) / len(band)
    ray = middle - camera[:2]
    ray = ray / max(math.hypot(float(ray[0]), float(ray[1])), 1e-9)
    off = band[:, :2] - middle
    across, along = np.sort(off @ np.array([-ray[1], ray[0]])), off @ ray
    along_sorted = np.sort(along)
    out += [_quantile(across, 95) - _quantile(across, 5), _quantile(along_sorted, 95) - _quantile(along_sorted, 5)]
    low, leg = column[over < 0.03, :2], column[(over > 0.12) & (over < 0.2), :2]
    out.append(float(np.linalg.norm(low.mean(axis=0) - leg.mean(axis=0))) if len(low) >= 3 and len(leg) >= 3 else -1.0)
    up = band[:, 2] >= lowest + 0.04
    n_up = int(np.count_nonzero(up))
    out.append(float(along[up].mean() - along[~up].mean()) if n_up >= 3 and len(band) - n_up >= 3 else 0.0)
    top = column[(over > 0.15) & (over < 0.25), :2]
    ref = top.mean(axis=0) if len(top) >= 3 else column[:, :2].mean(axis=0)
    slice_of = np.searchsorted(_SLICE_EDGES, over, side="right") - 1  # 0..4 inside the slices
    inside = (slice_of >= 0) & (slice_of < len(_SLICES))
    idx, pts = slice_of[inside], column[inside, :2]
    n = np.bincount(idx, minlength=len(_SLICES))
    cx = np.bincount(idx, pts[:, 0], len(_SLICES)) / np.maximum(n, 1)
    cy = np.bincount(idx, pts[:, 1], len(_SLICES)) / np.maximum(n, 1)
    r = np.hypot(pts[:, 0] - cx[idx], pts[:, 1] - cy[idx])
    r = r[np.lexsort((r, idx))]  # by slice, then by distance from the slice's middle
    start = 0
    for i in range(len(_SLICES)):
        count = int(n[i])
        if count >= 3:
            out += [_quantile(r[start:start + count], 90), math.hypot(float(cx[i] - ref[0]), float(cy[i] - ref[1])),
                    count / len(column)]
        else:
            out += [0.0, 0.0, 0.0]
        start += count
    on_floor = rule_height is not None and abs(rule_height - 0.04) < 1e-9
    out += [float(on_floor), float(rule_height is not None and not on_floor), float(shoe_mean_z)]
    return np.array(out, dtype=np.float64)


def _columns(rows: np.ndarray) -> np.ndarray:
    """[f, −|f|²/2] for each row f, as columns (FEATURES + 1, N)."""
    return np.ascontiguousarray(np.hstack([rows, -0.5 * np.einsum("ij,ij->i", rows, rows)[:, None]]).T)


def _boxes(rows: np.ndarray, index: np.ndarray, levels: int, smallest: int) -> list[np.ndarray]:
    """``index`` split in two at the median of the feature most spread over its rows, ``levels`` times
    over (a box of fewer than 2 × ``smallest`` is not split): the boxes' indices, in order."""
    if levels == 0 or len(index) < 2 * smallest:
        return [index]
    values = rows[index]
    dim = int(np.argmax(values.var(axis=0)))
    half = len(index) // 2
    split = np.argsort(values[:, dim], kind="stable")
    return (_boxes(rows, np.sort(index[split[:half]]), levels - 1, smallest)
            + _boxes(rows, np.sort(index[split[half:]]), levels - 1, smallest))


def view_frame(position: np.ndarray, camera: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(along, across): the horizontal unit vectors along the camera's view of ``position`` and across it."""
    ray = np.asarray(position[:2], dtype=float) - camera[:2]
    ray = ray / max(math.hypot(float(ray[0]), float(ray[1])), 1e-9)
    return ray, np.array([-ray[1], ray[0]])


class ShoeModel:
    """Feet with known corrections, looked up by their features (see the module's notes)."""

    def __init__(self, features: np.ndarray, corrections: np.ndarray, mean: np.ndarray, scale: np.ndarray,
                 k: int) -> None:
        if features.ndim != 2 or features.shape[1] != FEATURES or len(features) < k or k < 1:
            raise ValueError(f"expected ({FEATURES},)-feature rows, at least k={k} of them, got {features.shape}")
        if corrections.shape != (len(features), 3) or mean.shape != (FEATURES,) or scale.shape != (FEATURES,):
            raise ValueError(f"corrections {corrections.shape}, mean {mean.shape}, scale {scale.shape}: "
                             f"expected ({len(features)}, 3), ({FEATURES},), ({FEATURES},)")
        for name, a in (("features", features), ("corrections", corrections), ("mean", mean), ("scale", scale)):
            if not np.isfinite(a).all():
                raise ValueError(f"{name}: not all finite")
        if (scale <= 0).any():
            raise ValueError("scale: expected every value > 0")
        if float(np.abs(corrections).max()) > MAX_CORRECTION_M:
            raise ValueError(f"corrections: up to {float(np.abs(corrections).max()):.2f} m, expected at most "
                             f"{MAX_CORRECTION_M} m")
        self.k = int(k)
        self._mean, self._scale = mean.astype(np.float64), scale.astype(np.float64)
        scaled = ((features - mean) / scale).astype(np.float32)
        # The feet are split into boxes (the median of the most spread feature, again and again: the same
        # boxes on every machine) and a foot is looked for in the PROBED boxes whose middles are nearest,
        # each a product small enough that the BLAS keeps it on one thread (a product of all the feet at
        # once is handed to several, which a machine busy with two other processes turned from 0.05 ms into
        # 0.3 and 7.1 ms in two runs; these took 0.06–0.13 ms there: measured).
        leaves = _boxes(scaled, np.arange(len(scaled)), LEVELS, max(4 * self.k, 64))
        order = np.concatenate(leaves)
        self._starts = np.cumsum([0] + [len(leaf) for leaf in leaves])
        scaled, self._corrections = scaled[order], corrections[order].astype(np.float64)
        # nearest = largest f·q − |f|²/2: the query [q, 1] times the columns [f, −|f|²/2]
        self._blocks = [_columns(scaled[a:b]) for a, b in zip(self._starts[:-1], self._starts[1:], strict=True)]
        self._middles = _columns(np.stack([scaled[a:b].mean(axis=0) for a, b in
                                           zip(self._starts[:-1], self._starts[1:], strict=True)]))
        self._probe = min(PROBED, len(leaves))

    def __len__(self) -> int:
        return int(self._starts[-1])

    @classmethod
    def load(cls, path: Path) -> ShoeModel:
        """The model saved at ``path`` (``save``'s npz; no pickled objects are read)."""
        try:
            with open_regular(path) as fh, np.load(fh, allow_pickle=False) as f:
                arrays = {name: np.array(f[name]) for name in ("features", "corrections", "mean", "scale", "k")}
        except (OSError, KeyError, ValueError) as e:
            raise ValueError(f"{path}: not a shoe model ({e})") from e
        try:
            return cls(arrays["features"].astype(np.float64), arrays["corrections"].astype(np.float64),
                       arrays["mean"].astype(np.float64), arrays["scale"].astype(np.float64), int(arrays["k"]))
        except (TypeError, ValueError) as e:
            raise ValueError(f"{path}: {e}") from e

    @staticmethod
    def save(path: Path, features: np.ndarray, corrections: np.ndarray, k: int, seeds: list[int]) -> None:
        """Feet's features and corrections as a model (scaled by their own mean and spread)."""
        mean = features.mean(axis=0)
        scale = features.std(axis=0)
        scale[scale < 1e-9] = 1.0
        path.parent.mkdir(parents=True, exist_ok=True)
        part = path.with_name(path.name + ".part")  # written whole, then put in place: never half a model
        with part.open("wb") as f:
            np.savez_compressed(f, features=features.astype(np.float32), corrections=corrections.astype(np.float32),
                                mean=mean, scale=scale, k=np.array(k), seeds=np.array(seeds, dtype=np.int64))
        part.replace(path)

    def correction(self, features: np.ndarray) -> np.ndarray | None:
        """(along the view, across it, up) in metres: the mean of the ``k`` nearest feet's; None for
        features that are not all finite."""
        if features.shape != (FEATURES,) or not np.isfinite(features).all():
            return None
        q = np.append((features - self._mean) / self._scale, 1.0).astype(np.float32)
        near = np.argpartition(q @ self._middles, self._middles.shape[1] - self._probe)[-self._probe:]
        near.sort()
        score = np.concatenate([q @ self._blocks[i] for i in near])
        index = np.concatenate([np.arange(self._starts[i], self._starts[i + 1]) for i in near])
        nearest = index[np.argpartition(score, len(score) - self.k)[-self.k:]]
        out: np.ndarray = self._corrections[nearest].mean(axis=0)
        return out

    def corrected(self, foot: np.ndarray, features: np.ndarray, camera: np.ndarray) -> np.ndarray:
        """``foot`` (3,) moved by its correction in the camera's view frame (unchanged when there is none)."""
        c = self.correction(features)
        if c is None:
            return foot
        along, across = view_frame(foot, camera)
        out = np.array(foot, dtype=np.float64)
        out[:2] += c[0] * along + c[1] * across
        out[2] += c[2]
        return out
