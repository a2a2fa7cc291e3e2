"""Every character of a world as columns of numpy arrays (one row per character).

The controller, state machine and AI run once per control tick for all characters together
(``sim.mitake.control``, ``sim.mitake.states``, ``sim.mitake.ai``): at a thousand characters a Python loop over objects
costs more than the physics. ``Columns`` holds the per-character constants (spec fields and the
balance design), ``Crowd`` the state that changes. Rows are added, never removed.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from sim.config import INTENTS, CharacterSpec
from sim.frames import Frames, frames, tilt_rates
from sim.mitake.balance import BalanceDesign
from sim.snapshot import CharacterState

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

STATES: tuple[CharacterState, ...] = tuple(CharacterState)
WALK, STAGGER, FALL, BRAKE, LIE, STAND_UP = (STATES.index(s) for s in (
    CharacterState.WALK, CharacterState.STAGGER, CharacterState.FALL, CharacterState.BRAKE,
    CharacterState.LIE, CharacterState.STAND_UP))
IDLE, WANDER, APPROACH, FLEE, FOLLOW = (INTENTS.index(i) for i in ("idle", "wander", "approach", "flee", "follow"))
NO_INTENT = -1
SPEED_ERROR_SHARE = 1.0


class Columns:
    """Per-character constants: spec fields by name, plus the balance design's gains."""

    height: Array
    mass: Array
    inertia: Array
    com_height: Array
    half_depth: Array
    half_width: Array
    tau_max: Array
    tau_max_side: Array
    leg_force_max: Array
    yaw_torque_max: Array
    push_threshold_ns: Array
    stagger_ratio: Array
    recover_ratio: Array
    recover_hold_s: Array
    fall_ratio: Array
    ground_tilt_deg: Array
    still_speed: Array
    still_rate: Array
    still_hold_s: Array
    lie_duration_s: Array
    getup_duration_s: Array
    getup_torque_max: Array
    getup_frequency: Array
    upright_tilt_deg: Array
    brake_rate: Array
    walk_speed: Array
    flee_speed: Array
    approach_distance: Array
    personal_space: Array
    flee_duration_s: Array
    wander_pause_s: Array
    stage_margin: Array
    pivot_damping: Array
    pivot_s: Array
    after_fall_s: Array

    SPEC_FIELDS: ClassVar[tuple[str, ...]] = ()  # filled below from the annotations

    def __init__(self, specs: list[CharacterSpec], designs: list[BalanceDesign]) -> None:
        for name in self.SPEC_FIELDS:
            setattr(self, name, np.array([float(getattr(s, name)) for s in specs], dtype=np.float64))
        self.k_front = np.array([[d.front.k_force, d.front.k_torque] for d in designs]).reshape(-1, 2, 3)
        self.k_side = np.array([[d.side.k_force, d.side.k_torque] for d in designs]).reshape(-1, 2, 3)
        self.xi_front = np.array([d.front.xi_max for d in designs])
        self.xi_side = np.array([d.side.xi_max for d in designs])
        self.omega = np.array([d.front.omega for d in designs])
        self.yaw_kp = np.array([d.yaw_kp for d in designs])
        self.yaw_kd = np.array([d.yaw_kd for d in designs])
        self.ground_tilt = np.radians(self.ground_tilt_deg)
        self.upright_tilt = np.radians(self.upright_tilt_deg)
        # gains as columns (f_F row and τ row of each plane; columns θ, θ̇, v error) and reciprocals
        self.kf_force = tuple(self.k_front[:, 0, j].copy() for j in range(3))
        self.kf_torque = tuple(self.k_front[:, 1, j].copy() for j in range(3))
        self.ks_force = tuple(self.k_side[:, 0, j].copy() for j in range(3))
        self.ks_torque = tuple(self.k_side[:, 1, j].copy() for j in range(3))
        self.inv_mass = 1.0 / self.mass if self.mass.size else self.mass
        self.inv_inertia = 1.0 / self.inertia if self.inertia.size else self.inertia
        self.inv_tau_max = 1.0 / self.tau_max if self.tau_max.size else self.tau_max
        self.inv_tau_max_side = 1.0 / self.tau_max_side if self.tau_max_side.size else self.tau_max_side
        self.inv_yaw_torque_max = 1.0 / self.yaw_torque_max if self.yaw_torque_max.size else self.yaw_torque_max
        self.pivot_gain = self.inertia * self.pivot_damping
        # speed error that alone asks for SPEED_ERROR_SHARE of the torque bound (``sim.mitake.control``)
        self.speed_error_front = SPEED_ERROR_SHARE * self.tau_max / np.maximum(np.abs(self.kf_torque[2]), 1e-9)
        self.speed_error_side = SPEED_ERROR_SHARE * self.tau_max_side / np.maximum(np.abs(self.ks_torque[2]), 1e-9)
        self.walkable: dict[object, tuple[Array, Array, Array, Array]] = {}  # by stage (sim.mitake.ai.walkable)
        self.top_speed = np.maximum(self.walk_speed, self.flee_speed)
        self.min_stagger_ratio = float(self.stagger_ratio.min()) if self.stagger_ratio.size else 0.0


