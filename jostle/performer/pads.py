"""Virtual force pads on the stage floor: what a board of load cells under the performance would send.

Each pad is a rectangle on the floor (:class:`PadPlacement`). The force model (:func:`pad_forces`)
is a pure function of the people's poses:

- Every person has contact points: three under each shoe (heel, ball, toe), each hand, each knee,
  the pelvis and the chest, each with its clearance (how far its surface is below the joint). A
  point whose surface is within 2.5 cm of the floor touches it, fully at 0 (a linear ramp).
- The person's weight, plus what accelerates the body up or down, m·(g + a_z) (a_z: the pelvis's
  vertical acceleration), is shared among the touching points in proportion to their contact and
  inversely to their horizontal distance from the pelvis: one foot down carries everything; in
  double support the foot nearer under the body carries more.
- A hand that comes down onto the floor strikes it: an impulse J = m_hand·v (v its downward
  speed, m_hand = 2 kg·size²) spread as a 30 ms half-sine, on top of its share of the weight.

A pad reads the sum of the loads of the points over it. :class:`PerformerPads` samples that at the
board's rate and reports raw counts as a board would (newtons / ``newtons_per_count`` plus
Gaussian noise, on top of ``zero_counts``) and the calibrated newtons from those counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jostle.performer.choreography import SegmentPath, StagePose, mocap_to_stage, stage_joint_frames
from jostle.performer.config import check_number, check_whole
from jostle.performer.scene import Performance
from jostle.performer.timeline import TimelineSensor
from sensors.base import PadSample, SensorSpec
from sensors.clock import Clock
from sensors.untrusted import UntrustedInput, load_toml
from sensors.untrusted.limits import CONFIG_TOML as PAD_LAYOUT
from sim.motion import quaternion as quat
from sim.motion.mocap import HUMANOID

GRAVITY = 9.80665
TOUCH_M = 0.025  # a surface this close to the floor starts to touch it
ACCEL_STEP_S = 1.0 / 20.0  # the pelvis's acceleration: central second difference over ±this
STRIKE_S = 0.03
HAND_MASS_AT_SCALE_1_KG = 2.0
_SOLE = [(-0.07, -0.0525, 0.0), (0.05, -0.0525, 0.0), (0.17, -0.0525, 0.0)]  # under the shoe, ankle frame


def _names(*names: str) -> list[int]:
    return [HUMANOID.names.index(n) for n in names]


# contact points that are joints: (bone index, clearance of the body surface below it at scale 1)
_JOINT_POINTS = list(zip(_names("right_wrist", "left_wrist", "right_knee", "left_knee", "root", "chest"),
                         (0.06, 0.06, 0.06, 0.06, 0.12, 0.13), strict=True))
_ANKLES = _names("right_ankle", "left_ankle")
_HANDS = (6, 7)  # positions of the wrists among the contact points: 6 sole points come first
BLOCK = 32  # pad samples computed together


@dataclass(frozen=True)
class PadPlacement:
    """One pad: a ``width`` (along x) × ``depth`` (along y) rectangle on the floor centred at (x, y)."""

    x: float
    y: float
    width: float = 0.6
    depth: float = 0.6

    def __post_init__(self) -> None:
        check_number("x", self.x, -50.0, 50.0)
        check_number("y", self.y, -50.0, 50.0)
        check_number("width", self.width, 0.05, 10.0)
        check_number("depth", self.depth, 0.05, 10.0)

    def covers(self, xy: np.ndarray) -> np.ndarray:
        """True for the stage points (..., ≥2) whose (x, y) lie on the pad."""
        return (np.abs(xy[..., 0] - self.x) <= self.width / 2) & (np.abs(xy[..., 1] - self.y) <= self.depth / 2)


@dataclass(frozen=True)
class PadBoardConfig:
    """The board the pads are wired to: its sampling rate and how it turns force into counts."""

    rate_hz: float = 100.0
    newtons_per_count: float = 0.25
    noise_counts: float = 1.5
    zero_counts: int = 0

    def __post_init__(self) -> None:
        check_number("rate_hz", self.rate_hz, 0.0, 5000.0, open_lo=True)
        check_number("newtons_per_count", self.newtons_per_count, 0.0, 1000.0, open_lo=True)
        check_number("noise_counts", self.noise_counts, 0.0, 1000.0)
        check_whole("zero_counts", self.zero_counts, -(2**31), 2**31 - 1)


@dataclass(frozen=True)
class PadLayout:
    board: PadBoardConfig
    pads: tuple[PadPlacement, ...]

    def __post_init__(self) -> None:
        if not self.pads:
            raise ValueError("pad: expected at least one [[pad]] table")


def default_pad_layout() -> PadLayout:
    """Six 0.6 m pads: x at −1.2, 0 and 1.2 m, y at ±0.3 m (side by side: a walker along y = 0 steps on both rows)."""
    return PadLayout(PadBoardConfig(), tuple(PadPlacement(x, y) for y in (-0.3, 0.3) for x in (-1.2, 0.0, 1.2)))


def load_pad_layout(path: Path) -> PadLayout:
    """A layout file: board keys at the top (``rate_hz``, ``newtons_per_count``, ``noise_counts``,
    ``zero_counts``), then one ``[[pad]]`` table per pad (``x``, ``y``, ``width``, ``depth``)."""
    from jostle.configtree import ConfigError, build

    try:
        table = load_toml(Path(path), PAD_LAYOUT, "pad layout")
    except UntrustedInput as e:
        raise ConfigError(f"{path}: cannot read the pad layout ({e.problem})") from None
    pads = table.pop("pad", [])
    if not isinstance(pads, list) or not pads:
        raise ConfigError(f"{path}: pad: expected one or more [[pad]] tables with x and y")
    board = build(PadBoardConfig, table, source=str(path), key="", base_dir=Path(path).parent)
    placed = tuple(build(PadPlacement, p, source=str(path), key=f"pad[{i}]", base_dir=Path(path).parent)
                   for i, p in enumerate(pads))
    return PadLayout(board, placed)


def contact_points(poses: list[StagePose]) -> tuple[np.ndarray, np.ndarray]:
    """Stage positions (N, 12, 3) of the contact points of each pose (6 sole points, then wrists,
    knees, pelvis, chest) and the height (N, 12) of the body's surface under each above the floor."""
    pos, rot = stage_joint_frames(poses)
    scales = np.array([p.scale for p in poses])
    sole = np.array(_SOLE)
    points = []
    for a in _ANKLES:
        offsets = quat.rotate(rot[:, a, None, :], sole[None, :, :])  # (N, 3, 3) Y-up, unscaled
        points.append(pos[:, a, None, :] + mocap_to_stage(offsets) * scales[:, None, None])
    joints = pos[:, [i for i, _ in _JOINT_POINTS], :]
    clearance = np.concatenate([np.zeros(6), [c for _, c in _JOINT_POINTS]])
    all_points = np.concatenate([*points, joints], axis=1)
    heights = all_points[..., 2] - clearance[None, :] * scales[:, None]
    return all_points, heights


