"""The skeletons keyframe sets may name, and the figure drawn on each: capsules between points of the
skeleton, with radii and materials, and the link masses that place its centre of mass.

- ``humanoid``: the DeepMimic humanoid (``sim.motion.mocap.HUMANOID``), 1.62 m standing.
- ``critter``: the same joints with a small creature's proportions — a big head, a stout trunk, short
  arms and short legs (for the 0.8 m, 12 kg character). Poses made for the humanoid drive it as
  they are: every joint keeps its name and its axes; only bone lengths, radii and masses differ.
"""

from __future__ import annotations

import numpy as np

from sim.motion.mocap import HUMANOID, URDF_SCALE, Skeleton

SHIRT, TROUSERS, SKIN, SHOES = 0, 1, 2, 3


class Figure:
    """A skeleton with what is drawn on it and how its mass is spread.

    ``points``: named points (joint a, joint b, t) = a + t·(b − a); ``capsules``: (point, point,
    radius in skeleton metres, material). ``masses``: (bone, kg, centre of mass in the bone's frame).
    """

    def __init__(
        self,
        name: str,
        skeleton: Skeleton,
        points: dict[str, tuple[int, int, float]],
        capsules: tuple[tuple[str, str, float, int], ...],
        masses: tuple[tuple[str, float, tuple[float, float, float]], ...],
    ) -> None:
        self.name, self.skeleton, self.points, self.capsules, self.masses = name, skeleton, points, capsules, masses
        a = np.array([points[p] for p, _, _, _ in capsules], dtype=float)
        b = np.array([points[p] for _, p, _, _ in capsules], dtype=float)
        self.a_idx, self.a_t = a[:, :2].astype(int), a[:, 2]
        self.b_idx, self.b_t = b[:, :2].astype(int), b[:, 2]
        self.radii = np.array([r for _, _, r, _ in capsules])
        self.material = np.array([m for _, _, _, m in capsules])
        self.mass_idx = np.array([skeleton.names.index(n) for n, _, _ in masses])
        self.mass_kg = np.array([m for _, m, _ in masses])
        self.mass_off = np.array([o for _, _, o in masses])


def _points(s: Skeleton, head: tuple[float, float, float], hand: float) -> dict[str, tuple[int, int, float]]:
    n = s.names.index
    pts = {name: (n(name), n(name), 0.0) for name in s.names}
    pts |= {
        "head_low": (n("neck"), n("head_top"), head[0]),
        "head_high": (n("neck"), n("head_top"), head[1]),
        "neck_top": (n("neck"), n("head_top"), head[2]),
        "belly": (n("root"), n("chest"), 0.15),
        "right_hand": (n("right_elbow"), n("right_wrist"), hand),
        "left_hand": (n("left_elbow"), n("left_wrist"), hand),
        "right_heel": (n("right_ankle"), n("right_toe"), -0.25),
        "left_heel": (n("left_ankle"), n("left_toe"), -0.25),
    }
    return pts


def _capsules(r: dict[str, float]) -> tuple[tuple[str, str, float, int], ...]:
    """The 18 capsules of a figure with radii by part."""
    out: list[tuple[str, str, float, int]] = [
        ("right_hip", "left_hip", r["pelvis"], TROUSERS),
        ("belly", "chest", r["belly"], SHIRT),
        ("chest", "neck", r["chest"], SHIRT),
        ("right_shoulder", "left_shoulder", r["shoulders"], SHIRT),
        ("neck", "neck_top", r["neck"], SKIN),
        ("head_low", "head_high", r["head"], SKIN),
    ]
    for side in ("right", "left"):
        out += [
            (f"{side}_shoulder", f"{side}_elbow", r["upper_arm"], SHIRT),
            (f"{side}_elbow", f"{side}_wrist", r["forearm"], SKIN),
            (f"{side}_wrist", f"{side}_hand", r["hand"], SKIN),
            (f"{side}_hip", f"{side}_knee", r["thigh"], TROUSERS),
            (f"{side}_knee", f"{side}_ankle", r["shin"], TROUSERS),
            (f"{side}_heel", f"{side}_toe", r["foot"], SHOES),
        ]
    return tuple(out)


