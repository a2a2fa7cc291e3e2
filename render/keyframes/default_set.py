"""The shipped keyframe sets (``configs/keyframes/humanoid/`` and ``configs/keyframes/critter/``), built
deterministically by ``jostle keyframes build-default`` (or ``python -m render.keyframes.default_set [folder]``).

The humanoid set: one-dimensional animations of walking (four along Dz at Dx = 0, 0.25, 0.5, 0.75,
one family), staggering and falling (B = "walk", along Θ) and standing up (B = "stand_up"), from
pybullet's DeepMimic clips and the hand-made poses of ``render.keyframes.default_poses``. The
critter set: the same animations on the ``critter`` figure, with the ``humanoid3d_run`` cycle for
Dz, every pose placed with the critter's own centre of mass. What each animation holds and where it
comes from: ``configs/keyframes/humanoid/README.md``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

from render.keyframes.default_poses import (
    GETUPS,
    STAGGER_BACKWARD,
    STAGGER_FORWARD,
    STAGGER_RIGHT,
    Posed,
    cycle_keys,
    fall_backward_keys,
    fall_forward_keys,
    fall_right_keys,
    getup_keys,
    hand_posed,
    layered,
    side_step_keys,
    staggered,
    upright,
)
from render.keyframes.pose_text import format_pose
from render.keyframes.set_file import FORMAT
from render.keyframes.skeleton_pose import mirror, standing_height
from render.keyframes.skeletons import CRITTER_FIGURE, HUMANOID_FIGURE, Figure
from sensors.untrusted import write_owned

CYCLE_KEYS = 8
SIDE_KEYS = 6
SIDE_PHASES = (0.0, 0.25, 0.5, 0.75)
STAGGER_TILT = 0.3
SETS = {"humanoid": (HUMANOID_FIGURE, "walk"), "critter": (CRITTER_FIGURE, "run")}

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


def _phase(x: float) -> float:
    return round(x - math.floor(x), 12)


def build_set(out_dir: Path, figure: Figure = HUMANOID_FIGURE, cycle: str = "walk") -> Path:
    """Write one set into ``out_dir`` (manifest + poses/); returns the manifest's path. Deterministic."""
    out_dir = Path(out_dir)
    (out_dir / "poses").mkdir(parents=True, exist_ok=True)
    files: dict[str, list[str]] = {"walk": [], "stagger": [], "falls": [], "stand_up": []}
    anims: list[str] = []

    def add(file: str, name: str, pose: Posed, note: str) -> Key:
        files[file].append(format_pose(name, *pose, note))
        return (0.0, name, "")

    # walk: the cycle along Dz, with the side step's legs layered on along Dx
    walk = cycle_keys(cycle, CYCLE_KEYS)
    side = side_step_keys([k / SIDE_KEYS for k in range(SIDE_KEYS)])
    for c, step in zip(SIDE_PHASES, side_step_keys(list(SIDE_PHASES)), strict=True):
        tag = f"walk_dx{round(c * 1000):03d}"
        keys: list[Key] = []
        for k, raw in enumerate(walk):
            name = f"{tag}_dz{round(1000 * k / CYCLE_KEYS):03d}"
            note = f"{cycle} phase Dz={k / CYCLE_KEYS:g} (humanoid3d_{cycle}), side-step legs at Dx={c:g}"
            keys.append((k / CYCLE_KEYS, add("walk", name, upright(layered(raw, step, side[0]), figure), note)[1], ""))
        anims.append(_anim(tag, "walk", "dz", {"theta_x": 0.0, "theta_z": 0.0, "dx": c}, keys, "walk"))

    # staggers: hurrying the way the body leans
    sagittal_cycle: dict[str, float | str] = {"theta_z": 0.0, "dx": "any"}
    for name, tilt, upper in (("stagger_forward", STAGGER_TILT, STAGGER_FORWARD),
                              ("stagger_backward", -STAGGER_TILT, STAGGER_BACKWARD)):
        keys = []
        for k, raw in enumerate(walk):
            pose_name = f"{name}_dz{round(1000 * k / CYCLE_KEYS):03d}"
            posed = upright(staggered(raw, upper), figure)
            keys.append((k / CYCLE_KEYS, add("stagger", pose_name, posed, f"{name} at Dz={k / CYCLE_KEYS:g}")[1], ""))
        at: dict[str, float | str] = {"theta_x": tilt}
        anims.append(_anim(name, "walk", "dz", at | sagittal_cycle, keys))
    right_keys: list[Key] = []
    left_keys: list[Key] = []
    for k, raw in enumerate(side):
        phase = k / SIDE_KEYS
        stepping = upright(staggered(raw, STAGGER_RIGHT), figure)
        n_right = f"stagger_right_dx{round(1000 * phase):03d}"
        right_keys.append((phase, add("stagger", n_right, stepping, f"side step right at Dx={phase:g}")[1], ""))
        # the mirror image steps left: it advances as Dx decreases
        n_left = f"stagger_left_dx{round(1000 * _phase(-phase)):03d}"
        left_keys.append((_phase(-phase), add("stagger", n_left, mirror(*stepping), f"mirror of {n_right}")[1], ""))
    lateral_cycle: dict[str, float | str] = {"theta_x": 0.0, "dz": "any"}
    right_at: dict[str, float | str] = {"theta_z": STAGGER_TILT}
    left_at: dict[str, float | str] = {"theta_z": -STAGGER_TILT}
    anims.append(_anim("stagger_right", "walk", "dx", right_at | lateral_cycle, right_keys))
    anims.append(_anim("stagger_left", "walk", "dx", left_at | lateral_cycle, left_keys))

    # falls
    getups = {name: getup_keys(clip, up, lying, rise, figure) for name, clip, up, lying, rise in GETUPS}
    add("falls", "lying_face_up", getups["stand_up_faceup"][0][1], "the lying frame of the get-up clip")
    add("falls", "lying_face_down", getups["stand_up_facedown"][-1][1], "the lying frame of the get-up clip")
    sagittal: dict[str, float | str] = {"theta_z": 0.0, "dx": "any", "dz": "any"}
    lateral: dict[str, float | str] = {"theta_x": 0.0, "dx": "any", "dz": "any"}
    right = hand_posed(fall_right_keys(), figure)
    left = [(-t, name.replace("right", "left"), mirror(*p)) for t, name, p in right]
    falls = (
        ("fall_forward", "theta_x", sagittal, hand_posed(fall_forward_keys(), figure), STAGGER_TILT,
         "stagger_forward", (math.pi / 2, "lying_face_down")),
        ("fall_backward", "theta_x", sagittal, hand_posed(fall_backward_keys(), figure), -STAGGER_TILT,
         "stagger_backward", (-math.pi / 2, "lying_face_up")),
        ("fall_right", "theta_z", lateral, right, STAGGER_TILT, "stagger_right", None),
        ("fall_left", "theta_z", lateral, left, -STAGGER_TILT, "stagger_left", None),
    )
    for name, axis, at, ks, tilt, stagger, end in falls:
        keys = [(0.0, "", "walk"), (tilt, "", stagger)]
        for t, pose_name, p in ks:
            keys.append((t, add("falls", pose_name, p, f"{name} at {axis}={t:.4g}")[1], ""))
        if end is not None:
            keys.append((end[0], end[1], ""))
        anims.append(_anim(name, "walk", axis, at, keys))

    # stand up
    for name, rising in getups.items():
        keys = [(0.0, "", "walk")]
        for t, p in rising:
            if abs(abs(t) - math.pi / 2) < 1e-12:
                keys.append((t, "lying_face_up" if t < 0 else "lying_face_down", ""))
                continue
            pose_name = f"{name}_{round(math.degrees(abs(t))):03d}"
            keys.append((t, add("stand_up", pose_name, p, f"{name} at theta_x={t:.4g}")[1], ""))
        anims.append(_anim(name, "stand_up", "theta_x", sagittal, keys))

    header = "# Generated by `jostle keyframes build-default` (render/keyframes/default_set.py); see README.md.\n\n"
    for stem, poses in files.items():
        write_owned(out_dir / "poses" / f"{stem}.toml", header + "\n".join(poses))
    manifest = out_dir / "keyframes.toml"
    head = [
        header.rstrip("\n"),
        f"format = {FORMAT}",
        f'skeleton = "{figure.name}"',
        f"height = {standing_height(figure):.4f}",
        'default_behaviour = "walk"',
        "poses = [" + ", ".join(f'"poses/{s}.toml"' for s in files) + "]",
        "",
        "[interpolation]",
        "cycle_weight = 0.5",
        "sharpness = 2.0",
        "",
    ]
    write_owned(manifest, "\n".join(head) + "\n" + "\n".join(anims))
    return manifest


def build_default_set(out_dir: Path) -> Path:
    """The humanoid set into ``out_dir``."""
    return build_set(out_dir, HUMANOID_FIGURE, "walk")


def build_default_sets(folder: Path) -> list[Path]:
    """Every shipped set into ``folder/<name>/``; returns the manifests."""
    return [build_set(Path(folder) / name, figure, cycle) for name, (figure, cycle) in SETS.items()]


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    folder = Path(args[0]) if args else Path(__file__).resolve().parents[2] / "configs" / "keyframes"
    for manifest in build_default_sets(folder):
        print(manifest)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
