"""The performance every virtual sensor films: the cast, their poses and velocities at any time, one
pybullet client with a puppet per person, and the room's light — shared by the webcam, the OAK and
the pads so that all of them see the same people at the same moment.

Times here are *performance* times (seconds since the sensors were opened). Sensors that share a
:class:`Performance` must be opened at the same clock time. The pybullet client lives while any
sensor holds the performance (:meth:`Performance.acquire` / :meth:`Performance.release`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from jostle.performer.camera import PinholeCamera
from jostle.performer.cast import Person, build_cast
from jostle.performer.choreography import StagePose, stage_joint_positions
from jostle.performer.config import PerformerConfig
from jostle.performer.puppet import HumanoidPuppet, PuppetImage
from jostle.performer.room import RoomImage, render_room
from sensors.base import SensorNotOpen
from sim.motion.mocap import HUMANOID

VELOCITY_STEP_S = 1.0 / 480.0  # velocities: central differences over ±this (one-sided at the path's ends)


@dataclass(frozen=True, eq=False)
class PersonState:
    """One person at one moment. ``joints``/``velocities`` (B, 3) hold every bone of
    ``sim.motion.mocap.HUMANOID`` (in ``HUMANOID.names`` order) in stage metres and m/s; (0, 3) while
    the person is not on the stage (``pose`` is None)."""

    id: int
    size: float
    mass_kg: float
    pose: StagePose | None
    joints: np.ndarray
    velocities: np.ndarray

    @property
    def present(self) -> bool:
        return self.pose is not None

    def joint(self, name: str) -> np.ndarray:
        return self.joints[HUMANOID.names.index(name)]

    def joint_velocity(self, name: str) -> np.ndarray:
        return self.velocities[HUMANOID.names.index(name)]


def in_view(camera: PinholeCamera, positions: np.ndarray) -> bool:
    """False only when the whole body (joints plus a 0.3 m margin) projects outside the image."""
    cam = camera.to_camera(positions)
    depth = cam[:, 2]
    if np.all(depth <= camera.near):
        return False
    if np.any(depth <= camera.near):
        return True
    uv = camera.project(positions)
    margin = 0.3 * camera.focal_px / float(depth.min())
    return bool(
        uv[:, 0].max() >= -margin
        and uv[:, 0].min() <= camera.width + margin
        and uv[:, 1].max() >= -margin
        and uv[:, 1].min() <= camera.height + margin
    )


class Performance:
    """The people of ``config`` on the stage. See the module doc."""

    def __init__(self, config: PerformerConfig) -> None:
        self.config = config
        self.cast: tuple[Person, ...] = build_cast(config)
        self._light_phase = float(np.random.default_rng([config.seed, 1]).uniform(0, 2 * math.pi))
        self._puppet: HumanoidPuppet | None = None
        self._users = 0
        self._states: dict[float, tuple[PersonState, ...]] = {}

    # ------------------------------------------------------------ lifetime

    def acquire(self) -> None:
        """One more sensor is using the puppets (starts pybullet on first use)."""
        if self._puppet is None:
            self._puppet = HumanoidPuppet(tuple(p.plan.size for p in self.cast))
        self._users += 1

    def release(self) -> None:
        """A sensor is done; the last one out stops pybullet."""
        self._users = max(self._users - 1, 0)
        if self._users == 0 and self._puppet is not None:
            self._puppet.close()
            self._puppet = None

    def puppet(self) -> HumanoidPuppet:
        if self._puppet is None:
            raise SensorNotOpen("virtual performer: the puppets are not loaded (open a sensor first)")
        return self._puppet

    # ------------------------------------------------------------ people

    def people_at(self, tau: float) -> tuple[PersonState, ...]:
        """Everyone's state at performance time tau (cheap: kinematics only, no rendering)."""
        known = self._states.get(tau)
        if known is not None:
            return known
        out = tuple(self._person_at(person, tau) for person in self.cast)
        if len(self._states) >= 8:
            self._states.pop(next(iter(self._states)))
        self._states[tau] = out
        return out

    def _person_at(self, person: Person, tau: float) -> PersonState:
        plan = person.plan
        pose = person.path.pose(tau)
        if pose is None:
            empty = np.zeros((0, 3))
            return PersonState(plan.id, plan.size, plan.mass_kg, None, empty, empty)
        h = VELOCITY_STEP_S
        around = [person.path.pose(tau - h), pose, person.path.pose(tau + h)]
        known = [p for p in around if p is not None]
        all_positions = stage_joint_positions(known)
        positions = all_positions[known.index(pose)]
        span = h * (len(known) - 1)
        velocities = (all_positions[-1] - all_positions[0]) / span if span > 0 else np.zeros_like(positions)
        return PersonState(plan.id, plan.size, plan.mass_kg, pose, positions, velocities)

    def render(self, camera: PinholeCamera, tau: float, *, depth: bool = False) -> PuppetImage | None:
        """Everyone in view of ``camera`` at tau, drawn at once; None when no one is in view."""
        puppet = self.puppet()
        shown = False
        for state in self.people_at(tau):
            if state.pose is not None and in_view(camera, state.joints):
                puppet.set_pose(state.pose, state.id)
                shown = True
            else:
                puppet.hide(state.id)
        return puppet.render(camera, depth=depth) if shown else None

    # ------------------------------------------------------------ the room

    def light_gain(self, tau: float) -> float:
        """The global brightness factor at performance time tau."""
        c = self.config
        return 1.0 + c.light_change * math.sin(2 * math.pi * tau / c.light_period_s + self._light_phase)

    def room(self, camera: PinholeCamera) -> RoomImage:
        return render_room(camera, self.config.stage_half_width_m, self.config.seed)


def compose_colour(
    room: RoomImage,
    image: PuppetImage | None,
    people: tuple[PersonState, ...],
    gain: float,
    config: PerformerConfig,
    noise_sigma: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """A camera's BGR frame: the room, soft contact shadows, the people, lens fall-off, the room's
    light, optical blur and sensor noise."""
    img = room.bgr.copy()
    if config.shadow > 0:  # a soft contact shadow on the floor around each person's feet
        flat = img.reshape(-1, 3)
        for state in people:
            if state.pose is None:
                continue
            x, y = state.pose.position[0], state.pose.position[1]
            d2 = (room.floor_xy[:, 0] - x) ** 2 + (room.floor_xy[:, 1] - y) ** 2
            near = d2 < 1.0
            shade = 1.0 - config.shadow * np.exp(-d2[near] / (2 * 0.28**2))
            flat[room.floor_index[near]] *= shade[:, None].astype(np.float32)
    if image is not None:
        mask = image.person >= 0
        img[mask] = image.rgb[mask][:, ::-1]
    img *= room.vignette * np.float32(gain)
    if config.blur_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), config.blur_px)
    if noise_sigma > 0:
        img += rng.standard_normal(img.shape, dtype=np.float32) * np.float32(noise_sigma)
    np.clip(img, 0.0, 255.0, out=img)
    return np.rint(img).astype(np.uint8)
