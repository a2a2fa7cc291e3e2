"""The world in pybullet DIRECT: standing, walking, shoves, falls, stand-ups, bounds, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interaction.types import BodyObservation, Contactor, Impulse
from sim.config import CharacterSpec, WorldConfig
from sim.snapshot import CharacterState, WorldSnapshot
from sim.world import World

DT = WorldConfig().control_dt
S = CharacterState


def _world(seed: int = 0, **cfg: float) -> World:
    return World(WorldConfig(**cfg), np.random.default_rng(seed))  # type: ignore[arg-type]


def _shove(world: World, name: str, speed: float, travel: float, along: tuple[float, float],
           height: float = 1.2, seconds: float = 10.0) -> list[WorldSnapshot]:
    """A hand (sphere, r = 0.1 m) starting just behind the character moves ``travel`` m at ``speed`` m/s
    along ``along``, then leaves; the world runs for ``seconds``. Returns every snapshot."""
    spec = world.character(name).spec
    c = world.snapshot().characters[0].position
    ux, uy = along
    start = spec.half_depth + 0.12  # contact distance along the push for the body's front/back
    n_push = round(travel / speed / DT)
    out = []
    for i in range(round(seconds / DT)):
        if i < n_push:
            d = -start + speed * i * DT
            hand = Contactor(person=3, part="hand", position=(c[0] + ux * d, c[1] + uy * d, height),
                             velocity=(ux * speed, uy * speed, 0.0), radius=0.1)
            obs: BodyObservation | None = BodyObservation(t=world.t, contactors=(hand,))
        elif i == n_push:
            obs = BodyObservation(t=world.t)
        else:
            obs = None
        out.append(world.step(obs, DT))
    return out


def _after_states(snaps: list[WorldSnapshot]) -> list[CharacterState]:
    return [ch.after for s in snaps for ch in s.changes]


def test_alone_it_stays_upright_and_walks_to_the_person_it_approaches() -> None:
    with _world() as w:
        name = w.add_character(CharacterSpec(), (-2.0, 0.0), 0.0, intent="approach")
        person = Contactor(person=1, part="head", position=(2.0, 0.5, 1.6), velocity=(0.0, 0.0, 0.0), radius=0.1)
        worst_tilt = 0.0
        for _ in range(round(10.0 / DT)):
            s = w.step(BodyObservation(t=w.t, contactors=(person,)), DT)
            ch = s.characters[0]
            worst_tilt = max(worst_tilt, abs(ch.tilt[0]), abs(ch.tilt[1]))
            assert ch.state is S.WALK and ch.name == name
        assert s.t == pytest.approx(10.0)
        assert worst_tilt < math.radians(5.0)
        x, y, z = ch.position
        dist = math.hypot(2.0 - x, 0.5 - y)
        spec = CharacterSpec()
        assert dist == pytest.approx(spec.approach_distance, abs=0.25)  # arrived and stopped
        assert math.hypot(*ch.velocity[:2]) < 0.1
        assert z == pytest.approx(spec.com_height, abs=0.02)
        assert abs(ch.heading - math.atan2(0.5 - y, 2.0 - x)) < 0.2  # faces the person
        assert ch.d_front > 3.0  # eq. 6: it walked forward ~3.3 m
        assert abs(ch.d_side) < 0.3
        assert ch.behaviour == "walk" and ch.intent == "approach"


def test_wandering_keeps_upright_on_the_stage_and_moves() -> None:
    with _world(seed=4) as w:
        w.add_character(CharacterSpec(), (0.0, 0.0), 1.0, intent="wander")
        path = 0.0
        last = (0.0, 0.0)
        for _ in range(round(10.0 / DT)):
            ch = w.step(None, DT).characters[0]
            assert ch.state is S.WALK
            assert -3.0 < ch.position[0] < 3.0 and -1.0 < ch.position[1] < 1.0
            path += math.hypot(ch.position[0] - last[0], ch.position[1] - last[1])
            last = ch.position[:2]
        assert path > 2.0


def test_weak_shove_staggers_then_walks_again() -> None:
    with _world() as w:
        name = w.add_character(CharacterSpec(), (0.0, 0.0), 0.0, intent="idle")
        # 1.5 m/s: under the person's force budget (sim.person_contact) a 1 m/s hand only slides it (tilt 0.04 rad)
        snaps = _shove(w, name, speed=1.5, travel=0.3, along=(1.0, 0.0), seconds=4.0)
        states = _after_states(snaps)
        assert states[:2] == [S.STAGGER, S.WALK] and S.FALL not in states
        assert max(s.characters[0].contact_force_n for s in snaps) > 0.0
        assert snaps[-1].characters[0].state is S.WALK


@pytest.mark.parametrize(("heading", "from_behind"), [(0.7, True), (0.7, False), (-2.0, True)])
def test_strong_shove_falls_the_way_it_was_pushed_lies_and_stands_up(heading: float, from_behind: bool) -> None:
    with _world() as w:
        spec = CharacterSpec()
        name = w.add_character(spec, (0.0, 0.0), heading, intent="idle")
        for _ in range(20):
            w.step(None, DT)
        fwd = (math.cos(heading), math.sin(heading))
        along = fwd if from_behind else (-fwd[0], -fwd[1])
        start = w.snapshot().characters[0].position
        snaps = _shove(w, name, speed=3.0, travel=0.5, along=along, seconds=10.0)
        states = _after_states(snaps)
        if states and states[0] is S.STAGGER:
            states = states[1:]
        assert states == [S.FALL, S.BRAKE, S.LIE, S.STAND_UP, S.WALK]
        # when it lay still: face down if pushed from behind, face up if pushed from the front
        lying = next(s.characters[0] for s in snaps if s.characters[0].state is S.LIE)
        assert lying.face_up is (not from_behind)
        # it fell along the push: the centre of mass moved that way and the body axis points that way
        moved = (lying.position[0] - start[0], lying.position[1] - start[1])
        assert (moved[0] * along[0] + moved[1] * along[1]) / math.hypot(*moved) > 0.9
        tilt_x, tilt_z = lying.tilt
        assert abs(tilt_x) > math.radians(60) and abs(tilt_z) < math.radians(20)
        assert (tilt_x > 0) is from_behind  # leaning forward = lying on its face
        # and it is back on its feet, standing, within the 10 s
        end = snaps[-1].characters[0]
        assert end.state is S.WALK and abs(end.tilt[0]) < 0.1 and abs(end.tilt[1]) < 0.1
        stand_ups = [s for s in snaps if s.characters[0].state is S.STAND_UP]
        assert stand_ups and all(s.characters[0].behaviour == "stand_up" for s in stand_ups)
        assert stand_ups[-1].t - stand_ups[0].t > 0.5 * spec.getup_duration_s  # it rose, not teleported


def test_sideways_shove_lands_face_up_or_down_never_on_its_side() -> None:
    with _world() as w:
        name = w.add_character(CharacterSpec(), (0.0, 0.0), 0.0, intent="idle")
        snaps = _shove(w, name, speed=3.5, travel=0.5, along=(0.0, 1.0), seconds=6.0)
        assert S.LIE in _after_states(snaps)
        lying = next(s.characters[0] for s in snaps if s.characters[0].state is S.LIE)
        assert lying.face_up is not None
        assert lying.position[1] > 0.3  # went the way it was pushed (+y)
        assert lying.position[2] < 0.25  # low: lying on its front or back, not propped on its side


def test_control_bounds_are_never_exceeded() -> None:
    """Bounds from the controller's record, and independently from the physics: upright, with friction
    0 against the floor, the only horizontal force is the legs' f_F, so M |Δv| / dt ≤ leg_force_max."""
    with _world(seed=2) as w:
        spec = CharacterSpec()
        name = w.add_character(spec, (0.0, 0.0), 0.3, intent="wander")
        snaps = [w.step(None, DT) for _ in range(240)]
        snaps += _shove(w, name, speed=1.5, travel=0.3, along=(0.0, -1.0), seconds=2.0)
        snaps += _shove(w, name, speed=3.5, travel=0.5, along=(1.0, 0.0), seconds=8.0)
        ch = w.character(name)
        assert ch.peak_torque_ratio <= 1.0 + 1e-9 and ch.peak_friction_ratio <= 1.0 + 1e-9
        assert ch.peak_torque_ratio > 0.5  # the checks saw real work
        checked = 0
        for before, after in zip(snaps, snaps[1:], strict=False):
            a, b = before.characters[0], after.characters[0]
            if b.state not in (S.WALK, S.STAGGER) or a.contact_force_n > 0 or b.contact_force_n > 0:
                continue
            dv = math.hypot(b.velocity[0] - a.velocity[0], b.velocity[1] - a.velocity[1])
            assert spec.mass * dv / DT <= spec.leg_force_max * (1 + 1e-6) + 1e-6
            checked += 1
        assert checked > 300


