"""Joint limits (issue 9): pybullet itself holds the ball/universal joints inside their limits (the spherical
joint limit of the URDF the body is loaded from, ``sim.articulated.joint_limit``), in every state; hinges keep
their ranges; what the character measures as the excess is what the engine limits."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from sim.articulated import balance as bal
from sim.articulated.build import urdf_text
from sim.articulated.character import ArticulatedCharacter
from sim.articulated.joint_limit import clamp_inside, limit_angles, limit_angles_one, limit_excess
from sim.articulated.recovery import advance
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.snapshot import CharacterState

DT = 1.0 / 240.0
# Bound on the excess, every joint, every step of a walk, a push, a fall, lying and a get-up. The engine's
# limits are one-sided constraints that correct a small share of a violation per step (see the next test), and the
# spherical limit's rows act along the child frame's axes, not exactly along the angles it measures, so an
# impact can carry a joint a few degrees past its limit for a few steps. Measured in this run: 4.5° at worst
# pushed back (an ankle, falling), 5.8° pushed forward (a knee, falling), under 2.5° while walking,
# staggering or getting up — against 11–21° with the former explicit stops and 22–42° where they were off.
# (Harder cases, sideways pushes just short of a fall, are measured by ``jostle bench ragdoll``:
# ``joint_limit_excess_deg``.)
BOUND_DEG = 7.0


@pytest.mark.parametrize("force", [-600.0, 600.0])  # pushed back: falls face up; forward: face down
def test_limits_hold_through_a_walk_a_push_a_fall_and_a_get_up(client: int, skeleton: ArticulatedSkeleton,
                                                               force: float) -> None:
    ch = ArticulatedCharacter(client, skeleton, ArticulatedSpec(), None, (0.0, 0.0), 0.0)
    worst: dict[str, float] = {}
    states: list[CharacterState] = []
    for i in range(int(10.0 / DT)):
        if i == int(1.0 / DT):  # a 0.2 s push on the pelvis, 600 N: it falls
            h = bal.heading_of(ch.root()[1])
            ch.push("root", (force * math.cos(h), force * math.sin(h), 0.0), 0.2)
        advance(client, [ch], DT)
        e = ch.tracker.limits.excess(ch.joint_angles())
        assert np.isfinite(e).all()
        assert ch.limit_excess() == pytest.approx(float(e.max()), abs=1e-9)  # the float path, joint by joint
        for k in np.nonzero(e > 0.0)[0]:
            key = f"{ch.state.name}:{skeleton.links[ch.driven[k]].name}"
            worst[key] = max(worst.get(key, 0.0), math.degrees(float(e[k])))
        if not states or states[-1] != ch.state:
            states.append(ch.state)
    order = [CharacterState.WALK, CharacterState.FALL, CharacterState.LIE, CharacterState.STAND_UP]
    seen = iter(states)
    assert all(s in seen for s in order), states  # it went through what the test claims, in this order
    report = {k: round(v, 1) for k, v in worst.items()}
    assert all(deg <= BOUND_DEG for deg in worst.values()), sorted(report.items(), key=lambda kv: -kv[1])


def _one_joint_body(client: int, ranges: tuple[float, float, float]) -> int:
    """A fixed base and one free link on a spherical joint limited to ``ranges`` (x, y, z), as urdf_text
    writes limits."""
    text = (f'<robot name="j"><link name="a"><inertial><mass value="0"/><inertia ixx="0.1" iyy="0.1" izz="0.1" '
            f'ixy="0" ixz="0" iyz="0"/></inertial></link><link name="b"><inertial><origin xyz="0 0 0.2"/>'
            f'<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
            f'</link><joint name="j" type="spherical"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
            f'<limit lower="{ranges[0]}" upper="{ranges[1]}" twist="{ranges[2]}" effort="1000"/></joint></robot>')
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "j.urdf"
        path.write_text(text)
        body = int(p.loadURDF(str(path), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE,
                              physicsClientId=client))
    p.setJointMotorControlMultiDof(body, 0, p.POSITION_CONTROL, targetPosition=[0, 0, 0, 1], force=[0, 0, 0],
                                   physicsClientId=client)
    p.setGravity(0, 0, 0, physicsClientId=client)
    return body


def test_the_engine_stops_a_joint_at_its_range_about_each_axis(client: int) -> None:
    ranges = (0.5, 0.8, 0.3)
    body = _one_joint_body(client, ranges)
    for axis, limit in zip(np.eye(3), ranges, strict=True):  # a steady torque about each axis
        p.resetJointStateMultiDof(body, 0, [0, 0, 0, 1], [0, 0, 0], physicsClientId=client)
        for _ in range(480):
            p.applyExternalTorque(body, 0, (3.0 * axis).tolist(), p.WORLD_FRAME, physicsClientId=client)
            p.stepSimulation(physicsClientId=client)
        q = np.array(p.getJointStateMultiDof(body, 0, physicsClientId=client)[0])
        angle = 2.0 * math.acos(min(1.0, abs(float(q[3]))))
        assert angle == pytest.approx(limit, abs=0.01)  # free, 3 N·m for 2 s would turn it far beyond


def test_a_joint_thrown_past_its_limit_comes_back_slowly(client: int) -> None:
    """A measured trap of the engine's spherical limit: its rows ask back its own 0.2 of the excess times the
    solver's erp (pybullet's default 0.2, which the world keeps) per step, so a joint set 15° past its limit,
    at rest, goes back at 0.6° a step and is still 9° out after 10 steps. (At erp 1.0 it was inside in 5;
    the world keeps 0.2 because, measured, that made joints overshoot less but changed the walk enough that
    one walk-off after a get-up fell again: ``jostle bench ragdoll`` reports the overshoot.)"""
    ranges = (0.5, 0.8, 0.3)
    body = _one_joint_body(client, ranges)
    half = 0.5 * (ranges[2] + math.radians(15.0))
    past = [0.0, 0.0, math.sin(half), math.cos(half)]  # 15° past the twist range
    p.resetJointStateMultiDof(body, 0, past, [0, 0, 0], physicsClientId=client)
    out = []
    for _ in range(10):
        p.stepSimulation(physicsClientId=client)
        q = np.array(p.getJointStateMultiDof(body, 0, physicsClientId=client)[0])
        out.append(math.degrees(float(limit_excess(q[None], np.array([ranges]))[0])))
    assert out[0] == pytest.approx(14.4, abs=0.1)  # 0.2 × 0.2 of 15° in the first step
    assert out[9] == pytest.approx(9.0, abs=0.3)  # then on at that speed (the row holds no position)


def test_the_measured_excess_is_the_engines(client: int) -> None:
    """On random rotations, the engine pushes back exactly those ``limit_excess`` calls outside, and a
    rotation ``clamp_inside`` brought in is left alone."""
    ranges = np.array([0.5, 0.8, 0.3])
    body = _one_joint_body(client, (0.5, 0.8, 0.3))
    rng = np.random.default_rng(1)
    axes = rng.normal(size=(300, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    half = rng.uniform(0.0, 0.7, size=300)
    rots = np.concatenate([axes * np.sin(half)[:, None], np.cos(half)[:, None]], axis=1)
    outside = limit_excess(rots, np.tile(ranges, (300, 1))) > 0.0
    assert 50 < outside.sum() < 250  # both kinds are tried
    clamped = clamp_inside(rots, np.tile(ranges, (300, 1)))
    assert limit_excess(clamped, np.tile(ranges, (300, 1))).max() == 0.0
    for q, out, inside in zip(rots, outside, clamped, strict=True):
        assert np.allclose(limit_angles_one(q), limit_angles(q[None])[0], atol=1e-9)
        for rot, expect_push in ((q, out), (inside, False)):
            p.resetJointStateMultiDof(body, 0, rot.tolist(), [0, 0, 0], physicsClientId=client)
            p.stepSimulation(physicsClientId=client)
            moved = float(np.linalg.norm(p.getJointStateMultiDof(body, 0, physicsClientId=client)[1])) > 1e-6
            assert moved == bool(expect_push)


def test_the_body_carries_each_joints_limit(skeleton: ArticulatedSkeleton) -> None:
    text = urdf_text(skeleton)
    assert text.count('type="spherical"') == sum(link.kind in ("ball", "universal") for link in skeleton.links)
    assert text.count(" twist=") == text.count('type="spherical"')



def test_the_float_excess_is_the_vectorised_one(client: int, skeleton: ArticulatedSkeleton) -> None:
    """``limit_excess`` (per physics step in the bench) takes the float path joint by joint: the same figure
    as the vectorised measure on random rotations, signs flipped or not, hinges included."""
    limits = ArticulatedCharacter(client, skeleton, ArticulatedSpec(), None, (0.0, 0.0), 0.0).tracker.limits
    rng = np.random.default_rng(5)
    for k in range(500):
        rots = rng.normal(size=(len(limits.hinge), 4))
        rots /= np.linalg.norm(rots, axis=1, keepdims=True)
        if k % 2:
            rots = -rots
        assert limits.worst_excess(rots) == pytest.approx(float(limits.excess(rots).max()), abs=1e-9)
