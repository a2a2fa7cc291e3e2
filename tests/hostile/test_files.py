"""Every reader of a user's file, given what an attacker would: a FIFO, /dev/zero, a folder, a symlink
loop, an oversized file, deep nesting, a dotted key of 20000 parts. Each must refuse it within a few
seconds with one user error (``jostle.errors.user_facing``: one line naming the file), never hang,
never read it whole, never a traceback."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hang_guard import within

from interaction.depth.calibration import DepthCalibration
from interaction.webcam.calibration import Calibration
from jostle.bench.identify_experiment import load_spec
from jostle.config import load_config
from jostle.config import load_toml as load_config_toml
from jostle.errors import user_facing
from jostle.performer.pads import load_pad_layout
from jostle.terrain_layout import read_layout
from render.keyframes.gltf_io import import_gltf
from render.keyframes.set_check import check_set
from render.keyframes.set_file import read_set
from sensors.untrusted.limits import CHARACTER_SPEC
from sim.motion.bvh import read_bvh
from sim.motion.mocap import MotionClip

SECONDS = 10  # a refusal takes milliseconds; more than this is a hang


def _check_report(path: Path) -> None:
    report = check_set(path)
    if not report.ok:
        raise_from = [p for p in report.problems if p.severity == "error"]
        from render.keyframes.set_file import KeyframeError

        raise KeyframeError(f"{raise_from[0].file}: {raise_from[0].message}")


# name → (reader of a path, whether the file is TOML (else JSON, or neither: None))
READERS: dict[str, tuple[Callable[[Path], Any], str | None]] = {
    "config": (load_config, "toml"),
    "character spec": (lambda p: load_config_toml(p, CHARACTER_SPEC, "character spec"), "toml"),
    "bench character spec": (lambda p: load_spec(str(p)), "toml"),
    "keyframe manifest": (read_set, "toml"),
    "keyframe check": (_check_report, "toml"),
    "webcam calibration": (Calibration.load, "toml"),
    "depth calibration": (DepthCalibration.load, "toml"),
    "terrain layout": (lambda p: read_layout(p, (8, 8), 4), "toml"),
    "pad layout": (load_pad_layout, "toml"),
    "BVH": (read_bvh, None),
    "DeepMimic clip": (MotionClip.load, "json"),
    "glTF": (lambda p: import_gltf(p, p.parent / "set"), "json"),
}


def _hostile(kind: str, tmp_path: Path, syntax: str | None) -> Path:
    """A path in ``tmp_path`` that is the hostile input ``kind``."""
    path = tmp_path / "input.toml"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "dev zero":
        path.symlink_to("/dev/zero")
    elif kind == "folder":
        path.mkdir()
    elif kind == "symlink loop":
        path.symlink_to(tmp_path / "other")
        (tmp_path / "other").symlink_to(path)
    elif kind == "oversized":
        with path.open("wb") as f:  # sparse: 1 GiB on paper, nothing on disk
            f.truncate(1 << 30)
    elif kind == "deep nesting":
        path.write_text("x = " + "[" * 3000 + "]" * 3000 + "\n" if syntax == "toml" else
                        "[" * 100_000 + "]" * 100_000)
    elif kind == "dotted key":
        path.write_text("a" + ".a" * 19_999 + " = 1\n")
    return path


KINDS = ("fifo", "dev zero", "folder", "symlink loop", "oversized", "deep nesting", "dotted key")


CASES = [(reader, kind) for reader in sorted(READERS) for kind in KINDS
         if kind != "dotted key" or READERS[reader][1] == "toml"]  # dotted keys are TOML's


@pytest.mark.parametrize(("reader", "kind"), CASES)
def test_every_reader_refuses_hostile_files_with_one_line(reader: str, kind: str, tmp_path: Path) -> None:
    read, syntax = READERS[reader]
    path = _hostile(kind, tmp_path, syntax)
    with pytest.raises(Exception) as caught:
        within(SECONDS, lambda: read(path))
    message = user_facing(caught.value)
    assert message is not None, f"internal error: {type(caught.value).__name__}: {caught.value}"
    assert "\n" not in message and len(message) <= 500, message
    assert "input.toml" in message or str(tmp_path) in message, message


@pytest.mark.parametrize("kind", ["fifo", "dev zero", "folder"])
def test_a_pose_file_entry_that_is_not_a_regular_file_is_refused(kind: str, tmp_path: Path) -> None:
    pose = _hostile(kind, tmp_path, "toml")
    manifest = tmp_path / "keyframes.toml"
    manifest.write_text(f'format = 1\nskeleton = "humanoid"\nheight = 1.7\nposes = ["{pose.name}"]\n')
    with pytest.raises(Exception) as caught:
        within(SECONDS, lambda: read_set(manifest))
    message = user_facing(caught.value)
    assert message is not None and pose.name in message and "expected a regular file" in message, message


def test_a_long_string_value_is_not_echoed_whole(tmp_path: Path) -> None:
    config = tmp_path / "big.toml"
    config.write_text('[run]\nseed = "' + "a" * 1_000_000 + '"\n')  # just under the 1 MiB a config may be
    with pytest.raises(Exception) as caught:
        load_config(config)
    message = user_facing(caught.value)
    assert message is not None and "run.seed" in message and len(message) < 300, message[:500]


def test_a_bvh_hierarchy_nested_3000_deep_is_refused_by_its_bound(tmp_path: Path) -> None:
    path = tmp_path / "deep.bvh"
    joints = "".join(f"JOINT j{i} {{ OFFSET 0 0 1 CHANNELS 3 Zrotation Xrotation Yrotation " for i in range(3000))
    path.write_text("HIERARCHY ROOT r { OFFSET 0 0 0 CHANNELS 3 Xposition Yposition Zposition " + joints +
                    "}" * 3001 + " MOTION Frames: 1 Frame Time: 0.1 " + "0 " * 9003)
    with pytest.raises(Exception) as caught:
        within(SECONDS, lambda: read_bvh(path))
    message = user_facing(caught.value)
    assert message is not None and "deep.bvh" in message and "more than 64 levels" in message, message
