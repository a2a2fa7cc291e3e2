"""The pushes of ``jostle bench ragdoll``: how hard a walking character can be pushed, and what follows.

:func:`push_test` pushes a character walked to each of ``--phases`` phases (forward or to its left), of
rising strength until it falls, going back to the walk before each push (:class:`Checkpoint`); each fall
is followed for the get-up and, once up, the walk-off. :class:`Worst` keeps the largest joint-limit
excess seen (radians), overall and by when (``EXCESS_WHEN``).
"""

from __future__ import annotations

import argparse
import copy
from typing import Any

import numpy as np

from jostle.bench.ragdoll_baseline import BenchSim, log
from jostle.bench.ragdoll_walk import DOWN, new_character, run_steps

EXCESS_WHEN = ("unpushed", "survived", "felled", "down", "walkoff")  # joint_limit_excess_deg_<when>
WALK_ON_S, WALK_ON_M = 6.0, 2.0  # a get-up is followed by this long, in which this far must be walked
PUSH_S = 0.2


class Worst:
    """The largest joint-limit excess (radians) seen on any character watched, overall and by when (see
    ``EXCESS_WHEN``). Callers set ``when`` ("pushed" until ``end_push`` says whether the push felled it);
    ``down`` is read from the character's state."""

    def __init__(self) -> None:
        self.rad = 0.0
        self.when = "unpushed"
        self.by_when = dict.fromkeys(EXCESS_WHEN, 0.0)
        self._push = 0.0  # upright after the current push, not yet known to be survived or felled

    def see(self, chars: list[Any]) -> None:
        for c in chars:
            e = float(c.limit_excess())
            self.rad = max(self.rad, e)
            if str(c.state) in DOWN:
                self.by_when["down"] = max(self.by_when["down"], e)
            elif self.when == "pushed":
                self._push = max(self._push, e)
            else:
                self.by_when[self.when] = max(self.by_when[self.when], e)

    def end_push(self, felled: bool) -> None:
        """The push just watched survived or felled the character; after a fall, until the next ``when``,
        what is seen counts as ``down`` (getting up)."""
        when = "felled" if felled else "survived"
        self.by_when[when] = max(self.by_when[when], self._push)
        self._push = 0.0
        if felled:
            self.when = "down"


def _direction(char: Any, side: bool) -> np.ndarray:
    """The character's forward (or, with ``side``, its left) on the floor, from its root orientation."""
    from sim.motion import quaternion as quat

    _, orn = char.root()
    fwd = quat.rotate(np.asarray(orn, dtype=float), np.array([1.0, 0.0, 0.0]))
    fwd[2] = 0.0
    fwd /= max(float(np.linalg.norm(fwd)), 1e-9)
    return np.array([-fwd[1], fwd[0], 0.0]) if side else fwd


def _walked(s: argparse.Namespace, phase: int, worst: Worst) -> tuple[BenchSim, Any]:
    """A fresh character walked for the warm-up plus ``phase``/``phases`` of a clip cycle."""
    sim = BenchSim.open()
    char = new_character(sim, (0.0, 0.0), s.spec)
    cycle = float(char.walk.duration) if hasattr(char, "walk") else 1.3
    worst.when = "unpushed"
    run_steps(sim, [char], round((s.warmup + cycle * phase / s.phases) / sim.dt), lambda _: worst.see([char]))
    return sim, char


class Checkpoint:
    """The walk up to a push, kept to go back to: pybullet's saveState plus a deep copy of the character's
    Python state; when that cannot be copied, the walk is simulated again from the start instead."""

    def __init__(self, s: argparse.Namespace, phase: int, worst: Worst) -> None:
        import pybullet as p

        self.s, self.phase, self.worst = s, phase, worst
        self.sim, self.char = _walked(s, phase, worst)
        try:
            self.saved: dict[str, Any] | None = copy.deepcopy(self.char.__dict__)
            self.state = p.saveState(physicsClientId=self.sim.client)
        except (TypeError, copy.Error):
            self.saved = None
            log("the character's state cannot be copied: every push walks again from the start")

    def restore(self) -> Any:
        import pybullet as p

        if self.saved is None:
            self.sim.close()
            self.sim, self.char = _walked(self.s, self.phase, self.worst)
            return self.char
        p.restoreState(self.state, physicsClientId=self.sim.client)
        self.char.__dict__.clear()
        self.char.__dict__.update(copy.deepcopy(self.saved))
        return self.char


