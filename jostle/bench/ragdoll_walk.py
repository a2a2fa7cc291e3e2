"""The timed walk of ``jostle bench ragdoll``: articulated characters walking the clip, stepped and timed.

:func:`walking_slices` walks N characters (the DeepMimic humanoid skeleton and the walk clip) in one
client, yielding the wall seconds of each slice and returning the walk's figures; :func:`interleaved`
runs several such timed runs turn about, so that a ratio of two holds on a machine whose load changes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Generator, Iterator
from typing import Any

import numpy as np

from jostle.bench.ragdoll_baseline import BenchSim, log

DOWN = ("fall", "lie", "stand_up")  # CharacterState values that count as fallen


def new_character(sim: BenchSim, position: tuple[float, float], spec: Any = None) -> Any:
    """An articulated character (helper G1's API) on the DeepMimic skeleton, walking along +x (``spec``: the
    default ``ArticulatedSpec`` when None)."""
    from sim.articulated.character import ArticulatedCharacter
    from sim.articulated.skeleton import deepmimic_humanoid
    from sim.articulated.spec import ArticulatedSpec

    return ArticulatedCharacter(sim.client, deepmimic_humanoid(), spec or ArticulatedSpec(), None, position, 0.0)


def run_steps(sim: BenchSim, chars: list[Any], steps: int, each: Callable[[int], None] | None = None) -> float:
    """Step control + physics ``steps`` times; returns the wall seconds spent in them (``each`` excluded)."""
    from sim.articulated.recovery import advance

    spent = 0.0
    for s in range(steps):
        mark = time.perf_counter()
        advance(sim.client, chars, sim.dt)
        spent += time.perf_counter() - mark
        if each is not None:
            each(s)
    return spent


Walked = tuple[float, float, float, float, float]


def walking_slices(n: int, seconds: float, slices: int, spec: Any = None,
                   recovering: bool = False) -> Generator[float, None, Walked]:
    """n walkers for ``seconds``, in ``slices`` parts: yields the wall seconds of each part; returns (wall s,
    simulated s, mean tracking error deg, peak assist N, peak assist N·m). With ``recovering`` the first
    walker is kept recovering from a push (``sim.articulated.recovery``): the world steps finely throughout."""
    sim = BenchSim.open()
    try:
        chars = [new_character(sim, (0.0, 2.0 * i), spec) for i in range(n)]
        every = max(1, round(1.0 / 30.0 / sim.dt))
        errors: list[float] = []
        states: list[str] = []

        stepped = 0

        def sample(_: int) -> None:
            nonlocal stepped
            if recovering:
                chars[0].touched()
            if stepped % every == 0:
                states.extend(str(c.state) for c in chars)
                errors.extend(c.tracking_error_deg() for c in chars if str(c.state) in ("walk", "stagger"))
            stepped += 1

        steps = round(seconds / sim.dt)
        wall, done = 0.0, 0
        for k in range(slices):
            upto = round(steps * (k + 1) / slices)
            spent = run_steps(sim, chars, upto - done, sample)
            done = upto
            wall += spent
            yield spent
        down = sum(str(c.state) in DOWN for c in chars)
        if down:
            log(f"walking: {down} of {n} characters fell while walking unpushed")
        log("walking: time in each state " + ", ".join(f"{k} {states.count(k) / len(states):.0%}"
                                                      for k in sorted(set(states))))
        force = max(float(getattr(c, "external_assist_peak_n", 0.0)) for c in chars)
        torque = max(float(getattr(c, "external_assist_peak_nm", 0.0)) for c in chars)
        return wall, steps * sim.dt, float(np.mean(errors)) if errors else math.nan, force, torque
    finally:
        sim.close()


def interleaved(runs: list[Iterator[float]]) -> list[tuple[float, Any]]:
    """Run timed runs turn about, a slice of each in turn, until all are done: (wall seconds in all its
    slices, what it returned) of each. Timed so, a ratio of two runs holds on a machine whose load changes
    while they run (docs/notes/bench-timing.md)."""
    totals = [0.0] * len(runs)
    results: list[Any] = [None] * len(runs)
    live = list(range(len(runs)))
    while live:
        for i in list(live):
            try:
                totals[i] += next(runs[i])
            except StopIteration as stop:
                results[i] = stop.value
                live.remove(i)
    return list(zip(totals, results, strict=True))
