"""Depth camera → stage: the floor found by RANSAC in an empty-stage depth frame, plus where the
user says the camera stands (its foot point on the floor and a heading), as a rigid transform.

Camera frame (OpenCV's): x right, y down, z along the optical axis, metres. Stage frame: see
:mod:`interaction.types` (z up, floor z = 0). The fit: the floor's normal is the stage's z axis and
the camera's height is its distance to the floor; the stage's y axis is the optical axis laid flat
on the floor, turned by ``heading_deg`` about z (positive: toward the audience's left);
``origin_xy`` is the stage (x, y) of the floor point straight below the camera.

The check (the "reprojection error" of a floor): the distance of the floor pixels' points to the
fitted plane, RMS over every pixel within 4× the RANSAC threshold of it (so a wrong plane shows), in
metres. A stereo camera's error grows with the square of the distance, so a far floor scores worse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sensors.untrusted import MissingInput, UntrustedInput, load_toml, shorten, write_owned
from sensors.untrusted.limits import CALIBRATION

__all__ = ["DepthCalibration", "DepthCalibrationError", "FloorFit", "camera_points", "fit_floor", "calibrate_depth"]


class DepthCalibrationError(ValueError):
    """A depth calibration file that cannot be used, or a floor fit refused (the message says why)."""


MAX_STAGE_M = 1000.0  # metres: a camera (translation) or floor (d) farther from the stage is a broken file
_KEYS = ("rotation", "translation", "floor", "image_size", "floor_rms_m")


@dataclass(frozen=True)
class DepthCalibration:
    """Camera → stage: ``stage = R · camera + t``. ``rotation`` is R row-major (9 numbers, rows are the
    stage axes x, y, z in camera coordinates), ``translation`` is t (the camera's centre in stage
    metres), ``floor`` the floor plane in camera coordinates (a, b, c, d: a·x + b·y + c·z + d = 0,
    unit normal pointing up), ``image_size`` the depth image it was made for, ``floor_rms_m`` the
    fit's reprojection error."""

    rotation: tuple[float, ...]
    translation: tuple[float, ...]
    floor: tuple[float, ...]
    image_size: tuple[int, int] | None = None
    floor_rms_m: float = 0.0

    def __post_init__(self) -> None:
        if len(self.rotation) != 9 or not all(math.isfinite(v) for v in self.rotation):
            raise ValueError(f"rotation: expected 9 finite numbers (3 rows of 3), got {self.rotation!r}")
        r = np.array(self.rotation).reshape(3, 3)
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-4) or np.linalg.det(r) < 0:
            raise ValueError("rotation: expected a rotation matrix (orthonormal rows, determinant +1)")
        if len(self.translation) != 3 or not all(math.isfinite(v) for v in self.translation):
            raise ValueError(f"translation: expected [x, y, z] in stage metres, got {self.translation!r}")
        if max(abs(v) for v in self.translation) > MAX_STAGE_M:
            raise ValueError(f"translation: expected a camera within {MAX_STAGE_M:g} m of the stage, got {self.translation!r}")
        if len(self.floor) != 4 or not all(math.isfinite(v) for v in self.floor):
            raise ValueError(f"floor: expected 4 numbers a, b, c, d, got {self.floor!r}")
        if abs(math.hypot(*self.floor[:3]) - 1.0) > 1e-3 or abs(self.floor[3]) > MAX_STAGE_M:
            raise ValueError(f"floor: expected a unit normal (a, b, c) and |d| ≤ {MAX_STAGE_M:g} m, got {self.floor!r}")
        if self.image_size is not None and (len(self.image_size) != 2 or min(self.image_size) < 1):
            raise ValueError(f"image_size: expected [width, height] in whole pixels, got {self.image_size!r}")
        if not (math.isfinite(self.floor_rms_m) and self.floor_rms_m >= 0):
            raise ValueError(f"floor_rms_m: expected a number >= 0, got {self.floor_rms_m!r}")

    @property
    def matrix(self) -> np.ndarray:
        """R (3×3), camera → stage."""
        return np.array(self.rotation, dtype=np.float64).reshape(3, 3)

    @property
    def centre(self) -> np.ndarray:
        return np.array(self.translation, dtype=np.float64)

    def to_stage(self, points: np.ndarray) -> np.ndarray:
        """Camera points (..., 3) → stage points (..., 3)."""
        return np.asarray(points, dtype=np.float64) @ self.matrix.T + self.centre

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """Stage points (..., 3) → camera points (..., 3)."""
        return (np.asarray(points, dtype=np.float64) - self.centre) @ self.matrix

    def fits_image(self, size: tuple[int, int]) -> str | None:
        """None if depth frames of ``size`` (width, height) are the ones this calibration was made for
        (or it names none); a warning (one line) if only the scale differs: the same camera at another
        resolution, still right since the calibration is in metres and each frame brings its
        intrinsics. Another aspect ratio (another camera or mode) raises ``UntrustedInput``."""
        if self.image_size is None or tuple(size) == tuple(self.image_size):
            return None
        from sensors.untrusted import UntrustedInput

        (w0, h0), (w, h) = self.image_size, size
        made = f"the camera's depth frame is {w}×{h}, but the calibration was made for {w0}×{h0}"
        if abs(w * h0 - w0 * h) > 0.01 * w0 * h:
            raise UntrustedInput("depth calibration", f"{made} (another aspect ratio: another camera or mode); "
                                                      "calibrate again with `jostle calibrate depth`")
        return f"depth calibration: {made}: the same aspect ratio, taken as the same camera at another resolution"

    # ------------------------------------------------------------ TOML

    @classmethod
    def load(cls, path: Path | str) -> DepthCalibration:
        path = Path(path)
        try:
            data = load_toml(path, CALIBRATION, "depth calibration")
        except MissingInput:
            raise DepthCalibrationError(f"{path}: no such file (make it with `jostle calibrate depth`)") from None
        except UntrustedInput as e:
            raise DepthCalibrationError(str(e)) from None
        return cls.from_dict(data, str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "depth calibration") -> DepthCalibration:
        unknown = [k for k in data if k not in _KEYS]
        if unknown:
            raise DepthCalibrationError(f"{source}: {unknown[0]}: unknown key (expected {', '.join(_KEYS)})")
        kwargs: dict[str, Any] = {}
        for key, n in (("rotation", 9), ("translation", 3), ("floor", 4)):
            if key not in data:
                raise DepthCalibrationError(f"{source}: {key}: missing (expected {n} numbers)")
            value = data[key]
            flat = [x for row in value for x in (row if isinstance(row, list) else [row])] if isinstance(value, list) else None
            if flat is None or len(flat) != n or not all(_is_number(x) for x in flat):
                raise DepthCalibrationError(f"{source}: {key}: expected {n} numbers, got {shorten(value)}")
            kwargs[key] = tuple(float(x) for x in flat)
        if "image_size" in data:
            size = data["image_size"]
            if not (isinstance(size, list) and len(size) == 2 and all(type(s) is int for s in size)):
                raise DepthCalibrationError(f"{source}: image_size: expected [width, height] in whole pixels, got {shorten(size)}")
            kwargs["image_size"] = (size[0], size[1])
        if "floor_rms_m" in data:
            if not _is_number(data["floor_rms_m"]):
                raise DepthCalibrationError(f"{source}: floor_rms_m: expected a number, got {shorten(data['floor_rms_m'])}")
            kwargs["floor_rms_m"] = float(data["floor_rms_m"])
        try:
            return cls(**kwargs)
        except ValueError as e:
            raise DepthCalibrationError(f"{source}: {e}") from None

    def to_toml(self) -> str:
        r = self.rotation
        lines = [
            "# jostle depth calibration: stage = rotation . camera + translation (metres)",
            "# camera: x right, y down, z forward; stage: x right, y into the screen, z up, floor z = 0",
            "rotation = [",
            *(f"  [{_num(r[3 * i])}, {_num(r[3 * i + 1])}, {_num(r[3 * i + 2])}]," for i in range(3)),
            "]",
            f"translation = [{', '.join(_num(v) for v in self.translation)}]",
            "# the floor in camera coordinates: a*x + b*y + c*z + d = 0",
            f"floor = [{', '.join(_num(v) for v in self.floor)}]",
            f"floor_rms_m = {_num(self.floor_rms_m)}",
        ]
        if self.image_size is not None:
            lines.append(f"image_size = [{self.image_size[0]}, {self.image_size[1]}]")
        return "\n".join(lines) + "\n"

    def save(self, path: Path | str) -> None:
        write_owned(path, self.to_toml())  # atomic; a FIFO or device there is refused


