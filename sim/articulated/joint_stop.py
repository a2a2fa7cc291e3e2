"""One-sided joint stops for the ball and universal joints (pybullet spherical joints have no engine limits).

Every physics step, in every state (but for the two exceptions below), each ball/universal joint outside its swing cone or twist range meets
a stop: a torque on the child link (and its opposite on the parent, so the body's momentum is untouched)
back toward the limit, ``stiffness × excess + damping × outward speed`` (the damping acts only on motion
further out, never pulling inward), at most ``torque_cap``. The PD targets are left alone: the stop is the
joint's bone and ligament, not its muscle. Inside the limits it does nothing (one joint-state read).

The stop is an explicit torque at the physics step, so its gains are bounded by the inertia it moves:
``stiffness ≤ STIFF_SHARE · I / dt²`` and ``damping ≤ DAMP_SHARE · I / dt``, with I the inertia about the
joint (swing: across the bone; twist: about it) — limp, of the child link against the parent link, each
alone; driven, of the child's whole subtree (its joints' PD holds it together) — a stiffer explicit stop
overshoots and pumps energy in (measured: with the subtree's inertia while limp, a fall blew up).

One exception, measured: while walking (WALK, STAGGER) the ankles' *twist* (the foot's yaw about the shin)
has no stop — the stance foot is held by the floor, and a stop there turns the body against the balance
control: with it, the sideways push survived in ``jostle bench ragdoll`` fell from 300 N to 180 N (at 0.3 ×
its gains: 280 N, and one get-up in 8 failed). And the character does not apply the stops while getting up
(STAND_UP: the get-up clip's targets are inside the limits and tracked at full gains): with them, walking
off after the face-down get-up fell again (``tests/test_articulated_walkoff.py``, pushed forward and to the
side). Everything else is stopped in every state.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from sim.articulated import quat1 as q1
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.tracking import JointTracker

STIFF_SHARE = 0.5  # of I/dt²: the explicit stop's stiffness bound
DAMP_SHARE = 0.5  # of I/dt: the explicit stop's damping bound (at most half the outward speed per step)


def _link_inertia(skeleton: ArticulatedSkeleton, link: int, at: np.ndarray, axis: np.ndarray) -> tuple[float, float]:
    """(inertia across ``axis``, inertia about ``axis``) of one link about the point ``at`` (its own frame),
    kg·m²."""
    lk = skeleton.links[link]
    r = np.asarray(lk.com, dtype=float) - at
    along = float(np.dot(r, axis))
    perp2 = float(np.dot(r, r)) - along * along
    own = float(np.min(lk.inertia))
    return lk.mass * (0.5 * perp2 + along * along) + own, lk.mass * perp2 + own


def _joint_inertia(skeleton: ArticulatedSkeleton, child: int, axis: np.ndarray,
                   limp: bool) -> tuple[float, float]:
    """(across, about) ``axis``: the inertia the stop of ``child``'s joint turns, kg·m². Limp: the child link
    against the parent link, each alone about the joint (the links beyond them hardly help). Driven: the
    child's whole subtree, held together by its joints' PD (the parent side is the rest of the body)."""
    lk = skeleton.links[child]
    if limp:
        c = _link_inertia(skeleton, child, np.zeros(3), axis)
        par = _link_inertia(skeleton, lk.parent, np.asarray(lk.joint_offset, dtype=float), axis)
        return c[0] * par[0] / (c[0] + par[0]), c[1] * par[1] / (c[1] + par[1])
    across = about = 0.0
    for i in range(child, len(skeleton.links)):
        if _descends(skeleton, i, child):
            one = _link_inertia(skeleton, i, _offset(skeleton, i, child), axis)
            across, about = across + one[0], about + one[1]
    return across, about


def _descends(skeleton: ArticulatedSkeleton, link: int, ancestor: int) -> bool:
    while link > ancestor:
        link = skeleton.links[link].parent
    return link == ancestor


def _offset(skeleton: ArticulatedSkeleton, link: int, ancestor: int) -> np.ndarray:
    """Minus the rest-pose position of ``link``'s frame in ``ancestor``'s (link frames aligned)."""
    r = np.zeros(3)
    while link != ancestor:
        r += np.asarray(skeleton.links[link].joint_offset, dtype=float)
        link = skeleton.links[link].parent
    return -r


class JointStops:
    """The stops of one character's ball/universal joints (see the module docstring)."""

    def __init__(self, client: int, body: int, skeleton: ArticulatedSkeleton, tracker: JointTracker,
                 gain: float) -> None:
        self._client = client
        self._body = body
        lim = tracker.limits
        ks = [k for k in range(len(tracker.driven)) if not lim.hinge[k]]
        self._links = [tracker.indices[k] for k in ks]  # pybullet child links
        self._parents = [skeleton.links[tracker.driven[k]].parent - 1 for k in ks]
        self._axis = lim.twist_axis[ks]
        self._swing_limit = lim.swing_limit[ks]
        self._twist_limit = lim.twist_limit[ks]
        self._foot = [bool(skeleton.links[tracker.driven[k]].foot) for k in ks]  # ankles
        self._axis_f = [tuple(float(v) for v in row) for row in self._axis]
        self._swing_limit_f = [float(v) for v in self._swing_limit]
        self._twist_limit_f = [float(v) for v in self._twist_limit]
        self._inertia = {limp: [_joint_inertia(skeleton, tracker.driven[k], self._axis[n], limp)
                                for n, k in enumerate(ks)] for limp in (False, True)}
        self._kp = [gain * float(tracker.kp[k]) for k in ks]
        self._kd = [gain * float(tracker.kd[k]) for k in ks]
        self._cap = [gain * float(tracker.max_torque[k]) for k in ks]
        self._key: tuple[float, bool] = (0.0, False)
        self._k_swing: list[float] = []
        self._d_swing: list[float] = []
        self._k_twist: list[float] = []
        self._d_twist: list[float] = []
        self.last_torque_nm = 0.0  # the largest stop torque of the last step (0: every joint inside)

    def _bound_gains(self, dt: float, limp: bool) -> None:
        self._key = (dt, limp)
        inertia = self._inertia[limp]
        self._k_swing = [min(kp, STIFF_SHARE * i[0] / dt ** 2) for kp, i in zip(self._kp, inertia, strict=True)]
        self._d_swing = [min(kd, DAMP_SHARE * i[0] / dt) for kd, i in zip(self._kd, inertia, strict=True)]
        self._k_twist = [min(kp, STIFF_SHARE * i[1] / dt ** 2) for kp, i in zip(self._kp, inertia, strict=True)]
        self._d_twist = [min(kd, DAMP_SHARE * i[1] / dt) for kd, i in zip(self._kd, inertia, strict=True)]

    def apply(self, dt: float, limp: bool, walking: bool) -> None:
        """Read the joints; push back the ones outside their limits (call before every physics step of ``dt``;
        ``limp``: the PD gains are low, so the stops are bounded by the single links' inertia; ``walking``
        (WALK, STAGGER): the ankles' twist is left to the ground, see the module docstring)."""
        if self._key != (dt, limp):
            self._bound_gains(dt, limp)
        states = p.getJointStatesMultiDof(self._body, self._links, physicsClientId=self._client)
        self.last_torque_nm = 0.0
        for n, state in enumerate(states):  # floats, not numpy: this runs every step for a few joints
            x, y, z, w = state[0]
            ax, ay, az = self._axis_f[n]
            proj = x * ax + y * ay + z * az
            # swing-twist about a: twist = 2·atan2(proj, w), cos(swing / 2) = √(w² + proj²)
            twist_out = abs(2.0 * math.atan2(proj, w)) - self._twist_limit_f[n]
            swing_out = 2.0 * math.acos(min(1.0, math.sqrt(w * w + proj * proj))) - self._swing_limit_f[n]
            if (twist_out > 0.0 or swing_out > 0.0):
                self._push_back(n, np.array(state[0], dtype=float), np.asarray(state[1], dtype=float), walking)

    def _push_back(self, n: int, rot: np.ndarray, omega: np.ndarray, walking: bool) -> None:
        """Stop torque for joint ``n`` at local rotation ``rot`` (joint velocity ``omega`` in the child frame)."""
        c = self._client
        q = -rot if rot[3] < 0 else rot
        a = self._axis[n]
        proj = float(np.dot(q[:3], a))
        twist = 2.0 * math.atan2(proj, float(q[3]))
        twist_out = abs(twist) - float(self._twist_limit[n])
        swing = q1.mul(q, np.concatenate([-a * math.sin(0.5 * twist), [math.cos(0.5 * twist)]]))  # q·twist⁻¹
        sn = float(np.linalg.norm(swing[:3]))
        swing_out = 2.0 * math.atan2(sn, abs(float(swing[3]))) - float(self._swing_limit[n])
        tau = np.zeros(3)  # child frame
        if twist_out > 0.0 and not (walking and self._foot[n]):
            out_dir = math.copysign(1.0, twist) * a
            speed = max(float(np.dot(omega, out_dir)), 0.0)
            tau -= out_dir * (self._k_twist[n] * twist_out + self._d_twist[n] * speed)
        if swing_out > 0.0 and sn > 1e-9:
            s_parent = swing[:3] / sn * math.copysign(1.0, float(swing[3]))  # swing axis, parent frame
            out_dir = q1.rot(q1.conj(q), s_parent)  # the same axis in the child frame
            speed = max(float(np.dot(omega, out_dir)), 0.0)
            tau -= out_dir * (self._k_swing[n] * swing_out + self._d_swing[n] * speed)
        norm = float(np.linalg.norm(tau))
        if norm > self._cap[n]:
            tau *= self._cap[n] / norm
        self.last_torque_nm = max(self.last_torque_nm, min(norm, self._cap[n]))
        orn = p.getLinkState(self._body, self._links[n], physicsClientId=c)[5]
        world = q1.rot(np.asarray(orn, dtype=float), tau)
        p.applyExternalTorque(self._body, self._links[n], world.tolist(), p.WORLD_FRAME, physicsClientId=c)
        p.applyExternalTorque(self._body, self._parents[n], (-world).tolist(), p.WORLD_FRAME, physicsClientId=c)
