"""Balance of a walking articulated character with joint torques (SIMBICON, Yin et al. 2007, on mocap).

- Foot placement: the swing hip's target is turned by α = cd·Δd + cv·Δv (sagittal and coronal), where
  Δd, Δv are how far the root is from where the clip has it relative to the stance foot, and how much
  faster it moves than the clip (heading frame). Steps go where the body is going.
- Torso: the swing thigh's target is set in the *world* (the desired pelvis frame), and the stance hip
  produces the torque τ = Kp·log(q_d q⁻¹) − Kd·ω that keeps the pelvis at its world orientation: as an
  internal torque pair (+τ on the pelvis, −τ on the stance thigh — the hip actuator; no net external
  wrench, the SIMBICON trick).
- Ankle: the stance ankle's target pitches/rolls by ``ankle_gain``·Δd to move the centre of pressure
  under the displaced body.
- Step timing: staggering, the clip plays faster while the body heads toward the stance foot's side
  (``hurried_rate``).
Everything here is pure numpy on stage-frame quantities; the character applies the results (why the walking
assist is needed: docs/notes/articulated-balance.md). Source-frame
axes of the body (DeepMimic, Y up): x forward, y up, z to the right.
"""

from __future__ import annotations

import math

import numpy as np

from sim.articulated import quat1 as q1
from sim.articulated.reference import quat_exp, quat_log
from sim.motion import quaternion as quat

FORWARD = np.array([1.0, 0.0, 0.0])  # body frame
UP = np.array([0.0, 1.0, 0.0])
RIGHT = np.array([0.0, 0.0, 1.0])


def yaw_quat(yaw: float) -> np.ndarray:
    return np.array([0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)])


def heading_of(orientation: np.ndarray) -> float:
    """Yaw (stage, from +x) of the body's forward axis; of its up axis when it lies face up or down."""
    f = q1.rot(orientation, FORWARD)
    if math.hypot(f[0], f[1]) < 0.3:
        f = q1.rot(orientation, UP)
    return math.atan2(f[1], f[0])


def lying_heading_of(orientation: np.ndarray) -> float:
    """Yaw (stage) of the body's up axis (feet → head) projected on the floor: the heading of a lying body."""
    u = q1.rot(orientation, UP)
    return math.atan2(u[1], u[0])


def tilt_of(orientation: np.ndarray) -> float:
    """Angle (radians) between the body's up axis and stage up."""
    u = q1.rot(orientation, UP)
    return math.acos(max(-1.0, min(1.0, float(u[2]))))


def face_up(orientation: np.ndarray) -> bool:
    """Lying with the front (forward axis) toward the sky."""
    return bool(q1.rot(orientation, FORWARD)[2] > 0.0)


def tilt_components(orientation: np.ndarray) -> tuple[float, float]:
    """(θx, θz) of the snapshot: lean forward (+) and lean to the right (+), radians."""
    u = q1.rot(orientation, UP)
    h = heading_of(orientation)
    fwd = math.cos(h) * u[0] + math.sin(h) * u[1]
    left = -math.sin(h) * u[0] + math.cos(h) * u[1]
    return math.atan2(fwd, u[2]), math.atan2(-left, u[2])


def heading_frame(heading: float, v: np.ndarray) -> tuple[float, float]:
    """(forward, right) components of a stage vector in the heading frame."""
    c, s = math.cos(heading), math.sin(heading)
    return c * v[0] + s * v[1], s * v[0] - c * v[1]


def placement_rotation(d_fwd: float, d_right: float, v_fwd: float, v_right: float, cd_sag: float,
                       cv_sag: float, cd_cor: float, cv_cor: float, limit: float = 0.6) -> np.ndarray:
    """The turn (body frame) of the swing thigh that steps where the body is going (SIMBICON)."""
    a_sag = float(np.clip(cd_sag * d_fwd + cv_sag * v_fwd, -limit, limit))  # leg forward: about +z (right)
    a_cor = float(np.clip(cd_cor * d_right + cv_cor * v_right, -limit, limit))  # leg right: about −x
    return quat_exp(RIGHT * a_sag - FORWARD * a_cor)


def ankle_rotation(d_fwd: float, d_right: float, gain: float, gain_coronal: float | None = None,
                   limit: float = 0.3) -> np.ndarray:
    """The turn (shank frame) of the stance foot that moves the centre of pressure toward the body
    (``gain_coronal`` None: ``gain`` both ways)."""
    a_sag = float(np.clip(gain * d_fwd, -limit, limit))
    a_cor = float(np.clip((gain if gain_coronal is None else gain_coronal) * d_right, -limit, limit))
    return quat_exp(-RIGHT * a_sag + FORWARD * a_cor)


def hurried_rate(side: float, stance_left: bool, hurry: float, limit: float) -> float:
    """How fast the clip should play (1: as recorded) with the sideways capture offset ``side`` (m, + right):
    toward the stance foot's side, where the swing leg would have to step across the stance leg, faster by
    ``hurry`` per metre (at most ``limit``): that step lands sooner, and the leg on the side the body goes to
    steps out sooner."""
    inward = -side if stance_left else side
    return min(1.0 + hurry * max(inward, 0.0), limit)


def orientation_torque(desired: np.ndarray, actual: np.ndarray, omega: np.ndarray, kp: float, kd: float,
                       desired_omega: np.ndarray | None = None) -> np.ndarray:
    """World-frame PD torque turning ``actual`` toward ``desired`` (both x y z w)."""
    err = quat_log(q1.mul(desired, q1.conj(quat.align(actual, desired))))
    dw = -omega if desired_omega is None else desired_omega - omega
    out: np.ndarray = kp * err + kd * dw
    return out


def clamp_norm(v: np.ndarray, limit: float) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v if n <= limit or n == 0.0 else v * (limit / n)
