"""Webcam people placed on a floor calibration: feet on the floor, the body upright above them.

The observer (:mod:`interaction.webcam.observer`) finds a person's outline points, feet and keypoint
limbs in the image; here they get stage positions through a :class:`FloorCalibration`. The feet go
onto the floor from their soles (:func:`_shoe_middles`, a shoe's middle high: ``FOOT_MIDDLE_M``); the
person's ground point is their feet's middle (else the outline's bottom middle); everything else lands
on the upright plane through that ground point facing the camera, so a head is placed along the
vertical above the feet and a person's y is their depth. Velocities are the optical flow's
displacement mapped the same way (with a y part). Points whose ray misses their plane are left out.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from interaction.types import Contactor
from interaction.webcam.config import WebcamObserverConfig
from interaction.webcam.floor_calibration import FOOT_MIDDLE_M, FloorCalibration, PersonPlane
from interaction.webcam.people_flow import median_flow
from interaction.webcam.pose import LimbPoint

__all__ = ["FloorCalibration", "FloorPeople", "flow_back"]

_RADIUS_PER_SPACING = 0.6  # as the observer's: neighbouring outline contactors overlap a little
_SAME_SHOE_M = 0.15  # feet found nearer than this on the floor are pieces of one shoe (from above it is long)
_SOLE_WINDOW_PX = 2.0  # a foot's sole: the outline's lowest point this many columns either side of it (input px)
_SHOE_HALF_WIDTH_M = 0.03  # the shoe's middle beyond its sole's near edge (measured best of 0, 0.03, 0.06 m)
_KEYPOINT_STEP_S = 0.01  # a keypoint's pixel velocity is mapped over this time step
_MAX_REACH_M = 100.0  # a point placed farther from the stage origin is a ray that grazed its plane


class FloorPeople:
    """Stage contactors of webcam people on a floor calibration; remembers each person's upright
    plane from :meth:`body` for their keypoint limbs (:meth:`limbs`) in the same frame."""

    def __init__(self, calibration: FloorCalibration, config: WebcamObserverConfig) -> None:
        self.calibration = calibration
        self._cfg = config
        self._planes: dict[int, PersonPlane] = {}

    def body(self, person: int, parts: list[str], uv: np.ndarray, n_feet: int, outline: np.ndarray,
             back: np.ndarray | None, dt: float) -> list[Contactor]:
        """One person's contactors from input pixels ``uv`` (N, 2) named ``parts``, the last ``n_feet``
        the feet; ``outline`` (M, 2) input pixels; ``back`` (N, 2) where each point was a frame (``dt``
        seconds) before, relative to now, or None (no velocity)."""
        cal, cfg = self.calibration, self._cfg
        self._planes.pop(person, None)
        on_floor = np.arange(len(uv)) >= len(uv) - n_feet
        shoes = _shoe_middles(cal, uv[on_floor], outline)
        feet = shoes[np.isfinite(shoes).all(axis=1)]
        if len(feet):
            ground = feet[:, :2].mean(axis=0)
        else:  # no feet found: the outline's bottom middle (too near when the frame cuts the legs)
            pts = np.asarray(outline, dtype=np.float64).reshape(-1, 2)
            bottom = pts[pts[:, 1] >= pts[:, 1].max() - 1.0]
            ground = cal.image_to_floor(np.array([[bottom[:, 0].mean(), bottom[:, 1].max()]]))[0, :2]
            if not np.isfinite(ground).all():
                return []
        plane = self._planes[person] = cal.person((float(ground[0]), float(ground[1])))
        if cfg.contactor_radius_m > 0:
            radius = np.full(len(parts), cfg.contactor_radius_m)
        else:
            radius = _RADIUS_PER_SPACING * cfg.contour_spacing_px * plane.metres_per_pixel(uv)
        to_stage = _mapping(cal, plane, on_floor)
        pos = to_stage(uv)
        vel = (pos - to_stage(uv + back)) / dt if back is not None and dt > 0 else np.zeros_like(pos)
        pos[on_floor] = shoes
        keep = _one_per_shoe(pos, on_floor)
        return _contactors(person, [p for p, k in zip(parts, keep, strict=True) if k], pos[keep], vel[keep],
                           radius[keep], cal.half_depth)

    def limbs(self, person: int, limbs: list[LimbPoint], uv: np.ndarray, back: np.ndarray | None,
              dt: float) -> list[Contactor]:
        """Keypoint hands and feet (``uv`` (N, 2) their input pixels) on the plane :meth:`body` placed the
        person on this frame (none without one). Velocity: the flow's ``back`` over ``dt``, else the
        keypoints' own pixel velocity."""
        plane = self._planes.get(person)
        if plane is None:
            return []
        to_stage = _mapping(self.calibration, plane, np.array([limb.part.endswith("foot") for limb in limbs]))
        pos = to_stage(uv)
        if back is not None and dt > 0:
            vel = (pos - to_stage(uv + back)) / dt
        else:
            step = _KEYPOINT_STEP_S * np.array([limb.velocity for limb in limbs], dtype=np.float64)
            vel = (to_stage(uv + step) - pos) / _KEYPOINT_STEP_S
        radius = np.full(len(limbs), self._cfg.pose_radius_m)
        return _contactors(person, [limb.part for limb in limbs], pos, vel, radius, self.calibration.half_depth)


