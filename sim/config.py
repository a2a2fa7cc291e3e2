"""Configuration of the simulated world and of one character kind (frozen, validated, TOML-shaped).

Every field is a plain number/str/bool so the composition root can build these from TOML; each
``__post_init__`` raises ``ValueError`` whose message starts with the field name.
Angles a person sets are in degrees (``*_deg``); everything the sim reports is in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from sim.stepping import compute_n_substeps

INTENTS = ("idle", "wander", "approach", "flee", "follow")


# A character's body within sizes a person would draw and pybullet can step (m, kg, kg·m²).
_BODY_RANGES = (("height", 0.1, 10.0), ("mass", 0.1, 10_000.0), ("inertia", 1e-3, 1e5), ("half_depth", 0.01, 5.0),
                ("half_width", 0.01, 5.0))


def _check_positive(obj: object, *names: str) -> None:
    for name in names:
        value = getattr(obj, name)
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
            raise ValueError(f"{name}: expected a number > 0, got {value!r}")


def _check_non_negative(obj: object, *names: str) -> None:
    for name in names:
        value = getattr(obj, name)
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value < 0:
            raise ValueError(f"{name}: expected a number >= 0, got {value!r}")


def _check_finite(obj: object) -> None:
    for f in fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"{f.name}: expected a finite number, got {value!r}")


@dataclass(frozen=True)
class WorldConfig:
    """The world: time split, floor, stage bounds and input sanity limits.

    The stage (``x_min``..``x_max`` by ``y_min``..``y_max``) is the floor rectangle characters live on (stage frame: metres, z up, x to the
    audience's right, y into the screen). Randomness is not configured here: ``World`` takes a
    seeded ``numpy.random.Generator``.
    """

    physics_dt: float = 1.0 / 240.0
    # controller, state machine and AI: one tick per rendered frame at 30 fps, 8 physics steps in between
    # (``jostle bench sim``: the per-character pybullet calls of a tick cost more than its physics step)
    control_dt: float = 1.0 / 30.0
    max_catchup_ticks: int = 8
    gravity: float = 9.81
    floor_friction: float = 0.8  # μ between a body and the floor (bounds the legs' friction force too)
    x_min: float = -3.0
    x_max: float = 3.0
    y_min: float = -1.0
    y_max: float = 1.0
    contact_episode_gap_s: float = 0.1  # a contact episode ends after this long without contact
    contactor_hold_s: float = 0.25  # contactors of the last observation stay (extrapolated) this long
    contactor_friction: float = 0.5  # μ: a contactor's drag along its motion is at most μ·(normal force)
    # The contact law (``sim.person_contact``): people push like springs (N/m per metre of overlap) with
    # damping (N·s/m), and all of one person's contactors together push with at most max_person_force_n
    # (N; about a strong adult's shove, lower for a children's installation), checked every substep.
    contactor_stiffness: float = 20000.0
    contactor_damping: float = 2000.0
    max_person_force_n: float = 800.0
    max_contactor_speed: float = 15.0  # m/s; faster contactor velocities are clamped (and counted)
    max_contactor_radius: float = 1.0  # m; radii/half-depths are clamped to this
    max_impulse_force_n: float = 3000.0  # pad forces are clamped to this magnitude
    max_impulse_duration_s: float = 0.5
    max_impulse_ns: float = 300.0  # pad pushes and strikes carry at most this much momentum (N·s)
    max_character_speed: float = 20.0  # m/s; a body found faster (stacked pushes, solver trouble) is slowed
    max_character_spin: float = 40.0  # rad/s, likewise
    stage_escape_margin: float = 1.5  # a character this far outside the stage is put back on it
    stuck_timeout_s: float = 30.0  # fallen this long without standing up again: put back upright
    # Contact solver iterations per physics step (pybullet's default is 50). One body on a floor and the
    # odd neighbour need few; the cost of the step grows with them.
    solver_iterations: int = 10

    def __post_init__(self) -> None:
        _check_finite(self)
        _check_positive(self, "physics_dt", "control_dt", "gravity", "contact_episode_gap_s",
                        "max_contactor_speed", "max_contactor_radius", "max_impulse_force_n",
                        "max_impulse_duration_s", "max_impulse_ns", "stuck_timeout_s", "max_character_speed",
                        "max_character_spin", "max_person_force_n")
        _check_non_negative(self, "floor_friction", "contactor_hold_s", "contactor_friction",
                            "stage_escape_margin", "contactor_stiffness", "contactor_damping")
        for name in ("max_catchup_ticks", "solver_iterations"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name}: expected an integer >= 1, got {value!r}")
        compute_n_substeps(self.control_dt, self.physics_dt)
        if not self.x_min < self.x_max:
            raise ValueError(f"x_max: expected > x_min={self.x_min}, got {self.x_max}")
        if not self.y_min < self.y_max:
            raise ValueError(f"y_max: expected > y_min={self.y_min}, got {self.y_max}")

    @property
    def n_substeps(self) -> int:
        return compute_n_substeps(self.control_dt, self.physics_dt)


@dataclass(frozen=True)
class CharacterSpec:
    """One kind of character: body, balance limits, state-machine thresholds and AI temperament.

    Body (Mitake et al. 2009 §6.1): one rigid body ``height`` tall, ``mass`` kg, inertia
    ``inertia``·I about its centre of mass. Its shape is a convex hull whose horizontal
    cross-section at height z is an ellipse of half-axes ``half_depth``·s(z) (front-back) and
    ``half_width``·s(z) (sideways), s the superellipse profile with exponent ``bottom_exponent``
    below ``widest_height`` and ``top_exponent`` above. ``half_depth < half_width`` makes it fall
    front/back more easily and land face up or face down, never on its side.

    Balance (eqs. 1–5): ``tau_max`` / ``tau_max_side`` bound the centre-of-pressure torque in the
    front-back / sideways plane (reach of the legs × weight); ``leg_force_max`` bounds the legs'
    horizontal friction force (also bounded by μ·fN). The ``lqr_*_scale`` are Bryson's-rule scales of
    the state-feedback design (see ``sim.mitake.balance``).

    The state machine compares the *balance load* (0 upright and still, 1 at the edge of what the
    bounded controller can recover, see ``sim.mitake.balance.balance_load``) with ``stagger_ratio``,
    ``recover_ratio`` and ``fall_ratio``.
    """

    name: str = "character"
    # body
    height: float = 1.5
    mass: float = 40.0
    inertia: float = 10.0
    com_height: float = 0.75
    widest_height: float = 0.8
    half_depth: float = 0.14
    half_width: float = 0.25
    bottom_exponent: float = 1.8
    top_exponent: float = 2.2
    # balance limits and design
    tau_max: float = 40.0
    tau_max_side: float = 60.0
    leg_force_max: float = 160.0
    yaw_torque_max: float = 40.0
    yaw_frequency: float = 4.0  # rad/s, critically damped heading PD
    lqr_tilt_scale_deg: float = 6.0
    lqr_rate_scale: float = 1.0
    lqr_speed_scale: float = 0.4
    # state machine
    push_threshold_ns: float = 20.0
    stagger_ratio: float = 0.3
    recover_ratio: float = 0.1
    recover_hold_s: float = 0.4
    fall_ratio: float = 0.9
    ground_tilt_deg: float = 60.0  # falling body this tilted (and low) is on the ground: brake
    still_speed: float = 0.08
    still_rate: float = 0.3
    still_hold_s: float = 0.3
    lie_duration_s: float = 1.2
    getup_duration_s: float = 2.0
    getup_torque_max: float = 600.0
    getup_frequency: float = 5.0  # rad/s, stand-up PD on the tilt
    upright_tilt_deg: float = 6.0  # standing up is done below this tilt
    brake_rate: float = 4.0  # 1/s, PD brake gain on fallen velocity and spin
    # AI
    walk_speed: float = 0.8
    flee_speed: float = 1.5
    approach_distance: float = 0.8
    personal_space: float = 0.9
    flee_duration_s: float = 2.5
    wander_pause_s: float = 1.5
    stage_margin: float = 0.3
    # reactions and temperament (added with the vectorised model; all optional)
    pivot_damping: float = 0.5  # 1/s: a pushed character lets the push turn it (it pivots); spin decays at this rate
    pivot_s: float = 1.5  # s after the last push during which it pivots (then it turns back to its goal)
    waypoints: tuple[float, ...] = ()  # x0, y0, x1, y1, ... stage metres: the loop intent "follow" walks
    after_fall_intent: str = ""  # intent for after_fall_s once it stood up again ("" = its own intent)
    after_fall_s: float = 6.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"name: expected a non-empty string, got {self.name!r}")
        _check_finite(self)
        _check_positive(self, "height", "mass", "inertia", "com_height", "widest_height", "half_depth",
                        "half_width", "bottom_exponent", "top_exponent", "tau_max", "tau_max_side",
                        "leg_force_max", "yaw_torque_max", "yaw_frequency", "lqr_tilt_scale_deg",
                        "lqr_rate_scale", "lqr_speed_scale", "push_threshold_ns", "stagger_ratio",
                        "recover_ratio", "fall_ratio", "ground_tilt_deg", "still_speed", "still_rate",
                        "lie_duration_s", "getup_duration_s", "getup_torque_max", "getup_frequency",
                        "upright_tilt_deg", "brake_rate", "walk_speed", "flee_speed",
                        "approach_distance", "personal_space", "flee_duration_s")
        _check_non_negative(self, "recover_hold_s", "still_hold_s", "wander_pause_s", "stage_margin",
                            "pivot_damping", "pivot_s", "after_fall_s")
        if len(self.waypoints) % 2 or not all(isinstance(v, int | float) and math.isfinite(v)
                                              for v in self.waypoints):
            raise ValueError(f"waypoints: expected finite x, y pairs (an even count of numbers), got {self.waypoints!r}")
        if self.after_fall_intent not in ("", *INTENTS):
            raise ValueError(f"after_fall_intent: expected \"\" or one of {', '.join(INTENTS)}, "
                             f"got {self.after_fall_intent!r}")
        for key, lo, hi in _BODY_RANGES:  # a body pybullet can step: 1e308 m overflows on its way in
            value = getattr(self, key)
            if not lo <= value <= hi:
                raise ValueError(f"{key}: expected {lo:g} to {hi:g} (a character's body), got {value!r}")
        if not self.com_height < self.height:
            raise ValueError(f"com_height: expected < height={self.height}, got {self.com_height}")
        if not self.widest_height < self.height:
            raise ValueError(f"widest_height: expected < height={self.height}, got {self.widest_height}")
        if not self.half_depth <= self.half_width:
            raise ValueError(
                f"half_depth: expected <= half_width={self.half_width} (so it lands face up or down), "
                f"got {self.half_depth}"
            )
        if not self.recover_ratio < self.stagger_ratio < self.fall_ratio:
            raise ValueError(
                f"stagger_ratio: expected recover_ratio < stagger_ratio < fall_ratio, got "
                f"{self.recover_ratio} / {self.stagger_ratio} / {self.fall_ratio}"
            )
        if not self.upright_tilt_deg < self.ground_tilt_deg < 90.0:
            raise ValueError(
                f"ground_tilt_deg: expected between upright_tilt_deg={self.upright_tilt_deg} and 90, "
                f"got {self.ground_tilt_deg}"
            )
