"""``jostle bench ragdoll``: articulated characters (issue 9) against pybullet's own DeepMimic humanoid.

In one process, on the world's physics settings (``sim.physics.open_client``, 1/240 s):

1. walking: N articulated characters (``sim.articulated.character.ArticulatedCharacter``, the DeepMimic
   humanoid skeleton and the walk clip) in one client for ``--seconds``; wall time of control + physics
   gives ``realtime_factor`` (simulated seconds per wall second, all N together) and the mean joint angle
   error while walking unpushed (sampled every 1/30 s while in WALK or STAGGER — the balance feedback
   may stagger it unpushed —, not once fallen) ``tracking_error_deg``;
2. baseline: N DeepMimic humanoids loaded from pybullet_data's URDF, each tracking the same clip with
   pybullet's STABLE_PD_CONTROL at the same gains (one ``setJointMotorControlMultiDofArray`` per body per
   step, no balance, no state machine: they fall after a second or two, as DeepMimic's own PD does
   without its policy) for the same time; ``cost_ratio_vs_baseline`` = walking wall time / baseline's.
   Steps 1 and 2 run turn about, one simulated second of each in turn, each in its own client, so that
   a machine whose load changes meanwhile slows both alike;
3. pushes: for the forward and the sideways (to its left) direction and each of ``--phases`` walking
   phases (spread over one clip cycle after ``--warmup`` s of walking), a 0.2 s push on the pelvis
   rising from ``--push-start`` by ``--push-step`` N until the character falls within ``--after`` s
   (state FALL or later). The walk up to the push is simulated once per phase and restored (pybullet
   saveState + the character's Python state) before each strength. ``max_survived_*_n`` is the
   *smallest* over the phases of the largest strength survived (0: the first strength felled it);
4. get-up: every fall of step 3 is followed for ``--getup-window`` s from the moment it started;
   ``getup_success`` is the fraction that reached WALK again (None when nothing fell); and each that did is
   watched for 6 s more: ``walkoff_success`` is the fraction that walked on 2 m or more without falling
   again (the clip is resumed from a stand, its hardest moment);
5. ``external_assist_n``: the largest external force any character put on its own root (0 if none);
   ``external_assist_nm``: the largest external torque (the walking assist turning the pelvis upright, and
   the get-up's), both over every step of 1, 3 and 4;
6. ``joint_limit_excess_deg``: the most any joint of any character went past its limit, read after every
   physics step of steps 3 and 4 (walking up to a push, pushed, falling, lying, getting up; not in the
   timed walk of step 1, where reading the joints would be timed with it). pybullet holds the limits
   with constraint rows that exist only once a joint is past its limit and ask back 4 % of the excess a
   step, along the child link's axes rather than the angles limited: a fast compound swing (the crossing
   step of a push just short of a fall) carries a hip or an ankle well past (tests/test_articulated_limits.py).
   ``joint_limit_excess_deg_unpushed`` / ``_survived`` / ``_felled`` / ``_down`` / ``_walkoff`` split it by
   when: walking up to a push; upright after a push it survived (staggering, recovering, walking on);
   upright after a push that then felled it (up to the fall); fallen (falling, lying, getting up); walking
   off after a get-up.

7. ``recovery_cost_ratio`` (physics N = ``recovery_substeps`` times finer while one recovers, default 8,
   ``sim.articulated.recovery``; None with 1): step 1's walkers, one kept recovering, over step 1's time.

Details (per phase, the baseline's fall time) go to stderr; the figures are the keys above.
"""

from __future__ import annotations

import argparse
import copy
import math
import time
from collections.abc import Callable, Generator, Iterator
from typing import Any

import numpy as np

from jostle.bench.ragdoll_baseline import BenchSim, baseline_slices, log

KEYS = ("characters", "physics_hz", "realtime_factor", "cost_ratio_vs_baseline", "tracking_error_deg",
        "max_survived_forward_n", "max_survived_side_n", "getup_success", "external_assist_n")
EXCESS_WHEN = ("unpushed", "survived", "felled", "down", "walkoff")  # joint_limit_excess_deg_<when>: module doc
EXTRA_KEYS = ("external_assist_nm", "walkoff_success", "recovery_substeps", "recovery_cost_ratio",  # beyond the
              "joint_limit_excess_deg", *(f"joint_limit_excess_deg_{when}" for when in EXCESS_WHEN))  # issue's keys
WALK_ON_S, WALK_ON_M = 6.0, 2.0  # a get-up is followed by this long, in which this far must be walked
DOWN = ("fall", "lie", "stand_up")  # CharacterState values that count as fallen
PUSH_S = 0.2
SLICE_S = 1.0  # the walkers and the baseline run turn about, this many simulated seconds at a time