def touch(heights: np.ndarray) -> np.ndarray:
    """How much each point touches the floor: 0 at ``TOUCH_M`` and above, 1 at 0 and below."""
    return np.clip((TOUCH_M - heights) / TOUCH_M, 0.0, 1.0)


def grid_loads(path: SegmentPath, t0: float, dt: float, n: int, mass_kg: float) -> tuple[np.ndarray, np.ndarray]:
    """One person's contact points (n, 12, 3) and the vertical force (n, 12) in newtons each presses
    on the floor at the times t0 + j·dt, j < n (zeros while the person is not on the stage).

    The poses are sampled once on the grid, extended on both sides by the acceleration's step (at
    least 50 ms, so a hand's landing up to ``STRIKE_S`` before t0 is seen too), and the kinematics
    run once for all of them.
    """
    m = max(1, round(ACCEL_STEP_S / dt))
    h = m * dt
    times = [t0 + j * dt for j in range(-m, n + m)]
    poses = [path.pose(t) for t in times]
    present = [i for i, pose in enumerate(poses) if pose is not None]
    points = np.zeros((len(times), 12, 3))
    heights = np.full((len(times), 12), np.inf)
    if present:
        points[present], heights[present] = contact_points([p for p in poses if p is not None])
    c = touch(heights)
    loads = np.zeros((n, 12))
    strikes = HandStrikes(path, times, heights)
    for j in range(n):
        e = j + m
        pose, before, after = poses[e], poses[e - m], poses[e + m]
        if pose is None or c[e].sum() <= 0:
            continue
        accel = 0.0
        if before is not None and after is not None:
            accel = (float(before.position[2]) - 2 * float(pose.position[2]) + float(after.position[2])) / h**2
        weight = max(mass_kg * (GRAVITY + accel), 0.0)
        distance = np.hypot(points[e, :, 0] - pose.position[0], points[e, :, 1] - pose.position[1])
        w = c[e] / (0.05 + distance)
        loads[j] = weight * w / w.sum()
        for hand in _HANDS:
            if c[e, hand] > 0:
                loads[j, hand] += strikes.force(e, hand)
    return points[m : m + n], loads


def point_loads(path: SegmentPath, tau: float, mass_kg: float) -> tuple[np.ndarray, np.ndarray]:
    """One person's contact points (12, 3) and their loads (12,) at tau (see :func:`grid_loads`)."""
    points, loads = grid_loads(path, tau, ACCEL_STEP_S, 1, mass_kg)
    return points[0], loads[0]


