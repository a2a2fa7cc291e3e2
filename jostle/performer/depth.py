"""The virtual OAK: a stereo depth camera filming the performance, with the errors a real one makes.

:class:`PerformerDepth` is a Sensor producing :class:`sensors.base.DepthImage` frames (uint16
millimetres along the optical axis, 0 = no data, exact pinhole intrinsics, and the aligned colour
image when ``DepthCameraConfig.color``). The clean depth is the room (ray-cast once, floor
included) and the people (pybullet's TINY renderer depth buffer, converted with the near and far
planes), nearest first. :func:`stereo_depth` then applies the stereo error model described on
:class:`~jostle.performer.config.DepthCameraConfig`. The depth map is aligned to the left camera of
the pair, so the band the right camera cannot see lies to the left of nearer objects.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from jostle.performer.config import DepthCameraConfig
from jostle.performer.puppet import PuppetImage
from jostle.performer.room import RoomImage
from jostle.performer.scene import Performance, PersonState, compose_colour
from jostle.performer.timeline import TimelineSensor
from sensors.base import DepthImage, SensorNotOpen, SensorSpec
from sensors.clock import Clock


@dataclass(frozen=True, eq=False)
class DepthTruth:
    """What the depth camera really faces at time ``t``: the clean depth (metres along the optical
    axis, before any stereo error; inf where nothing is), who is seen at each pixel (-1: no one),
    the link index there (-1: no person) and everyone's state."""

    t: float
    depth_m: np.ndarray  # (H, W) float32
    person: np.ndarray  # (H, W) int8
    parts: np.ndarray  # (H, W) int16
    people: tuple[PersonState, ...]


def sigma_depth_m(z: np.ndarray | float, config: DepthCameraConfig) -> np.ndarray | float:
    """Standard deviation of the depth error from the disparity noise alone: z²·σd / (f·B)."""
    return np.square(z) * config.disparity_noise_px / (config.stereo_focal_px() * config.baseline_m)


def occluded_in_second_view(depth_m: np.ndarray, focal_px: float, baseline_m: float) -> np.ndarray:
    """Pixels of the left view that the right camera cannot see, because a nearer surface to their
    right covers them there: a pixel u is hidden when some u' > u has u' − d(u') < u − d(u) − ½."""
    with np.errstate(divide="ignore"):
        disparity = np.where(np.isfinite(depth_m), focal_px * baseline_m / depth_m, 0.0)
    u = np.arange(depth_m.shape[1], dtype=np.float64)[None, :]
    a = u - disparity
    right_min = np.minimum.accumulate(a[:, ::-1], axis=1)[:, ::-1]  # min over u' >= u
    beyond = np.full_like(a, np.inf)
    beyond[:, :-1] = right_min[:, 1:]  # min over u' > u
    return np.asarray(beyond < a - 0.5)


def depth_edges(depth_m: np.ndarray) -> np.ndarray:
    """Pixels on a depth discontinuity (a jump of more than max(0.1 m, 5 %) to a 4-neighbour)."""
    z = np.where(np.isfinite(depth_m), depth_m, 1e4)
    edge = np.zeros(z.shape, dtype=bool)
    for dz, a, b in ((np.abs(np.diff(z, axis=0)), np.s_[:-1, :], np.s_[1:, :]),
                     (np.abs(np.diff(z, axis=1)), np.s_[:, :-1], np.s_[:, 1:])):
        near = np.minimum(z[a], z[b])
        jump = dz > np.maximum(0.1, 0.05 * near)
        edge[a] |= jump
        edge[b] |= jump
    return edge


