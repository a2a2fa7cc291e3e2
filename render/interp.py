"""Interpolation in the keyframe space Q = (Θx, Θz, Dx, Dz) for one behaviour B (Mitake et al. 2009 §5).

A *curve* is one 1-D animation: keys at increasing coordinates along one axis of Q, at a fixed
*base* for the other three coordinates — each base coordinate a number, or ``None`` ("any": the
animation holds for every value of it, as the paper's stand-up line does for D). Along Dx/Dz the
curve is periodic (p(x) = x − ⌊x⌋); along Θ it is a segment, and a query beyond its ends takes the
end key. A key is either a stored pose (an index into the set's key table) or a *reference* to a
family: "here the pose is whatever that family gives at this query" (how a fall starts from the
current walking phase).

A *family* is one curve, or several parallel curves whose bases differ in one coordinate (the
*loft* coordinate): between neighbouring members the family blends them linearly in that
coordinate (periodically for Dx/Dz).

Evaluating a query gives non-negative weights over the key table that sum to 1:

1. each curve: linear between the two keys that bracket the query's coordinate on its axis;
2. each family: linear between the two members that bracket the query's loft coordinate, and its
   distance is the same blend of the members' distances to the query;
3. the families of a behaviour: inverse-distance weights ``(d_min / d_F) ** sharpness``,
   normalised. A family at distance 0 (the query lies on one of its curves) takes all the weight,
   so the set is exact on every curve and at every key; families that meet must agree where they
   meet (the loader checks it). Distances add Θ differences (radians) and periodic D differences
   times ``cycle_weight`` in quadrature; "any" coordinates do not count.

Everything is a convex combination of stored keys, so nothing overshoots its neighbours.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

AXES: tuple[str, ...] = ("theta_x", "theta_z", "dx", "dz")
PERIODIC: tuple[bool, ...] = (False, False, True, True)
_ZERO = 1e-12  # distances at or below this count as "on the curve"


@dataclass(frozen=True, eq=False)
class Curve:
    """One 1-D animation. ``keys[i]`` is a key-table index (int) or a referenced family's name (str)."""

    name: str
    behaviour: str
    family: str
    axis: int
    base: tuple[float | None, ...]  # 4 entries; None = any; base[axis] is None
    coords: np.ndarray  # (M,) strictly increasing; in [0, 1) on a periodic axis
    keys: tuple[int | str, ...]

    def __post_init__(self) -> None:
        if len(self.coords) != len(self.keys) or len(self.coords) == 0:
            raise ValueError(f"{self.name}: expected as many coordinates as keys, at least one")

    @property
    def lo(self) -> float:
        return float(self.coords[0])

    @property
    def hi(self) -> float:
        return float(self.coords[-1])

    def spans(self, coord: int) -> tuple[float, float] | None:
        """The set of values of ``coord`` on this curve: (lo, hi), or None for "all values"."""
        if coord == self.axis:
            return None if PERIODIC[coord] else (self.lo, self.hi)
        b = self.base[coord]
        return None if b is None else (b, b)


