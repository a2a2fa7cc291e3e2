"""Multidimensional keyframe sets (Mitake et al. 2009 §5): poses at points of Q = (Θx, Θz, Dx, Dz, B).

- Θx: lean forward (+) / backward (−), Θz: lean right (+) / left (−), radians — the identity map of
  the sim's ``CharacterSnapshot.tilt``.
- Dx = p(d_side), Dz = p(d_front) with p(x) = x − ⌊x⌋: the phase of sideways / forward travel.
- More coordinates a set may add (``[dimensions.NAME]`` in its manifest), each computed from the
  snapshot by ``EXTRA_AXES``: ``speed`` (horizontal speed, m/s), ``turn_rate`` (yaw rate, rad/s),
  ``lift`` (centre-of-mass height over the character's height).
- B: a behaviour name (e.g. "walk", "stand_up"), or a blend of behaviours given as weights: all
  values of B are adjacent, so a pose can be on its way from one behaviour to another. A B the set
  lacks falls back to the set's default behaviour, with one warning per name.

A pose is a root offset (3, metres), a root rotation and per-joint rotations (``JOINTS`` order,
quaternions x y z w), all in the *rigid body's* frame with the skeleton's axes (x forward, y up,
z right): the renderer places it with the body's position and orientation and scales it to the
character's height. In the shipped sets the root offset puts the skeleton's centre of mass at the
body's origin (the sim's centre of mass).

How poses are interpolated is in ``render.keyframes.interp``; the file format in ``render.keyframes.set_file``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from render.keyframes.interp import BehaviourTable, Curve, Family, Space, meeting_points
from render.keyframes.set_file import KeyframeError, SetData, read_set
from sim.motion import quaternion as quat
from sim.motion.mocap import JOINTS, Skeleton
from sim.snapshot import CharacterSnapshot

__all__ = [
    "EXTRA_AXES", "KeyframeError", "KeyframeQuery", "KeyframeSet", "Pose", "periodic", "query_from_snapshot"
]

MEET_ANGLE = math.radians(0.05)  # animations that meet must agree to this (per joint) …
MEET_OFFSET = 1e-4  # … and to this many metres of root offset

# added coordinates of Q a set may declare, and how each is read from a snapshot
EXTRA_AXES: dict[str, Callable[[CharacterSnapshot], float]] = {
    "speed": lambda c: math.hypot(c.velocity[0], c.velocity[1]),
    "turn_rate": lambda c: float(c.angular_velocity[2]),
    "lift": lambda c: float(c.position[2]) / c.height,
}

BehaviourSpec = str | Mapping[str, float]  # one behaviour, or weights over behaviours (≥ 0, summing to 1)


def periodic(x: float) -> float:
    """p(x) = x − ⌊x⌋ (Mitake eq. 8)."""
    return x - math.floor(x)


@dataclass(frozen=True, slots=True)
class KeyframeQuery:
    """A point of the keyframe space. ``dx``/``dz`` are phases; any real is taken modulo 1.
    ``extra``: values of the coordinates a set adds, by name (those a set does not have are ignored;
    those it has and the query lacks count as the low end of their range, or 0).
    ``behaviour``: a name, or weights over names (a blend between behaviours)."""

    theta_x: float
    theta_z: float
    dx: float
    dz: float
    behaviour: BehaviourSpec
    extra: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        for name in ("theta_x", "theta_z", "dx", "dz"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ValueError(f"{name}: expected a finite number, got {v!r}")
        b = self.behaviour
        if isinstance(b, Mapping):
            ws = list(b.values())
            if not b or any(not isinstance(w, int | float) or not w >= 0 for w in ws) or abs(sum(ws) - 1) > 1e-9:
                raise ValueError(f"behaviour: expected weights >= 0 that sum to 1, got {dict(b)!r}")
        elif not isinstance(b, str) or not b:
            raise ValueError(f"behaviour: expected a behaviour name, got {b!r}")
        for name, v in self.extra:
            if not isinstance(v, int | float) or not math.isfinite(v):
                raise ValueError(f"extra.{name}: expected a finite number, got {v!r}")

    def as_array(self) -> np.ndarray:
        return np.array([self.theta_x, self.theta_z, self.dx, self.dz], dtype=float)


def query_from_snapshot(c: CharacterSnapshot) -> KeyframeQuery:
    """The correspondence function (Mitake §5.2): identity for tilt, p() of the travelled distances,
    and every ``EXTRA_AXES`` coordinate."""
    return KeyframeQuery(
        theta_x=float(c.tilt[0]),
        theta_z=float(c.tilt[1]),
        dx=periodic(float(c.d_side)),
        dz=periodic(float(c.d_front)),
        behaviour=c.behaviour,
        extra=tuple((name, float(f(c))) for name, f in EXTRA_AXES.items()),
    )


@dataclass(frozen=True, eq=False)
class Pose:
    """One pose, or a batch of them along a leading axis (body frame, skeleton axes, metres)."""

    root_offset: np.ndarray  # (..., 3)
    root_rotation: np.ndarray  # (..., 4) x y z w
    joint_rotations: np.ndarray  # (..., J, 4) in JOINTS order

    def __len__(self) -> int:
        return int(self.root_offset.shape[0]) if self.root_offset.ndim > 1 else 1

    def __getitem__(self, i: int) -> Pose:
        return Pose(self.root_offset[i], self.root_rotation[i], self.joint_rotations[i])

    def rotations(self) -> np.ndarray:
        """Root then joints: (..., 1 + J, 4)."""
        return np.concatenate([self.root_rotation[..., None, :], self.joint_rotations], axis=-2)


class KeyframeSet:
    """A keyframe set for one skeleton: ``pose(q)`` for one query, ``poses(qs)`` for many, and
    ``evaluate(q_array, behaviours)`` — the fast path — for whole batches as arrays."""

    def __init__(self, data: SetData, source: Path | None = None) -> None:
        self.source = source
        self.skeleton: Skeleton = data.skeleton
        self.height = data.height
        self.default_behaviour = data.default_behaviour
        self.space: Space = data.space
        self.families: dict[str, Family] = data.families
        self.key_names = data.key_names
        self.key_offsets = data.key_offsets
        rots = quat.normalize(data.key_rotations)
        self.key_rotations = np.where(rots[..., 3:4] < 0, -rots, rots)  # one hemisphere: w >= 0
        # the sign that aligns key j to key i, per joint: blending aligns every key to the heaviest
        self._align = np.where(np.einsum("ijc,kjc->ikj", self.key_rotations, self.key_rotations) < 0, -1.0, 1.0)
        self.sharpness = data.sharpness
        self.tables = {
            b: BehaviourTable(b, data.families, data.space, data.sharpness)
            for b in sorted({f.behaviour for f in data.families.values()})
        }
        self._warned: set[str] = set()
        self._check_meetings()

    @classmethod
    def load(cls, path: str | Path) -> KeyframeSet:
        """Read ``keyframes.toml`` and its pose files; KeyframeError (one line) when anything is wrong."""
        return cls(read_set(path), Path(path))

    @property
    def behaviours(self) -> tuple[str, ...]:
        return tuple(self.tables)

    @property
    def animations(self) -> tuple[Curve, ...]:
        return tuple(m for f in self.families.values() for m in f.members)

    def resolve(self, behaviour: str) -> str:
        """The behaviour the set will use for B: itself, or the default (warned once per name)."""
        if behaviour in self.tables:
            return behaviour
        if behaviour not in self._warned:
            self._warned.add(behaviour)
            where = f"{self.source}: " if self.source else ""
            warnings.warn(
                f"{where}no animations for behaviour {behaviour!r}; using {self.default_behaviour!r} "
                f"(the set has {', '.join(self.behaviours)})",
                stacklevel=3,
            )
        return self.default_behaviour

    # ------------------------------------------------------------------------ queries as arrays

    def query_array(self, qs: Sequence[KeyframeQuery]) -> np.ndarray:
        """Queries (N, D) in this set's coordinates (its added dimensions from each query's ``extra``)."""
        extra_axes = self.space.axes[4:]
        out = np.empty((len(qs), self.space.dims))
        for i, q in enumerate(qs):
            out[i, :4] = (q.theta_x, q.theta_z, q.dx, q.dz)
            if extra_axes:
                given = dict(q.extra)
                for j, name in enumerate(extra_axes):
                    lo = self.space.lo[4 + j]
                    out[i, 4 + j] = given.get(name, lo if math.isfinite(lo) else 0.0)
        return out

    def snapshot_array(self, chars: Sequence[CharacterSnapshot]) -> np.ndarray:
        """Queries (N, D) straight from snapshots (the correspondence function, without objects)."""
        n = len(chars)
        out = np.empty((n, self.space.dims))
        if n == 0:
            return out
        out[:, 0:2] = [c.tilt for c in chars]
        out[:, 2] = [c.d_side for c in chars]
        out[:, 3] = [c.d_front for c in chars]
        out[:, 2:4] -= np.floor(out[:, 2:4])
        for j, name in enumerate(self.space.axes[4:]):
            f = EXTRA_AXES[name]
            out[:, 4 + j] = [f(c) for c in chars]
        return out

    # ------------------------------------------------------------------------ evaluation

    def weights(self, qs: Sequence[KeyframeQuery]) -> np.ndarray:
        """Blend weights (N, K) over ``key_names``: every entry ≥ 0, every row sums to 1."""
        return self.weights_array(self.query_array(qs), [q.behaviour for q in qs])

    def weights_array(self, q: np.ndarray, behaviours: Sequence[BehaviourSpec]) -> np.ndarray:
        """As ``weights`` for queries given as an (N, D) array and N behaviours (names or weights)."""
        q = self.space.clamp(np.asarray(q, dtype=float).reshape(-1, self.space.dims))
        n_keys = len(self.key_names)
        if len(q) and all(isinstance(b, str) for b in behaviours) and len(set(behaviours)) == 1:
            return self.tables[self.resolve(str(behaviours[0]))].weights(q, n_keys)  # the common case
        out = np.zeros((len(q), n_keys))
        groups: dict[str, tuple[list[int], list[float]]] = {}
        for i, b in enumerate(behaviours):
            for name, w in (((b, 1.0),) if isinstance(b, str) else b.items()):
                if w > 0:
                    rows, ws = groups.setdefault(self.resolve(name), ([], []))
                    rows.append(i)
                    ws.append(w)
        for name, (rows, ws) in groups.items():
            if len(rows) == len(q) and all(w == 1.0 for w in ws):
                out += self.tables[name].weights(q, n_keys)
            else:
                idx = np.array(rows)
                np.add.at(out, idx, np.array(ws)[:, None] * self.tables[name].weights(q[idx], n_keys))
        return out

    def pose(self, q: KeyframeQuery) -> Pose:
        return self.poses([q])[0]

    def poses(self, qs: Sequence[KeyframeQuery]) -> Pose:
        """Poses for many queries at once (vectorised)."""
        return self.pose_from_weights(self.weights(qs))

    def evaluate(self, q: np.ndarray, behaviours: Sequence[BehaviourSpec]) -> Pose:
        """Poses for queries (N, D) (``query_array``/``snapshot_array``) and N behaviours."""
        return self.pose_from_weights(self.weights_array(q, behaviours))

    def pose_from_weights(self, w: np.ndarray) -> Pose:
        """The convex combination of the stored keys with weights (N, K).

        Root offsets blend linearly; rotations are sign-aligned to each query's heaviest key,
        summed with the weights and normalised. Only the keys with non-zero weight take part, so the
        cost grows with the number of keys that blend, not the set's size.
        """
        w = np.asarray(w, dtype=float).reshape(-1, len(self.key_names))
        nnz = max(1, int(np.count_nonzero(w, axis=1).max(initial=1)))
        if nnz < w.shape[1]:
            idx = np.argpartition(w, w.shape[1] - nnz, axis=1)[:, -nnz:]
        else:
            idx = np.broadcast_to(np.arange(w.shape[1]), w.shape)
        wt = np.take_along_axis(w, idx, axis=1)  # (N, L)
        heaviest = np.argmax(w, axis=1)
        signed = self._align[heaviest[:, None], idx] * wt[:, :, None]  # (N, L, 1 + J)
        blended = np.einsum("nlj,nljc->njc", signed, self.key_rotations[idx])
        blended /= np.sqrt(np.einsum("njc,njc->nj", blended, blended))[..., None]
        offsets = np.einsum("nl,nlc->nc", wt, self.key_offsets[idx])  # per row alike, whatever the batch
        return Pose(offsets, blended[:, 0], blended[:, 1:])

    def curve_weights(self, curve: Curve, q: np.ndarray) -> np.ndarray:
        """Weights (N, K) of one animation alone at queries (N, D): its own keys and references."""
        solo = Family(curve.name, curve.behaviour, (curve,), None,
                      frozenset(k for k in curve.keys if isinstance(k, str)))
        return self._alone(solo, q)

    def family_weights(self, name: str, q: np.ndarray) -> np.ndarray:
        """Weights (N, K) of one family alone at queries (N, D) (what a key referring to it gives)."""
        return self._alone(self.families[name], q)

    def _alone(self, fam: Family, q: np.ndarray) -> np.ndarray:
        fams = {f.name: f for f in self.families.values() if f.name in fam.refs} | {fam.name: fam}
        table = BehaviourTable(fam.behaviour, fams, self.space, self.sharpness)
        return table.weights(self.space.clamp(np.asarray(q, dtype=float).reshape(-1, self.space.dims)),
                             len(self.key_names))

    # ------------------------------------------------------------------------ checks

    def _check_meetings(self) -> None:
        """Animations of different families that meet must give the same pose where they meet."""
        anims = self.animations
        for i, a in enumerate(anims):
            for b in anims[i + 1 :]:
                if a.family == b.family or a.behaviour != b.behaviour:
                    continue
                pts = meeting_points(a, b, self.space)
                if len(pts) == 0:
                    continue
                pa = self.pose_from_weights(self.curve_weights(a, pts))
                pb = self.pose_from_weights(self.curve_weights(b, pts))
                dots = np.abs(np.sum(pa.rotations() * pb.rotations(), axis=-1)).clip(0.0, 1.0)
                angle = 2.0 * np.arccos(dots)  # (P, 1 + J)
                doff = np.linalg.norm(pa.root_offset - pb.root_offset, axis=-1)
                bad = (angle.max(axis=1) > MEET_ANGLE) | (doff > MEET_OFFSET)
                if np.any(bad):
                    p = int(np.argmax(bad))
                    j = int(np.argmax(angle[p]))
                    part = "root" if j == 0 else JOINTS[j - 1]
                    at = ", ".join(f"{n}={v:.4g}" for n, v in zip(self.space.axes, pts[p], strict=True))
                    where = f"{self.source}: " if self.source else ""
                    raise KeyframeError(
                        f"{where}animations '{a.name}' and '{b.name}' meet at ({at}) with different poses "
                        f"({part} differs by {math.degrees(angle[p, j]):.2f}°, root offset by {doff[p]:.4f} m); "
                        "give them the same pose there"
                    )
