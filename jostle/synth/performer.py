"""The virtual performer: a webcam filming a motion-captured person in a room, with ground truth.

:class:`PerformerSensor` is a :class:`sensors.base.Sensor` that produces BGR frames at ``fps`` on
the injected clock's timeline, like a replay: frame k has ``t = t_open + k / fps`` and ``read``
returns it once the clock has reached that time (never sleeping, never skipping). The first
``empty_s`` seconds show the empty room; then a DeepMimic humanoid walks in from the left along the
stage plane y = 0 (stopping left of centre to perform the action clips, if any), turns, walks back
and leaves; the round then repeats (see ``jostle.synth.choreography``). Every frame is a pure function of (config, k): the same config and seed give the same
bytes. :meth:`PerformerSensor.truth` gives what is really there (silhouette, body parts, joints in
stage metres and their velocities) and :meth:`PerformerSensor.homography` the exact map from
pixels to the stage plane.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import lru_cache
from types import TracebackType

import cv2
import numpy as np

from jostle.synth.camera import PinholeCamera
from jostle.synth.choreography import Choreography, StagePose, stage_joint_positions
from jostle.synth.puppet import HumanoidPuppet
from jostle.synth.room import render_room
from render.mocap import HUMANOID, MotionClip, MotionFileError, pybullet_motion_path
from sensors.base import (
    ColorImage,
    Frame,
    SensorNotOpen,
    SensorSpec,
    SensorState,
    SensorStatus,
)
from sensors.clock import Clock


@lru_cache(maxsize=32)
def _load_clip(name: str) -> MotionClip:
    return MotionClip.load(pybullet_motion_path(name))


def _number(name: str, value: object, lo: float, hi: float = math.inf, *, open_lo: bool = False) -> None:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        v = float(value)  # type: ignore[arg-type]
        ok = (v > lo if open_lo else v >= lo) and v <= hi
    if not ok:
        bound = f"> {lo}" if open_lo else f">= {lo}"
        rng = f"{bound} and <= {hi}" if math.isfinite(hi) else bound
        raise ValueError(f"{name}: expected a number {rng}, got {value!r}")


@dataclass(frozen=True)
class PerformerConfig:
    """Everything that decides the performer's frames. Defaults make the shipped demo clip."""

    clips: tuple[str, ...] = ("walk",)  # first: a looping walking clip; the rest: actions, in order
    width: int = 320
    height: int = 240
    fps: float = 15.0
    duration_s: float = 16.0
    seed: int = 0
    noise_sigma: float = 3.0  # camera noise, grey levels (standard deviation per channel)
    light_change: float = 0.12  # amplitude of the slow global brightness drift (0.12 = ±12 %)
    light_period_s: float = 20.0
    empty_s: float = 1.5  # empty stage at the start of each round, to learn the background from
    stage_half_width_m: float = 3.0
    turn_radius_m: float = 0.3
    camera_distance_m: float = 4.5  # from the plane y = 0, on the audience side
    camera_height_m: float = 1.3
    camera_pitch_deg: float = 7.0  # downward tilt
    camera_hfov_deg: float = 72.0
    shadow: float = 0.35  # darkening of the floor right under the performer, 0..1
    blur_px: float = 0.6  # optical blur (Gaussian sigma, pixels), 0 = none

    def __post_init__(self) -> None:
        if not isinstance(self.clips, tuple) or not self.clips or not all(isinstance(c, str) for c in self.clips):
            raise ValueError(f"clips: expected a non-empty list of clip names like ['walk', 'punch'], got {self.clips!r}")
        for name in self.clips:
            try:
                _load_clip(name)
            except MotionFileError as e:
                raise ValueError(f"clips: {e}") from None
        walk = _load_clip(self.clips[0])
        if not walk.loop or float(np.linalg.norm(walk.cycle_offset)) / max(walk.duration, 1e-9) < 0.2:
            raise ValueError(f"clips: the first clip must loop and travel (walk, run), got {self.clips[0]!r}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not 16 <= v <= 4096:
                raise ValueError(f"{name}: expected a whole number of pixels 16..4096, got {v!r}")
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or self.seed < 0:
            raise ValueError(f"seed: expected a whole number >= 0, got {self.seed!r}")
        _number("fps", self.fps, 0.0, 240.0, open_lo=True)
        _number("duration_s", self.duration_s, 0.0, open_lo=True)
        _number("noise_sigma", self.noise_sigma, 0.0, 64.0)
        _number("light_change", self.light_change, 0.0, 0.9)
        _number("light_period_s", self.light_period_s, 0.0, open_lo=True)
        _number("empty_s", self.empty_s, 0.0)
        _number("stage_half_width_m", self.stage_half_width_m, 0.5, 50.0)
        _number("turn_radius_m", self.turn_radius_m, 0.05, 5.0)
        _number("camera_distance_m", self.camera_distance_m, 0.5, 100.0)
        _number("camera_height_m", self.camera_height_m, 0.1, 10.0)
        _number("camera_pitch_deg", self.camera_pitch_deg, -45.0, 45.0)
        _number("camera_hfov_deg", self.camera_hfov_deg, 10.0, 150.0)
        _number("shadow", self.shadow, 0.0, 1.0)
        _number("blur_px", self.blur_px, 0.0, 10.0)

    @property
    def frame_count(self) -> int:
        """Frames k = 0, 1, … with k / fps < duration_s."""
        return int(math.ceil(self.duration_s * self.fps - 1e-9))

    def camera(self) -> PinholeCamera:
        return PinholeCamera(
            self.width,
            self.height,
            (0.0, -self.camera_distance_m, self.camera_height_m),
            self.camera_pitch_deg,
            self.camera_hfov_deg,
        )


@dataclass(frozen=True, eq=False)
class PerformerTruth:
    """What is really in front of the camera at time ``t`` (loop clock).

    ``joints``/``velocities`` hold every bone of ``render.mocap.HUMANOID`` (root, chest, neck,
    head_top, hips, knees, ankles, toes, shoulders, elbows, wrists) in stage metres and m/s while
    the performer is on its path (even outside the picture); they are empty while the stage is
    empty. ``parts`` is the pybullet link index seen at each pixel (-1: not the person; names in
    ``PerformerSensor.link_names``). ``present`` is true when any pixel shows the person.
    """

    t: float
    present: bool
    silhouette: np.ndarray  # (H, W) bool
    parts: np.ndarray  # (H, W) int16
    joints: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    velocities: dict[str, tuple[float, float, float]] = field(default_factory=dict)


class PerformerSensor:
    """A virtual webcam filming the performer. See the module doc for the timeline."""

    def __init__(self, config: PerformerConfig, clock: Clock, name: str = "webcam") -> None:
        self.config = config
        self.name = name
        self._clock = clock
        self.camera = config.camera()
        hw = config.stage_half_width_m
        view_half = config.camera_distance_m * math.tan(math.radians(config.camera_hfov_deg) / 2)
        self.choreography = Choreography(
            _load_clip(config.clips[0]),
            tuple(_load_clip(c) for c in config.clips[1:]),
            entry_x=-(view_half + 0.7),
            turn_x=0.6 * hw,
            action_x=-0.35 * hw,
            turn_radius=config.turn_radius_m,
            empty_s=config.empty_s,
        )
        self._room = render_room(self.camera, hw, config.seed)
        self._light_phase = float(np.random.default_rng([config.seed, 1]).uniform(0, 2 * math.pi))
        self._puppet: HumanoidPuppet | None = None
        self._t_open = 0.0
        self._next = 0
        self._state = SensorState.CLOSED
        self._reason = ""
        self._render_s = 0.0
        self._cache: dict[int, PerformerTruth] = {}

    # ------------------------------------------------------------ Sensor

    @property
    def spec(self) -> SensorSpec:
        c = self.config
        return SensorSpec(self.name, "color", c.fps, c.width, c.height)

    @property
    def status(self) -> SensorStatus:
        ms = 1000.0 * self._render_s / self._next if self._next else 0.0
        return SensorStatus(self._state, self._reason, frames=self._next, extra={"ms_per_frame": ms})

    def open(self) -> None:
        if self._puppet is not None:
            return
        self._puppet = HumanoidPuppet()
        self._t_open = self._clock.now()
        self._next = 0
        self._render_s = 0.0
        self._cache.clear()
        self._state = SensorState.CONNECTED if self.config.frame_count > 0 else SensorState.ENDED
        self._reason = ""

    def read(self, timeout: float) -> Frame | None:
        """The next frame once the clock has reached its time, else None at once (never sleeps)."""
        if self._puppet is None:
            raise SensorNotOpen(f"{self.name}: read() before open() (or after close())")
        if self._next >= self.config.frame_count:
            return None
        k = self._next
        t = self._t_open + k / self.config.fps
        if self._clock.now() < t:
            return None
        start = time.perf_counter()
        bgr = self._frame_image(k)
        self._render_s += time.perf_counter() - start
        self._next += 1
        if self._next >= self.config.frame_count:
            self._state = SensorState.ENDED
            self._reason = f"the performance ends after {self.config.duration_s} s"
        return Frame(self.name, t, k, ColorImage(bgr))

    def close(self) -> None:
        if self._puppet is not None:
            self._puppet.close()
            self._puppet = None
        self._state = SensorState.CLOSED
        self._cache.clear()

    def __enter__(self) -> PerformerSensor:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ------------------------------------------------------------ ground truth

    @property
    def link_names(self) -> tuple[str, ...]:
        """Names of the pybullet links that ``PerformerTruth.parts`` indexes (needs ``open``)."""
        return self._open_puppet().link_names

    def homography(self, plane_y: float = 0.0) -> np.ndarray:
        """H (3×3): OpenCV pixel coordinates (u, v, 1) → stage (x, z, 1) on the plane y = plane_y."""
        return self.camera.plane_homography(plane_y)

    def truth(self, t: float) -> PerformerTruth:
        """Ground truth at loop-clock time t (a frame's ``t`` gives exactly what that frame shows)."""
        self._open_puppet()
        tau = t - self._t_open
        k = round(tau * self.config.fps)
        on_frame = abs(tau * self.config.fps - k) < 1e-6
        if on_frame and k in self._cache:
            return self._cache[k]
        truth, _, _ = self._scene(tau, t)
        if on_frame:
            self._remember(k, truth)
        return truth

    def light_gain(self, tau: float) -> float:
        """The global brightness factor at performance time tau (seconds since open)."""
        c = self.config
        return 1.0 + c.light_change * math.sin(2 * math.pi * tau / c.light_period_s + self._light_phase)

    # ------------------------------------------------------------ rendering

    def _open_puppet(self) -> HumanoidPuppet:
        if self._puppet is None:
            raise SensorNotOpen(f"{self.name}: ground truth needs the sensor open")
        return self._puppet

    def _remember(self, k: int, truth: PerformerTruth) -> None:
        if len(self._cache) >= 4:
            self._cache.pop(next(iter(self._cache)))
        self._cache[k] = truth

    def _scene(self, tau: float, t: float) -> tuple[PerformerTruth, np.ndarray | None, StagePose | None]:
        """Truth at performance time tau, the rendered person (RGB, or None) and its pose."""
        c = self.config
        puppet = self._open_puppet()
        pose = self.choreography.pose(tau)
        parts = np.full((c.height, c.width), -1, dtype=np.int16)
        if pose is None:
            return PerformerTruth(t, False, parts >= 0, parts), None, None
        h = 1.0 / 480.0  # velocities: central differences over ±h (one-sided at the ends of the path)
        around = [self.choreography.pose(tau - h), pose, self.choreography.pose(tau + h)]
        known = [p for p in around if p is not None]
        all_positions = stage_joint_positions(known)
        positions = all_positions[known.index(pose)]
        span = h * (len(known) - 1)
        velocities = (all_positions[-1] - all_positions[0]) / span if span > 0 else np.zeros_like(positions)
        rgb = None
        if self._in_view(positions):
            puppet.set_pose(pose)
            image = puppet.render(self.camera)
            parts, rgb = image.parts, image.rgb
        names = HUMANOID.names
        joints = {n: (float(p[0]), float(p[1]), float(p[2])) for n, p in zip(names, positions, strict=True)}
        vel = {n: (float(v[0]), float(v[1]), float(v[2])) for n, v in zip(names, velocities, strict=True)}
        silhouette = parts >= 0
        return PerformerTruth(t, bool(silhouette.any()), silhouette, parts, joints, vel), rgb, pose

    def _frame_image(self, k: int) -> np.ndarray:
        c = self.config
        tau = k / c.fps
        truth, rgb, pose = self._scene(tau, self._t_open + tau)
        self._remember(k, truth)
        room = self._room
        img = room.bgr.copy()
        if pose is not None and c.shadow > 0:  # a soft contact shadow on the floor around the feet
            d2 = (room.floor_xy[:, 0] - pose.position[0]) ** 2 + (room.floor_xy[:, 1] - pose.position[1]) ** 2
            near = d2 < 1.0
            shade = 1.0 - c.shadow * np.exp(-d2[near] / (2 * 0.28**2))
            flat = img.reshape(-1, 3)
            flat[room.floor_index[near]] *= shade[:, None].astype(np.float32)
        if rgb is not None:
            mask = truth.silhouette
            img[mask] = rgb[mask][:, ::-1]
        img *= room.vignette * np.float32(self.light_gain(tau))
        if c.blur_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), c.blur_px)
        if c.noise_sigma > 0:
            rng = np.random.default_rng([c.seed, 2, k])
            img += rng.standard_normal(img.shape, dtype=np.float32) * np.float32(c.noise_sigma)
        np.clip(img, 0.0, 255.0, out=img)
        return np.rint(img).astype(np.uint8)

    def _in_view(self, positions: np.ndarray) -> bool:
        """False only when the whole body (joints plus a 0.3 m margin) projects outside the image."""
        cam = self.camera.to_camera(positions)
        depth = cam[:, 2]
        if np.all(depth <= self.camera.near):
            return False
        if np.any(depth <= self.camera.near):
            return True
        uv = self.camera.project(positions)
        margin = 0.3 * self.camera.focal_px / float(depth.min())
        return bool(
            uv[:, 0].max() >= -margin
            and uv[:, 0].min() <= self.camera.width + margin
            and uv[:, 1].max() >= -margin
            and uv[:, 1].min() <= self.camera.height + margin
        )