def stereo_depth(clean_m: np.ndarray, config: DepthCameraConfig, focal_px: float, rng: np.random.Generator) -> np.ndarray:
    """The depth an OAK would report (uint16 mm, 0 = no data) for the true depth ``clean_m``."""
    h, w = clean_m.shape
    fb = config.stereo_focal_px() * config.baseline_m
    valid = np.isfinite(clean_m) & (clean_m > 0)
    with np.errstate(divide="ignore"):
        disparity = np.where(valid, fb / np.where(valid, clean_m, 1.0), 0.0)
    if config.disparity_noise_px > 0:
        disparity = disparity + rng.standard_normal((h, w)) * config.disparity_noise_px
    steps = float(2**config.subpixel_bits)
    disparity = np.rint(disparity * steps) / steps
    valid &= disparity > 0
    with np.errstate(divide="ignore"):
        z = np.where(valid, fb / np.where(valid, disparity, 1.0), 0.0)
    valid &= (z >= config.min_depth_m) & (z <= config.max_depth_m)
    valid &= ~occluded_in_second_view(clean_m, focal_px, config.baseline_m)
    if config.edge_holes > 0:
        edges = np.flatnonzero(depth_edges(clean_m))
        lost = edges[rng.random(len(edges)) < config.edge_holes]
        valid.reshape(-1)[lost] = False
    blobs = rng.poisson(config.blobs_per_frame) if config.blobs_per_frame > 0 else 0
    if blobs:
        mask = np.zeros((h, w), dtype=np.uint8)
        scale = w / config.stereo_width
        for _ in range(blobs):
            cx, cy = int(rng.integers(0, w)), int(rng.integers(0, h))
            r = max(config.blob_radius_px * scale * float(rng.uniform(0.4, 1.0)), 0.6)
            axes = (max(int(round(r)), 1), max(int(round(r * float(rng.uniform(0.5, 1.0)))), 1))
            cv2.ellipse(mask, (cx, cy), axes, float(rng.uniform(0, 180)), 0, 360, 1, -1)
        valid &= mask == 0
    return np.where(valid, np.rint(z * 1000.0), 0).clip(0, 65535).astype(np.uint16)


class PerformerDepth(TimelineSensor):
    """The virtual OAK filming ``performance`` (shared with the webcam and pads of one recording)."""

    def __init__(self, performance: Performance, config: DepthCameraConfig, clock: Clock, name: str = "oak") -> None:
        super().__init__(performance, clock, name, config.fps)
        self.config = config
        self.camera = config.camera()
        self._room: RoomImage = performance.room(self.camera)
        self._truths: dict[int, DepthTruth] = {}

    @property
    def spec(self) -> SensorSpec:
        return SensorSpec(self.name, "depth", self.config.fps, self.config.width, self.config.height)

    @property
    def intrinsics(self) -> tuple[float, float, float, float]:
        """(fx, fy, cx, cy) of the depth (and aligned colour) image, OpenCV pixel convention."""
        k = self.camera.intrinsics
        return float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2])

    def _on_open(self) -> None:
        self._truths.clear()

    def _on_close(self) -> None:
        self._truths.clear()

    def truth(self, t: float) -> DepthTruth:
        """The clean depth and who is where at loop-clock time t (a frame's t: exactly its scene)."""
        if not self._open:
            raise SensorNotOpen(f"{self.name}: ground truth needs the sensor open")
        tau = t - self.t_open
        k = round(tau * self.config.fps)
        if abs(tau * self.config.fps - k) < 1e-6 and k in self._truths:
            return self._truths[k]
        return self._scene(tau, t)[0]

    def _scene(self, tau: float, t: float) -> tuple[DepthTruth, PuppetImage | None]:
        people = self.performance.people_at(tau)
        image = self.performance.render(self.camera, tau, depth=True)
        room = self._room.depth_m
        if image is None or image.depth_m is None:
            shape = room.shape
            truth = DepthTruth(t, room, np.full(shape, -1, np.int8), np.full(shape, -1, np.int16), people)
            return truth, None
        nearer = image.depth_m < room
        depth = np.where(nearer, image.depth_m, room)
        person = np.where(nearer, image.person, -1).astype(np.int8)
        parts = np.where(nearer, image.parts, -1).astype(np.int16)
        seen = dataclasses.replace(image, person=person, parts=parts)
        return DepthTruth(t, depth, person, parts, people), seen

    def _payload(self, k: int, tau: float) -> DepthImage:
        truth, image = self._scene(tau, self.t_open + tau)
        if len(self._truths) >= 4:
            self._truths.pop(next(iter(self._truths)))
        self._truths[k] = truth
        seed = self.performance.config.seed
        depth_mm = stereo_depth(truth.depth_m, self.config, self.camera.focal_px, np.random.default_rng([seed, 13, k]))
        color = None
        if self.config.color:
            color = compose_colour(self._room, image, truth.people, self.performance.light_gain(tau),
                                   self.performance.config, self.config.noise_sigma,
                                   np.random.default_rng([seed, 12, k]))
        fx, fy, cx, cy = self.intrinsics
        return DepthImage(depth_mm, fx, fy, cx, cy, color)
