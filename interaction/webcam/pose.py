"""Body keypoints through OpenCV: BlazePose's landmark model run by ``cv2.dnn`` on person crops.

The model (``pose_landmark_full.tflite``, from the mediapipe wheel; see :mod:`interaction.webcam.pose_models`)
takes a 256×256 RGB crop in [0, 1] (NCHW) that holds one person, upright and centred on the hips,
and gives 33 keypoints (plus 6 of its own for the next crop) as (x, y, z, visibility, presence)
in crop pixels, a presence score for the whole person, and heatmaps. MediaPipe's person detector
does not load in OpenCV, so, as MediaPipe does between detections, the crop comes from elsewhere:
from the silhouette's outline on first sight (:meth:`PoseCrop.around`), then from the previous
frame's keypoints (:meth:`PoseCrop.from_keypoints`: centre on the hips, side 2.5 × the distance from
the hips to the model's own "body extent" point, turned so the body is upright). For still
photographs the selfie segmentation model gives the person's outline instead
(:meth:`PoseModel.person_mask`).

OpenCV traps (measured with OpenCV 5.0): the default ("new") DNN engine exposes only one output
of the landmark model; the classic engine exposes all five, so both nets are loaded with
``ENGINE_CLASSIC``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from interaction.webcam.pose_models import LANDMARK_FILE, SEGMENTATION_FILE

__all__ = [
    "KEYPOINT_NAMES",
    "LIMBS",
    "Keypoints",
    "LimbPoint",
    "PoseCrop",
    "PoseModel",
    "PoseModelError",
    "PoseTracker",
]

KEYPOINT_NAMES: tuple[str, ...] = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye", "right_eye_outer",
    "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder", "right_shoulder", "left_elbow",
    "right_elbow", "left_wrist", "right_wrist", "left_pinky", "right_pinky", "left_index", "right_index",
    "left_thumb", "right_thumb", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle",
    "right_ankle", "left_heel", "right_heel", "left_foot_index", "right_foot_index",
)
"""The 33 BlazePose keypoints, in the model's order ("left" is the person's own left)."""

_INPUT = 256  # the landmark model's crop side, pixels
_HEATMAP = 64  # its heatmaps' side
_OUTPUTS = ("Identity", "Identity_1", "Identity_2", "Identity_3", "Identity_4")
_HIPS, _EXTENT = 33, 34  # the model's own alignment points: mid-hips, and a point at the body's reach
_CROP_SCALE = 1.25  # MediaPipe's: the crop side is 2 × 1.25 × the hips-to-extent distance
_REFINE_KERNEL = 7  # heatmap window (cells) for refining keypoints, as MediaPipe does
_REFINE_MIN = 0.5  # refine only where the heatmap is at least this confident


class PoseModelError(RuntimeError):
    """A model file that cannot be loaded; one line naming the file."""


@dataclass(frozen=True)
class PoseCrop:
    """A square, possibly turned, region of an image that holds one person.

    ``centre`` (u, v) and ``side`` are in the image's pixels (pixel centres at whole numbers, as in
    OpenCV); ``up`` is the unit vector in the image pointing from the person's hips to their head.
    """

    centre: tuple[float, float]
    side: float
    up: tuple[float, float] = (0.0, -1.0)

    @classmethod
    def around(cls, points: np.ndarray) -> PoseCrop:
        """The crop for a person outlined by ``points`` (N, 2) pixels, assumed upright: centred on the
        middle of their bounding box (near the hips when standing), side 2 × 1.25 × the distance from
        there to the farthest outline point (MediaPipe's crop for a detection)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        lo, hi = p.min(axis=0), p.max(axis=0)
        c = 0.5 * (lo + hi)
        reach = float(np.sqrt(((p - c) ** 2).sum(axis=1)).max())
        return cls((float(c[0]), float(c[1])), max(2.0 * _CROP_SCALE * reach, 8.0))

    @classmethod
    def from_keypoints(cls, uv: np.ndarray) -> PoseCrop | None:
        """The crop for the next frame from this frame's 35+ keypoints (the model's hips and extent
        points), as MediaPipe tracks a person between detections; None if they coincide."""
        hips, extent = np.asarray(uv[_HIPS], np.float64), np.asarray(uv[_EXTENT], np.float64)
        d = extent - hips
        r = float(np.hypot(d[0], d[1]))
        if not math.isfinite(r) or r < 2.0:
            return None
        return cls((float(hips[0]), float(hips[1])), 2.0 * _CROP_SCALE * r, (float(d[0] / r), float(d[1] / r)))

    def to_crop(self) -> np.ndarray:
        """The 2×3 affine map from image pixels to the model's crop pixels."""
        ux, uy = self.up
        s = _INPUT / self.side
        # crop x runs along (−uy, ux) (the person's left-to-right as seen), crop y along −up
        a = np.array([[-uy * s, ux * s], [-ux * s, -uy * s]], dtype=np.float64)
        # continuous coordinates (pixel k spans k … k+1) put the centre at the crop's middle, 128;
        # in pixel-index coordinates (image u ↔ u + 0.5, crop j ↔ j + 0.5) that is j = A(u − c) + 127.5
        b = (_INPUT - 1) / 2 - a @ np.asarray(self.centre, dtype=np.float64)
        return np.column_stack([a, b])

    def to_image(self, crop_xy: np.ndarray) -> np.ndarray:
        """Crop pixel coordinates (N, 2), in the model's continuous convention (0 … 256), → image pixels."""
        m = self.to_crop()
        a, b = m[:, :2], m[:, 2]
        # model x is continuous (pixel j spans j … j+1): the crop pixel index is x − 0.5
        j = np.asarray(crop_xy, dtype=np.float64).reshape(-1, 2) - 0.5
        return (j - b) @ np.linalg.inv(a).T


@dataclass(frozen=True, eq=False)
class Keypoints:
    """One person's keypoints in one image.

    ``uv`` (39, 2) image pixels: the 33 of :data:`KEYPOINT_NAMES` then the model's 6 auxiliary
    points; ``z`` (39,) depth relative to the hips, in the same pixel scale (smaller = nearer);
    ``visibility`` and ``presence`` (39,) in [0, 1]; ``score`` the model's confidence that a person
    is in the crop at all; ``crop`` the region it looked at; ``t`` the time (seconds) of the frame
    they were computed from, when known.
    """

    uv: np.ndarray
    z: np.ndarray
    visibility: np.ndarray
    presence: np.ndarray
    score: float
    crop: PoseCrop
    t: float | None = None

    def point(self, name: str) -> tuple[float, float]:
        i = KEYPOINT_NAMES.index(name)
        return float(self.uv[i, 0]), float(self.uv[i, 1])

    def next_crop(self) -> PoseCrop | None:
        """Where to look for this person in the next frame."""
        return PoseCrop.from_keypoints(self.uv)


class PoseModel:
    """The BlazePose landmark model (and, if given, the selfie segmentation model) on ``cv2.dnn``.

    Not thread-safe (one net, one input). Its cost per crop: docs/notes/webcam.md.
    """

    def __init__(self, landmark_path: Path, segmentation_path: Path | None = None, *, refine: bool = True) -> None:
        self._net = _load(landmark_path)
        self._seg = _load(segmentation_path) if segmentation_path is not None else None
        self._refine = refine
        self.landmark_path = landmark_path
        self.segmentation_path = segmentation_path

    @classmethod
    def from_dir(cls, directory: Path, *, refine: bool = True) -> PoseModel:
        """Both models from a folder made by :mod:`interaction.webcam.pose_models`."""
        seg = directory / SEGMENTATION_FILE
        return cls(directory / LANDMARK_FILE, seg if seg.is_file() else None, refine=refine)

    def keypoints(self, bgr: np.ndarray, crop: PoseCrop) -> Keypoints:
        """The keypoints of the person in ``crop`` of a uint8 BGR image."""
        m = crop.to_crop()
        patch = cv2.warpAffine(bgr, m, (_INPUT, _INPUT), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))
        self._net.setInput(cv2.dnn.blobFromImage(patch, 1.0 / 255.0, (_INPUT, _INPUT), swapRB=True))
        raw, flag, _seg, heat, _world = self._net.forward(list(_OUTPUTS))
        lm = np.asarray(raw, dtype=np.float64).reshape(39, 5)
        xy = lm[:, :2].copy()
        if self._refine:
            xy = _refine_with_heatmap(xy, np.asarray(heat, dtype=np.float64).reshape(39, _HEATMAP, _HEATMAP))
        scale = crop.side / _INPUT
        return Keypoints(
            uv=crop.to_image(xy),
            z=lm[:, 2] * scale,
            visibility=_sigmoid(lm[:, 3]),
            presence=_sigmoid(lm[:, 4]),
            score=float(np.asarray(flag).reshape(-1)[0]),
            crop=crop,
        )

    def person_mask(self, bgr: np.ndarray) -> np.ndarray:
        """The selfie segmentation of a whole image: float32 (H, W) in [0, 1], 1 = a person.
        Made for people near the camera (a selfie, a kiosk); raises if the model was not loaded."""
        if self._seg is None:
            raise PoseModelError(f"{SEGMENTATION_FILE}: the segmentation model was not loaded")
        h, w = bgr.shape[:2]
        self._seg.setInput(cv2.dnn.blobFromImage(bgr, 1.0 / 255.0, (_INPUT, _INPUT), swapRB=True))
        out = np.asarray(self._seg.forward(), dtype=np.float32).reshape(_INPUT, _INPUT)
        return cv2.resize(out, (w, h), interpolation=cv2.INTER_LINEAR)


