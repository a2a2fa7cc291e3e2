"""Imports into a keyframe set are transactions, and a glTF file is checked before it is trusted:
every structural error (a missing accessor, ``MAT4``, a count past the buffer, a buffer ``uri`` out of
the file's folder or onto a FIFO, …) is one user error naming the file and what is wrong, and a failed
import leaves the set's folder byte for byte as it was (or absent, if it was)."""

from __future__ import annotations

import copy
import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from jostle.errors import user_facing
from render.keyframes.clip_import import Placement, import_clip
from render.keyframes.gltf_io import export_gltf, import_gltf
from render.keyframes.keyframe_set import KeyframeSet
from render.keyframes.set_check import check_set
from sim.motion.mocap import pybullet_motion_path

ROOT = Path(__file__).resolve().parent.parent.parent
HUMANOID = ROOT / "configs" / "keyframes" / "humanoid"


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The shipped humanoid set exported to glTF (buffer embedded), as parsed JSON."""
    path = export_gltf(KeyframeSet.load(HUMANOID / "keyframes.toml"), tmp_path_factory.mktemp("gltf") / "h.gltf")
    doc: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return doc


@pytest.fixture(scope="module")
def single(exported: dict[str, Any]) -> dict[str, Any]:
    """The first animation alone, renamed with its poses, so it also imports into the shipped set."""
    doc = copy.deepcopy(exported)
    anim = doc["animations"][0]
    anim["name"] = "imported_walk"
    anim["extras"]["jostle"]["family"] = "imported_walk"
    for key in anim["extras"]["jostle"]["keys"]:
        key["pose"] = "imported_" + key["pose"]
    doc["animations"] = [anim]
    return doc


def _snapshot(folder: Path) -> dict[str, bytes | None]:
    """Every file (bytes) and folder (None) under ``folder``, by relative path."""
    if not folder.exists():
        return {}
    return {p.relative_to(folder).as_posix(): (p.read_bytes() if p.is_file() else None) for p in folder.rglob("*")}


def _last_family(d: dict[str, Any]) -> None:
    d["animations"][-1]["extras"]["jostle"]["keys"][0] = {"at": 0.0, "family": "no_such_family"}


# what to break → words the one-line error must hold
BROKEN: dict[str, tuple[Callable[[dict[str, Any]], None], str]] = {
    "MAT4": (lambda d: d["accessors"][1].update(type="MAT4"), "accessor 1: type 'MAT4'"),
    "no accessor": (lambda d: d["animations"][0]["samplers"][0].update(output=9999), "accessor 9999: no such accessor"),
    "huge count": (lambda d: d["accessors"][1].update(count=10**9), "accessor 1: count"),
    "past the view": (lambda d: d["accessors"][1].update(count=9), "run past its buffer view"),
    "no view": (lambda d: d["accessors"][1].update(bufferView=999), "accessor 1: bufferView 999: no such buffer view"),
    "view past buffer": (lambda d: d["bufferViews"][1].update(byteLength=10**9), "bufferView byteLength"),
    "not float": (lambda d: d["accessors"][1].update(componentType=5123), "accessor 1: expected float data"),
    "no buffer": (lambda d: d["bufferViews"][1].update(buffer=5), "buffer 5: no such buffer"),
    "negative offset": (lambda d: d["accessors"][1].update(byteOffset=-4), "accessor 1: byteOffset"),
    "tiny stride": (lambda d: d["bufferViews"][1].update(byteStride=1), "byteStride"),
    "uri escape": (lambda d: d["buffers"][0].update(uri="../../../../../../etc/passwd"), "leads outside this folder"),
    "uri absolute": (lambda d: d["buffers"][0].update(uri="/etc/passwd"), "expected a relative path inside"),
    "uri fifo": (lambda d: d["buffers"][0].update(uri="fifo.bin"), "('fifo.bin'): is a FIFO"),
    "bad base64": (lambda d: d["buffers"][0].update(uri="data:application/octet-stream;base64,!!!"), "not valid base64"),
    "no sampler": (lambda d: d["animations"][0]["channels"][0].update(sampler=99), "channel 0: no such sampler"),
    "keys not a list": (lambda d: d["animations"][0]["extras"]["jostle"].update(keys="x"), "keys: expected a list"),
    "key at nan": (lambda d: d["animations"][0]["extras"]["jostle"]["keys"][0].update(at="nan"), "key 0: at"),
    "path in a name": (lambda d: d["animations"][0].update(name="../../evil"), "'../../evil'"),
    "quote in a pose": (lambda d: d["animations"][0]["extras"]["jostle"]["keys"][0].update(pose='a"]\nx'), "pose"),
    "unknown family": (_last_family, "no_such_family"),
}


@pytest.mark.parametrize("fresh", [False, True], ids=["into the shipped set", "into a new set"])
@pytest.mark.parametrize("case", sorted(BROKEN))
def test_a_broken_gltf_is_one_line_and_leaves_the_set_as_it_was(
        case: str, fresh: bool, single: dict[str, Any], tmp_path: Path) -> None:
    edit, said = BROKEN[case]
    doc = copy.deepcopy(single)
    edit(doc)
    source = tmp_path / "in" / "broken.gltf"
    source.parent.mkdir()
    source.write_text(json.dumps(doc), encoding="utf-8")
    os.mkfifo(source.parent / "fifo.bin")
    set_dir = tmp_path / "set"
    if not fresh:
        shutil.copytree(HUMANOID, set_dir)
    before = _snapshot(set_dir)
    with pytest.raises(Exception) as caught:
        import_gltf(source, set_dir)
    message = user_facing(caught.value)
    assert message is not None, f"internal error: {type(caught.value).__name__}: {caught.value}"
    assert "\n" not in message and "broken.gltf" in message and said in message, message
    assert _snapshot(set_dir) == before  # nothing written, nothing left behind (no staging folder)
    assert fresh or check_set(set_dir).ok


def test_a_clip_import_that_fails_its_check_leaves_the_set_as_it_was(tmp_path: Path) -> None:
    set_dir = tmp_path / "set"
    shutil.copytree(HUMANOID, set_dir)
    before = _snapshot(set_dir)
    placement = Placement("walk_again", "walk", "dz", {"theta_x": 0.0, "theta_z": 0.0, "dx": "any"},
                          family="no_such_family")
    with pytest.raises(Exception) as caught:
        import_clip(pybullet_motion_path("walk"), set_dir, placement, keys=4)
    assert user_facing(caught.value) is not None, caught.value
    assert _snapshot(set_dir) == before and check_set(set_dir).ok


def test_a_good_import_still_commits(exported: dict[str, Any], single: dict[str, Any], tmp_path: Path) -> None:
    source = tmp_path / "good.gltf"
    source.write_text(json.dumps(exported), encoding="utf-8")
    manifest = import_gltf(source, tmp_path / "set")
    assert check_set(manifest).ok and not list((tmp_path / "set").glob(".staging-*"))
    assert len(KeyframeSet.load(manifest).animations) == len(exported["animations"])
    shipped = tmp_path / "shipped"
    shutil.copytree(HUMANOID, shipped)
    source.write_text(json.dumps(single), encoding="utf-8")
    grown = KeyframeSet.load(import_gltf(source, shipped))
    assert len(grown.animations) == len(KeyframeSet.load(HUMANOID / "keyframes.toml").animations) + 1


def test_the_import_command_gives_one_line_and_exit_2(single: dict[str, Any], tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    from jostle.cli import main

    doc = copy.deepcopy(single)
    doc["buffers"][0]["uri"] = "../../../../../../etc/passwd"
    source = tmp_path / "escape.gltf"
    source.write_text(json.dumps(doc), encoding="utf-8")
    set_dir = tmp_path / "set"
    shutil.copytree(HUMANOID, set_dir)
    before = _snapshot(set_dir)
    code = main(["keyframes", "import", str(source), "--into", str(set_dir)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert "escape.gltf: buffer 0: uri '../../../../../../etc/passwd': leads outside this folder" in err, err
    assert _snapshot(set_dir) == before


def test_a_failed_import_into_a_new_nested_folder_leaves_no_folder(single: dict[str, Any], tmp_path: Path) -> None:
    doc = copy.deepcopy(single)
    doc["accessors"][1]["type"] = "MAT4"
    source = tmp_path / "broken.gltf"
    source.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(Exception) as caught:
        import_gltf(source, tmp_path / "a" / "b" / "set")
    assert user_facing(caught.value) is not None
    assert not (tmp_path / "a").exists()
    _last_family(doc := copy.deepcopy(single))  # fails only when the staged set is loaded
    source.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(Exception) as caught:
        import_gltf(source, tmp_path / "a" / "b" / "set")
    assert "no_such_family" in str(user_facing(caught.value)) and not (tmp_path / "a").exists()
