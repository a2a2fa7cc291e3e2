"""``jostle ragdoll export``: the command's checks (one-line errors naming what to fix)."""

from __future__ import annotations

from pathlib import Path

import pytest

from jostle.cli import main

CONFIGS = Path(__file__).resolve().parent.parent / "configs"


def test_export_refuses_an_unknown_format_and_a_run_without_an_end(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ragdoll", "export", str(CONFIGS / "demo.toml"), "--out", str(tmp_path / "x.fbx")]) == 2
    assert "--out: expected a .bvh, .gltf or .glb file name" in capsys.readouterr().err
    assert main(["ragdoll", "export", str(CONFIGS / "webcam.toml"), "--out", str(tmp_path / "x.bvh")]) == 2
    assert "webcam.toml: has live sensors; give --seconds" in capsys.readouterr().err
    assert not (tmp_path / "x.bvh").exists()


def test_export_of_a_run_without_articulated_characters_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["ragdoll", "export", str(CONFIGS / "demo.toml"), "--seconds", "0.2", "--out", str(tmp_path / "x.bvh"),
                 "--quiet"])
    assert code == 2
    assert "demo.toml: the run has no articulated characters" in capsys.readouterr().err


def ragdoll_config(tmp_path: Path, count: int = 2) -> Path:
    """The demo's recording and observer with ``count`` articulated characters (configs/characters/ragdoll.toml)."""
    path = tmp_path / "ragdoll.toml"
    path.write_text(f"""
[run]
seed = 3

[sensors.webcam]
type = "replay"
path = "{CONFIGS / 'recordings' / 'demo.mcap'}"
channel = "webcam"

[observers.webcam]
type = "webcam"
sensor = "webcam"
calibration = "{CONFIGS / 'recordings' / 'demo.calibration.toml'}"

[[characters]]
spec = "{CONFIGS / 'characters' / 'ragdoll.toml'}"
count = {count}

[render]
keyframes = "{CONFIGS / 'keyframes' / 'humanoid' / 'keyframes.toml'}"
""", encoding="utf-8")
    return path


def test_export_writes_what_the_run_did_bvh_and_gltf(tmp_path: Path) -> None:
    import argparse

    import numpy as np

    from jostle.cli.ragdoll import collect
    from sim.articulated.export import STAGE_TO_Y_UP, read_gltf_rotations
    from sim.motion import quaternion as quat
    from sim.motion.bvh import read_bvh

    config = ragdoll_config(tmp_path)
    base = ["ragdoll", "export", str(config), "--seconds", "1", "--quiet"]
    assert main([*base, "--out", str(tmp_path / "take.bvh")]) == 0
    assert main([*base, "--out", str(tmp_path / "one.glb"), "--character", "ragdoll-2"]) == 0
    assert sorted(p.name for p in tmp_path.glob("take_*.bvh")) == ["take_ragdoll-2.bvh", "take_ragdoll.bvh"]
    # the same run again (same seed, simulated time: the same snapshots), for the expected joint angles
    snaps = collect(argparse.Namespace(run=config, config=None, fps=None, seed=None, seconds=1.0, quiet=True))
    links = [next(c for c in s.characters if c.name == "ragdoll-2").links for s in snaps]
    names = [lk.name for lk in links[0]]
    world = quat.multiply(STAGE_TO_Y_UP, np.array([[lk.orientation for lk in f] for f in links]))
    m = read_bvh(tmp_path / "take_ragdoll-2.bvh")
    gl_names, _, gl_rot = read_gltf_rotations(tmp_path / "one.glb")
    assert m.frames == len(snaps) == 30 and m.local_rotations is not None and list(gl_names) == names
    def angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:  # exact for small angles, unlike arccos
        d = quat.multiply(quat.conjugate(quat.normalize(a)), quat.normalize(b))
        return 2.0 * np.arctan2(np.linalg.norm(d[..., :3], axis=-1), np.abs(d[..., 3]))

    parent = {"chest": "root", "neck": "chest", "right_knee": "right_hip", "left_elbow": "left_shoulder"}
    for child, par in parent.items():
        want = quat.multiply(quat.conjugate(world[:, names.index(par)]), world[:, names.index(child)])
        assert angle(m.local_rotations[:, m.names.index(child)], want).max() < 1e-4, child  # 6 decimals of a degree
        assert angle(gl_rot[:, names.index(child)], want).max() < 1e-5, child  # float32


def test_body_lists_what_a_bvh_file_makes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from test_bvh_body import bvh_from_clip

    bvh_from_clip(tmp_path / "walk.bvh", frames=5)
    assert main(["ragdoll", "body", str(tmp_path / "walk.bvh"), "--mass", "60", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["scale_m_per_unit"] == pytest.approx(0.01) and doc["frames"] == 5
    assert sum(link["mass"] for link in doc["links"]) == pytest.approx(60.0)
    assert {link["name"]: link["kind"] for link in doc["links"]}["RightLeg"] == "hinge"
    assert main(["ragdoll", "body", str(tmp_path / "walk.bvh")]) == 0
    out = capsys.readouterr().out
    assert "18 links, 70.0 kg, 5 frames" in out and "RightLeg" in out
