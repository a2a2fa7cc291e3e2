"""The walking balance of an articulated character: foot placement, the torso pair, the root assist.

``WalkingBalance`` is the part of ``ArticulatedCharacter`` (``sim.articulated.character``) that runs at
each control update while it walks or staggers: it reads which foot stands (contacts, else the nearer
under the centre of mass), turns the swing thigh and stance ankle targets (``sim.articulated.balance``,
SIMBICON), measures the balance load (capture-point distance over ``_REACH_M``) and asks the bounded
root assist (``sim.articulated.assist``) for its torque and force. Stage frame: metres, z up; forces in
N, torques in N·m.
"""

from __future__ import annotations

import math

import numpy as np

from sim.articulated import assist, getup
from sim.articulated import balance as bal
from sim.articulated import quat1 as q1
from sim.articulated.readout import BodyReadout
from sim.articulated.reference import MotionReference, ReferencePose
from sim.articulated.spec import ArticulatedSpec
from sim.snapshot import CharacterState

SLOW_MS = 0.1  # m/s: foot placement ignores being slower than the clip beyond this (measured: 0 and 0.3 worse)
_REACH_M = 1.0  # m: capture-point distance from the clip's place over the stance foot at balance load 1
_G = 9.81


class WalkingBalance:
    """The walking balance's methods; ``ArticulatedCharacter`` holds the state they read and write."""

    spec: ArticulatedSpec
    readout: BodyReadout
    state: CharacterState
    ref: MotionReference
    walk: MotionReference
    load: float
    getup_face_up: bool | None
    external_assist_peak_n: float
    external_assist_peak_nm: float
    _feet: tuple[int, int] | None
    _hips: tuple[int, ...]
    _drv_pos: dict[int, int]
    _stance_left: bool
    _rate: float
    _dd: np.ndarray
    _dv: np.ndarray
    _heading: float
    _up: np.ndarray
    _modified: list[int]
    _torques: list[tuple[int, list[float]]]
    _forces: list[tuple[int, list[float], tuple[float, float, float]]]

    @property
    def _gains(self) -> ArticulatedSpec:
        raise NotImplementedError

    def _walk_in(self) -> float:
        raise NotImplementedError

    def com_state(self) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _foot_contacts(self) -> tuple[bool, bool]:
        """(right foot touches something, left foot touches something)."""
        assert self._feet is not None
        return self.readout.touches(self._feet[0]), self.readout.touches(self._feet[1])

    def _support_left(self) -> bool:
        """Which foot carries the body: the one touching the ground, else the one nearer below the com."""
        if self._feet is None:
            return False
        right, left = self._foot_contacts()
        if right != left:
            return left
        com, _ = self.com_state()
        coms = self.readout.link_coms()
        d = [float(np.linalg.norm((coms[f] - com)[:2])) for f in self._feet]
        return bool(d[1] < d[0])

    def _balance(self, r: ReferencePose, root: np.ndarray, orn: np.ndarray, omega: np.ndarray,
                 desired_root: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = self._gains
        assert self._feet is not None
        right_on, left_on = self._foot_contacts()
        stance_left = left_on if right_on != left_on else r.stance_left  # the ground decides when it can
        self._stance_left = stance_left
        stance_foot = self._feet[1] if stance_left else self._feet[0]
        swing_hip, stance_hip = (self._hips[0], self._hips[1]) if stance_left else (self._hips[1], self._hips[0])
        ankle = self.readout.joint_position(stance_foot)
        vel, _ = self.readout.base_velocity()
        heading = bal.heading_of(desired_root)
        d_fwd, d_right = bal.heading_frame(heading, root - ankle)
        v_fwd, v_right = bal.heading_frame(heading, np.array(vel))
        dd = np.array([d_fwd, d_right]) - r.d_ref
        dv = np.array([v_fwd, v_right]) - r.v_ref
        h = max(float(root[2] - ankle[2]), 0.3)
        self.load = float(np.linalg.norm(dd + dv * math.sqrt(h / _G))) / _REACH_M
        self._dd, self._dv, self._heading = dd, dv, heading
        if self._staggering():
            self._rate = bal.hurried_rate(float(dd[1] + dv[1] * math.sqrt(h / _G)), stance_left, s.stagger_hurry,
                                          s.stagger_hurry_max)
        targets = r.rots.copy()
        k_sw = self._drv_pos[swing_hip]
        # slower than the clip (walking off from a stand) by more than a deficit of SLOW_MS: shorter steps
        # would only slow it more, so placement ignores the rest
        v_sag = max(float(dv[0]), -SLOW_MS)
        place = bal.placement_rotation(dd[0], dd[1], v_sag, dv[1], s.cd_sagittal, s.cv_sagittal,
                                       s.cd_coronal, s.cv_coronal)
        # swing thigh in the world: through the desired pelvis frame, whatever the actual pelvis does
        world = q1.mul(desired_root, q1.mul(place, r.rots[k_sw]))
        targets[k_sw] = q1.mul(q1.conj(orn), world)
        self._modified.append(k_sw)
        k_st = self._drv_pos[stance_hip]
        scale[k_st] = s.stagger_stance_hip_gain if self._staggering() else s.stance_hip_gain
        k_an = self._drv_pos[stance_foot]
        if s.ankle_gain > 0 or s.ankle_gain_coronal > 0:
            turn = bal.ankle_rotation(dd[0], dd[1], s.ankle_gain, s.ankle_gain_coronal)
            targets[k_an] = q1.mul(turn, r.rots[k_an])
            self._modified.append(k_an)
        torso = bal.orientation_torque(desired_root, orn, omega, s.torso_kp, s.torso_kd)
        return targets, bal.clamp_norm(torso, s.gains("hip")[2])

    def _staggering(self) -> bool:
        """Taking a push while walking (the stagger strategies are for that, not for walking off from a
        stand after a get-up, which has its own help: ``walk_in_*``)."""
        return self.state == CharacterState.STAGGER and self.ref is self.walk and self._walk_in() >= 1.0

    def _assist(self, r: ReferencePose, root: np.ndarray, orn: np.ndarray, omega: np.ndarray,
                desired_root: np.ndarray) -> None:
        vel, _ = self.readout.base_velocity()
        rising = None  # rising from the face-up get-up's crouch: the root over the feet as in the clip
        if self.state == CharacterState.STAND_UP and self.getup_face_up and self._feet is not None:
            rising = getup.root_offset(self.readout, self._feet, r, desired_root, self.spec.getup_place_tilt_deg)
        torque, force = assist.root_help(
            self._gains, self.state, self._walk_in() < 1.0, self._feet is not None, desired_root, orn, omega,
            self._dd, self._dv, self._heading, (float(q1.rot(self._up, r.root_pos)[2]), float(root[2]), float(vel[2])),
            rising, bool(self.getup_face_up))
        self.external_assist_nm = 0.0 if torque is None else float(np.linalg.norm(torque))  # this tick's
        if torque is not None:
            self._torques.append((-1, torque.tolist()))
            self.external_assist_peak_nm = max(self.external_assist_peak_nm, float(np.linalg.norm(torque)))
        if force is not None:
            self._forces.append((-1, force.tolist(), self.readout.base_com()))
            self.external_assist_peak_n = max(self.external_assist_peak_n, float(np.linalg.norm(force)))

