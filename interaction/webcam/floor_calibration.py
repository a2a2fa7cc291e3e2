"""Webcam → stage calibration on the floor, for a raised camera looking down: the camera's 3×4 matrix.

``projection`` P maps stage points to pixels, ``[u·w, v·w, w] = P·[x, y, z, 1]`` (stage frame: x to
the audience's right, y into the screen, z up, floor z = 0; w > 0 in front of the camera). Its
columns 0, 1 and 3 are the floor homography, column 2 the vertical's vanishing point. A person is
placed by their feet: the feet go through the floor (:meth:`FloorCalibration.image_to_floor`;
:mod:`interaction.webcam.floor_people`), and the rest of the body onto the upright plane through the person's
ground point facing the camera (:meth:`FloorCalibration.person`), so a head is placed along the
vertical above the feet. From a floor homography alone the camera is recovered assuming square pixels
and the principal point at the image centre (:func:`camera_from_floor`; the focal length found or given).

Saved as TOML with ``kind = "floor"`` (an upright-plane file has no ``kind`` or ``kind = "upright"``;
:func:`load_webcam_calibration` reads either)::

    kind = "floor"
    projection = [[p00, p01, p02, p03], [p10, ...], [p20, ...]]
    half_depth = 0.25
    image_size = [640, 480]   # optional
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from interaction.webcam.calibration import Calibration, CalibrationError, round_off_zeros
from sensors.untrusted import UntrustedInput, finite, load_toml, whole, write_owned

__all__ = ["FOOT_MIDDLE_M", "FloorCalibration", "PersonPlane", "camera_from_floor", "load_webcam_calibration"]

FOOT_MIDDLE_M = 0.04  # a foot's contactor (a shoe's middle) is this high above the floor
_KEYS = ("kind", "projection", "half_depth", "image_size")


@dataclass(frozen=True)
class FloorCalibration:
    """The camera's 3×4 matrix P (12 floats, row-major), stage metres → pixels; see the module.

    ``half_depth``: how far a webcam contactor reaches either side of the person's own upright plane
    (metres). ``image_size`` (width, height), when given, is the size it was made for.
    """

    projection: tuple[float, ...]
    half_depth: float = 0.25
    image_size: tuple[int, int] | None = None
    _p: np.ndarray = field(init=False, repr=False, compare=False)
    _m_inv: np.ndarray = field(init=False, repr=False, compare=False)
    _centre: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        p = self.projection
        if len(p) != 12 or not all(isinstance(x, int | float) and math.isfinite(x) for x in p):
            raise ValueError(f"projection: expected 12 finite numbers (3×4, row-major), got {list(p)!r}")
        m = np.asarray(p, dtype=np.float64).reshape(3, 4)
        if np.linalg.det(m[:, :3]) < 0:  # P and -P are one camera: the one with w > 0 in front (det K·R > 0)
            m = -m
        if not np.isfinite(np.linalg.cond(m[:, :3])) or np.linalg.cond(m[:, :3]) > 1e12:
            raise ValueError("projection: its left 3×3 part is singular (no camera has it)")
        if not (math.isfinite(self.half_depth) and self.half_depth >= 0):
            raise ValueError(f"half_depth: expected a number ≥ 0, got {self.half_depth}")
        if self.image_size is not None and (
            len(self.image_size) != 2
            or not all(isinstance(s, int) and not isinstance(s, bool) and s > 0 for s in self.image_size)
        ):
            raise ValueError(f"image_size: expected [width, height] in whole pixels > 0, got {self.image_size!r}")
        m_inv = np.linalg.inv(m[:, :3])
        centre = -m_inv @ m[:, 3]
        if centre[2] <= 0:
            raise ValueError(f"projection: puts the camera at height {centre[2]:.3f} m, below the floor")
        object.__setattr__(self, "_p", m)
        object.__setattr__(self, "_m_inv", m_inv)
        object.__setattr__(self, "_centre", centre)

    # ------------------------------------------------------------ geometry

    @property
    def matrix(self) -> np.ndarray:
        """P as a 3×4 float64 array (a copy)."""
        return np.array(self._p)

    @property
    def camera_centre(self) -> np.ndarray:
        """The camera's position in stage metres (3,)."""
        return np.array(self._centre)

    def stage_to_image(self, xyz: np.ndarray) -> np.ndarray:
        """Stage points (N, 3) → pixels (N, 2)."""
        p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        ph = np.column_stack([p, np.ones(len(p))]) @ self._p.T
        return ph[:, :2] / ph[:, 2:3]

    def rays(self, uv: np.ndarray) -> np.ndarray:
        """Stage directions (N, 3) of the rays through pixels (N, 2), pointing away from the camera."""
        p = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        return np.column_stack([p, np.ones(len(p))]) @ self._m_inv.T

    def image_to_floor(self, uv: np.ndarray, height: float = 0.0) -> np.ndarray:
        """Pixels (N, 2) → the stage points (N, 3) they see on the horizontal plane z = ``height``;
        NaN rows for pixels at or above that plane's horizon."""
        d = self.rays(uv)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (height - self._centre[2]) / d[:, 2]
        s = np.where(s > 0, s, np.nan)
        return self._centre + s[:, None] * d

    def person(self, ground_xy: tuple[float, float]) -> PersonPlane:
        """The upright plane through a person's ground point (stage x, y), facing the camera."""
        g = np.array([ground_xy[0], ground_xy[1], 0.0])
        n = g - self._centre
        n[2] = 0.0
        if float(np.linalg.norm(n)) < 1e-6:  # right under the camera: face along the optical axis, laid flat
            n = np.array([self._p[2, 0], self._p[2, 1], 0.0])
        if float(np.linalg.norm(n)) < 1e-9:  # and the camera looks straight down: face the audience
            n = np.array([0.0, 1.0, 0.0])
        return PersonPlane(self, g, n / float(np.linalg.norm(n)))

    def upright(self, plane_y: float | None = None) -> Calibration:
        """The upright-plane calibration (image → (x, z) on y = ``plane_y``; default: the floor point
        seen at the bottom middle of the image), for drawing a silhouette where the people are."""
        if plane_y is None:
            w, h = self.image_size or (640, 480)
            y = float(self.image_to_floor(np.array([[(w - 1) / 2, h - 1.0]]))[0, 1])
            plane_y = y if math.isfinite(y) else 0.0
        p = self._p
        to_image = np.column_stack([p[:, 0], p[:, 2], p[:, 3] + plane_y * p[:, 1]])
        m = np.linalg.inv(to_image)
        h_inv = tuple(float(x) for x in round_off_zeros(m / m[2, 2]).ravel())
        try:
            return Calibration(h_inv, plane_y, self.half_depth, self.image_size)
        except ValueError:  # the plane's horizon crosses the image (a turned camera): drawn without the size check
            return Calibration(h_inv, plane_y, self.half_depth, None)

    # ------------------------------------------------------------ files

    @classmethod
    def from_table(cls, data: dict[str, Any], source: str = "<calibration>") -> FloorCalibration:
        """Build from a parsed TOML table; errors are one line starting ``source: key:``."""
        unknown = sorted(set(data) - set(_KEYS))
        if unknown:
            raise CalibrationError(f"{source}: {unknown[0]}: unknown key (expected {', '.join(_KEYS)})")
        rows = data.get("projection")
        if not (isinstance(rows, list) and len(rows) == 3 and all(isinstance(r, list) and len(r) == 4 for r in rows)):
            raise CalibrationError(f"{source}: projection: expected 3 rows of 4 numbers, got {rows!r}"[:300])
        try:
            values = tuple(float(finite(x, f"{source}: projection")) for r in rows for x in r)
            half_depth = float(finite(data.get("half_depth", 0.25), f"{source}: half_depth", 0.0, 100.0))
            size = data.get("image_size")
            image_size = None
            if size is not None:
                if not (isinstance(size, list) and len(size) == 2):
                    raise UntrustedInput(f"{source}: image_size", f"expected [width, height], got {size!r}"[:200])
                image_size = (whole(size[0], f"{source}: image_size", 1, 65536),
                              whole(size[1], f"{source}: image_size", 1, 65536))
            return cls(values, half_depth, image_size)
        except ValueError as e:  # UntrustedInput is one
            msg = str(e)
            raise CalibrationError(msg if msg.startswith(source) else f"{source}: {msg}") from None

    def to_toml(self) -> str:
        """The TOML text (floats written exactly: a round trip is lossless)."""
        p = self.projection
        lines = [
            "# jostle webcam calibration on the floor: [u*w, v*w, w] = projection . [x, y, z, 1]",
            "# stage frame: x right, y into the screen, z up, the floor at z = 0",
            'kind = "floor"',
            "projection = [",
            *(f"  [{', '.join(repr(float(p[4 * r + c])) for c in range(4))}]," for r in range(3)),
            "]",
            f"half_depth = {float(self.half_depth)!r}",
        ]
        if self.image_size is not None:
            lines.append(f"image_size = [{self.image_size[0]}, {self.image_size[1]}]")
        return "\n".join(lines) + "\n"

    def save(self, path: Path | str) -> None:
        """Write the TOML file, replacing only a regular file."""
        write_owned(Path(path), self.to_toml().encode("utf-8"))


