"""The shipped keyframe set for the humanoid (``configs/keyframes/humanoid/``), built deterministically.

``python -m render.default_set [out_dir]`` rebuilds it. What it holds:

- **walk** (B = "walk"), family ``walk``: four animations along Dz, each 8 keys sampled evenly
  over the cycle of pybullet's ``humanoid3d_walk`` mocap (root translation removed, mean heading
  turned to +x). They sit at Dx = 0, 0.25, 0.5, 0.75: the one at Dx = 0 is the clip itself, the
  others the same cycle with the hips turned outward (abduction) by one phase of a side step, so
  moving along Dx steps sideways. That side step is synthesised, not captured: a plain stance-width
  change about the hips, with the ankles levelled; no weight shift, no crossing of the legs.
- **falls** (B = "walk"): forward and backward along Θx, right and left along Θz, each starting at
  Θ = 0 from whatever the walk gives at the query's phase (a key that refers to family ``walk``).
  Hand-posed by rotating joints: falling forward the arms come forward to catch; falling backward
  the body folds, sits and rolls onto its back; falling sideways the arms flutter and reach out.
  The lying ends are the first frames of the get-up clips, so lying and getting up share a pose.
- **stand_up** (B = "stand_up"): ``humanoid3d_getup_faceup`` along Θx < 0 and
  ``humanoid3d_getup_facedown`` along Θx > 0, ending at Θx = 0 in the walk. A frame's Θ is where a
  rigid body rising about its base would hold its centre of mass at the frame's height:
  |Θ| = arccos((h − h_lying) / (h_standing − h_lying)). The root's own tilt is not monotone in these
  clips (measured: face-up pelvis pitch −97° → −164° while rocking back → −7° → −20° in the squat →
  +12° → 2°), and the rise out of the squat happens with the trunk upright, so it cannot order the
  keys; the centre-of-mass height can, after the rocking (keys follow its running maximum). Each
  frame is expressed in the body frame at that Θ, heading taken from the trunk.

Every pose puts the skeleton's centre of mass at the body origin (the sim's centre of mass).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from render import quaternion as quat
from render.keyframe_file import FORMAT
from render.mocap import HUMANOID, JOINTS, MotionClip, pybullet_motion_path
from render.pose_text import format_pose
from render.skeleton_pose import (
    X,
    Z,
    centre_of_mass,
    chain,
    in_body_frame,
    joints,
    mirror,
    rot,
    standing_height,
    tilt_rotation,
    yaw_rotation,
)

WALK_KEYS = 8
SIDE_PHASES = (0.0, 0.25, 0.5, 0.75)
# hip abduction (degrees, right, left) at each side-step phase: right foot out, both wide, left follows
SIDE_ABDUCTION = ((0.0, 0.0), (20.0, 3.0), (11.0, 11.0), (2.0, 8.0))
# get-up keys: |Θ| (radians) between lying (π/2) and upright (0, where the walk takes over)
GETUP_TILTS = (1.35, 1.15, 0.95, 0.75, 0.55, 0.38, 0.22, 0.1)

Posed = tuple[np.ndarray, np.ndarray]  # (root_offset (3,), rotations (1 + J, 4))


def _posed(root_offset: np.ndarray, root_rot: np.ndarray, joint_rots: np.ndarray) -> Posed:
    return np.asarray(root_offset, dtype=float), np.concatenate([root_rot[None], joint_rots], axis=0)


def _upright(root_rot: np.ndarray, joint_rots: np.ndarray) -> Posed:
    off, rr = in_body_frame(quat.IDENTITY, root_rot, joint_rots)
    return _posed(off, rr, joint_rots)


def _authored(root_rot: np.ndarray, joint_rots: np.ndarray) -> Posed:
    """A hand-made pose, already relative to the body (root_rot relative to the tilted body)."""
    off = -centre_of_mass(np.zeros(3), root_rot, joint_rots)
    return _posed(off, quat.normalize(root_rot), joint_rots)


# ------------------------------------------------------------------------------ walk


def walk_keys() -> list[tuple[np.ndarray, np.ndarray]]:
    """(root_rot, joint_rots) of the walk cycle at Dz = k / WALK_KEYS, mean heading turned to +x."""
    clip = MotionClip.load(pybullet_motion_path("walk"))
    samples = [clip.sample(clip.duration * k / WALK_KEYS) for k in range(WALK_KEYS)]
    fwd = np.array([quat.rotate(r, X) for _, r, _ in samples])
    heading = math.atan2(-float(fwd[:, 2].mean()), float(fwd[:, 0].mean()))
    turn = quat.conjugate(yaw_rotation(heading))
    return [(quat.multiply(turn, r), j) for _, r, j in samples]


def side_stepped(joint_rots: np.ndarray, right_deg: float, left_deg: float) -> np.ndarray:
    """The walk's joints with the hips turned outward (right about −x, left about +x), ankles levelled."""
    out = joint_rots.copy()
    for side, deg in (("right", -right_deg), ("left", left_deg)):
        hip, ankle = JOINTS.index(f"{side}_hip"), JOINTS.index(f"{side}_ankle")
        out[hip] = quat.multiply(rot(X, deg), joint_rots[hip])
        out[ankle] = quat.multiply(rot(X, -deg), joint_rots[ankle])
    return out