def bracket(coords: np.ndarray, x: np.ndarray, periodic: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices (i0, i1) of the keys around each x and the fraction t from i0 to i1 (t = 0 on a key).

    Periodic: x wraps into [0, 1) and the last key is followed by the first. Otherwise x is clamped
    to the first/last key.
    """
    m = len(coords)
    x = np.asarray(x, dtype=float)
    zeros = np.zeros(x.shape, dtype=int)
    if m == 1:
        return zeros, zeros, np.zeros(x.shape)
    if periodic:
        x = x - np.floor(x)
        i1 = np.searchsorted(coords, x, side="right") % m
        i0 = (i1 - 1) % m
        span = (coords[i1] - coords[i0]) % 1.0
        span = np.where(span <= 0.0, 1.0, span)
        t = ((x - coords[i0]) % 1.0) / span
        return i0, i1, np.clip(t, 0.0, 1.0)
    xc = np.clip(x, coords[0], coords[-1])
    i1 = np.clip(np.searchsorted(coords, xc, side="right"), 1, m - 1)
    i0 = i1 - 1
    t = (xc - coords[i0]) / (coords[i1] - coords[i0])
    return i0, i1, np.clip(t, 0.0, 1.0)


def periodic_gap(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray:
    """|a − b| on the unit circle (0 … 0.5)."""
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    return np.abs(d - np.round(d))


@dataclass(frozen=True, eq=False)
class Family:
    """Parallel curves of one behaviour, blended across ``loft`` (a coordinate index) when several."""

    name: str
    behaviour: str
    members: tuple[Curve, ...]  # sorted by their loft coordinate
    loft: int | None
    refs: frozenset[str] = field(default_factory=frozenset)  # families its keys refer to

    @property
    def axis(self) -> int:
        return self.members[0].axis


class Interpolator:
    """Weights over the key table for batches of queries; built once per keyframe set."""

    def __init__(
        self, families: dict[str, Family], n_keys: int, *, cycle_weight: float, sharpness: float
    ) -> None:
        self.families = families
        self.n_keys = n_keys
        self.cycle_weight = cycle_weight
        self.sharpness = sharpness
        self.by_behaviour: dict[str, list[Family]] = {}
        # per curve: each key's column in the key table, or −1 − r for the r-th referenced family
        self._slots: dict[str, tuple[np.ndarray, tuple[str, ...]]] = {}
        for fam in families.values():
            self.by_behaviour.setdefault(fam.behaviour, []).append(fam)
            for curve in fam.members:
                refs = tuple(sorted({k for k in curve.keys if isinstance(k, str)}))
                cols = np.array([k if isinstance(k, int) else -1 - refs.index(k) for k in curve.keys])
                self._slots[curve.name] = (cols, refs)

    # -------------------------------------------------------------- one curve, one family

    def curve_distance(self, curve: Curve, q: np.ndarray) -> np.ndarray:
        """Distance (N,) from queries q (N, 4) to the curve, in radians-equivalent."""
        d2 = np.zeros(len(q))
        for c in range(4):
            x = q[:, c]
            if c == curve.axis:
                if not PERIODIC[c]:
                    d2 += np.maximum(0.0, np.maximum(curve.lo - x, x - curve.hi)) ** 2
                continue
            b = curve.base[c]
            if b is None:
                continue
            d2 += (self.cycle_weight * periodic_gap(x, b)) ** 2 if PERIODIC[c] else (x - b) ** 2
        return np.sqrt(d2)

    def curve_weights(self, curve: Curve, q: np.ndarray, ref_weights: dict[str, np.ndarray]) -> np.ndarray:
        """Weights (N, K) of one curve alone at queries q; references resolved through ``ref_weights``."""
        n = len(q)
        out = np.zeros((n, self.n_keys))
        i0, i1, t = bracket(curve.coords, q[:, curve.axis], PERIODIC[curve.axis])
        cols, refs = self._slots[curve.name]
        rows = np.arange(n)
        for idx, w in ((i0, 1.0 - t), (i1, t)):
            c = cols[idx]
            direct = c >= 0
            np.add.at(out, (rows[direct], c[direct]), w[direct])
            for r, name in enumerate(refs):
                sel = c == -1 - r
                if np.any(sel):
                    out[sel] += w[sel, None] * ref_weights[name][sel]
        return out

    def family_weights(
        self, fam: Family, q: np.ndarray, ref_weights: dict[str, np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """(weights (N, K), distance (N,)) of one family alone at queries q."""
        n = len(q)
        if fam.loft is None:
            (curve,) = fam.members
            return self.curve_weights(curve, q, ref_weights), self.curve_distance(curve, q)
        values = np.array([m.base[fam.loft] for m in fam.members], dtype=float)
        i0, i1, t = bracket(values, q[:, fam.loft], PERIODIC[fam.loft])
        weights = np.zeros((n, self.n_keys))
        dist = np.zeros(n)
        for k, member in enumerate(fam.members):
            lam = np.where(i0 == k, 1.0 - t, 0.0) + np.where(i1 == k, t, 0.0)
            sel = lam > 0.0
            if not np.any(sel):
                continue
            weights[sel] += lam[sel, None] * self.curve_weights(member, q[sel], _subset(ref_weights, sel))
            dist[sel] += lam[sel] * self.curve_distance(member, q[sel])
        return weights, dist

    # -------------------------------------------------------------- a whole behaviour

    def referenced(self, q: np.ndarray, names: set[str]) -> dict[str, np.ndarray]:
        """Weights of the referenced families (which hold no references themselves)."""
        return {name: self.family_weights(self.families[name], q, {})[0] for name in sorted(names)}

    def weights(self, q: np.ndarray, behaviour: str) -> np.ndarray:
        """Weights (N, K) over the key table for queries q (N, 4) of one behaviour: ≥ 0, rows sum to 1."""
        fams = self.by_behaviour[behaviour]
        refs = self.referenced(q, set().union(*(f.refs for f in fams)))
        parts = [self.family_weights(f, q, refs) for f in fams]
        dist = np.stack([d for _, d in parts], axis=1)  # (N, F)
        dmin = dist.min(axis=1, keepdims=True)
        on = dist <= _ZERO
        ratio = np.where(on, 1.0, np.where(dmin <= _ZERO, 0.0, dmin / np.maximum(dist, _ZERO)))
        fw = ratio**self.sharpness
        fw /= fw.sum(axis=1, keepdims=True)
        out = np.zeros((len(q), self.n_keys))
        for j, (w, _) in enumerate(parts):
            out += fw[:, j : j + 1] * w
        return out


def _subset(ref_weights: dict[str, np.ndarray], sel: np.ndarray) -> dict[str, np.ndarray]:
    return {k: v[sel] for k, v in ref_weights.items()}


# ------------------------------------------------------------------------------ where curves meet


def meeting_points(a: Curve, b: Curve, samples: int = 8) -> np.ndarray:
    """Sample points (P, 4) of the set where two curves meet (empty when they do not).

    Per coordinate each curve covers a point, an interval, or everything; the meeting set is the
    product of the per-coordinate intersections, sampled at their ends, at every key coordinate
    inside them, and at ``samples`` points across a whole period.
    """
    per_coord: list[np.ndarray] = []
    for c in range(4):
        sa, sb = a.spans(c), b.spans(c)
        keys = np.concatenate(
            [a.coords if c == a.axis else np.empty(0), b.coords if c == b.axis else np.empty(0)]
        )
        if sa is None and sb is None:
            if PERIODIC[c]:
                vals = np.concatenate([np.arange(samples) / samples, keys])
            else:  # "any" Θ on both: sample a fair range of tilts
                vals = np.concatenate([np.linspace(-np.pi / 2, np.pi / 2, samples + 1), keys])
        else:
            lo = max(sa[0] if sa else -np.inf, sb[0] if sb else -np.inf)
            hi = min(sa[1] if sa else np.inf, sb[1] if sb else np.inf)
            if lo > hi + 1e-12:
                return np.empty((0, 4))
            inner = keys[(keys >= lo) & (keys <= hi)]
            vals = np.concatenate([[lo, hi], inner, np.linspace(lo, hi, samples) if hi > lo else []])
        per_coord.append(np.unique(np.round(vals, 12)))
    grid = np.meshgrid(*per_coord, indexing="ij")
    return np.stack([g.ravel() for g in grid], axis=1)