class HandStrikes:
    """The impulse part of the hands' forces on a grid of times: a half-sine of ``STRIKE_S`` from the
    moment a hand touched the floor, of area J = m_hand·v (v: its downward speed then). The moment
    is found between two grid times by bisection, so it does not depend on the grid."""

    def __init__(self, path: SegmentPath, times: list[float], heights: np.ndarray) -> None:
        self.path = path
        self.times = times
        self.heights = heights
        self._landings: dict[tuple[int, int], tuple[float, float]] = {}  # (hand, grid index) → (time, J)

    def force(self, e: int, hand: int) -> float:
        """The strike force of ``hand`` at grid index e (the hand touches there)."""
        touching = self.heights[:, hand] < TOUCH_M
        i = e
        while i > 0 and touching[i - 1]:
            i -= 1
            if self.times[e] - self.times[i] > STRIKE_S:
                return 0.0  # it has been down longer than a strike lasts
        if i == 0:
            return 0.0  # down since before the grid's history: no landing seen
        key = (hand, i)
        if key not in self._landings:
            self._landings[key] = self._landing(hand, self.times[i - 1], self.times[i])
        moment, impulse = self._landings[key]
        since = self.times[e] - moment
        if not 0.0 <= since < STRIKE_S:
            return 0.0
        return float(math.pi * impulse / (2 * STRIKE_S) * math.sin(math.pi * since / STRIKE_S))

    def _height(self, hand: int, t: float) -> float:
        pose = self.path.pose(t)
        return math.inf if pose is None else float(contact_points([pose])[1][0, hand])

    def _landing(self, hand: int, lo: float, hi: float) -> tuple[float, float]:
        while hi - lo > 1e-5:
            mid = 0.5 * (lo + hi)
            if self._height(hand, mid) < TOUCH_M:
                hi = mid
            else:
                lo = mid
        step = 0.004
        drop = self._height(hand, hi - step) - self._height(hand, hi)
        speed = max(drop / step, 0.0) if math.isfinite(drop) else 0.0
        pose = self.path.pose(hi)
        scale = pose.scale if pose is not None else 1.0
        return hi, HAND_MASS_AT_SCALE_1_KG * scale**2 * speed


def pad_forces(performance: Performance, layout: PadLayout, tau: float) -> np.ndarray:
    """The true vertical force (newtons) on every pad at performance time tau."""
    return grid_pad_forces(performance, layout, tau, ACCEL_STEP_S, 1)[0]


def grid_pad_forces(performance: Performance, layout: PadLayout, t0: float, dt: float, n: int) -> np.ndarray:
    """The true force (n, pads) on every pad at the times t0 + j·dt, j < n."""
    forces = np.zeros((n, len(layout.pads)))
    for person in performance.cast:
        points, loads = grid_loads(person.path, t0, dt, n, person.plan.mass_kg)
        if not loads.any():
            continue
        for i, pad in enumerate(layout.pads):
            forces[:, i] += np.where(pad.covers(points), loads, 0.0).sum(axis=1)
    return forces


class PerformerPads(TimelineSensor):
    """A board of force pads under the performance, sampled at ``layout.board.rate_hz``."""

    uses_puppets = False  # forces come from the poses alone: no pybullet needed

    def __init__(self, performance: Performance, layout: PadLayout, clock: Clock, name: str = "pads") -> None:
        super().__init__(performance, clock, name, layout.board.rate_hz)
        self.layout = layout
        self._block = (-1, np.zeros((0, len(layout.pads))))

    @property
    def spec(self) -> SensorSpec:
        return SensorSpec(self.name, "pads", self.rate_hz, pads=len(self.layout.pads))

    def forces(self, t: float) -> np.ndarray:
        """The true force on every pad at loop-clock time t (no noise, no rounding)."""
        return pad_forces(self.performance, self.layout, t - self.t_open)

    def _on_open(self) -> None:
        self._block = (-1, np.zeros((0, len(self.layout.pads))))

    def _payload(self, k: int, tau: float) -> PadSample:
        board = self.layout.board
        first = k - k % BLOCK
        if self._block[0] != first:  # whole blocks at fixed places: the same numbers however it is read
            self._block = (first, grid_pad_forces(self.performance, self.layout, first / self.rate_hz,
                                                  1.0 / self.rate_hz, BLOCK))
        forces = self._block[1][k - first]
        rng = np.random.default_rng([self.performance.config.seed, 21, k])
        counts = forces / board.newtons_per_count + rng.standard_normal(len(forces)) * board.noise_counts
        raw = np.rint(counts).astype(np.int64) + board.zero_counts
        newtons = (raw - board.zero_counts) * board.newtons_per_count
        return PadSample(tuple(float(v) for v in newtons), tuple(int(v) for v in raw))