# ------------------------------------------------------------------------------ falls (hand-posed)


def _arms(flex_r: float, abd_r: float, elbow_r: float, flex_l: float, abd_l: float, elbow_l: float) -> dict:
    return {
        "right_shoulder": chain(rot(X, -abd_r), rot(Z, flex_r)),
        "right_elbow": rot(Z, elbow_r),
        "left_shoulder": chain(rot(X, abd_l), rot(Z, flex_l)),
        "left_elbow": rot(Z, elbow_l),
    }


def _legs(
    hip_r: float, knee_r: float, hip_l: float, knee_l: float, abd_r: float = 0.0, abd_l: float = 0.0
) -> dict:
    return {
        "right_hip": chain(rot(X, -abd_r), rot(Z, hip_r)),
        "right_knee": rot(Z, -knee_r),
        "right_ankle": rot(Z, 0.3 * knee_r),
        "left_hip": chain(rot(X, abd_l), rot(Z, hip_l)),
        "left_knee": rot(Z, -knee_l),
        "left_ankle": rot(Z, 0.3 * knee_l),
    }


def _trunk(lean_fwd: float, neck_fwd: float, lean_right: float = 0.0, neck_right: float = 0.0) -> dict:
    return {
        "chest": chain(rot(X, lean_right), rot(Z, -lean_fwd)),
        "neck": chain(rot(X, neck_right), rot(Z, -neck_fwd)),
    }


def fall_forward_keys() -> list[tuple[float, str, Posed]]:
    keys = [
        (
            0.3,
            "fall_forward_stumble",
            _trunk(8, -15) | _arms(62, 15, 40, 55, 15, 45) | _legs(45, 55, -12, 15),
        ),
        (0.75, "fall_forward_reach", _trunk(5, -30) | _arms(88, 12, 15, 84, 12, 18) | _legs(25, 20, -5, 45)),
        (1.2, "fall_forward_brace", _trunk(0, -38) | _arms(118, 15, 35, 114, 15, 35) | _legs(8, 20, -4, 32)),
    ]
    return [(t, name, _authored(quat.IDENTITY, joints(**j))) for t, name, j in keys]


def fall_backward_keys() -> list[tuple[float, str, Posed]]:
    keys = [
        # staggering back: upper body forward against the fall, arms flung forward, a leg steps back
        (
            -0.3,
            "fall_backward_stagger",
            0.0,
            _trunk(20, 10) | _arms(70, 25, 30, 75, 25, 35) | _legs(20, 20, -8, 40),
        ),
        # folding: hips and knees bend, the pelvis stays nearer upright than the body
        (
            -0.7,
            "fall_backward_fold",
            25.0,
            _trunk(25, 15) | _arms(62, 18, 40, 58, 18, 45) | _legs(85, 100, 80, 105),
        ),
        # sitting on the floor, legs out in front, hands behind for support
        (
            -1.1,
            "fall_backward_sit",
            33.0,
            _trunk(22, 10) | _arms(-35, 15, 10, -32, 15, 12) | _legs(52, 40, 48, 48),
        ),
    ]
    out = []
    for t, name, pelvis_fwd, j in keys:
        out.append((t, name, _authored(rot(Z, -pelvis_fwd), joints(**j))))
    return out


