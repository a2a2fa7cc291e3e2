"""Recovering from a push: finer physics steps, the recovery's gains and braced joints, until it walks again.

pybullet holds joint limits with soft constraint rows (``sim.articulated.tracking``): at the world's 1/240 s a
push carries a hip 10–20° past its range. The joint drive evaluated at a finer step holds the joints inside
(pybullet's own ``numSubSteps``, which holds the drive's torques between sub-steps, does not: measured). So
(``spec.recovery_substeps``, 8 by default; 1: never), from a push, a person's contact, a stagger or a fall
on, a character asks for that many physics steps per world step (``wanted_substeps``), and whoever steps the
world (``sim.world.World``, ``jostle bench ragdoll``, tests: ``advance``) steps every body that finely while
any character asks. At the finer step the body is stiffer and the walking gains no longer balance it, so
while it recovers, or is stepped finely for another's recovery (``stepped_finely``), a character uses
``recovering_spec``: foot placement's velocity gains ``recovery_cv_sagittal`` / ``recovery_cv_coronal``, the
pelvis torque limit ``recovery_assist_torque_max_nm``, and state loads of its own: ``recovery_fall_load``
(beyond it, it gives up and falls: without it, it took forward pushes of 500–1000 N, where DeepMimic's policy
takes 240), ``recovery_stagger_load`` / ``recovery_recover_load`` (at the finer step its walk has balance
loads of 0.5–0.8 once a stride, where at the world's step 0.2–0.5: with the walking 0.8 / 0.5 it never
stopped staggering).
Its joints (``Recovery.brace``): falling or lying, the neck keeps ``recovery_neck_gain`` of its gains (limp,
a face-down landing bent it 10.5° past its limit) and every joint within ``brace_margin_deg`` of a limit is
held where it is, that far inside, at ``brace_gain`` × its gains and torque limit (a limp body that stiffens
only where it would bend past: falls went from 4–5.5° past to under 0.9°; at 1×, a body lying on its arm
bent the shoulder 5.8° past its 100 N·m, at 2× 0.7°); upright or getting up, a joint past a limit is driven
``limit_stop_inside_deg`` back inside at ``limit_stop_gain`` × its gains and torque limit (a shoulder
carrying the body in a get-up went 7.4° past at its own 100 N·m).
It settles once it has walked (not staggered) unpushed, and not walking off from a stand, for
``recovery_settle_s``; then, for ``recovery_handover_s``, it stays at the finer step while its balance
gains blend into the walking ones (its state loads kept), and only then goes back to the world's step.
Going back in one jump was a jolt that felled it (240 N forward at one phase: 4.9° past a limit in the
first 1/4 s at the world's step, a fall 1 s later). Handing over with the recovery's gains at the world's
step: 7.0° past and a fall within 1 s (the same push); with the walking gains at the finer step: after the
get-ups of 700 N forward and backward, a stagger and a fall within 2 s (measured).

Measured, ``jostle bench ragdoll --phases 8`` (with ``--recovery-substeps 1`` in brackets):
- joints at most 3.15° past a limit (28.3°): unpushed 0, after pushes survived 0.47, felled 1.06, fallen
  3.15 (a shoulder in one get-up of 16), walking off 0.09°; the default 4 phases: 1.09° (22.4°);
- pushes survived forward 460 N (220), sideways 400 N (300); get-ups 16 of 16, walk-offs 16 of 16; largest
  assist 300 N (the get-up's lift at its bound) and 300 N·m;
- the five pushes of tests/test_articulated_recovery.py (taken by stepping each way; falls forward,
  backward and sideways with the get-up and the walk on): at most 0.0 / 0.0 / 0.35 / 1.07 / 0.62° past.
The walk before a push runs at the world's step: ``cost_ratio_vs_baseline`` (unpushed walking) is unchanged.
Tried and not kept: 16 substeps (9.2° while staggering, 3.7° falling); falls braced whole (every joint at
0.5 / 0.3 of its gains: 0 / 6 of 8 get-ups, the body never lying still); ``recovery_cv_sagittal`` 0.2 – 0.5;
finer steps only while staggering, falling, lying or getting up (26.9°, and pushes of 40–100 N felled it:
switching back and forth mid-stride is what fells it); each joint set back onto its limit after every step
(``sim.articulated.tracking``).

Weak:
- Cost: while any character recovers, every body's physics is stepped 8 times: 4 walkers, one of them kept
  recovering, take 3.3–4.3× the wall time of the 4 alone (the bench's ``recovery_cost_ratio``: 3.73 in the
  run above); at the world's step those 4 ran 2.7–5.5× faster than real time on this 2-core machine.
- "Never past a limit" holds to the engine's give, not to zero: up to 3.2° in one get-up of 16, 2.1° in a
  hip toppling in the last 1/100 s before a fall (tests/test_articulated_walkoff.py).
- It takes bigger pushes than DeepMimic's policy (460 / 400 N at the weakest phase, 840 N sideways at
  one): the recovery's gains at the finer step are stiffer than the walk's.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence
from typing import Protocol

import numpy as np
import pybullet as p

from sim.articulated.spec import ArticulatedSpec
from sim.articulated.tracking import JointLimits
from sim.snapshot import CharacterState


def recovering_spec(spec: ArticulatedSpec) -> ArticulatedSpec:
    """``spec`` with the recovery's balance gains and state loads in place of the walking ones."""
    return dataclasses.replace(spec, cv_sagittal=spec.recovery_cv_sagittal, cv_coronal=spec.recovery_cv_coronal,
                               assist_torque_max_nm=spec.recovery_assist_torque_max_nm if spec.assist_torque_max_nm else 0.0,
                               fall_load=spec.recovery_fall_load, stagger_load=spec.recovery_stagger_load,
                               recover_load=spec.recovery_recover_load)


