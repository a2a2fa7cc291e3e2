"""The virtual performer: a webcam filming motion-captured people in a room, with ground truth.

:class:`PerformerSensor` is a :class:`sensors.base.Sensor` that produces BGR frames at ``fps`` on
the injected clock's timeline, like a replay: frame k has ``t = t_open + k / fps`` and ``read``
returns it once the clock has reached that time (never sleeping, never skipping). With the default
``route = "round"`` the first ``empty_s`` seconds show the empty room; then a DeepMimic humanoid
walks in from the left along the stage plane y = 0 (stopping left of centre to perform the action
clips, if any), turns, walks back and leaves; the round then repeats (see
``jostle.performer.choreography``). With ``route = "crossing"`` 1..4 people of different sizes cross
the stage on their own lanes (``jostle.performer.cast``). Every frame is a pure function of (config,
k): the same config and seed give the same bytes. :meth:`PerformerSensor.truth` gives what is
really there (silhouette, body parts, who is where, joints in stage metres and their velocities)
and :meth:`PerformerSensor.homography` the exact map from pixels to the stage plane.

The people are a :class:`jostle.performer.scene.Performance`; pass the same one to the virtual OAK
(``jostle.performer.depth``) and pads (``jostle.performer.pads``) to record them all together.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from jostle.performer.choreography import SegmentPath
from jostle.performer.config import PerformerConfig
from jostle.performer.puppet import HumanoidPuppet, PuppetImage
from jostle.performer.room import RoomImage
from jostle.performer.scene import Performance, PersonState, compose_colour
from jostle.performer.timeline import TimelineSensor
from sensors.base import ColorImage, SensorNotOpen, SensorSpec
from sensors.clock import Clock
from sim.motion.mocap import HUMANOID

__all__ = ["PerformerConfig", "PerformerSensor", "PerformerTruth"]


@dataclass(frozen=True, eq=False)
class PerformerTruth:
    """What is really in front of the camera at time ``t`` (loop clock).

    ``joints``/``velocities`` hold every bone of ``sim.motion.mocap.HUMANOID`` (root, chest, neck,
    head_top, hips, knees, ankles, toes, shoulders, elbows, wrists) of person 0 in stage metres and
    m/s while that person is on its path (even outside the picture); they are empty while the
    person is off the stage. ``people`` holds everyone's state (ids 0, 1, …). ``parts`` is the
    pybullet link index seen at each pixel (-1: no person; names in ``PerformerSensor.link_names``),
    ``person`` the id of the person seen there (-1: none). ``present`` is true when any pixel shows
    a person.
    """

    t: float
    present: bool
    silhouette: np.ndarray  # (H, W) bool
    parts: np.ndarray  # (H, W) int16
    joints: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    velocities: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    people: tuple[PersonState, ...] = ()
    person: np.ndarray | None = None  # (H, W) int8


class PerformerSensor(TimelineSensor):
    """A virtual webcam filming the performance. See the module doc for the timeline.

    ``performance``: the people to film, shared with other virtual sensors (default: its own,
    made from ``config``).
    """

    def __init__(
        self, config: PerformerConfig, clock: Clock, name: str = "webcam", *, performance: Performance | None = None
    ) -> None:
        performance = performance or Performance(config)
        if performance.config != config:
            raise ValueError(f"{name}: the performance was made from another config than this sensor's")
        super().__init__(performance, clock, name, config.fps)
        self.config = config
        self.camera = config.camera()
        self._room: RoomImage = performance.room(self.camera)
        self._cache: dict[int, PerformerTruth] = {}

    @property
    def choreography(self) -> SegmentPath:
        """The first person's path (for the round: the demo's ``Choreography``)."""
        return self.performance.cast[0].path

    @property
    def spec(self) -> SensorSpec:
        c = self.config
        return SensorSpec(self.name, "color", c.fps, c.width, c.height)

    def _on_open(self) -> None:
        self._cache.clear()

    def _on_close(self) -> None:
        self._cache.clear()

    def _payload(self, k: int, tau: float) -> ColorImage:
        truth, image = self._scene(tau, self.t_open + tau)
        self._remember(k, truth)
        rng = np.random.default_rng([self.config.seed, 2, k])
        bgr = compose_colour(self._room, image, truth.people, self.performance.light_gain(tau), self.config,
                             self.config.noise_sigma, rng)
        return ColorImage(bgr)

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
        tau = t - self.t_open
        k = round(tau * self.config.fps)
        on_frame = abs(tau * self.config.fps - k) < 1e-6
        if on_frame and k in self._cache:
            return self._cache[k]
        truth, _ = self._scene(tau, t)
        if on_frame:
            self._remember(k, truth)
        return truth

    def light_gain(self, tau: float) -> float:
        """The global brightness factor at performance time tau (seconds since open)."""
        return self.performance.light_gain(tau)

    # ------------------------------------------------------------ rendering

    def _open_puppet(self) -> HumanoidPuppet:
        if not self._open:
            raise SensorNotOpen(f"{self.name}: ground truth needs the sensor open")
        return self.performance.puppet()

    def _remember(self, k: int, truth: PerformerTruth) -> None:
        if len(self._cache) >= 4:
            self._cache.pop(next(iter(self._cache)))
        self._cache[k] = truth

    def _scene(self, tau: float, t: float) -> tuple[PerformerTruth, PuppetImage | None]:
        """Truth at performance time tau and the rendered people (or None when no one is in view)."""
        c = self.config
        people = self.performance.people_at(tau)
        image = self.performance.render(self.camera, tau)
        if image is None:
            parts = np.full((c.height, c.width), -1, dtype=np.int16)
            person = np.full((c.height, c.width), -1, dtype=np.int8)
        else:
            parts, person = image.parts, image.person
        first = people[0]
        names = HUMANOID.names
        joints = {n: (float(p[0]), float(p[1]), float(p[2])) for n, p in zip(names, first.joints, strict=False)}
        vel = {n: (float(v[0]), float(v[1]), float(v[2])) for n, v in zip(names, first.velocities, strict=False)}
        silhouette = person >= 0
        truth = PerformerTruth(t, bool(silhouette.any()), silhouette, parts, joints, vel, people, person)
        return truth, image
