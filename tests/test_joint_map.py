"""Any common BVH rig maps onto our bones with no hand edit (issue J): real CMU capture on the iClone rig
(excerpts in tests/fixtures/bvh/), and the same motion written in the other conventions users bring
(Mixamo, cgspeed, CMU ASF-style, DeepMimic names, Rigify; cm, inches, metres)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from render.keyframes.bvh import bvh_to_clip
from sim.motion import quaternion as quat
from sim.motion.bvh import read_bvh, write_bvh
from sim.motion.joint_map import load_joint_map, map_joints, words
from sim.motion.mocap import MotionFileError

FIXTURES = Path(__file__).parent / "fixtures" / "bvh"
WALK = FIXTURES / "002_01_excerpt.bvh"
JUMPS = FIXTURES / "001_01_excerpt.bvh"
MEDIA = Path(__file__).resolve().parents[1] / ".." / ".." / "shared" / "media" / "bvh" / "cmu_iclone"

# iClone joint (without CC_Base_, L_ for the left side) → the name in each convention ({S}: Left/Right)
_MAIN = ("Hip", "Pelvis", "Waist", "Spine01", "Spine02", "NeckTwist01", "NeckTwist02", "Head", "Clavicle",
         "Upperarm", "Forearm", "Hand", "Thigh", "Calf", "Foot", "ToeBase")
CONVENTIONS: dict[str, tuple[tuple[str, ...], float]] = {  # names in _MAIN's order, metres per unit
    "mixamo": (("mixamorig:Hips", "mixamorig:Pelvis", "mixamorig:Spine", "mixamorig:Spine1", "mixamorig:Spine2",
                "mixamorig:Neck", "mixamorig:Neck1", "mixamorig:Head", "mixamorig:{S}Shoulder", "mixamorig:{S}Arm",
                "mixamorig:{S}ForeArm", "mixamorig:{S}Hand", "mixamorig:{S}UpLeg", "mixamorig:{S}Leg",
                "mixamorig:{S}Foot", "mixamorig:{S}ToeBase"), 0.01),
    "cgspeed": (("Hips", "Pelvis", "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head", "{S}Shoulder", "{S}Arm",
                 "{S}ForeArm", "{S}Hand", "{S}UpLeg", "{S}Leg", "{S}Foot", "{S}ToeBase"), 0.0254),
    "asf": (("Hips", "Pelvis", "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head", "{S}Collar", "{S}Shoulder",
             "{S}Elbow", "{S}Wrist", "{S}Hip", "{S}Knee", "{S}Ankle", "{S}Toe"), 1.0),
    "deepmimic": (("root", "pelvis", "abdomen", "spine", "chest", "neck", "neck_upper", "head", "{s}_collar",
                   "{s}_shoulder", "{s}_elbow", "{s}_wrist", "{s}_hip", "{s}_knee", "{s}_ankle", "{s}_toe"), 1.0),
    "rigify": (("DEF-spine", "DEF-pelvis", "DEF-spine.001", "DEF-spine.002", "DEF-spine.003", "DEF-spine.004",
                "DEF-spine.005", "DEF-spine.006", "DEF-shoulder.{c}", "DEF-upper_arm.{c}", "DEF-forearm.{c}",
                "DEF-hand.{c}", "DEF-thigh.{c}", "DEF-shin.{c}", "DEF-foot.{c}", "DEF-toe.{c}"), 0.01),
}


def convert(source: Path, out: Path, convention: str, *, drop_clavicles: bool = False,
            rename: dict[str, str] | None = None) -> Path:
    """Write the iClone file's main joints (every ancestor kept, so the motion is exact) in ``convention``."""
    m = read_bvh(source)
    names, per_metre_cm = CONVENTIONS[convention]
    assert m.local_rotations is not None and m.local_translations is not None
    new: dict[int, str] = {}
    for b, n in enumerate(m.names):
        plain = n.removeprefix("CC_Base_")
        side = plain[:2] if plain[:2] in ("L_", "R_") else ""
        if plain[len(side):] in _MAIN and not (drop_clavicles and plain[len(side):] == "Clavicle"):
            text = names[_MAIN.index(plain[len(side):])]
            long, short = ("Left", "l") if side == "L_" else ("Right", "r")
            new[b] = text.format(S=long, s=long.lower(), c=short.upper())
    new.setdefault(0, "Reference")  # a root above the hips (iClone's RL_BoneRoot) carries the root motion
    keep = sorted(new)
    root = keep[0]
    scale = 0.01 / per_metre_cm  # file cm → the convention's unit
    parents, offsets = [], []
    rots = m.local_rotations[:, keep].copy()
    for k, b in enumerate(keep):
        p = m.parents[b]
        off = m.offsets[b].copy()
        while p >= 0 and p not in new:  # a dropped clavicle: its turn goes to the arm, its offset added at rest
            off = off + m.offsets[p]  # (so the motion is near, not exact: such files serve the mapping tests)
            rots[:, k] = quat.multiply(m.local_rotations[:, p], rots[:, k])
            p = m.parents[p]
        parents.append(keep.index(p) if p >= 0 else -1)
        offsets.append(off * scale)
    names_out = [(rename or {}).get(new[b], new[b]) for b in keep]
    return write_bvh(out, names_out, parents, np.array(offsets), m.local_translations[:, root] * scale, rots,
                     m.frame_time)


