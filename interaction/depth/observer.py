"""The depth observer: depth frames of people → contactors in stage metres.

Per frame: the depth image (sampled down to ``work_width``) → points through the frame's intrinsics
and the :class:`DepthCalibration` (stage metres, floor at z = 0), cropped to the stage volume and
lifted off the floor by ``floor_clearance_m``. The points are binned on a top-down floor grid;
cells occupied while the first ``learn_frames`` frames were learned are furniture; connected cells
holding something taller than ``min_height_m`` are people (two close together split by 2-means),
tracked with stable ids (:class:`interaction.people.PeopleTracker`).

Each person gives a head (the top), four stacked "body" hull spheres, and hands and feet
(:mod:`interaction.depth.parts`, followed by :class:`interaction.depth.limb_tracks.LimbTracker`).
``people`` counts those seen plus those hidden behind someone seen (:mod:`interaction.depth.hidden_people`).
Positions are the frame's own measurement (no lag). Velocities (m/s): a hand's or foot's is the
frame-to-frame one, claimed only on steady tracks; the head's and the hull's an alpha-beta filter per
track (``alpha``, ``beta``). Work arrays are kept from frame to frame.

Latency, cost and velocity figures, and what was tried: docs/notes/depth.md.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import cv2
import numpy as np

from interaction.depth.calibration import DepthCalibration
from interaction.depth.config import DepthObserverConfig
from interaction.depth.fine_depth import FineDepth
from interaction.depth.hidden_people import HiddenPeople
from interaction.depth.limb_tracks import LimbTracker
from interaction.depth.parts import find_feet, find_hands
from interaction.depth.shoe_model import shipped_shoe_model
from interaction.people import PeopleTracker, split_side_by_side
from interaction.types import BodyObservation, Contactor
from sensors.base import DepthImage, Frame

__all__ = ["DepthCalibration", "DepthObserver", "DepthObserverConfig"]


log = logging.getLogger("interaction.depth")
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
        self._size_checked: tuple[int, int] | None = None  # the frame size last checked against the calibration
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
        if p.size != self._size_checked:
            note = self._cal.fits_image(p.size)  # another aspect ratio raises (the frame is refused)
            self._size_checked = p.size
            if note is not None:
                log.warning("%s", note)
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
