"""The control laws the state machine selects (Mitake et al. 2009 §4.2, Figure 3).

- ``upright_control``: WALK / STAGGER — the bounded LQR of ``sim.balance`` in both vertical planes
  toward the AI's goal velocity, plus a bounded heading PD. The friction force acts at the foot point
  (the body's bottom, ``com_height`` below the COM along its axis), the torques about the COM.
- ``brake_control``: BRAKE / LIE — a D-only "PD brake" on the fallen body's velocity and spin.
- ``stand_up_control``: STAND_UP — a PD on the tilt toward a smoothly shrinking reference, bounded by
  ``getup_torque_max``; physics keeps running, so a push during it still counts.

Every output is bounded here and recorded in ``Control`` so the bounds can be checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim.balance import BalanceDesign, friction_bound
from sim.body import Kinematics
from sim.config import CharacterSpec
from sim.frames import BodyFrame, Vec3, cross, dot, tilt_rates, wrap_angle

ZERO: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class Control:
    """What one control tick applies: ``force`` at the world point ``at`` and a world ``torque``.

    The scalar parts are kept for checking the bounds: ``tau_front``/``tau_side`` the balance torques
    of each plane, ``friction`` the magnitude of the horizontal leg force and ``friction_limit`` its
    bound at that tick.
    """

    force: Vec3 = ZERO
    at: Vec3 = ZERO
    torque: Vec3 = ZERO
    tau_front: float = 0.0
    tau_side: float = 0.0
    tau_yaw: float = 0.0
    friction: float = 0.0
    friction_limit: float = 0.0


def _clip(v: float, bound: float) -> float:
    return max(-bound, min(bound, v))


def upright_control(design: BalanceDesign, spec: CharacterSpec, frame: BodyFrame, kin: Kinematics,
                    goal_velocity: tuple[float, float], goal_heading: float, mu: float,
                    normal_force: float) -> Control:
    f, r = frame.forward, frame.right
    v = kin.velocity
    rate_x, rate_z = tilt_rates(frame, kin.angular_velocity)
    v_front = v[0] * f[0] + v[1] * f[1]
    v_right = v[0] * r[0] + v[1] * r[1]
    g_front = goal_velocity[0] * f[0] + goal_velocity[1] * f[1]
    g_right = goal_velocity[0] * r[0] + goal_velocity[1] * r[1]
    force_f, tau_f = design.front.feedback(frame.tilt_x, rate_x, v_front - g_front)
    force_r, tau_r = design.side.feedback(frame.tilt_z, rate_z, v_right - g_right)
    limit = friction_bound(spec, mu, normal_force)
    size = math.hypot(force_f, force_r)
    if size > limit:
        scale = limit / size if size > 0.0 else 0.0
        force_f, force_r = force_f * scale, force_r * scale
    yaw_error = wrap_angle(frame.heading - goal_heading)
    tau_yaw = _clip(-design.yaw_kp * yaw_error - design.yaw_kd * kin.angular_velocity[2], spec.yaw_torque_max)
    if normal_force <= 0.0:  # feet off the floor: no leg can push or turn it
        tau_f = tau_r = tau_yaw = 0.0
    left = frame.left
    force = (force_f * f[0] + force_r * r[0], force_f * f[1] + force_r * r[1], 0.0)
    torque = (
        tau_f * left[0] + tau_r * f[0],
        tau_f * left[1] + tau_r * f[1],
        tau_yaw,
    )
    lever = spec.com_height
    p = kin.position
    at = (p[0] - lever * frame.up[0], p[1] - lever * frame.up[1], p[2] - lever * frame.up[2])
    return Control(force=force, at=at, torque=torque, tau_front=tau_f, tau_side=tau_r, tau_yaw=tau_yaw,
                   friction=math.hypot(force_f, force_r), friction_limit=limit)


def brake_control(spec: CharacterSpec, frame: BodyFrame, kin: Kinematics, mu: float,
                  normal_force: float) -> Control:
    """Damp the fallen body's horizontal velocity (force at the COM) and its spin (torque).

    On the ground the arms and legs can brace: the torque is bounded by ``getup_torque_max``, the
    force by the floor friction and ``leg_force_max``.
    """
    k = spec.brake_rate
    v = kin.velocity
    fx, fy = -spec.mass * k * v[0], -spec.mass * k * v[1]
    limit = friction_bound(spec, mu, normal_force)
    size = math.hypot(fx, fy)
    if size > limit:
        scale = limit / size if size > 0.0 else 0.0
        fx, fy = fx * scale, fy * scale
    w = kin.angular_velocity
    bound = spec.getup_torque_max
    tx, ty, tz = (-spec.inertia * k * w[0], -spec.inertia * k * w[1], -spec.inertia * k * w[2])
    size_t = math.sqrt(tx * tx + ty * ty + tz * tz)
    if size_t > bound:
        s = bound / size_t
        tx, ty, tz = tx * s, ty * s, tz * s
    return Control(force=(fx, fy, 0.0), at=kin.position, torque=(tx, ty, tz),
                   tau_front=dot((tx, ty, tz), frame.left), tau_side=dot((tx, ty, tz), frame.forward),
                   tau_yaw=tz, friction=math.hypot(fx, fy), friction_limit=limit)


def _smoothstep(u: float) -> float:
    u = max(0.0, min(1.0, u))
    return u * u * (3.0 - 2.0 * u)


def stand_up_reference(start_tilt: float, elapsed: float, duration: float) -> float:
    """The tilt the stand-up PD aims at ``elapsed`` seconds in: start_tilt → 0, smoothly."""
    return start_tilt * (1.0 - _smoothstep(elapsed / duration))


def stand_up_control(spec: CharacterSpec, frame: BodyFrame, kin: Kinematics, start_tilt: float,
                     elapsed: float, gravity: float) -> Control:
    """Rotate e_up back toward world z about a = e_up × z, following ``stand_up_reference``.

    The body pivots about its foot on the floor, so the PD uses the inertia about the foot
    (I + M l²) and feeds forward the gravity moment M g l sin(tilt); spin about other axes is damped.
    The whole torque is bounded by ``getup_torque_max``.
    """
    axis = cross(frame.up, (0.0, 0.0, 1.0))
    n = math.sqrt(dot(axis, axis))
    if n < 1e-6:
        axis = frame.left  # exactly upright (or exactly upside down): any horizontal axis
    else:
        axis = (axis[0] / n, axis[1] / n, axis[2] / n)
    w = kin.angular_velocity
    rate = -dot(w, axis)  # d(tilt)/dt: rotating about +axis decreases the tilt
    lever = spec.com_height
    pivot_inertia = spec.inertia + spec.mass * lever * lever
    wn = spec.getup_frequency
    target = stand_up_reference(start_tilt, elapsed, spec.getup_duration_s)
    along = (pivot_inertia * wn * wn * (frame.tilt - target) + 2.0 * pivot_inertia * wn * rate
             + spec.mass * gravity * lever * math.sin(frame.tilt))
    w_along = dot(w, axis)
    damp = 2.0 * spec.inertia * wn
    tx = along * axis[0] - damp * (w[0] - w_along * axis[0])
    ty = along * axis[1] - damp * (w[1] - w_along * axis[1])
    tz = along * axis[2] - damp * (w[2] - w_along * axis[2])
    size = math.sqrt(tx * tx + ty * ty + tz * tz)
    if size > spec.getup_torque_max:
        s = spec.getup_torque_max / size
        tx, ty, tz = tx * s, ty * s, tz * s
    return Control(force=ZERO, at=kin.position, torque=(tx, ty, tz),
                   tau_front=dot((tx, ty, tz), frame.left), tau_side=dot((tx, ty, tz), frame.forward),
                   tau_yaw=tz)