Columns.SPEC_FIELDS = tuple(k for k in Columns.__annotations__ if k != "SPEC_FIELDS")

# name -> (trailing shape, fill value, dtype) of every per-character state array
_STATE_ARRAYS: dict[str, tuple[tuple[int, ...], float, type]] = {
    "pos": ((3,), 0.0, np.float64),
    "quat": ((4,), 0.0, np.float64),
    "vel": ((3,), 0.0, np.float64),
    "ang": ((3,), 0.0, np.float64),
    "rate_x": ((), 0.0, np.float64),
    "rate_z": ((), 0.0, np.float64),
    "normal": ((), 0.0, np.float64),
    "vz_after": ((), math.nan, np.float64),  # vertical velocity right after the last write (nan: unknown)
    "load": ((), 0.0, np.float64),
    "state": ((), WALK, np.int64),
    "entered": ((), 0.0, np.float64),
    "since": ((), math.nan, np.float64),  # start of the calm/still stretch being timed (nan: none)
    "face_up": ((), -1, np.int64),  # -1 not lying, 0 face down, 1 face up
    "stand_up_start": ((), 0.0, np.float64),
    "not_upright_since": ((), math.nan, np.float64),
    "fell_at": ((), math.nan, np.float64),  # when the current fall started (nan: not down)
    "pushed_at": ((), -math.inf, np.float64),  # the last control tick in which someone pushed it
    "d_front": ((), 0.0, np.float64),
    "d_side": ((), 0.0, np.float64),
    "contact_force": ((), 0.0, np.float64),
    "peak_torque_ratio": ((), 0.0, np.float64),
    "peak_friction_ratio": ((), 0.0, np.float64),
    "non_finite": ((), 0, np.int64),
    "friction_now": ((), 0.0, np.float64),
    # AI
    "intent": ((), IDLE, np.int64),
    "base_intent": ((), IDLE, np.int64),
    "override_intent": ((), NO_INTENT, np.int64),  # after a fall: this intent until override_until
    "override_until": ((), 0.0, np.float64),
    "heading_goal": ((), 0.0, np.float64),
    "waypoint": ((2,), math.nan, np.float64),
    "waypoint_deadline": ((), 0.0, np.float64),
    "pause_until": ((), 0.0, np.float64),
    "flee_until": ((), 0.0, np.float64),
    "flee_dir": ((2,), 0.0, np.float64),
    "path_index": ((), 0, np.int64),
    "goal_v": ((2,), 0.0, np.float64),
    # control record of the last tick (for checking the bounds)
    "tau_front": ((), 0.0, np.float64),
    "tau_side": ((), 0.0, np.float64),
    "tau_yaw": ((), 0.0, np.float64),
    "friction": ((), 0.0, np.float64),
    "friction_limit": ((), 0.0, np.float64),
}