def fall_right_keys() -> list[tuple[float, str, Posed]]:
    keys = [
        # arms flutter up, the left leg lifts out
        (
            0.3,
            "fall_right_flail",
            _trunk(0, 0, -8, -15) | _arms(10, 60, 25, 15, 120, 35) | _legs(5, 15, 5, 25, 0, 25),
        ),
        (
            0.7,
            "fall_right_reach",
            _trunk(0, 0, -10, -20) | _arms(15, 85, 15, 10, 55, 60) | _legs(5, 20, 8, 20, 0, 35),
        ),
        (
            1.1,
            "fall_right_catch",
            _trunk(0, 0, -6, -22) | _arms(15, 120, 25, 20, 100, 30) | _legs(10, 25, 12, 15, 0, 20),
        ),
        (
            math.pi / 2,
            "lying_right_side",
            _trunk(5, 0, 0, -15) | _arms(10, 160, 20, 30, 10, 40) | _legs(22, 32, 30, 45),
        ),
    ]
    return [(t, name, _authored(quat.IDENTITY, joints(**j))) for t, name, j in keys]


# ------------------------------------------------------------------------------ get-ups (mocap)

# (animation, clip, face up, lying frame, frame the final rise starts from). Face up, the clip lies
# still (frame 0), rocks back with the legs over the head (frames 10–100, centre of mass up to
# 0.36 m) and rises from its lowest point after that (frame 102); face down it pushes up from frame 28.
GETUPS = (
    ("stand_up_faceup", "getup_faceup", True, 0, 102),
    ("stand_up_facedown", "getup_facedown", False, 28, 28),
)


def getup_keys(clip_name: str, face_up: bool, lying: int, rise: int) -> list[tuple[float, Posed]]:
    """(Θx, pose) keys of a get-up clip: the lying frame at ±π/2, then one frame per GETUP_TILTS."""
    clip = MotionClip.load(pybullet_motion_path(clip_name))
    com = centre_of_mass(clip.root_pos, clip.root_rot, clip.joint_rots)[:, 1]
    h_lie, h_up = float(com[lying]), float(com[-1])
    envelope = np.maximum.accumulate(com[rise:])  # keys follow the running maximum: Θ never turns back
    sign = -1.0 if face_up else 1.0
    out = [(sign * math.pi / 2, _clip_pose(clip, clip.times[lying], sign * math.pi / 2, face_up))]
    for mag in GETUP_TILTS:
        level = h_lie + math.cos(mag) * (h_up - h_lie)
        i = int(np.argmax(envelope >= level))
        if envelope[i] < level or i == 0:
            raise ValueError(f"{clip_name}: the rise from frame {rise} does not pass {level:.3f} m")
        # the time at which the running maximum crosses the level, between frames
        u = (level - envelope[i - 1]) / (envelope[i] - envelope[i - 1])
        t = clip.times[rise + i - 1] + u * (clip.times[rise + i] - clip.times[rise + i - 1])
        out.append((sign * mag, _clip_pose(clip, t, sign * mag, face_up)))
    return sorted(out, key=lambda k: k[0])


def _clip_pose(clip: MotionClip, t: float, theta_x: float, face_up: bool) -> Posed:
    """A clip frame in the body frame at tilt θx, its heading from the trunk and the pelvis."""
    root_pos, root_rot, joint_rots = clip.sample(float(t))
    pos, _ = HUMANOID.forward_kinematics(root_pos, root_rot, joint_rots)
    trunk = pos[HUMANOID.names.index("neck")] - pos[0]
    trunk = trunk / np.linalg.norm(trunk)
    facing = quat.rotate(root_rot, X)
    h = facing + (-1.0 if face_up else 1.0) * trunk
    heading = math.atan2(-float(h[2]), float(h[0]))
    body = quat.multiply(yaw_rotation(heading), tilt_rotation(theta_x, 0.0))
    off, rr = in_body_frame(body, root_rot, joint_rots)
    return _posed(off, rr, joint_rots)


# ------------------------------------------------------------------------------ writing the set

Key = tuple[float, str, str]  # (coordinate, pose name or "", referenced family or "")


def _anim(
    name: str, behaviour: str, axis: str, at: dict[str, float | str], keys: list[Key], family: str = ""
) -> str:
    def val(v: float | str) -> str:
        return f'"{v}"' if isinstance(v, str) else f"{v:.6g}"

    lines = ["[[animation]]", f'name = "{name}"', f'behaviour = "{behaviour}"']
    if family:
        lines.append(f'family = "{family}"')
    lines.append(f'axis = "{axis}"')
    lines.append("at = { " + ", ".join(f"{k} = {val(v)}" for k, v in at.items()) + " }")
    lines.append("keys = [")
    for x, pose, fam in sorted(keys):
        ref = f'family = "{fam}"' if fam else f'pose = "{pose}"'
        lines.append(f"  {{ at = {x!r}, {ref} }},")
    lines.append("]")
    return "\n".join(lines) + "\n"


