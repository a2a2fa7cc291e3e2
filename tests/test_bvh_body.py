"""BVH files: parse and write (sim.motion.bvh), and the articulated body built from one (sim.articulated.bvh_body).

The BVH files are generated here from the DeepMimic walk clip shipped with pybullet (``bvh_from_clip``),
Z-up and in centimetres like many exported files, so every expected value comes from the clip itself.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from sim.articulated.build import build_multibody, source_to_stage
from sim.articulated.bvh_body import SEED_MASSES_KG, body_part, bvh_body
from sim.motion import quaternion as quat
from sim.motion.bvh import euler_to_quat, parse_bvh, quat_to_euler, read_bvh, write_bvh
from sim.motion.mocap import HUMANOID, JOINTS, MotionClip, MotionFileError, pybullet_motion_path

CMU = {"root": "Hips", "chest": "Chest", "neck": "Neck", "head_top": "Head", "right_hip": "RightUpLeg",
       "right_knee": "RightLeg", "right_ankle": "RightFoot", "right_toe": "RightToeBase",
       "right_shoulder": "RightArm", "right_elbow": "RightForeArm", "right_wrist": "RightHand"}
CMU |= {k.replace("right", "left"): v.replace("Right", "Left") for k, v in CMU.items() if "right" in k}
Z_UP = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), math.pi / 2)  # the clip's y up → the file's z up


def bvh_from_clip(path: Path, frames: int = 40, units: float = 100.0) -> MotionClip:
    """Write the DeepMimic walk as a Z-up BVH (CMU names, ``units`` per metre); returns the clip."""
    clip = MotionClip.load(pybullet_motion_path("walk"))
    s = HUMANOID
    root_pos = np.zeros((frames, 3))
    local = np.tile(quat.IDENTITY, (frames, len(s.names), 1))
    inv = quat.conjugate(Z_UP)
    for f in range(frames):
        pos, rot, joints = clip.sample(f / 30.0)
        root_pos[f] = quat.rotate(Z_UP, pos) * units
        local[f, 0] = quat.multiply(quat.multiply(Z_UP, rot), inv)
        for b, name in enumerate(s.names):
            if name in JOINTS:
                local[f, b] = quat.multiply(quat.multiply(Z_UP, joints[JOINTS.index(name)]), inv)
    write_bvh(path, [CMU[n] for n in s.names], s.parents, quat.rotate(Z_UP, s.offsets) * units, root_pos, local,
              1 / 30)
    return clip


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The angle (rad) of the rotation between unit quaternions, either sign (exact near 0, unlike arccos)."""
    d = quat.multiply(quat.conjugate(quat.normalize(a)), quat.normalize(b))
    return 2.0 * np.arctan2(np.linalg.norm(d[..., :3], axis=-1), np.abs(d[..., 3]))


# ------------------------------------------------------------------------------ format


@pytest.mark.parametrize("order", ["ZYX", "XYZ", "ZXY", "YXZ"])
def test_euler_angles_give_back_the_rotation_in_every_order(order: str) -> None:
    rng = np.random.default_rng(3)
    q = quat.normalize(rng.normal(size=(500, 4)))
    assert angle_between(euler_to_quat(order, quat_to_euler(q, order)), q).max() < 1e-12
    locked = euler_to_quat(order, np.array([[40.0, 90.0, 25.0], [-70.0, -90.0, 10.0]]))  # gimbal lock
    assert angle_between(euler_to_quat(order, quat_to_euler(locked, order)), locked).max() < 1e-7  # asin near 1