@dataclass(frozen=True)
class FloorFit:
    """A floor found in depth frames: the plane (camera coordinates, unit normal up), how many pixels
    lie on it, and the reprojection error (RMS distance of the floor band's points to it, metres)."""

    plane: tuple[float, float, float, float]
    inliers: int
    valid: int
    rms_m: float

    @property
    def height_m(self) -> float:
        """The camera's height above the floor."""
        return self.plane[3]

    def describe(self) -> str:
        a, b, c, _ = self.plane
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, -b))))
        return (f"floor: camera {self.height_m:.3f} m above it, tilted {tilt:.1f}° from level; "
                f"{self.inliers} of {self.valid} pixels on it; reprojection error {self.rms_m * 1000:.1f} mm RMS")


def camera_points(depth_mm: np.ndarray, intrinsics: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Camera-frame points (N, 3) of the valid pixels of a depth image, and those pixels' (v, u) indices (N, 2)."""
    fx, fy, cx, cy = intrinsics
    v, u = np.nonzero(depth_mm)
    z = depth_mm[v, u].astype(np.float64) * 0.001
    pts = np.column_stack([(u - cx) / fx * z, (v - cy) / fy * z, z])
    return pts, np.column_stack([v, u])


def fit_floor(
    depth_mm: np.ndarray,
    intrinsics: tuple[float, float, float, float],
    *,
    threshold_m: float = 0.05,
    max_tilt_deg: float = 60.0,
    iterations: int = 300,
    seed: int = 0,
) -> FloorFit:
    """The floor in one (ideally a median of several) empty-stage depth image, by RANSAC.

    Candidate planes must face the camera from below (the camera above them) with a normal within
    ``max_tilt_deg`` of the camera's up (−y); of those, the one with most points within
    ``threshold_m`` wins, refined by least squares on its inliers. Raises DepthCalibrationError."""
    pts, _ = camera_points(depth_mm, intrinsics)
    if len(pts) < 100:
        raise DepthCalibrationError(f"floor: only {len(pts)} pixels hold depth; expected a view of the floor")
    rng = np.random.default_rng(seed)
    sample = pts if len(pts) <= 20000 else pts[rng.choice(len(pts), 20000, replace=False)]
    cos_tilt = math.cos(math.radians(max_tilt_deg))
    best: tuple[int, np.ndarray] | None = None
    for _ in range(iterations):
        a, b, c = sample[rng.choice(len(sample), 3, replace=False)]
        n = np.cross(b - a, c - a)
        norm = float(np.linalg.norm(n))
        if norm < 1e-9:
            continue
        n /= norm
        if n[1] > 0:
            n = -n  # up in the camera frame is −y
        d = -float(n @ a)
        if -n[1] < cos_tilt or d <= 0:
            continue
        count = int(np.count_nonzero(np.abs(sample @ n + d) < threshold_m))
        if best is None or count > best[0]:
            best = (count, np.append(n, d))
    if best is None:
        raise DepthCalibrationError("floor: no plane below the camera found; is the camera upright and the floor in view?")
    plane = best[1]
    for _ in range(3):  # least-squares refinement on the inliers
        on = np.abs(pts @ plane[:3] + plane[3]) < threshold_m
        if np.count_nonzero(on) < 3:
            break
        q = pts[on]
        centroid = q.mean(axis=0)
        _, _, vt = np.linalg.svd(q - centroid, full_matrices=False)
        n = vt[2] if vt[2][1] < 0 else -vt[2]
        plane = np.append(n, -float(n @ centroid))
    inliers = int(np.count_nonzero(np.abs(pts @ plane[:3] + plane[3]) < threshold_m))
    on = np.abs(pts @ plane[:3] + plane[3]) < 4 * threshold_m  # the floor band the error is measured over
    residual = pts[on] @ plane[:3] + plane[3]
    rms = float(np.sqrt(np.mean(np.square(residual)))) if len(residual) else math.inf
    a_, b_, c_, d_ = (float(v) for v in plane)
    return FloorFit((a_, b_, c_, d_), inliers, len(pts), rms)


def calibrate_depth(
    fit: FloorFit,
    origin_xy: tuple[float, float],
    heading_deg: float = 0.0,
    image_size: tuple[int, int] | None = None,
) -> DepthCalibration:
    """The camera → stage transform from a floor fit and where the camera stands (see the module doc)."""
    n = np.array(fit.plane[:3])
    forward = np.array([0.0, 0.0, 1.0]) - n[2] * n
    if np.linalg.norm(forward) < 1e-6:
        raise DepthCalibrationError("floor: the camera looks straight down; give the heading with a marker instead")
    forward /= np.linalg.norm(forward)
    h = math.radians(heading_deg)
    y_axis = math.cos(h) * forward + math.sin(h) * np.cross(n, forward)
    x_axis = np.cross(y_axis, n)
    r = np.vstack([x_axis, y_axis, n])
    t = (float(origin_xy[0]), float(origin_xy[1]), fit.height_m)
    return DepthCalibration(tuple(float(v) for v in r.reshape(-1)), t, fit.plane, image_size, fit.rms_m)


# ---------------------------------------------------------------- internals


def _is_number(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _num(x: float) -> str:
    return repr(float(x))