def flow_back(flow_px: np.ndarray | None, people: np.ndarray, uv_px: np.ndarray, window_px: int, scale: float,
              dt: float) -> np.ndarray | None:
    """Where points (work pixels ``uv_px``) were a frame before, relative to now, in input pixels
    (N, 2), from the median backward flow ``flow_px`` (work pixels) over the person's pixels near each
    (``scale``: work pixels per input pixel); None without flow or interval."""
    if flow_px is None or dt <= 0:
        return None
    return np.asarray(median_flow(flow_px, people, uv_px, window_px) / scale)


def _mapping(cal: FloorCalibration, plane: PersonPlane, on_floor: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """Pixels (N, 2) → stage (N, 3): rows ``on_floor`` through the floor at a shoe's middle, the rest
    onto ``plane``."""
    def to_stage(uv: np.ndarray) -> np.ndarray:
        out = plane.image_to_stage(uv)
        if on_floor.any():
            out[on_floor] = cal.image_to_floor(uv[on_floor], FOOT_MIDDLE_M)
        return out
    return to_stage


def _shoe_middles(cal: FloorCalibration, feet_uv: np.ndarray, outline: np.ndarray) -> np.ndarray:
    """Stage points (K, 3) of the shoes' middles from the feet's pixels (K, 2): the outline's lowest
    point within ``_SOLE_WINDOW_PX`` columns of a foot is the sole's edge nearest the camera, on the
    floor; the shoe's middle is ``_SHOE_HALF_WIDTH_M`` beyond it (away from the camera), a shoe's middle
    high. From a raised camera the foot's own pixel (its leg end's lowest rows) sits 1–1.5 px below the
    shoe's middle (docs/notes/floor-calibration.md)."""
    pts = np.asarray(outline, dtype=np.float64).reshape(-1, 2)
    soles = np.array(feet_uv, dtype=np.float64).reshape(-1, 2)
    for k, (u, v) in enumerate(soles):
        near = pts[np.abs(pts[:, 0] - u) <= _SOLE_WINDOW_PX, 1]
        soles[k, 1] = max(v, float(near.max())) if len(near) else v
    out = cal.image_to_floor(soles, 0.0)
    away = out - cal.camera_centre
    away[:, 2] = 0.0
    out += _SHOE_HALF_WIDTH_M * away / np.linalg.norm(away, axis=1, keepdims=True).clip(1e-9)
    out[:, 2] = FOOT_MIDDLE_M
    return out


def _one_per_shoe(pos: np.ndarray, on_floor: np.ndarray) -> np.ndarray:
    """Which rows to keep (bool (N,)) when feet (rows ``on_floor``) nearer than ``_SAME_SHOE_M`` on the
    floor are one shoe: the first of them is kept, moved (in ``pos``, with the others' mean)."""
    keep = np.ones(len(pos), bool)
    rows = np.flatnonzero(on_floor)
    for i, a in enumerate(rows):
        if not keep[a]:
            continue
        same = [b for b in rows[i + 1:] if keep[b] and np.hypot(*(pos[b, :2] - pos[a, :2])) < _SAME_SHOE_M]
        if same:
            pos[a] = pos[[a, *same]].mean(axis=0)
            keep[same] = False
    return keep


def _contactors(person: int, parts: list[str], pos: np.ndarray, vel: np.ndarray, radius: np.ndarray,
                half_depth: float) -> list[Contactor]:
    """Contactors of the points placed within ``_MAX_REACH_M`` of the stage origin (a ray grazing its
    plane lands far off); a velocity that is not finite (its point's ray missed) is 0."""
    out = []
    vel = np.nan_to_num(vel, nan=0.0, posinf=0.0, neginf=0.0)
    for part, p, v, r in zip(parts, pos.tolist(), vel.tolist(), radius.tolist(), strict=True):
        if all(map(math.isfinite, p)) and math.hypot(*p) < _MAX_REACH_M and math.isfinite(r):
            out.append(Contactor(person, part, (p[0], p[1], p[2]), (v[0], v[1], v[2]), r, half_depth))
    return out