def test_written_bvh_reads_back_to_the_same_rotations_and_positions(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    names, parents = ["Hips", "Spine", "Head", "Arm"], [-1, 0, 1, 1]
    offsets = np.array([[0.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 8.0, 0.0], [6.0, 5.0, 0.0]])
    rot = quat.normalize(rng.normal(size=(7, 4, 4)))
    pos = rng.normal(size=(7, 3)) * 50
    path = write_bvh(tmp_path / "x.bvh", names, parents, offsets, pos, rot, 0.04, order="ZXY")
    m = read_bvh(path)
    assert m.frames == 7 and m.frame_time == pytest.approx(0.04)
    assert [n for n in m.names if not n.endswith("_end")] == names
    assert m.channels[0] == ("xposition", "yposition", "zposition", "zrotation", "xrotation", "yrotation")
    assert m.local_rotations is not None
    got = m.local_rotations[:, [m.names.index(n) for n in names]]
    assert angle_between(got, rot).max() < 1e-6  # degrees written with 6 decimals
    assert np.abs(m.positions[:, 0] - pos).max() < 1e-5
    arm = m.names.index("Arm")  # forward kinematics: the arm's joint hangs off the spine's frame
    want = pos + quat.rotate(rot[:, 0], offsets[1]) + quat.rotate(quat.multiply(rot[:, 0], rot[:, 1]), offsets[3])
    assert np.abs(m.positions[:, arm] - want).max() < 1e-4


def test_broken_bvh_is_one_line_naming_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Xposition Yposition Wrotation\n}\n"
                   "MOTION\nFrames: 1\nFrame Time: 0.1\n1 2 3\n", encoding="utf-8")
    with pytest.raises(MotionFileError, match=r"bad.bvh: not a BVH file I can read \(unknown channel 'wrotation'\)"):
        read_bvh(bad)
    with pytest.raises(MotionFileError, match="expected 2 frames of 3 numbers, got 3 numbers"):
        parse_bvh("HIERARCHY ROOT A { OFFSET 0 0 0 CHANNELS 3 Xposition Yposition Zposition } "
                  "MOTION Frames: 2 Frame Time: 0.1 1 2 3", "x.bvh")


# ------------------------------------------------------------------------------ body


def test_body_from_bvh_has_the_seeds_masses_joint_kinds_and_bone_lengths(tmp_path: Path) -> None:
    bvh_from_clip(tmp_path / "walk.bvh")
    body = bvh_body(read_bvh(tmp_path / "walk.bvh"), total_mass=70.0)
    sk = body.skeleton
    assert body.scale == pytest.approx(0.01)  # centimetres recognised from the figure's height
    assert sk.total_mass == pytest.approx(70.0)
    mass = {link.name: link.mass for link in sk.links}
    assert mass["RightUpLeg"] / mass["RightLeg"] == pytest.approx(SEED_MASSES_KG["upper_leg"] / SEED_MASSES_KG["lower_leg"])
    assert mass["RightUpLeg"] == pytest.approx(mass["LeftUpLeg"])
    assert mass["RightFoot"] / mass["Hips"] == pytest.approx(SEED_MASSES_KG["foot"] / SEED_MASSES_KG["hip"])
    kinds = {link.name: link.kind for link in sk.links}
    assert kinds["Hips"] == "root" and kinds["Chest"] == "ball" and kinds["Neck"] == "ball"
    assert {kinds[n] for n in ("RightUpLeg", "LeftFoot", "RightArm")} == {"universal"}
    assert kinds["RightLeg"] == kinds["LeftForeArm"] == "hinge" and kinds["Head"] == "fixed"
    knee, elbow = sk.links[sk.index("RightLeg")], sk.links[sk.index("RightForeArm")]
    assert (knee.lower, knee.upper) == (0.0, 2.5) and (elbow.lower, elbow.upper) == (-2.7, 0.0)
    assert {sk.links[sk.foot("right")].name, sk.links[sk.foot("left")].name} == {"RightFoot", "LeftFoot"}
    # the file is Z-up: the body is in y-up, x-forward axes; offsets are the skeleton's, in metres
    for b, name in enumerate(HUMANOID.names):
        link = sk.links[sk.index(CMU[name])]
        if b:
            assert np.allclose(link.joint_offset, HUMANOID.offsets[b], atol=1e-6), name
    thigh = sk.links[sk.index("RightUpLeg")]
    assert thigh.shape == "capsule"
    length = thigh.size[1] + thigh.size[0]  # between the cap centres, plus the inset
    assert length == pytest.approx(np.linalg.norm(HUMANOID.offsets[HUMANOID.names.index("right_knee")]), abs=1e-6)
    assert body_part("mixamorig:LeftForeArm") == "lower_arm" and body_part("RThigh") == "upper_leg"


