"""Bounded external help on the root (the pelvis), for when joint torques alone are not enough.

Walking: a torque toward the upright (balance) orientation and a horizontal force that keeps the root where
the clip has it relative to the stance foot and at the clip's speed. Standing up: a torque toward the clip's
root orientation and an upward force toward the clip's root height. Each is clamped to its limit in the
spec (0 switches it off), and the character switches all of it off while falling and lying, and counts
the peaks (``external_assist_peak_n`` / ``_nm``) for the benchmark's ``external_assist_n``.
"""

from __future__ import annotations

import math

import numpy as np

from sim.articulated import balance as bal
from sim.articulated.spec import ArticulatedSpec
from sim.snapshot import CharacterState

ASSIST_KP = 1000.0  # N·m/rad, root orientation
ASSIST_KD = 3.0  # N·m·s/rad: explicit damping on the light pelvis must stay small (30 vibrates at 240 Hz)
FORCE_KP = 400.0  # N/m, root place relative to the stance foot vs the clip
FORCE_KD = 150.0  # N·s/m, root speed vs the clip
GETUP_KP = 600.0  # N·m/rad
LIFT_KP = 2000.0  # N/m
LIFT_KD = 200.0  # N·s/m


def orientation_help(desired: np.ndarray, actual: np.ndarray, omega: np.ndarray, kp: float,
                     limit: float) -> np.ndarray:
    """World torque (3,) turning the root toward ``desired``, at most ``limit`` N·m."""
    return bal.clamp_norm(bal.orientation_torque(desired, actual, omega, kp, ASSIST_KD), limit)


def placement_help(dd: np.ndarray, dv: np.ndarray, heading: float, limit: float) -> np.ndarray:
    """World horizontal force (3,) on the root from its (forward, right) place and speed errors."""
    f_fwd, f_right = -FORCE_KP * dd - FORCE_KD * dv
    c, s = math.cos(heading), math.sin(heading)
    return bal.clamp_norm(np.array([c * f_fwd + s * f_right, s * f_fwd - c * f_right, 0.0]), limit)


def lift_help(z_desired: float, z: float, vz: float, limit: float) -> float:
    """Upward force (N, ≥ 0) toward the clip's root height, at most ``limit``."""
    return float(np.clip(LIFT_KP * (z_desired - z) - LIFT_KD * vz, 0.0, limit))


def speed_help(dv: np.ndarray, heading: float, limit: float) -> np.ndarray:
    """World horizontal force (3,) bringing the root up to the clip's speed (walking off from a stand)."""
    f_fwd, f_right = -FORCE_KD * dv
    c, s = math.cos(heading), math.sin(heading)
    return bal.clamp_norm(np.array([c * f_fwd + s * f_right, s * f_fwd - c * f_right, 0.0]), limit)


def root_help(s: ArticulatedSpec, state: CharacterState, walk_in: bool, feet: bool, desired: np.ndarray,
              orn: np.ndarray, omega: np.ndarray, dd: np.ndarray, dv: np.ndarray, heading: float,
              height: tuple[float, float, float],
              rising: tuple[np.ndarray, np.ndarray, float] | None = None,
              after_face_up: bool = False) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(world torque, world force) on the root for this state, or None for each that is off. ``walk_in``:
    walking off from a stand (after a get-up), helped ``walk_in_assist`` times harder; ``feet``: the
    skeleton has feet (placement help); ``height``: (clip root height, root height, root vertical speed);
    ``rising``: standing up, (place error, speed error, heading) of the root over the feet vs the clip
    (``sim.articulated.getup.root_offset``), held with at most ``getup_place_force_n`` horizontally;
    ``after_face_up``: the walk-in follows the face-up get-up (speed help ``walk_in_force_faceup_n``)."""
    torque: np.ndarray | None = None
    force: np.ndarray | None = None
    if state in (CharacterState.WALK, CharacterState.STAGGER):
        boost = s.walk_in_assist if walk_in else 1.0
        if s.assist_torque_max_nm > 0:
            torque = orientation_help(desired, orn, omega, ASSIST_KP, s.assist_torque_max_nm * boost)
        speed_limit = s.walk_in_force_faceup_n if after_face_up else s.walk_in_force_n
        if feet and walk_in and speed_limit > 0:  # up to the clip's speed
            force = speed_help(dv, heading, speed_limit)
        elif s.assist_force_max_n > 0 and feet:
            force = placement_help(dd, dv, heading, s.assist_force_max_n)
    elif state == CharacterState.STAND_UP:
        if s.getup_assist_torque_max_nm > 0:
            torque = orientation_help(desired, orn, omega, GETUP_KP, s.getup_assist_torque_max_nm)
        if s.getup_assist_force_max_n > 0:
            z_des, z, vz = height
            force = np.array([0.0, 0.0, lift_help(z_des, z, vz, s.getup_assist_force_max_n)])
        if rising is not None and s.getup_place_force_n > 0:
            place = placement_help(rising[0], rising[1], rising[2], s.getup_place_force_n)
            force = place if force is None else force + place
    return torque, force
