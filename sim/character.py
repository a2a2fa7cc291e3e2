"""One character: its body, balance design, state machine, AI and travelled distances.

Per control tick the world calls ``think`` (state machine, then the control law of the state), then
``apply`` before every physics substep (pybullet clears external forces after each step, and the world
steps substeps one by one to measure contact impulses per substep), then ``sense`` with the new readout.
"""

from __future__ import annotations

import dataclasses
import math

from sim.ai import BEHAVIOUR_WALK, CharacterAI, Goal, behaviour_for
from sim.balance import BalanceDesign
from sim.body import CharacterBody, Kinematics
from sim.config import CharacterSpec
from sim.control import Control, brake_control, stand_up_control, stand_up_reference, upright_control
from sim.frames import BodyFrame, Vec3, body_frame, tilt_rates, yaw_quaternion
from sim.snapshot import CharacterSnapshot, CharacterState
from sim.states import BalanceReading, StateMachine

UPRIGHT_STATES = (CharacterState.WALK, CharacterState.STAGGER)


def _finite3(v: Vec3) -> bool:
    return math.isfinite(v[0]) and math.isfinite(v[1]) and math.isfinite(v[2])


class Character:
    def __init__(self, name: str, spec: CharacterSpec, body: CharacterBody, design: BalanceDesign,
                 ai: CharacterAI, floor_friction: float, gravity: float, t: float) -> None:
        self.name = name
        self.spec = spec
        self.body = body
        self.design = design
        self.ai = ai
        self.machine = StateMachine(spec, t)
        self._mu = floor_friction
        self._gravity = gravity
        self.kin: Kinematics = body.read()
        self.frame: BodyFrame = body_frame(self.kin.orientation)
        self.normal_force = 0.0
        self.control = Control()
        self.goal = Goal(velocity=(0.0, 0.0), heading=self.frame.heading, behaviour=BEHAVIOUR_WALK,
                         intent=ai.intent)
        self.d_front = 0.0
        self.d_side = 0.0
        self.contact_force = 0.0  # largest force a person applied during the current world step
        self.stand_up_start_tilt = 0.0
        self.not_upright_since: float | None = None
        # largest |applied| / bound seen so far, for checking the bounds (≤ 1 when they hold)
        self.peak_torque_ratio = 0.0
        self.peak_friction_ratio = 0.0
        self.non_finite_controls = 0
        self.load = 0.0  # balance load at the last tick (see sim.balance)

    @property
    def state(self) -> CharacterState:
        return self.machine.state

    def sense(self, kin: Kinematics, normal_force: float) -> None:
        self.kin = kin
        self.frame = body_frame(kin.orientation)
        self.normal_force = normal_force

    def reading(self, t: float) -> BalanceReading:
        rate_x, rate_z = tilt_rates(self.frame, self.kin.angular_velocity)
        v, w = self.kin.velocity, self.kin.angular_velocity
        error = 0.0
        if self.machine.state is CharacterState.STAND_UP:
            error = self.frame.tilt - stand_up_reference(self.stand_up_start_tilt, t - self.machine.entered,
                                                         self.spec.getup_duration_s)
        return BalanceReading(
            load=self.design.balance_load(self.frame.tilt_x, rate_x, self.frame.tilt_z, rate_z)
            if self.frame.tilt < 0.5 * math.pi else math.inf,
            tilt=self.frame.tilt,
            speed=math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]),
            spin=math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]),
            face_up=self.frame.face_up,
            stand_up_error=error,
        )

    def think(self, t: float, goal: Goal) -> tuple[CharacterState, CharacterState] | None:
        """Run the state machine and compute this tick's control; returns a state change if any."""
        reading = self.reading(t)
        self.load = reading.load
        change = self.machine.update(t, reading)
        state = self.machine.state
        self.goal = dataclasses.replace(goal, behaviour=behaviour_for(state)) if change is not None else goal
        if change is not None:
            self.body.set_floor_friction(0.0 if state in UPRIGHT_STATES else self._mu)
            if state is CharacterState.STAND_UP:
                self.stand_up_start_tilt = self.frame.tilt
            if state is CharacterState.WALK:
                self.ai.reset_heading(self.frame.heading)
        if state in UPRIGHT_STATES:
            self.not_upright_since = None
        elif self.not_upright_since is None:
            self.not_upright_since = t
        if state in UPRIGHT_STATES:
            control = upright_control(self.design, self.spec, self.frame, self.kin, goal.velocity,
                                      goal.heading, self._mu, self.normal_force)
        elif state is CharacterState.FALL:
            control = Control(at=self.kin.position)
        elif state is CharacterState.STAND_UP:
            control = stand_up_control(self.spec, self.frame, self.kin, self.stand_up_start_tilt,
                                       t - self.machine.entered, self._gravity)
        else:
            control = brake_control(self.spec, self.frame, self.kin, self._mu, self.normal_force)
        if not (_finite3(control.force) and _finite3(control.at) and _finite3(control.torque)):
            self.non_finite_controls += 1
            control = Control(at=self.kin.position)
        self.control = control
        self._record_bounds(control, state)
        return change

    def _record_bounds(self, c: Control, state: CharacterState) -> None:
        if state in UPRIGHT_STATES:
            ratio = max(abs(c.tau_front) / self.spec.tau_max, abs(c.tau_side) / self.spec.tau_max_side,
                        abs(c.tau_yaw) / self.spec.yaw_torque_max)
        else:  # stand-up and brake: the whole torque vector within getup_torque_max
            t = c.torque
            ratio = math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) / self.spec.getup_torque_max
        self.peak_torque_ratio = max(self.peak_torque_ratio, ratio)
        if c.friction > 0.0:
            bound = c.friction_limit
            self.peak_friction_ratio = max(self.peak_friction_ratio,
                                           c.friction / bound if bound > 0.0 else math.inf)

    def apply(self) -> None:
        c = self.control
        self.body.apply(c.force, c.at, c.torque)

    def integrate(self, dt: float) -> None:
        """Travelled distances, eqs. (6)–(7): ∫ f·v dt and ∫ r·v dt in the heading frame."""
        v, f, r = self.kin.velocity, self.frame.forward, self.frame.right
        self.d_front += (v[0] * f[0] + v[1] * f[1]) * dt
        self.d_side += (v[0] * r[0] + v[1] * r[1]) * dt

    def put_upright(self, position: Vec3, heading: float, t: float) -> None:
        """Recovery only (stuck, off stage, non-finite): stand it up at ``position``, still."""
        self.body.reset(position, yaw_quaternion(heading))
        self.body.set_floor_friction(0.0)
        self.machine.force(CharacterState.WALK, t)
        self.ai.reset_heading(heading)
        self.not_upright_since = None
        self.sense(self.body.read(), self.normal_force)
        self.control = Control(at=position)

    def snapshot(self) -> CharacterSnapshot:
        k, fr = self.kin, self.frame
        return CharacterSnapshot(
            name=self.name,
            position=k.position,
            orientation=k.orientation,
            velocity=k.velocity,
            angular_velocity=k.angular_velocity,
            heading=fr.heading,
            tilt=(fr.tilt_x, fr.tilt_z),
            d_front=self.d_front,
            d_side=self.d_side,
            state=self.machine.state,
            behaviour=self.goal.behaviour,
            intent=self.goal.intent,
            face_up=self.machine.face_up,
            contact_force_n=self.contact_force,
            height=self.spec.height,
        )