def build_default_set(out_dir: Path) -> Path:
    """Write the default humanoid set into ``out_dir``; returns the manifest's path. Deterministic."""
    out_dir = Path(out_dir)
    (out_dir / "poses").mkdir(parents=True, exist_ok=True)
    files: dict[str, list[str]] = {"walk": [], "falls": [], "stand_up": []}
    anims: list[str] = []
    from_walk: Key = (0.0, "", "walk")

    walk = walk_keys()
    for c, (abd_r, abd_l) in zip(SIDE_PHASES, SIDE_ABDUCTION, strict=True):
        tag = f"walk_dx{round(c * 1000):03d}"
        keys: list[Key] = []
        for k, (rr, jr) in enumerate(walk):
            name = f"{tag}_dz{round(1000 * k / WALK_KEYS):03d}"
            note = f"walk phase Dz={k / WALK_KEYS:g} from humanoid3d_walk, side-step phase Dx={c:g}"
            files["walk"].append(format_pose(name, *_upright(rr, side_stepped(jr, abd_r, abd_l)), note))
            keys.append((k / WALK_KEYS, name, ""))
        anims.append(_anim(tag, "walk", "dz", {"theta_x": 0.0, "theta_z": 0.0, "dx": c}, keys, "walk"))

    getups = {name: getup_keys(clip, up, lying, rise) for name, clip, up, lying, rise in GETUPS}
    lying = {
        "lying_face_up": getups["stand_up_faceup"][0][1],
        "lying_face_down": getups["stand_up_facedown"][-1][1],
    }
    for name, posed in lying.items():
        files["falls"].append(format_pose(name, *posed, "the lying frame of the get-up clip"))

    sagittal: dict[str, float | str] = {"theta_z": 0.0, "dx": "any", "dz": "any"}
    lateral: dict[str, float | str] = {"theta_x": 0.0, "dx": "any", "dz": "any"}
    right = fall_right_keys()
    left = [(-t, name.replace("right", "left"), mirror(*posed)) for t, name, posed in right]
    falls = (
        ("fall_forward", "theta_x", sagittal, fall_forward_keys(), (math.pi / 2, "lying_face_down")),
        ("fall_backward", "theta_x", sagittal, fall_backward_keys(), (-math.pi / 2, "lying_face_up")),
        ("fall_right", "theta_z", lateral, right, None),
        ("fall_left", "theta_z", lateral, left, None),
    )
    for name, axis, at, ks, end in falls:
        keys = [from_walk]
        for t, pose_name, posed in ks:
            files["falls"].append(format_pose(pose_name, *posed, f"{name} at {axis}={t:.4g}"))
            keys.append((t, pose_name, ""))
        if end is not None:
            keys.append((end[0], end[1], ""))
        anims.append(_anim(name, "walk", axis, at, keys))

    for name, rising in getups.items():
        keys = [from_walk]
        for t, posed in rising:
            if abs(abs(t) - math.pi / 2) < 1e-12:
                keys.append((t, "lying_face_up" if t < 0 else "lying_face_down", ""))
                continue
            pose_name = f"{name}_{round(math.degrees(abs(t))):03d}"
            files["stand_up"].append(format_pose(pose_name, *posed, f"{name} at theta_x={t:.4g}"))
            keys.append((t, pose_name, ""))
        anims.append(_anim(name, "stand_up", "theta_x", sagittal, keys))

    header = "# Generated by render/default_set.py (python -m render.default_set); see README.md.\n\n"
    for stem, poses in files.items():
        (out_dir / "poses" / f"{stem}.toml").write_text(header + "\n".join(poses), encoding="utf-8")
    manifest = out_dir / "keyframes.toml"
    head = [
        header.rstrip("\n"),
        f"format = {FORMAT}",
        'skeleton = "humanoid"',
        f"height = {standing_height():.4f}",
        'default_behaviour = "walk"',
        "poses = [" + ", ".join(f'"poses/{s}.toml"' for s in files) + "]",
        "",
        "[interpolation]",
        "cycle_weight = 0.5",
        "sharpness = 2.0",
        "",
    ]
    manifest.write_text("\n".join(head) + "\n" + "\n".join(anims), encoding="utf-8")
    return manifest


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    out = (
        Path(args[0])
        if args
        else Path(__file__).resolve().parent.parent / "configs" / "keyframes" / "humanoid"
    )
    print(build_default_set(out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
