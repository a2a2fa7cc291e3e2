"""People's keypoints as the pose worker hands them back, turned into hands and feet at a frame's time.

The observer gives :class:`PoseLimbs` each frame's people (:meth:`PoseLimbs.update`); it passes them
to the :class:`~interaction.webcam.pose_worker.PoseWorker` and attaches whatever keypoints came back
to the people still tracked, feeding each limb's 1€ filter at the keypoints' own frame time, so a
limb's velocity is pixels over the time between the frames the keypoints came from, however late
they arrived. :meth:`PoseLimbs.limbs` moves each limb on by that velocity from its keypoints' frame
to the asked time (0 s with ``pose_sync``) and keeps those on the person's silhouette.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from interaction.webcam.config import WebcamObserverConfig
from interaction.webcam.pose import Keypoints, LimbPoint, PoseModel, PoseModelError, PoseTracker
from interaction.webcam.pose_models import LANDMARK_FILE, default_model_dir
from interaction.webcam.pose_worker import PosePerson, PoseResult, PoseWorker

__all__ = ["PoseLimbs"]

log = logging.getLogger("jostle.webcam")


class PoseLimbs:
    """Keypoints, limbs and refresh counts per tracked person, from a pose worker.

    ``limb_filter`` is a :class:`PoseTracker` used only for its limbs' filters (this thread's own;
    the worker's tracker runs the model). Limbs whose keypoints are older than ``max_age_s`` seconds
    are not placed.
    """

    def __init__(self, worker: PoseWorker, limb_filter: PoseTracker, max_age_s: float) -> None:
        self.worker = worker
        self._filter = limb_filter
        self._max_age = max_age_s
        self._tracked: set[int] = set()
        self._keypoints: dict[int, Keypoints] = {}
        self._limbs: dict[int, tuple[float, list[LimbPoint]]] = {}  # person → (keypoints' t, limbs then)
        self._updates: dict[int, int] = {}
        self._focus: np.ndarray | None = None

    @classmethod
    def from_config(cls, config: WebcamObserverConfig) -> PoseLimbs | None:
        """The pose model from the configured folder beside the loop (a worker thread, or inline with
        ``pose_sync``), or None (said once, loudly) when the model cannot be had."""
        folder = Path(config.pose_model_dir).expanduser() if config.pose_model_dir else default_model_dir()
        if not (folder / LANDMARK_FILE).is_file():
            log.warning("webcam observer: pose: no model files in %s (fetch them with `python -m "
                        "interaction.webcam.pose_models`); running silhouette-only, without body keypoints", folder)
            return None
        try:
            model = PoseModel.from_dir(folder)
        except PoseModelError as e:
            log.warning("webcam observer: pose: %s; running silhouette-only, without body keypoints", e)
            return None
        tracker = PoseTracker(model, config.pose_min_score, config.pose_min_visibility)
        worker = PoseWorker(tracker, threaded=not config.pose_sync, cpu_share=config.pose_cpu_share)
        return cls(worker, PoseTracker(model, config.pose_min_score, config.pose_min_visibility), config.pose_max_age_s)

    @property
    def keypoints(self) -> dict[int, Keypoints]:
        return dict(self._keypoints)

    @property
    def updates(self) -> dict[int, int]:
        return dict(self._updates)

    def focus_on(self, points: np.ndarray | None) -> None:
        """Stage points (N, 3) metres (the characters): the people nearest them on the floor (x, y) are
        looked at first; None: the largest first."""
        self._focus = None if points is None or len(points) == 0 else np.asarray(points, np.float64).reshape(-1, 3)

    def update(self, t: float, bgr: np.ndarray, ids: Sequence[int], outlines: Sequence[np.ndarray],
               to_stage: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        """This frame's people (ids and outlines (N, 2) in the frame's pixels; everyone else is
        forgotten) to the worker, ranked (:meth:`people`), and whatever it has found since onto them."""
        self.forget(set(ids))
        self.worker.submit(t, bgr, self.people(ids, outlines, to_stage))
        self._attach(self.worker.take())

    def people(self, ids: Sequence[int], outlines: Sequence[np.ndarray],
               to_stage: Callable[[np.ndarray], np.ndarray] | None = None) -> list[PosePerson]:
        """The people by id, ranked: metres on the floor from their box's middle (``to_stage``: pixels
        → stage metres) to the nearest focus point, or without focus minus their box's area."""
        people: list[PosePerson] = []
        for pid, outline in sorted(zip(ids, outlines, strict=True), key=lambda p: p[0]):
            lo, hi = outline.min(axis=0), outline.max(axis=0)
            rank = -float((hi - lo).prod())  # the largest box first
            if self._focus is not None and to_stage is not None:
                at = to_stage(0.5 * (lo + hi).reshape(1, 2))[0]
                rank = float(np.hypot(self._focus[:, 0] - at[0], self._focus[:, 1] - at[1]).min())
            people.append(PosePerson(pid, outline, rank))
        return people

    def limbs(self, person: int, t: float, accept: np.ndarray, scale: float = 1.0) -> list[LimbPoint]:
        """The person's hands and feet at time ``t`` (image pixels; velocities in pixels per second),
        moved on from their keypoints' frame by their velocity, only those where the uint8 mask
        ``accept`` (``scale`` of its pixels per image pixel) is not 0; none when the keypoints are
        older than ``max_age_s``."""
        entry = self._limbs.get(person)
        if entry is None or not (0.0 <= t - entry[0] <= self._max_age):
            return []
        age = t - entry[0]
        h, w = accept.shape
        out: list[LimbPoint] = []
        for limb in entry[1]:
            u, v = limb.uv[0] + age * limb.velocity[0], limb.uv[1] + age * limb.velocity[1]
            iu, iv = round((u + 0.5) * scale - 0.5), round((v + 0.5) * scale - 0.5)
            if 0 <= iu < w and 0 <= iv < h and accept[iv, iu] != 0:
                out.append(LimbPoint(limb.part, (u, v), limb.velocity))
        return out

    def forget(self, keep: set[int]) -> None:
        """Drop the keypoints and limbs of people not in ``keep`` (no longer tracked)."""
        self._tracked = keep
        self._keypoints = {p: k for p, k in self._keypoints.items() if p in keep}
        self._limbs = {p: e for p, e in self._limbs.items() if p in keep}
        self._filter.forget(keep)

    def reset(self) -> None:
        """Forget everyone, here and in the worker, and the refresh counts."""
        self.worker.reset()
        self.forget(set())
        self._updates.clear()

    def _attach(self, results: list[PoseResult]) -> None:
        for r in results:
            if r.person not in self._tracked:
                continue  # gone since the worker looked
            if r.keypoints is None:  # looked, not found: no limbs until found again
                self._keypoints.pop(r.person, None)
                self._limbs.pop(r.person, None)
                continue
            self._keypoints[r.person] = r.keypoints
            self._updates[r.person] = self._updates.get(r.person, 0) + 1
            self._limbs[r.person] = (r.t, self._filter.limbs(r.person, r.keypoints, r.t))