class Crowd:
    """The characters of one world: names, bodies, specs, constants and state, row by row."""

    pos: Array
    quat: Array
    vel: Array
    ang: Array
    rate_x: Array
    rate_z: Array
    normal: Array
    vz_after: Array
    load: Array
    state: IntArray
    entered: Array
    since: Array
    face_up: IntArray
    stand_up_start: Array
    not_upright_since: Array
    fell_at: Array
    pushed_at: Array
    d_front: Array
    d_side: Array
    contact_force: Array
    peak_torque_ratio: Array
    peak_friction_ratio: Array
    non_finite: IntArray
    friction_now: Array
    intent: IntArray
    base_intent: IntArray
    override_intent: IntArray
    override_until: Array
    heading_goal: Array
    waypoint: Array
    waypoint_deadline: Array
    pause_until: Array
    flee_until: Array
    flee_dir: Array
    path_index: IntArray
    goal_v: Array
    tau_front: Array
    tau_side: Array
    tau_yaw: Array
    friction: Array
    friction_limit: Array

    def __init__(self) -> None:
        self.names: list[str] = []
        self.index: dict[str, int] = {}
        self.bodies: list[int] = []
        self.specs: list[CharacterSpec] = []
        self.designs: list[BalanceDesign] = []
        self.paths: list[Array] = []  # per character: (K, 2) waypoints for "follow"
        self.path_len: IntArray = np.zeros(0, dtype=np.int64)
        self.after_fall: IntArray = np.zeros(0, dtype=np.int64)  # intent code or NO_INTENT
        self._cols = Columns([], [])
        self._path_xy: Array = np.zeros((0, 1, 2))
        self._stale = False  # rows were added since the columns and paths were built
        for name, (shape, fill, dtype) in _STATE_ARRAYS.items():
            setattr(self, name, np.full((0, *shape), fill, dtype=dtype))
        self.frames: Frames = frames(np.zeros((0, 4)))

    def __len__(self) -> int:
        return len(self.names)

    def add(self, name: str, body: int, spec: CharacterSpec, design: BalanceDesign, intent: str,
            path: Array, t: float) -> int:
        """A new row for a character standing still; returns its index."""
        i = len(self.names)
        self.names.append(name)
        self.index[name] = i
        self.bodies.append(body)
        self.specs.append(spec)
        self.designs.append(design)
        self.paths.append(path)
        self._stale = True
        self.path_len = np.append(self.path_len, len(path))
        code = INTENTS.index(intent)
        after = INTENTS.index(spec.after_fall_intent) if spec.after_fall_intent else NO_INTENT
        self.after_fall = np.append(self.after_fall, after)
        for key, (shape, fill, dtype) in _STATE_ARRAYS.items():
            setattr(self, key, np.concatenate([getattr(self, key), np.full((1, *shape), fill, dtype=dtype)]))
        self.intent[i] = self.base_intent[i] = code
        self.entered[i] = t
        return i

    def _build(self) -> None:
        self._cols = Columns(self.specs, self.designs)
        longest = max([1, *(len(q) for q in self.paths)])
        self._path_xy = np.zeros((len(self.paths), longest, 2))
        for k, q in enumerate(self.paths):
            self._path_xy[k, :len(q)] = q
        self._stale = False

    @property
    def cols(self) -> Columns:
        """Per-character constants (rebuilt once after characters were added)."""
        if self._stale:
            self._build()
        return self._cols

    @property
    def path_xy(self) -> Array:
        """(N, K, 2) every character's "follow" waypoints, padded (``path_len`` says how many are real)."""
        if self._stale:
            self._build()
        return self._path_xy

    def place(self, row: int, pos: tuple[float, float, float], quat: tuple[float, float, float, float],
              mass: float, gravity: float) -> None:
        """A body was just put at ``pos``/``quat``, still, standing on the floor: set its row."""
        self.pos[row], self.quat[row] = pos, quat
        self.vel[row] = self.ang[row] = 0.0
        self.vz_after[row] = math.nan
        self.normal[row] = mass * gravity
        self.frames = frames(self.quat)
        self.rate_x, self.rate_z = tilt_rates(self.frames, self.ang)

    def sense(self, pos: Array, quat: Array, vel: Array, ang: Array, tick_dt: float, gravity: float) -> None:
        """Take a new readout of every body; derive frames, tilt rates and the support force.

        The support force f_N is the vertical momentum balance of the last tick,
        M (Δv_z / dt + g) ≥ 0: what the floor (and anything else under the body) held up. Upright, the
        only vertical forces are gravity and the floor, so this is the floor's normal force; in the air
        it is 0, so the legs can neither push nor turn.
        """
        dvz = np.where(np.isfinite(self.vz_after), vel[:, 2] - self.vz_after, 0.0)
        self.normal = np.maximum(0.0, self.cols.mass * (dvz / tick_dt + gravity))
        self.pos, self.quat, self.vel, self.ang = pos, quat, vel, ang
        self.frames = frames(quat)
        self.rate_x, self.rate_z = tilt_rates(self.frames, ang)

    def balance_load(self) -> Array:
        """Both planes' |ξ|/ξ_max, root-sum-square (``sim.mitake.balance``); ∞ when tilted past horizontal."""
        f, c = self.frames, self.cols
        front = np.abs(f.tilt_x + self.rate_x / c.omega) / c.xi_front
        side = np.abs(f.tilt_z + self.rate_z / c.omega) / c.xi_side
        out: Array = np.where(f.tilt < 0.5 * math.pi, np.hypot(front, side), math.inf)
        return out

    def upright(self) -> BoolArray:
        out: BoolArray = self.state <= STAGGER
        return out
