"""An observer that cannot take the show down: crashes are caught, the observer is rebuilt later.

:class:`ObserverGuard` stands between the main loop and one observer. When ``observe()`` raises, the
crash is logged (with its traceback the first time that error is seen, printed by the command only
with ``--debug``; one line after that) and counted; the observer is dropped, and until it is back
every frame gets an empty observation (a crashed observer must not leave stale people pushing);
after a back-off (``first_backoff_s``, doubling up to ``max_backoff_s``, reset after
``healthy_after_s`` without a crash) it is rebuilt from its config.
A rebuild that itself raises counts as a failed restart and backs off further.

What comes out of a healthy observer is checked too: a contactor or impulse carrying a NaN or
infinite number is dropped and counted (``dropped_non_finite``), and pad samples with non-finite
newtons are counted on the way in (``non_finite_inputs``). The test is ``interaction.types.finite``,
the same one the sim applies to whatever reaches ``World.step``. Times are the loop's clock, so on a
SimClock the restarts are as deterministic as the rest; :meth:`ObserverGuard.health` returns the
counters as a frozen :class:`ObserverHealth`, and :meth:`ObserverGuard.never_observed` says when an
observer was handed frames but returned nothing for any (the run then fails: ``jostle.app``).
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
from sensors.base import Frame, PadSample
from sensors.clock import Clock

log = logging.getLogger("jostle.observers")

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
    non_finite_inputs: int  # pad samples with NaN or infinite newtons handed to the observer
    last_error: str  # one line: "ValueError: ..." ("" if none yet)
    retry_in_s: float  # seconds until the next rebuild (0 while running)
    frames: int = 0  # frames its sensor handed it
    observations: int = 0  # observations its observer returned (a crash or a wait for a rebuild: none)


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
            frames=self._frames, observations=self._observations,
        )

    def never_observed(self) -> str | None:
        """One line when its sensor handed it frames and it returned no observation for any (it crashed
        on every one, or could not be rebuilt), else None: such a run did not do its job."""
        if not self._frames or self._observations:
            return None
        why = f"; last error: {self._last_error}" if self._last_error else ""
        return (f"observer {self.name!r} produced nothing from the {self._frames} frames of its sensor "
                f"(crashes: {self._crashes}, failed rebuilds: {self._failed_restarts}{why})")

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
        payload = frame.payload
        if isinstance(payload, PadSample) and not finite(*payload.newtons):
            self._non_finite_in += 1
        try:
            obs = self._observer.observe(frame)
        except Exception as e:  # any bug in one observer; the loop and the other observers go on
            self._crashed(e, now, "crashed")
            return BodyObservation(t=frame.t)
        self._observations += 1
        return self._checked(obs)

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