def braced(limits: JointLimits, rots: np.ndarray, targets: np.ndarray, omegas: np.ndarray, scale: np.ndarray,
           within_deg: float, inside_deg: float, gain: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The (targets, omegas, scale) of a drive whose joints within ``within_deg`` of a limit (or past it), at
    ``rots`` now, are held where they are, brought ``inside_deg`` inside, at rest, at ``gain`` of their gains
    at least (0: unchanged)."""
    near = limits.near(rots, math.radians(within_deg))
    if gain <= 0.0 or not near.any():
        return targets, omegas, scale
    return (np.where(near[:, None], limits.clamp_within(rots, math.radians(inside_deg)), targets),
            np.where(near[:, None], 0.0, omegas), np.where(near, np.maximum(scale, gain), scale))


class Recovery:
    """Whether a character is recovering (finer steps, recovery gains), for how long it has walked since, and
    its hand-over back to the world's step (finer steps, the gains blending into the walking ones)."""

    def __init__(self, spec: ArticulatedSpec) -> None:
        self.spec = recovering_spec(spec)
        self.substeps = int(spec.recovery_substeps)
        self.settle_s = float(spec.recovery_settle_s)
        self.handover_s = float(spec.recovery_handover_s)
        self.active = False
        self.handover_left = 0.0  # s still to walk at the finer step, the gains blending into the walking ones
        self._blends: dict[float, ArticulatedSpec] = {}
        self._steady_s = 0.0

    def begin(self) -> None:
        """Pushed, touched, staggering or falling: recover (again) from now (never with ``recovery_substeps`` 1)."""
        if self.substeps > 1:
            self.active = True
            self.handover_left = 0.0
        self._steady_s = 0.0

    def update(self, state: CharacterState, pushed: bool, walking_in: bool, dt: float) -> None:
        """Settled after ``settle_s`` in a row walking (not staggering), unpushed and not walking off from a
        stand (``walking_in``); then ``handover_s`` more at the finer step, handing over (``gains``)."""
        if not self.active:
            self.handover_left = max(0.0, self.handover_left - dt)
            return
        steady = state == CharacterState.WALK and not pushed and not walking_in
        self._steady_s = self._steady_s + dt if steady else 0.0
        if self._steady_s >= self.settle_s - 1e-9:  # (steps of dt summed)
            self.active = False
            self.handover_left = self.handover_s
            self._steady_s = 0.0

    @property
    def wanted_substeps(self) -> int:
        return self.substeps if self.active or self.handover_left > 0.0 else 1

    def gains(self, walking: ArticulatedSpec) -> ArticulatedSpec:
        """The spec to balance with: the recovery's while it recovers; handing over, the recovery's with its
        balance gains blended into the ``walking`` ones as the hand-over runs out (its state loads kept); else
        ``walking``."""
        if self.active:
            return self.spec
        if self.handover_left <= 0.0 or self.handover_s <= 0.0:
            return walking
        f = round(20.0 * self.handover_left / self.handover_s) / 20.0  # 1 → 0, in twentieths (cached)
        if f not in self._blends:
            r, w = self.spec, walking
            mix = {k: f * getattr(r, k) + (1.0 - f) * getattr(w, k)
                   for k in ("cv_sagittal", "cv_coronal", "assist_torque_max_nm")}
            self._blends[f] = dataclasses.replace(r, **mix)
        return self._blends[f]

    def brace(self, limits: JointLimits, rots: np.ndarray, state: CharacterState,
              drive: tuple[np.ndarray, np.ndarray, np.ndarray], neck: list[int]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The drive (targets, omegas, gain scale) of a recovering character at ``rots`` now. Falling or lying:
        the ``neck`` joints at ``recovery_neck_gain``, and every joint within ``brace_margin_deg`` of a limit
        held where it is at ``brace_gain``; upright or getting up: a joint past a limit driven
        ``limit_stop_inside_deg`` inside at ``limit_stop_gain``."""
        s = self.spec
        targets, omegas, scale = drive
        if state in (CharacterState.FALL, CharacterState.LIE):
            scale = scale.copy()
            scale[neck] = s.recovery_neck_gain
            return braced(limits, rots, targets, omegas, scale, s.brace_margin_deg, s.brace_margin_deg, s.brace_gain)
        return braced(limits, rots, targets, omegas, scale, 0.0, s.limit_stop_inside_deg, s.limit_stop_gain)


class Stepped(Protocol):
    """What ``advance`` steps: an articulated character."""

    stepped_finely: bool  # told by whoever steps it: the world steps finer for a recovery, use its gains
    recovery: Recovery

    @property
    def wanted_substeps(self) -> int: ...

    def step_control(self, dt: float) -> None: ...


def substeps_of(characters: Iterable[Stepped]) -> int:
    """Physics steps per step the world should take now: the most any character asks for (1: none)."""
    return max((c.wanted_substeps for c in characters), default=1)


def any_recovering(characters: Iterable[Stepped]) -> bool:
    """Whether any character recovers (not only hands over): then all balance with the recovery's gains."""
    return any(c.recovery.active for c in characters)


def advance(client: int, characters: Sequence[Stepped], dt: float) -> int:
    """One physics step of ``dt`` for ``characters`` (all in ``client``): their control and pybullet's step,
    split into ``substeps_of(characters)`` equal steps. Returns that number."""
    n = substeps_of(characters)
    recovering = n > 1 and any_recovering(characters)
    for c in characters:
        c.stepped_finely = recovering
    if n > 1:
        p.setPhysicsEngineParameter(fixedTimeStep=dt / n, physicsClientId=client)
    for _ in range(n):
        for c in characters:
            c.step_control(dt / n)
        p.stepSimulation(physicsClientId=client)
    if n > 1:
        p.setPhysicsEngineParameter(fixedTimeStep=dt, physicsClientId=client)
    return n
