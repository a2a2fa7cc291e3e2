"""The depth observer: depth frames of people → contactors in stage metres.

Per frame: the depth image (sampled down to ``work_width``) → points with the frame's own
intrinsics → stage metres through the :class:`DepthCalibration` (floor at z = 0) → cropped to the
stage volume and lifted off the floor by ``floor_clearance_m``. The points are binned on a
top-down floor grid; cells that were occupied while the first ``learn_frames`` frames were
learned (furniture) are left out; connected cells holding something taller than
``min_height_m`` are people (a blob of two people close together is split by 2-means), tracked
with stable ids (:class:`interaction.people.PeopleTracker`: nearest to where each is predicted;
someone hidden for a while is found again within twice ``match_distance_m``). Only points higher
than ``body_clearance_m`` find people (the floor's stereo noise stays below it); the other points
within a cell or two of a person's cells (feet, an arm's sparse end) are given to that person.

Each person gives a head (the top), a coarse hull of four stacked "body" spheres as wide as their band of the
body, and hands and feet (:mod:`interaction.depth_parts`): *found* on the sampled points, *measured* on every
pixel of the full image near them, moved from the surface seen back to the middle of the part. A hand is only
reported when it is an arm's length out from its shoulder and clear of the torso (and the head) and of the legs,
and not where the arm goes on behind something nearer (then what is seen is the forearm); feet are the points
low over the floor under the shins. Hands and feet are followed by :class:`interaction.limb_tracks.LimbTracker`
(hands reported from their second frame on, feet from their first; velocity claimed only when steady).

People: ``people`` counts those seen plus those hidden: someone seen in 5 frames or more who
vanished less than ``hidden_memory_s`` ago next to (``hidden_near_m``) someone still seen is
behind or merged with them, and still counted (with no contactors of their own) — unless a track born
about then is there, the same person under a new id (``interaction.hidden_people``).

Latency: a contactor's position is the frame's own measurement (no filtering, no lag). A hand's
or foot's velocity is the frame-to-frame one (half a frame behind), claimed from its third frame;
the head's and the hull's are an alpha-beta filter per track (α = 0.6, β = 0.4: 40 % of a sudden
change of velocity on the first frame, 80 % on the second, 104 % on the third, at most 12 %
overshoot), which follows a constant velocity with no lag. At the OAK's 30 fps most of a shove is
felt within ~2 frames (≈ 67 ms) after it shows in the depth; at 15 fps twice that. Processing
itself (frame in → contactors out) takes ≈ 3 ms of CPU per 640×400 frame on average with 1–4
people on this machine, 0.15 ms a foot of it the shoe model's (``jostle bench interaction``: depth_fps
336, latency_ms_p99 7.7 ms; no frame builds whole-image tables except the first of an image size,
≈ 1 ms; work arrays are kept from frame to frame).

A velocity's direction is limited by the frame rate as much as by the noise: on the virtual
performer at 15 fps, for hands (feet) moving faster than 0.5 m/s, the frame-to-frame step of their
exact centres is off the true velocity by p50 8° (12°), p95 34° (51°) — a swing turns and stops
within a frame — and the step of the measured positions by p95 47° (70°); at 30 fps the exact
centres' p95 is 29° (39°). Hence velocities are claimed only on steady tracks: a track that followed
its prediction for 3 frames and whose last two steps turn less than 20° (``limb_steady_frames``,
``limb_consistent_deg``). On the performer (``jostle bench interaction``, seeds 0 and 100) that claims
a velocity on 144–160 of the ≈ 650 contactors at a limb moving over 0.5 m/s, p95 28° off; the exact
centres' steps between the same frames are off by p95 25–29° there, 47–49° over all fast limbs
(``velocity_direction_error_deg_p95_sampled_truth``). A 15° turn claimed ≈ 115 at 27°; 2 frames, ≈ 200 at 28–32°.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from interaction.depth_calibration import DepthCalibration
from interaction.depth_parts import FineDepth, find_feet, find_hands
from interaction.hidden_people import HiddenPeople
from interaction.limb_tracks import LimbTracker
from interaction.people import PeopleTracker, split_side_by_side
from interaction.shoe_model import shipped_shoe_model
from interaction.types import BodyObservation, Contactor
from sensors.base import DepthImage, Frame

__all__ = ["DepthCalibration", "DepthObserver", "DepthObserverConfig"]


def _check(name: str, value: object, lo: float, hi: float) -> None:
    if not isinstance(value, int | float) or isinstance(value, bool) or not lo <= value <= hi:
        raise ValueError(f"{name}: expected a number {lo}..{hi}, got {value!r}")


@dataclass(frozen=True)
class DepthObserverConfig:
    """How the depth observer finds people. Distances in stage metres."""

    work_width: int = 160  # depth pixels across the sampled image (the frame's width when smaller)
    stage_x: tuple[float, ...] = (-3.5, 3.5)  # the stage volume: x range
    stage_y: tuple[float, ...] = (-2.0, 2.2)  # y range
    max_height_m: float = 2.4  # top of the volume
    floor_clearance_m: float = 0.03  # points nearer the floor than this are floor
    body_clearance_m: float = 0.15  # only points higher than this find people (the rest: their feet)
    cell_m: float = 0.05  # the top-down grid's cell size
    min_height_m: float = 0.9  # a person reaches at least this high
    min_points: int = 60  # … and holds at least this many points (at the work size)
    max_people: int = 8
    side_by_side_m: float = 0.4  # a blob whose two halves' middles are this far apart is two people
    match_distance_m: float = 0.6  # a person moves less than this between frames
    track_memory_frames: int = 30
    hidden_memory_s: float = 1.0  # a person unseen this long, near someone seen, is still counted (hidden)
    hidden_near_m: float = 0.7
    learn_frames: int = 5  # first frames: what is on the stage then is furniture
    hand_band_low: float = 0.5  # hands are looked for above this fraction of the person's height
    min_arm_reach: float = 0.27  # … this far from the shoulders at least (a fraction of the height)
    min_hand_reach_m: float = 0.2  # a hand is this far out from the torso's axis (nearer: not told from it)
    alpha: float = 0.6  # the velocity filter's gains
    beta: float = 0.4
    limb_gate_m: float = 0.3  # a hand (foot) moves less than this from where its track predicts it
    limb_steady_m: float = 0.1  # … and its velocity is trusted after it stays this close for:
    limb_steady_frames: int = 3
    limb_consistent_deg: float = 20.0  # … and claimed when its last two steps turn less than this
    limb_min_speed: float = 0.5  # … and are faster than this (m/s)
    limb_confirm_frames: int = 2  # a hand is reported once found in this many frames in a row
    foot_confirm_frames: int = 1  # … a foot in this many (its first frame's error is no larger: no confirming)
    limb_memory_frames: int = 3  # a track not found for longer is forgotten
    shoe_model: bool = True  # feet corrected by the shipped shoe model (interaction.shoe_model); false: rules only

    def __post_init__(self) -> None:
        if not isinstance(self.work_width, int) or not 16 <= self.work_width <= 4096:
            raise ValueError(f"work_width: expected a whole number 16..4096, got {self.work_width!r}")
        for name in ("stage_x", "stage_y"):
            r = getattr(self, name)
            if not (isinstance(r, tuple) and len(r) == 2 and all(isinstance(v, int | float) for v in r) and r[0] < r[1]):
                raise ValueError(f"{name}: expected [low, high] with low < high, got {r!r}")
        _check("max_height_m", self.max_height_m, 0.5, 5.0)
        _check("floor_clearance_m", self.floor_clearance_m, 0.0, 0.5)
        _check("body_clearance_m", self.body_clearance_m, 0.0, 1.0)
        _check("cell_m", self.cell_m, 0.01, 0.5)
        _check("min_height_m", self.min_height_m, 0.1, 3.0)
        for name, hi in (("min_points", 100000), ("max_people", 64), ("track_memory_frames", 1000), ("learn_frames", 1000),
                         ("limb_steady_frames", 100), ("limb_confirm_frames", 100), ("foot_confirm_frames", 100),
                         ("limb_memory_frames", 1000)):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not 0 <= v <= hi:
                raise ValueError(f"{name}: expected a whole number 0..{hi}, got {v!r}")
        _check("side_by_side_m", self.side_by_side_m, 0.2, 3.0)
        _check("match_distance_m", self.match_distance_m, 0.01, 10.0)
        _check("hidden_memory_s", self.hidden_memory_s, 0.0, 60.0)
        _check("hidden_near_m", self.hidden_near_m, 0.0, 10.0)
        _check("hand_band_low", self.hand_band_low, 0.0, 0.9)
        _check("min_arm_reach", self.min_arm_reach, 0.0, 1.0)
        _check("min_hand_reach_m", self.min_hand_reach_m, 0.0, 1.0)
        _check("alpha", self.alpha, 0.01, 1.0)
        _check("beta", self.beta, 0.0, 2.0)
        _check("limb_gate_m", self.limb_gate_m, 0.01, 5.0)
        _check("limb_steady_m", self.limb_steady_m, 0.0, 5.0)
        _check("limb_consistent_deg", self.limb_consistent_deg, 0.0, 180.0)
        _check("limb_min_speed", self.limb_min_speed, 0.0, 10.0)
        if not isinstance(self.shoe_model, bool):
            raise ValueError(f"shoe_model: expected true or false, got {self.shoe_model!r}")


_KERNEL5 = np.ones((5, 5), np.uint8)
_LIMBS = {"hand": 0.07, "foot": 0.08}  # the parts followed by LimbTracker, and their contactors' radii


@dataclass
class _Track:
    position: np.ndarray
    velocity: np.ndarray
    t: float


class DepthObserver:
    """Turns depth frames into a :class:`BodyObservation` of spheres (``half_depth == 0``)."""

    def __init__(self, config: DepthObserverConfig, calibration: DepthCalibration) -> None:
        self._cfg = config
        self._cal = calibration
        self._rays: tuple[tuple[int, int, int, tuple[float, ...]], np.ndarray] | None = None
        self._arrays: _SampledArrays | None = None  # the per-frame work arrays, made by the first frame
        cfg = config
        self._grid = (math.ceil((cfg.stage_y[1] - cfg.stage_y[0]) / cfg.cell_m),
                      math.ceil((cfg.stage_x[1] - cfg.stage_x[0]) / cfg.cell_m))  # (rows: y, cols: x)
        self._learned = 0
        self._static_count = np.zeros(self._grid, dtype=np.int32)
        # the floor grid's per-frame arrays, written into every frame: the occupied cells, closed, labelled
        self._occupied = np.empty(self._grid, dtype=bool)
        self._closed = np.empty(self._grid, dtype=np.uint8)
        self._labels = np.empty(self._grid, dtype=np.int32)
        self._labels16 = np.empty(self._grid, dtype=np.uint16)
        self._grown = np.empty(self._grid, dtype=np.uint16)
        self._static: np.ndarray | None = None
        self._tracker = PeopleTracker(cfg.match_distance_m, cfg.track_memory_frames)
        self._tracks: dict[tuple[int, str], _Track] = {}
        self._points: np.ndarray = np.zeros((0, 3))
        self._fine = FineDepth(calibration)
        self._feet_seen: list[np.ndarray] = []  # the last person's feet as measured on their points seen
        self._shoes = shipped_shoe_model() if config.shoe_model else None
        # a list here gets every foot's (features, position before the shoe model): jostle.bench.shoe_model_fit
        self.shoes_seen: list[tuple[np.ndarray, np.ndarray]] | None = None
        self._hidden = HiddenPeople(config.hidden_memory_s, config.hidden_near_m,
                                    (float(calibration.translation[0]), float(calibration.translation[1])))
        self._limbs = LimbTracker(gate_m=cfg.limb_gate_m, steady_m=cfg.limb_steady_m,
                                  confirm_frames=cfg.limb_confirm_frames, steady_frames=cfg.limb_steady_frames,
                                  memory_frames=cfg.limb_memory_frames, consistent_deg=cfg.limb_consistent_deg,
                                  min_speed=cfg.limb_min_speed, confirm_by_part={"foot": cfg.foot_confirm_frames})

    @property
    def config(self) -> DepthObserverConfig:
        return self._cfg

    @property
    def calibration(self) -> DepthCalibration:
        return self._cal

    @property
    def learning(self) -> bool:
        return self._learned < self._cfg.learn_frames

    @property
    def points(self) -> np.ndarray:
        """The last frame's stage points inside the volume (N, 3) (for display and tests)."""
        return self._points

    def relearn(self) -> None:
        """Forget the furniture and the people; the next ``learn_frames`` frames learn the empty stage."""
        self._learned = 0
        self._static_count[:] = 0
        self._static = None
        self._tracker.clear()
        self._hidden.clear()
        self._tracks.clear()
        self._limbs.clear()

    # ------------------------------------------------------------ per frame

    def observe(self, frame: Frame) -> BodyObservation:
        """The people in one depth frame. Raises ValueError on a frame that is not a depth image."""
        p = frame.payload
        if not isinstance(p, DepthImage):
            raise ValueError(f"DepthObserver: frame {frame.seq} from sensor {frame.sensor!r} carries a "
                             f"{frame.kind} payload; expected a depth image")
        cfg = self._cfg
        pts, cell = self._stage_points(p)
        self._fine.set_frame(p)
        self._points = pts
        rows, cols = self._grid
        raised = pts[:, 2] > cfg.body_clearance_m  # clear of the floor's noise
        occupied = self._occupied
        occupied.fill(False)
        occupied.reshape(-1)[cell[raised]] = True  # the cells holding a raised point
        if self.learning:
            self._static_count += occupied
            self._learned += 1
            if not self.learning:
                static = (self._static_count * 2 > self._learned).astype(np.uint8)
                self._static = cv2.dilate(static, np.ones((3, 3), np.uint8)) > 0
            return BodyObservation(t=frame.t)
        grid: np.ndarray = occupied.astype(np.uint8)
        if self._static is not None:
            grid[self._static] = 0
        grid = cv2.morphologyEx(grid, cv2.MORPH_CLOSE, _KERNEL5, dst=self._closed)
        n, labels = cv2.connectedComponents(grid, labels=self._labels, connectivity=8)
        # low points (feet) go to the person whose footprint, grown by a cell or two, they are in
        labels16 = self._labels16
        np.copyto(labels16, labels, casting="unsafe")  # (a grid's blobs are far fewer than 65536)
        grown = cv2.dilate(labels16, _KERNEL5, dst=self._grown)
        own = labels16.reshape(-1)[cell]
        label = np.where(raised & (own > 0), own, grown.reshape(-1)[cell])  # an arm's sparse end: to its body
        order = np.argsort(label, kind="stable")  # 16-bit keys: a radix sort (a quarter of a 32-bit one's time)
        bounds = np.searchsorted(label[order], np.arange(n + 1))
        people: list[np.ndarray] = []
        for k in range(1, n):
            for q in split_side_by_side(pts[order[bounds[k]:bounds[k + 1]]], cfg.side_by_side_m):
                if len(q) >= cfg.min_points and float(q[:, 2].max()) >= cfg.min_height_m:
                    people.append(q)
        people.sort(key=len, reverse=True)
        people = people[: cfg.max_people]
        centres = [(float(q[:, 0].sum()) / len(q), float(q[:, 1].sum()) / len(q)) for q in people]  # the means
        ids = self._tracker.assign(centres)
        hidden = self._hidden.count(ids, centres, self._tracker.predicted(), frame.t)
        contactors: list[Contactor] = []
        seen: set[tuple[int, str]] = set()
        for pid, q in sorted(zip(ids, people, strict=True), key=lambda x: x[0]):
            born = pid in self._tracker.born
            found = self._body(q)
            for part, slot, pos, radius in found:
                if part in _LIMBS:
                    continue
                key = (pid, slot)
                seen.add(key)
                vel = self._velocity(key, pos, frame.t, born)
                contactors.append(Contactor(pid, part, _vec(pos), _vec(vel), radius))
            for part, radius in _LIMBS.items():
                moving = self._feet_seen if part == "foot" else None  # velocities of the feet as measured
                for _, pos, vel in self._limbs.update(pid, part, [f[2] for f in found if f[0] == part], frame.t, born,
                                                      moving):
                    contactors.append(Contactor(pid, part, _vec(pos), _vec(vel), radius))
        for key in [k for k in self._tracks if k not in seen]:
            del self._tracks[key]
        self._limbs.forget_people(set(ids))
        people_now = len(people) + hidden - self._hidden.unconfirmed(ids)
        return BodyObservation(t=frame.t, contactors=tuple(contactors), people=people_now)

    # ------------------------------------------------------------ internals

    def _stage_points(self, p: DepthImage) -> tuple[np.ndarray, np.ndarray]:
        """Stage points (N, 3) of the sampled image's pixels inside the stage volume, and their floor-grid
        cells (N,)."""
        cfg = self._cfg
        h, w = p.depth_mm.shape
        step = max(1, w // cfg.work_width)
        key = (w, h, step, (p.fx, p.fy, p.cx, p.cy))
        if self._rays is None or self._rays[0] != key:
            v, u = np.mgrid[0:h:step, 0:w:step].astype(np.float64)
            cam = np.stack([(u - p.cx) / p.fx, (v - p.cy) / p.fy, np.ones_like(u)], axis=-1)
            rays = (cam @ self._cal.matrix.T).reshape(-1, 3).T  # stage direction per metre of depth
            self._rays = (key, np.ascontiguousarray(rays, dtype=np.float32))
        rays = self._rays[1]
        sampled = p.depth_mm[::step, ::step]
        a = self._arrays
        if a is None or a.z.shape != (sampled.size,):
            a = self._arrays = _SampledArrays(sampled.size)
        z = a.z
        np.copyto(z.reshape(sampled.shape), sampled, casting="unsafe")  # uint16 → float32, exact
        np.multiply(z, np.float32(0.001), out=z)
        c = self._cal.centre.astype(np.float32)
        x, y, up = (np.add(np.multiply(rays[i], z, out=out), c[i], out=out) for i, out in enumerate((a.x, a.y, a.up)))
        rows, cols = self._grid
        for at, low, cell in ((x, cfg.stage_x[0], a.ix), (y, cfg.stage_y[0], a.iy)):  # truncation: fine inside the volume
            np.copyto(cell, np.multiply(np.subtract(at, low, out=a.scratch), 1 / cfg.cell_m, out=a.scratch), casting="unsafe")
        ix, iy, inside, test = a.ix, a.iy, a.inside, a.test
        np.greater(z, 0, out=inside)
        inside &= np.greater(x, cfg.stage_x[0], out=test)
        inside &= np.greater(y, cfg.stage_y[0], out=test)
        inside &= np.less(ix, cols, out=test)
        inside &= np.less(iy, rows, out=test)
        inside &= np.greater(up, cfg.floor_clearance_m, out=test)
        inside &= np.less(up, cfg.max_height_m, out=test)
        keep = np.flatnonzero(inside)
        pts = np.stack([x[keep], y[keep], up[keep]], axis=1).astype(np.float64)
        return pts, (iy[keep] * cols + ix[keep]).astype(np.int64)

    def _body(self, q: np.ndarray) -> list[tuple[str, str, np.ndarray, float]]:
        """One person's contactors: (part, track slot, position, radius)."""
        top = float(q[:, 2].max())
        out: list[tuple[str, str, np.ndarray, float]] = []
        head = q[q[:, 2] > top - 0.15]
        out.append(("head", "head", self._inset(head.sum(axis=0) / len(head), 0.08), 0.12))
        z = q[:, 2]
        torso = q[(z > 0.45 * top) & (z < 0.8 * top), :2]
        axis = torso.sum(axis=0) / len(torso) if len(torso) else q[:, :2].sum(axis=0) / len(q)
        # the hull: stacked spheres, as wide as their band's points spread (RMS) around its middle
        band = np.minimum(np.searchsorted(np.array([0.3 * top, 0.55 * top, 0.8 * top]), z, side="right"), 3)  # digitize
        count = np.bincount(band, minlength=4)
        centre = np.stack([np.bincount(band, q[:, i], minlength=4) for i in (0, 1)], axis=1) / np.maximum(count, 1)[:, None]
        spread = np.bincount(band, np.add.reduce(np.square(q[:, :2] - centre[band]), axis=1), minlength=4)
        radius = np.clip(np.sqrt(spread / np.maximum(count, 1)) * 1.2, 0.08, 0.35)
        mids = (0.15 * top, 0.425 * top, 0.675 * top, 0.9 * top)
        for i in range(4):
            if count[i] >= 5:
                out.append(("body", f"body{i}", np.array([centre[i, 0], centre[i, 1], mids[i]]), float(radius[i])))
        torso_r = float(np.sqrt(spread[2] / max(count[2], 1)))  # the chest band's RMS radius
        cfg = self._cfg
        self._feet_seen = []
        feet = find_feet(q, self._fine, self._feet_seen, self._shoes, self.shoes_seen)
        hands = find_hands(q, top, axis, torso_r, feet, self._fine, band_low=cfg.hand_band_low,
                           min_reach=cfg.min_hand_reach_m, min_arm_reach=cfg.min_arm_reach)
        out.extend(("hand", "hand", h, 0.07) for h in hands)
        out.extend(("foot", "foot", f, 0.08) for f in feet)
        return out

    def _inset(self, point: np.ndarray, distance: float) -> np.ndarray:
        """A surface point moved ``distance`` away from the camera (toward the inside of the body)."""
        ray = point - self._cal.centre
        return np.asarray(point + ray / math.sqrt(float(ray.dot(ray))) * distance, dtype=np.float64)

    def _velocity(self, key: tuple[int, str], pos: np.ndarray, t: float, born: bool) -> np.ndarray:
        """The alpha-beta filtered velocity of one contactor track (zero on its first frame)."""
        track = self._tracks.get(key)
        if track is None or born or t <= track.t:
            self._tracks[key] = _Track(pos.copy(), np.zeros(3), t)
            return np.zeros(3)
        dt = t - track.t
        predicted = track.position + track.velocity * dt
        residual = pos - predicted
        track.position = predicted + self._cfg.alpha * residual
        track.velocity = track.velocity + self._cfg.beta * residual / dt
        track.t = t
        return track.velocity


class _SampledArrays:
    """The work arrays of :meth:`DepthObserver._stage_points` for one sampled image size (n pixels),
    kept between frames: a frame allocates nothing the size of the image but the points it keeps."""

    def __init__(self, n: int) -> None:
        # depth (metres), the stage coordinates, a scratch array; the floor-grid cell column and row; masks
        self.z, self.x, self.y, self.up, self.scratch = (np.empty(n, np.float32) for _ in range(5))
        self.ix, self.iy = np.empty(n, np.int32), np.empty(n, np.int32)
        self.inside, self.test = np.empty(n, bool), np.empty(n, bool)


def _vec(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))
