"""The webcam observer: colour frames of people → contactors in stage metres.

Per frame: foreground against the frozen background (light change undone, shadows suppressed,
cleaned by morphology; see :mod:`interaction.webcam.silhouette`), blobs → people (pieces under a body
joined to it, people who walked into each other cut apart; :mod:`interaction.webcam.silhouette_parts`)
with ids kept by nearest centroid, points along each outline plus head and hands
(:mod:`interaction.people`) and feet at the middles of the leg ends, each with a velocity from DIS
dense optical flow (in boxes around the people; :mod:`interaction.webcam.people_flow`), all mapped through
the calibration onto the stage plane (or floor). A hand or foot that cannot be placed (legs hidden by a
background like them, a person cut from others) is left out rather than reported at a wrong place.
With ``pose`` on, BlazePose's keypoints per person (:mod:`interaction.webcam.pose`, run beside the loop
by :mod:`interaction.webcam.pose_worker`) add hands and feet as contactors with their own velocities.
Uncalibrated (``jostle observe``), observations carry the people count only; the contactors in image
pixels are :attr:`WebcamObserver.image_contactors`. Pure of hardware.

A frame allocates no image-sized arrays but the one it hands out (the people's mask) and the flow DIS
returns: the work arrays are kept from frame to frame (why: docs/notes/webcam.md).
"""

from __future__ import annotations

import logging
import math

import cv2
import numpy as np
import numpy.ma  # noqa: F401  np.median imports it on first use (~16 ms): at import, not in the first frame

from interaction.people import PeopleTracker
from interaction.types import BodyObservation, Contactor, Silhouette
from interaction.webcam.calibration import Calibration
from interaction.webcam.config import FlowPreset, WebcamObserverConfig
from interaction.webcam.floor_people import FloorCalibration, FloorPeople
from interaction.webcam.people_flow import people_flow, same_size
from interaction.webcam.people_found import PersonFinder, person_finder
from interaction.webcam.pose import Keypoints
from interaction.webcam.pose_limbs import PoseLimbs
from interaction.webcam.pose_worker import PoseWorker
from interaction.webcam.silhouette import BackgroundModel
from interaction.webcam.silhouette_parts import join_fragments
from interaction.webcam.stage_placement import StagePlacement, to_input_px
from sensors.base import ColorImage, Frame

__all__ = ["WebcamObserver", "WebcamObserverConfig"]

log = logging.getLogger("jostle.webcam")

_DIS_PRESETS: dict[FlowPreset, int] = {
    "ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
    "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
    "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
}
_PIXELS = Calibration((1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), half_depth=0.0)  # uncalibrated: (u, v) → (u, v)


