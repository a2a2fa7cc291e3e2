"""Interpolation in the keyframe space Q for one behaviour B (Mitake et al. 2009 §5), vectorised.

Q's continuous coordinates are ``Space.axes``: Θx, Θz, Dx, Dz, plus any a set adds. A *curve* is one
1-D animation: keys at increasing coordinates along one axis, at a fixed *base* for the others (a
number, or ``None``: "any"). Along a periodic axis (Dx, Dz) it wraps; along any other a query beyond
its ends takes the end key. A key is a stored pose (an index into the key table) or a *reference* to
a family ("whatever that family gives at this query"). A *family* is one curve or several parallel
curves whose bases differ in one *loft* coordinate.

A query gets non-negative weights over the key table that sum to 1: linear between the bracketing
keys of each curve; linear between the bracketing members of each family (its distance the same
blend); inverse-distance weights ``(d_min / d_F) ** sharpness`` between families, so a family at
distance 0 takes all the weight (exact on every curve and key). Distances add each coordinate's
difference times its axis' ``scale`` (radians for Θ; ``cycle_weight`` per cycle for D) in
quadrature; "any" does not count. Families that meet must agree where they meet (the loader checks
it). Everything is a convex combination of stored keys, so nothing overshoots; one set of numpy
operations per behaviour, whatever the number of queries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

STANDARD_AXES: tuple[str, ...] = ("theta_x", "theta_z", "dx", "dz")
_ZERO = 1e-12  # distances at or below this count as "on the curve"


@dataclass(frozen=True)
class Space:
    """The continuous coordinates of Q: names, periodicity, distance scale, and the range queries are
    clamped to (±inf for none)."""

    axes: tuple[str, ...]
    periodic: tuple[bool, ...]
    scale: tuple[float, ...]
    lo: tuple[float, ...]
    hi: tuple[float, ...]

    @classmethod
    def standard(cls, cycle_weight: float = 0.5) -> Space:
        inf = math.inf
        return cls(STANDARD_AXES, (False, False, True, True), (1.0, 1.0, cycle_weight, cycle_weight),
                   (-inf,) * 4, (inf,) * 4)

    def with_axis(self, name: str, *, periodic: bool, scale: float, lo: float, hi: float) -> Space:
        return Space(self.axes + (name,), self.periodic + (periodic,), self.scale + (scale,),
                     self.lo + (lo,), self.hi + (hi,))

    @property
    def dims(self) -> int:
        return len(self.axes)

    def clamp(self, q: np.ndarray) -> np.ndarray:
        """Queries (N, D) with periodic coordinates wrapped into [0, 1) and the others clamped to range."""
        q = np.clip(np.asarray(q, dtype=float), self.lo, self.hi)
        per = np.array(self.periodic)
        if per.any():
            q[:, per] -= np.floor(q[:, per])
        return q


@dataclass(frozen=True, eq=False)
class Curve:
    """One 1-D animation. ``keys[i]`` is a key-table index (int) or a referenced family's name (str)."""

    name: str
    behaviour: str
    family: str
    axis: int
    base: tuple[float | None, ...]  # one per axis; None = any; base[axis] is None
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

    def spans(self, coord: int, space: Space) -> tuple[float, float] | None:
        """The values of ``coord`` on this curve: (lo, hi), or None for "all values"."""
        if coord == self.axis:
            return None if space.periodic[coord] else (self.lo, self.hi)
        b = self.base[coord]
        return None if b is None else (b, b)


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


