"""Character AI: separation, approach, flee after a push, seeded wandering."""

from __future__ import annotations

import math

import numpy as np

from interaction.types import BodyObservation, Contactor
from sim.ai import CharacterAI, Stage, separation_velocities
from sim.config import CharacterSpec, WorldConfig
from sim.snapshot import CharacterState
from sim.world import World

DT = 1 / 60


def test_separation_pushes_apart_only_inside_personal_space() -> None:
    xy = np.array([[0.0, 0.0], [0.5, 0.0], [5.0, 0.0]])
    v = separation_velocities(xy, np.full(3, 1.0), np.full(3, 1.0))
    assert v[0, 0] < 0 < v[1, 0]  # the close pair moves apart along x
    assert np.allclose(v[0], -v[1]) and np.allclose(v[2], 0.0)
    assert np.allclose(v[0], [-0.5, 0.0])  # (1 − d/s)·speed
    assert separation_velocities(xy[:1], np.ones(1), np.ones(1)).shape == (1, 2)


def test_wander_targets_come_from_the_injected_generator_and_stay_on_stage() -> None:
    spec = CharacterSpec()
    stage = Stage(-3.0, 3.0, -1.0, 1.0)

    def goals(seed: int) -> list[tuple[float, float]]:
        ai = CharacterAI(spec, "wander", stage, np.random.default_rng(seed), 0.0)
        return [ai.decide(k * DT, 0.0, 0.0, CharacterState.WALK, (0.0, 0.0), None).velocity for k in range(3)]

    assert goals(1) == goals(1) and goals(1) != goals(2)
    ai = CharacterAI(spec, "wander", stage, np.random.default_rng(3), 0.0)
    for k in range(50):
        ai.decide(k * 10.0, 0.0, 0.0, CharacterState.WALK, (0.0, 0.0), None)
        wp = ai.waypoint
        assert wp is None or (-2.7 <= wp[0] <= 2.7 and -0.7 <= wp[1] <= 0.7)


def test_characters_approaching_one_person_keep_apart() -> None:
    spec = CharacterSpec()
    with World(WorldConfig(), np.random.default_rng(0)) as w:
        for i in range(3):
            w.add_character(spec, (-2.5, -0.6 + 0.6 * i), 0.0, intent="approach")
        person = Contactor(person=1, part="head", position=(2.0, 0.0, 1.6), velocity=(0.0, 0.0, 0.0), radius=0.1)
        closest = math.inf
        for _ in range(round(10 / DT)):
            s = w.step(BodyObservation(t=w.t, contactors=(person,)), DT)
            ps = [c.position for c in s.characters]
            assert all(c.state is CharacterState.WALK for c in s.characters)
            closest = min(closest, *(math.hypot(a[0] - b[0], a[1] - b[1]) for i, a in enumerate(ps) for b in ps[i + 1:]))
        assert closest > 2 * spec.half_width + 0.05  # never bumped into each other
        for c in s.characters:
            assert abs(math.hypot(2.0 - c.position[0], c.position[1]) - spec.approach_distance) < 0.2


def test_a_pushed_character_flees_from_the_pusher_then_calms_down() -> None:
    spec = CharacterSpec(flee_duration_s=2.0)
    with World(WorldConfig(), np.random.default_rng(0)) as w:
        w.add_character(spec, (-1.5, 0.0), 0.0, intent="idle")
        c = w.snapshot().characters[0].position
        pushed_at = None
        intents = []
        for i in range(round(5 / DT)):
            obs = None
            if i < 12:  # a hand from the -x side moving +x at 1.5 m/s
                hand = Contactor(person=2, part="hand", position=(c[0] - 0.26 + 1.5 * i * DT, 0.0, 1.2),
                                 velocity=(1.5, 0.0, 0.0), radius=0.1)
                obs = BodyObservation(t=w.t, contactors=(hand,))
            s = w.step(obs, DT)
            if pushed_at is None and any(e.push for e in s.contacts):
                pushed_at = (s.t, s.characters[0].position)
            intents.append(s.characters[0].intent)
        assert pushed_at is not None and "flee" in intents
        assert intents[-1] == "idle"
        flee_ticks = intents.count("flee")
        assert abs(flee_ticks * DT - spec.flee_duration_s) < 0.1
        # while fleeing it ran on, away from the hand (+x), beyond the shove itself
        i_end = len(intents) - 1 - intents[::-1].index("flee")
        assert s.characters[0].position[0] - pushed_at[1][0] > 1.0
        assert i_end * DT > pushed_at[0]
