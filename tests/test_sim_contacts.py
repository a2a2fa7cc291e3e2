"""People in the world: contact episodes and events, pad impulses, bad input, recovery."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interaction.types import BodyObservation, Contactor, Impulse
from sim.config import CharacterSpec, WorldConfig
from sim.contactors import ContactEpisodes
from sim.snapshot import PAD_PERSON, CharacterState, ContactEvent, StateChange
from sim.world import World

DT = WorldConfig().control_dt
PHYS = 1 / 240


def _world(seed: int = 0) -> World:
    return World(WorldConfig(), np.random.default_rng(seed))


def test_episodes_join_close_contacts_and_split_after_the_gap() -> None:
    ep = ContactEpisodes(gap_s=0.1)
    for k in range(1, 11):  # 10 steps of 100 N: 0.0417 s
        ep.add(k * PHYS, "a", 1, 100.0, PHYS)
    ep.add(0.08, "a", 1, 300.0, PHYS)  # 0.038 s later: same episode
    assert ep.close(0.15, lambda _: 5.0) == []  # only 0.07 s since the last contact
    (ev,) = ep.close(0.18, lambda _: 5.0)
    assert ev.impulse_ns == pytest.approx(100.0 * 10 * PHYS + 300.0 * PHYS)
    assert ev.peak_force_n == 300.0 and ev.push is True  # 5.42 N·s ≥ 5
    assert ev.t_start == pytest.approx(0.0) and ev.t_end == pytest.approx(0.08)


def test_episode_push_flag_follows_the_threshold_and_pairs_are_separate() -> None:
    ep = ContactEpisodes(gap_s=0.1)
    ep.add(0.01, "a", 1, 1000.0, 0.01)  # 10 N·s
    ep.add(0.01, "b", 1, 1000.0, 0.02)  # 20 N·s
    ep.add(0.01, "a", 2, 0.0, 0.01)  # no force: no episode
    events = {e.character: e for e in ep.close(1.0, lambda name: 15.0)}
    assert set(events) == {"a", "b"}
    assert events["a"].push is False and events["b"].push is True


def _touch(world: World, speed: float, travel: float, height: float = 1.2, person: int = 5,
           seconds: float = 1.0) -> list[ContactEvent]:
    c = world.snapshot().characters[0].position
    spec = world.character(world.snapshot().characters[0].name).spec
    start = spec.half_depth + 0.12
    n_push = max(1, round(travel / speed / DT))
    events: list[ContactEvent] = []
    for i in range(round(seconds / DT)):
        if i < n_push:
            hand = Contactor(person=person, part="hand", position=(c[0] - start + speed * i * DT, c[1], height),
                             velocity=(speed, 0.0, 0.0), radius=0.1)
            obs: BodyObservation | None = BodyObservation(t=world.t, contactors=(hand,))
        else:
            obs = BodyObservation(t=world.t) if i == n_push else None
        events += world.step(obs, DT).contacts
    return events


def test_a_gentle_touch_is_not_a_push_and_a_shove_is() -> None:
    with _world() as w:
        spec = CharacterSpec()
        w.add_character(spec, (0.0, 0.0), 0.0, intent="idle")
        gentle = _touch(w, speed=0.15, travel=0.06)
        assert len(gentle) == 1 and gentle[0].person == 5
        assert 0.0 < gentle[0].impulse_ns < spec.push_threshold_ns and not gentle[0].push
    with _world() as w:
        w.add_character(spec, (0.0, 0.0), 0.0, intent="idle")
        shove = _touch(w, speed=1.5, travel=0.3)
        assert len(shove) == 1 and shove[0].push and shove[0].impulse_ns >= spec.push_threshold_ns
        assert shove[0].peak_force_n > 0.0 and shove[0].t_end >= shove[0].t_start


def test_capsule_contactors_lie_along_stage_y() -> None:
    """A webcam-style capsule (half_depth 1 m along y) centred at y = 0 hits a character standing at
    y = 0.6; a sphere at the same centre passes by."""
    for half_depth, hits in ((1.0, True), (0.0, False)):
        with _world() as w:
            w.add_character(CharacterSpec(), (0.0, 0.6), 0.0, intent="idle")
            events: list[ContactEvent] = []
            for i in range(40):
                bar = Contactor(person=4, part="outline", position=(-0.6 + 1.2 * i * DT, 0.0, 1.0),
                                velocity=(1.2, 0.0, 0.0), radius=0.1, half_depth=half_depth)
                obs = BodyObservation(t=w.t, contactors=(bar,) if i < 30 else ())
                events += w.step(obs, DT).contacts
            assert bool(events) is hits


def test_impact_impulse_matches_the_momentum_it_gave() -> None:
    """A 3 m/s hand hits once (rigid impact): the recorded ∫F dt equals the body's change of momentum."""
    with _world() as w:
        spec = CharacterSpec()
        w.add_character(spec, (0.0, 0.0), 0.0, intent="idle")
        before = w.snapshot().characters[0].velocity
        c = w.snapshot().characters[0].position
        hand = Contactor(person=1, part="hand", position=(c[0] - spec.half_depth - 0.11, 0.0, c[2]),
                         velocity=(3.0, 0.0, 0.0), radius=0.1)
        after = w.step(BodyObservation(t=0.0, contactors=(hand,)), DT).characters[0].velocity
        events: list[ContactEvent] = []
        for _ in range(20):
            events += w.step(BodyObservation(t=w.t), DT).contacts
        (ev,) = events
        momentum = spec.mass * (after[0] - before[0])
        assert ev.impulse_ns == pytest.approx(momentum, rel=0.12)
        assert ev.push


