"""One articulated character: a multibody tracking a source motion, balancing, taking pushes, getting up.

The walking clip loops; each pass is re-anchored at the character's current position and heading (the
loop continues from where the character is, no snapping back). Joint targets blend over ``BLEND_S`` from
the pose the character is in whenever a new clip starts; after a get-up the walk starts at the frame of
the supporting foot's stance with the feet closest together, blending over only ``spec.walk_in_blend_s``
(lingering in the get-up's crouch made it fall again), with ``walk_in_assist`` × the pelvis torque limit for
``walk_in_s`` (and, after the face-up get-up, a speed help: ``walk_in_force_faceup_n``); rising from the
face-up get-up the root is held over the feet as in the clip (``sim.articulated.getup``); foot placement
ignores being slower than the clip beyond ``SLOW_MS`` (``sim.articulated.walking``). Staggering after a push,
the stance hip is stiffer (``stagger_stance_hip_gain``) and the clip plays faster while the capture point is
toward the stance foot's side (``stagger_hurry``: the crossing step lands sooner, the leg on the side the body
goes to steps out sooner). Balance: ``sim.articulated.balance``; bounded root help: ``sim.articulated.assist``.
Targets, balance and states update at ``spec.control_hz``. Joint limits are pybullet's own constraints in
every state (``sim.articulated.build``), held harder while it recovers (``sim.articulated.recovery``).
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from sim.articulated import balance as bal
from sim.articulated import getup
from sim.articulated import quat1 as q1
from sim.articulated.build import build_multibody, source_to_stage
from sim.articulated.pushes import LinkPushes
from sim.articulated.readout import BodyReadout
from sim.articulated.recovery import Recovery
from sim.articulated.reference import MotionReference, ReferencePose
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.articulated.states import Readings, next_state
from sim.articulated.tracking import JointTracker, PDCommand
from sim.articulated.walking import WalkingBalance
from sim.motion import quaternion as quat
from sim.motion.clips import load_motion
from sim.motion.mocap import MotionClip
from sim.snapshot import CharacterState, LinkPose

BLEND_S = 0.4  # s: joint targets blend from the current pose when a clip starts
YAW_SHARE = 0.2  # the torso control turns toward the clip's heading by this share of the error
TURN_RATE = 0.6  # rad/s: how fast steering turns the clip's frame (1.0 makes it fall: measured)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class ArticulatedCharacter(WalkingBalance):
    """A multibody tracking its clip; ``position`` (stage x, y) and ``heading`` (yaw from +x) place it.

    Call ``step_control(dt)`` before every physics step (pybullet clears joint torques and external forces
    after each ``stepSimulation``). The state machine (``sim.snapshot.CharacterState``):

        WALK ──push / load ≥ stagger_load──▶ STAGGER ──load < recover_load for recover_hold_s──▶ WALK
        WALK, STAGGER ──pelvis tilt ≥ fall_tilt_deg, root below fall_height or load ≥ fall_load──▶ FALL (limp: ragdoll_gain)
        FALL ──still for still_hold_s──▶ LIE ──lie_duration_s──▶ STAND_UP (getup_faceup / getup_facedown)
        STAND_UP ──clip done, upright──▶ WALK        STAND_UP ──tilted over or getup_timeout_s──▶ FALL

    Use (what benchmarks and tests do)::

        from sim.articulated.character import ArticulatedCharacter
        from sim.articulated.recovery import advance
        from sim.articulated.skeleton import deepmimic_humanoid
        from sim.articulated.spec import ArticulatedSpec

        ch = ArticulatedCharacter(client, deepmimic_humanoid(), ArticulatedSpec(), clip=None,
                                  position=(x, y), heading=yaw)   # clip None: spec.walk_clip
        for each physics step:
            advance(client, [ch, ...], physics_dt)  # sim.articulated.recovery: control + stepSimulation, split
                                                    # into ch.wanted_substeps while one recovers from a push
        ch.push(link, force_xyz, duration)      # link: skeleton index or name ("root" is the pelvis)
        ch.state                                # sim.snapshot.CharacterState
        ch.tracking_error_deg()                 # mean |angle| between driven joints and the clip, now
        ch.joint_angles()                       # (12, 4) local rotations, x y z w, ch.driven order
        ch.limit_excess()                       # radians beyond the joint limits now (0 inside)
        ch.external_assist_peak_n, ch.external_assist_peak_nm   # largest root assist force / torque used
        ch.falls, ch.getups                     # counters
        ch.com_state(), ch.root(), ch.link_poses(), ch.body (pybullet id)
    """

    def __init__(self, client: int, skeleton: ArticulatedSkeleton, spec: ArticulatedSpec,
                 clip: MotionClip | None = None, position: tuple[float, float] = (0.0, 0.0),
                 heading: float = 0.0) -> None:
        self.client = client
        self.skeleton = skeleton
        self.spec = spec
        self.recovery = Recovery(spec)  # finer steps after a push, and the balance gains meanwhile (.spec)
        self.stepped_finely = False  # the world steps finer now (for it or another character): recovery gains
        self._up = source_to_stage(skeleton)
        self.walk = MotionReference(clip or load_motion(spec.walk_clip, "walk_clip", cycle=True), skeleton)
        self.ref = self.walk
        self.driven = self.walk.driven
        self._feet = (skeleton.foot("right"), skeleton.foot("left")) if any(x.foot for x in skeleton.links) else None
        self._hips = tuple(skeleton.index(n) for n in ("right_hip", "left_hip"))
        self._drv_pos = {link: k for k, link in enumerate(self.driven)}
        self._neck = [k for k, link in enumerate(self.driven) if skeleton.links[link].gain_group == "neck"]
        r0 = self.walk.sample(0.0)
        self._anchor_yaw = heading - bal.heading_of(q1.mul(self._up, r0.root_rot))
        orn = self._stage_root_rot(r0)
        root = np.array([position[0], position[1], q1.rot(self._up, r0.root_pos)[2]])
        self.body = build_multibody(client, skeleton, (float(root[0]), float(root[1]), float(root[2])),
                                    (float(orn[0]), float(orn[1]), float(orn[2]), float(orn[3])))
        self.tracker = JointTracker(client, self.body, skeleton, spec, self.driven)
        self.walk.limit(self.tracker.limits.clamp)  # clip frames inside the joint limits, once
        self._getups = getup.GetUpClips(skeleton, spec, self.tracker.limits)
        self.getup_face_up: bool | None = None  # the last get-up started lying face up (None: none yet)
        self.readout = BodyReadout(client, self.body, skeleton)
        self._set_pose(r0, root, orn)
        self.state = CharacterState.WALK
        self.t = 0.0
        self._clip_t = 0.0
        self._state_t = 0.0
        self._hold_t = 0.0
        self.heading_goal: float | None = None
        self._blend_from: np.ndarray | None = None
        self._blend_t = 0.0
        self._blend_s = BLEND_S
        self._pushes = LinkPushes(client, self.body, self.readout)
        self._since = 0.0
        self._walk_started = -1.0  # when it last started walking from a stand (-1: it was placed walking)
        self._cmd: PDCommand | None = None
        self._torques: list[tuple[int, list[float]]] = []  # (pybullet link, world torque), re-applied each step
        self._forces: list[tuple[int, list[float], tuple[float, float, float]]] = []  # (link, force, at)
        self.load = 0.0
        self._rate = 1.0  # clip seconds per second (faster while hurrying a crossing step)
        self._stance_left = False
        self._dd = np.zeros(2)
        self._dv = np.zeros(2)
        self._heading = heading
        self.external_assist_peak_n = 0.0
        self.external_assist_peak_nm = 0.0
        self.external_assist_nm = 0.0  # the root assist torque of the last control tick, N·m
        self.falls = 0
        self.getups = 0
        self.last_push_force_n = 0.0

    # ------------------------------------------------------------------ placement
    def _stage_root_rot(self, r: ReferencePose) -> np.ndarray:
        out: np.ndarray = q1.mul(bal.yaw_quat(self._anchor_yaw), q1.mul(self._up, r.root_rot))
        return out

    def _set_pose(self, r: ReferencePose, root: np.ndarray, orn: np.ndarray) -> None:
        c = self.client
        p.resetBasePositionAndOrientation(self.body, root.tolist(), orn.tolist(), physicsClientId=c)
        rots = self.tracker.limits.clamp(r.rots)
        for k, j in enumerate(self.tracker.indices):
            if self.tracker.hinge[k]:
                p.resetJointState(self.body, j, float(self.walk.hinge_angles(rots)[k]),
                                  float(np.dot(r.omegas[k], self.tracker.axis[k])), physicsClientId=c)
            else:
                p.resetJointStateMultiDof(self.body, j, rots[k].tolist(), r.omegas[k].tolist(), physicsClientId=c)
        lowest = min(p.getAABB(self.body, j, physicsClientId=c)[0][2] for j in range(-1, len(self.skeleton.links) - 1))
        root = root - np.array([0.0, 0.0, lowest - 0.002])
        p.resetBasePositionAndOrientation(self.body, root.tolist(), orn.tolist(), physicsClientId=c)
        fwd = q1.rot(orn, bal.FORWARD)
        p.resetBaseVelocity(self.body, (fwd * r.v_ref[0]).tolist(), [0.0, 0.0, 0.0], physicsClientId=c)

    # ------------------------------------------------------------------ readouts
    def root(self) -> tuple[np.ndarray, np.ndarray]:
        """Root joint position and orientation (stage)."""
        return self.readout.root()

    def com_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Whole-body centre of mass and its velocity (stage)."""
        return self.readout.com_state()

    def link_poses(self) -> tuple[LinkPose, ...]:
        """Every link's frame in the stage (``CharacterSnapshot.links``)."""
        return self.readout.link_poses()

    def joint_angles(self) -> np.ndarray:
        """Local rotations (D, 4, x y z w) of the driven joints, in ``self.driven`` order."""
        return self.tracker.read()[0]

    def tracking_error_deg(self) -> float:
        """Mean angle (degrees) between the driven joints and the clip's rotations right now."""
        rots, _ = self.tracker.read()
        return float(np.degrees(self.tracker.tracking_error(rots, self.ref.sample(self._clip_t).rots).mean()))

    def limit_excess(self) -> float:
        """Largest amount (radians) by which any joint is outside its limits now (0 inside)."""
        return self.tracker.limits.worst_excess(self.joint_angles())

    # ------------------------------------------------------------------ inputs
    def push(self, link: int | str, force: tuple[float, float, float], duration: float) -> None:
        """Push ``link`` (skeleton index or name) with the world-frame ``force`` (N) for ``duration`` s."""
        i = self.skeleton.index(link) if isinstance(link, str) else int(link)
        f = np.asarray(force, dtype=float)
        self._pushes.add(i, f, float(duration))
        self.touched()
        if float(np.linalg.norm(f)) * duration >= self.spec.push_threshold_ns:
            self._enter(CharacterState.STAGGER, only_from=(CharacterState.WALK,))

    def staggered(self) -> None:
        """Someone pushed it (a contact episode that was a push): WALK → STAGGER."""
        self.touched()
        self._enter(CharacterState.STAGGER, only_from=(CharacterState.WALK,))

    def touched(self) -> None:
        """Something pushes it now (a push, a contact, a fall): recover at finer steps (``sim.articulated.recovery``)."""
        self.recovery.begin()

    @property
    def _gains(self) -> ArticulatedSpec:
        """The spec balance, assist and states use: the recovery's while any recovers, else ``Recovery.gains``."""
        return self.recovery.spec if self.stepped_finely else self.recovery.gains(self.spec)

    @property
    def wanted_substeps(self) -> int:
        """Physics steps per world step it needs now: ``spec.recovery_substeps`` while recovering, else 1."""
        return self.recovery.wanted_substeps

    def nearest_link(self, at: tuple[float, float, float]) -> int:
        """The link whose centre of mass is nearest the stage point ``at``."""
        return self.readout.nearest_link(at)

    # ------------------------------------------------------------------ control
    def _enter(self, state: CharacterState, only_from: tuple[CharacterState, ...] | None = None) -> None:
        if only_from is not None and self.state not in only_from:
            return
        if state == self.state:
            return
        self.state = state
        self._state_t = 0.0
        self._hold_t = 0.0
        if state in (CharacterState.FALL, CharacterState.STAGGER):  # however it came to: recover at finer steps
            self.falls += int(state == CharacterState.FALL)
            self.touched()
        if state == CharacterState.STAND_UP:
            _, orn = self.root()
            self.getup_face_up = bal.face_up(orn)
            self.ref = self._getups.clip(self.getup_face_up)
            r0 = self.ref.sample(0.0)
            self._anchor_yaw = (bal.lying_heading_of(orn)
                                - bal.lying_heading_of(q1.mul(self._up, r0.root_rot)))
            self._start_clip()
        if state == CharacterState.WALK and self.ref is not self.walk:
            self.getups += 1
            self.ref = self.walk
            self._reanchor_walk()
            on_left = self._support_left()
            self._start_clip(self.spec.walk_in_blend_s, self.walk.feet_together_t[1 if on_left else 0])
            self._walk_started = self.t

    def steer(self, heading: float | None) -> None:
        """Walk toward the stage yaw ``heading`` (turning at most ``TURN_RATE``); None: follow the clip."""
        self.heading_goal = None if heading is None else float(heading)

    def _reanchor_walk(self) -> None:
        _, orn = self.root()
        self._anchor_yaw = bal.heading_of(orn) - bal.heading_of(q1.mul(self._up, self.walk.sample(0.0).root_rot))

    def _start_clip(self, blend_s: float = BLEND_S, at: float = 0.0) -> None:
        """Play ``self.ref`` from ``at``, blending from the current pose over ``blend_s``."""
        self._clip_t = at
        self._blend_from, _ = self.tracker.read()
        self._blend_t = 0.0
        self._blend_s = blend_s

    def step_control(self, dt: float) -> None:
        """Apply this physics step's joint drive, balance torques, assist and pushes.

        The targets, balance feedback and state machine update at ``spec.control_hz``; in between the
        last command is re-issued (pybullet clears joint torques and external forces after each step).
        """
        self.t += dt
        self._state_t += dt
        self._clip_t += dt * self._rate
        self._since += dt
        if self._cmd is None or self._since >= 1.0 / self.spec.control_hz - 1e-9:
            self._update(self._since)
            self._since = 0.0
        assert self._cmd is not None
        self.recovery.update(self.state, bool(self._pushes), self._walk_in() < 1.0, dt)
        self.tracker.issue(self._cmd)
        c = self.client
        for link, torque in self._torques:
            p.applyExternalTorque(self.body, link, torque, p.WORLD_FRAME, physicsClientId=c)
        for link, force, at in self._forces:
            p.applyExternalForce(self.body, link, force, at, p.WORLD_FRAME, physicsClientId=c)
        self.last_push_force_n = self._pushes.apply(dt)

    def _walk_in(self) -> float:
        """How far into walking off from a stand (0 just started … 1 done, or not walking off)."""
        if self._walk_started < 0.0 or self.spec.walk_in_s <= 0.0:
            return 1.0
        return min(1.0, (self.t - self._walk_started) / self.spec.walk_in_s)

    def _update(self, dt: float) -> None:
        self._rate = 1.0
        if self.ref.clip.loop and self._clip_t >= self.ref.duration:
            self._clip_t -= self.ref.duration
            self._reanchor_walk()
        root, orn = self.root()
        if self.heading_goal is not None and self.ref is self.walk:  # steer: turn the clip's frame
            turn = _wrap(self.heading_goal - bal.heading_of(orn))
            self._anchor_yaw += float(np.clip(turn, -TURN_RATE * dt, TURN_RATE * dt))
        r = self.ref.sample(self._clip_t)
        _, omega_a = self.readout.base_velocity()
        targets = r.rots.copy()
        scale = np.ones(len(self.driven))
        self._modified: list[int] = []
        self._torques = []
        self._forces = []
        walking = self.state in (CharacterState.WALK, CharacterState.STAGGER)
        desired_root = self._stage_root_rot(r)
        if walking:  # balance the tilt; turn toward the clip's heading only gently (YAW_SHARE)
            yaw_err = _wrap(bal.heading_of(orn) - bal.heading_of(desired_root))
            desired_root = q1.mul(bal.yaw_quat((1.0 - YAW_SHARE) * yaw_err), desired_root)
        if walking and self._feet is not None:
            targets, torso = self._balance(r, root, orn, omega_a, desired_root, scale)
            stance = self._hips[1] if self._stance_left else self._hips[0]
            self._torques += [(-1, torso.tolist()), (stance - 1, (-torso).tolist())]
        if self._blend_from is not None and self._blend_t < self._blend_s:
            self._blend_t += dt
            targets = quat.slerp(self._blend_from, targets, min(1.0, self._blend_t / self._blend_s))
            targets = self.tracker.limits.clamp(targets)
        else:  # only what balance changed needs clamping (the clip's own frames are inside the limits)
            for k in self._modified:
                targets[k] = self.tracker.limits.clamp_one(targets[k], k)
        omegas = r.omegas * self._rate  # the clip plays at _rate: so do its joint velocities
        if self.state in (CharacterState.FALL, CharacterState.LIE):
            scale *= self.spec.ragdoll_gain
        if self.recovery.active:  # the head and the joints at their limits braced (sim.articulated.recovery)
            targets, omegas, scale = self.recovery.brace(self.tracker.limits, self.tracker.read()[0], self.state,
                                                         (targets, omegas, scale), self._neck)
        self._cmd = self.tracker.command(targets, omegas, scale)
        self._assist(r, root, orn, omega_a, desired_root)
        self._update_state(root, orn, dt)

    def _update_state(self, root: np.ndarray, orn: np.ndarray, dt: float) -> None:
        vel, _ = self.readout.base_velocity()
        readings = Readings(math.degrees(bal.tilt_of(orn)), float(root[2]), self.load, bool(self._pushes),
                            float(np.linalg.norm(vel)), self._state_t, self._clip_t, self.ref.duration)
        after, self._hold_t = next_state(self.state, readings, self._gains, self._hold_t, dt)
        if after != self.state:
            self._enter(after)
