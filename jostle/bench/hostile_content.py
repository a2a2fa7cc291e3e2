"""Hostile content files a config names, and motion files the command line imports.

Keyframe sets and their pose files, character specs, webcam and depth calibrations and terrain
layouts are each replaced, in a copy of a shipped config, by a FIFO, a ``/dev/zero`` twin, or a
file with nesting, numbers or shapes out of range; each must give one error line (``jostle run``).
BVH files go to ``jostle ragdoll body``; glTF files (the critter set exported, with one of its
animations broken in one of 12 structural ways, or its buffer ``uri`` escaping, a FIFO or a device)
to ``jostle keyframes import``, which must refuse them leaving its ``--into`` folder without a file.
"""

from __future__ import annotations

import base64
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from jostle.bench.hostile_recordings import drawn_frames, write_messages
from jostle.bench.hostile_run import Case
from jostle.bench.hostile_workspace import Workspace

Pairs = list[tuple[Case, bool]]


def _special(ws: Workspace, stem: str) -> list[tuple[str, Path | None]]:
    return [("fifo", ws.fifo(stem + ".fifo")), ("dev_zero_twin", ws.device_twin(stem + ".zero", 5))]


def _run_case(ws: Workspace, surface: str, name: str, config: Path, size: int, sample: bool) -> tuple[Case, bool]:
    return Case(surface, name, ws.run_argv(config, f"{surface}-{name}"), "error", size, max_line_chars=1000), sample


def referenced_cases(ws: Workspace, sample: bool) -> Pairs:
    """Keyframe sets, pose files, character specs, webcam calibrations and terrain layouts."""
    cases: Pairs = []
    targets = [("keyframes", 'keyframes = "keyframes/humanoid/keyframes.toml"', "keyframes = {}"),
               ("character_spec", 'spec = "characters/default.toml"', "spec = {}"),
               ("calibration", 'calibration = "recordings/demo.calibration.toml"', "calibration = {}")]
    for surface, old, new in targets:
        for kind, path in _special(ws, surface):
            if path is None:
                ws.skipped.append(f"{surface}-{kind} (mknod refused)")
                continue
            cfg = ws.demo_with(f"{surface}-{kind}", old, new.format(json.dumps(str(path))))
            cases.append(_run_case(ws, surface, kind, cfg, 0, True))
        bad = {"keyframes": [("nested_3000", "format = 1\nx = " + "[" * 3000 + "]" * 3000 + "\n")],
               "character_spec": [("mass_nan", _edit(ws, "characters/default.toml", "mass = 40.0", "mass = nan")),
                                  ("height_1e308", _edit(ws, "characters/default.toml", "height = 1.5",
                                                         "height = 1e308")),
                                  ("mass_minus1", _edit(ws, "characters/default.toml", "mass = 40.0", "mass = -1.0"))],
               "calibration": [("homography_zero", "homography = [[0.0,0.0,0.0],[0.0,0.0,0.0],[0.0,0.0,0.0]]\n"
                                "plane_y = 0.0\nhalf_depth = 1.0\n"),
                               ("homography_nan", _edit(ws, "recordings/demo.calibration.toml",
                                                        "[0.0, -0.00034851275009931685, 1.0]", "[0.0, nan, 1.0]"))]}
        for i, (name, text) in enumerate(bad[surface]):
            path = ws.file(f"{surface}-{name}.toml", text)
            cfg = ws.demo_with(f"{surface}-{name}", old, new.format(json.dumps(str(path))))
            cases.append(_run_case(ws, surface, name, cfg, path.stat().st_size, i == 0))
    # a keyframe set whose pose file is a FIFO, a /dev/zero twin, or holds nan
    for kind in ("fifo", "dev_zero_twin", "nan"):
        kset = ws.root / "in" / f"kset-{kind}"
        if not kset.exists():
            shutil.copytree(ws.configs / "keyframes" / "humanoid", kset)
            pose = kset / "poses" / "stagger.toml"
            if kind == "nan":
                pose.write_text(pose.read_text().replace("degrees = ", "degrees = nan #", 1))
            else:
                pose.unlink()
                special = ws.fifo(f"pose-{kind}") if kind == "fifo" else ws.device_twin(f"pose-{kind}", 5)
                if special is None:
                    ws.skipped.append(f"pose_file-{kind} (mknod refused)")
                    continue
                pose.symlink_to(special)
        cfg = ws.demo_with(f"pose-{kind}", 'keyframes = "keyframes/humanoid/keyframes.toml"',
                           f'keyframes = "{kset / "keyframes.toml"}"')
        cases.append(_run_case(ws, "pose_file", kind, cfg, 0, True))
    cases += _terrain_cases(ws)
    return cases


