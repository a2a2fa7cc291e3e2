"""Configuration of one articulated character kind (TOML: ``configs/characters/ragdoll.toml``).

Gains are the seed's (Lu, table 3.2) in "ODE units", i.e. N·m/rad and N·m·s/rad for its 70 kg body. In
pybullet the units are the same (SI), but this body is lighter (the DeepMimic humanoid: 45 kg), so every
gain is multiplied by ``gain_scale`` (default 45/70: torques scale with mass at equal accelerations). The
seed integrated ODE at a small step; with pybullet's 1/240 s step an *explicit* PD at these gains is
unstable on the light distal links, which is what pybullet's stable PD (``pd = "stable"``) fixes — see
``sim/articulated/tracking.py`` and the measurements in the report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Literal

GROUPS = ("hip", "knee", "ankle", "torso", "neck", "shoulder", "elbow")


def _positive(obj: object, *names: str) -> None:
    for name in names:
        v = getattr(obj, name)
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v <= 0:
            raise ValueError(f"{name}: expected a number > 0, got {v!r}")


def _non_negative(obj: object, *names: str) -> None:
    for name in names:
        v = getattr(obj, name)
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
            raise ValueError(f"{name}: expected a number >= 0, got {v!r}")


@dataclass(frozen=True)
class ArticulatedSpec:
    """An articulated character kind: skeleton, source motions, PD gains, balance feedback, state thresholds."""

    name: str = "ragdoll"
    body: Literal["articulated"] = "articulated"
    skeleton: str = "deepmimic_humanoid"  # or a BVH file: its own body walking its own motion (bvh_character)
    height: float = 1.65  # m, for drawing / snapshots
    com_height: float = 0.93  # m, centre of mass when standing (drawing: where the figure's com sits)
    walk_clip: str = "walk"  # pybullet_data clips by name, or motion files (.bvh, .txt: sim.motion.clips)
    getup_faceup_clip: str = "getup_faceup"
    getup_facedown_clip: str = "getup_facedown"
    # tracking
    pd: Literal["stable", "explicit"] = "stable"
    control_hz: float = 60.0  # targets, balance feedback and states update this often (physics: every step)
    gain_scale: float = 45.0 / 70.0
    kp_hip: float = 4000.0
    kd_hip: float = 300.0
    kp_knee: float = 6000.0
    kd_knee: float = 450.0
    kp_ankle: float = 600.0
    kd_ankle: float = 45.0
    kp_torso: float = 4000.0
    kd_torso: float = 300.0
    kp_neck: float = 1000.0
    kd_neck: float = 75.0
    kp_shoulder: float = 600.0
    kd_shoulder: float = 45.0
    kp_elbow: float = 100.0
    kd_elbow: float = 15.0
    # torque limits per joint group, N·m (DeepMimic's humanoid maxima)
    max_torque_hip: float = 200.0
    max_torque_knee: float = 150.0
    max_torque_ankle: float = 90.0
    max_torque_torso: float = 200.0
    max_torque_neck: float = 50.0
    max_torque_shoulder: float = 100.0
    max_torque_elbow: float = 60.0
    # balance (SIMBICON): swing hip target += cd·d + cv·v (rad per m, rad per m/s), sagittal and coronal
    cd_sagittal: float = 0.0
    cv_sagittal: float = 0.2
    cd_coronal: float = 0.15
    cv_coronal: float = 0.5
    torso_kp: float = 200.0  # N·m/rad: the stance hip keeps the pelvis at its world orientation
    torso_kd: float = 0.0
    stance_hip_gain: float = 1.0  # the stance hip's own PD is scaled by this (the torso torque does the rest)
    stagger_stance_hip_gain: float = 1.5  # … and by this while staggering (a stiffer stance hip after a push)
    # staggering with the capture point toward the stance foot's side (the swing leg would have to step across
    # the stance leg), the clip plays 1 + stagger_hurry × that offset (m) times faster, at most
    # stagger_hurry_max: the crossing step lands sooner and the leg on the pushed side steps out sooner.
    # Bench (4 walking phases, side/forward N survived): off (0, 1.0) 220/300; 1.5, 1.5 (max 2 or 3) 300/280;
    # 1.0 or 1.25 with 1.5, or 1.5 with 1.75 or 2.0, or max 1.5 or 1.75: a ~100 N side push fells it at one
    # phase; 1.75 or 2.0 with 1.5: 280. Max 3 rather than 2: same bench, and a fall pushed sideways while
    # staggering at 2.0 s then walks off after its get-up (with max 2 it walked in place, 1 m in 6 s). Over
    # 8 phases 1.5, 1.5, max 3 still takes >= 300 N sideways everywhere (measured, issue 9)
    stagger_hurry: float = 1.5
    stagger_hurry_max: float = 3.0
    ankle_gain: float = 0.0  # rad per m of root offset forward: stance ankle strategy (sagittal)
    ankle_gain_coronal: float = 0.0  # rad per m sideways (0.15 and 0.3 both ways cut side pushes: measured)
    # bounded external help on the root (0 = none); switched off while falling and lying
    assist_torque_max_nm: float = 150.0  # walking: torque on the pelvis toward upright
    assist_force_max_n: float = 0.0  # walking: horizontal force on the pelvis toward the clip's place
    walk_in_s: float = 3.0  # after getting up, walking off from a stand for this long: the torque assist
    walk_in_assist: float = 1.5  # is this many times larger, and a horizontal force of at most
    walk_in_force_n: float = 0.0  # this brings the root up to the clip's speed (0: off) after the face-down
    walk_in_force_faceup_n: float = 50.0  # get-up, and this after the face-up one. Falls at 6 walking phases
    # each, walked off (> 2 m in 6 s) after the get-up, stagger strategies off: with 0 / 0 N: face up 5 of 10,
    # face down 11 of 12; 50 N after both: 10/10 and 4/12 (the face-down get-up ends leaning forward and,
    # pushed along, runs ahead of its feet); 50 N face up only: 10/10 and 11/12 (measured)
    walk_in_blend_s: float = 0.05  # s: after a get-up the walk's targets blend from the get-up's last pose
    # this long (0.4 and 1.0: it stays in the get-up's crouch and falls within ~2 s; 0.05: walks on: measured)
    getup_assist_force_max_n: float = 300.0  # standing up: vertical force toward the clip's root height
    getup_assist_torque_max_nm: float = 300.0  # standing up: torque toward the clip's root orientation
    # rising from the face-up get-up (its pelvis within getup_place_tilt_deg of upright): a horizontal force of
    # at most this keeps the root over the feet where the clip has it (0: off; without it the body pivots
    # forward over its feet, ends crouched and leaning ~20° and falls walking off: measured)
    getup_place_force_n: float = 150.0
    getup_place_tilt_deg: float = 45.0
    # recovering from a push (sim.articulated.recovery): the world steps this many times finer from a push, a
    # person's contact, a stagger or a fall on (1: never), until it has walked unpushed for recovery_settle_s,
    # then recovery_handover_s more, its gains blending into the walking ones; meanwhile foot placement's velocity gains, the
    # pelvis torque limit and the state loads are these. Falling or lying, the neck keeps recovery_neck_gain
    # of its gains and every joint within brace_margin_deg of a limit is held where it is at brace_gain; upright
    # or getting up, a joint past a limit is driven limit_stop_inside_deg inside at limit_stop_gain (0: off).
    # That module has the figures (jostle bench ragdoll), what it costs and what is still weak
    recovery_substeps: int = 8
    recovery_settle_s: float = 4.0
    recovery_handover_s: float = 2.0
    recovery_cv_sagittal: float = 0.6
    recovery_cv_coronal: float = 0.2
    recovery_assist_torque_max_nm: float = 200.0
    recovery_fall_load: float = 1.25
    recovery_neck_gain: float = 1.0
    recovery_stagger_load: float = 1.0
    recovery_recover_load: float = 0.9
    brace_gain: float = 2.0
    brace_margin_deg: float = 11.5
    limit_stop_gain: float = 3.0
    limit_stop_inside_deg: float = 1.0
    # states
    push_threshold_ns: float = 10.0  # an impulse this large (N·s) makes it STAGGER
    stagger_load: float = 0.8  # balance load (capture point / support reach) above which it staggers
    recover_load: float = 0.5
    recover_hold_s: float = 0.6
    fall_tilt_deg: float = 50.0  # pelvis this tilted from upright: falling
    fall_height: float = 0.45  # m: root joint this low: falling
    # balance load this high (the capture point this many metres from the clip's place over the stance foot):
    # beyond catching, it gives up and falls (0: never; recovering: recovery_fall_load). Recovering at 8
    # substeps, peak load after 0.2 s pelvis pushes while walking (4 phases): forward 240 N 0.86-0.98, 400 N
    # 1.06-1.15, 700 N 1.37-1.56; sideways 300 N 0.85-1.02 (measured); without it, recovering so, it took
    # forward pushes of 500-1000 N
    fall_load: float = 0.0
    ragdoll_gain: float = 0.05  # falling and lying: PD gains scaled by this (a limp body)
    still_speed: float = 0.15  # m/s
    still_hold_s: float = 0.2
    lie_duration_s: float = 0.5
    getup_timeout_s: float = 8.0
    upright_tilt_deg: float = 20.0  # standing up is done when the pelvis is this upright and high
    upright_height: float = 0.72  # m, root joint
    getup_grace_s: float = 1.2  # s after the get-up clip's last frame (holding it) to become upright, else fell

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"name: expected a non-empty string, got {self.name!r}")
        if self.body != "articulated":
            raise ValueError(f"body: expected \"articulated\", got {self.body!r}")
        if not isinstance(self.skeleton, str) or (self.skeleton != "deepmimic_humanoid"
                                                   and not self.skeleton.lower().endswith(".bvh")):
            raise ValueError(f"skeleton: expected \"deepmimic_humanoid\" or a .bvh file, got {self.skeleton!r}")
        if self.pd not in ("stable", "explicit"):
            raise ValueError(f"pd: expected \"stable\" or \"explicit\", got {self.pd!r}")
        for f in ("walk_clip", "getup_faceup_clip", "getup_facedown_clip"):
            if not isinstance(getattr(self, f), str) or not getattr(self, f):
                raise ValueError(f"{f}: expected a clip name, got {getattr(self, f)!r}")
        gains = [f.name for f in fields(self) if f.name.startswith(("kp_", "kd_", "max_torque_"))]
        _positive(self, "height", "com_height", "control_hz", "gain_scale", *gains, "push_threshold_ns",
                  "stagger_load", "recover_load", "fall_tilt_deg", "fall_height", "ragdoll_gain", "still_speed",
                  "lie_duration_s", "getup_timeout_s", "getup_place_tilt_deg", "upright_tilt_deg", "upright_height", "getup_grace_s",
                  "recovery_stagger_load", "recovery_recover_load")
        _non_negative(self, "cd_sagittal", "cv_sagittal", "cd_coronal", "cv_coronal", "torso_kp", "torso_kd",
                      "stance_hip_gain", "stagger_stance_hip_gain", "stagger_hurry", "ankle_gain", "ankle_gain_coronal",
                      "assist_torque_max_nm", "assist_force_max_n",
                      "getup_assist_force_max_n", "getup_assist_torque_max_nm", "getup_place_force_n", "walk_in_s", "walk_in_assist",
                      "walk_in_force_n", "walk_in_force_faceup_n", "walk_in_blend_s", "recover_hold_s", "still_hold_s")
        _non_negative(self, "fall_load", "recovery_settle_s", "recovery_handover_s", "recovery_cv_sagittal", "recovery_cv_coronal",
                      "recovery_assist_torque_max_nm", "recovery_fall_load", "recovery_neck_gain", "brace_gain",
                      "brace_margin_deg", "limit_stop_gain", "limit_stop_inside_deg")
        if isinstance(self.recovery_substeps, bool) or not isinstance(self.recovery_substeps, int) \
                or not 1 <= self.recovery_substeps <= 32:
            raise ValueError(f"recovery_substeps: expected a whole number from 1 to 32, got {self.recovery_substeps!r}")
        if not (isinstance(self.stagger_hurry_max, int | float) and self.stagger_hurry_max >= 1.0):
            raise ValueError(f"stagger_hurry_max: expected a number >= 1, got {self.stagger_hurry_max!r}")
        if not self.recover_load < self.stagger_load:
            raise ValueError(f"recover_load: expected < stagger_load={self.stagger_load}, got {self.recover_load}")
        if not self.recovery_recover_load < self.recovery_stagger_load:
            raise ValueError(f"recovery_recover_load: expected below recovery_stagger_load="
                             f"{self.recovery_stagger_load}, got {self.recovery_recover_load}")
        if not 0 < self.fall_tilt_deg < 90 or not self.upright_tilt_deg < self.fall_tilt_deg:
            raise ValueError(f"fall_tilt_deg: expected between upright_tilt_deg={self.upright_tilt_deg} and 90, "
                             f"got {self.fall_tilt_deg}")

    def gains(self, group: str) -> tuple[float, float, float]:
        """(kp, kd, max torque) of a joint group in pybullet units for this body (gain_scale applied)."""
        if group not in GROUPS:
            raise KeyError(f"no gain group {group!r}; groups: {', '.join(GROUPS)}")
        s = self.gain_scale
        return (s * getattr(self, f"kp_{group}"), s * getattr(self, f"kd_{group}"),
                getattr(self, f"max_torque_{group}"))