def periodic_gap(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray:
    """|a − b| on the unit circle (0 … 0.5)."""
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    return np.abs(d - np.round(d))


def bracket(coords: np.ndarray, x: np.ndarray, periodic: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices (i0, i1) of the keys around each x and the fraction t from i0 to i1 (t = 0 on a key).
    Periodic: x wraps and the last key is followed by the first; otherwise x is clamped to the ends."""
    i0, i1, t = _bracket(coords[None, :], np.array([len(coords)]), np.array([periodic]),
                         np.asarray(x, dtype=float).reshape(-1, 1))
    return i0[:, 0], i1[:, 0], t[:, 0]


def _bracket(
    coords: np.ndarray, count_keys: np.ndarray, periodic: np.ndarray, x: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Batched ``bracket``: coords (C, M) padded with +inf, keys per row (C,), periodic (C,), x (N, C)."""
    m = count_keys[None, :]
    x = np.where(periodic[None, :], x - np.floor(x), x)
    below = (x[:, :, None] >= coords[None, :, :]).sum(axis=2)  # keys at or below x: 0 … M
    seg1 = np.clip(below, 1, np.maximum(m - 1, 1))
    i1 = np.where(periodic[None, :], below % m, np.minimum(seg1, m - 1))
    i0 = np.where(periodic[None, :], (below - 1) % m, np.maximum(seg1 - 1, 0))
    rows = np.arange(coords.shape[0])[None, :]
    c0, c1 = coords[rows, i0], coords[rows, i1]
    span = np.where(periodic[None, :], (c1 - c0) % 1.0, c1 - c0)
    off = np.where(periodic[None, :], (x - c0) % 1.0, x - c0)
    single = m == 1
    span = np.where(span > 0.0, span, 1.0)
    t = np.where(single, 0.0, np.clip(off / span, 0.0, 1.0))
    return i0, i1, t


class BehaviourTable:
    """The curves and families of one behaviour (plus the families they refer to), compiled to arrays."""

    def __init__(self, behaviour: str, families: dict[str, Family], space: Space, sharpness: float) -> None:
        own = [f for f in families.values() if f.behaviour == behaviour]
        referenced = sorted({r for f in own for r in f.refs} - {f.name for f in own})
        fams = own + [families[r] for r in referenced]
        self.behaviour = behaviour
        self.space = space
        self.sharpness = sharpness
        self.n_own = len(own)
        self.family_names = tuple(f.name for f in fams)
        curves = [c for f in fams for c in f.members]
        index = {c.name: i for i, c in enumerate(curves)}
        fam_index = {f.name: i for i, f in enumerate(fams)}
        m = max(len(c.coords) for c in curves)
        d = space.dims
        self.coords = np.full((len(curves), m), np.inf)
        self.slots = np.zeros((len(curves), m), dtype=np.int64)
        self.count = np.array([len(c.coords) for c in curves])
        self.axis = np.array([c.axis for c in curves])
        self.periodic = np.array([space.periodic[c.axis] for c in curves])
        self.lo = np.array([c.lo for c in curves])
        self.hi = np.array([c.hi for c in curves])
        self.base = np.zeros((len(curves), d))
        self.weight = np.zeros((len(curves), d))  # scale² where the base is a number
        self.base_periodic = np.array(space.periodic)
        scale2 = np.array(space.scale) ** 2
        for i, c in enumerate(curves):
            self.coords[i, : len(c.coords)] = c.coords
            for k, key in enumerate(c.keys):
                self.slots[i, k] = key if isinstance(key, int) else -1 - fam_index[key]
            for j, b in enumerate(c.base):
                if b is not None and j != c.axis:
                    self.base[i, j], self.weight[i, j] = b, scale2[j]
        self.axis_scale2 = scale2[self.axis]
        # families: member curves and loft values; single-member families blend nothing
        self.first = np.array([index[f.members[0].name] for f in fams])
        self.lofts: list[tuple[int, int, np.ndarray, np.ndarray, bool]] = []  # (family, coord, values, curves, periodic)
        for fi, f in enumerate(fams):
            if f.loft is not None:
                values = np.array([mb.base[f.loft] for mb in f.members], dtype=float)
                members = np.array([index[mb.name] for mb in f.members])
                self.lofts.append((fi, f.loft, values, members, space.periodic[f.loft]))
        self.has_refs = bool(np.any(self.slots < 0))

    def distances(self, q: np.ndarray) -> np.ndarray:
        """Distance (N, F) from clamped queries q (N, D) to each of the behaviour's own families."""
        n = len(q)
        dist = self._curve_distances(q, q[:, self.axis])
        j0, j1, lam = self._members(q)
        r = np.arange(n)[:, None]
        return ((1 - lam) * dist[r, j0] + lam * dist[r, j1])[:, : self.n_own]

    def _curve_distances(self, q: np.ndarray, x: np.ndarray) -> np.ndarray:
        gap = q[:, None, :] - self.base[None, :, :]
        gap = np.where(self.base_periodic, np.abs(gap - np.round(gap)), gap)
        d2 = np.einsum("ncd,cd->nc", gap * gap, self.weight)
        over = np.where(self.periodic, 0.0, np.maximum(0.0, np.maximum(self.lo - x, x - self.hi)))
        return np.sqrt(d2 + self.axis_scale2 * over * over)

    def _members(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per family (N, F): the two members around the query's loft coordinate and λ between them."""
        n, nf = len(q), len(self.first)
        j0 = np.broadcast_to(self.first, (n, nf)).copy()
        j1 = j0.copy()
        lam = np.zeros((n, nf))
        for fi, coord, values, members, per in self.lofts:
            a, b, u = _bracket(values[None, :], np.array([len(values)]), np.array([per]), q[:, coord : coord + 1])
            j0[:, fi], j1[:, fi], lam[:, fi] = members[a[:, 0]], members[b[:, 0]], u[:, 0]
        return j0, j1, lam

    def weights(self, q: np.ndarray, n_keys: int) -> np.ndarray:
        """Weights (N, K) over the key table for clamped queries q (N, D): ≥ 0, rows sum to 1."""
        n = len(q)
        x = q[:, self.axis]  # (N, C)
        i0, i1, t = _bracket(self.coords, self.count, self.periodic, x)
        rows = np.arange(len(self.axis))[None, :]
        k0, k1 = self.slots[rows, i0], self.slots[rows, i1]
        dist = self._curve_distances(q, x)
        j0, j1, lam = self._members(q)
        r = np.arange(n)[:, None]
        keys = np.stack([k0[r, j0], k1[r, j0], k0[r, j1], k1[r, j1]], axis=2)  # (N, F, 4)
        t0, t1 = t[r, j0], t[r, j1]
        within = np.stack([(1 - lam) * (1 - t0), (1 - lam) * t0, lam * (1 - t1), lam * t1], axis=2)
        fdist = (1 - lam) * dist[r, j0] + lam * dist[r, j1]
        # inverse-distance weights over the behaviour's own families
        own = fdist[:, : self.n_own]
        dmin = own.min(axis=1, keepdims=True)
        on = own <= _ZERO
        ratio = np.where(on, 1.0, np.where(dmin <= _ZERO, 0.0, dmin / np.maximum(own, _ZERO)))
        fw = ratio**self.sharpness
        fw /= fw.sum(axis=1, keepdims=True)
        ek = keys[:, : self.n_own]  # (N, F, 4)
        ew = within[:, : self.n_own] * fw[:, :, None]
        if self.has_refs:  # a reference expands into the referenced family's own four entries
            ref = ek < 0
            target = np.where(ref, -1 - ek, 0)
            rk = keys[r[:, :, None], target]  # (N, F, 4, 4)
            rw = within[r[:, :, None], target] * ew[..., None]
            direct = np.zeros_like(rw)
            direct[..., 0] = ew
            flat_k = np.where(ref[..., None], rk, np.where(ek[..., None] < 0, 0, ek[..., None]))
            flat_w = np.where(ref[..., None], rw, direct)
        else:
            flat_k, flat_w = ek, ew
        flat_k = flat_k.reshape(n, -1)
        flat_w = flat_w.reshape(n, -1)
        out = np.bincount((flat_k + np.arange(n)[:, None] * n_keys).ravel(), flat_w.ravel(), n * n_keys)
        return out.reshape(n, n_keys)


# ------------------------------------------------------------------------------ where curves meet


def meeting_points(a: Curve, b: Curve, space: Space, samples: int = 8) -> np.ndarray:
    """Sample points (P, D) of Q where two curves meet (empty when they do not).

    Per coordinate each curve covers a point, an interval, or everything; the meeting set is the
    product of the per-coordinate intersections, sampled at their ends, at every key coordinate
    inside them, and at ``samples`` points across a whole period (or a fair range when unbounded).
    """
    per_coord: list[np.ndarray] = []
    for c in range(space.dims):
        sa, sb = a.spans(c, space), b.spans(c, space)
        keys = np.concatenate(
            [a.coords if c == a.axis else np.empty(0), b.coords if c == b.axis else np.empty(0)]
        )
        if sa is None and sb is None:
            if space.periodic[c]:
                vals = np.concatenate([np.arange(samples) / samples, keys])
            else:
                lo = space.lo[c] if math.isfinite(space.lo[c]) else -np.pi / 2
                hi = space.hi[c] if math.isfinite(space.hi[c]) else np.pi / 2
                vals = np.concatenate([np.linspace(lo, hi, samples + 1), keys])
        else:
            lo = max(sa[0] if sa else -np.inf, sb[0] if sb else -np.inf)
            hi = min(sa[1] if sa else np.inf, sb[1] if sb else np.inf)
            if lo > hi + 1e-12:
                return np.empty((0, space.dims))
            inner = keys[(keys >= lo) & (keys <= hi)]
            vals = np.concatenate([[lo, hi], inner, np.linspace(lo, hi, samples) if hi > lo else []])
        per_coord.append(np.unique(np.round(vals, 12)))
    grid = np.meshgrid(*per_coord, indexing="ij")
    return np.stack([g.ravel() for g in grid], axis=1)
