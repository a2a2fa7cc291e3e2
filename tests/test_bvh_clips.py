"""A BVH file is a clip wherever a clip is asked for (issue J): the virtual performer's --clip and
--person-clips, a ragdoll's walk_clip, the README's ragdoll example; errors name the key and the file."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from jostle.cli.commands import main
from sim.motion.clips import best_cycle, load_motion
from sim.motion.mocap import MotionFileError

ROOT = Path(__file__).resolve().parents[1]
WALK = ROOT / "tests" / "fixtures" / "bvh" / "002_01_excerpt.bvh"  # CMU subject 2 walking, iClone rig


def test_a_bvh_walk_is_cut_to_a_loop_that_travels() -> None:
    clip = load_motion(str(WALK), "clip", cycle=True)
    assert clip.loop and 0.7 <= clip.duration <= 1.3  # the excerpt holds one 1.1 s stride pair at 10 fps
    speed = float(np.linalg.norm(clip.cycle_offset)) / clip.duration
    assert 0.8 < speed < 2.0, speed  # a walk on the 1.6 m humanoid, m/s
    assert 0.7 < float(clip.root_pos[:, 1].mean()) < 1.1  # the hips above the floor, metres
    whole = load_motion(str(WALK), "clip")
    assert not whole.loop and len(whole.times) == 14
    assert best_cycle(whole).times[0] == 0.0


def test_errors_name_the_key_and_the_file(tmp_path: Path) -> None:
    with pytest.raises(MotionFileError, match=r"^walk_clip: .*nope.bvh: no such BVH file$"):
        load_motion(str(tmp_path / "nope.bvh"), "walk_clip")
    with pytest.raises(MotionFileError, match=r"^clip: no pybullet motion clip 'flyy'; known clips: .*walk"):
        load_motion("flyy", "clip")


def test_the_performer_walks_a_bvh(tmp_path: Path) -> None:
    out = tmp_path / "p.mcap"
    assert main(["synth", "performer", "--clip", str(WALK), "--duration", "1", "--size", "160x120",
                 "--out", str(out)]) == 0
    assert out.stat().st_size > 0
    assert main(["synth", "performer", "--clip", str(tmp_path / "gone.bvh"), "--duration", "1",
                 "--out", str(tmp_path / "q.mcap")]) == 2


def test_a_ragdoll_walks_a_bvh_from_its_spec_and_the_readme_example_runs(tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    configs = tmp_path / "configs"
    shutil.copytree(ROOT / "configs", configs, ignore=shutil.ignore_patterns("keyframes"))
    (configs / "keyframes").symlink_to(ROOT / "configs" / "keyframes")
    spec = configs / "characters" / "ragdoll.toml"
    shutil.copy(WALK, configs / "characters" / "walk.bvh")
    spec.write_text(spec.read_text(encoding="utf-8").replace('walk_clip = "walk"', 'walk_clip = "walk.bvh"'),
                    encoding="utf-8")
    assert main(["ragdoll", "export", str(configs / "ragdoll.toml"), "--seconds", "0.5", "--quiet",
                 "--out", str(tmp_path / "take.bvh")]) == 0
    assert (tmp_path / "take_ragdoll.bvh").is_file()
    (configs / "characters" / "walk.bvh").unlink()
    assert main(["ragdoll", "export", str(configs / "ragdoll.toml"), "--seconds", "0.5", "--quiet",
                 "--out", str(tmp_path / "take.bvh")]) == 2
    err = capsys.readouterr().err
    assert "ragdoll.toml: walk_clip: " in err and "walk.bvh: no such BVH file" in err, err


def test_ragdoll_track_reports_every_figure(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    assert main(["ragdoll", "track", str(WALK), "--seconds", "1", "--push", "1", "--json"]) == 0
    row = json.loads(capsys.readouterr().out)
    assert list(row) == ["clip", "body", "seconds", "height_m", "clip_loop_s", "falls", "getups", "tracking_error_deg_mean",
                         "tracking_error_deg_p95", "realtime_factor", "assist_torque_nm_mean", "assist_torque_nm_max",
                         "assist_force_n_max"]
    assert row["clip"] == WALK.name and row["seconds"] == 1.0 and 1.7 < row["height_m"] < 1.9
    assert 0 <= row["tracking_error_deg_mean"] <= row["tracking_error_deg_p95"] < 90
    assert 0 <= row["assist_torque_nm_mean"] <= row["assist_torque_nm_max"] <= 150.0 * 1.5 + 1e-6
    assert main(["ragdoll", "track", str(WALK), "--seconds", "1", "--no-assist", "--json"]) == 0
    bare = json.loads(capsys.readouterr().out)
    assert bare["assist_torque_nm_max"] == bare["assist_force_n_max"] == 0.0
    assert main(["ragdoll", "track", "walk", "--seconds", "-1"]) == 2


def test_bench_ragdoll_takes_a_bvh_clip(tmp_path: Path) -> None:
    from jostle.cli.bench import main_json

    figures = main_json("ragdoll", ["--quick", "--clip", str(WALK)])
    assert figures["tracking_error_deg"] is not None and 0 < float(str(figures["tracking_error_deg"])) < 90
    with pytest.raises(MotionFileError, match=r"^--clip: .*gone.bvh: no such BVH file$"):
        main_json("ragdoll", ["--quick", "--clip", str(tmp_path / "gone.bvh")])


def test_a_ragdoll_spec_takes_a_bvh_skeleton(tmp_path: Path) -> None:
    """skeleton = "FILE.bvh": the file's own body walks its own motion (the CMU ASF-style rig here)."""
    from test_joint_map import convert

    from sim.articulated.spec import ArticulatedSpec

    configs = tmp_path / "configs"
    shutil.copytree(ROOT / "configs", configs, ignore=shutil.ignore_patterns("keyframes"))
    (configs / "keyframes").symlink_to(ROOT / "configs" / "keyframes")
    convert(WALK, configs / "characters" / "asf.bvh", "asf")
    spec = configs / "characters" / "ragdoll.toml"
    spec.write_text(spec.read_text(encoding="utf-8").replace('skeleton = "deepmimic_humanoid"', 'skeleton = "asf.bvh"'),
                    encoding="utf-8")
    assert main(["ragdoll", "export", str(configs / "ragdoll.toml"), "--seconds", "0.3", "--quiet",
                 "--out", str(tmp_path / "take.bvh")]) == 0
    names = (tmp_path / "take_ragdoll.bvh").read_text(encoding="utf-8")
    assert "JOINT left_shoulder" in names and "JOINT LeftCollar" in names  # ASF's upper arm drives, collar rides
    with pytest.raises(ValueError, match=r"skeleton: expected \"deepmimic_humanoid\" or a .bvh file, got 'x.fbx'"):
        ArticulatedSpec(skeleton="x.fbx")


def test_a_joint_map_beside_the_file_serves_every_command(tmp_path: Path) -> None:
    """A Rigify take (its head is a spine bone) works as a performer's clip once take.joints.toml is beside it."""
    from test_joint_map import convert

    take = convert(WALK, tmp_path / "take.bvh", "rigify")
    with pytest.raises(MotionFileError, match=r"^clip: .*take.bvh: cannot map the joints \(head: no joint named "
                       r"head\).*FILE.joints.toml beside the BVH"):
        load_motion(str(take), "clip", cycle=True)
    shutil.copy(ROOT / "configs" / "joint_maps" / "rigify.toml", tmp_path / "take.joints.toml")
    assert load_motion(str(take), "clip", cycle=True).loop
    assert main(["synth", "performer", "--clip", str(take), "--duration", "1", "--size", "160x120",
                 "--out", str(tmp_path / "p.mcap")]) == 0
