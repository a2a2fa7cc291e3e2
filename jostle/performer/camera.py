"""The virtual webcam: a pinhole camera in the stage frame, its pybullet matrices and the exact
homography from its pixels to a vertical stage plane.

Conventions. Stage frame: metres, z up, x to the audience's right, y away from the audience.
Camera frame (OpenCV's): x right, y down, z along the optical axis. Pixel coordinates (u, v) are
OpenCV's: the centre of the top-left pixel is (0, 0), u grows to the right, v downward.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from interaction.webcam.calibration import round_off_zeros


@dataclass(frozen=True)
class PinholeCamera:
    """A square-pixel pinhole camera at ``position`` looking along +y, tilted down by ``pitch_deg``."""

    width: int
    height: int
    position: tuple[float, float, float]
    pitch_deg: float
    hfov_deg: float
    near: float = 0.05
    far: float = 40.0

    # ------------------------------------------------------------ intrinsics

    @property
    def vfov_deg(self) -> float:
        half = math.atan(math.tan(math.radians(self.hfov_deg) / 2) * self.height / self.width)
        return math.degrees(2 * half)

    @property
    def focal_px(self) -> float:
        return (self.width / 2) / math.tan(math.radians(self.hfov_deg) / 2)

    @property
    def intrinsics(self) -> np.ndarray:
        """K (3×3) for OpenCV pixel coordinates (pixel centres at integers), as pybullet renders.

        Measured on pybullet's TINY renderer (fit of rendered squares at known stage positions, at
        320×240 and 640×480): its image is the ideal pinhole image shifted by (+0.5, −0.5) pixel, i.e.
        the principal point sits at (W/2, H/2 − 1) rather than at the image centre (W/2 − ½, H/2 − ½).
        """
        f = self.focal_px
        return np.array([[f, 0.0, self.width / 2], [0.0, f, self.height / 2 - 1.0], [0.0, 0.0, 1.0]])

    # ------------------------------------------------------------ extrinsics

    @property
    def rotation(self) -> np.ndarray:
        """R (3×3): stage directions → camera frame; rows are the camera's right, down, forward."""
        p = math.radians(self.pitch_deg)
        right = [1.0, 0.0, 0.0]
        down = [0.0, -math.sin(p), -math.cos(p)]
        forward = [0.0, math.cos(p), -math.sin(p)]
        return np.array([right, down, forward])

    @property
    def centre(self) -> np.ndarray:
        return np.asarray(self.position, dtype=float)

    # ------------------------------------------------------------ geometry

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """Stage points (..., 3) in the camera frame (..., 3)."""
        return (np.asarray(points, dtype=float) - self.centre) @ self.rotation.T

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates (..., 2) of stage points (..., 3) in front of the camera."""
        c = self.to_camera(points)
        k = self.intrinsics
        z = c[..., 2]
        return np.stack([k[0, 0] * c[..., 0] / z + k[0, 2], k[1, 1] * c[..., 1] / z + k[1, 2]], axis=-1)

    def pixel_rays(self) -> np.ndarray:
        """Unit stage directions (H, W, 3) of the rays through every pixel centre."""
        k = self.intrinsics
        u, v = np.meshgrid(np.arange(self.width, dtype=float), np.arange(self.height, dtype=float))
        cam = np.stack([(u - k[0, 2]) / k[0, 0], (v - k[1, 2]) / k[1, 1], np.ones_like(u)], axis=-1)
        world = cam @ self.rotation  # R is orthonormal: camera → stage is R^T
        return world / np.linalg.norm(world, axis=-1, keepdims=True)

    def plane_homography(self, plane_y: float = 0.0) -> np.ndarray:
        """H (3×3) taking pixels (u, v, 1) to stage-plane coordinates (x, z, 1) on the plane y = plane_y.

        A stage point (x, plane_y, z) projects to K·R·(X − C) = K·R·[e_x | e_z | (0, plane_y, 0) − C]·(x, z, 1),
        so the pixel → plane map is the inverse of that 3×3 matrix, scaled so that H[2, 2] = 1.
        """
        kr = self.intrinsics @ self.rotation
        offset = np.array([0.0, plane_y, 0.0]) - self.centre
        plane_to_image = np.column_stack([kr[:, 0], kr[:, 2], kr @ offset])
        h = np.linalg.inv(plane_to_image)
        return round_off_zeros(h / h[2, 2])  # the same file on every CPU (no 1e-19 round-off entries)

    def camera_matrix(self) -> np.ndarray:
        """P (3×4) taking stage points (x, y, z, 1) to pixels (u·w, v·w, w), w the depth along the
        optical axis: K·R·[I | −C]. Its columns 0, 1, 3 are the floor's homography (the exact
        ``kind = "floor"`` calibration, ``interaction.webcam.floor_calibration``)."""
        kr = self.intrinsics @ self.rotation
        return round_off_zeros(np.column_stack([kr, -kr @ self.centre]))

    # ------------------------------------------------------------ pybullet

    def view_matrix(self) -> list[float]:
        """pybullet's (OpenGL) view matrix for this camera."""
        import pybullet as pb

        r = self.rotation
        eye = self.centre
        return list(pb.computeViewMatrix(eye.tolist(), (eye + r[2]).tolist(), (-r[1]).tolist()))

    def projection_matrix(self) -> list[float]:
        import pybullet as pb

        aspect = self.width / self.height
        return list(pb.computeProjectionMatrixFOV(self.vfov_deg, aspect, self.near, self.far))


def apply_homography(h: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Map points (..., 2) through a 3×3 homography."""
    uv = np.asarray(uv, dtype=float)
    ones = np.ones((*uv.shape[:-1], 1))
    out = np.concatenate([uv, ones], axis=-1) @ np.asarray(h, dtype=float).T
    return out[..., :2] / out[..., 2:3]
