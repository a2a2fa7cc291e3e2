"""The articulated body as data and as a pybullet multibody; the clip as joint targets; limits; the spec."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from jostle.config import load_toml
from jostle.configtree import build
from sim.articulated.build import build_multibody, source_to_stage
from sim.articulated.reference import MotionReference, quat_exp, quat_log
from sim.articulated.skeleton import (
    ArticulatedLink,
    ArticulatedSkeleton,
    deepmimic_humanoid,
    deepmimic_urdf_path,
)
from sim.articulated.spec import ArticulatedSpec
from sim.articulated.tracking import JointLimits
from sim.motion import quaternion as quat
from sim.motion.mocap import MotionClip, pybullet_motion_path

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def skeleton() -> ArticulatedSkeleton:
    return deepmimic_humanoid()


@pytest.fixture()
def client() -> object:
    c = p.connect(p.DIRECT)
    yield c
    p.disconnect(c)


def test_humanoid_skeleton_is_the_urdf_with_the_seed_joint_kinds(skeleton: ArticulatedSkeleton) -> None:
    assert len(skeleton.links) == 15
    assert skeleton.total_mass == pytest.approx(45.0)
    kinds = {link.name: link.kind for link in skeleton.links}
    assert kinds["root"] == "root" and kinds["chest"] == "ball"
    assert {kinds[n] for n in ("right_hip", "left_ankle", "right_shoulder")} == {"universal"}
    assert {kinds[n] for n in ("right_knee", "left_elbow")} == {"hinge"}
    assert kinds["right_wrist"] == "fixed"
    knee = skeleton.links[skeleton.index("right_knee")]
    assert (knee.lower, knee.upper) == (-3.14, 0.0)
    assert skeleton.foot("left") == skeleton.index("left_ankle")


def test_multibody_matches_pybullets_own_urdf_loader(skeleton: ArticulatedSkeleton, client: int) -> None:
    turn = tuple(float(v) for v in source_to_stage(skeleton))
    mine = build_multibody(client, skeleton, (0.3, -0.2, 1.0), turn)  # type: ignore[arg-type]
    ref = p.loadURDF(str(deepmimic_urdf_path()), [0.3, -0.2, 1.0], turn, globalScaling=0.25,
                     flags=p.URDF_MAINTAIN_LINK_ORDER, physicsClientId=client)
    assert p.getNumJoints(mine, physicsClientId=client) == 14
    for j in range(14):  # the URDF has one more (massless "base") link in front
        a = p.getLinkState(mine, j, physicsClientId=client)
        b = p.getLinkState(ref, j + 1, physicsClientId=client)
        np.testing.assert_allclose(a[4], b[4], atol=1e-5)  # link frame (joint)
        np.testing.assert_allclose(a[0], b[0], atol=1e-5)  # centre of mass
        assert p.getDynamicsInfo(mine, j, physicsClientId=client)[0] == pytest.approx(
            p.getDynamicsInfo(ref, j + 1, physicsClientId=client)[0])


def test_skeleton_rejects_bad_trees() -> None:
    root = ArticulatedLink("root", -1, "root", (0, 0, 0), 1.0, (0, 0, 0), (1, 1, 1), "sphere", (0.1,))
    arm = ArticulatedLink("arm", 0, "hinge", (0, 1, 0), 1.0, (0, 0, 0), (1, 1, 1), "sphere", (0.1,))
    ArticulatedSkeleton("ok", (root, arm))
    with pytest.raises(ValueError, match="^links"):
        ArticulatedSkeleton("bad", (arm, root))
    with pytest.raises(ValueError, match="^mass"):
        ArticulatedLink("x", 0, "ball", (0, 0, 0), 0.0, (0, 0, 0), (1, 1, 1), "sphere", (0.1,))


def test_reference_velocity_carries_one_frame_onto_the_next(skeleton: ArticulatedSkeleton) -> None:
    clip = MotionClip.load(pybullet_motion_path("walk"))
    ref = MotionReference(clip, skeleton)
    for i in (0, 7, 20):
        t0, t1 = clip.times[i], clip.times[i + 1]
        a, b = ref.sample(float(t0)), ref.sample(float(t1) - 1e-9)
        # seed eq. 3.3: ω = log(q_i⁻¹ q_i+1)/Δt, so q_i · exp(ω Δt) = q_i+1
        stepped = quat.multiply(a.rots, quat_exp(a.omegas * (t1 - t0)))
        dots = np.abs(np.sum(stepped * b.rots, axis=-1))
        assert np.all(dots > 1 - 1e-6)
    # hinges keep only their own axis; the walk's stance alternates
    knees = [k for k, i in enumerate(ref.driven) if skeleton.links[i].kind == "hinge"]
    r = ref.sample(0.3)
    assert np.allclose(np.cross(quat_log(r.rots[knees]), ref.axes[knees]), 0.0, atol=1e-9)
    sides = {ref.sample(t).stance_left for t in np.linspace(0, clip.duration, 40)}
    assert sides == {True, False}


def test_limits_clamp_puts_every_joint_inside(skeleton: ArticulatedSkeleton) -> None:
    ref = MotionReference(MotionClip.load(pybullet_motion_path("walk")), skeleton)
    limits = JointLimits(skeleton, ref.driven)
    rng = np.random.default_rng(3)
    rots = quat.normalize(rng.normal(size=(len(ref.driven), 4)))
    excess = limits.excess(rots)
    assert excess.max() > 0.1  # random rotations break some limits
    inside = limits.clamp(rots)
    assert limits.excess(inside).max() < 1e-6
    ok = limits.clamp(inside)  # already inside: unchanged
    assert np.all(np.abs(np.sum(ok * inside, axis=-1)) > 1 - 1e-9)
    for k in range(len(rots)):  # the one-joint float version used per control update agrees
        assert abs(float(np.dot(limits.clamp_one(rots[k], k), inside[k]))) > 1 - 1e-12


def test_spec_validates_and_loads_from_toml() -> None:
    with pytest.raises(ValueError, match="^kp_knee"):
        ArticulatedSpec(kp_knee=-1.0)
    with pytest.raises(ValueError, match="^pd"):
        ArticulatedSpec(pd="implicit")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="^recover_load"):
        ArticulatedSpec(recover_load=0.9, stagger_load=0.8)
    path = ROOT / "configs" / "characters" / "ragdoll.toml"
    spec = build(ArticulatedSpec, load_toml(path), source=str(path), key="", base_dir=path.parent)
    assert spec.body == "articulated" and spec.pd == "stable"
    assert spec.recovery_substeps == ArticulatedSpec().recovery_substeps == 8  # shipped recovering (issue 9)
    kp, kd, fmax = spec.gains("knee")
    assert kp == pytest.approx(6000.0 * 45.0 / 70.0, rel=1e-5) and kd == pytest.approx(450 * 45 / 70, rel=1e-5)
    assert fmax == 150.0
    assert math.isclose(spec.gain_scale, 45 / 70, rel_tol=1e-5)