def test_words_split_every_convention() -> None:
    assert words("mixamorig:LeftUpLeg") == ("left", "upleg")
    assert words("CC_Base_L_Thigh") == ("left", "thigh")
    assert words("LHipJoint") == ("left", "hipjoint")
    assert words("rfemur") == ("right", "femur")
    assert words("DEF-upper_arm.R") == ("right", "upperarm")
    assert words("right_shoulder") == ("right", "shoulder")
    assert words("RL_BoneRoot") == ("", "boneroot")


@pytest.mark.parametrize("source", [WALK, JUMPS])
def test_the_iclone_rig_maps_with_its_clavicles(source: Path) -> None:
    m = read_bvh(source)
    jm = map_joints(m, source=source.name)
    got = {role: m.names[b] for role, b in jm.roles.items()}
    assert got["left_clavicle"] == "CC_Base_L_Clavicle" and got["left_upper_arm"] == "CC_Base_L_Upperarm"
    assert got["right_hand"] == "CC_Base_R_Hand" and got["right_toe"] == "CC_Base_R_ToeBase"
    assert got["hips"] == "CC_Base_Pelvis" and got["chest"] == "CC_Base_Spine02" and got["neck"] == "CC_Base_NeckTwist01"
    assert (jm.rig, jm.unit, jm.how) == ("iClone", "cm", "detected")
    assert 1.2 < jm.height_m < 1.9


@pytest.mark.parametrize("convention", sorted(CONVENTIONS))
def test_every_convention_imports_the_same_motion(convention: str, tmp_path: Path) -> None:
    original = read_bvh(WALK)
    written = convert(WALK, tmp_path / f"{convention}.bvh", convention)
    motion = read_bvh(written)
    explicit = load_joint_map(Path("configs/joint_maps/rigify.toml")) if convention == "rigify" else None
    jm = map_joints(motion, explicit, source=written.name)
    assert jm.unit == {"mixamo": "cm", "cgspeed": "in", "asf": "m", "deepmimic": "m", "rigify": "cm"}[convention]
    assert abs(jm.height_m - map_joints(original).height_m) < 1e-4  # the same body in any unit (written to 1e-6)
    upper = motion.names[jm.roles["left_upper_arm"]]
    assert upper == {"mixamo": "mixamorig:LeftArm", "cgspeed": "LeftArm", "asf": "LeftShoulder",
                     "deepmimic": "left_shoulder", "rigify": "DEF-upper_arm.L"}[convention]
    want, got = bvh_to_clip(original), bvh_to_clip(motion, joint_map=jm)
    # the same bones point the same way: the Euler text round trip costs ~1e-6 degrees
    gap = np.abs(np.abs(np.sum(want.joint_rots * got.joint_rots, axis=-1)) - 1.0)
    assert gap.max() < 1e-8
    assert np.abs(np.abs(np.sum(want.root_rot * got.root_rot, axis=-1)) - 1.0).max() < 1e-8
    # the root's path in the file's units (1e-5 m: positions are written to 6 decimals)
    assert np.allclose(got.root_pos * jm.scale, want.root_pos * 0.01, atol=1e-5)


def test_without_clavicles_the_shoulder_is_the_upper_arm(tmp_path: Path) -> None:
    written = convert(WALK, tmp_path / "asf.bvh", "asf", drop_clavicles=True)
    motion = read_bvh(written)
    jm = map_joints(motion)
    assert motion.names[jm.roles["right_upper_arm"]] == "RightShoulder" and "right_clavicle" not in jm.roles
    assert motion.names[jm.roles["chest"]] == "Spine1"


def test_an_upper_arm_named_a_clavicle_is_refused_not_guessed(tmp_path: Path) -> None:
    written = convert(WALK, tmp_path / "odd.bvh", "cgspeed", rename={"LeftArm": "LeftClavicle2"})
    with pytest.raises(MotionFileError, match="left_upper_arm: LeftClavicle2 is named as a clavicle"):
        map_joints(read_bvh(written), source="odd.bvh")