def _load(path: Path) -> cv2.dnn.Net:
    if not path.is_file():
        raise PoseModelError(f"{path}: no such model file (fetch it: python -m interaction.webcam.pose_models)")
    if not hasattr(cv2.dnn, "readNetFromTFLite"):
        raise PoseModelError(f"{path}: this OpenCV ({cv2.__version__}) cannot read TFLite models; OpenCV 5 can")
    try:
        engine = getattr(cv2.dnn, "ENGINE_CLASSIC", None)
        return cv2.dnn.readNetFromTFLite(str(path)) if engine is None else cv2.dnn.readNetFromTFLite(str(path), engine)
    except cv2.error as e:
        first = str(e).strip().splitlines()[-1] if str(e).strip() else "unknown error"
        raise PoseModelError(f"{path}: OpenCV {cv2.__version__} cannot load it ({first})") from None


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return np.asarray(1.0 / (1.0 + np.exp(-np.clip(x, -60.0, 60.0))), dtype=np.float64)


def _refine_with_heatmap(xy: np.ndarray, heat: np.ndarray) -> np.ndarray:
    """MediaPipe's refinement: each keypoint moves to the confidence-weighted mean of its heatmap in
    a 7×7 window around it, if the heatmap there is confident enough. ``heat`` (39, 64, 64) logits."""
    out = xy.copy()
    r = _REFINE_KERNEL // 2
    cell = _INPUT / _HEATMAP
    for k in range(len(xy)):
        col, row = int(xy[k, 0] / cell), int(xy[k, 1] / cell)
        if not (0 <= col < _HEATMAP and 0 <= row < _HEATMAP):
            continue
        r0, r1 = max(0, row - r), min(_HEATMAP, row + r + 1)
        c0, c1 = max(0, col - r), min(_HEATMAP, col + r + 1)
        conf = _sigmoid(heat[k, r0:r1, c0:c1])
        total = float(conf.sum())
        if total <= 0 or float(conf.max()) < _REFINE_MIN:
            continue
        rows, cols = np.mgrid[r0:r1, c0:c1]
        out[k, 0] = float((conf * cols).sum()) / total * cell
        out[k, 1] = float((conf * rows).sum()) / total * cell
    return out