class _Worst:
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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--characters", type=int, default=4, metavar="N", help="walking characters (default 4)")
    parser.add_argument("--seconds", type=float, default=10.0, metavar="S", help="walking time (default 10)")
    parser.add_argument("--phases", type=int, default=4, metavar="K", help="walking phases pushed (default 4)")
    parser.add_argument("--warmup", type=float, default=2.0, metavar="S", help="walking before the first phase")
    parser.add_argument("--push-start", type=float, default=20.0, metavar="N", help="first push strength")
    parser.add_argument("--push-step", type=float, default=20.0, metavar="N", help="push strength step (20)")
    parser.add_argument("--push-max", type=float, default=1000.0, metavar="N", help="strongest push tried")
    parser.add_argument("--after", type=float, default=3.0, metavar="S", help="watch this long after a push")
    parser.add_argument("--getup-window", type=float, default=8.0, metavar="S", help="time to stand again")
    parser.add_argument("--recovery-substeps", type=int, default=None, metavar="N",
                        help="physics steps per step while a character recovers (default: the character's, 8, "
                             "which holds the joint limits; 1: never finer; sim.articulated.recovery)")
    parser.add_argument("--quick", action="store_true",
                        help="tiny settings for tests: 1 character, 0.5 s, 1 phase, one 600 N push")


def _settings(args: argparse.Namespace) -> argparse.Namespace:
    s = copy.copy(args)
    if args.quick:
        s.characters, s.seconds, s.phases, s.warmup = 1, 0.5, 1, 0.3
        s.push_start = s.push_max = 600.0
        s.after, s.getup_window = 0.5, 0.5
    for name in ("characters", "phases"):
        if getattr(s, name) < 1:
            raise ValueError(f"--{name}: expected a whole number >= 1, got {getattr(s, name)}")
    for name in ("seconds", "push_step", "after", "getup_window"):
        v = getattr(s, name)
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"--{name.replace('_', '-')}: expected a number > 0, got {v}")
    if not 0 <= s.push_start <= s.push_max or s.warmup < 0:
        raise ValueError(f"--push-start: expected 0 <= start <= --push-max={s.push_max}, got {s.push_start}")
    s.spec = character_spec(s)
    return s


def character_spec(args: argparse.Namespace) -> Any:
    """The characters' spec: the default one, with ``--recovery-substeps`` when given."""
    from sim.articulated.spec import ArticulatedSpec

    try:
        return ArticulatedSpec(**({} if args.recovery_substeps is None else {"recovery_substeps": args.recovery_substeps}))
    except ValueError as e:  # "recovery_substeps: expected …" said as the flag
        raise ValueError("--" + str(e).replace("recovery_substeps", "recovery-substeps", 1)) from None


def _new_character(sim: BenchSim, position: tuple[float, float], spec: Any = None) -> Any:
    """An articulated character (helper G1's API) on the DeepMimic skeleton, walking along +x (``spec``: the
    default ``ArticulatedSpec`` when None)."""
    from sim.articulated.character import ArticulatedCharacter
    from sim.articulated.skeleton import deepmimic_humanoid
    from sim.articulated.spec import ArticulatedSpec

    return ArticulatedCharacter(sim.client, deepmimic_humanoid(), spec or ArticulatedSpec(), None, position, 0.0)


def _run(sim: BenchSim, chars: list[Any], steps: int, each: Callable[[int], None] | None = None) -> float:
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
        chars = [_new_character(sim, (0.0, 2.0 * i), spec) for i in range(n)]
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
            spent = _run(sim, chars, upto - done, sample)
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
    while they run (one after the other, on a busy machine: a ratio of 1.22 where alone it was 0.96)."""
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


def _direction(char: Any, side: bool) -> np.ndarray:
    """The character's forward (or, with ``side``, its left) on the floor, from its root orientation."""
    from sim.motion import quaternion as quat

    _, orn = char.root()
    fwd = quat.rotate(np.asarray(orn, dtype=float), np.array([1.0, 0.0, 0.0]))
    fwd[2] = 0.0
    fwd /= max(float(np.linalg.norm(fwd)), 1e-9)
    return np.array([-fwd[1], fwd[0], 0.0]) if side else fwd


def _walked(s: argparse.Namespace, phase: int, worst: _Worst) -> tuple[BenchSim, Any]:
    """A fresh character walked for the warm-up plus ``phase``/``phases`` of a clip cycle."""
    sim = BenchSim.open()
    char = _new_character(sim, (0.0, 0.0), s.spec)
    cycle = float(char.walk.duration) if hasattr(char, "walk") else 1.3
    worst.when = "unpushed"
    _run(sim, [char], round((s.warmup + cycle * phase / s.phases) / sim.dt), lambda _: worst.see([char]))
    return sim, char


