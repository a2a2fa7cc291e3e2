"""An observer that cannot take the show down: bad frames are skipped, crashes caught and rebuilt.

:class:`ObserverGuard` stands between the main loop and one observer. A frame the data makes wrong
(an image size or pad count other than the frames observed so far, pad forces NaN, infinite or over
``PAD_MAX_NEWTONS``, or the observer raising ``UntrustedInput``) is skipped: one warning line per
kind, then counted (``bad_frames``); the observer keeps running. Any other exception is a crash:
one error line (its record carries the first traceback, shown only with ``--debug``), counted; the
observer is dropped, every frame gets an empty observation until, after a back-off
(``first_backoff_s`` doubling to ``max_backoff_s``, reset after ``healthy_after_s``), it is rebuilt.
A contactor or impulse carrying a NaN or infinite number is dropped and counted
(``dropped_non_finite``). Times are the loop's clock. :meth:`ObserverGuard.health` returns the
counters; :meth:`ObserverGuard.never_observed` says when frames came and no observation came out.
"""

from __future__ import annotations

import dataclasses
import logging
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from interaction.observers import Observer
from interaction.types import BodyObservation, finite
from sensors.base import ColorImage, DepthImage, Frame, PadSample
from sensors.clock import Clock
from sensors.untrusted import UntrustedInput, one_line

log = logging.getLogger("jostle.observers")

PAD_MAX_NEWTONS = 20_000.0  # N on one pad, either sign: two tonnes; a person landing a jump gives < 5 kN

GuardState = Literal["running", "restarting"]


@dataclass(frozen=True, slots=True)
class ObserverHealth:
    """One guarded observer's state and counters (all 0 in a healthy installation)."""

    name: str
    state: GuardState  # "restarting": crashed, waiting out the back-off before a rebuild
    crashes: int  # exceptions raised by observe()
    restarts: int  # successful rebuilds
    failed_restarts: int  # rebuilds that raised
    dropped_non_finite: int  # contactors / impulses dropped for NaN or infinite numbers
    non_finite_inputs: int  # pad samples with NaN or infinite newtons (skipped, also in bad_frames)
    last_error: str  # one line: "ValueError: ..." ("" if none yet)
    retry_in_s: float  # seconds until the next rebuild (0 while running)
    frames: int = 0  # frames its sensor handed it
    observations: int = 0  # observations its observer returned (a crash, a wait or a skipped frame: none)
    bad_frames: int = 0  # frames skipped because of what they hold (see the module docstring)
    bad_kinds: tuple[str, ...] = ()  # the kinds of bad frames seen, in the order first seen


def _signature(e: BaseException) -> tuple[str, str, int]:
    """The error's type and the place it was raised: the same crash again is not logged in full."""
    frames = traceback.extract_tb(e.__traceback__)
    where = frames[-1] if frames else None
    return type(e).__name__, where.filename if where else "", where.lineno or 0 if where else 0


