"""Tools for animators: check, import (DeepMimic, BVH, glTF), export, preview; added dimensions, blends of B,
and quaternion signs in the files."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from jostle.cli import main
from render.keyframes import KeyframeQuery, KeyframeSet
from render.keyframes.bvh import bvh_to_clip, read_bvh
from render.keyframes.clip_import import Placement, import_clip
from render.keyframes.gltf_io import export_gltf, import_gltf
from render.keyframes.set_check import check_set
from sim.motion import quaternion as quat
from sim.motion.mocap import HUMANOID, JOINTS, MotionClip, pybullet_motion_path

ROOT = Path(__file__).resolve().parent.parent / "configs" / "keyframes"


def rotation_gap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle between unit quaternions, sign-blind; precise near 0 (arccos is not)."""
    chord = np.minimum(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))
    return 4.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0))


# ------------------------------------------------------------------------------ check


@pytest.mark.parametrize("name", ["humanoid", "critter"])
def test_shipped_sets_pass_the_check(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["keyframes", "check", str(ROOT / name), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["problems"] == [] and report["ok"] is True
    assert report["animations"] >= 12 and report["keyframes"] >= 57
    assert report["behaviours"] == ["stand_up", "walk"]


def broken_set(folder: Path) -> Path:
    (folder / "poses.toml").write_text(
        "[a]\n[a.joints]\nrigt_knee = 10.0\n"
        "[b]\n[b.joints]\nleft_elbo = 10.0\n"
        "[c]\n[c.joints]\nneck = 5.0\n",
        encoding="utf-8",
    )
    (folder / "keyframes.toml").write_text(
        'format = 1\nskeleton = "humanoid"\nheight = 1.6\ndefault_behaviour = "walk"\nposes = ["poses.toml"]\n'
        '[[animation]]\nname = "walk"\nbehaviour = "walk"\naxis = "dz"\nat = { theta_x = 0.0, theta_z = 0.0, dx = 0.0 }\n'
        'keys = [{ at = 0.0, pose = "a" }, { at = 0.1, pose = "b" }, { at = 0.1, pose = "c" }, { at = 1.2, pose = "c" }]\n'
        '[[animation]]\nname = "fall"\nbehaviour = "walk"\naxis = "theta_z"\nat = { theta_x = 4.0, dx = "any", dz = "any" }\n'
        'keys = [{ at = 0.0, pose = "c" }, { at = 1.5, pose = "c" }]\n',
        encoding="utf-8",
    )
    return folder / "keyframes.toml"


def test_check_lists_every_problem_with_its_file_and_animation(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    report = check_set(broken_set(tmp_path))
    kinds = [(p.kind, p.animation, p.key) for p in report.problems]
    assert not report.ok
    unknown = [p for p in report.problems if p.kind == "unknown-joint"]
    assert len(unknown) == 2 and all(p.file.endswith("poses.toml") for p in unknown)
    assert {"rigt_knee", "left_elbo"} == {p.message.split(": ")[1].split(".")[1] for p in unknown}
    assert ("duplicate", "walk", 2) in kinds  # two keys at dz = 0.1
    assert ("out-of-range", "walk", 3) in kinds  # dz = 1.2 on a periodic axis
    assert ("out-of-range", "fall", None) in kinds  # theta_x = 4 is outside [-π, π]
    assert any(p.kind == "gap" and p.animation == "fall" for p in report.problems)  # 1.5 rad between keys
    assert all(p.file.endswith(("poses.toml", "keyframes.toml")) for p in report.problems)
    assert main(["keyframes", "check", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "animation 'walk' key 2" in out and "[duplicate]" in out and "errors" in out


# ------------------------------------------------------------------------------ signs, dimensions, B


def test_quaternion_signs_in_the_files_do_not_change_the_pose(tmp_path: Path) -> None:
    """Every third pose of the shipped set rewritten with each quaternion negated (the same rotations)."""
    shipped = KeyframeSet.load(ROOT / "humanoid" / "keyframes.toml")
    folder = tmp_path / "set"
    (folder / "poses").mkdir(parents=True)
    (folder / "keyframes.toml").write_text((ROOT / "humanoid" / "keyframes.toml").read_text(encoding="utf-8"))
    index = {name: i for i, name in enumerate(shipped.key_names)}
    for f in (ROOT / "humanoid" / "poses").glob("*.toml"):
        import tomllib

        lines = []
        for name in tomllib.loads(f.read_text(encoding="utf-8")):
            i = index[name]
            sign = -1.0 if i % 3 == 0 else 1.0
            rots = shipped.key_rotations[i] * sign
            vec = lambda q: "[" + ", ".join(repr(float(v)) for v in q) + "]"  # noqa: E731
            lines += [f"[{name}]", f"root_offset = {vec(shipped.key_offsets[i])}", f"root_rotation = {vec(rots[0])}",
                      f"[{name}.joints]"] + [f"{j} = {vec(rots[1 + k])}" for k, j in enumerate(JOINTS)]
        (folder / "poses" / f.name).write_text("\n".join(lines) + "\n", encoding="utf-8")
    flipped = KeyframeSet.load(folder / "keyframes.toml")
    rng = np.random.default_rng(9)
    q = np.column_stack([rng.uniform(-1.6, 1.6, 500), rng.uniform(-1.6, 1.6, 500), rng.uniform(0, 1, 500),
                         rng.uniform(0, 1, 500)])
    for b in ("walk", "stand_up"):
        a, c = shipped.evaluate(q, [b] * len(q)), flipped.evaluate(q, [b] * len(q))
        chord = np.minimum(np.linalg.norm(a.rotations() - c.rotations(), axis=-1),
                           np.linalg.norm(a.rotations() + c.rotations(), axis=-1))
        assert chord.max() < 1e-9
    # and mocap whose signs flip between frames in the file reads as one smooth motion
    clip = MotionClip.load(pybullet_motion_path("walk"))
    assert np.all(np.sum(clip.joint_rots[1:] * clip.joint_rots[:-1], axis=-1) > 0)


def speed_set(folder: Path) -> Path:
    (folder / "poses.toml").write_text(
        "[stand]\n[walk_a]\n[walk_a.joints]\nright_hip = { axis = [0, 0, 1], degrees = 30 }\n"
        "[walk_b]\n[walk_b.joints]\nright_hip = { axis = [0, 0, 1], degrees = -30 }\n",
        encoding="utf-8",
    )
    (folder / "keyframes.toml").write_text(
        'format = 1\nskeleton = "humanoid"\nheight = 1.6\ndefault_behaviour = "walk"\nposes = ["poses.toml"]\n'
        "[dimensions.speed]\nscale = 1.0\nmin = 0.0\nmax = 1.0\n"
        '[[animation]]\nname = "stand"\nbehaviour = "walk"\naxis = "dz"\n'
        'at = { theta_x = 0.0, theta_z = 0.0, dx = "any", speed = 0.0 }\nkeys = [{ at = 0.0, pose = "stand" }]\n'
        '[[animation]]\nname = "walk"\nbehaviour = "walk"\naxis = "dz"\n'
        'at = { theta_x = 0.0, theta_z = 0.0, dx = "any", speed = 1.0 }\n'
        'keys = [{ at = 0.0, pose = "walk_a" }, { at = 0.5, pose = "walk_b" }]\n',
        encoding="utf-8",
    )
    return folder / "keyframes.toml"


def test_an_added_dimension_blends_through_the_same_mechanism(tmp_path: Path) -> None:
    kset = KeyframeSet.load(speed_set(tmp_path))
    assert kset.space.axes == ("theta_x", "theta_z", "dx", "dz", "speed")
    hip = 1 + JOINTS.index("right_hip")

    def hip_deg(speed: float, dz: float) -> float:
        pose = kset.pose(KeyframeQuery(0.0, 0.0, 0.3, dz, "walk", extra=(("speed", speed),)))
        return math.degrees(2 * math.atan2(pose.rotations()[hip, 2], pose.rotations()[hip, 3]))

    assert hip_deg(0.0, 0.0) == pytest.approx(0.0, abs=1e-9)  # standing still: the stand pose, exactly
    assert hip_deg(1.0, 0.0) == pytest.approx(30.0, abs=1e-6)  # at speed: the walk, exactly
    assert hip_deg(3.0, 0.5) == pytest.approx(-30.0, abs=1e-6)  # beyond the range: clamped to it
    half = hip_deg(0.5, 0.0)
    assert 0.0 < half < 30.0  # in between: a blend, no overshoot
    steps = [hip_deg(s, 0.0) for s in np.linspace(0.0, 1.0, 41)]
    assert max(abs(np.diff(steps))) < 3.0  # continuous in speed


def test_blends_of_behaviours_are_convex_and_exact_at_either_end() -> None:
    kset = KeyframeSet.load(ROOT / "humanoid" / "keyframes.toml")
    q = np.array([[-0.9, 0.0, 0.2, 0.6]] * 5)
    mixes = [{"walk": 1 - u, "stand_up": u} for u in (0.0, 0.25, 0.5, 0.75, 1.0)]
    w = kset.weights_array(q, mixes)
    assert w.min() >= 0.0 and np.allclose(w.sum(axis=1), 1.0)
    walk, up = kset.evaluate(q[:1], ["walk"]), kset.evaluate(q[:1], ["stand_up"])
    mixed = kset.evaluate(q, mixes)
    assert rotation_gap(mixed.rotations()[0], walk.rotations()[0]).max() < 1e-12
    assert rotation_gap(mixed.rotations()[4], up.rotations()[0]).max() < 1e-12
    gaps = [rotation_gap(mixed.rotations()[i], mixed.rotations()[i + 1]).max() for i in range(4)]
    total = rotation_gap(walk.rotations()[0], up.rotations()[0]).max()
    assert max(gaps) < total  # each quarter of the way moves less than the whole way


# ------------------------------------------------------------------------------ import and export


def test_gltf_export_then_import_gives_the_same_set(tmp_path: Path) -> None:
    shipped = KeyframeSet.load(ROOT / "humanoid" / "keyframes.toml")
    path = export_gltf(shipped, tmp_path / "humanoid.gltf")
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["asset"]["version"] == "2.0" and len(doc["animations"]) == len(shipped.animations)
    assert doc["animations"][0]["extras"]["jostle"]["axis"] == "dz"
    back = KeyframeSet.load(import_gltf(path, tmp_path / "back"))
    assert sorted(back.key_names) == sorted(shipped.key_names)
    assert {a.name for a in back.animations} == {a.name for a in shipped.animations}
    rng = np.random.default_rng(3)
    q = np.column_stack([rng.uniform(-2, 2, 1000), rng.uniform(-2, 2, 1000), rng.uniform(0, 1, 1000),
                         rng.uniform(0, 1, 1000)])
    for b in ("walk", "stand_up"):
        a, c = shipped.evaluate(q, [b] * len(q)), back.evaluate(q, [b] * len(q))
        assert rotation_gap(a.rotations(), c.rotations()).max() < 1e-5  # float32 in the file
        assert np.abs(a.root_offset - c.root_offset).max() < 1e-5
    assert check_set(tmp_path / "back").ok


def test_deepmimic_import_places_frames_as_keys(tmp_path: Path) -> None:
    src = pybullet_motion_path("run")
    code = main(["keyframes", "import", str(src), "--into", str(tmp_path / "set"), "--name", "run",
                 "--axis", "dz", "--at", "theta_x=0,theta_z=0,dx=any", "--keys", "6"])
    assert code == 0
    kset = KeyframeSet.load(tmp_path / "set" / "keyframes.toml")
    (curve,) = kset.animations
    assert curve.coords.tolist() == pytest.approx([k / 6 for k in range(6)])
    clip = MotionClip.load(src)
    for k in range(6):
        _, _, joints = clip.sample(clip.duration * k / 6)
        pose = kset.pose(KeyframeQuery(0.0, 0.0, 0.7, k / 6, "walk"))
        assert rotation_gap(pose.joint_rotations, joints).max() < 1e-4
    assert check_set(tmp_path / "set").ok
    # a second animation along theta_x joins the same set
    main(["keyframes", "import", str(pybullet_motion_path("getup_facedown")), "--into", str(tmp_path / "set"),
          "--name", "rise", "--behaviour", "stand_up", "--axis", "theta_x", "--at", "theta_z=0,dx=any,dz=any",
          "--keys", "4", "--range", "1.5", "0"])
    assert {a.name for a in KeyframeSet.load(tmp_path / "set" / "keyframes.toml").animations} == {"run", "rise"}


def write_bvh(path: Path, clip: MotionClip, frames: int) -> None:
    """The clip as a Z-up, centimetre BVH with CMU-style names (the test's own writer)."""
    names = {"root": "Hips", "chest": "Chest", "neck": "Neck", "head_top": "Head", "right_hip": "RightUpLeg",
             "right_knee": "RightLeg", "right_ankle": "RightFoot", "right_toe": "RightToeBase",
             "right_shoulder": "RightArm", "right_elbow": "RightForeArm", "right_wrist": "RightHand"}
    names |= {k.replace("right", "left"): v.replace("Right", "Left") for k, v in names.items() if "right" in k}
    skel = HUMANOID
    lines = ["HIERARCHY"]
    order: list[int] = []

    def emit(b: int, depth: int) -> None:
        pad = "  " * depth
        kind = "ROOT" if b == 0 else "JOINT"
        lines.append(f"{pad}{kind} {names[skel.names[b]]}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET " + " ".join(f"{100 * v:.6f}" for v in skel.offsets[b]))
        chans = "6 Xposition Yposition Zposition Zrotation Xrotation Yrotation" if b == 0 else "3 Zrotation Xrotation Yrotation"
        lines.append(f"{pad}  CHANNELS {chans}")
        order.append(b)
        kids = [c for c in range(len(skel.names)) if skel.parents[c] == b]
        for c in kids:
            emit(c, depth + 1)
        if not kids:
            lines.extend([f"{pad}  End Site", pad + "  {", f"{pad}    OFFSET 0 5 0", pad + "  }"])
        lines.append(pad + "}")

    emit(0, 0)
    to_z = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), math.pi / 2)  # the file is Z-up
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    for f in range(frames):
        pos, rot, joints = clip.sample(clip.duration * f / frames)
        row: list[float] = []
        for b in order:
            name = skel.names[b]
            if b == 0:
                q = quat.multiply(to_z, rot)
                row += list(100 * quat.rotate(to_z, pos))
            else:
                q = joints[JOINTS.index(name)] if name in JOINTS else quat.IDENTITY
            m = quat.to_matrix(q)
            row += [math.degrees(math.atan2(-m[0, 1], m[1, 1])), math.degrees(math.asin(np.clip(m[2, 1], -1, 1))),
                    math.degrees(math.atan2(-m[2, 0], m[2, 2]))]
        lines.append(" ".join(f"{v:.6f}" for v in row))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def test_bvh_is_read_and_retargeted_by_bone_directions(tmp_path: Path) -> None:
    clip = MotionClip.load(pybullet_motion_path("walk"))
    write_bvh(tmp_path / "walk.bvh", clip, 12)
    motion = read_bvh(tmp_path / "walk.bvh")
    assert motion.positions.shape[0] == 12 and "RightToeBase" in motion.names
    got = bvh_to_clip(motion)
    for f in range(12):
        want_pos, _ = HUMANOID.forward_kinematics(*clip.sample(clip.duration * f / 12))
        have_pos, _ = HUMANOID.forward_kinematics(np.zeros(3), got.root_rot[f], got.joint_rots[f])
        want_root = clip.sample(clip.duration * f / 12)[1]
        for b in range(1, len(HUMANOID.names)):  # every bone points the same way, seen from the pelvis
            p = HUMANOID.parents[b]
            d_want = quat.rotate(quat.conjugate(want_root), want_pos[b] - want_pos[p])
            d_have = quat.rotate(quat.conjugate(got.root_rot[f]), have_pos[b] - have_pos[p])
            cos = np.dot(d_want, d_have) / np.linalg.norm(d_want) / np.linalg.norm(d_have)
            assert cos > math.cos(math.radians(1.0)), (f, HUMANOID.names[b])
    placement = Placement("walk", "walk", "dz", {"theta_x": 0.0, "theta_z": 0.0, "dx": "any"})
    manifest, recognised = import_clip(tmp_path / "walk.bvh", tmp_path / "set", placement, keys=6)
    assert "unit cm (detected)" in recognised
    assert len(KeyframeSet.load(manifest).key_names) == 6


def test_import_errors_are_one_line(tmp_path: Path) -> None:
    from render.keyframes.set_file import KeyframeError
    from sim.motion.mocap import MotionFileError

    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n OFFSET 0 0\n", encoding="utf-8")
    with pytest.raises(MotionFileError, match="bad.bvh: not a BVH file"):
        read_bvh(bad)
    with pytest.raises(KeyframeError, match="range: an animation along theta_x needs --range"):
        import_clip(pybullet_motion_path("walk"), tmp_path / "s",
                    Placement("f", "walk", "theta_x", {"theta_z": 0.0, "dx": "any", "dz": "any"}), keys=3)
    assert not (tmp_path / "s" / "keyframes.toml").exists()


# ------------------------------------------------------------------------------ preview


def test_preview_writes_a_labelled_contact_sheet_and_a_sweep(tmp_path: Path) -> None:
    import cv2

    from render.gl.preview import TILE, contact_sheet, sweep

    kset = KeyframeSet.load(speed_set(tmp_path))
    tiles = contact_sheet(kset, tmp_path / "out" / "contact_sheet.png", columns=2)
    sheet = cv2.imread(str(tmp_path / "out" / "contact_sheet.png"))
    assert tiles == 3 and sheet.shape == (2 * TILE, 2 * TILE, 3)
    assert sheet[:TILE, :TILE].std() > 10 and (sheet[TILE:, TILE:] == 30).all()  # drawn tiles, one empty slot
    frames = sweep(kset, tmp_path / "out" / "sweep.mp4", frames_per_axis=8, size=(160, 120))
    cap = cv2.VideoCapture(str(tmp_path / "out" / "sweep.mp4"))
    assert frames == 8 and int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 8
    assert (tmp_path / "out" / "sweep.gif").stat().st_size > 0