# ---------------------------------------------------------------- tracking people's keypoints

LIMBS: dict[str, tuple[int, ...]] = {
    "left_hand": (15, 17, 19),  # wrist, pinky, index
    "right_hand": (16, 18, 20),
    "left_foot": (29, 31),  # heel, toes
    "right_foot": (30, 32),
}
"""The contactors made from keypoints: each is the mean of its visible keypoints. A foot is the middle
of the heel and the toes (the shoe's middle; the ankle is above it: with it, feet sat ~3 cm high)."""


@dataclass(frozen=True, eq=False)
class LimbPoint:
    """A hand or foot of one person: image position (pixels) and velocity (pixels per second)."""

    part: str
    uv: tuple[float, float]
    velocity: tuple[float, float]


class _OneEuro:
    """The 1€ filter (Casiez et al. 2012) on a 2-D point: smooth when slow, quick when fast.
    ``dx`` is its low-passed speed, in pixels per second, from the raw points (the paper differences
    against the smoothed point, which lags a moving one: its speed came out 1.7× too high at 120 px/s)."""

    def __init__(self, min_cutoff: float, beta: float, d_cutoff: float) -> None:
        self.min_cutoff, self.beta, self.d_cutoff = min_cutoff, beta, d_cutoff
        self.x: np.ndarray | None = None
        self.raw: np.ndarray | None = None
        self.dx = np.zeros(2)
        self.t = 0.0

    @staticmethod
    def _alpha(cutoff: float, dt: float) -> float:
        tau = 1.0 / (2.0 * math.pi * cutoff)
        return 1.0 / (1.0 + tau / dt)

    def __call__(self, x: np.ndarray, t: float) -> np.ndarray:
        if self.x is None or self.raw is None or t <= self.t:
            self.x, self.raw, self.t = x.astype(np.float64), x.astype(np.float64), t
            return self.x
        dt = t - self.t
        a_d = self._alpha(self.d_cutoff, dt)
        self.dx = a_d * (x - self.raw) / dt + (1.0 - a_d) * self.dx
        self.raw = x.astype(np.float64)
        a = self._alpha(self.min_cutoff + self.beta * float(np.hypot(*self.dx)), dt)
        self.x, self.t = a * x + (1.0 - a) * self.x, t
        return self.x


