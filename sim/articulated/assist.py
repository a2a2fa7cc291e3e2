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
