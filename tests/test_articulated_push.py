"""Pushing an articulated character: a small push and back to the clip; a large one, a fall and getting up;
the World hook (strike, contactors, snapshots, config)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pybullet as p

from interaction.types import BodyObservation, Contactor
from sim.articulated import balance as bal
from sim.articulated.character import ArticulatedCharacter
from sim.articulated.recovery import advance
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.config import WorldConfig
from sim.snapshot import CharacterState
from sim.world import World

DT = 1.0 / 240.0
ROOT = Path(__file__).resolve().parents[1]


def run(client: int, ch: ArticulatedCharacter, seconds: float, push_at: float | None = None,
        force: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> list[tuple[float, CharacterState, np.ndarray]]:
    """Step ``seconds``; push the pelvis at ``push_at`` for 0.2 s along the character's heading frame
    (force = forward, left, up). Returns (t, state, com) every 0.05 s."""
    out = []
    for i in range(int(round(seconds / DT))):
        if push_at is not None and abs(ch.t - push_at) < DT / 2:
            _, orn = ch.root()
            h = bal.heading_of(orn)
            f = (force[0] * math.cos(h) - force[1] * math.sin(h), force[0] * math.sin(h) + force[1] * math.cos(h),
                 force[2])
            ch.push("root", f, 0.2)
        advance(client, [ch], DT)
        if i % 12 == 11:
            out.append((ch.t, ch.state, ch.com_state()[0]))
    return out


def test_small_push_changes_the_motion_and_it_returns_to_the_clip(client: int, skeleton: ArticulatedSkeleton) -> None:
    quiet = ArticulatedCharacter(client, skeleton, ArticulatedSpec(), None, (0.0, 0.0), 0.0)
    pushed = ArticulatedCharacter(client, skeleton, ArticulatedSpec(), None, (0.0, 3.0), 0.0)
    p.setCollisionFilterPair(quiet.body, pushed.body, -1, -1, 0, physicsClientId=client)
    trace_q, trace_p = [], []
    for i in range(int(6.0 / DT)):
        if i == int(2.0 / DT):
            pushed.push("root", (150.0, 0.0, 0.0), 0.2)  # 30 N·s forward
        advance(client, [quiet, pushed], DT)
        if i % 12 == 11:
            trace_q.append((quiet.state, quiet.com_state()[0]))
            trace_p.append((pushed.state, pushed.com_state()[0], pushed.tracking_error_deg()))
    states = [s for s, *_ in trace_p]
    assert CharacterState.STAGGER in states and pushed.falls == 0 and quiet.falls == 0
    # the push moved it: it is ahead of its unpushed twin (same start, same clip) right after the push
    k = int(2.6 / 0.05)
    assert trace_p[k][1][0] - trace_q[k][1][0] > 0.05
    # and it goes back to the clip: tracking error in the last second like before the push
    before = np.mean([e for _, _, e in trace_p[10:40]])
    after = np.mean([e for _, _, e in trace_p[-20:]])
    assert after < before + 4.0
    assert states[-1] in (CharacterState.WALK, CharacterState.STAGGER)


def test_large_push_falls_lies_and_gets_up(client: int, skeleton: ArticulatedSkeleton) -> None:
    ch = ArticulatedCharacter(client, skeleton, ArticulatedSpec(), None, (0.0, 0.0), 0.0)
    trace = run(client, ch, 11.0, push_at=1.0, force=(700.0, 0.0, 0.0))
    states = [s for _, s, _ in trace]
    order = [CharacterState.FALL, CharacterState.LIE, CharacterState.STAND_UP, CharacterState.WALK]
    firsts = []
    for st in order:
        assert st in states, f"never {st}: {sorted(set(states))}"
        firsts.append(states.index(st, firsts[-1] if firsts else 0))
    assert firsts == sorted(firsts)
    t_fall = trace[firsts[0]][0]
    t_up = trace[firsts[3]][0]
    assert t_up - t_fall < 8.0  # standing again within 8 s (the bench's getup_success window)
    assert ch.getups == 1
    # assists are bounded by the spec and off while falling and lying
    spec = ch.spec
    assert ch.external_assist_peak_n <= max(spec.assist_force_max_n, spec.getup_assist_force_max_n) + 1e-9
    assert ch.limit_excess() < math.radians(10.0)


def test_world_carries_articulated_characters(tmp_path: Path) -> None:
    with World(WorldConfig(x_min=-6.0, x_max=6.0, y_min=-3.0, y_max=3.0), np.random.default_rng(1)) as world:
        name = world.add_character(ArticulatedSpec(), (-3.0, 0.0), 0.0)
        again = world.add_character(ArticulatedSpec(), (-3.0, 2.0), 0.0)
        assert (name, again) == ("ragdoll", "ragdoll-2")
        snaps = []
        for i in range(45):
            if i == 30:
                world.strike(name, (0.0, 900.0, 0.0), 0.2, (0.0, 0.0, 0.5))  # on the chest, to its left
            snaps.append(world.step(None, 1.0 / 30.0))
        first = {c.name: c for c in snaps[0].characters}[name]
        last = {c.name: c for c in snaps[-1].characters}[name]
        assert len(last.links) == 15 and last.links[0].name == "root" and last.kind == "ragdoll"
        assert last.position[0] > first.position[0] + 0.5  # walked forward (+x)
        changes = [c for s in snaps for c in s.changes if c.character == name]
        assert any(c.after == CharacterState.STAGGER for c in changes)
        # the link poses are the multibody's joints, stacked as a standing body's are
        z = {lp.name: lp.position[2] for lp in first.links}
        assert z["neck"] > z["chest"] > z["root"] > z["left_knee"] > z["left_ankle"] > 0.0


def test_a_contactor_hits_the_links_it_touches() -> None:
    """A person's hand (a kinematic sphere) walking into the character's chest pushes it and is reported."""
    with World(WorldConfig(x_min=-6.0, x_max=6.0, y_min=-3.0, y_max=3.0), np.random.default_rng(2)) as world:
        name = world.add_character(ArticulatedSpec(), (0.0, 0.0), 0.0)
        events = []
        hit_force = 0.0
        for i in range(40):
            snap = world.step(None, 1.0 / 30.0) if i < 10 else None
            if i >= 10:
                me = {c.name: c for c in world.snapshot().characters}[name]
                chest = {lp.name: lp.position for lp in me.links}["chest"]
                # a hand 0.3 m to its left moving right at 1.5 m/s, at chest height
                hand = Contactor(person=7, part="hand", position=(chest[0] + 0.05, chest[1] + 0.35 - 0.05 * (i - 10),
                                                                 chest[2] + 0.1),
                                 velocity=(0.0, -1.5, 0.0), radius=0.06)
                snap = world.step(BodyObservation(t=world.t, contactors=(hand,), people=1), 1.0 / 30.0)
                hit_force = max(hit_force, {c.name: c for c in snap.characters}[name].contact_force_n)
            assert snap is not None
            events += [e for e in snap.contacts if e.character == name]
        assert hit_force > 0.0
        assert any(e.person == 7 for e in events)
