"""PD tracking of desired joint rotations: explicit PD and pybullet's stable PD, plus joint limits.

Explicit PD (seed eq. 3.1), per joint in the child link's frame:
    τ = Kp·log(q⁻¹ q_d) + Kd·(ω_d − ω)  [N·m; rotations in rad, rates in rad/s], clamped to the joint's
torque limit, applied with ``TORQUE_CONTROL``. Stable PD (Tan et al. 2011) evaluates the same law at the
next step's state, implicitly, through pybullet's ``STABLE_PD_CONTROL``; it stays stable at gains where
the explicit law explodes at 1/240 s. Both are issued every physics step (pybullet clears applied joint
torques after each ``stepSimulation``).

Limits: desired rotations are clamped into the joint's limits before they are tracked, and pybullet
enforces them as soft constraints (hinges: their range; ball/universal: the URDF's spherical limit,
``sim.articulated.joint_limit``); ``limit_excess`` says by how much (degrees) a pose is past them (0
inside). What keeps a recovering body inside is ``sim.articulated.recovery``.
Experiments on harder limits (what was tried, with figures): docs/notes/tracking.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p

from sim.articulated.joint_limit import (
    CLAMP_MARGIN,
    clamp_inside,
    limit_angles,
    limit_angles_one,
    limit_excess,
    limit_ranges,
)
from sim.articulated.reference import quat_exp, quat_log
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.motion import quaternion as quat


@dataclass(frozen=True, eq=False)
class PDCommand:
    """Targets and gains of one control update, kept to be re-issued every physics step until the next."""

    rots: np.ndarray
    omegas: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    fmax: np.ndarray
    positions: list[list[float]]
    velocities: list[list[float]]
    forces: list[list[float]]
    kp_list: list[float]
    kd_list: list[float]


class JointLimits:
    """Limits of the driven joints (in ``driven`` order), vectorised. Ball/universal joints are measured as
    pybullet's spherical limit measures them (``sim.articulated.joint_limit``)."""

    def __init__(self, skeleton: ArticulatedSkeleton, driven: tuple[int, ...]) -> None:
        links = [skeleton.links[i] for i in driven]
        self.hinge = np.array([link.kind == "hinge" for link in links])
        self.axis = np.array([link.axis for link in links], dtype=float)
        self.lower = np.array([link.lower if link.kind == "hinge" else 0.0 for link in links])
        self.upper = np.array([link.upper if link.kind == "hinge" else 0.0 for link in links])
        self.ranges = np.array([limit_ranges(link, skeleton.up_axis) for link in links])  # (D, 3): x, y, z
        self._ball = np.nonzero(~self.hinge)[0]

    def _hinge_angles(self, rots: np.ndarray) -> np.ndarray:
        out: np.ndarray = np.sum(quat_log(rots) * self.axis, axis=-1)
        return out

    def clamp_one(self, q: np.ndarray, k: int) -> np.ndarray:
        """``clamp`` for joint ``k`` alone (the per-update path)."""
        if self.hinge[k]:
            ax, ay, az = (float(v) for v in self.axis[k])
            angle = min(max(self._hinge_angle_one(q, k), float(self.lower[k])), float(self.upper[k]))
            h = 0.5 * angle
            return np.array([ax * math.sin(h), ay * math.sin(h), az * math.sin(h), math.cos(h)])
        ranges = self.ranges[k]
        if all(abs(a) <= float(r) - CLAMP_MARGIN for a, r in zip(limit_angles_one(q), ranges, strict=True)):
            return np.asarray(q, dtype=float) / float(np.linalg.norm(q))
        out: np.ndarray = clamp_inside(np.asarray(q, dtype=float)[None], self.ranges[k:k + 1])[0]
        return out

    def worst_excess(self, rots: np.ndarray) -> float:
        """``excess(rots).max()`` in float arithmetic, joint by joint (a few µs each: cheap enough to watch
        every physics step)."""
        worst = 0.0
        for k, q in enumerate(rots):
            if self.hinge[k]:
                angle = self._hinge_angle_one(q, k)
                outside = min(max(float(self.lower[k]) - a, a - float(self.upper[k]), 0.0)
                              for a in (angle - 2.0 * math.pi, angle, angle + 2.0 * math.pi))
            else:
                outside = max(abs(a) - float(r) for a, r in zip(limit_angles_one(q), self.ranges[k], strict=True))
            worst = max(worst, outside)
        return worst

    def _hinge_angle_one(self, q: np.ndarray, k: int) -> float:
        """The angle of rotation q about hinge k's axis (as ``_hinge_angles``: the log's component along it)."""
        x, y, z, w = (float(v) for v in q)
        if w < 0.0:
            x, y, z, w = -x, -y, -z, -w
        ax, ay, az = (float(v) for v in self.axis[k])
        s = math.sqrt(x * x + y * y + z * z)
        return 2.0 * math.atan2(s, w) * ((x * ax + y * ay + z * az) / s if s > 1e-12 else 0.0)

    def _hinge_nearest(self, rots: np.ndarray) -> np.ndarray:
        """Hinge angles (D,), each taken a turn up or down where that puts it nearer its range (a knee folded
        to its −3.14 limit reads +3.14)."""
        angle = self._hinge_angles(rots)[:, None] + np.array([-2.0 * math.pi, 0.0, 2.0 * math.pi])
        outside = np.maximum(np.maximum(self.lower[:, None] - angle, angle - self.upper[:, None]), 0.0)
        out: np.ndarray = np.take_along_axis(angle, np.argmin(outside, axis=1)[:, None], axis=1)[:, 0]
        return out

    def near(self, rots: np.ndarray, margin: float) -> np.ndarray:
        """(D,) bool: each joint within ``margin`` (radians) of its limits, or past them."""
        angle = self._hinge_nearest(rots)
        out = (angle < self.lower + margin) | (angle > self.upper - margin)
        b = self._ball
        out[b] = np.any(np.abs(limit_angles(rots[b])) > self.ranges[b] - margin, axis=-1)
        return out

    def clamp_within(self, rots: np.ndarray, margin: float) -> np.ndarray:
        """The rotations (D, 4) brought at least ``margin`` inside every limit (as ``clamp``)."""
        m = np.minimum(margin, 0.5 * (self.upper - self.lower))
        angle = np.clip(self._hinge_nearest(rots), self.lower + m, self.upper - m)
        out: np.ndarray = np.where(self.hinge[:, None], quat_exp(self.axis * angle[:, None]), rots)
        b = self._ball
        out[b] = clamp_inside(rots[b], self.ranges[b], margin)
        return out

    def clamp(self, rots: np.ndarray) -> np.ndarray:
        """The rotations (D, 4) brought inside the limits (hinges: the range; ball/universal: the twist
        clamped, the swing shortened along its arc)."""
        angle = np.clip(self._hinge_angles(rots), self.lower, self.upper)
        out: np.ndarray = np.where(self.hinge[:, None], quat_exp(self.axis * angle[:, None]), rots)
        b = self._ball
        out[b] = clamp_inside(rots[b], self.ranges[b])
        return out

    def excess(self, rots: np.ndarray) -> np.ndarray:
        """Radians by which each joint (D,) is outside its limits (0 inside)."""
        angle = self._hinge_nearest(rots)
        out = np.where(self.hinge, np.maximum(np.maximum(self.lower - angle, angle - self.upper), 0.0), 0.0)
        b = self._ball
        out[b] = limit_excess(rots[b], self.ranges[b])
        return out


