"""Character AI: separation, approach, flee after a push, seeded wandering."""

from __future__ import annotations

import math

import numpy as np

from interaction.types import BodyObservation, Contactor, Impulse
from sim.config import CharacterSpec, WorldConfig
from sim.mitake.ai import Neighbours, Stage, decide, separation_velocities
from sim.mitake.balance import BalanceDesign
from sim.mitake.crowd import Crowd
from sim.snapshot import CharacterState
from sim.world import World

DT = WorldConfig().control_dt


def test_separation_pushes_apart_only_inside_personal_space() -> None:
    xy = np.array([[0.0, 0.0], [0.5, 0.0], [5.0, 0.0]])
    v = separation_velocities(xy, np.full(3, 1.0), np.full(3, 1.0))
    assert v[0, 0] < 0 < v[1, 0]  # the close pair moves apart along x
    assert np.allclose(v[0], -v[1]) and np.allclose(v[2], 0.0)
    assert np.allclose(v[0], [-0.5, 0.0])  # (1 − d/s)·speed
    assert separation_velocities(xy[:1], np.ones(1), np.ones(1)).shape == (1, 2)


def test_grid_neighbour_search_gives_the_all_pairs_answer() -> None:
    rng = np.random.default_rng(5)
    xy = rng.uniform(-6.0, 6.0, size=(300, 2))
    space = rng.uniform(0.5, 1.2, size=300)
    speed = rng.uniform(0.5, 2.0, size=300)
    diff = xy[:, None, :] - xy[None, :, :]
    dist = np.sqrt(np.sum(diff * diff, axis=2))
    np.fill_diagonal(dist, 1e6)
    weight = np.where(dist < space[:, None], (1.0 - dist / space[:, None]) / np.maximum(dist, 1e-6), 0.0)
    expected = np.sum(diff * (weight * speed[:, None])[:, :, None], axis=1)
    got = separation_velocities(xy, space, speed)
    assert np.count_nonzero(np.abs(expected).sum(axis=1)) > 50  # many characters are crowded
    assert np.allclose(got, expected, atol=1e-12)


def _crowd(n: int, spec: CharacterSpec, intent: str) -> Crowd:
    crowd = Crowd()
    design = BalanceDesign.for_spec(spec, 0.8, 9.81, DT)
    for i in range(n):
        crowd.add(f"c{i}", i, spec, design, intent, np.zeros((0, 2)), 0.0)
    return crowd


def test_wander_targets_come_from_the_injected_generator_and_stay_on_stage() -> None:
    spec = CharacterSpec()
    stage = Stage(-3.0, 3.0, -1.0, 1.0)

    def goals(seed: int) -> list[list[float]]:
        crowd = _crowd(4, spec, "wander")
        rng = np.random.default_rng(seed)
        out = []
        for k in range(3):
            decide(crowd, k * DT, stage, np.zeros((4, 2)), np.full((4, 2), np.nan), rng)
            out.append(crowd.goal_v.ravel().tolist())
        return out

    assert goals(1) == goals(1) and goals(1) != goals(2)
    crowd = _crowd(3, spec, "wander")
    rng = np.random.default_rng(3)
    for k in range(50):
        decide(crowd, k * 10.0, stage, np.zeros((3, 2)), np.full((3, 2), np.nan), rng)
        wp = crowd.waypoint[np.isfinite(crowd.waypoint[:, 0])]
        assert np.all((-2.7 <= wp[:, 0]) & (wp[:, 0] <= 2.7) & (-0.7 <= wp[:, 1]) & (wp[:, 1] <= 0.7))
        assert np.all(np.hypot(*crowd.goal_v.T) <= spec.walk_speed + 1e-9)


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


def test_follow_walks_the_waypoint_loop() -> None:
    square = (-1.5, -0.5, 1.5, -0.5, 1.5, 0.5, -1.5, 0.5)
    spec = CharacterSpec(waypoints=square)
    with World(WorldConfig(), np.random.default_rng(0)) as w:
        w.add_character(spec, (-1.5, -0.5), 0.0, intent="follow")
        visited: list[int] = []
        for _ in range(round(20 / DT)):
            ch = w.step(None, DT).characters[0]
            assert ch.state is CharacterState.WALK and ch.intent == "follow"
            corner = int(np.argmin([np.hypot(ch.position[0] - x, ch.position[1] - y)
                                    for x, y in zip(square[::2], square[1::2], strict=True)]))
            if np.hypot(ch.position[0] - square[2 * corner], ch.position[1] - square[2 * corner + 1]) < 0.3 \
                    and (not visited or visited[-1] != corner):
                visited.append(corner)
        # 8 m of loop at 0.8 m/s: it went round once and on, in order
        assert visited[:5] == [0, 1, 2, 3, 0]


def test_after_a_fall_it_takes_its_after_fall_intent_for_a_while() -> None:
    spec = CharacterSpec(after_fall_intent="flee", after_fall_s=3.0, flee_duration_s=0.5)
    with World(WorldConfig(), np.random.default_rng(0)) as w:
        name = w.add_character(spec, (0.0, 0.0), 0.0, intent="idle")
        w.step(BodyObservation(t=0.0, impulses=(
            Impulse(position=(0.0, 0.0, 1.3), force=(-1500.0, 0.0, 0.0), duration=0.1, source="pad"),)), DT)
        person = Contactor(person=1, part="head", position=(-2.5, 0.0, 1.6), velocity=(0.0, 0.0, 0.0), radius=0.1)
        stood_up_at = None
        intents = []
        for _ in range(round(14 / DT)):
            s = w.step(BodyObservation(t=w.t, contactors=(person,)), DT)
            if any(c.before is CharacterState.STAND_UP and c.after is CharacterState.WALK for c in s.changes):
                stood_up_at = s.t
            if stood_up_at is not None:
                intents.append((s.t - stood_up_at, s.characters[0].intent))
        assert stood_up_at is not None and w.character(name).state is CharacterState.WALK
        assert {i for dt, i in intents if dt < 2.9} == {"flee"}  # away from the person, after the fall
        assert {i for dt, i in intents if dt > 3.1} == {"idle"}  # then itself again


def test_the_verlet_list_gives_the_same_separation_and_rebuilds_rarely() -> None:
    rng = np.random.default_rng(8)
    xy = rng.uniform(-8.0, 8.0, size=(200, 2))
    space, speed = np.full(200, 0.9), np.full(200, 1.6)
    kept = Neighbours(skin=0.6)
    for _ in range(40):  # everyone walks 2 cm per call, in its own direction
        xy = xy + rng.normal(size=(200, 2)) * 0.02
        assert np.allclose(separation_velocities(xy, space, speed, kept), separation_velocities(xy, space, speed),
                           atol=1e-12)
    assert 1 < kept.builds < 20