class _Checkpoint:
    """The walk up to a push, kept to go back to: pybullet's saveState plus a deep copy of the character's
    Python state; when that cannot be copied, the walk is simulated again from the start instead."""

    def __init__(self, s: argparse.Namespace, phase: int, worst: _Worst) -> None:
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
              worst: _Worst) -> tuple[float, list[float], list[bool], list[bool], tuple[float, float]]:
    """(smallest over phases of the largest strength survived, per-phase values, get-up outcomes, walk-off
    outcomes of those that stood, (peak assist N, peak assist N·m))."""
    survived: list[float] = []
    getups: list[bool] = []
    walkoffs: list[bool] = []
    peak = [0.0, 0.0]
    for k in range(s.phases):
        point = _Checkpoint(s, k, worst)
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


def _watch(sim: BenchSim, char: Any, seconds: float, worst: _Worst, settle: bool = True) -> float | None:
    """Step for ``seconds``; the time (s from now) it went down, or None if it stayed up (with ``settle``,
    a fall is followed to the end of ``seconds``; without, the watch stops there)."""
    from sim.articulated.recovery import advance

    for s in range(round(seconds / sim.dt)):
        advance(sim.client, [char], sim.dt)
        worst.see([char])
        if str(char.state) in DOWN:
            if settle:
                rest = seconds - (s + 1) * sim.dt
                _run(sim, [char], max(0, round(rest / sim.dt)), lambda _: worst.see([char]))
            return (s + 1) * sim.dt
    return None


def _walks_on(sim: BenchSim, char: Any, worst: _Worst) -> bool:
    """Whether a character that just stood up walks ``WALK_ON_M`` in ``WALK_ON_S`` without falling again."""
    start = np.array(char.root()[0], dtype=float)
    worst.when = "walkoff"
    fell = _watch(sim, char, WALK_ON_S, worst, settle=False) is not None
    moved = float(np.linalg.norm((np.array(char.root()[0], dtype=float) - start)[:2]))
    return not fell and moved >= WALK_ON_M


def _stands_again(sim: BenchSim, char: Any, seconds: float, worst: _Worst) -> bool:
    """Whether it is walking again within ``seconds`` more."""
    from sim.articulated.recovery import advance

    for _ in range(max(0, round(seconds / sim.dt))):
        if str(char.state) == "walk":
            return True
        advance(sim.client, [char], sim.dt)
        worst.see([char])
    return str(char.state) == "walk"


def run(args: argparse.Namespace) -> dict[str, object]:
    from jostle.quiet import import_pybullet_quietly

    import_pybullet_quietly()
    s = _settings(args)
    from sim.config import WorldConfig

    hz = 1.0 / WorldConfig().physics_dt
    worst = _Worst()
    slices = max(1, math.ceil(s.seconds / SLICE_S))
    runs = [walking_slices(s.characters, s.seconds, slices, s.spec), baseline_slices(s.characters, s.seconds, slices)]
    if s.spec.recovery_substeps > 1:  # what recovering costs: the same walkers, one of them kept recovering
        runs.append(walking_slices(s.characters, s.seconds, slices, s.spec, recovering=True))
    timed = interleaved(runs)
    (wall, simulated, error, assist_n, assist_nm), base = timed[0][1], timed[1][0]
    forward, per_fwd, up_fwd, on_fwd, peak_fwd = push_test(s, side=False, worst=worst)
    sideways, per_side, up_side, on_side, peak_side = push_test(s, side=True, worst=worst)
    assist_n = max(assist_n, peak_fwd[0], peak_side[0])
    assist_nm = max(assist_nm, peak_fwd[1], peak_side[1])
    log(f"pushes survived per phase (N): forward {per_fwd}, sideways {per_side}; the figures are the minimum")
    getups, walkoffs = up_fwd + up_side, on_fwd + on_side
    log(f"falls {len(getups)}, stood again within {s.getup_window:g} s: {sum(getups)}, then walked on "
        f"{WALK_ON_M:g} m in {WALK_ON_S:g} s: {sum(walkoffs)}; peak assist torque {assist_nm:.1f} N·m")
    figures: dict[str, object] = {
        "characters": s.characters,
        "physics_hz": round(hz, 3),
        "realtime_factor": round(simulated / wall, 3) if wall > 0 else None,
        "cost_ratio_vs_baseline": round(wall / base, 3) if base > 0 else None,
        "tracking_error_deg": round(error, 2) if math.isfinite(error) else None,
        "max_survived_forward_n": forward,
        "max_survived_side_n": sideways,
        "getup_success": round(sum(getups) / len(getups), 3) if getups else None,
        "external_assist_n": round(assist_n, 1),
        "external_assist_nm": round(assist_nm, 1),
        "walkoff_success": round(sum(walkoffs) / len(walkoffs), 3) if walkoffs else None,
        "recovery_substeps": s.spec.recovery_substeps,
        "recovery_cost_ratio": round(timed[2][0] / timed[0][0], 3) if len(timed) > 2 and timed[0][0] > 0 else None,
        "joint_limit_excess_deg": round(math.degrees(worst.rad), 2),
        **{f"joint_limit_excess_deg_{when}": round(math.degrees(rad), 2) for when, rad in worst.by_when.items()},
    }
    return figures
