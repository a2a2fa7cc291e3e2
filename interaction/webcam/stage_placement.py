"""Where one frame's people go on the stage: their outline points, hands and feet (and, with pose,
their limbs from body keypoints) become contactors in stage metres and m/s, through the webcam's
calibration onto its upright plane or, with a floor calibration, through :class:`FloorPeople`.
Velocities come from the backward optical flow at each point (work pixels, ``scale`` work pixels per
input pixel), or from the keypoints' own motion where there is no flow yet."""

from __future__ import annotations

import cv2
import numpy as np

from interaction.people import Blob, outline_points
from interaction.types import Contactor
from interaction.webcam.calibration import Calibration
from interaction.webcam.config import WebcamObserverConfig
from interaction.webcam.floor_people import FloorPeople, flow_back
from interaction.webcam.people_flow import median_flow
from interaction.webcam.pose_limbs import PoseLimbs
from interaction.webcam.silhouette_parts import PersonBlob, feet

RADIUS_PER_SPACING = 0.6  # derived radius: neighbouring outline contactors overlap a little


def to_input_px(scale: float, uv_work: np.ndarray) -> np.ndarray:
    """Work pixel coordinates → input pixel coordinates (pixel centres kept aligned)."""
    if scale == 1.0:
        return uv_work
    return (uv_work + 0.5) / scale - 0.5


class StagePlacement:
    """Places people on the stage for one observer: ``calibration`` (the upright plane; an identity
    for image pixels when uncalibrated) and ``floor`` (None unless a floor calibration is used)."""

    def __init__(self, config: WebcamObserverConfig, calibration: Calibration, floor: FloorPeople | None) -> None:
        self._cfg, self._cal, self._floor = config, calibration, floor

    def body(self, person: int, blob: PersonBlob, people: np.ndarray, dt: float, flow_px: np.ndarray | None,
             scale: float) -> list[Contactor]:
        """One person's contactors; ``dt`` ≤ 0 gives them no velocity (first sight, no interval).
        Feet are the middles of the leg ends (:func:`interaction.webcam.silhouette_parts.feet`), not the
        lowest outline points; a person cut apart from others gets no hands from the outline (its
        torso, which tells an arm held out from the body, is partly the cut)."""
        cfg = self._cfg
        size = people.shape[::-1]
        outline, named = outline_points(blob.blob.contour, cfg.contour_spacing_px * scale, size)
        cut = blob.cut_left or blob.cut_right  # its torso, which places the hands, is not its own outline
        keep = [part != "foot" and not (part == "hand" and cut) for part in named]
        found_feet = feet(blob.blob.contour, size, blob.cut_left, blob.cut_right)
        uv_work = np.concatenate([outline[keep].astype(np.float64), found_feet])
        parts = [p for p, k in zip(named, keep, strict=True) if k] + ["foot"] * len(found_feet)
        uv_px = np.rint(uv_work).astype(np.intp)
        uv = to_input_px(scale, uv_work)
        if self._floor is not None:
            back = flow_back(flow_px, people, uv_px, self._cfg.flow_window_px, scale, dt)
            return self._floor.body(person, parts, uv, len(found_feet), to_input_px(scale, blob.blob.contour), back, dt)
        pos = self._cal.image_to_stage(uv)
        vel = self._flow_velocity(uv_px, uv, pos, people, dt, flow_px, scale)
        if vel is None:
            vel = np.zeros_like(pos)
        if cfg.contactor_radius_m > 0:
            radius = np.full(len(parts), cfg.contactor_radius_m)
        else:
            radius = RADIUS_PER_SPACING * cfg.contour_spacing_px * self._cal.metres_per_pixel(uv)
        half_depth = self._cal.half_depth
        p, v, r = pos.tolist(), vel.tolist(), radius.tolist()
        return [
            Contactor(person, part, (p[i][0], p[i][1], p[i][2]), (v[i][0], 0.0, v[i][2]), r[i], half_depth)
            for i, part in enumerate(parts)
        ]

    def _flow_velocity(
        self, uv_px: np.ndarray, uv: np.ndarray, pos: np.ndarray, people: np.ndarray, dt: float,
        flow_px: np.ndarray | None, scale: float,
    ) -> np.ndarray | None:
        """Stage velocities (N, 3) of points (work pixels ``uv_px`` as ints, input pixels ``uv``, stage
        ``pos``) from the median optical flow over the person's pixels near each; None without flow."""
        if flow_px is None or dt <= 0:
            return None
        back = median_flow(flow_px, people, uv_px, self._cfg.flow_window_px)
        vel = (pos - self._cal.image_to_stage(uv + back / scale)) / dt
        vel[:, 1] = 0.0
        return vel

    def limbs(
        self, pose: PoseLimbs, bgr: np.ndarray, ids: list[int], blobs: list[Blob], people: np.ndarray, t: float,
        dt: float, born: frozenset[int], flow_px: np.ndarray | None, scale: float,
    ) -> list[Contactor]:
        """Hands and feet from each person's newest body keypoints, moved on by their velocity from the
        keypoints' frame to this one, where they lie on the silhouette. Their velocity is the optical
        flow at the limb, or the keypoints' smoothed motion where there is no flow (a person's first
        frames): the flow is the better of the two (docs/notes/webcam.md)."""
        outlines = [to_input_px(scale, b.contour.astype(np.float64)) for b in blobs]
        pose.update(t, bgr, ids, outlines, self._cal.image_to_stage)
        grow = 2 * self._cfg.morphology_px + 1  # the people a little grown, at work size (at 1768×994: 10 ms)
        accept = cv2.dilate(people, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (grow, grow)))
        out: list[Contactor] = []
        for pid in sorted(ids):
            limbs = pose.limbs(pid, t, accept, scale)
            if not limbs:
                continue
            uv = np.array([limb.uv for limb in limbs])
            uv_px = np.clip(np.rint((uv + 0.5) * scale - 0.5), 0, np.array(people.shape[::-1]) - 1).astype(np.intp)
            if self._floor is not None:
                back = flow_back(flow_px, people, uv_px, self._cfg.flow_window_px, scale, 0.0 if pid in born else dt)
                out.extend(self._floor.limbs(pid, limbs, uv, back, dt))
                continue
            pos = self._cal.image_to_stage(uv)
            vel = self._flow_velocity(uv_px, uv, pos, people, 0.0 if pid in born else dt, flow_px, scale)
            if vel is None:
                vxz = np.einsum("nij,nj->ni", self._cal.jacobian(uv), np.array([limb.velocity for limb in limbs]))
                vel = np.column_stack([vxz[:, 0], np.zeros(len(vxz)), vxz[:, 1]])
            r, hd = self._cfg.pose_radius_m, self._cal.half_depth
            for limb, p, v in zip(limbs, pos.tolist(), vel.tolist(), strict=True):
                out.append(Contactor(pid, limb.part, (p[0], p[1], p[2]), (v[0], 0.0, v[2]), r, hd))
        return out