def _edit(ws: Workspace, shipped: str, old: str, new: str) -> str:
    text = (ws.configs / shipped).read_text()
    if old not in text:
        raise ValueError(f"{shipped} has no {old!r}")
    return text.replace(old, new, 1)


def _terrain_cases(ws: Workspace) -> Pairs:
    text = (ws.configs / "quadruped.toml").read_text()
    old = 'layout = "terrain/steps.toml"'
    cases: Pairs = []
    layouts: list[tuple[str, Path | None]] = _special(ws, "terrain")
    layouts += [("at_1e308", ws.file("terrain-at.toml", _edit(ws, "terrain/steps.toml", "at = [23, 36]",
                                                               "at = [1e308, 36]"))),
                ("rows_100000", ws.file("terrain-rows.toml", "at = [0, 0]\nrows = [" + '"9",' * 100_000 + "]\n"))]
    for i, (kind, path) in enumerate(layouts):
        if path is None:
            ws.skipped.append(f"terrain-{kind} (mknod refused)")
            continue
        cfg = ws.config(f"terrain-{kind}", text.replace(old, f"layout = {json.dumps(str(path))}", 1))
        cases.append(_run_case(ws, "terrain", kind, cfg, path.stat().st_size if path.is_file() else 0, i < 2))
    return cases


def depth_calibration_cases(ws: Workspace, sample: bool) -> Pairs:
    """Invalid depth calibrations for a depth observer on a 160×128 recording (16 kinds)."""
    rec = ws.root / "rec" / "depth-good.mcap"
    rec.parent.mkdir(parents=True, exist_ok=True)
    if not rec.exists():
        write_messages(rec, drawn_frames(seconds=1.0))
    base = (ws.configs / "calibration" / "oak-example.toml").read_text().replace("[160, 100]", "[160, 128]")
    tr = "translation = [0.0, -4.0, 2.400638801387667]"
    rotation = _without_rotation(base)

    def rot(value: str) -> Callable[[str], str]:
        return lambda t: f"rotation = {value}\n{_without_rotation(t)}"

    variants: dict[str, Callable[[str], str]] = {
        "floor_zero": lambda t: _line(t, "floor = ", "floor = [0.0, 0.0, 0.0, 0.0]"),
        "translation_1e300": lambda t: t.replace(tr, "translation = [1e300, -4.0, 2.4]"),
        "translation_nan": lambda t: t.replace(tr, "translation = [nan, -4.0, 2.4]"),
        "rotation_scaled": rot("[[2.0,0.0,0.0],[0.0,2.0,0.0],[0.0,0.0,2.0]]"),
        "rotation_reflection": rot("[[-1.0,0.0,0.0],[0.0,1.0,0.0],[0.0,0.0,1.0]]"),
        "rotation_2x2": rot("[[1.0,0.0],[0.0,1.0]]"),
        "rotation_text": rot('"identity"'),
        "no_rotation": lambda t: rotation,
        "no_floor": lambda t: _line(t, "floor = ", ""),
        "floor_3": lambda t: _line(t, "floor = ", "floor = [0.0, 1.0, 0.0]"),
        "image_size_zero": lambda t: t.replace("[160, 128]", "[0, 0]"),
        "image_size_negative": lambda t: t.replace("[160, 128]", "[-160, 128]"),
        "image_size_other": lambda t: t.replace("[160, 128]", "[640, 400]"),
        "rms_negative": lambda t: _line(t, "floor_rms_m = ", "floor_rms_m = -1.0"),
        "rms_nan": lambda t: _line(t, "floor_rms_m = ", "floor_rms_m = nan"),
        "empty": lambda t: "",
    }
    cases: Pairs = []
    for name, change in variants.items():
        cal = ws.file(f"depth-{name}.toml", change(base))
        cfg = ws.config(f"depth-{name}", f"""[run]\ntail_s = 0.0\n[sensors.depth]\ntype = "replay"
path = "{rec}"\nchannel = "depth"\n[observers.depth]\ntype = "depth"\nsensor = "depth"
calibration = "{cal}"\n[render]\nkeyframes = "keyframes/humanoid/keyframes.toml"\n""")
        in_sample = name in ("floor_zero", "translation_1e300", "image_size_other")
        cases.append(_run_case(ws, "depth_calibration", name, cfg, cal.stat().st_size, in_sample))
    return cases


