"""People push limbs (issue 9): a push acts on the link it touches. A shove on the shoulder turns the
torso (the same push on the pelvis barely does); a kick on the shin of the swinging leg trips the
character: it falls face down over the kicked foot, where the same push on the pelvis throws it on its back.

Each case runs twins side by side in one world (collisions between them off), same clip, same start:
the unpushed twin is the reference."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from sim.articulated import balance as bal
from sim.articulated.character import ArticulatedCharacter
from sim.articulated.recovery import advance
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.snapshot import CharacterState

DT = 1.0 / 240.0


def twins(client: int, skeleton: ArticulatedSkeleton, n: int) -> list[ArticulatedCharacter]:
    chars = [ArticulatedCharacter(client, skeleton, ArticulatedSpec(), None, (0.0, 3.0 * k), 0.0) for k in range(n)]
    for a in chars:
        for b in chars:
            if a is not b:
                p.setCollisionFilterPair(a.body, b.body, -1, -1, 0, physicsClientId=client)
    return chars


def step(client: int, chars: list[ArticulatedCharacter]) -> None:
    advance(client, chars, DT)


def chest_heading(ch: ArticulatedCharacter) -> float:
    chest = {lp.name: lp for lp in ch.link_poses()}["chest"]
    return bal.heading_of(np.array(chest.orientation))


def walk_to(client: int, chars: list[ArticulatedCharacter], t: float) -> None:
    while chars[0].t < t - DT / 2:
        step(client, chars)


def backward(ch: ArticulatedCharacter, newtons: float) -> tuple[float, float, float]:
    """A force against the character's walking heading."""
    h = bal.heading_of(ch.root()[1])
    return (-newtons * math.cos(h), -newtons * math.sin(h), 0.0)


@pytest.mark.parametrize("side", ["right", "left"])
def test_a_shove_on_the_shoulder_turns_the_torso(client: int, skeleton: ArticulatedSkeleton, side: str) -> None:
    quiet, pelvis, shoulder = twins(client, skeleton, 3)
    walk_to(client, [quiet, pelvis, shoulder], 2.15)
    pelvis.push("root", backward(pelvis, 150.0), 0.2)  # 30 N·s against the walk
    shoulder.push(f"{side}_shoulder", backward(shoulder, 150.0), 0.2)
    turn = {"pelvis": 0.0, "shoulder": 0.0}
    for _ in range(round(0.6 / DT)):
        step(client, [quiet, pelvis, shoulder])
        ref = chest_heading(quiet)
        for key, ch in (("pelvis", pelvis), ("shoulder", shoulder)):
            d = (chest_heading(ch) - ref + math.pi) % (2 * math.pi) - math.pi
            if abs(d) > abs(turn[key]):
                turn[key] = d
    # pushed back on the right shoulder, the torso turns right (clockwise seen from above); on the left, left
    expected = -1.0 if side == "right" else 1.0
    assert expected * turn["shoulder"] > math.radians(10.0), turn
    assert abs(turn["pelvis"]) < 0.5 * abs(turn["shoulder"]), turn


def test_a_kick_on_the_swinging_shin_trips_it_forward(client: int, skeleton: ArticulatedSkeleton) -> None:
    """Eight walking phases 0.05 s apart while the right leg swings; at each, one twin is kicked on the right
    ankle (80 N·s) and one pushed on the pelvis (120 N·s), against the walk. Which way a body falls at one
    phase is chaotic, so the claim is about all eight: a kick that brings it down trips it face down (forward
    over the swept foot), a push on the pelvis throws it on its back. Recovering at finer steps (the default)
    it takes more than it did at the world's step (40 N·s each then): measured, 80 N·s on the pelvis felled
    1 of 8, 120 N·s on the shin threw 7 of 8 on their backs (the legs swept out from under it)."""
    phases = [2.0 + 0.05 * k for k in range(8)]
    cases = [(t, link) for t in phases for link in ("right_ankle", "root")]
    chars = twins(client, skeleton, len(cases))
    landed: dict[tuple[float, str], bool] = {}  # case → face up when it came to lie
    for _ in range(round((phases[-1] + 2.5) / DT)):
        for (t, link), ch in zip(cases, chars, strict=True):
            if abs(ch.t - t) < DT / 2:
                ch.push(link, backward(ch, 800.0 if link == "right_ankle" else 1200.0), 0.1)
        step(client, chars)
        for case, ch in zip(cases, chars, strict=True):
            if case not in landed and ch.state == CharacterState.LIE:
                landed[case] = bal.face_up(ch.root()[1])
    kicked = [up for (_, link), up in landed.items() if link == "right_ankle"]
    pushed = [up for (_, link), up in landed.items() if link == "root"]
    assert kicked.count(False) >= 2 and kicked.count(False) > kicked.count(True), landed
    assert pushed.count(True) >= 2 and pushed.count(True) > pushed.count(False), landed
