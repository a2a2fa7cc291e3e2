"""The control laws the state machine selects (Mitake et al. 2009 §4.2, Figure 3), for all characters at once.

- WALK / STAGGER — the bounded LQR of ``sim.mitake.balance`` in both vertical planes toward the AI's goal
  velocity. The legs' friction force f_F acts at the foot point (the body's bottom, ``com_height``
  below the centre of mass along its axis), the centre-of-pressure torques τ about the centre of mass.
  Heading: a bounded PD toward the AI's heading while walking; while staggering, and for ``pivot_s``
  after any push, only a weak damping of the spin (``pivot_damping``), so an off-centre push turns
  the character — it pivots on a foot, as the paper's characters do — and then it turns back to
  where the AI wants to go.
- BRAKE / LIE — a D-only "PD brake" on the fallen body's velocity and spin.
- STAND_UP — a PD on the tilt toward a smoothly shrinking reference, bounded by ``getup_torque_max``;
  physics keeps running, so a push during it still counts.
- FALL — nothing: the body falls.

The tick's force F and torque T act as one impulse at the start of the tick (``sim.mitake.balance`` designs
the gains for exactly that): Δv = F dt / M and Δω = (T + r_foot × F) dt / I (isotropic inertia). Every
bound is applied here, before the impulse, and recorded so it can be checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sim.frames import clamp, wrap_angles
from sim.mitake.crowd import BRAKE, FALL, LIE, STAGGER, STAND_UP, Crowd
from sim.mitake.states import stand_up_reference

Array = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Impulses:
    """What one control tick adds to each body's velocities (stage frame), and which rows changed."""

    dv: Array  # (N, 3)
    dw: Array  # (N, 3)
    active: NDArray[np.bool_]  # rows whose impulse is not zero


def _scale_to(fx: Array, fy: Array, limit: Array) -> tuple[Array, Array]:
    size = np.hypot(fx, fy)
    over = size > limit
    if not over.any():
        return fx, fy
    scale = np.where(over, limit / np.maximum(size, 1e-300), 1.0)
    return fx * scale, fy * scale


def control(crowd: Crowd, t: float, mu: float, gravity: float, dt: float) -> Impulses:
    """This tick's impulses for every character, by state; records the bounded inputs on ``crowd``.

    The upright law is evaluated for every row (it is the common case and cheap as whole columns);
    rows in other states are then overwritten by their own law.
    """
    c, f = crowd.cols, crowd.frames
    n = len(crowd)
    state = crowd.state
    ch, sh = f.cos_h, f.sin_h
    v, w = crowd.vel, crowd.ang
    limit = np.minimum(mu * crowd.normal, c.leg_force_max)
    up = state <= STAGGER
    all_up = bool(up.all())

    # upright: bounded LQR in both planes, heading PD (walking) or pivot damping (staggering)
    ex = v[:, 0] - crowd.goal_v[:, 0]
    ey = v[:, 1] - crowd.goal_v[:, 1]
    # the speed error the LQR sees is limited (a reference governor): far from its goal speed the
    # character slows down as fast as balance allows instead of letting the speed term saturate the
    # bounded inputs and leave nothing to keep it upright (that runs away, leaning, at full leg force)
    e_front = clamp(ex * ch + ey * sh, -c.speed_error_front, c.speed_error_front)
    e_right = clamp(ex * sh - ey * ch, -c.speed_error_side, c.speed_error_side)
    tx, rx, tz, rz = f.tilt_x, crowd.rate_x, f.tilt_z, crowd.rate_z
    k = c.kf_force
    ff = -(k[0] * tx + k[1] * rx + k[2] * e_front)
    k = c.kf_torque
    tau_f = clamp(-(k[0] * tx + k[1] * rx + k[2] * e_front), -c.tau_max, c.tau_max)
    k = c.ks_force
    fr = -(k[0] * tz + k[1] * rz + k[2] * e_right)
    k = c.ks_torque
    tau_r = clamp(-(k[0] * tz + k[1] * rz + k[2] * e_right), -c.tau_max_side, c.tau_max_side)
    ff, fr = _scale_to(ff, fr, limit)
    wz = w[:, 2]
    tau_y = -c.yaw_kp * wrap_angles(f.heading - crowd.heading_goal) - c.yaw_kd * wz
    pivoting = (state == STAGGER) | (t - crowd.pushed_at < c.pivot_s)
    if pivoting.any():
        tau_y = np.where(pivoting, -c.pivot_gain * wz, tau_y)
    tau_y = clamp(tau_y, -c.yaw_torque_max, c.yaw_torque_max)
    grounded = crowd.normal > 0.0  # feet off the floor: no leg can push or turn it (f_F is 0 by its bound)
    if not grounded.all():
        tau_f, tau_r, tau_y = tau_f * grounded, tau_r * grounded, tau_y * grounded
    fx = ff * ch + fr * sh
    fy = ff * sh - fr * ch
    # τ_front about the left axis (−sin ψ, cos ψ, 0), τ_side about forward (cos ψ, sin ψ, 0); plus the
    # moment of f_F acting at the foot, r × F with r = −l e_up
    lever = c.com_height
    ux, uy, uz = f.up[:, 0], f.up[:, 1], f.up[:, 2]
    mx = -tau_f * sh + tau_r * ch + lever * uz * fy
    my = tau_f * ch + tau_r * sh - lever * uz * fx
    mz = tau_y - lever * (ux * fy - uy * fx)
    friction = np.hypot(ff, fr)
    torque_ratio = np.maximum(np.maximum(np.abs(tau_f) * c.inv_tau_max, np.abs(tau_r) * c.inv_tau_max_side),
                              np.abs(tau_y) * c.inv_yaw_torque_max)
    if not all_up:
        fx, fy, mx, my, mz, tau_f, tau_r, tau_y, friction, torque_ratio = _other_states(
            crowd, t, gravity, limit, up, fx, fy, mx, my, mz, tau_f, tau_r, tau_y, friction, torque_ratio)
    dv = np.zeros((n, 3))
    dw = np.empty((n, 3))
    dtm = dt * c.inv_mass
    dti = dt * c.inv_inertia
    dv[:, 0] = fx * dtm
    dv[:, 1] = fy * dtm
    dw[:, 0] = mx * dti
    dw[:, 1] = my * dti
    dw[:, 2] = mz * dti
    if not np.isfinite(dv.sum() + dw.sum()):
        bad = ~(np.isfinite(dv).all(axis=1) & np.isfinite(dw).all(axis=1))
        crowd.non_finite[bad] += 1
        dv[bad] = 0.0
        dw[bad] = 0.0
    crowd.tau_front, crowd.tau_side, crowd.tau_yaw = tau_f, tau_r, tau_y
    crowd.friction, crowd.friction_limit = friction, limit
    crowd.peak_torque_ratio = np.maximum(crowd.peak_torque_ratio, torque_ratio)
    pushing = friction > 0.0
    if pushing.any():
        f_ratio = np.divide(friction, limit, out=np.full(n, math.inf), where=limit > 0.0)
        crowd.peak_friction_ratio = np.maximum(crowd.peak_friction_ratio, np.where(pushing, f_ratio, 0.0))
    active = state != FALL if not all_up else np.ones(n, dtype=bool)
    return Impulses(dv=dv, dw=dw, active=active)


