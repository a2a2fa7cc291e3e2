"""What sim/ produces: an immutable snapshot of the world after each step, and the events of the step."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

from interaction.types import Vec3

Quat = tuple[float, float, float, float]  # x, y, z, w (pybullet's order)


class CharacterState(StrEnum):
    """The control state machine (Mitake et al. 2009, Figure 3)."""

    WALK = "walk"  # upright, balanced by the inverted-pendulum state feedback
    STAGGER = "stagger"  # pushed off balance, the bounded controller still recovering
    FALL = "fall"  # beyond recovery, falling
    BRAKE = "brake"  # on the ground, PD brake until still
    LIE = "lie"  # lying face up or face down
    STAND_UP = "stand_up"  # rising back to upright


@dataclass(frozen=True, slots=True)
class LinkPose:
    """One rigid link of an articulated character (issue G) or a quadruped (issue H), in stage metres.

    ``position`` is the link frame's origin (pybullet's link world position for the link frame, i.e. the
    joint), ``orientation`` its world orientation (x, y, z, w).
    """

    name: str
    position: Vec3
    orientation: Quat


@dataclass(frozen=True, slots=True)
class CharacterSnapshot:
    """One character after a step.

    ``tilt`` is (θx, θz) of the paper in radians: θx the lean forward (+) / backward (−) about the
    character's side axis, θz the lean to its right (+) / left (−) about its forward axis.
    ``d_front`` / ``d_side`` are the paper's travelled distances (eqs. 6–7), metres.
    ``behaviour`` is B, the animation behaviour the AI picks (e.g. "walk", "stand_up");
    ``intent`` is what the AI is doing (e.g. "wander", "flee").
    ``kind``, ``balance_load``, ``links`` and ``com_height`` were added later (defaults keep older constructors working).
    """

    name: str
    position: Vec3  # centre of mass, stage metres
    orientation: Quat
    velocity: Vec3
    angular_velocity: Vec3
    heading: float  # yaw of the character's forward axis from stage +x, radians
    tilt: tuple[float, float]
    d_front: float
    d_side: float
    state: CharacterState
    behaviour: str
    intent: str
    face_up: bool | None  # when lying: True face up, False face down; None otherwise
    contact_force_n: float  # largest force a person applied on it during the last step
    height: float  # metres, from the character spec (for drawing)
    kind: str = ""  # the character spec's name (e.g. "walker", "critter"): which figure to draw
    balance_load: float = 0.0  # 0 balanced … ≥ 1 beyond what its bounded controller can recover (10: down)
    links: tuple[LinkPose, ...] = ()  # articulated kinds only: every link's world pose (render draws these)
    # metres above its lowest point, from the spec (render lifts the figure by it); None: half its height.
    # Left out of repr, so the run's trace hash (of the reprs) stays what it was before the field came.
    com_height: float | None = field(default=None, repr=False)


PAD_PERSON = -1  # ContactEvent.person for pads and strikes (they carry no person id)


@dataclass(frozen=True, slots=True)
class ContactEvent:
    """One contact episode between a person and a character, reported when it ends.

    ``push`` is True when ``impulse_ns`` reached the character's configured push threshold.
    """

    t_start: float
    t_end: float
    character: str
    person: int
    impulse_ns: float
    peak_force_n: float
    push: bool


@dataclass(frozen=True, slots=True)
class StateChange:
    t: float
    character: str
    before: CharacterState
    after: CharacterState


@dataclass(frozen=True, slots=True)
class WorldSnapshot:
    """The world after one ``World.step``: characters, and the events since the previous snapshot.

    ``dropped_time`` is simulated time skipped because catch-up was capped (0 when none).
    """

    t: float
    steps: int  # physics steps taken since the world was made
    characters: tuple[CharacterSnapshot, ...]
    contacts: tuple[ContactEvent, ...] = ()
    changes: tuple[StateChange, ...] = ()
    dropped_time: float = 0.0