# link masses (kg) and centres of mass in the link frame, from pybullet_data/humanoid/humanoid.urdf
_HUMANOID_MASS = [
    ("root", 6.0, (0.0, 0.28, 0.0)),
    ("chest", 14.0, (0.0, 0.48, 0.0)),
    ("neck", 2.0, (0.0, 0.70, 0.0)),
    ("right_hip", 4.5, (0.0, -0.84, 0.0)),
    ("right_knee", 3.0, (0.0, -0.80, 0.0)),
    ("right_ankle", 1.0, (0.18, -0.09, 0.0)),
    ("right_shoulder", 1.5, (0.0, -0.56, 0.0)),
    ("right_elbow", 1.0, (0.0, -0.48, 0.0)),
    ("right_wrist", 0.5, (0.0, 0.0, 0.0)),
]
_HUMANOID_MASS += [(n.replace("right", "left"), m, o) for n, m, o in _HUMANOID_MASS if n.startswith("right")]

HUMANOID_FIGURE = Figure(
    "humanoid",
    HUMANOID,
    _points(HUMANOID, (0.42, 0.62, 0.25), 1.28),
    _capsules({"pelvis": 0.085, "belly": 0.105, "chest": 0.12, "shoulders": 0.07, "neck": 0.045, "head": 0.098,
               "upper_arm": 0.05, "forearm": 0.04, "hand": 0.045, "thigh": 0.07, "shin": 0.055, "foot": 0.042}),
    tuple((n, m, (o[0] * URDF_SCALE, o[1] * URDF_SCALE, o[2] * URDF_SCALE)) for n, m, o in _HUMANOID_MASS),
)

# ------------------------------------------------------------------------------ the critter

# bone length factors against the humanoid, by the bone's own name (its offset from its parent)
_CRITTER_LENGTH = {
    "chest": 0.75, "neck": 0.7, "head_top": 1.7,
    "right_hip": 1.25, "left_hip": 1.25, "right_knee": 0.55, "left_knee": 0.55,
    "right_ankle": 0.5, "left_ankle": 0.5, "right_toe": 0.8, "left_toe": 0.8,
    "right_shoulder": 1.0, "left_shoulder": 1.0, "right_elbow": 0.62, "left_elbow": 0.62,
    "right_wrist": 0.6, "left_wrist": 0.6,
}


def _critter() -> Figure:
    offsets = HUMANOID.offsets.copy()
    for i, name in enumerate(HUMANOID.names):
        offsets[i] *= _CRITTER_LENGTH.get(name, 1.0)
    skel = Skeleton(HUMANOID.names, HUMANOID.parents, offsets)
    # a link's centre of mass scales with the bone it runs along (its first child's offset)
    masses = []
    child_of = {HUMANOID.names[HUMANOID.parents[b]]: HUMANOID.names[b] for b in range(len(HUMANOID.names) - 1, 0, -1)}
    kg = {"root": 2.0, "chest": 3.5, "neck": 2.2, "hip": 0.9, "knee": 0.45, "ankle": 0.2, "shoulder": 0.3,
          "elbow": 0.2, "wrist": 0.1}
    for name, _, off in _HUMANOID_MASS:
        k = _CRITTER_LENGTH.get(child_of.get(name, name), 1.0)
        f = URDF_SCALE * k
        masses.append((name, kg[name.split("_")[-1]], (off[0] * f, off[1] * f, off[2] * f)))
    radii = {"pelvis": 0.1, "belly": 0.15, "chest": 0.15, "shoulders": 0.085, "neck": 0.06, "head": 0.2,
             "upper_arm": 0.06, "forearm": 0.055, "hand": 0.06, "thigh": 0.085, "shin": 0.07, "foot": 0.06}
    return Figure("critter", skel, _points(skel, (0.38, 0.56, 0.2), 1.3), _capsules(radii), tuple(masses))


CRITTER_FIGURE = _critter()
FIGURES: dict[str, Figure] = {"humanoid": HUMANOID_FIGURE, "critter": CRITTER_FIGURE}
SKELETONS: dict[str, Skeleton] = {name: f.skeleton for name, f in FIGURES.items()}


def figure_for(skeleton: Skeleton) -> Figure:
    """The figure drawn on a skeleton (by identity; a skeleton no figure knows is an error)."""
    for f in FIGURES.values():
        if f.skeleton is skeleton:
            return f
    raise KeyError("render: no figure for this skeleton; add one to render.keyframes.skeletons.FIGURES")
