"""Recovering from a push: finer physics steps, the recovery's gains and braced joints, until it walks again.

From a push, a person's contact, a stagger or a fall on, a character asks for ``spec.recovery_substeps``
physics steps per world step (``wanted_substeps``; 1: never), and whoever steps the world (``World``,
``jostle bench ragdoll``, tests: ``advance``) steps every body that finely while any character asks.
While it recovers, or is stepped finely for another's recovery (``stepped_finely``), a character uses
``recovering_spec``: its own foot-placement gains, pelvis torque limit and state loads. Its joints
(``Recovery.brace``): falling or lying, the neck goes limp to ``recovery_neck_gain`` and every joint
within ``brace_margin_deg`` of a limit is held where it is at ``brace_gain`` × its gains; upright or
getting up, a joint past a limit is driven ``limit_stop_inside_deg`` back inside. It settles after
``recovery_settle_s`` of unpushed walking, then hands over to the walking gains over
``recovery_handover_s`` (s) before going back to the world's step.
Why, with the figures measured, what was tried and its weaknesses: docs/notes/recovery.md.
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
