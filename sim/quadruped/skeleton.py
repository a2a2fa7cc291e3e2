"""The quadruped's skeleton (the paper's Fig. 4) on a URDF body, and analytic leg inverse kinematics.

The body is pybullet_data's laikago (``laikago/laikago_toes_zup.urdf``: z up, x forward, y left; a rigid
chassis, per leg an abduction joint about x, a hip and a knee about y, and a toe sphere). Fig. 4's parts:
- spine: the chassis (a straight line: laikago has no spine joint), from the root to the reference point;
- root: midpoint of the rear hips; reference point: midpoint of the front hips;
- four knees: the lower-leg joints; four ankles: the toes (the feet, whose centres IK places).
Joints outside these (a tail, ears: none on laikago) are never written: they keep their own motion.

``LegGeometry`` is measured from the loaded body at zero joint angles (so ``globalScaling`` and any
URDF with the same joint layout work); ``solve`` is closed-form: abduction from the foot's height and
side offset, then the planar two-link (hip, knee) triangle, knee bent backwards as laikago's are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p
import pybullet_data
from numpy.typing import NDArray

Array = NDArray[np.float64]

# gait order of the symmetrical gait: right fore, right rear, left fore, left rear
LEGS = ("FR", "RR", "FL", "RL")
LEG_NAMES = {"FR": "right fore", "RR": "right rear", "FL": "left fore", "RL": "left rear"}
FRONT = ("FR", "FL")
REAR = ("RR", "RL")
TOE_RADIUS_URDF = 0.03  # laikago's toe collision sphere at scale 1


@dataclass(frozen=True)
class LegGeometry:
    """One leg in the chassis frame (metres, at the loaded scale)."""

    leg: str
    joints: tuple[int, int, int]  # abduction, hip, knee joint indices
    toe_link: int
    knee_link: int
    abduction_at: Array  # the abduction joint's position
    abduction_sign: float  # +1 when the abduction joint turns about +x, -1 about -x
    side_offset: float  # the toe's constant y offset from the abduction axis (in the abducted frame)
    upper: Array  # hip joint → knee joint, (x, z) at zero angles
    lower: Array  # knee joint → toe centre, (x, z) at zero angles

    @property
    def reach(self) -> float:
        return float(np.hypot(*self.upper) + np.hypot(*self.lower))

    def solve(self, toe: Array) -> tuple[tuple[float, float, float], bool]:
        """Joint angles (abduction, hip, knee) putting the toe centre at ``toe`` (chassis frame), and
        whether it is reachable (when not, the angles reach as near as they can, leg straight)."""
        d = np.asarray(toe, dtype=np.float64) - self.abduction_at
        ly = self.side_offset
        r2 = d[1] * d[1] + d[2] * d[2]
        ok = True
        if r2 < ly * ly + 1e-12:
            r2, ok = ly * ly + 1e-12, False
        zp = -math.sqrt(r2 - ly * ly)
        q0 = math.atan2(d[2], d[1]) - math.atan2(zp, ly)
        l1, l2 = float(np.hypot(*self.upper)), float(np.hypot(*self.lower))
        dist = math.hypot(d[0], zp)
        c = (dist * dist - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
        if c > 1.0 or c < -1.0:
            ok = False
            c = max(-1.0, min(1.0, c))
        phi1 = math.atan2(self.upper[1], self.upper[0])
        phi2 = math.atan2(self.lower[1], self.lower[0])
        q2 = phi2 - phi1 - math.acos(c)
        # v = upper + R_y(q2) lower, R_y(q) turns an (x, z) angle by -q
        a2 = phi2 - q2
        vx = self.upper[0] + l2 * math.cos(a2)
        vz = self.upper[1] + l2 * math.sin(a2)
        q1 = math.atan2(vz, vx) - math.atan2(zp, d[0])
        wrap = math.remainder
        return (wrap(self.abduction_sign * q0, math.tau), wrap(q1, math.tau), wrap(q2, math.tau)), ok


@dataclass(frozen=True)
class Skeleton:
    """A loaded quadruped body and its Fig. 4 parts."""

    body: int
    legs: dict[str, LegGeometry]
    link_names: tuple[str, ...]  # per link index (-1 = base is "chassis", not listed)
    scale: float
    toe_radius: float
    stand_height: float  # chassis origin above the toes at zero angles

    def hip(self, leg: str) -> Array:
        """The abduction joint of ``leg`` in the chassis frame."""
        return self.legs[leg].abduction_at

    @property
    def root(self) -> Array:
        """Fig. 4's root: midpoint of the rear hips (chassis frame)."""
        out: Array = 0.5 * (self.hip("RR") + self.hip("RL"))
        return out

    @property
    def reference_point(self) -> Array:
        """Fig. 4's reference point: midpoint of the front hips (chassis frame)."""
        out: Array = 0.5 * (self.hip("FR") + self.hip("FL"))
        return out


def load_laikago(client: int, scale: float, urdf: str = "laikago/laikago_toes_zup_lores.urdf") -> Skeleton:
    """Load ``urdf`` (relative to pybullet_data, or absolute) at ``scale`` and measure its legs."""
    path = urdf if urdf.startswith("/") else f"{pybullet_data.getDataPath()}/{urdf}"
    body: int = p.loadURDF(path, (0.0, 0.0, 5.0), (0.0, 0.0, 0.0, 1.0), globalScaling=scale,
                           flags=p.URDF_MAINTAIN_LINK_ORDER, physicsClientId=client)
    n = p.getNumJoints(body, physicsClientId=client)
    names = []
    index: dict[str, int] = {}
    for j in range(n):
        info = p.getJointInfo(body, j, physicsClientId=client)
        index[info[1].decode()] = j
        names.append(info[12].decode())
        p.resetJointState(body, j, 0.0, 0.0, physicsClientId=client)
    base_pos, base_orn = p.getBasePositionAndOrientation(body, physicsClientId=client)
    inv_pos, inv_orn = p.invertTransform(base_pos, base_orn)

    def local(link: int) -> Array:
        state = p.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)
        pos, _ = p.multiplyTransforms(inv_pos, inv_orn, state[4], state[5])
        return np.array(pos)

    def axis_x(joint: int) -> float:
        info = p.getJointInfo(body, joint, physicsClientId=client)
        state = p.getLinkState(body, joint, computeForwardKinematics=True, physicsClientId=client)
        _, orn = p.multiplyTransforms(inv_pos, inv_orn, state[4], state[5])
        rot = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        return float(np.sign((rot @ np.array(info[13]))[0]))

    legs: dict[str, LegGeometry] = {}
    for leg in LEGS:
        try:
            abd = index[f"{leg}_hip_motor_2_chassis_joint"]
            hip = index[f"{leg}_upper_leg_2_hip_motor_joint"]
            knee = index[f"{leg}_lower_leg_2_upper_leg_joint"]
            toe = index[f"jtoe{leg}"]
        except KeyError as e:
            raise ValueError(f"urdf: {path} has no joint {e.args[0]} (expected laikago's joint names)") from None
        a, h, k, t = local(abd), local(hip), local(knee), local(toe)
        legs[leg] = LegGeometry(leg, (abd, hip, knee), toe, knee, a, axis_x(abd), float(t[1] - a[1]),
                                np.array([k[0] - h[0], k[2] - h[2]]), np.array([t[0] - k[0], t[2] - k[2]]))
    stand = -float(np.mean([local(legs[leg].toe_link)[2] for leg in LEGS]))
    return Skeleton(body, legs, tuple(names), scale, TOE_RADIUS_URDF * scale, stand)