class PoseTracker:
    """Keypoints of each tracked person, frame to frame, as MediaPipe tracks between detections.

    A person's crop comes from the last frame's keypoints while they were found (score ≥
    ``min_score``) and the crop's centre still lies in the person's box; otherwise from their
    outline. Hands and feet (:data:`LIMBS`) are the mean of their keypoints with visibility ≥
    ``min_visibility``, smoothed by a 1€ filter whose derivative is their velocity.
    """

    MIN_CUTOFF_HZ = 1.0  # 1€ filter: still hands barely jitter ...
    BETA = 0.02  # ... and a hand moving 500 px/s is followed at 11 Hz
    D_CUTOFF_HZ = 8.0

    def __init__(self, model: PoseModel, min_score: float = 0.5, min_visibility: float = 0.5) -> None:
        self.model = model
        self.min_score = min_score
        self.min_visibility = min_visibility
        self._last: dict[int, Keypoints] = {}
        self._filters: dict[tuple[int, str], _OneEuro] = {}

    @property
    def keypoints(self) -> dict[int, Keypoints]:
        """The last frame's keypoints of every person found in it."""
        return dict(self._last)

    def forget(self, keep: set[int]) -> None:
        """Drop everything about people not in ``keep`` (not seen this frame)."""
        self._last = {p: k for p, k in self._last.items() if p in keep}
        self._filters = {key: f for key, f in self._filters.items() if key[0] in keep}

    def track(self, bgr: np.ndarray, person: int, outline: np.ndarray) -> Keypoints | None:
        """The keypoints of ``person`` (outline (N, 2) image pixels) in this frame, or None."""
        crop = None
        last = self._last.get(person)
        if last is not None:
            crop = last.next_crop()
            lo, hi = outline.min(axis=0), outline.max(axis=0)
            if crop is not None and not (lo[0] <= crop.centre[0] <= hi[0] and lo[1] <= crop.centre[1] <= hi[1]):
                crop = None  # the person moved away from where the keypoints were
        kp = self.model.keypoints(bgr, crop if crop is not None else PoseCrop.around(outline))
        if kp.score < self.min_score and crop is not None:  # lost them: look again around the outline
            kp = self.model.keypoints(bgr, PoseCrop.around(outline))
        if kp.score < self.min_score:
            self._last.pop(person, None)
            return None
        if crop is None:  # first sight: the outline's crop is rough; look again where the keypoints say
            again = kp.next_crop()
            if again is not None:
                better = self.model.keypoints(bgr, again)
                kp = better if better.score >= self.min_score else kp
        self._last[person] = kp
        return kp

    def limbs(self, person: int, kp: Keypoints, t: float, accept: np.ndarray | None = None) -> list[LimbPoint]:
        """The hands and feet of one person's keypoints at time ``t``. ``accept``, a uint8 mask at
        image size, rejects limbs that fall where it is 0 (outside the person's silhouette)."""
        out: list[LimbPoint] = []
        for part, idx in LIMBS.items():
            vis = [i for i in idx if kp.visibility[i] >= self.min_visibility and kp.presence[i] >= self.min_visibility]
            key = (person, part)
            if not vis:
                self._filters.pop(key, None)
                continue
            uv = kp.uv[vis].mean(axis=0)
            if accept is not None:
                h, w = accept.shape
                u, v = int(round(uv[0])), int(round(uv[1]))
                if not (0 <= u < w and 0 <= v < h) or accept[v, u] == 0:
                    self._filters.pop(key, None)
                    continue
            f = self._filters.get(key)
            if f is None:
                f = self._filters[key] = _OneEuro(self.MIN_CUTOFF_HZ, self.BETA, self.D_CUTOFF_HZ)
            p = f(uv, t)
            out.append(LimbPoint(part, (float(p[0]), float(p[1])), (float(f.dx[0]), float(f.dx[1]))))
        return out
