"""The people's contact law (``sim.person_contact``): the force budget, push-out, pushes along the motion."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pytest

from interaction.types import BodyObservation, Contactor
from sim.config import CharacterSpec, WorldConfig
from sim.person_contact import PairForce
from sim.snapshot import CharacterState
from sim.world import World

DT = WorldConfig().control_dt
BUDGET = WorldConfig().max_person_force_n


def _record_totals(world: World) -> list[dict[int, float]]:
    """Wrap the world's contact law so every substep's total per person (N) is kept."""
    law = world._law
    apply = law.apply
    totals: list[dict[int, float]] = []

    def recorded(contactors: Mapping[int, Contactor], dt: float, ahead: float = 0.0) -> PairForce:
        pairs = apply(contactors, dt, ahead)
        per: dict[int, float] = {}
        for (_, person), f in pairs.items():
            per[person] = per.get(person, 0.0) + f
        totals.append(per)
        return pairs

    law.apply = recorded  # type: ignore[method-assign]
    return totals


def _crowd(c: tuple[float, float, float], person: int, n: int = 12) -> tuple[Contactor, ...]:
    """``n`` hands of one person around and inside a character, all moving into it at 3 m/s."""
    hands = []
    for k in range(n):
        a = 2 * math.pi * k / n
        pos = (c[0] + 0.15 * math.cos(a), c[1] + 0.15 * math.sin(a), 0.6 + 0.08 * k)
        hands.append(Contactor(person=person, part="hand", position=pos,
                               velocity=(-3.0 * math.cos(a), -3.0 * math.sin(a), 0.0), radius=0.15))
    return tuple(hands)


def test_the_budget_holds_over_a_crowded_run() -> None:
    """Many contactors on one character, a silhouette appearing inside bodies, a fallen character under a
    person: every substep, each person's total force stays within the budget (and reaches it)."""
    with World(WorldConfig(), np.random.default_rng(0)) as w:
        a = w.add_character(CharacterSpec(), (0.0, 0.0), 0.0, intent="idle")
        w.add_character(CharacterSpec(), (1.2, 0.0), 0.0, intent="idle")
        totals = _record_totals(w)
        w.strike(a, (0.0, 900.0, 0.0), 0.3, (0.0, 0.0, 0.4))  # a falls
        for _ in range(45):
            w.step(None, DT)
        assert w.character(a).state in (CharacterState.FALL, CharacterState.BRAKE, CharacterState.STAND_UP)
        peak = 0.0
        for i in range(60):
            snap = w.step(None, 0.0)
            at = {ch.name: ch.position for ch in snap.characters}
            people = _crowd(at[a], person=1)  # twelve hands on the fallen one, pressing down too
            wall = Contactor(person=2, part="outline", position=(1.2, 0.0, 1.0), velocity=(0.0, 0.0, -0.5),
                             radius=0.3, half_depth=1.0)  # a silhouette appearing inside the standing one
            pin = Contactor(person=1, part="foot", position=(at[a][0], at[a][1], at[a][2] + 0.1),
                            velocity=(0.0, 0.0, -2.0), radius=0.2)
            snap = w.step(BodyObservation(t=w.t, contactors=(*people, pin, wall) if i < 40 else ()), DT)
            peak = max([peak, *(ch.contact_force_n for ch in snap.characters)])
        worst = {person: max(t.get(person, 0.0) for t in totals) for person in (1, 2)}
        assert len(totals) >= 40 * WorldConfig().n_substeps
        assert all(v <= BUDGET * (1 + 1e-9) for t in totals for v in t.values())
        assert worst[1] > 0.95 * BUDGET and worst[2] > 0.5 * BUDGET, worst  # the crowd did press hard
        assert 0.0 < peak <= BUDGET * (1 + 1e-9)


def test_a_silhouette_inside_a_body_pushes_it_out_over_a_few_frames() -> None:
    with World(WorldConfig(), np.random.default_rng(0)) as w:
        w.add_character(CharacterSpec(), (0.0, 0.0), 0.0, intent="idle")
        for _ in range(20):
            w.step(None, DT)
        x0 = w.snapshot().characters[0].position
        body = Contactor(person=3, part="outline", position=(x0[0] - 0.1, 0.0, 1.0), velocity=(0.0, 0.0, 0.0),
                         radius=0.2, half_depth=0.3)
        moved = []
        for _ in range(20):
            pos = w.step(BodyObservation(t=w.t, contactors=(body,)), DT).characters[0].position
            moved.append(math.hypot(pos[0] - x0[0], pos[1] - x0[1]))
        assert moved[0] < 0.03, moved[:3]  # not out in one step
        assert moved[-1] > 0.25, moved  # but out within 20 frames (0.67 s)


def test_a_hand_moving_sideways_pushes_a_standing_character_sideways() -> None:
    """The character faces +x; a hand sweeps +y into its right side, 5 cm in front of its centre."""
    with World(WorldConfig(), np.random.default_rng(0)) as w:
        spec = CharacterSpec()
        w.add_character(spec, (0.0, 0.0), 0.0, intent="idle")
        for _ in range(20):
            w.step(None, DT)
        c0 = w.snapshot().characters[0].position
        for i in range(12):
            hand = Contactor(person=1, part="hand", position=(c0[0] + 0.05, c0[1] - 0.6 + 2.0 * i * DT, 1.1),
                             velocity=(0.0, 2.0, 0.0), radius=0.1)
            w.step(BodyObservation(t=w.t, contactors=(hand,)), DT)
        w.step(BodyObservation(t=w.t), DT)
        c1 = w.snapshot().characters[0].position
        dx, dy = c1[0] - c0[0], c1[1] - c0[1]
        assert dy > 0.05, (dx, dy)
        assert abs(math.degrees(math.atan2(dx, dy))) < 30.0, (dx, dy)


def _trace(seed: int) -> str:
    with World(WorldConfig(), np.random.default_rng(seed)) as w:
        w.add_character(CharacterSpec(), (0.0, 0.0), 0.0)
        w.add_character(CharacterSpec(), (0.6, 0.3), 1.0)
        out = []
        for i in range(40):
            hands = _crowd((0.3 * math.sin(i / 7), 0.1, 1.0), person=1, n=4)
            out.append(repr(w.step(BodyObservation(t=w.t, contactors=hands), DT)))
        return "".join(out)


def test_a_seed_and_the_same_input_give_the_same_trace() -> None:
    assert _trace(4) == _trace(4)


def test_the_budget_must_be_positive() -> None:
    with pytest.raises(ValueError, match="max_person_force_n"):
        WorldConfig(max_person_force_n=0.0)