class ObserverGuard:
    """Runs ``build()``'s observer, catching its crashes (see the module docstring).

    The first ``build()`` happens here and is not guarded: an observer that cannot be made from its
    config at start is a configuration error and stops the run.
    """

    def __init__(
        self,
        name: str,
        build: Callable[[], Observer],
        clock: Clock,
        *,
        first_backoff_s: float = 1.0,
        max_backoff_s: float = 30.0,
        healthy_after_s: float = 60.0,
    ) -> None:
        if not 0 < first_backoff_s <= max_backoff_s:
            raise ValueError(f"first_backoff_s: expected seconds > 0 and ≤ max_backoff_s ({max_backoff_s}), "
                             f"got {first_backoff_s}")
        if not healthy_after_s >= 0:
            raise ValueError(f"healthy_after_s: expected seconds ≥ 0, got {healthy_after_s}")
        self.name = name
        self._build = build
        self._clock = clock
        self.first_backoff_s = first_backoff_s
        self.max_backoff_s = max_backoff_s
        self.healthy_after_s = healthy_after_s
        self._observer: Observer | None = build()
        self._since = clock.now()  # when the current observer was built
        self._in_a_row = 0  # crashes since the observer last ran healthy_after_s
        self._retry_at = 0.0
        self._seen: set[tuple[str, str, int]] = set()
        self._crashes = 0
        self._restarts = 0
        self._failed_restarts = 0
        self._dropped = 0
        self._non_finite_in = 0
        self._last_error = ""
        self._frames = 0
        self._observations = 0
        self._bad: dict[str, int] = {}  # kind of bad frame → frames skipped
        self._shape: tuple[str, tuple[int, ...]] | None = None  # payload kind and size of good frames
        self.restart_times: list[float] = []  # clock times of the successful rebuilds (the last 64)

    # ------------------------------------------------------------------ what the loop reads

    @property
    def observer(self) -> Observer | None:
        """The observer now running (None while restarting)."""
        return self._observer

    def health(self) -> ObserverHealth:
        running = self._observer is not None
        return ObserverHealth(
            name=self.name, state="running" if running else "restarting", crashes=self._crashes,
            restarts=self._restarts, failed_restarts=self._failed_restarts, dropped_non_finite=self._dropped,
            non_finite_inputs=self._non_finite_in, last_error=self._last_error,
            retry_in_s=0.0 if running else max(0.0, self._retry_at - self._clock.now()),
            frames=self._frames, observations=self._observations, bad_frames=sum(self._bad.values()),
            bad_kinds=tuple(self._bad),
        )

    def never_observed(self) -> str | None:
        """One line when its sensor handed it frames and it returned no observation for any (it crashed
        on every one, could not be rebuilt, or every frame was bad), else None: such a run did not do
        its job."""
        if not self._frames or self._observations:
            return None
        why = f"; last error: {self._last_error}" if self._last_error else ""
        bad = f", bad frames: {sum(self._bad.values())} ({', '.join(self._bad)})" if self._bad else ""
        return (f"observer {self.name!r} produced nothing from the {self._frames} frames of its sensor "
                f"(crashes: {self._crashes}, failed rebuilds: {self._failed_restarts}{bad}{why})")

    # ------------------------------------------------------------------ the loop's call

    def observe(self, frame: Frame) -> BodyObservation:
        now = self._clock.now()
        self._frames += 1
        if self._observer is None:
            if now < self._retry_at:
                return BodyObservation(t=frame.t)
            self._rebuild(now)
            if self._observer is None:
                return BodyObservation(t=frame.t)
        elif self._in_a_row and now - self._since >= self.healthy_after_s:
            self._in_a_row = 0  # ran long enough: the next crash backs off from the start again
        refused = self._refusal(frame)
        if refused is not None:
            self._skip(frame, *refused)
            return BodyObservation(t=frame.t)
        try:
            obs = self._observer.observe(frame)
        except UntrustedInput as e:  # the observer says the data is wrong: skip it, keep the observer
            self._skip(frame, e.source, e.problem)
            return BodyObservation(t=frame.t)
        except Exception as e:  # any bug in one observer; the loop and the other observers go on
            self._crashed(e, now, "crashed")
            return BodyObservation(t=frame.t)
        self._observations += 1
        if self._shape is None:
            self._shape = _shape(frame)
        return self._checked(obs)

    def _refusal(self, frame: Frame) -> tuple[str, str] | None:
        """(kind, what is wrong) if ``frame`` is not one to observe, else None."""
        payload = frame.payload
        shape, before = _shape(frame), self._shape
        if before is not None and shape != before:  # first: cheap, and a million pads are not looked at
            if shape[0] == "pads":
                return "pad count", f"a sample of {shape[1][0]} pads after samples of {before[1][0]}"
            return "frame size", (f"a {shape[0]} frame of {_size(shape[1])} after frames of {_size(before[1])} "
                                  "(the size changed mid-stream)")
        if isinstance(payload, PadSample):
            newtons = payload.newtons
            if not newtons:
                return "pad count", "a pad sample with no pads"
            if not finite(*newtons):
                self._non_finite_in += 1
                return "pad force", "a pad sample with a NaN or infinite force"
            if max(abs(f) for f in newtons) > PAD_MAX_NEWTONS:
                return "pad force", (f"a pad force of {max(newtons, key=abs):.3g} N, beyond the "
                                     f"{PAD_MAX_NEWTONS:g} N a pad can take")
        return None

    def _skip(self, frame: Frame, kind: str, problem: str) -> None:
        """Count a frame skipped for what it holds; one warning line the first time of each kind."""
        first = kind not in self._bad
        self._bad[kind] = self._bad.get(kind, 0) + 1
        if first:
            log.warning("%s", one_line(f"observer {self.name!r}: frame {frame.seq} of sensor {frame.sensor!r} "
                                       f"skipped: {problem} (frames like it are counted as bad_frames in the "
                                       "health report, not logged again)"))

    def _checked(self, obs: BodyObservation) -> BodyObservation:
        contactors = tuple(c for c in obs.contactors if c.finite)
        impulses = tuple(i for i in obs.impulses if i.finite)
        dropped = len(obs.contactors) - len(contactors) + len(obs.impulses) - len(impulses)
        if not dropped:
            return obs
        if not self._dropped:
            log.warning("observer %r: dropped a contactor or impulse with NaN or infinite numbers "
                        "(counted from now on in the health report, not logged again)", self.name)
        self._dropped += dropped
        return dataclasses.replace(obs, contactors=contactors, impulses=impulses)

    def _backoff(self) -> float:
        return min(self.first_backoff_s * 2.0 ** max(self._in_a_row - 1, 0), self.max_backoff_s)

    def _crashed(self, e: Exception, now: float, what: str) -> None:
        if what == "crashed":
            self._crashes += 1
        else:
            self._failed_restarts += 1
        self._in_a_row += 1
        self.close()
        self._observer = None
        delay = self._backoff()
        self._retry_at = now + delay
        self._last_error = f"{type(e).__name__}: {e}".splitlines()[0][:300]
        signature = _signature(e)
        first = signature not in self._seen
        self._seen.add(signature)
        log.error("observer %r %s (%s, %d in a row); rebuilding it in %.3g s", self.name, what,
                  self._last_error, self._in_a_row, delay, exc_info=e if first else None)

    def close(self) -> None:
        """Close the observer (one with threads, the webcam's pose worker, stops them) at the end of a
        run; its health stays as it was."""
        close = getattr(self._observer, "close", None)
        if callable(close):
            try:
                close()
            except Exception:
                log.exception("observer %r: closing it failed", self.name)

    def _rebuild(self, now: float) -> None:
        try:
            observer = self._build()
        except Exception as e:
            self._crashed(e, now, "could not be rebuilt")
            return
        self._observer = observer
        self._since = now
        self._restarts += 1
        self.restart_times.append(now)
        del self.restart_times[:-64]
        log.info("observer %r rebuilt after a crash (restart %d)", self.name, self._restarts)


def _shape(frame: Frame) -> tuple[str, tuple[int, ...]]:
    """What must stay the same from frame to frame of one sensor: the image size or the pad count."""
    p = frame.payload
    if isinstance(p, ColorImage | DepthImage):
        return ("color" if isinstance(p, ColorImage) else "depth"), p.size
    if isinstance(p, PadSample):
        return "pads", (len(p.newtons),)
    return type(p).__name__, ()


def _size(size: tuple[int, ...]) -> str:
    return "×".join(str(n) for n in size)