@dataclass(frozen=True, eq=False)
class PersonPlane:
    """The upright plane through one person's ground point ``ground`` (3,), normal ``normal`` (3,,
    horizontal): where the body seen in the image is placed."""

    calibration: FloorCalibration
    ground: np.ndarray
    normal: np.ndarray

    def image_to_stage(self, uv: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) → stage points (N, 3) on the plane; NaN rows for rays that miss it."""
        c = self.calibration.camera_centre
        d = self.calibration.rays(uv)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = float(self.normal @ (self.ground - c)) / (d @ self.normal)
        s = np.where(s > 0, s, np.nan)
        return c + s[:, None] * d

    def metres_per_pixel(self, uv: np.ndarray) -> np.ndarray:
        """The local scale (N,) on the plane at pixels (N, 2): √ of the area a pixel covers, metres."""
        p = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        at = self.image_to_stage(p)
        du = self.image_to_stage(p + [1.0, 0.0]) - at
        dv = self.image_to_stage(p + [0.0, 1.0]) - at
        return np.sqrt(np.linalg.norm(np.cross(du, dv), axis=1))


def camera_from_floor(
    floor_to_image: np.ndarray, image_size: tuple[int, int], focal_px: float | None = None
) -> tuple[np.ndarray, float]:
    """The camera matrix P (3×4, stage → pixels, its third row a unit vector) and the focal length
    (pixels) from the homography floor (x, y, 1) → pixels. Square pixels, the principal point at the
    image centre; the focal length is found from the homography unless given. Raises
    CalibrationError when the view cannot tell it (straight down, or no tilt) or the floor is seen
    from below (the points are mirrored)."""
    w, h = image_size
    k0 = np.array([[1.0, 0.0, (w - 1) / 2], [0.0, 1.0, (h - 1) / 2], [0.0, 0.0, 1.0]])
    g = np.linalg.inv(k0) @ np.asarray(floor_to_image, dtype=np.float64)  # ∝ diag(f, f, 1)[r1 r2 t]
    g = g / np.linalg.norm(g[:, :2])
    g1, g2 = g[:, 0], g[:, 1]
    if focal_px is None:
        # r1 ⟂ r2 and |r1| = |r2| with r_i ∝ (g_ix / f, g_iy / f, g_iz): two equations a·w + b = 0 in
        # w = 1/f², solved together by least squares (either alone fails for some views, e.g. no yaw)
        a = np.array([g1[0] * g2[0] + g1[1] * g2[1], g1[0] ** 2 + g1[1] ** 2 - g2[0] ** 2 - g2[1] ** 2])
        b = np.array([g1[2] * g2[2], g1[2] ** 2 - g2[2] ** 2])
        den = float(a @ a)
        w_inv = -float(a @ b) / den if den > 1e-30 else -1.0
        f2 = 1.0 / w_inv if w_inv > 0 else -1.0
        if not (math.isfinite(f2) and f2 > 0):
            raise CalibrationError("a floor seen from straight above or edge-on does not tell the camera's focal "
                                   "length")
        focal_px = math.sqrt(f2)
    f = float(focal_px)
    kinv = np.diag([1.0 / f, 1.0 / f, 1.0])
    a1, a2, a3 = kinv @ g1, kinv @ g2, kinv @ g[:, 2]
    lam = 2.0 / (np.linalg.norm(a1) + np.linalg.norm(a2))
    # in front of the camera: the floor point seen at the bottom middle of the image
    seen = np.linalg.solve(np.asarray(floor_to_image, dtype=np.float64), [(w - 1) / 2, h - 1.0, 1.0])
    if (lam * (a1 * seen[0] + a2 * seen[1] + a3 * seen[2]))[2] * seen[2] < 0:
        lam = -lam
    r1, r2, t = lam * a1, lam * a2, lam * a3
    u, _, vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    r = u @ vt  # the nearest rotation (exact data: r itself)
    p = np.diag([f, f, 1.0]) @ np.column_stack([r, t])
    p = k0 @ p
    if (-np.linalg.inv(p[:, :3]) @ p[:, 3])[2] <= 0:
        raise CalibrationError("the floor is seen from below: the points are mirrored (two of them swapped, or x "
                               "and y exchanged)")
    return round_off_zeros(p), f


def load_webcam_calibration(path: Path | str) -> Calibration | FloorCalibration:
    """Read a webcam calibration file of either kind: ``kind = "floor"`` or the upright plane (no
    ``kind``, or ``kind = "upright"``). Every error is one line naming the file and the key."""
    try:
        data = load_toml(path, what="calibration file")
    except FileNotFoundError:
        raise CalibrationError(f"{path}: no such calibration file (make one with `jostle calibrate`)") from None
    except ValueError as e:
        raise CalibrationError(str(e)) from None
    kind = data.get("kind", "upright")
    if kind == "floor":
        return FloorCalibration.from_table(data, str(path))
    if kind != "upright":
        raise CalibrationError(f"{path}: kind: expected 'floor' or 'upright', got {kind!r}"[:300])
    return Calibration.from_table(data, str(path))