class WebcamObserver:
    """Turns colour frames into a :class:`BodyObservation` of webcam contactors.

    The first ``config.learn_frames`` frames learn the empty stage; meanwhile (``learning``)
    every observation is empty. Contactors are capsules along the stage's y axis at
    ``calibration.plane_y`` ± ``calibration.half_depth``; velocities have no y part (floor: :class:`FloorPeople`; none uncalibrated).
    """

    def __init__(self, config: WebcamObserverConfig, calibration: Calibration | FloorCalibration | None = None) -> None:
        self._cfg = config  # a floor calibration places people (``_floor``); ``_cal`` is then its upright plane
        self._floor = FloorPeople(calibration, config) if isinstance(calibration, FloorCalibration) else None
        upright = calibration.upright() if isinstance(calibration, FloorCalibration) else calibration
        self._calibrated, self._cal = upright, upright or _PIXELS  # None: uncalibrated, image space only
        self._placing = StagePlacement(config, self._cal, self._floor)
        self._finder: PersonFinder | None = None  # made by the first frame (its size sets the pixel limits)
        self._outlines: dict[int, np.ndarray] = {}  # the people: id → outline
        self._image_contactors: tuple[Contactor, ...] = ()  # uncalibrated: in image pixels
        self._background = BackgroundModel(config)
        self._tracker: PeopleTracker | None = None
        self._flow = cv2.DISOpticalFlow.create(_DIS_PRESETS[config.flow_preset])
        self._flow.setFinestScale(config.flow_finest_scale)
        self._input_size: tuple[int, int] | None = None  # (width, height) of the frames, fixed by the first one
        self._scale = 1.0  # work pixels per input pixel
        self._prev_grey: np.ndarray | None = None
        # image-sized arrays kept from frame to frame (a frame allocates none): the work-size frame, the
        # grey frame not in use (the previous one is still needed), the grown mask, the optical flow
        self._work: np.ndarray | None = None
        self._spare_grey: np.ndarray | None = None
        self._grown: np.ndarray | None = None
        self._flow_work: np.ndarray | None = None
        k = 2 * config.morphology_px + 1
        self._grow_kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))
        self._prev_t: float | None = None
        self._mask: np.ndarray | None = None  # people at work size
        self._silhouette: np.ndarray | None = None  # people at input size, made when asked for
        self._flow_px: np.ndarray | None = None
        self._pose = PoseLimbs.from_config(config) if config.pose else None

    # ------------------------------------------------------------ read-only views

    @property
    def config(self) -> WebcamObserverConfig:
        return self._cfg

    @property
    def calibration(self) -> Calibration | None:  # None: uncalibrated; a floor calibration: its upright plane
        return self._calibrated

    @property
    def people(self) -> dict[int, np.ndarray]:
        """The last frame's people: id → outline (M, 2) in input pixels (float)."""
        return self._outlines

    @property
    def image_contactors(self) -> tuple[Contactor, ...]:
        """Uncalibrated only: the last frame's contactors in input pixels (position (u, 0, v), px/s, radius px)."""
        return self._image_contactors

    @property
    def crowd_frames(self) -> int:
        """Frames that held more people than ``max_people`` (the smallest of them not reported)."""
        return self._finder.crowd_frames if self._finder is not None else 0

    @property
    def learning(self) -> bool:
        """True until the background has been learned from the first frames."""
        return self._background.learning

    @property
    def silhouette(self) -> np.ndarray | None:
        """The last frame's people as a uint8 mask the size of the frames (255 = a person, holes
        filled), read-only; None while learning."""
        if self._silhouette is None and self._mask is not None and self._input_size is not None:
            sil = self._mask
            if sil.shape[::-1] != self._input_size:
                sil = cv2.resize(sil, self._input_size, interpolation=cv2.INTER_NEAREST)
            sil.flags.writeable = False
            self._silhouette = sil
        return self._silhouette

    @property
    def work_silhouette(self) -> np.ndarray | None:
        """The last frame's people at work size (see ``WebcamObserverConfig.work_width``), read-only."""
        return self._mask

    @property
    def background(self) -> np.ndarray | None:
        """The learned empty stage (uint8 BGR copy), None while learning."""
        return self._background.background

    @property
    def light_gain(self) -> tuple[float, float, float]:
        """The last frame's light relative to the background, per channel (B, G, R)."""
        return self._background.gain

    @property
    def flow(self) -> np.ndarray | None:
        """The last backward optical flow at work size (h, w, 2), in work pixels: where each pixel was
        in the previous frame, relative to where it is now. Computed only in a box around the people
        (0 elsewhere); None when not computed (no one in view, or only people seen for the first time).
        The observer's own array, overwritten by the next frame (copy it to keep it)."""
        return self._flow_px

    @property
    def pose_active(self) -> bool:
        """True when body keypoints are being found (``pose`` on and the model files loaded)."""
        return self._pose is not None

    @property
    def keypoints(self) -> dict[int, Keypoints]:
        """The newest body keypoints per person id in view (empty when pose is off or no one was found);
        each carries the time ``t`` of the frame it was computed from (this frame's with ``pose_sync``)."""
        return self._pose.keypoints if self._pose is not None else {}

    @property
    def pose_updates(self) -> dict[int, int]:
        """Keypoint refreshes per person id since start (or the last :meth:`relearn`): how many new
        sets of keypoints (a person found by the model) were attached to each person."""
        return self._pose.updates if self._pose is not None else {}

    @property
    def pose_worker(self) -> PoseWorker | None:
        """The worker running the pose model (None when pose is off): its counts, for benches."""
        return self._pose.worker if self._pose is not None else None

    def focus_on(self, points: np.ndarray | None) -> None:
        """Stage points (N, 3) metres, the characters: when the model cannot look at everyone each
        frame, the people nearest them (on the floor, x and y) come first; None: the largest first."""
        if self._pose is not None:
            self._pose.focus_on(points)

    def close(self) -> None:
        """Stop the pose worker's thread. Idempotent; the observer is not to be used afterwards."""
        if self._pose is not None:
            self._pose.worker.close()

    def relearn(self) -> None:
        """Forget the background and the people; the next frames learn the empty stage again."""
        self._background.relearn()
        self._tracker = None
        self._finder, self._outlines, self._image_contactors = None, {}, ()
        if self._pose is not None:
            self._pose.reset()
        self._input_size = None
        self._mask = None
        self._silhouette = None
        self._flow_px = None

    # ------------------------------------------------------------ per frame

    def observe(self, frame: Frame) -> BodyObservation:
        """The people in one colour frame. Raises ValueError on a frame that is not a colour image,
        or whose size differs from the calibration's or from the frames before it."""
        bgr = self._check(frame)
        work = self._work_image(bgr)
        grey = cv2.cvtColor(work, cv2.COLOR_BGR2GRAY, dst=same_size(self._spare_grey, work.shape[:2], np.uint8))
        prev_grey, prev_t = self._prev_grey, self._prev_t
        self._prev_grey, self._prev_t = grey, frame.t
        self._spare_grey = prev_grey  # still read this frame (the flow); written into next frame
        self._flow_px = None

        if self._background.learning:
            self._background.learn(work)
            return BodyObservation(t=frame.t)

        cfg = self._cfg
        h, w = grey.shape
        mask = self._background.foreground(work, ignore=self._ignore_for_light())
        finder = self._finder = self._finder or person_finder(cfg, self._scale, (w, h), self._calibrated, self._input_size)
        found = join_fragments(finder.find(mask))
        recent: list[tuple[float, float]] = []
        if self._tracker is not None and found:  # people who walked into each other: cut where each was
            recent = finder.apart(self._tracker.predicted(), frame.t)
        persons = finder.cut(found, recent)[: cfg.max_people]
        blobs = [p.blob for p in persons]

        people = np.zeros_like(mask)
        if blobs:
            cv2.drawContours(people, [b.contour.reshape(-1, 1, 2) for b in blobs], -1, 255, cv2.FILLED)
        grown = cv2.dilate(people, self._grow_kernel, dst=same_size(self._grown, people.shape, np.uint8)) if blobs else None
        self._background.refresh(work, grown)  # adapts where no one stands
        people.flags.writeable = False
        self._mask, self._silhouette = people, None
        if self._tracker is None:
            self._tracker = PeopleTracker(cfg.match_distance * math.hypot(w, h), cfg.track_memory_frames)
        ids = self._tracker.assign([b.centroid for b in blobs])  # also ages the people not seen
        finder.seen(ids, persons, found, frame.t)
        for ghost in finder.still.still(ids, blobs, grey, prev_grey, frame.t, self._background.grey):
            self._background.absorb(work, ghost.contour)  # gone from the next frame on
        self._outlines = {i: self._to_input_px(b.contour.astype(np.float64)) for i, b in zip(ids, blobs, strict=True)}
        self._image_contactors = ()
        seen = Silhouette(self.silhouette, self._calibrated) if self._calibrated is not None else None  # type: ignore[arg-type]
        if not blobs:
            if self._pose is not None:
                self._pose.update(frame.t, bgr, [], [])  # everyone is forgotten, by the worker too
            return BodyObservation(t=frame.t, silhouette=seen)
        born = self._tracker.born

        dt = frame.t - prev_t if prev_t is not None else 0.0
        if prev_grey is not None and dt > 0 and len(born) < len(ids):
            self._flow_work = same_size(self._flow_work, (*grey.shape, 2), np.float32)
            self._flow_px = people_flow(self._flow, grey, prev_grey, blobs, self._flow_work)

        contactors: list[Contactor] = []
        for pid, person in sorted(zip(ids, persons, strict=True), key=lambda p: p[0]):
            contactors.extend(self._placing.body(pid, person, people, 0.0 if pid in born else dt, self._flow_px, self._scale))
        if self._pose is not None:
            contactors.extend(self._placing.limbs(self._pose, bgr, ids, blobs, people, frame.t, dt, born, self._flow_px,
                                                   self._scale))
        self._image_contactors = () if self._calibrated else tuple(contactors)  # uncalibrated: kept apart, none out
        return BodyObservation(t=frame.t, contactors=tuple(contactors) if self._calibrated else (), people=len(blobs),
                               silhouette=seen)

    # ------------------------------------------------------------ internals

    def _check(self, frame: Frame) -> np.ndarray:
        p = frame.payload
        if not isinstance(p, ColorImage):
            raise ValueError(
                f"WebcamObserver: frame {frame.seq} from sensor {frame.sensor!r} carries a {frame.kind} payload; "
                "expected a colour image"
            )
        bgr = p.bgr
        if bgr.dtype != np.uint8 or bgr.ndim != 3 or bgr.shape[2] != 3:
            raise ValueError(
                f"WebcamObserver: frame {frame.seq} from sensor {frame.sensor!r}: expected uint8 BGR (H, W, 3), "
                f"got {bgr.dtype} {bgr.shape}"
            )
        size = p.size
        want = (self._floor.calibration if self._floor is not None else self._cal).image_size
        if want is not None and size != want:
            raise ValueError(
                f"WebcamObserver: frame {frame.seq} from sensor {frame.sensor!r} is {size[0]}×{size[1]}, "
                f"but the calibration was made for {want[0]}×{want[1]}"
            )
        if self._input_size is None:
            self._input_size = size
            ww = self._cfg.work_width
            self._scale = ww / size[0] if 0 < ww < size[0] else 1.0
        elif size != self._input_size:
            first = self._input_size
            raise ValueError(
                f"WebcamObserver: frame {frame.seq} from sensor {frame.sensor!r} is {size[0]}×{size[1]}, "
                f"but the frames before were {first[0]}×{first[1]} (call relearn() after changing the camera)"
            )
        return bgr

    def _work_image(self, bgr: np.ndarray) -> np.ndarray:
        if self._scale == 1.0:
            return bgr
        h, w = bgr.shape[:2]
        size = (max(1, round(w * self._scale)), max(1, round(h * self._scale)))
        self._work = same_size(self._work, (size[1], size[0], 3), np.uint8)
        return cv2.resize(bgr, size, dst=self._work, interpolation=cv2.INTER_AREA)

    def _to_input_px(self, uv_work: np.ndarray) -> np.ndarray:
        return to_input_px(self._scale, uv_work)

    def _ignore_for_light(self) -> np.ndarray | None:
        """Where people stood last frame, grown a little: left out of the light measurement."""
        if self._mask is None or not self._mask.any():
            return None
        self._grown = same_size(self._grown, self._mask.shape, np.uint8)
        return cv2.dilate(self._mask, self._grow_kernel, dst=self._grown)
