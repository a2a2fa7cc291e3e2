"""The pose worker: BlazePose's landmark model beside the observer's loop, not in it.

The observer hands it (:meth:`PoseWorker.submit`) each frame and the people tracked in it. With
``threaded`` (the live default) a thread takes the newest frame (one not yet started is replaced by
a newer one: never a queue) and runs the model on its people, least recently looked at first, then
by rank (nearest the characters, or largest), until a newer frame waits (at least one person a
frame), idling after each run so it uses at most ``cpu_share`` of one core, at a lower priority
(nice +10 on Linux) so that on a busy machine the loop comes first. cv2.dnn releases the GIL, so a
thread does as well as a process here (figures: docs/notes/pose-worker.md). Results
(:meth:`take`) carry the time of the frame they were computed from. Without ``threaded`` every
person is looked at inline in :meth:`submit`, in the order given: deterministic (replays, tests).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from interaction.webcam.pose import Keypoints, PoseTracker

__all__ = ["PosePerson", "PoseResult", "PoseWorker", "looking_order"]

log = logging.getLogger("jostle.webcam")

_CLOSE_TIMEOUT_S = 5.0  # a model run takes ~25 ms: the thread is gone long before this
_NICE = 10  # the worker thread's niceness (Linux: per thread); the observer's loop keeps 0


@dataclass(frozen=True, eq=False)
class PosePerson:
    """One tracked person to look at: ``outline`` (N, 2) in the frame's pixels; ``rank``, smaller is
    looked at first among people refreshed equally long ago (metres to the nearest character, or
    minus the person's size in pixels when there are no stage positions)."""

    person: int
    outline: np.ndarray
    rank: float = 0.0


@dataclass(frozen=True, eq=False)
class PoseResult:
    """The model's answer for one person in the frame of time ``t`` (seconds, the frame's clock):
    their keypoints (``keypoints.t == t``), or None when no person was found in the crop."""

    person: int
    t: float
    keypoints: Keypoints | None


class PoseWorker:
    """Runs a :class:`PoseTracker` on the newest frame, in a thread of its own or inline.

    The tracker belongs to the worker from now on (its thread is the only caller). ``submit`` keeps
    a reference to the image: the frame's pixels must not be overwritten afterwards (frames are
    immutable). An error in the thread is raised again by the next :meth:`take`.
    """

    def __init__(self, tracker: PoseTracker, *, threaded: bool = True, cpu_share: float = 1.0) -> None:
        if not (0.0 < cpu_share <= 1.0):
            raise ValueError(f"cpu_share: expected a number > 0 and ≤ 1, got {cpu_share!r}")
        self._tracker = tracker
        self._cpu_share = cpu_share
        self._wake = threading.Condition()
        self._stopping = threading.Event()
        self._pending: tuple[float, np.ndarray, tuple[PosePerson, ...]] | None = None
        self._results: list[PoseResult] = []
        self._error: BaseException | None = None
        self._forget_all = False
        self._busy = False  # the thread is looking at a frame
        self._looked: dict[int, float] = {}  # person → time of the last frame they were looked at in
        self.frames_dropped = 0  # frames replaced by a newer one before the worker started them
        self.frames_started = 0
        self.runs = 0  # people looked at (one to three model runs each)
        self._thread: threading.Thread | None = None
        if threaded:
            self._thread = threading.Thread(target=self._loop, name="jostle-pose", daemon=True)
            self._thread.start()

    @property
    def threaded(self) -> bool:
        return self._thread is not None

    @property
    def running(self) -> bool:
        """True while the worker's thread is alive (always False inline)."""
        return self._thread is not None and self._thread.is_alive()

    def submit(self, t: float, bgr: np.ndarray, people: Sequence[PosePerson]) -> None:
        """The newest frame (time ``t``, uint8 BGR) and everyone tracked in it; people not in it are
        forgotten. Threaded: replaces a frame not yet started and returns at once."""
        if self._thread is None:
            self._tracker.forget({p.person for p in people})
            found = [self._look(t, bgr, p) for p in people]
            self._results.extend(found)
            self.frames_started += 1
            return
        if self._stopping.is_set():
            raise RuntimeError("PoseWorker.submit: the worker was closed")
        with self._wake:
            if self._pending is not None:
                self.frames_dropped += 1
            self._pending = (t, bgr, tuple(people))
            self._wake.notify_all()  # the thread, and anyone in wait_idle

    def take(self) -> list[PoseResult]:
        """The results that arrived since the last call, oldest first."""
        with self._wake:
            out, self._results = self._results, []
            error, self._error = self._error, None
        if error is not None:
            raise RuntimeError(f"pose worker: {error}") from error
        return out

    def wait_idle(self, timeout: float) -> bool:
        """Wait until no frame waits and none is being looked at (True), or ``timeout`` seconds (False)."""
        deadline = time.monotonic() + timeout
        with self._wake:
            while self._pending is not None or self._busy:
                left = deadline - time.monotonic()
                if left <= 0 or not self.running:
                    return False
                self._wake.wait(min(left, 0.05))
        return True

    def reset(self) -> None:
        """Forget the people and drop the waiting frame and results (the camera changed)."""
        if self._thread is None:
            self._tracker.forget(set())
            self._results.clear()
            self._looked.clear()
            return
        with self._wake:
            self._pending = None
            self._results = []
            self._forget_all = True

    def close(self) -> None:
        """Stop the thread (waits for the model run under way, ~25 ms). Idempotent."""
        self._stopping.set()
        with self._wake:
            self._wake.notify_all()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(_CLOSE_TIMEOUT_S)

    # ------------------------------------------------------------ the thread

    def _look(self, t: float, bgr: np.ndarray, p: PosePerson) -> PoseResult:
        kp = self._tracker.track(bgr, p.person, p.outline)
        self._looked[p.person] = t
        self.runs += 1
        return PoseResult(p.person, t, None if kp is None else dataclasses.replace(kp, t=t))

    def _loop(self) -> None:
        if sys.platform == "linux":  # a thread is a task of its own there; elsewhere this would nice the process
            try:
                os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), _NICE)
            except OSError:
                log.debug("pose worker: cannot lower its priority", exc_info=True)
        while True:
            with self._wake:
                self._busy = False
                self._wake.notify_all()
                while self._pending is None and not self._stopping.is_set():
                    self._wake.wait()
                if self._stopping.is_set():
                    return
                assert self._pending is not None
                t, bgr, people = self._pending
                self._pending = None
                self._busy = True
                forget_all, self._forget_all = self._forget_all, False
            try:
                self._one_frame(t, bgr, people, forget_all)
            except Exception as e:  # raised again in the observer's thread by take()
                log.debug("pose worker failed", exc_info=True)
                with self._wake:
                    self._error = e

    def _one_frame(self, t: float, bgr: np.ndarray, people: tuple[PosePerson, ...], forget_all: bool) -> None:
        if forget_all:
            self._tracker.forget(set())
            self._looked.clear()
        keep = {p.person for p in people}
        self._tracker.forget(keep)
        self._looked = {k: v for k, v in self._looked.items() if k in keep}
        self.frames_started += 1
        for i, p in enumerate(looking_order(people, self._looked)):
            if i > 0 and (self._pending is not None or self._stopping.is_set()):
                return  # a newer frame waits: look at the people there
            start = time.perf_counter()
            result = self._look(t, bgr, p)
            cost = time.perf_counter() - start
            with self._wake:
                if self._forget_all:
                    return  # reset while looking: this frame's people are no longer anyone
                self._results.append(result)
            if self._cpu_share < 1.0 and self._stopping.wait(cost * (1.0 / self._cpu_share - 1.0)):
                return


def looking_order(people: Sequence[PosePerson], looked: dict[int, float]) -> list[PosePerson]:
    """Who the model looks at first: the person looked at longest ago (``looked``: person → time of
    that frame; never looked at comes first), then the smaller rank, then the smaller id."""
    return sorted(people, key=lambda p: (looked.get(p.person, -math.inf), p.rank, p.person))