def _without_rotation(text: str) -> str:
    """The calibration text without its (multi-line) ``rotation = [...]`` entry."""
    lines, out, skipping = text.splitlines(), [], False
    for ln in lines:
        if ln.startswith("rotation = ["):
            skipping = True
        if not skipping:
            out.append(ln)
        if skipping and ln.strip() == "]":
            skipping = False
    return "\n".join(out) + "\n"


def _line(text: str, start: str, new: str) -> str:
    return "\n".join(new if ln.startswith(start) else ln for ln in text.splitlines()) + "\n"


BVH = """HIERARCHY
ROOT hips
{{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT spine
  {{
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
{nest}    End Site
    {{
      OFFSET 0 10 0
    }}
{close}  }}
}}
MOTION
Frames: {frames}
Frame Time: {dt}
{rows}"""


def _bvh(nest: int = 0, frames: str = "2", dt: str = "0.0333", row: str = "0 90 0 0 0 0 0 0 0") -> str:
    opening = "".join(f"JOINT j{i}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" for i in range(nest))
    extra = " 0 0 0" * nest
    return BVH.format(nest=opening, close="}\n" * nest, frames=frames, dt=dt, rows=(row + extra + "\n") * 2)


def bvh_cases(ws: Workspace, sample: bool) -> Pairs:
    """BVH motion for ``jostle ragdoll body``: special files, 5000 nested joints, wild numbers."""
    files: list[tuple[str, Path | None]] = _special(ws, "motion.bvh")
    files += [("nested_5000", ws.file("nested.bvh", _bvh(nest=5000))),
              ("frames_1e9", ws.file("frames.bvh", _bvh(frames="1000000000"))),
              ("frame_time_nan", ws.file("nan-dt.bvh", _bvh(dt="nan"))),
              ("value_1e999", ws.file("big.bvh", _bvh(row="0 1e999 0 0 0 0 0 0 0"))),
              ("truncated", ws.file("cut.bvh", _bvh()[:200]))]
    cases: Pairs = []
    for i, (name, path) in enumerate(files):
        if path is None:
            ws.skipped.append(f"bvh-{name} (mknod refused)")
            continue
        size = path.stat().st_size if path.is_file() else 0
        cases.append((Case("bvh", name, ("ragdoll", "body", str(path)), "error", size), i in (0, 2, 3)))
    return cases


