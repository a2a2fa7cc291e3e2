"""The balance design and the state machine, without pybullet: the derivation checked on its own model."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from sim.config import CharacterSpec
from sim.frames import Frames, frames, tilt_rates, wrap_angle
from sim.mitake.balance import BalanceDesign, discretise, dlqr, expm, impulse_discretise, pendulum_matrices
from sim.mitake.crowd import STATES, Crowd
from sim.mitake.states import Readings, advance
from sim.snapshot import CharacterState

G = 9.81
DT = 1 / 30  # the default control tick


def test_expm_matches_rotation_and_scalar() -> None:
    w = 2.3
    gen = np.array([[0.0, -w], [w, 0.0]])
    e = expm(gen * 1.7)
    assert np.allclose(e, [[math.cos(w * 1.7), -math.sin(w * 1.7)], [math.sin(w * 1.7), math.cos(w * 1.7)]],
                       atol=1e-12)
    assert np.allclose(expm(np.array([[3.0]])), [[math.exp(3.0)]], rtol=1e-12)


def test_zero_order_hold_discretisation_integrates_a_constant_input() -> None:
    # ẍ = u: after dt with u held, x = u dt²/2, v = u dt
    a = np.array([[0.0, 1.0], [0.0, 0.0]])
    b = np.array([[0.0], [1.0]])
    ad, bd = discretise(a, b, 0.5)
    assert np.allclose(ad, [[1.0, 0.5], [0.0, 1.0]])
    assert np.allclose(bd, [[0.125], [0.5]])


def test_impulse_discretisation_matches_an_impulse_then_free_motion() -> None:
    # ẍ = u given as the impulse u·dt at the start: v⁺ = v + u dt, x⁺ = x + (v + u dt) dt
    a = np.array([[0.0, 1.0], [0.0, 0.0]])
    b = np.array([[0.0], [1.0]])
    ad, bd = impulse_discretise(a, b, 0.5)
    assert np.allclose(ad, [[1.0, 0.5], [0.0, 1.0]])
    assert np.allclose(bd, [[0.25], [0.5]])


def test_lqr_stabilises_the_linearised_pendulum() -> None:
    spec = CharacterSpec()
    a, b = pendulum_matrices(spec.mass, spec.inertia, spec.com_height, G)
    assert np.max(np.linalg.eigvals(a).real) > 5.0  # the open loop falls (ω ≈ 5.4 rad/s)
    ad, bd = discretise(a, b, DT)
    k = dlqr(ad, bd, np.diag([100.0, 1.0, 1.0]), np.diag([1e-4, 1e-3]))
    assert np.max(np.abs(np.linalg.eigvals(ad - bd @ k))) < 1.0


def _simulate_plane(design_gains: object, spec: CharacterSpec, theta: float, rate: float, v: float,
                    seconds: float, mu: float = 0.8) -> tuple[float, float]:
    """The linear plane model under the *bounded* feedback, integrated finely. Returns (max |θ|, final v)."""
    from sim.mitake.balance import PlaneGains, friction_bound

    assert isinstance(design_gains, PlaneGains)
    m, i, length = spec.mass, spec.inertia, spec.com_height
    h = 1 / 2400
    limit = friction_bound(spec, mu, m * G)
    worst = abs(theta)
    for _ in range(int(seconds / DT)):
        force, torque = design_gains.feedback(theta, rate, v)
        force = max(-limit, min(limit, force))
        rate += (-length * math.cos(theta) * force + torque) / i * DT  # the tick's impulse, as the world
        v += force / m * DT
        for _ in range(round(DT / h)):
            rate += m * G * length * math.sin(theta) / i * h
            theta += rate * h
        worst = max(worst, abs(theta))
        if worst > 1.2:
            break
    return worst, v


@pytest.mark.parametrize("plane", ["front", "side"])
def test_capture_bound_separates_recovery_from_falling(plane: str) -> None:
    """The criterion is tight for this bounded controller: 0.9 of the bound recovers, 1.05 falls."""
    spec = CharacterSpec()
    g = getattr(BalanceDesign.for_spec(spec, 0.8, G, DT), plane)
    # a push leaves the body upright with a tilt rate; load = |rate/ω| / ξ_max
    inside = 0.9 * g.xi_max * g.omega
    assert g.load(0.0, inside) == pytest.approx(0.9)
    worst, v = _simulate_plane(g, spec, 0.0, inside, 0.0, 6.0)
    assert worst < 0.5 and abs(v) < 0.05  # recovered and stopped (goal velocity 0)
    worst, _ = _simulate_plane(g, spec, 0.0, 1.05 * g.xi_max * g.omega, 0.0, 4.0)
    assert worst > 1.0  # fell: the bounded inputs could not save it


def test_tracks_goal_velocity_in_the_model() -> None:
    spec = CharacterSpec()
    g = BalanceDesign.for_spec(spec, 0.8, G, DT).front
    # error state: v − goal; starting 0.8 m/s below the goal, the error must vanish without falling
    worst, err = _simulate_plane(g, spec, 0.0, 0.0, -0.8, 5.0)
    assert worst < 0.2 and abs(err) < 0.02


def _frame(q: tuple[float, ...]) -> Frames:
    return frames(np.array([q]))


def test_frames_heading_and_tilt_signs() -> None:
    heading = 0.7
    lean = 0.2
    # lean forward: rotate about the character's left axis, after turning to the heading
    q = p.getQuaternionFromEuler([0.0, lean, heading])  # yaw applied last: extrinsic X, Y, Z
    f = _frame(q)
    assert f.heading[0] == pytest.approx(heading, abs=1e-9)
    assert f.tilt_x[0] == pytest.approx(lean, abs=1e-9) and abs(f.tilt_z[0]) < 1e-9
    f = _frame(p.getQuaternionFromEuler([lean, 0.0, heading]))  # +roll about forward: leans right
    assert f.tilt_z[0] == pytest.approx(lean, abs=1e-9) and abs(f.tilt_x[0]) < 1e-9
    # lying face down (pitched forward 90°) keeps its heading; face axis points down
    f = _frame(p.getQuaternionFromEuler([0.0, math.pi / 2, heading]))
    assert f.heading[0] == pytest.approx(heading, abs=1e-6) and not f.face_up[0]
    assert _frame(p.getQuaternionFromEuler([0.0, -math.pi / 2, heading])).face_up[0]
    # a forward pitch rate shows up as θ̇x
    up = _frame(p.getQuaternionFromEuler([0.0, 0.0, heading]))
    rx, rz = tilt_rates(up, np.array([[-math.sin(heading) * 1.5, math.cos(heading) * 1.5, 0.0]]))
    assert rx[0] == pytest.approx(1.5) and rz[0] == pytest.approx(0.0, abs=1e-12)
    assert wrap_angle(3 * math.pi) == pytest.approx(-math.pi)
    # rows are independent, and the rotation's columns are the body axes
    many = frames(np.array([p.getQuaternionFromEuler([0.0, lean, h]) for h in (0.0, 1.0, -2.0)]))
    assert np.allclose(many.heading, [0.0, 1.0, -2.0]) and np.allclose(many.tilt_x, lean)
    rot = many.rotation()
    assert np.allclose(rot[:, :, 2], many.up) and np.allclose(np.linalg.det(rot), 1.0)
    # a broken quaternion reads as upright instead of spreading NaN
    assert frames(np.array([[math.nan, 0.0, 0.0, 1.0]])).tilt[0] == 0.0


class _Machine:
    """One character's state machine driven through ``advance`` with hand-made readings."""

    def __init__(self, spec: CharacterSpec) -> None:
        self.crowd = Crowd()
        self.crowd.add("c", 0, spec, BalanceDesign.for_spec(spec, 0.8, G, DT), "idle", np.zeros((0, 2)), 0.0)

    @property
    def state(self) -> CharacterState:
        return STATES[int(self.crowd.state[0])]

    @property
    def face_up(self) -> bool | None:
        v = int(self.crowd.face_up[0])
        return None if v < 0 else bool(v)

    def force(self, state: CharacterState, t: float) -> None:
        self.crowd.state[0] = STATES.index(state)
        self.crowd.entered[0] = t

    def update(self, t: float, r: Readings) -> tuple[CharacterState, CharacterState] | None:
        changes = advance(self.crowd, r, t)
        return (STATES[changes[0][1]], STATES[changes[0][2]]) if changes else None