def test_same_seed_and_inputs_give_identical_snapshots() -> None:
    def run(seed: int) -> list[WorldSnapshot]:
        with _world(seed=seed) as w:
            spec = CharacterSpec()
            for i in range(3):
                w.add_character(spec, (-1.5 + 1.5 * i, 0.2 * i), 0.5 * i, intent="wander")
            out = []
            for k in range(240):
                hand = Contactor(person=1, part="hand", position=(-2.5 + 0.02 * k, 0.0, 1.1),
                                 velocity=(1.2, 0.0, 0.0), radius=0.1, half_depth=0.3 if k % 2 else 0.0)
                imp = (Impulse(position=(0.0, 0.0, 1.2), force=(0.0, 400.0, 0.0), duration=0.1, source="pad"),) \
                    if k == 100 else ()
                out.append(w.step(BodyObservation(t=k * DT, contactors=(hand,), impulses=imp), DT))
            return out

    a, b, c = run(11), run(11), run(12)
    assert a == b
    assert a != c  # the seed matters (wander targets)


def test_catch_up_is_capped_and_dropped_time_reported() -> None:
    with _world() as w:
        w.add_character(CharacterSpec(), (0.0, 0.0), 0.0)
        cap = w.config.max_catchup_ticks
        s = w.step(None, 1.0)
        assert s.t == pytest.approx(cap * DT)
        assert s.steps == cap * w.config.n_substeps
        assert s.dropped_time == pytest.approx(1.0 - cap * DT)
        assert w.counters.dropped_ticks == round(1.0 / DT) - cap
        s = w.step(None, 0.5 * DT)  # less than a tick: waits
        assert s.t == pytest.approx(cap * DT) and s.dropped_time == 0.0
        s = w.step(None, 0.5 * DT)
        assert s.t == pytest.approx((cap + 1) * DT)


def test_close_is_idempotent_and_names_are_unique() -> None:
    w = _world()
    spec = CharacterSpec(name="kid")
    assert [w.add_character(spec, (float(i), 0.0), 0.0) for i in range(3)] == ["kid", "kid-2", "kid-3"]
    with pytest.raises(ValueError, match="intent"):
        w.add_character(spec, (0.0, 0.5), 0.0, intent="dance")
    w.close()
    w.close()
    with pytest.raises(RuntimeError):
        w.step(None, DT)
