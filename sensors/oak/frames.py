"""Host side of the OAK driver: depthai messages → ``Frame(DepthImage)``, with no device needed.

What arrives from a camera is a ``dai.MessageGroup`` (the pipeline's Sync node pairs depth and
colour by timestamp) holding ``"depth"`` (RAW16, millimetres, aligned to the colour camera) and,
when colour is on, ``"color"``. Every depthai 3 ``ImgFrame`` carries its intrinsics in
``getTransformation()`` (the calibration combined with every crop and scale the pipeline applied),
so each frame is self-describing; the calibration read at connect time is the fallback.

Intrinsics follow OpenCV's convention (pixel centres at whole coordinates), the one
``foxglove.CameraCalibration`` and every jostle consumer use. Resizing an image by ``s`` moves a
point from ``x`` to ``(x + 0.5)·s − 0.5`` (cv2.resize's mapping), so ``cx' = (cx + 0.5)·s − 0.5``.
(depthai's own ``ImgTransformation.addScale`` multiplies ``cx`` by ``s``: a (s−1)/2 px difference.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from sensors.base import DepthImage, Frame

FitMode = Literal["crop", "stretch"]
MAX_AGE_S = 1.0  # a message older than this on arrival is taken as clock skew, not latency


class BadMessage(ValueError):
    """A message that cannot become a frame (wrong type, no depth, a size that makes no sense)."""


@dataclass(frozen=True, slots=True)
class Intrinsics:
    """Pinhole intrinsics of an image of ``width`` × ``height`` pixels (OpenCV convention)."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    @property
    def size(self) -> tuple[int, int]:
        return self.width, self.height

    @classmethod
    def from_matrix(cls, k: Any, size: tuple[int, int]) -> Intrinsics:
        """From a 3×3 matrix (nested lists or an array) for an image of ``size`` (w, h)."""
        m = np.asarray(k, dtype=np.float64)
        if m.shape != (3, 3) or not np.all(np.isfinite(m)):
            raise BadMessage(f"intrinsic matrix: expected 3x3 finite numbers, got shape {m.shape}")
        return cls(float(m[0, 0]), float(m[1, 1]), float(m[0, 2]), float(m[1, 2]), int(size[0]), int(size[1]))

    @property
    def plausible(self) -> bool:
        """Focal lengths > 1 px and the principal point inside the image (an identity matrix is not)."""
        return (self.fx > 1.0 and self.fy > 1.0 and 0.0 <= self.cx <= self.width and 0.0 <= self.cy <= self.height
                and all(math.isfinite(v) for v in (self.fx, self.fy, self.cx, self.cy)))


def fit_intrinsics(k: Intrinsics, size: tuple[int, int], mode: FitMode = "crop") -> Intrinsics:
    """The intrinsics of ``k``'s image after it is brought to ``size`` (w, h).

    ``"stretch"`` scales each axis on its own (cv2.resize to ``size``). ``"crop"`` keeps the aspect
    ratio: scale by the larger ratio, then crop the excess evenly from both sides (what depthai's
    Camera outputs and ``keepAspectRatio`` do).
    """
    w, h = int(size[0]), int(size[1])
    if w <= 0 or h <= 0:
        raise ValueError(f"size: expected width and height > 0, got {size}")
    sx, sy = w / k.width, h / k.height
    if mode == "stretch":
        ox = oy = 0.0
    elif mode == "crop":
        sx = sy = max(sx, sy)
        ox, oy = (k.width * sx - w) / 2.0, (k.height * sy - h) / 2.0
    else:
        raise ValueError(f"mode: expected 'crop' or 'stretch', got {mode!r}")
    return Intrinsics(fx=k.fx * sx, fy=k.fy * sy, cx=(k.cx + 0.5) * sx - 0.5 - ox, cy=(k.cy + 0.5) * sy - 0.5 - oy,
                      width=w, height=h)