def _r(load: float = 0.0, tilt: float = 0.0, speed: float = 0.0, spin: float = 0.0, face_up: bool = True,
       error: float = 0.0) -> Readings:
    def a(v: float) -> np.ndarray:
        return np.array([v])

    return Readings(load=a(load), tilt=a(tilt), speed=a(speed), spin=a(spin), face_up=np.array([face_up]),
                    stand_up_error=a(error))


def test_state_machine_walks_the_whole_cycle() -> None:
    spec = CharacterSpec()
    m = _Machine(spec)
    S = CharacterState
    seen = []
    t = 0.0

    def tick(r: Readings, n: int = 1) -> None:
        nonlocal t
        for _ in range(n):
            t += DT
            ch = m.update(t, r)
            if ch is not None:
                seen.append(ch[1])

    tick(_r(load=0.1), 5)
    assert m.state is S.WALK
    tick(_r(load=0.5))
    assert m.state is S.STAGGER
    tick(_r(load=0.05), int(spec.recover_hold_s / DT) + 2)
    assert m.state is S.WALK
    tick(_r(load=0.95))
    assert m.state is S.FALL
    tick(_r(load=math.inf, tilt=math.radians(40)), 3)
    assert m.state is S.FALL
    tick(_r(load=math.inf, tilt=math.radians(80), speed=1.0, spin=2.0), 10)
    assert m.state is S.BRAKE
    tick(_r(load=math.inf, tilt=math.radians(85), face_up=False), int(spec.still_hold_s / DT) + 2)
    assert m.state is S.LIE and m.face_up is False
    tick(_r(load=math.inf, tilt=math.radians(85), face_up=False), int(spec.lie_duration_s / DT) + 1)
    assert m.state is S.STAND_UP and m.face_up is False
    tick(_r(load=0.1, tilt=math.radians(3)))
    assert m.state is S.WALK and m.face_up is None
    assert seen == [S.STAGGER, S.WALK, S.FALL, S.BRAKE, S.LIE, S.STAND_UP, S.WALK]


def test_state_machine_stand_up_knocked_over_falls_again() -> None:
    spec = CharacterSpec()
    m = _Machine(spec)
    m.force(CharacterState.STAND_UP, 0.0)
    assert m.update(0.1, _r(load=math.inf, tilt=1.0, error=math.radians(50))) is None  # grace period
    assert m.update(1.0, _r(load=math.inf, tilt=1.0, error=math.radians(50))) == (
        CharacterState.STAND_UP, CharacterState.FALL)
