"""An articulated character walking its clip: tracking, staying up, limits, determinism, explicit vs stable PD."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from sim.articulated.character import ArticulatedCharacter
from sim.articulated.recovery import advance
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.config import WorldConfig
from sim.physics import open_client
from sim.snapshot import CharacterState

DT = 1.0 / 240.0
UPRIGHT = (CharacterState.WALK, CharacterState.STAGGER)


def walk(client: int, skeleton: ArticulatedSkeleton, seconds: float, spec: ArticulatedSpec | None = None,
         heading: float = 0.0) -> tuple[ArticulatedCharacter, dict[str, list[float]]]:
    ch = ArticulatedCharacter(client, skeleton, spec or ArticulatedSpec(), None, (0.0, 0.0), heading)
    trace: dict[str, list[float]] = {"error": [], "excess": [], "x": [], "y": [], "up": []}
    for i in range(int(round(seconds / DT))):
        advance(client, [ch], DT)
        excess = ch.tracker.limits.excess(ch.joint_angles())  # every physics step
        trace["excess"].append(float(excess.max()))
        if i % 12 == 11:
            com, _ = ch.com_state()
            trace["error"].append(ch.tracking_error_deg())
            trace["x"].append(float(com[0]))
            trace["y"].append(float(com[1]))
            trace["up"].append(1.0 if ch.state in UPRIGHT else 0.0)
    return ch, trace


def test_walks_five_seconds_tracking_the_clip(client: int, skeleton: ArticulatedSkeleton) -> None:
    heading = 0.7
    ch, trace = walk(client, skeleton, 5.0, heading=heading)
    assert ch.falls == 0 and min(trace["up"]) == 1.0
    # it goes where the clip goes: ~1 m/s along its heading (the clip: 1.24 m per 1.27 s pass)
    along = trace["x"][-1] * math.cos(heading) + trace["y"][-1] * math.sin(heading)
    assert along > 3.0
    assert float(np.mean(trace["error"])) < 12.0  # degrees, mean over the 12 driven joints
    # walking unpushed, no joint is ever outside its limits, at any physics step (targets are clamped inside;
    # pushes, falls and get-ups do carry joints past: tests/test_articulated_limits.py, jostle bench ragdoll)
    assert max(trace["excess"]) == 0.0
    assert ch.external_assist_peak_n <= ArticulatedSpec().assist_force_max_n + 1e-9
    assert ch.external_assist_peak_nm <= ArticulatedSpec().assist_torque_max_nm + 1e-9


def test_without_assist_and_balance_it_falls(client: int, skeleton: ArticulatedSkeleton) -> None:
    """The bounded assist is doing real work: the same body without it falls within seconds."""
    spec = ArticulatedSpec(assist_torque_max_nm=0.0, assist_force_max_n=0.0, getup_assist_force_max_n=0.0,
                           getup_assist_torque_max_nm=0.0)
    ch, trace = walk(client, skeleton, 3.0, spec)
    assert ch.falls >= 1
    assert ch.external_assist_peak_n == 0.0 and ch.external_assist_peak_nm == 0.0


def test_same_inputs_same_trace(skeleton: ArticulatedSkeleton) -> None:
    runs = []
    for _ in range(2):
        c, _ = open_client(WorldConfig())
        try:
            ch, trace = walk(c, skeleton, 1.5)
            ch.push("chest", (0.0, 150.0, 0.0), 0.2)
            for _ in range(120):
                advance(c, [ch], DT)
            runs.append((trace, [lp.position for lp in ch.link_poses()]))
        finally:
            p.disconnect(c)
    assert runs[0][0] == runs[1][0]
    assert runs[0][1] == runs[1][1]


def test_stable_pd_tracks_better_than_explicit_pd_at_the_seed_gains(skeleton: ArticulatedSkeleton) -> None:
    """Hanging from a fixed root (no balance involved): the seed's gains at 240 Hz."""
    errors = {}
    for pd in ("stable", "explicit"):
        c, _ = open_client(WorldConfig())
        try:
            ch = ArticulatedCharacter(c, skeleton, ArticulatedSpec(pd=pd, assist_torque_max_nm=0.0,
                                                                   assist_force_max_n=0.0), None, (0.0, 0.0), 0.0)
            ch._feet = None  # no balance feedback: pure tracking
            root, orn = ch.root()
            p.resetBasePositionAndOrientation(ch.body, (0.0, 0.0, 2.0), orn.tolist(), physicsClientId=c)
            p.createConstraint(ch.body, -1, -1, -1, p.JOINT_FIXED, (0, 0, 0), (0, 0, 0), ch.readout.base_com(),
                               childFrameOrientation=orn.tolist(), physicsClientId=c)
            err = []
            for i in range(240):
                advance(c, [ch], DT)
                if i % 12 == 11:
                    err.append(ch.tracking_error_deg())
            errors[pd] = float(np.mean(err))
        finally:
            p.disconnect(c)
    assert errors["stable"] < 6.0
    assert errors["explicit"] > 2.0 * errors["stable"]


def test_walks_thirty_seconds(client: int, skeleton: ArticulatedSkeleton) -> None:
    ch, trace = walk(client, skeleton, 30.0)
    assert ch.falls == 0 and min(trace["up"]) == 1.0
    assert math.hypot(trace["x"][-1], trace["y"][-1]) > 8.0  # (its heading drifts: it walks a wide curve)
    assert max(trace["excess"]) == 0.0  # never outside a limit, at any of its 7200 physics steps
    assert float(np.mean(trace["error"])) < 12.0


def test_steering_turns_the_walk(client: int, skeleton: ArticulatedSkeleton) -> None:
    from sim.articulated import balance as bal

    ch = ArticulatedCharacter(client, skeleton, ArticulatedSpec(), None, (0.0, 0.0), 0.0)
    ch.steer(math.pi / 2)
    for _ in range(int(4.0 / DT)):
        advance(client, [ch], DT)
    _, orn = ch.root()
    assert ch.falls == 0
    assert abs(math.remainder(bal.heading_of(orn) - math.pi / 2, math.tau)) < 0.5
    com, v = ch.com_state()
    assert v[1] > 0.2  # walking along +y now
