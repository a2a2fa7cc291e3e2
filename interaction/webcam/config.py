"""The settings of the webcam observer (one frozen, validated dataclass; built from TOML by jostle/)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

__all__ = ["FlowPreset", "WebcamObserverConfig"]

FlowPreset = Literal["ultrafast", "fast", "medium"]


def _need(ok: bool, name: str, expected: str, value: object) -> None:
    if not ok:
        raise ValueError(f"{name}: expected {expected}, got {value!r}")


@dataclass(frozen=True)
class WebcamObserverConfig:
    """How colour frames become people and contactors.

    Work size: frames wider than ``work_width`` pixels are shrunk to that width first (0: never);
    ``morphology_px`` and ``flow_window_px`` count pixels of the shrunk frame, ``contour_spacing_px``
    pixels of the original frame (the calibration's).

    Background: the median of the first ``learn_frames`` frames, then adapted at ``adapt_rate`` per
    frame wherever no person stands (selective: a scene that never empties still adapts), and at
    ``refresh_rate`` everywhere once no one has been in view for ``refresh_after_empty_frames``
    frames; a "person" who
    has not moved at all for ``still_to_background_s`` seconds (0: never) is taken into it (a ghost of
    what stood there while learning, a changed light). Global light
    change is undone before differencing (per-channel gain measured where no one stands).

    Foreground: colour distance to the background above ``diff_threshold`` (BGR units 0–255) and
    above ``noise_sigmas`` × the pixel's own noise measured while learning; minus shadows: pixels
    darker than the background by a ratio in [``shadow_min_ratio``, 1] whose colour is the
    background's within ``shadow_colour_tolerance`` (a fraction of the brightness), and likewise
    local light: brighter by a ratio up to ``highlight_max_ratio`` with the background's colour.

    People: blobs at least half as tall as the smallest person, ``min_person_px`` pixels of the
    frame (0: ``min_person_m`` metres through the calibration where it shrinks most, or a quarter
    of the frame's height uncalibrated), after a morphological open/close of ``morphology_px`` and
    an upright close of twice that; side-by-side people cut at the dip between their head tops
    (:mod:`interaction.webcam.people_found`); at most ``max_people`` (largest first; more are
    counted and said once). ``min_blob_area`` (a fraction of the image) is the old, deprecated
    size limit: still applied when set, with a warning. Ids follow the nearest centroid within
    ``match_distance`` (fraction of the image diagonal) and survive ``track_memory_frames`` frames
    unseen. A blob holding several people's predicted centroids is cut between them.

    Contactors: along each outer outline every ``contour_spacing_px`` pixels, plus head (top),
    hands (extreme left and right, arms held out; none for a person cut from others) and feet
    (the middle of each leg end's lowest shoe-high band; see :mod:`interaction.webcam.silhouette_parts`).
    Radius ``contactor_radius_m`` metres, or 0 to derive it from the spacing (0.6 × spacing at
    the local image scale). Velocity: the median DIS optical flow (``flow_preset``, its finest
    pyramid level overridden by ``flow_finest_scale``: 0 full work size, 1 half, 2 quarter) over the
    person's pixels in a ``flow_window_px`` square at each contactor, over the frame interval.

    Pose (``pose = true``): BlazePose's 33 keypoints per person through ``cv2.dnn`` (see
    :mod:`interaction.webcam.pose`), from the model files in ``pose_model_dir`` ("" = the cache that
    ``python -m interaction.webcam.pose_models`` fills). Hands and feet become contactors of their own
    ("left_hand", "right_hand", "left_foot", "right_foot"; radius ``pose_radius_m``) with their own
    velocities, when the person's score is at least ``pose_min_score``, the keypoints' visibility at
    least ``pose_min_visibility``, and they lie on the person's silhouette. Without the model files
    the observer says so once and runs silhouette-only. The model runs beside the loop, in a thread
    using at most ``pose_cpu_share`` of one core, on the newest frame (:mod:`interaction.webcam.pose_worker`);
    keypoints older than ``pose_max_age_s`` place no limbs. ``pose_sync = true`` runs it inline on
    every person every frame instead: deterministic, for replays and tests, at the model's cost.
    """

    work_width: int = 320
    learn_frames: int = 10
    diff_threshold: float = 16.0
    noise_sigmas: float = 4.0
    shadow_min_ratio: float = 0.6
    shadow_colour_tolerance: float = 0.12
    morphology_px: int = 3
    min_person_px: int = 0
    min_person_m: float = 1.0
    min_blob_area: float | None = None
    max_people: int = 8
    highlight_max_ratio: float = 1.35
    contour_spacing_px: float = 12.0
    contactor_radius_m: float = 0.0
    flow_preset: FlowPreset = "ultrafast"
    flow_finest_scale: int = 1
    flow_window_px: int = 7
    match_distance: float = 0.2
    track_memory_frames: int = 15
    refresh_rate: float = 0.02
    refresh_after_empty_frames: int = 30
    adapt_rate: float = 0.01
    still_to_background_s: float = 1.0
    pose: bool = False
    pose_model_dir: str = ""
    pose_min_score: float = 0.5
    pose_min_visibility: float = 0.5
    pose_radius_m: float = 0.1
    pose_sync: bool = False
    pose_cpu_share: float = 1.0
    pose_max_age_s: float = 0.3

    def __post_init__(self) -> None:
        def whole(name: str, lo: int, hi: int) -> None:
            v = getattr(self, name)
            _need(type(v) is int and lo <= v <= hi, name, f"a whole number from {lo} to {hi}", v)

        def number(name: str, lo: float, hi: float, lo_open: bool = False) -> None:
            v = getattr(self, name)
            ok = isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            ok = ok and (lo < v if lo_open else lo <= v) and v <= hi
            _need(ok, name, f"a number {'>' if lo_open else '≥'} {lo} and ≤ {hi}", v)

        _need(type(self.work_width) is int and (self.work_width == 0 or 32 <= self.work_width <= 8192),
              "work_width", "0 (never shrink) or a whole number of pixels from 32 to 8192", self.work_width)
        whole("learn_frames", 1, 1000)
        number("diff_threshold", 0.0, 442.0, lo_open=True)
        number("noise_sigmas", 0.0, 100.0)
        number("shadow_min_ratio", 0.0, 1.0)
        number("shadow_colour_tolerance", 0.0, 1.0)
        whole("morphology_px", 1, 99)
        whole("min_person_px", 0, 100000)
        number("min_person_m", 0.1, 3.0)
        if self.min_blob_area is not None:
            number("min_blob_area", 0.0, 1.0, lo_open=True)
        number("highlight_max_ratio", 1.0, 4.0)
        whole("max_people", 1, 64)
        number("contour_spacing_px", 1.0, 1000.0)
        number("contactor_radius_m", 0.0, 10.0)
        _need(self.flow_preset in ("ultrafast", "fast", "medium"), "flow_preset",
              "one of 'ultrafast', 'fast', 'medium'", self.flow_preset)
        whole("flow_finest_scale", 0, 4)
        whole("flow_window_px", 1, 99)
        number("match_distance", 0.0, 2.0, lo_open=True)
        whole("track_memory_frames", 0, 100000)
        number("refresh_rate", 0.0, 1.0)
        number("adapt_rate", 0.0, 1.0)
        whole("refresh_after_empty_frames", 0, 100000)
        number("still_to_background_s", 0.0, 86400.0)
        _need(isinstance(self.pose, bool), "pose", "true or false", self.pose)
        _need(isinstance(self.pose_model_dir, str), "pose_model_dir", "a folder path (\"\" = the default cache)",
              self.pose_model_dir)
        number("pose_min_score", 0.0, 1.0)
        number("pose_min_visibility", 0.0, 1.0)
        number("pose_radius_m", 0.0, 10.0, lo_open=True)
        _need(isinstance(self.pose_sync, bool), "pose_sync", "true or false", self.pose_sync)
        number("pose_cpu_share", 0.0, 1.0, lo_open=True)
        number("pose_max_age_s", 0.0, 10.0, lo_open=True)
