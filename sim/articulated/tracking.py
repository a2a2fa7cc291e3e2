"""PD tracking of desired joint rotations: explicit PD and pybullet's stable PD, plus joint limits.

Explicit PD (seed eq. 3.1), per joint in the child link's frame:
    τ = Kp·log(q⁻¹ q_d) + Kd·(ω_d − ω), clamped to the joint's torque limit,
applied with ``TORQUE_CONTROL``. Stable PD (Tan et al. 2011) evaluates the same law at the *next* step's
state, implicitly, through pybullet's ``STABLE_PD_CONTROL`` in ``setJointMotorControlMultiDofArray``; it
stays stable at gains where the explicit law explodes at 1/240 s. Both are issued every physics step
(pybullet clears applied joint torques after each ``stepSimulation``).

Limits: desired rotations are clamped into the joint's limits before they are tracked, and pybullet
enforces them as constraints (hinges: their range; ball/universal: the spherical joint limit of the URDF the
body is loaded from, measured as ``sim.articulated.joint_limit`` says). Those constraints act only once a
joint is past its limit, and a fast compound swing can carry it well past (``jostle bench ragdoll``'s
``joint_limit_excess_deg``); ``limit_excess`` measures by how much a pose is outside the limits (0 inside).
Measured on one hip held at rest (no gravity, pelvis fixed) under a steady 150 N·m: the spherical limit
alone lets it go 20–60° past, its rows pushing along the child frame's axes while the angle grows along
the others. Harder stops were tried on the bench's push sweep (4 phases each way; default: worst 22.4°,
pushes survived ≥ 280 N forward, ≥ 300 N sideways at every phase): a joint past its limit driven by
pybullet's spherical motor toward zero outward velocity (every physics step, up to 200–1000 N·m) cut the
worst excess to 11.9–15.1°, but a sideways push of 100 N then felled it at one phase (forward: 180–220 N);
a stiff stable PD toward the nearest pose inside (30× the joint's gains; 100× diverges) 16.9° and
again 100 N sideways at one phase; the engine's limits 8° inside the skeleton's, 16.2° with the pushes
kept. The recovering steps of a near-fall swing a hip past its limits, and stops there take that step
away. (Splitting one step's ``STABLE_PD_CONTROL`` over two calls, each for some of the joints, is no way
to mix modes: the body falls at once, as if only the last call acted; measured.)
Hips (and ankles) built as three revolute joints in series, with two light links between, were tried
too: pybullet's revolute limit is no harder (its row also waits until the joint is past, and with split
impulse on, as the world has it, a joint more than ~2.3° past stays there under a steady torque). Best
measured, hips and ankles hinged in x-y-z order: worst excess 18.3°, pushes 240 / 300 N kept, but
walk-offs after a get-up 4 of 8 (7 of 8 as built here); other orders and link masses did worse.
Also measured on the same sweep and not kept: the engine's ball/universal limits 12 / 15 / 18° inside the
skeleton's: worst 10.1 / 6.4 / 8.8°, but sideways minimum 300 / 200 / 100 N and walk-offs 3 / 0 / 0 of 8
(15° on the twist alone, of every ball joint / of the hips: 16.9 / 13.7°, walk-offs 6 / 5 of 8,
sideways minimum 100 / 300 N); a stop
as an internal torque pair on the two links of a joint (sized from the two sides' inertia about the
limited axis, to stop in the coming step what would cross the limit): a 100 N push then throws the body
far, the pair saturating (a planted foot makes the inertia seen at a hip, knee or ankle far larger than
its links'); and a joint past its limit set back onto it after each step (resetJointStateMultiDof, its
outward rate removed: the child links jump, and a planted foot slides): worst 0°, but forward pushes of
80–100 N fell it and no get-up stood (positions only: 100 N sideways at one phase, 6 of 8 get-ups).
Joint damping on every joint (``changeDynamics`` ``jointDamping`` 1 or 5, to slow the swings that carry a
joint past) makes it fall while walking, before any push (measured).
Where the worst excesses happen (the sweep, logged step by step): a hip 60° sideways driven to 82° in
6 steps, both feet down, the pelvis turning at 10–17 rad/s; a hip's twist 40° → 56° with both feet off
the ground; one at 74° sideways with the pelvis at 60 rad/s: fast turns of the light pelvis under the
walking assist (150 N·m on it) and the torso pair. Spreading that assist over the whole body (the same
torque about the centre of mass, as forces m·α×r on every link: no strain on the joints) leaves it
unable to balance: pushes of 0–80 N fell it at some phases (over the pelvis and the chest, by mass or
half each: 80–160 N) (measured). Without the assist, or at 75 N·m,
it falls walking.
The assist re-evaluated every physics step instead of held between control updates (its damping 5 /
8 / 10 / 15 N·m·s/rad; walking off after a get-up as before): worst 29.1 / 12.8 / 16.2 / 20.5°, walk-offs
7 / 8 / 4 / 6 of 8, pushes kept; but at 8, over 8 phases, 23.3° and 180 N forward at one. Each of these
changes moves the sweep's figures about as much as any other: one push sweep is a single sample of a
chaotic system, and a change is kept only when it holds over 8 phases as well.
More solver iterations (30 / 100; the world runs 10) do not harden the limits: 25.8 / 31.4°.
Also measured on the sweep and not kept: the pelvis's rotational inertia raised 3 / 5 / 10× (its mass
kept; a pelvis of de Leva's proportions would be about 2.5×), so that the assist turns it less: worst
16.7 / 18.0 / 13.4°, sideways minimum 220 / 320 / 320 N, walk-offs 6 / 8 / 6 of 8; with the chest's 2.5–3×
too, 18.3–23.4° and 120 N sideways at one phase. Split impulse off: the same worst step, 22.4°; with erp
0.8 too, 26.1°. The engine and ``limit_excess`` agree on those poses: set at rest at each of the sweep's
265 steps more than 6° past (one free link, no gravity), the engine turns it back 3–4 % of the excess in a
step, as at small excesses; it is the body's load (planted feet, the other constraints in 10 solver
iterations) that holds a joint out. And no pybullet stop is hard against torques of the size that move a
body: one link on a fixed base under a steady 150 N·m in 60 random directions for 1 s goes 82° past a
spherical limit at the median (with its twist axis along the bone instead: 139°), and 16–20° past three
revolute limits in series even with split impulse off and 50 solver iterations.
The torques on the pelvis (torso pair, assist) spared their component that turns a hip or the chest further
past its limit (the excess's gradient, per control update): walking off after a get-up, 13.6° → 0.8° over 4
phases, but over 8 a walk-off staggered an ankle 17.0° past, and the worst after pushes was unchanged
(22.4°: that hip is driven past by the push itself, both feet down) (``jostle bench ragdoll``'s
``joint_limit_excess_deg_*`` split). Not kept.
The engine's ``erp`` at 1.0 instead of 0.2 (its limits ask back 20 % of an excess a step, not 4 %), over 8
phases: after pushes survived 11.8°, felled 22.1°, fallen 11.3°, walking off 10.8°; pushes 220 / 300 N and
16 of 16 get-ups as at 0.2, but walk-offs 12 of 16 (15 of 16 at 0.2), and tests/test_articulated_walkoff.py's
face-down walk-off falls again (the rest of the suite passes with it; ``erp`` also sets how fast multibody
contacts are pushed apart). At 0.5: 15.4 / 27.5 / 9.9 / 9.1°, walk-offs 12 of 16. Not kept.
What makes them soft: with split impulse on (the world's setting), a hinge held against a steady torque
(4.5 kg link, 0.2 m) settles past its limit: 3.0 / 6.0 / 15.1° under 50 / 150 / 500 N·m, whatever the
limit's effort or ``erp`` (0.2, 0.8); 3.9° at 480 Hz, 0 at 960 Hz; with split impulse off, 0 at every rate
(measured). But the sweep with split impulse off is no better (above): three hinges in series under the same
150 N·m in random directions still go 17–25° past (p50, 10–50 iterations), and a ball joint's limit is
another constraint. Smaller steps do harden the body's limits: the world at 480 Hz throughout, on the
4-phase sweep: worst 11.2°, but forward minimum 160 N and
walk-offs 5 of 8; 2 / 4 / 8 physics steps per 1/240 s from the push on (walking up to it as before): worst
11.1 / 6.5 / 1.2°, sideways minimum 200 / 180 / 180 N (forward 220 / 240 / 0 N, the last a 20 N push felling
it at one phase), walk-offs 5 / 7 / 2 of 8; 4 steps only while a joint is within 5 / 10° of a limit: 40.2 /
9.0° and forward 220 / 60 N; 4 steps only while falling (and lying): fallen 9.6 → 6.4 (4.9)°, walking off
13.6 → 24.3 (2.5)°, pushes as before. With the limits near hard, this controller's recovery from a sideways push
(which crosses a hip past its range) is what gives. Not kept. Nor a cap on the joints' speed (``changeDynamics``
``maxJointVelocity`` 12 / 20 rad/s, default 100): worst 18.5 / 134.5°, sideways minimum 60 / 80 N.
Feet that slip sooner (their ``lateralFriction`` 0.6, 0.5, 0.4 instead of the body's 0.9: a push slides them
instead of bending the hips over them): on 4 phases worst 13.6 / 19.7 / 16.3° and pushes up (forward minimum
300 / 340 / 340 N, sideways 320 / 380 / 400 N), but over 8 phases at 0.6 worst 21.1° (at 0.9: 22.4° on 4
phases, 28.3° on 8) and sideways it kept no more than 140 N at one; with 4 / 8 physics steps per 1/240 s from
the push on as well, worst 5.1 / 1.6°, but forward it kept no more than 240 / 40 N and sideways 160 / 120 N
at one phase. Not kept.
pybullet's own sub-steps instead (``numSubSteps`` 4 / 8 from the push on: contacts and limits solved at
960 / 1920 Hz, the stable PD's torques computed once per 1/240 s and held, as external forces and torques are;
measured on one free link): worst 11.7 / 13.0°, forward minimum 220 / 220 N, sideways 300 / 280 N, walk-offs
1 / 8 of 8 each. So it is the drive evaluated at the finer rate, not the finer constraint solve, that
hardened the limits above. Not kept.
With the drive at 4 steps per 1/240 s from the push on, the coronal foot placement's velocity gain
(``cv_coronal``, 0.5) retuned (4 phases, sideways only: 0.1 / 0.2 / 0.25 / 0.3 / 0.4 / 0.6 / 0.8 → minimum
260 / 280 / 260 / 260 / 200 / 140 / 120 N, worst 0.8 / 2.6 / 7.2 / 4.5 / 4.0 / 5.0 / 6.6°): at 0.1 / 0.15 over 8
phases both ways, worst 4.1 / 4.3° (after pushes survived 0.7 / 4.3°), but forward minimum 200 N, sideways
200 / 260 N, and no walk-off after a get-up (0 of 16); 0.1 / 0.2 only while staggering, walk-offs 6 / 7 of 8
but forward 200 N, sideways 200 / 180 N (4 phases). Not kept.
Also tried: each joint set back onto its limit after every physics step (``resetJointStateMultiDof``, at 8
steps per 1/240 s, where the excesses left are small): with its outward rate removed, or its rate zeroed,
the body blew up within a second of a 300–700 N push (a hip spun to pybullet's 100 rad/s cap); positions
only, a 300 N sideways push it otherwise takes by stepping felled it. Not kept.
What is kept, on by default (``sim.articulated.recovery``, ``recovery_substeps`` 8): 8 steps per 1/240 s from
a push, a contact, a stagger or a fall on, with the recovery's own balance gains and state loads; falling,
the joints near a limit braced where they are; upright or getting up, a joint past a limit driven back in.
That module has its figures and its weaknesses.
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