def test_every_missing_joint_is_listed_at_once(tmp_path: Path) -> None:
    written = convert(WALK, tmp_path / "rigify.bvh", "rigify",
                      rename={"DEF-hand.L": "DEF-palm.L", "DEF-foot.R": "DEF-sole.R"})
    with pytest.raises(MotionFileError) as caught:
        map_joints(read_bvh(written), source="rigify.bvh")
    text = str(caught.value)
    for role in ("left_hand: no joint named left wrist or hand", "right_foot: no joint named right ankle or foot",
                 "head: no joint named head", "--joint-map"):
        assert role in text, text
    assert "\n" not in text


def test_units_are_detected_or_given(tmp_path: Path) -> None:
    m = read_bvh(WALK)
    assert map_joints(m, unit="in").unit == "in"
    detected, given = map_joints(m), map_joints(m, height=1.37)
    assert (given.how, given.height_m) == ("--height", 1.37)
    assert given.scale * detected.height_m / detected.scale == pytest.approx(1.37, rel=1e-12)
    tiny = convert(WALK, tmp_path / "tiny.bvh", "asf")
    text = tiny.read_text(encoding="utf-8")
    head, motion = text.split("MOTION", 1)
    scaled = re.sub(r"OFFSET (\S+) (\S+) (\S+)", lambda g: "OFFSET " + " ".join(
        f"{float(v) * 0.1:.6f}" for v in g.groups()), head)  # a 13 cm figure: no unit fits
    (tmp_path / "tiny.bvh").write_text(scaled + "MOTION" + motion, encoding="utf-8")
    with pytest.raises(MotionFileError, match=r"tiny.bvh: cannot tell the unit .* give --unit or --height"):
        map_joints(read_bvh(tmp_path / "tiny.bvh"), source="tiny.bvh")


def test_a_joint_map_file_is_checked(tmp_path: Path) -> None:
    bad = tmp_path / "map.toml"
    bad.write_text('[joints]\nnose = "Head"\n', encoding="utf-8")
    with pytest.raises(MotionFileError, match=r"map.toml: joints.'nose': not a role"):
        load_joint_map(bad)
    bad.write_text('[joints]\nhead = "Kopf"\n', encoding="utf-8")
    with pytest.raises(MotionFileError, match=r"head: the joint map names 'Kopf'"):
        map_joints(read_bvh(WALK), load_joint_map(bad), source="walk")


def test_the_command_imports_a_converted_rig_and_says_the_height(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    from jostle.cli.commands import main

    written = convert(JUMPS, tmp_path / "take.bvh", "rigify")
    rc = main(["keyframes", "import", str(written), "--into", str(tmp_path / "set"), "--name", "walk",
               "--axis", "dz", "--at", "theta_x=0,theta_z=0,dx=0", "--keys", "4",
               "--joint-map", "configs/joint_maps/rigify.toml"])
    err = capsys.readouterr().err
    assert rc == 0 and "unit cm (detected), standing height 1.8" in err, err
    assert (tmp_path / "set" / "poses" / "walk.toml").is_file()


@pytest.mark.slow
def test_every_shipped_cmu_clip_imports(tmp_path: Path) -> None:
    from render.keyframes.clip_import import Placement, import_clip

    clips = sorted(MEDIA.resolve().glob("*.bvh"))
    if not clips:
        pytest.skip(f"no media folder at {MEDIA.resolve()}")
    for clip in clips:
        _, said = import_clip(clip, tmp_path / clip.stem, Placement("walk", "walk", "dz", {"theta_x": 0.0,
                              "theta_z": 0.0, "dx": "any"}), keys=8)
        assert "rig iClone, unit cm (detected)" in said, (clip.name, said)
    assert len(clips) == 37



def test_a_ragdoll_from_the_asf_release_moves_its_upper_arms(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """CMU's ASF-style LeftShoulder is the upper arm: it is a driven shoulder, LeftCollar the fixed clavicle."""
    from jostle.cli.commands import main
    from sim.articulated.bvh_body import bvh_body

    written = convert(WALK, tmp_path / "asf.bvh", "asf")
    body = bvh_body(read_bvh(written))
    kinds = {link.name: (link.kind, link.motion_channel) for link in body.skeleton.links}
    assert kinds["LeftShoulder"] == ("universal", "left_shoulder") and kinds["LeftCollar"] == ("fixed", "")
    assert kinds["RightElbow"] == ("hinge", "right_elbow") and kinds["Neck"] == ("ball", "neck")
    iclone = bvh_body(read_bvh(WALK))  # the 100-joint rig: its twist and finger joints ride along, fixed
    moving = {link.motion_channel for link in iclone.skeleton.links if link.motion_channel}
    assert len(moving) == 12 and iclone.scale == 0.01
    assert main(["ragdoll", "body", str(written), "--height", "1.37"]) == 0
    out = capsys.readouterr().out
    assert "rig CMU ASF-style, unit scaled (--height), standing height 1.37 m" in out, out