def crop_to_aspect(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """The centred part of ``image`` with the aspect ratio of ``size`` (what "crop" fitting keeps)."""
    h, w = image.shape[:2]
    s = max(size[0] / w, size[1] / h)
    cw, ch = min(w, round(size[0] / s)), min(h, round(size[1] / s))
    x0, y0 = (w - cw) // 2, (h - ch) // 2
    return image[y0 : y0 + ch, x0 : x0 + cw]


def intrinsics_of(msg: Any) -> Intrinsics | None:
    """The intrinsics an ``ImgFrame`` carries (None if its transformation is unset or implausible)."""
    get = getattr(msg, "getTransformation", None)
    if get is None:
        return None
    try:
        tr = get()
        if not tr.isValid():
            return None
        size = tuple(int(v) for v in tr.getSize())
        k = Intrinsics.from_matrix(tr.getIntrinsicMatrix(), (size[0], size[1]))
    except (BadMessage, RuntimeError, TypeError, ValueError):
        return None
    if k.size != (int(msg.getWidth()), int(msg.getHeight())) or not k.plausible:
        return None
    return k


def _resize(image: np.ndarray, size: tuple[int, int], *, nearest: bool) -> np.ndarray:
    import cv2

    interp = cv2.INTER_NEAREST if nearest else cv2.INTER_AREA
    return np.asarray(cv2.resize(image, size, interpolation=interp))


def depth_of(msg: Any) -> np.ndarray:
    """The (H, W) uint16 millimetres of a depth ``ImgFrame``."""
    data = np.asarray(msg.getFrame())
    if data.ndim != 2 or data.dtype != np.uint16:
        raise BadMessage(f"depth frame: expected RAW16 (H, W) uint16 millimetres, got {data.dtype} {data.shape} "
                         f"(type {msg.getType()})")
    return data


def color_of(msg: Any) -> np.ndarray:
    """The (H, W, 3) uint8 BGR of a colour ``ImgFrame`` (depthai converts NV12 and planar types)."""
    data = np.asarray(msg.getCvFrame())
    if data.ndim == 2:
        data = np.repeat(data[:, :, None], 3, axis=2)
    if data.ndim != 3 or data.shape[2] != 3 or data.dtype != np.uint8:
        raise BadMessage(f"colour frame: expected BGR uint8 (H, W, 3), got {data.dtype} {data.shape}")
    return data


def group_parts(message: Any) -> tuple[Any, Any | None]:
    """(depth, colour or None) of a ``MessageGroup``; a lone ``ImgFrame`` is depth only."""
    names = getattr(message, "getMessageNames", None)
    if names is None:
        return message, None
    present = set(names())
    if "depth" not in present:
        raise BadMessage(f"message group without depth (it holds {', '.join(sorted(present)) or 'nothing'})")
    return message["depth"], message["color"] if "color" in present else None


def assemble_depth(message: Any, size: tuple[int, int], fallback: Intrinsics | None) -> tuple[DepthImage, str]:
    """A ``DepthImage`` of exactly ``size`` from one message, and where its intrinsics came from.

    Depth that arrives at another size is resized (nearest: no invented depths) with its intrinsics
    fitted ("stretch", the same mapping); colour at another size than the depth is resized to it.
    The source is ``"frame"`` (the message's own transformation), ``"calibration"`` (``fallback``,
    fitted to the size) or ``"none"`` (zero intrinsics: Foxglove's "uncalibrated").
    """
    depth_msg, color_msg = group_parts(message)
    depth = depth_of(depth_msg)
    h, w = depth.shape
    k = intrinsics_of(depth_msg)
    source = "frame"
    if k is None and fallback is not None:
        k, source = fit_intrinsics(fallback, (w, h), "crop"), "calibration"
    if k is None:
        source = "none"
    if (w, h) != size:
        depth = _resize(depth, size, nearest=True)
        if k is not None:
            k = fit_intrinsics(k, size, "stretch")
    color = None
    if color_msg is not None:
        color = color_of(color_msg)
        if (color.shape[1], color.shape[0]) != size:
            color = _resize(color, size, nearest=False)
    fx, fy, cx, cy = (k.fx, k.fy, k.cx, k.cy) if k is not None else (0.0, 0.0, 0.0, 0.0)
    return DepthImage(depth_mm=np.ascontiguousarray(depth), fx=fx, fy=fy, cx=cx, cy=cy, color=color), source


class FrameNumbering:
    """Loop-clock times and sequence numbers for the frames of one sensor, across reconnects.

    ``t`` is the arrival time on the loop clock minus the message's age (its latency, when the
    device clock is synced to the host), never before ``start_t`` (when the sensor opened) nor
    before the previous frame. ``seq`` steps over the frames the device numbered but that never
    arrived; when the device's numbering restarts (a reconnect, a reboot) it simply counts on.
    """

    def __init__(self, start_t: float = 0.0) -> None:
        self.start_t = start_t
        self._last_t: float | None = None
        self._last_seq: int | None = None
        self._last_device_seq: int | None = None
        self.skipped = 0

    def next(self, now: float, age_s: float, device_seq: int) -> tuple[float, int]:
        age = age_s if math.isfinite(age_s) and 0.0 <= age_s <= MAX_AGE_S else 0.0
        t = max(now - age, self.start_t)
        if self._last_t is not None and t < self._last_t:
            t = self._last_t
        if self._last_seq is None:
            seq = 0
        elif self._last_device_seq is not None and device_seq > self._last_device_seq:
            gap = device_seq - self._last_device_seq
            seq = self._last_seq + gap
            self.skipped += gap - 1
        else:
            seq = self._last_seq + 1
        self._last_t, self._last_seq, self._last_device_seq = t, seq, device_seq
        return t, seq

    def restart_device_numbering(self) -> None:
        """The device's numbering starts again (after a reconnect): do not read it as a gap."""
        self._last_device_seq = None


def make_frame(name: str, message: Any, numbering: FrameNumbering, *, now: float, age_s: float,
               size: tuple[int, int], fallback: Intrinsics | None) -> tuple[Frame, str]:
    """One ``Frame`` from one message (see :func:`assemble_depth`), and its intrinsics source."""
    payload, source = assemble_depth(message, size, fallback)
    depth_msg, _ = group_parts(message)
    t, seq = numbering.next(now, age_s, int(depth_msg.getSequenceNum()))
    return Frame(sensor=name, t=float(t), seq=seq, payload=payload), source
