"""Export of an articulated character's motion (sim.articulated.export): link poses → BVH / glTF → read back.

The link poses are real: the DeepMimic humanoid is built in pybullet (DIRECT) and posed frame by frame
from the walk clip (resetJointStateMultiDof), and its link frames are read back with getLinkState — what
the World reports in ``CharacterSnapshot.links``. The expected joint angles are the clip's own.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from sim.articulated.build import build_multibody, source_to_stage
from sim.articulated.export import (
    STAGE_TO_Y_UP,
    ExportError,
    local_motion,
    read_gltf_rotations,
    shape_ends,
    track_from_snapshots,
    write_track,
)
from sim.articulated.skeleton import ArticulatedSkeleton, deepmimic_humanoid
from sim.motion import quaternion as quat
from sim.motion.bvh import read_bvh
from sim.motion.mocap import JOINTS, MotionClip, pybullet_motion_path
from sim.snapshot import CharacterSnapshot, CharacterState, LinkPose, WorldSnapshot

FRAMES = 24


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The angle (rad) of the rotation between unit quaternions, either sign (exact near 0, unlike arccos)."""
    d = quat.multiply(quat.conjugate(quat.normalize(a)), quat.normalize(b))
    return 2.0 * np.arctan2(np.linalg.norm(d[..., :3], axis=-1), np.abs(d[..., 3]))


def snapshot_of(name: str, t: float, links: tuple[LinkPose, ...]) -> WorldSnapshot:
    root = links[0]
    c = CharacterSnapshot(name, root.position, root.orientation, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, (0.0, 0.0),
                          0.0, 0.0, CharacterState.WALK, "walk", "wander", None, 0.0, 1.6, kind="ragdoll", links=links)
    return WorldSnapshot(t, 0, (c,))


def pose_links(client: int, body: int, sk: ArticulatedSkeleton, pos: np.ndarray, rot: np.ndarray,
               joints: np.ndarray) -> tuple[LinkPose, ...]:
    """Put the body in the clip's pose (root joint at stage ``pos``) and read every link frame back."""
    turn = source_to_stage(sk)
    root_rot = quat.multiply(turn, rot)
    com = pos + quat.rotate(root_rot, np.array(sk.links[0].com))
    p.resetBasePositionAndOrientation(body, com.tolist(), root_rot.tolist(), physicsClientId=client)
    for i, link in enumerate(sk.links[1:], start=1):
        if link.motion_channel:
            q = joints[JOINTS.index(link.motion_channel)]
            if link.kind == "hinge":
                p.resetJointState(body, i - 1, 2.0 * math.atan2(q[2], q[3]), physicsClientId=client)
            else:
                p.resetJointStateMultiDof(body, i - 1, q.tolist(), physicsClientId=client)
    out = [LinkPose(sk.links[0].name, tuple(pos), tuple(root_rot))]
    for i in range(1, len(sk.links)):
        s = p.getLinkState(body, i - 1, computeForwardKinematics=True, physicsClientId=client)
        out.append(LinkPose(sk.links[i].name, tuple(s[4]), tuple(s[5])))
    return tuple(out)


@pytest.fixture(scope="module")
def walk() -> Iterator[tuple[ArticulatedSkeleton, MotionClip, list[WorldSnapshot]]]:
    sk = deepmimic_humanoid()
    clip = MotionClip.load(pybullet_motion_path("walk"))
    client = p.connect(p.DIRECT)
    try:
        body = build_multibody(client, sk, (0.0, 0.0, 1.0), tuple(source_to_stage(sk)))
        snaps = []
        for f in range(FRAMES):
            pos, rot, joints = clip.sample(f / 30.0)
            stage_pos = quat.rotate(source_to_stage(sk), pos) + np.array([0.5, 1.0, 0.0])
            snaps.append(snapshot_of("ann", f / 30.0, pose_links(client, body, sk, stage_pos, rot, joints)))
        yield sk, clip, snaps
    finally:
        p.disconnect(client)


def parents_of(sk: ArticulatedSkeleton) -> dict[str, str | None]:
    return {link.name: (None if link.parent < 0 else sk.links[link.parent].name) for link in sk.links}