class JointTracker:
    """Reads and drives the driven joints of one multibody (skeleton link i = pybullet link i − 1)."""

    def __init__(self, client: int, body: int, skeleton: ArticulatedSkeleton, spec: ArticulatedSpec,
                 driven: tuple[int, ...]) -> None:
        self._client = client
        self._body = body
        self.driven = driven
        self.indices = [i - 1 for i in driven]
        self.limits = JointLimits(skeleton, driven)
        gains = [spec.gains(skeleton.links[i].gain_group) for i in driven]
        self.kp = np.array([g[0] for g in gains])
        self.kd = np.array([g[1] for g in gains])
        self.max_torque = np.array([g[2] for g in gains])
        self.hinge = self.limits.hinge
        self.axis = self.limits.axis
        self.mode = spec.pd

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations (D, 4) and angular velocities (D, 3, child frame) of the driven joints."""
        states = p.getJointStatesMultiDof(self._body, self.indices, physicsClientId=self._client)
        rots = np.empty((len(self.indices), 4))
        omegas = np.empty((len(self.indices), 3))
        for k, (pos, vel, _, _) in enumerate(states):
            if self.hinge[k]:
                rots[k] = quat_exp(self.axis[k] * pos[0])
                omegas[k] = self.axis[k] * vel[0]
            else:
                rots[k] = pos
                omegas[k] = vel
        return rots, omegas

    def command(self, target_rots: np.ndarray, target_omegas: np.ndarray, scale: np.ndarray) -> PDCommand:
        """The drive toward the targets with gains and torque limits × ``scale`` (D,) (0: limp); ``issue`` it
        every physics step until the next command."""
        kp = self.kp * scale
        kd = self.kd * scale
        fmax = self.max_torque * np.maximum(scale, 0.0)
        positions: list[list[float]] = []
        velocities: list[list[float]] = []
        forces: list[list[float]] = []
        hinge_angles = np.sum(quat_log(target_rots) * self.axis, axis=-1)
        for k in range(len(self.indices)):
            f = float(fmax[k])
            if self.hinge[k]:
                positions.append([float(hinge_angles[k])])
                velocities.append([float(np.dot(target_omegas[k], self.axis[k]))])
                forces.append([f])
            else:
                positions.append([float(v) for v in target_rots[k]])
                velocities.append([float(v) for v in target_omegas[k]])
                forces.append([f, f, f])
        return PDCommand(target_rots, target_omegas, kp, kd, fmax, positions, velocities, forces,
                         [float(v) for v in kp], [float(v) for v in kd])

    def issue(self, cmd: PDCommand) -> None:
        """Apply ``cmd`` for this physics step (stable PD, or explicit PD from the current joint state)."""
        if self.mode == "stable":
            p.setJointMotorControlMultiDofArray(
                self._body, self.indices, p.STABLE_PD_CONTROL, targetPositions=cmd.positions,
                targetVelocities=cmd.velocities, forces=cmd.forces, positionGains=cmd.kp_list,
                velocityGains=cmd.kd_list, physicsClientId=self._client)
            return
        rots, omegas = self.read()
        err = quat_log(quat.multiply(quat.conjugate(rots), cmd.rots))
        tau = cmd.kp[:, None] * err + cmd.kd[:, None] * (cmd.omegas - omegas)
        norm = np.linalg.norm(tau, axis=-1)
        tau *= np.minimum(1.0, cmd.fmax / np.maximum(norm, 1e-12))[:, None]
        self.apply_torques(tau)

    def apply_torques(self, tau: np.ndarray) -> None:
        """Joint torques (D, 3) in each child frame (hinges: the component along the axis)."""
        forces = [[float(np.dot(tau[k], self.axis[k]))] if self.hinge[k] else [float(v) for v in tau[k]]
                  for k in range(len(self.indices))]
        p.setJointMotorControlMultiDofArray(self._body, self.indices, p.TORQUE_CONTROL, forces=forces,
                                            physicsClientId=self._client)

    def tracking_error(self, rots: np.ndarray, target_rots: np.ndarray) -> np.ndarray:
        """Angle (radians, D) between each joint's rotation and its target."""
        out: np.ndarray = np.linalg.norm(quat_log(quat.multiply(quat.conjugate(rots), target_rots)), axis=-1)
        return out