def test_clip_from_bvh_is_the_source_motion(tmp_path: Path) -> None:
    clip = bvh_from_clip(tmp_path / "walk.bvh")
    got = bvh_body(read_bvh(tmp_path / "walk.bvh")).clip
    assert got.joint_rots.shape == (40, len(JOINTS), 4)
    for f in range(0, 40, 7):
        pos, rot, joints = clip.sample(f / 30.0)
        assert angle_between(got.joint_rots[f], joints).max() < 1e-6
        assert angle_between(got.root_rot[f], rot) < 1e-6
        assert np.abs(got.root_pos[f] - pos).max() < 1e-6


def test_the_multibody_stands_where_the_skeleton_says(tmp_path: Path) -> None:
    bvh_from_clip(tmp_path / "walk.bvh")
    sk = bvh_body(read_bvh(tmp_path / "walk.bvh")).skeleton
    client = p.connect(p.DIRECT)
    try:
        turn = source_to_stage(sk)
        body = build_multibody(client, sk, (0.0, 0.0, 1.0), tuple(turn))
        assert p.getNumJoints(body, physicsClientId=client) == len(sk.links) - 1
        world = {0: np.array([0.0, 0.0, 1.0])}
        for i, link in enumerate(sk.links[1:], start=1):  # rest pose: offsets turned onto the stage
            world[i] = world[link.parent] + quat.rotate(turn, np.array(link.joint_offset))
            state = p.getLinkState(body, i - 1, computeForwardKinematics=True, physicsClientId=client)
            assert np.allclose(state[4], world[i], atol=1e-5), link.name
        mass = p.getDynamicsInfo(body, -1, physicsClientId=client)[0]
        mass += sum(p.getDynamicsInfo(body, j, physicsClientId=client)[0] for j in range(len(sk.links) - 1))
        assert mass == pytest.approx(70.0)
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client)
        p.createMultiBody(0, plane, physicsClientId=client)
        p.setGravity(0, 0, -9.8, physicsClientId=client)
        for _ in range(240):  # limp: it must crumple onto the floor, not explode or sink
            p.stepSimulation(physicsClientId=client)
        low = min(p.getLinkState(body, j, physicsClientId=client)[0][2] for j in range(len(sk.links) - 1))
        high = max(p.getLinkState(body, j, physicsClientId=client)[0][2] for j in range(len(sk.links) - 1))
        assert -0.02 < low and high < 1.0
    finally:
        p.disconnect(client)


def test_a_bvh_without_legs_says_what_is_missing(tmp_path: Path) -> None:
    path = write_bvh(tmp_path / "arm.bvh", ["Hips", "Spine", "Head"], [-1, 0, 1],
                     np.array([[0.0, 0, 0], [0, 30, 0], [0, 40, 0]]), np.zeros((2, 3)),
                     np.tile(quat.IDENTITY, (2, 3, 1)), 0.1)
    with pytest.raises(MotionFileError, match=r"arm: cannot map the joints \(left_hand: .*; right_foot: no joint named "
                       r"right ankle or foot\); the file has 'Hips, Spine, Head'"):
        bvh_body(read_bvh(path), name="arm")


CMU_LIKE = [  # name, parent, offset (cm, y up, facing +z as CMU files do; x is the character's left)
    ("Hips", None, (0, 0, 0)), ("LHipJoint", "Hips", (0, 0, 0)), ("LeftUpLeg", "LHipJoint", (9, -6, 2)),
    ("LeftLeg", "LeftUpLeg", (0, -42, 0)), ("LeftFoot", "LeftLeg", (0, -40, 0)), ("LeftToeBase", "LeftFoot", (0, -4, 12)),
    ("RHipJoint", "Hips", (0, 0, 0)), ("RightUpLeg", "RHipJoint", (-9, -6, 2)), ("RightLeg", "RightUpLeg", (0, -42, 0)),
    ("RightFoot", "RightLeg", (0, -40, 0)), ("RightToeBase", "RightFoot", (0, -4, 12)),
    ("LowerBack", "Hips", (0, 2, 0)), ("Spine", "LowerBack", (0, 12, 0)), ("Spine1", "Spine", (0, 12, 0)),
    ("Neck", "Spine1", (0, 10, 0)), ("Neck1", "Neck", (0, 5, 0)), ("Head", "Neck1", (0, 8, 0)),
    ("LeftShoulder", "Spine1", (3, 8, 0)), ("LeftArm", "LeftShoulder", (14, 0, 0)), ("LeftForeArm", "LeftArm", (28, 0, 0)),
    ("LeftHand", "LeftForeArm", (25, 0, 0)), ("RightShoulder", "Spine1", (-3, 8, 0)),
    ("RightArm", "RightShoulder", (-14, 0, 0)), ("RightForeArm", "RightArm", (-28, 0, 0)),
    ("RightHand", "RightForeArm", (-25, 0, 0)),
]


