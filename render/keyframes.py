"""Multidimensional keyframe sets (Mitake et al. 2009 §5): poses at points of Q = (Θx, Θz, Dx, Dz, B).

- Θx: lean forward (+) / backward (−), Θz: lean right (+) / left (−), radians — the identity map of
  the sim's ``CharacterSnapshot.tilt``.
- Dx = p(d_side), Dz = p(d_front) with p(x) = x − ⌊x⌋: the phase of sideways / forward travel.
- B: a behaviour name (e.g. "walk", "stand_up"). A B the set lacks falls back to the set's
  default behaviour, with one warning per name.

A pose is a root offset (3, metres), a root rotation and per-joint rotations (``JOINTS`` order,
quaternions x y z w), all in the *rigid body's* frame with the skeleton's axes (x forward, y up,
z right): the renderer places it with the body's position and orientation and scales it to the
character's height. In the shipped sets the root offset puts the skeleton's centre of mass at the
body's origin (the sim's centre of mass).

How poses are interpolated is in ``render.interp``; the file format in ``render.keyframe_file``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from render import quaternion as quat
from render.interp import AXES, Curve, Family, Interpolator, meeting_points
from render.keyframe_file import KeyframeError, SetData, read_set
from render.mocap import JOINTS, Skeleton
from sim.snapshot import CharacterSnapshot

__all__ = ["KeyframeError", "KeyframeQuery", "KeyframeSet", "Pose", "periodic", "query_from_snapshot"]

MEET_ANGLE = math.radians(0.05)  # animations that meet must agree to this (per joint) …
MEET_OFFSET = 1e-4  # … and to this many metres of root offset


def periodic(x: float) -> float:
    """p(x) = x − ⌊x⌋ (Mitake eq. 8)."""
    return x - math.floor(x)


@dataclass(frozen=True, slots=True)
class KeyframeQuery:
    """A point of the keyframe space. ``dx``/``dz`` are phases; any real is taken modulo 1."""

    theta_x: float
    theta_z: float
    dx: float
    dz: float
    behaviour: str

    def __post_init__(self) -> None:
        for name in ("theta_x", "theta_z", "dx", "dz"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ValueError(f"{name}: expected a finite number, got {v!r}")
        if not isinstance(self.behaviour, str) or not self.behaviour:
            raise ValueError(f"behaviour: expected a behaviour name, got {self.behaviour!r}")

    def as_array(self) -> np.ndarray:
        return np.array([self.theta_x, self.theta_z, self.dx, self.dz], dtype=float)


def query_from_snapshot(c: CharacterSnapshot) -> KeyframeQuery:
    """The correspondence function (Mitake §5.2): identity for tilt, p() of the travelled distances."""
    return KeyframeQuery(
        theta_x=float(c.tilt[0]),
        theta_z=float(c.tilt[1]),
        dx=periodic(float(c.d_side)),
        dz=periodic(float(c.d_front)),
        behaviour=c.behaviour,
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
    """A keyframe set for one skeleton: ``pose(q)`` for one query, ``poses(qs)`` for many at once."""

    def __init__(self, data: SetData, source: Path | None = None) -> None:
        self.source = source
        self.skeleton: Skeleton = data.skeleton
        self.height = data.height
        self.default_behaviour = data.default_behaviour
        self.families: dict[str, Family] = data.families
        self.key_names = data.key_names
        self.key_offsets = data.key_offsets
        rots = quat.normalize(data.key_rotations)
        self.key_rotations = np.where(rots[..., 3:4] < 0, -rots, rots)  # one hemisphere: w >= 0
        self.interpolator = Interpolator(
            data.families, len(data.key_names), cycle_weight=data.cycle_weight, sharpness=data.sharpness
        )
        self._warned: set[str] = set()
        self._check_meetings()

    @classmethod
    def load(cls, path: str | Path) -> KeyframeSet:
        """Read ``keyframes.toml`` and its pose files; KeyframeError (one line) when anything is wrong."""
        return cls(read_set(path), Path(path))

    @property
    def behaviours(self) -> tuple[str, ...]:
        return tuple(sorted(self.interpolator.by_behaviour))

    @property
    def animations(self) -> tuple[Curve, ...]:
        return tuple(m for f in self.families.values() for m in f.members)

    def resolve(self, behaviour: str) -> str:
        """The behaviour the set will use for B: itself, or the default (warned once per name)."""
        if behaviour in self.interpolator.by_behaviour:
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

    # ------------------------------------------------------------------------ evaluation

    def weights(self, qs: Sequence[KeyframeQuery]) -> np.ndarray:
        """Blend weights (N, K) over ``key_names``: every entry ≥ 0, every row sums to 1."""
        arr = np.array([q.as_array() for q in qs], dtype=float).reshape(-1, 4)
        return self.weights_array(arr, [q.behaviour for q in qs])

    def weights_array(self, q: np.ndarray, behaviours: Sequence[str]) -> np.ndarray:
        """As ``weights`` for queries given as an (N, 4) array (Θx, Θz, Dx, Dz) and N behaviour names."""
        q = np.asarray(q, dtype=float).reshape(-1, 4)
        resolved = np.array([self.resolve(b) for b in behaviours], dtype=object)
        out = np.zeros((len(q), len(self.key_names)))
        for b in sorted(set(resolved.tolist())):
            sel = resolved == b
            out[sel] = self.interpolator.weights(q[sel], b)
        return out

    def pose(self, q: KeyframeQuery) -> Pose:
        return self.poses([q])[0]

    def poses(self, qs: Sequence[KeyframeQuery]) -> Pose:
        """Poses for many queries at once (vectorised)."""
        return self.pose_from_weights(self.weights(qs))

    def pose_from_weights(self, w: np.ndarray) -> Pose:
        """The convex combination of the stored keys with weights (N, K).

        Root offsets blend linearly; rotations are sign-aligned to each query's heaviest key,
        summed with the weights and normalised (``quaternion.blend``). Only the keys with non-zero
        weight take part, so the cost grows with the number of keys that blend, not the set's size.
        """
        w = np.asarray(w, dtype=float).reshape(-1, len(self.key_names))
        nnz = max(1, int((w > 0).sum(axis=1).max(initial=1)))
        idx = np.argsort(-w, axis=1, kind="stable")[:, :nnz]
        wt = np.take_along_axis(w, idx, axis=1)  # (N, L)
        rots = self.key_rotations[idx]  # (N, L, 1 + J, 4)
        blended = quat.blend(np.swapaxes(rots, 1, 2), wt[:, None, :])  # (N, 1 + J, 4)
        offsets = np.einsum("nl,nlc->nc", wt, self.key_offsets[idx])
        return Pose(offsets, blended[:, 0], blended[:, 1:])

    def curve_weights(self, curve: Curve, q: np.ndarray) -> np.ndarray:
        """Weights (N, K) of one animation alone at queries (N, 4) — its own keys and references."""
        fam = self.families[curve.family]
        refs = self.interpolator.referenced(q, set(fam.refs))
        return self.interpolator.curve_weights(curve, q, refs)

    # ------------------------------------------------------------------------ checks

    def _check_meetings(self) -> None:
        """Animations of different families that meet must give the same pose where they meet."""
        anims = self.animations
        for i, a in enumerate(anims):
            for b in anims[i + 1 :]:
                if a.family == b.family or a.behaviour != b.behaviour:
                    continue
                pts = meeting_points(a, b)
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
                    at = ", ".join(f"{n}={v:.4g}" for n, v in zip(AXES, pts[p], strict=True))
                    where = f"{self.source}: " if self.source else ""
                    raise KeyframeError(
                        f"{where}animations '{a.name}' and '{b.name}' meet at ({at}) with different poses "
                        f"({part} differs by {math.degrees(angle[p, j]):.2f}°, root offset by {doff[p]:.4f} m); "
                        "give them the same pose there"
                    )
