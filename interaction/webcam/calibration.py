"""Webcam → stage calibration: a homography from image pixels onto one vertical stage plane.

A webcam sees the people as a flat picture. The calibration says where that picture lies on the
stage: pixel (u, v) maps to stage metres (x, z) on the vertical plane ``y = plane_y`` (stage frame:
x to the audience's right, y into the screen, z up, floor z = 0). Contactors made from a webcam
are capsules along y spanning ``plane_y ± half_depth``, since a webcam cannot see depth.

Saved as a tiny TOML file::

    # jostle webcam calibration
    homography = [
      [h00, h01, h02],
      [h10, h11, h12],
      [h20, h21, h22],
    ]
    plane_y = 0.0
    half_depth = 1.0
    image_size = [640, 480]   # optional
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sensors.untrusted import MissingInput, UntrustedInput, load_toml, shorten, write_owned
from sensors.untrusted.limits import CALIBRATION

__all__ = ["Calibration", "CalibrationError"]

_KEYS = ("homography", "plane_y", "half_depth", "image_size", "kind")  # kind: "upright" if given


class CalibrationError(ValueError):
    """A calibration file or fit that cannot be used; one line naming the file (or input) and key."""


@dataclass(frozen=True)
class Calibration:
    """Image pixel (u, v) → stage (x, z) metres on the plane y = ``plane_y``.

    ``homography`` is the 3×3 matrix H, row-major, as 9 floats: ``[x·w, z·w, w] = H·[u, v, 1]``.
    ``image_size`` (width, height), when given, is the size the calibration was made for; an
    observer then refuses frames of another size.
    """

    homography: tuple[float, ...]
    plane_y: float = 0.0
    half_depth: float = 1.0
    image_size: tuple[int, int] | None = None
    _h: np.ndarray = field(init=False, repr=False, compare=False)
    _h_inv: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        h = self.homography
        if len(h) != 9 or not all(isinstance(x, int | float) and math.isfinite(x) for x in h):
            raise ValueError(f"homography: expected 9 finite numbers (3×3, row-major), got {h!r}")
        m = np.asarray(h, dtype=np.float64).reshape(3, 3)
        if not np.isfinite(np.linalg.cond(m)) or np.linalg.cond(m) > 1e12:
            raise ValueError(f"homography: expected an invertible 3×3 matrix, got {list(h)} (singular)")
        if not math.isfinite(self.plane_y):
            raise ValueError(f"plane_y: expected a finite number, got {self.plane_y}")
        if not (math.isfinite(self.half_depth) and self.half_depth >= 0):
            raise ValueError(f"half_depth: expected a number ≥ 0, got {self.half_depth}")
        if self.image_size is not None:
            size = self.image_size
            if len(size) != 2 or not all(isinstance(s, int) and not isinstance(s, bool) and s > 0 for s in size):
                raise ValueError(f"image_size: expected [width, height] in whole pixels > 0, got {size!r}")
            w, hh = size
            corners = np.array([[0, 0, 1], [w, 0, 1], [w, hh, 1], [0, hh, 1]], dtype=np.float64)
            ws = corners @ m[2]
            if not (np.all(ws > 0) or np.all(ws < 0)):
                raise ValueError(
                    f"homography: maps part of the {w}×{hh} image to infinity (the horizon crosses the image)"
                )
        object.__setattr__(self, "_h", m)
        object.__setattr__(self, "_h_inv", np.linalg.inv(m))

    # ------------------------------------------------------------ construction

    @classmethod
    def from_correspondences(
        cls,
        image_uv: np.ndarray,
        stage_xz: np.ndarray,
        *,
        plane_y: float = 0.0,
        half_depth: float = 1.0,
        image_size: tuple[int, int] | None = None,
    ) -> Calibration:
        """The homography fitted (normalised DLT, least squares) to ≥ 4 point pairs:
        image pixels (N, 2) and the stage (x, z) metres (N, 2) where they lie."""
        src = np.asarray(image_uv, dtype=np.float64).reshape(-1, 2)
        dst = np.asarray(stage_xz, dtype=np.float64).reshape(-1, 2)
        if len(src) < 4 or len(src) != len(dst):
            raise CalibrationError(f"image_uv: expected ≥ 4 point pairs, got {len(src)} image and {len(dst)} stage points")
        ts, td = _normaliser(src), _normaliser(dst)
        s = _project(ts, src)
        d = _project(td, dst)
        rows = []
        for (u, v), (x, z) in zip(s, d, strict=True):
            rows.append([u, v, 1, 0, 0, 0, -x * u, -x * v, -x])
            rows.append([0, 0, 0, u, v, 1, -z * u, -z * v, -z])
        _, sv, vt = np.linalg.svd(np.asarray(rows))
        if sv[-2] < 1e-9 * sv[0]:
            raise CalibrationError("image_uv: the points are degenerate (three or more on one line)")
        hn = vt[-1].reshape(3, 3)
        h = np.linalg.inv(td) @ hn @ ts
        h = h / h[2, 2] if abs(h[2, 2]) > 1e-12 else h / np.linalg.norm(h)
        return cls(tuple(float(x) for x in round_off_zeros(h).ravel()), plane_y, half_depth, image_size)

    # ------------------------------------------------------------ mapping

    @property
    def matrix(self) -> np.ndarray:
        """H as a 3×3 float64 array (a copy)."""
        return np.array(self._h)

    def image_to_stage(self, uv: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) → stage points (N, 3) on the plane y = ``plane_y``."""
        xz = _project(self._h, uv)
        out = np.empty((len(xz), 3), dtype=np.float64)
        out[:, 0] = xz[:, 0]
        out[:, 1] = self.plane_y
        out[:, 2] = xz[:, 1]
        return out

    def stage_to_image(self, xyz: np.ndarray) -> np.ndarray:
        """Stage points (N, 3) → pixels (N, 2), projected along y onto the calibrated plane."""
        p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        return _project(self._h_inv, p[:, [0, 2]])

    def metres_per_pixel(self, uv: np.ndarray) -> np.ndarray:
        """The local scale (N,) at pixels (N, 2): √|det J| of the map (u, v) → (x, z), in metres per pixel."""
        return np.sqrt(np.abs(np.linalg.det(self.jacobian(uv))))

    def jacobian(self, uv: np.ndarray) -> np.ndarray:
        """∂(x, z)/∂(u, v) at pixels (N, 2), shape (N, 2, 2)."""
        h = self._h
        p = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        ph = np.column_stack([p, np.ones(len(p))])
        num = ph @ h[:2].T  # (N, 2): x·w, z·w
        w = ph @ h[2]  # (N,)
        # d(a/w)/du = (a_u w - a w_u) / w²
        jac = (h[None, :2, :2] * w[:, None, None] - num[:, :, None] * h[None, 2, :2][:, None, :]) / (w**2)[
            :, None, None
        ]
        return jac

    # ------------------------------------------------------------ files

    @classmethod
    def load(cls, path: Path | str) -> Calibration:
        """Read a calibration TOML file. Every error is one line naming the file and the key."""
        path = Path(path)
        try:
            data = load_toml(path, CALIBRATION, "calibration")
        except MissingInput:
            raise CalibrationError(f"{path}: no such calibration file (make one with `jostle calibrate`)") from None
        except UntrustedInput as e:
            raise CalibrationError(str(e)) from None
        return cls.from_table(data, source=str(path))

    @classmethod
    def from_table(cls, data: dict[str, Any], source: str = "<calibration>") -> Calibration:
        """Build from an already parsed TOML table; errors start with ``source: key:``."""
        if data.get("kind", "upright") != "upright":
            raise CalibrationError(f"{source}: kind: expected 'upright' here, got {data['kind']!r}"[:300])
        unknown = sorted(set(data) - set(_KEYS))
        if unknown:
            raise CalibrationError(f"{source}: {unknown[0]}: unknown key (expected {', '.join(_KEYS)})")
        if "homography" not in data:
            raise CalibrationError(f"{source}: homography: missing (expected 3 rows of 3 numbers)")
        rows = data["homography"]
        if not (
            isinstance(rows, list)
            and len(rows) == 3
            and all(isinstance(r, list) and len(r) == 3 and all(_is_number(x) for x in r) for r in rows)
        ):
            raise CalibrationError(f"{source}: homography: expected 3 rows of 3 numbers, got {shorten(rows)}")
        kwargs: dict[str, Any] = {"homography": tuple(float(x) for r in rows for x in r)}
        for key in ("plane_y", "half_depth"):
            if key in data:
                if not _is_number(data[key]):
                    raise CalibrationError(f"{source}: {key}: expected a number, got {shorten(data[key])}")
                kwargs[key] = float(data[key])
        if "image_size" in data:
            size = data["image_size"]
            if not (isinstance(size, list) and len(size) == 2 and all(type(s) is int for s in size)):
                raise CalibrationError(f"{source}: image_size: expected [width, height] in whole pixels, got {shorten(size)}")
            kwargs["image_size"] = (size[0], size[1])
        try:
            return cls(**kwargs)
        except ValueError as e:
            raise CalibrationError(f"{source}: {e}") from None

    def to_toml(self) -> str:
        """The TOML text of this calibration (floats written exactly, so a round trip is lossless)."""
        h = self.homography
        lines = [
            "# jostle webcam calibration: image pixel (u, v) -> stage metres (x, z) on the plane y = plane_y",
            "# [x*w, z*w, w] = homography . [u, v, 1]; stage frame: x right, y into the screen, z up",
            "homography = [",
            *(f"  [{_num(h[3 * r])}, {_num(h[3 * r + 1])}, {_num(h[3 * r + 2])}]," for r in range(3)),
            "]",
            f"plane_y = {_num(self.plane_y)}",
            f"half_depth = {_num(self.half_depth)}",
        ]
        if self.image_size is not None:
            lines.append(f"image_size = [{self.image_size[0]}, {self.image_size[1]}]")
        return "\n".join(lines) + "\n"

    def save(self, path: Path | str) -> None:
        """Write the TOML file (see :meth:`to_toml`)."""
        write_owned(path, self.to_toml())  # atomic; a FIFO or device there is refused