def test_pad_impulse_pushes_the_nearest_character_and_is_applied_once() -> None:
    with _world() as w:
        spec = CharacterSpec()
        near = w.add_character(spec, (1.5, 0.0), 0.0, intent="idle")
        far = w.add_character(spec, (-1.5, 0.0), 0.0, intent="idle")
        hit = Impulse(position=(1.4, 0.0, spec.com_height), force=(150.0, 0.0, 0.0), duration=0.1, source="pad0")
        events: list[ContactEvent] = []
        for k in range(30):  # the same report re-sent for the first frames, while the hit still acts
            s = w.step(BodyObservation(t=0.0, impulses=(hit,)) if k < 3 else None, DT)
            events += s.contacts
        (ev,) = events
        assert ev.person == PAD_PERSON and ev.character == near
        assert ev.impulse_ns == pytest.approx(15.0) and ev.push is False
        by_name = {c.name: c for c in s.characters}
        # 15 N·s at the centre of mass of 40 kg: 0.375 m/s at first; the controller then brings it back
        assert by_name[near].position[0] > 1.5 + 0.05
        assert abs(by_name[far].position[0] + 1.5) < 0.01


def test_nan_and_absurd_inputs_are_dropped_or_clamped_and_counted() -> None:
    with _world() as w:
        w.add_character(CharacterSpec(), (0.0, 0.0), 0.0, intent="idle")
        nan = math.nan
        obs = BodyObservation(
            t=0.0,
            contactors=(
                Contactor(person=1, part="hand", position=(nan, 0.0, 1.0), velocity=(0.0, 0.0, 0.0), radius=0.1),
                Contactor(person=1, part="hand", position=(2.0, 0.0, 1.0), velocity=(nan, 1e9, 0.0), radius=0.1),
                Contactor(person=1, part="head", position=(2.5, 0.5, 1.6), velocity=(1e6, 0.0, 0.0), radius=50.0),
                Contactor(person=2, part="hand", position=(2.0, 0.5, 1.0), velocity=(0.0, 0.0, 0.0),
                          radius=math.inf),
            ),
            impulses=(
                Impulse(position=(0.0, 0.0, 1.0), force=(nan, 0.0, 0.0), duration=0.1, source="pad"),
                Impulse(position=(0.0, 0.0, 1.0), force=(1e12, 0.0, 0.0), duration=0.05, source="pad"),
                Impulse(position=(0.0, 0.0, 1.0), force=(10.0, 0.0, 0.0), duration=math.inf, source="pad"),
            ),
        )
        s = w.step(obs, DT)
        counters = w.counters
        assert counters.rejected_inputs == 4  # NaN position, inf radius, NaN force, inf duration
        assert counters.clamped_inputs == 4  # NaN velocity (zeroed), 1e6 m/s, 50 m radius, the 1e12 N
        s = w.step(None, math.nan)  # a broken dt is counted too, and advances nothing
        assert w.counters.clamped_inputs == 5 and s.t == pytest.approx(DT)
        for _ in range(120):
            s = w.step(None, DT)
        ch = s.characters[0]
        assert all(math.isfinite(v) for v in (*ch.position, *ch.velocity, *ch.orientation))
        assert w.counters.non_finite_controls == 0
        # the 1e12 N pad was cut to max_impulse_force_n: 3000 N × 0.05 s = 150 N·s, a hard knock, not a launch
        assert math.hypot(*ch.velocity) < 10.0


def test_character_off_the_stage_is_put_back() -> None:
    with _world() as w:
        w.add_character(CharacterSpec(), (9.0, 0.0), 0.0, intent="idle")
        s = w.step(None, DT)
        assert w.counters.recovered_characters == 1
        x, y, _ = s.characters[0].position
        assert -3.0 <= x <= 3.0 and -1.0 <= y <= 1.0
        for _ in range(60):
            s = w.step(None, DT)
        assert s.characters[0].state is CharacterState.WALK


def test_a_character_fallen_for_too_long_is_stood_up() -> None:
    cfg = WorldConfig(stuck_timeout_s=1.0)
    spec = CharacterSpec(lie_duration_s=30.0)  # would lie for 30 s
    with World(cfg, np.random.default_rng(0)) as w:
        w.add_character(spec, (0.0, 0.0), 0.0, intent="idle")
        hit = Impulse(position=(0.0, 0.0, 1.3), force=(1500.0, 0.0, 0.0), duration=0.1, source="pad")
        w.step(BodyObservation(t=0.0, impulses=(hit,)), DT)
        changes: list[StateChange] = []
        for _ in range(round(3.0 / DT)):
            changes += w.step(None, DT).changes
        assert CharacterState.FALL in [c.after for c in changes]
        assert w.counters.recovered_characters == 1
        assert changes[-1].after is CharacterState.WALK