def test_bvh_export_reads_back_with_the_clips_joint_angles(tmp_path: Path, walk: tuple) -> None:
    sk, clip, snaps = walk
    track = track_from_snapshots(snaps, "ann", parents_of(sk))
    assert track.names == sk.names and local_motion(track).offset_drift_m < 1e-5  # link frames: rigid offsets
    assert track_from_snapshots(snaps, "ann").parents == track.parents  # the hierarchy found from the motion
    m = read_bvh(write_track(track, tmp_path / "ann.bvh", ends=shape_ends(sk)))
    assert m.frames == FRAMES and m.frame_time == pytest.approx(1 / 30)
    # End Sites at the ends of the shapes: the toes forward of the ankle, the head's top above the neck
    toe = m.offsets[m.names.index("right_ankle_end")]
    assert toe[0] > 10.0 and abs(toe[1]) < 5.0  # cm, y up, x forward
    head = m.offsets[m.names.index("neck_end")]
    assert head[1] > 20.0 and abs(head[0]) < 1e-6
    assert m.local_rotations is not None
    for f in range(FRAMES):
        _, rot, joints = clip.sample(f / 30.0)
        for link in sk.links[1:]:
            if link.motion_channel:
                got = m.local_rotations[f, m.names.index(link.name)]
                assert angle_between(got, joints[JOINTS.index(link.motion_channel)]) < 1e-4, (f, link.name)
        # the root turns as the clip's root in the file's y-up axes (the clip is y up: the same)
        assert angle_between(m.local_rotations[f, 0], rot) < 1e-4
    # forward kinematics of the file (centimetres, y up) lands every joint on its link
    back = quat.rotate(quat.conjugate(STAGE_TO_Y_UP), m.positions / 100.0)
    for f in (0, FRAMES // 2, FRAMES - 1):
        for link in snaps[f].characters[0].links:
            assert np.abs(back[f, m.names.index(link.name)] - link.position).max() < 1e-4, (f, link.name)


def test_gltf_export_reads_back_with_the_same_rotations(tmp_path: Path, walk: tuple) -> None:
    sk, _, snaps = walk
    track = track_from_snapshots(snaps, "ann", parents_of(sk))
    want = local_motion(track).rotations
    for name in ("ann.gltf", "ann.glb"):
        names, times, rot = read_gltf_rotations(write_track(track, tmp_path / name))
        assert names == sk.names
        assert times == pytest.approx(np.arange(FRAMES) / 30.0, abs=1e-6)
        assert angle_between(rot, want).max() < 1e-3  # float32 in the file
        for f in range(FRAMES):  # local rotations: the parent's world turn times the child's
            world = quat.multiply(STAGE_TO_Y_UP, np.array([lk.orientation for lk in snaps[f].characters[0].links]))
            for i, link in enumerate(sk.links[1:], start=1):
                expect = quat.multiply(quat.conjugate(world[link.parent]), world[i])
                assert angle_between(rot[f, i], expect) < 1e-3


def test_export_errors_name_what_is_wrong(tmp_path: Path, walk: tuple) -> None:
    sk, _, snaps = walk
    track = track_from_snapshots(snaps, "ann", parents_of(sk))
    with pytest.raises(ExportError, match=r"out.fbx: expected a .bvh, .gltf or .glb file name"):
        write_track(track, tmp_path / "out.fbx")
    with pytest.raises(ExportError, match=r"character 'bob': no articulated links in the run"):
        track_from_snapshots(snaps, "bob", parents_of(sk))
    with pytest.raises(ExportError, match=r"no parent known for link\(s\) neck"):
        track_from_snapshots(snaps, "ann", {k: v for k, v in parents_of(sk).items() if k != "neck"})


def test_a_fall_in_the_world_exports_with_the_same_joint_angles(tmp_path: Path) -> None:
    """A real World run: an articulated character shoved over (big turns, Euler angles near their wraps)."""
    from sim.articulated.spec import ArticulatedSpec
    from sim.config import WorldConfig
    from sim.world import World

    with World(WorldConfig(), np.random.default_rng(1)) as world:
        name = world.add_character(ArticulatedSpec(), (0.0, 0.0), 0.0)
        snaps = [world.step(None, 1 / 30)]
        world.strike(name, (0.0, 900.0, 0.0), 0.2, (0.0, 0.0, 0.3))  # hard, sideways, at the chest
        snaps += [world.step(None, 1 / 30) for _ in range(59)]
    track = track_from_snapshots(snaps, name)
    m = read_bvh(write_track(track, tmp_path / "fall.bvh"))
    g_names, _, g_rot = read_gltf_rotations(write_track(track, tmp_path / "fall.glb"))
    world_rot = quat.multiply(STAGE_TO_Y_UP, track.orientations)
    assert m.local_rotations is not None
    turned = 0.0
    for i in range(1, len(track.names)):
        want = quat.multiply(quat.conjugate(world_rot[:, track.parents[i]]), world_rot[:, i])
        assert angle_between(m.local_rotations[:, m.names.index(track.names[i])], want).max() < 1e-4
        assert angle_between(g_rot[:, g_names.index(track.names[i])], want).max() < 1e-5
        turned = max(turned, float(angle_between(want[0], want).max()))
    assert angle_between(m.local_rotations[:, 0], world_rot[:, 0]).max() < 1e-4
    assert turned > 1.0  # the joints really moved (rad)
    tilt = quat.rotate(world_rot[-1, 0], np.array([0.0, 1.0, 0.0]))[1]  # root's up axis, file y up
    assert tilt < 0.7  # it went over
