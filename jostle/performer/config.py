"""What decides the virtual performance: the people (:class:`PerformerConfig`, which also holds the
webcam filming them) and the virtual OAK depth camera (:class:`DepthCameraConfig`).

Both are frozen config dataclasses of simple fields, validated in ``__post_init__`` with errors
that start with the field's name. The pads are placed by a layout (``jostle.performer.pads``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np

from jostle.performer.camera import PinholeCamera
from sim.motion.clips import load_motion
from sim.motion.mocap import MotionClip, MotionFileError

Route = Literal["round", "crossing"]
MAX_PEOPLE = 4


@lru_cache(maxsize=32)
def load_clip(name: str, cycle: bool = False) -> MotionClip:
    """A DeepMimic clip shipped with pybullet_data by name (walk, run, punch, …), or a motion file (a
    BVH of any common rig, DeepMimic JSON: ``sim.motion.clips``), cached; ``cycle``: the person's walk,
    a BVH cut to its best loop."""
    return load_motion(name, "", cycle=cycle)


def check_number(name: str, value: object, lo: float, hi: float = math.inf, *, open_lo: bool = False) -> None:
    """Raise ``ValueError("<name>: expected a number ...")`` unless lo <= value <= hi (lo < value if open_lo)."""
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        v = float(value)  # type: ignore[arg-type]
        ok = (v > lo if open_lo else v >= lo) and v <= hi
    if not ok:
        bound = f"> {lo}" if open_lo else f">= {lo}"
        rng = f"{bound} and <= {hi}" if math.isfinite(hi) else bound
        raise ValueError(f"{name}: expected a number {rng}, got {value!r}")


def check_whole(name: str, value: object, lo: int, hi: int) -> None:
    if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
        raise ValueError(f"{name}: expected a whole number {lo}..{hi}, got {value!r}")


def check_clip_sequence(name: str, clips: tuple[str, ...]) -> None:
    """Every clip exists; the first loops and travels (the person's way of walking)."""
    for clip in clips:
        try:
            load_clip(clip)
        except MotionFileError as e:
            raise ValueError(f"{name}: {e}") from None
    walk = load_clip(clips[0], True)
    if not walk.loop or float(np.linalg.norm(walk.cycle_offset)) / max(walk.duration, 1e-9) < 0.2:
        raise ValueError(f"{name}: the first clip must loop and travel (walk, run), got {clips[0]!r}")


@dataclass(frozen=True)
class PerformerConfig:
    """Everything that decides the people and the webcam's frames. Defaults make the shipped demo clip.

    People: ``route = "round"`` is one person walking in, performing the action clips, turning and
    walking out, over and over (the demo); ``"crossing"`` is 1..4 people, each walking straight
    across the stage along their own lane (y), in from just out of view, some from the left and some
    from the right, so that they pass each other near the middle about 3.5 s after the empty start,
    each playing their own action clips on the way (``jostle.performer.cast``). Unset sizes, lanes,
    paces and start times come from ``seed``.
    ``person_clips`` gives each person's clip sequence as ``"walk+punch"`` (default: ``clips``,
    with the actions in a different order for each person).
    """

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
    people: int = 1
    route: Route = "round"
    sizes: tuple[float, ...] = ()  # body scale per person (1.0 = the 1.6 m humanoid); () = from the seed
    person_clips: tuple[str, ...] = ()  # per person "walk+punch"; () = ``clips`` for everyone

    def __post_init__(self) -> None:
        if not isinstance(self.clips, tuple) or not self.clips or not all(isinstance(c, str) for c in self.clips):
            raise ValueError(f"clips: expected a non-empty list of clip names like ['walk', 'punch'], got {self.clips!r}")
        check_clip_sequence("clips", self.clips)
        for name in ("width", "height"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not 16 <= v <= 4096:
                raise ValueError(f"{name}: expected a whole number of pixels 16..4096, got {v!r}")
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or self.seed < 0:
            raise ValueError(f"seed: expected a whole number >= 0, got {self.seed!r}")
        check_number("fps", self.fps, 0.0, 240.0, open_lo=True)
        check_number("duration_s", self.duration_s, 0.0, open_lo=True)
        check_number("noise_sigma", self.noise_sigma, 0.0, 64.0)
        check_number("light_change", self.light_change, 0.0, 0.9)
        check_number("light_period_s", self.light_period_s, 0.0, open_lo=True)
        check_number("empty_s", self.empty_s, 0.0)
        check_number("stage_half_width_m", self.stage_half_width_m, 0.5, 50.0)
        check_number("turn_radius_m", self.turn_radius_m, 0.05, 5.0)
        check_number("camera_distance_m", self.camera_distance_m, 0.5, 100.0)
        check_number("camera_height_m", self.camera_height_m, 0.1, 10.0)
        check_number("camera_pitch_deg", self.camera_pitch_deg, -45.0, 45.0)
        check_number("camera_hfov_deg", self.camera_hfov_deg, 10.0, 150.0)
        check_number("shadow", self.shadow, 0.0, 1.0)
        check_number("blur_px", self.blur_px, 0.0, 10.0)
        check_whole("people", self.people, 1, MAX_PEOPLE)
        if self.route not in ("round", "crossing"):
            raise ValueError(f"route: expected 'round' or 'crossing', got {self.route!r}")
        if self.route == "round" and self.people != 1:
            raise ValueError(f"route: 'round' is one person's walk; {self.people} people need 'crossing'")
        self._check_per_person()

    def _check_per_person(self) -> None:
        if not isinstance(self.sizes, tuple) or len(self.sizes) not in (0, self.people):
            raise ValueError(f"sizes: expected one body scale per person ({self.people}) or none, got {self.sizes!r}")
        for size in self.sizes:
            check_number("sizes", size, 0.5, 1.5)
        clips = self.person_clips
        if not isinstance(clips, tuple) or len(clips) not in (0, self.people):
            raise ValueError(f"person_clips: expected one clip sequence per person ({self.people}) or none, "
                             f"got {clips!r}")
        for sequence in clips:
            if not isinstance(sequence, str) or not all(sequence.split("+")):
                raise ValueError(f"person_clips: expected sequences like 'walk+punch', got {sequence!r}")
            check_clip_sequence("person_clips", tuple(sequence.split("+")))

    @property
    def frame_count(self) -> int:
        """Frames k = 0, 1, … with k / fps < duration_s."""
        return frame_count(self.duration_s, self.fps)

    def camera(self) -> PinholeCamera:
        return PinholeCamera(
            self.width,
            self.height,
            (0.0, -self.camera_distance_m, self.camera_height_m),
            self.camera_pitch_deg,
            self.camera_hfov_deg,
        )


def frame_count(duration_s: float, rate_hz: float) -> int:
    """Samples k = 0, 1, … with k / rate_hz < duration_s."""
    return int(math.ceil(duration_s * rate_hz - 1e-9))


@dataclass(frozen=True)
class DepthCameraConfig:
    """The virtual OAK: a stereo depth camera above the audience looking down at the stage.

    Depth is along the optical axis in millimetres (uint16, 0 = no data), as an OAK gives it.
    Errors are made where a stereo camera makes them: the disparity d = f·B/z is measured with
    Gaussian noise ``disparity_noise_px`` and rounded to 1/2^``subpixel_bits`` pixel, so the depth
    error grows with the square of the distance; ``stereo_width`` is the resolution the disparity is
    matched at (an OAK matches at 640 px and may output a smaller map). Holes (0): pixels the
    second camera cannot see (the band beside a nearer object), ``edge_holes`` of the pixels on a
    depth edge, ``blobs_per_frame`` small random blobs (on average) of radius up to
    ``blob_radius_px`` (at the stereo width), and whatever is nearer than ``min_depth_m`` or farther
    than ``max_depth_m``.
    """

    width: int = 640
    height: int = 400
    fps: float = 15.0
    position: tuple[float, ...] = (0.0, -4.0, 2.4)  # stage metres
    pitch_deg: float = 25.0  # downward tilt, looking along +y
    hfov_deg: float = 72.0
    color: bool = True  # record the aligned colour image with the depth
    baseline_m: float = 0.075
    stereo_width: int = 640
    disparity_noise_px: float = 0.08
    subpixel_bits: int = 3
    min_depth_m: float = 0.35
    max_depth_m: float = 12.0
    edge_holes: float = 0.5
    blobs_per_frame: float = 4.0
    blob_radius_px: float = 5.0
    noise_sigma: float = 3.0  # colour noise, grey levels

    def __post_init__(self) -> None:
        check_whole("width", self.width, 16, 4096)
        check_whole("height", self.height, 16, 4096)
        check_number("fps", self.fps, 0.0, 240.0, open_lo=True)
        pos = self.position
        if (not isinstance(pos, tuple) or len(pos) != 3
                or not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in pos)):
            raise ValueError(f"position: expected [x, y, z] in stage metres, got {pos!r}")
        if not 0.2 <= float(pos[2]) <= 2.7:
            raise ValueError(f"position: expected a height (z) of 0.2..2.7 m (the room's ceiling is at 2.8 m), "
                             f"got {pos[2]!r}")
        check_number("pitch_deg", self.pitch_deg, -10.0, 80.0)
        check_number("hfov_deg", self.hfov_deg, 10.0, 150.0)
        if not isinstance(self.color, bool):
            raise ValueError(f"color: expected true or false, got {self.color!r}")
        check_number("baseline_m", self.baseline_m, 0.0, 1.0, open_lo=True)
        check_whole("stereo_width", self.stereo_width, 16, 4096)
        check_number("disparity_noise_px", self.disparity_noise_px, 0.0, 5.0)
        check_whole("subpixel_bits", self.subpixel_bits, 0, 8)
        check_number("min_depth_m", self.min_depth_m, 0.0, 10.0)
        check_number("max_depth_m", self.max_depth_m, 0.5, 60.0)
        if self.max_depth_m <= self.min_depth_m:
            raise ValueError(f"max_depth_m: expected more than min_depth_m ({self.min_depth_m}), got {self.max_depth_m}")
        check_number("edge_holes", self.edge_holes, 0.0, 1.0)
        check_number("blobs_per_frame", self.blobs_per_frame, 0.0, 1000.0)
        check_number("blob_radius_px", self.blob_radius_px, 0.5, 100.0)
        check_number("noise_sigma", self.noise_sigma, 0.0, 64.0)

    def camera(self) -> PinholeCamera:
        x, y, z = (float(v) for v in self.position)
        # near/far: the depth buffer is converted with them; keep the range tight for precision
        return PinholeCamera(self.width, self.height, (x, y, z), self.pitch_deg, self.hfov_deg,
                             near=0.1, far=max(20.0, 2.0 * self.max_depth_m))

    def stereo_focal_px(self) -> float:
        """Focal length in pixels at the matching resolution (the noise is made there)."""
        return (self.stereo_width / 2) / math.tan(math.radians(self.hfov_deg) / 2)