def gltf_cases(ws: Workspace, sample: bool) -> Pairs:
    """glTF imports: 12 structural errors in the last animation, escaping and special buffers."""
    from render.keyframes import KeyframeSet
    from render.keyframes.gltf_io import export_gltf

    base = ws.root / "in" / "critter.gltf"
    if not base.exists():
        export_gltf(KeyframeSet.load(ws.configs / "keyframes" / "critter" / "keyframes.toml"), base)
    doc: dict[str, Any] = json.loads(base.read_text())
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    ws.file("critter.bin", blob)
    last = doc["animations"][-1]
    acc = last["samplers"][-1]["output"]

    def setter(*path: Any, value: Any) -> Callable[[dict[str, Any]], None]:
        def change(d: dict[str, Any]) -> None:
            node = d
            for key in path[:-1]:
                node = node[key]
            node[path[-1]] = value
        return change

    n_anim = len(doc["animations"]) - 1
    broken: dict[str, Callable[[dict[str, Any]], None]] = {
        "accessor_type_mat4": setter("accessors", acc, "type", value="MAT4"),
        "accessor_view_999": setter("accessors", acc, "bufferView", value=999),
        "accessor_count_1e9": setter("accessors", acc, "count", value=10**9),
        "accessor_offset_1e9": setter("accessors", acc, "byteOffset", value=10**9),
        "accessor_ubyte": setter("accessors", acc, "componentType", value=5121),
        "view_buffer_5": setter("bufferViews", doc["accessors"][acc]["bufferView"], "buffer", value=5),
        "sampler_output_999": setter("animations", n_anim, "samplers", 0, "output", value=999),
        "channel_sampler_999": setter("animations", n_anim, "channels", 0, "sampler", value=999),
        "channel_node_999": setter("animations", n_anim, "channels", 0, "target", "node", value=999),
        "keys_not_list": setter("animations", n_anim, "extras", "jostle", "keys", value="all"),
        "key_at_text": setter("animations", n_anim, "extras", "jostle", "keys", 0, "at", value="soon"),
        "no_nodes": setter("nodes", value=[]),
        "uri_escape": setter("buffers", 0, "uri", value="../" * 12 + "etc/passwd"),
        "uri_absolute": setter("buffers", 0, "uri", value="/etc/hostname"),
    }
    for kind, minor in (("uri_fifo", None), ("uri_dev_zero_twin", 5)):
        special = ws.fifo("buffer.fifo") if minor is None else ws.device_twin("buffer.zero", minor)
        if special is None:
            ws.skipped.append(f"gltf-{kind} (mknod refused)")
            continue
        broken[kind] = setter("buffers", 0, "uri", value=special.name)
    cases: Pairs = []
    for name, change in broken.items():
        d = json.loads(json.dumps(doc))
        d["buffers"][0]["uri"] = "critter.bin"
        change(d)
        path = ws.file(f"{name}.gltf", json.dumps(d))
        into = ws.root / "sets" / name
        shutil.rmtree(into, ignore_errors=True)
        in_sample = name in ("accessor_type_mat4", "channel_node_999", "uri_escape", "uri_fifo")
        cases.append((Case("gltf", name, ("keyframes", "import", str(path), "--into", str(into)), "error",
                           path.stat().st_size, checks=(_left_empty(into),)), in_sample))
    deep = ws.file("deep.gltf", '{"asset": {"version": "2.0"}, "extras": ' + "[" * 100_000 + "]" * 100_000 + "}")
    cases.append((Case("gltf", "json_nested_100000", ("keyframes", "import", str(deep), "--into",
                                                       str(ws.root / "sets" / "deep")), "error", deep.stat().st_size), False))
    return cases


def _left_empty(folder: Path) -> Callable[[int | None], str | None]:
    """A check: an import that failed left no file in its ``--into`` folder (it was a transaction)."""
    def check(exit_code: int | None) -> str | None:
        if exit_code == 0:
            return None
        files = [p for p in folder.rglob("*") if p.is_file()] if folder.exists() else []
        return f"a refused import left {len(files)} file(s) in {folder}" if files else None
    return check