def push_test(s: argparse.Namespace, side: bool,
              worst: Worst) -> tuple[float, list[float], list[bool], list[bool], tuple[float, float]]:
    """(smallest over phases of the largest strength survived, per-phase values, get-up outcomes, walk-off
    outcomes of those that stood, (peak assist N, peak assist N·m))."""
    survived: list[float] = []
    getups: list[bool] = []
    walkoffs: list[bool] = []
    peak = [0.0, 0.0]
    for k in range(s.phases):
        point = Checkpoint(s, k, worst)
        try:
            if str(point.char.state) in DOWN:
                log(f"push {'side' if side else 'forward'} phase {k}: fell before the push (counts as 0 N)")
                survived.append(0.0)
                continue
            best, force = 0.0, float(s.push_start)
            while force <= s.push_max + 1e-9:
                char = point.restore()
                worst.when = "pushed"
                char.push("root", tuple(float(v) for v in force * _direction(char, side)), PUSH_S)
                fell_at = _watch(point.sim, char, s.after, worst)
                worst.end_push(fell_at is not None)
                if fell_at is not None:
                    getups.append(_stands_again(point.sim, char, s.getup_window - (s.after - fell_at), worst))
                    if getups[-1] and not s.quick:
                        walkoffs.append(_walks_on(point.sim, char, worst))
                peak[0] = max(peak[0], float(getattr(char, "external_assist_peak_n", 0.0)))
                peak[1] = max(peak[1], float(getattr(char, "external_assist_peak_nm", 0.0)))
                if fell_at is not None:
                    break
                best = force
                force += s.push_step
            survived.append(best)
        finally:
            point.sim.close()
    return min(survived), survived, getups, walkoffs, (peak[0], peak[1])


def _watch(sim: BenchSim, char: Any, seconds: float, worst: Worst, settle: bool = True) -> float | None:
    """Step for ``seconds``; the time (s from now) it went down, or None if it stayed up (with ``settle``,
    a fall is followed to the end of ``seconds``; without, the watch stops there)."""
    from sim.articulated.recovery import advance

    for s in range(round(seconds / sim.dt)):
        advance(sim.client, [char], sim.dt)
        worst.see([char])
        if str(char.state) in DOWN:
            if settle:
                rest = seconds - (s + 1) * sim.dt
                run_steps(sim, [char], max(0, round(rest / sim.dt)), lambda _: worst.see([char]))
            return (s + 1) * sim.dt
    return None


def _walks_on(sim: BenchSim, char: Any, worst: Worst) -> bool:
    """Whether a character that just stood up walks ``WALK_ON_M`` in ``WALK_ON_S`` without falling again."""
    start = np.array(char.root()[0], dtype=float)
    worst.when = "walkoff"
    fell = _watch(sim, char, WALK_ON_S, worst, settle=False) is not None
    moved = float(np.linalg.norm((np.array(char.root()[0], dtype=float) - start)[:2]))
    return not fell and moved >= WALK_ON_M


def _stands_again(sim: BenchSim, char: Any, seconds: float, worst: Worst) -> bool:
    """Whether it is walking again within ``seconds`` more."""
    from sim.articulated.recovery import advance

    for _ in range(max(0, round(seconds / sim.dt))):
        if str(char.state) == "walk":
            return True
        advance(sim.client, [char], sim.dt)
        worst.see([char])
    return str(char.state) == "walk"