def test_cmu_like_hierarchy_folds_fixed_joints_and_keeps_every_moving_links_turn(tmp_path: Path) -> None:
    names = [n for n, _, _ in CMU_LIKE]
    parents = [-1 if p_ is None else names.index(p_) for _, p_, _ in CMU_LIKE]
    offsets = np.array([o for _, _, o in CMU_LIKE], dtype=float)
    rng = np.random.default_rng(11)
    frames = 6
    rot = quat.normalize(np.concatenate([rng.normal(scale=0.25, size=(frames, len(names), 3)),
                                         np.ones((frames, len(names), 1))], axis=-1))
    path = write_bvh(tmp_path / "cmu.bvh", names, parents, offsets, rng.normal(size=(frames, 3)) * 5, rot, 1 / 120)
    motion = read_bvh(path)
    body = bvh_body(motion, total_mass=80.0)
    sk = body.skeleton
    assert sk.total_mass == pytest.approx(80.0)
    kinds = {link.name: link.kind for link in sk.links}
    assert kinds["LowerBack"] == "ball" and kinds["Spine"] == kinds["Spine1"] == kinds["Neck1"] == "fixed"
    assert kinds["LHipJoint"] == kinds["LeftShoulder"] == kinds["LeftToeBase"] == kinds["LeftHand"] == "fixed"
    assert kinds["LeftUpLeg"] == "universal" and kinds["LeftLeg"] == "hinge"
    assert sk.links[sk.foot("left")].name == "LeftFoot"
    to_c = body.to_canonical  # the file faces +z with x to its left: canonical x forward, z right
    assert np.allclose(quat.rotate(to_c, np.array([0.0, 0.0, 1.0])), [1, 0, 0], atol=1e-9)
    assert np.allclose(quat.rotate(to_c, np.array([1.0, 0.0, 0.0])), [0, 0, -1], atol=1e-9)
    assert motion.rotations is not None
    for f in range(frames):  # forward kinematics of the body's channels = the file's turn of every moving link
        world = {0: body.clip.root_rot[f]}
        for i, link in enumerate(sk.links[1:], start=1):
            local = body.clip.joint_rots[f, JOINTS.index(link.motion_channel)] if link.motion_channel else quat.IDENTITY
            world[i] = quat.multiply(world[link.parent], local)
            if link.motion_channel:
                b = motion.names.index(link.name)
                want = quat.multiply(quat.multiply(to_c, motion.rotations[f, b]), quat.conjugate(to_c))
                assert angle_between(world[i], want) < 1e-6, (f, link.name)


def test_a_bvh_body_tracks_its_clip_under_pd_control(tmp_path: Path) -> None:
    """The whole chain: BVH → body + clip → sim.articulated's PD-tracked character in pybullet."""
    from sim.articulated.character import ArticulatedCharacter
    from sim.articulated.recovery import advance
    from sim.articulated.spec import ArticulatedSpec
    from sim.config import WorldConfig
    from sim.physics import open_client

    bvh_from_clip(tmp_path / "walk.bvh", frames=39)
    body = bvh_body(read_bvh(tmp_path / "walk.bvh"), total_mass=45.0, loop=True, link_names="channels")
    assert "right_hip" in body.skeleton.names and "RightUpLeg" not in body.skeleton.names  # DeepMimic names
    cfg = WorldConfig()
    client, _ = open_client(cfg)
    try:
        ch = ArticulatedCharacter(client, body.skeleton, ArticulatedSpec(), body.clip)
        start, _ = ch.root()
        errors = []
        for s in range(120):  # 0.5 s
            advance(client, [ch], cfg.physics_dt)
            if s % 8 == 7:
                errors.append(ch.tracking_error_deg())
        end, _ = ch.root()
        assert str(ch.state) == "walk" and end[2] > 0.7
        assert end[0] - start[0] > 0.3  # it walks forward (the clip: ≈1 m/s along +x)
        assert float(np.mean(errors)) < 10.0
    finally:
        p.disconnect(client)
