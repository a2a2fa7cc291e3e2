"""Balance of the single-rigid-body character: the inverted pendulum of Mitake et al. 2009, eqs. (1)–(5).

Model (one vertical plane; the front-back and sideways planes are alike and designed separately).
The body (mass M, inertia I about its centre of mass, COM at height l above its foot point, tilt θ
from vertical) is acted on at the foot point — the body's bottom, l below the COM along its axis — by
the floor's normal force f_N and the legs' horizontal friction force f_F, and by the torque
τ = (β − α)·f_N of the centre of pressure β shifted from the contact point α. Newton–Euler about the
COM, with x the horizontal COM position:

    M ẍ = f_F                                   (eq. 1/4)
    I θ̈ = l sin θ · f_N − l cos θ · f_F + τ      (eq. 3, our signs: θ > 0 leans forward, τ > 0 pitches forward)

Linearised about upright (θ ≈ 0, f_N ≈ M g):

    I θ̈ = M g l θ − l f_F + τ                    (eq. 5; the paper's + M l r̈ is our − l f_F = − M l ẍ)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sim.config import CharacterSpec

FloatArray = NDArray[np.float64]


def expm(m: FloatArray) -> FloatArray:
    """Matrix exponential by scaling and squaring of a Taylor series (small dense matrices)."""
    norm = float(np.max(np.sum(np.abs(m), axis=1))) if m.size else 0.0
    squarings = max(0, math.ceil(math.log2(norm)) + 1) if norm > 0.5 else 0
    a = m / (2.0**squarings)
    result = np.eye(m.shape[0])
    term = np.eye(m.shape[0])
    for k in range(1, 24):
        term = term @ a / k
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result


def discretise(a: FloatArray, b: FloatArray, dt: float) -> tuple[FloatArray, FloatArray]:
    """Exact zero-order-hold discretisation of ẋ = A x + B u."""
    n, m = b.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n] = a
    block[:n, n:] = b
    e = expm(block * dt)
    return e[:n, :n], e[:n, n:]


def impulse_discretise(a: FloatArray, b: FloatArray, dt: float) -> tuple[FloatArray, FloatArray]:
    """ẋ = A x + B u with u acting as the impulse B u dt at the start of each step: x⁺ = e^{A dt}(x + B dt u)."""
    ad = expm(a * dt)
    return ad, ad @ b * dt


def dlqr(ad: FloatArray, bd: FloatArray, q: FloatArray, r: FloatArray) -> FloatArray:
    """Discrete LQR gain K (u = −K x) from the fixed point of the Riccati recursion."""
    p = q.copy()
    for _ in range(20000):
        btp = bd.T @ p
        k = np.linalg.solve(r + btp @ bd, btp @ ad)
        p_next = q + ad.T @ p @ (ad - bd @ k)
        p_next = 0.5 * (p_next + p_next.T)
        if np.max(np.abs(p_next - p)) <= 1e-10 * max(1.0, float(np.max(np.abs(p)))):
            p = p_next
            break
        p = p_next
    else:  # pragma: no cover - the design is controllable; this guards a bad spec
        raise ValueError("lqr: the Riccati recursion did not converge")
    btp = bd.T @ p
    gain = np.asarray(np.linalg.solve(r + btp @ bd, btp @ ad), dtype=np.float64)
    return gain


def pendulum_matrices(mass: float, inertia: float, length: float, gravity: float) -> tuple[FloatArray, FloatArray]:
    """(A, B) of the linearised plane model above."""
    a = np.array([[0.0, 1.0, 0.0], [mass * gravity * length / inertia, 0.0, 0.0], [0.0, 0.0, 0.0]])
    b = np.array([[0.0, 0.0], [-length / inertia, 1.0 / inertia], [1.0 / mass, 0.0]])
    return a, b


@dataclass(frozen=True, slots=True)
class PlaneGains:
    """u = −K x for one plane, K as plain floats: f_F row then τ row, columns θ, θ̇, v error."""

    k_force: tuple[float, float, float]
    k_torque: tuple[float, float, float]
    tau_max: float
    xi_max: float  # recoverable bound on the divergent component ξ = θ + θ̇/ω
    omega: float  # sqrt(M g l / I)

    def feedback(self, theta: float, rate: float, speed_error: float) -> tuple[float, float]:
        """(f_F, τ) before the friction bound; τ already clipped to ±tau_max."""
        kf, kt = self.k_force, self.k_torque
        force = -(kf[0] * theta + kf[1] * rate + kf[2] * speed_error)
        torque = -(kt[0] * theta + kt[1] * rate + kt[2] * speed_error)
        return force, max(-self.tau_max, min(self.tau_max, torque))

    def load(self, theta: float, rate: float) -> float:
        return abs(theta + rate / self.omega) / self.xi_max


def friction_bound(spec: CharacterSpec, mu: float, normal_force: float) -> float:
    """Largest horizontal force the legs can put on the floor now: min(μ f_N, leg_force_max)."""
    return max(0.0, min(mu * max(normal_force, 0.0), spec.leg_force_max))


def design_plane(spec: CharacterSpec, tau_max: float, mu: float, gravity: float, control_dt: float) -> PlaneGains:
    """LQR gains and the recoverability bound of one plane (see the module docstring)."""
    m, i, lever = spec.mass, spec.inertia, spec.com_height
    a, b = pendulum_matrices(m, i, lever, gravity)
    ad, bd = impulse_discretise(a, b, control_dt)
    force_max = friction_bound(spec, mu, m * gravity)
    if force_max <= 0.0:
        force_max = spec.leg_force_max  # frictionless floor: design as if the legs could push
    q = np.diag([1.0 / math.radians(spec.lqr_tilt_scale_deg) ** 2, 1.0 / spec.lqr_rate_scale**2,
                 1.0 / spec.lqr_speed_scale**2])
    r = np.diag([1.0 / force_max**2, 1.0 / tau_max**2])
    k = dlqr(ad, bd, q, r)
    mgl = m * gravity * lever
    righting = tau_max + lever * friction_bound(spec, mu, m * gravity)
    omega = math.sqrt(mgl / i)
    discrete = omega * control_dt / -math.expm1(-omega * control_dt)  # impulse per tick (docstring)
    return PlaneGains(
        k_force=(float(k[0, 0]), float(k[0, 1]), float(k[0, 2])),
        k_torque=(float(k[1, 0]), float(k[1, 1]), float(k[1, 2])),
        tau_max=tau_max,
        xi_max=righting / mgl * discrete,
        omega=omega,
    )


@dataclass(frozen=True, slots=True)
class BalanceDesign:
    """Both planes' gains and the heading PD of one character kind on one floor.

    State x = [θ, θ̇, v − v_goal] (v the horizontal COM velocity), input u = [f_F, τ]:

        A = [[0, 1, 0], [M g l / I, 0, 0], [0, 0, 0]],   B = [[0, 0], [−l / I, 1 / I], [1 / M, 0]]

    Every constant velocity with θ = 0 is an equilibrium with u = 0, so tracking the AI's goal velocity is
    regulation of this error state. (A, B) is controllable (the pendulum through τ, the velocity through f_F).

    Gains: the controller runs once per control tick and acts through one *impulse* at the start of the
    tick (``sim.mitake.control``: the tick's force and torque times control_dt, added to the body's velocities
    with one pybullet call — pybullet clears external forces after every ``stepSimulation``, and its
    ``applyExternalTorque`` ignores the inertia of maximal-coordinate bodies). The model is discretised
    exactly for that input: x⁺ = e^{A dt} (x + B dt u) (``impulse_discretise``), and a discrete LQR is
    solved by iterating the Riccati recursion to its fixed point: u = −K x. Weights by Bryson's rule:
    Q = diag(1/θs², 1/θ̇s², 1/vs²) from the spec's ``lqr_*_scale``, R = diag(1/F², 1/τ²) with F, τ the
    input bounds — so the design asks for about as much input as the bounds allow.

    Bounds are hard and applied after the feedback: |τ| ≤ tau_max per plane, and the horizontal friction
    vector of both planes |f_F| ≤ min(μ f_N, leg_force_max). A strong push therefore wins.

    Recoverability (``balance_load``): with the bounds, the largest torque that can right the body is
    T = τ_max + l·F_max (centre of pressure at the edge plus the legs' full friction force, whose moment
    about the COM is l·f_F). For θ̈ = ω²θ + u/I (ω² = M g l / I), |u| ≤ T, the divergent component of
    motion ξ = θ + θ̇/ω obeys ξ̇ = ω (ξ + u/(M g l)), so the body can be brought back iff
    |ξ| < T/(M g l) (the capture-point criterion). With the input given as one impulse per tick of dt,
    ξ jumps by u ω dt/(M g l) and then grows freely by e^{ω dt}, so the bound of this controller is
    ξ_max = T/(M g l) · ω dt / (1 − e^{−ω dt}) (1.09× the continuous one at 30 Hz, 1.05× at 60 Hz).
    ``balance_load`` returns |ξ|/ξ_max per plane and their root-sum-square (the friction budget is
    shared): 0 upright and still, ≥ 1 beyond rescue.
    """

    front: PlaneGains  # front-back plane: θx, forward velocity, pitch torque
    side: PlaneGains  # sideways plane: θz, rightward velocity, roll torque
    yaw_kp: float
    yaw_kd: float

    @staticmethod
    def for_spec(spec: CharacterSpec, mu: float, gravity: float, control_dt: float) -> BalanceDesign:
        w = spec.yaw_frequency
        return BalanceDesign(
            front=design_plane(spec, spec.tau_max, mu, gravity, control_dt),
            side=design_plane(spec, spec.tau_max_side, mu, gravity, control_dt),
            yaw_kp=spec.inertia * w * w,
            yaw_kd=2.0 * spec.inertia * w,
        )

    def balance_load(self, tilt_x: float, rate_x: float, tilt_z: float, rate_z: float) -> float:
        """Root-sum-square of both planes' |ξ|/ξ_max: < 1 recoverable with the bounded inputs."""
        return math.hypot(self.front.load(tilt_x, rate_x), self.side.load(tilt_z, rate_z))