# ---------------------------------------------------------------- internals


def round_off_zeros(h: np.ndarray) -> np.ndarray:
    """``h`` with every entry within 1e-12 of its largest magnitude set to exactly 0.0 (not -0.0).

    Such an entry is zero up to round-off, and its last bits differ between CPUs and BLAS kernels
    (3.66e-19 on one machine, 5.36e-19 on another): a homography that is computed and then saved
    holds 0 instead, so the file is the same wherever it was made (DESIGN.md §8)."""
    m = np.asarray(h, dtype=np.float64)
    scale = float(np.max(np.abs(m))) if m.size else 0.0
    return np.where(np.abs(m) <= 1e-12 * scale, 0.0, m)


def _is_number(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _num(x: float) -> str:
    """A float as TOML: repr round-trips exactly and is valid TOML for finite values."""
    return repr(float(x))


def _project(m: np.ndarray, pts: np.ndarray) -> np.ndarray:
    p = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    ph = np.column_stack([p, np.ones(len(p))]) @ m.T
    return ph[:, :2] / ph[:, 2:3]


def _normaliser(p: np.ndarray) -> np.ndarray:
    """Hartley normalisation: centre on the mean, mean distance √2."""
    c = p.mean(axis=0)
    d = float(np.mean(np.linalg.norm(p - c, axis=1)))
    s = math.sqrt(2) / d if d > 0 else 1.0
    return np.array([[s, 0, -s * c[0]], [0, s, -s * c[1]], [0, 0, 1]], dtype=np.float64)