def _other_states(crowd: Crowd, t: float, gravity: float, limit: Array, up: NDArray[np.bool_], fx: Array,
                  fy: Array, mx: Array, my: Array, mz: Array, tau_f: Array, tau_r: Array, tau_y: Array,
                  friction: Array, torque_ratio: Array) -> tuple[Array, ...]:
    """Overwrite the rows that are not upright with their state's law (brake, stand-up, nothing)."""
    c, f, state = crowd.cols, crowd.frames, crowd.state
    n = len(crowd)
    v, w = crowd.vel, crowd.ang
    torque = np.zeros((n, 3))
    force_x, force_y = np.zeros(n), np.zeros(n)
    down = (state == BRAKE) | (state == LIE)
    if down.any():
        kb = c.brake_rate
        bx, by = _scale_to(-c.mass * kb * v[:, 0], -c.mass * kb * v[:, 1], limit)
        force_x, force_y = np.where(down, bx, 0.0), np.where(down, by, 0.0)
        torque = np.where(down[:, None], _bound3(-(c.inertia * kb)[:, None] * w, c.getup_torque_max), torque)
    rising = state == STAND_UP
    if rising.any():
        torque = np.where(rising[:, None], _stand_up_torque(crowd, t, gravity), torque)
    ch, sh = f.cos_h, f.sin_h
    keep = up
    pure = np.sqrt(np.sum(torque * torque, axis=1)) / c.getup_torque_max
    return (
        np.where(keep, fx, force_x), np.where(keep, fy, force_y),
        np.where(keep, mx, torque[:, 0]), np.where(keep, my, torque[:, 1]), np.where(keep, mz, torque[:, 2]),
        np.where(keep, tau_f, -torque[:, 0] * sh + torque[:, 1] * ch),
        np.where(keep, tau_r, torque[:, 0] * ch + torque[:, 1] * sh),
        np.where(keep, tau_y, torque[:, 2]),
        np.where(keep, friction, np.hypot(force_x, force_y)),
        np.where(keep, torque_ratio, pure),
    )


def _bound3(t: Array, bound: Array) -> Array:
    size = np.sqrt(np.sum(t * t, axis=1))
    scale = np.where(size > bound, bound / np.maximum(size, 1e-300), 1.0)
    out: Array = t * scale[:, None]
    return out


def _stand_up_torque(crowd: Crowd, t: float, gravity: float) -> Array:
    """Rotate e_up back toward world z about a = e_up × z, following the stand-up reference.

    The body pivots about its foot on the floor, so the PD uses the inertia about the foot
    (I + M l²) and feeds forward the gravity moment M g l sin(tilt); spin about other axes is damped.
    The whole torque is bounded by ``getup_torque_max``.
    """
    c, f = crowd.cols, crowd.frames
    up = f.up
    axis = np.stack([up[:, 1], -up[:, 0], np.zeros(len(crowd))], axis=1)
    norm = np.sqrt(np.sum(axis * axis, axis=1))
    left = np.stack([-f.sin_h, f.cos_h, np.zeros(len(crowd))], axis=1)
    axis = np.where((norm < 1e-6)[:, None], left, axis / np.maximum(norm, 1e-12)[:, None])
    w = crowd.ang
    w_along = np.sum(w * axis, axis=1)
    rate = -w_along  # d(tilt)/dt: rotating about +axis decreases the tilt
    pivot_inertia = c.inertia + c.mass * c.com_height**2
    wn = c.getup_frequency
    target = stand_up_reference(crowd.stand_up_start, t - crowd.entered, c.getup_duration_s)
    along = (pivot_inertia * wn * wn * (f.tilt - target) + 2.0 * pivot_inertia * wn * rate
             + c.mass * gravity * c.com_height * np.sin(f.tilt))
    damp = 2.0 * c.inertia * wn
    out = along[:, None] * axis - damp[:, None] * (w - w_along[:, None] * axis)
    return _bound3(out, c.getup_torque_max)
