"""Keyframe sets as glTF 2.0 (``pygltflib``): export for animators' tools, import back.

The file holds the skeleton as a node tree (one node per bone, named as the bone, translation = its
offset; a top node ``jostle_axes`` turns the skeleton's x-forward to glTF's +z-forward) and one glTF
animation per 1-D animation of the set: key k at time k/30 s, channels for the root's translation
(the root offset) and rotation and every joint's rotation, linear. Where each key lies in Q is in the
animation's ``extras``::

    "extras": {"jostle": {"behaviour": "walk", "family": "walk", "axis": "dz",
                          "at": {"theta_x": 0.0, "theta_z": 0.0, "dx": 0.25},
                          "keys": [{"at": 0.0, "pose": "walk_dx250_dz000"}, {"at": 0.3, "family": "stagger"}]}}

A key with ``family`` refers to that family (its samples show the family's pose there, for viewing;
import ignores them). The set's own settings (skeleton, height, default behaviour, interpolation,
added dimensions) are in the asset's ``extras.jostle``. Animations without ``extras.jostle`` are
skipped on import, with a warning naming them.
"""

from __future__ import annotations

import base64
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from render.keyframes.clip_import import Placement, add_animation
from render.keyframes.keyframe_set import KeyframeSet
from render.keyframes.set_file import KeyframeError
from render.keyframes.skeletons import figure_for
from sim.motion import quaternion as quat
from sim.motion.gltf_file import save_gltf
from sim.motion.mocap import JOINTS

FPS = 30.0
AXES_NODE = "jostle_axes"


def export_gltf(kset: KeyframeSet, path: Path) -> Path:
    """Write the set as ``.gltf`` (JSON, buffer embedded) or ``.glb``; returns the path."""
    import pygltflib as g

    skel = kset.skeleton
    figure = figure_for(skel)
    nodes = [g.Node(name=AXES_NODE, rotation=[0.0, -math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4)], children=[1])]
    for b, name in enumerate(skel.names):
        children = [1 + c for c in range(len(skel.names)) if skel.parents[c] == b]
        nodes.append(g.Node(name=name, translation=[float(v) for v in skel.offsets[b]], children=children or None))
    blob = bytearray()
    accessors: list[Any] = []
    views: list[Any] = []

    def add(data: np.ndarray, kind: str, minmax: bool = False) -> int:
        arr = np.ascontiguousarray(data, dtype=np.float32)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=arr.nbytes))
        blob.extend(arr.tobytes())
        while len(blob) % 4:
            blob.append(0)
        acc = g.Accessor(bufferView=len(views) - 1, componentType=g.FLOAT, count=len(arr), type=kind)
        if minmax:
            acc.min, acc.max = [float(arr.min())], [float(arr.max())]
        accessors.append(acc)
        return len(accessors) - 1

    animations = []
    for curve in kset.animations:
        q = np.array([[0.0 if b is None else b for b in curve.base]] * len(curve.coords))
        q[:, curve.axis] = curve.coords
        poses = kset.evaluate(q, [curve.behaviour] * len(q))
        if len(curve.coords) == 1:
            poses = type(poses)(*(np.concatenate([a, a]) for a in (poses.root_offset, poses.root_rotation,
                                                                   poses.joint_rotations)))
        times = add(np.arange(len(poses.root_offset)) / FPS, g.SCALAR, minmax=True)
        samplers, channels = [], []
        tracks = [(1, "translation", poses.root_offset, g.VEC3), (1, "rotation", poses.root_rotation, g.VEC4)]
        tracks += [(1 + skel.names.index(j), "rotation", poses.joint_rotations[:, i], g.VEC4) for i, j in enumerate(JOINTS)]
        for node, path_name, values, kind in tracks:
            samplers.append(g.AnimationSampler(input=times, output=add(values, kind), interpolation="LINEAR"))
            channels.append(g.AnimationChannel(sampler=len(samplers) - 1,
                                               target=g.AnimationChannelTarget(node=node, path=path_name)))
        keys = [{"at": float(x), "family": k} if isinstance(k, str) else {"at": float(x), "pose": kset.key_names[k]}
                for x, k in zip(curve.coords, curve.keys, strict=True)]
        at = {kset.space.axes[c]: ("any" if b is None else float(b)) for c, b in enumerate(curve.base) if c != curve.axis}
        extras = {"jostle": {"behaviour": curve.behaviour, "family": curve.family, "axis": kset.space.axes[curve.axis],
                             "at": at, "keys": keys}}
        animations.append(g.Animation(name=curve.name, samplers=samplers, channels=channels, extras=extras))
    dims = {kset.space.axes[c]: {"scale": kset.space.scale[c], "periodic": kset.space.periodic[c],
                                 **({"min": kset.space.lo[c]} if math.isfinite(kset.space.lo[c]) else {}),
                                 **({"max": kset.space.hi[c]} if math.isfinite(kset.space.hi[c]) else {})}
            for c in range(4, kset.space.dims)}
    asset_extras = {"jostle": {"skeleton": figure.name, "height": kset.height, "default_behaviour": kset.default_behaviour,
                               "cycle_weight": kset.space.scale[2], "sharpness": kset.sharpness, "dimensions": dims}}
    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator="jostle keyframes export", extras=asset_extras),
        scene=0, scenes=[g.Scene(nodes=[0])], nodes=nodes, animations=animations,
        accessors=accessors, bufferViews=views, buffers=[g.Buffer(byteLength=len(blob))],
    )
    return save_gltf(doc, blob, path)


def _read(doc: Any, index: int, path: Path) -> np.ndarray:
    import pygltflib as g

    acc = doc.accessors[index]
    view = doc.bufferViews[acc.bufferView]
    data = doc.binary_blob() if doc.buffers[view.buffer].uri is None else _uri_bytes(doc.buffers[view.buffer].uri, path)
    width = {g.SCALAR: 1, g.VEC3: 3, g.VEC4: 4}[acc.type]
    if acc.componentType != g.FLOAT:
        raise KeyframeError(f"{path}: accessor {index}: expected float data, got component type {acc.componentType}")
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    stride = view.byteStride or 4 * width
    raw = np.frombuffer(data, dtype=np.uint8, count=stride * (acc.count - 1) + 4 * width, offset=start)
    rows = [np.frombuffer(raw[i * stride : i * stride + 4 * width].tobytes(), dtype="<f4") for i in range(acc.count)]
    return np.array(rows, dtype=float).reshape(acc.count, width)


def _uri_bytes(uri: str, path: Path) -> bytes:
    if uri.startswith("data:"):
        return base64.b64decode(uri.split(",", 1)[1])
    return (path.parent / uri).read_bytes()


def import_gltf(path: Path, set_dir: Path) -> Path:
    """Add every animation of a glTF file that carries ``extras.jostle`` to the set in ``set_dir``
    (made when missing, with the file's skeleton and settings); returns the manifest."""
    import pygltflib as g

    path = Path(path)
    try:
        doc = g.GLTF2().load(str(path))
    except Exception as e:  # pygltflib raises many unrelated types for a bad file
        raise KeyframeError(f"{path}: not a glTF file I can read ({type(e).__name__}: {e})") from e
    if doc is None:
        raise KeyframeError(f"{path}: not a glTF file I can read")
    info = ((doc.asset.extras or {}) if doc.asset else {}).get("jostle", {})
    skeleton = info.get("skeleton", "humanoid")
    node_of = {n.name: i for i, n in enumerate(doc.nodes)}
    manifest = set_dir / "keyframes.toml"
    done = 0
    for a, anim in enumerate(doc.animations):
        extras = (anim.extras or {}).get("jostle")
        name = anim.name or f"animation_{a}"
        if not isinstance(extras, dict):
            warnings.warn(f"{path}: animation '{name}': no extras.jostle (where it lies in Q); skipped", stacklevel=2)
            continue
        tracks: dict[tuple[int, str], np.ndarray] = {}
        for ch in anim.channels:
            tracks[(ch.target.node, ch.target.path)] = _read(doc, anim.samplers[ch.sampler].output, path)
        keys = extras.get("keys", [])
        root = node_of.get("root")
        if root is None:
            raise KeyframeError(f"{path}: no node named 'root' (the skeleton's bones are nodes named as the bones)")
        missing = [j for j in JOINTS if j not in node_of]
        if missing:
            raise KeyframeError(f"{path}: animation '{name}': no node for joint(s) {', '.join(missing)}")
        poses: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        entries = []
        for k, key in enumerate(keys):
            if "family" in key:
                entries.append((float(key["at"]), "", str(key["family"])))
                continue
            pose_name = str(key.get("pose", f"{name}_{k:02d}"))
            offset = tracks.get((root, "translation"), np.zeros((len(keys), 3)))[k]
            rots = [tracks.get((root, "rotation"), np.tile(quat.IDENTITY, (len(keys), 1)))[k]]
            rots += [tracks.get((node_of[j], "rotation"), np.tile(quat.IDENTITY, (len(keys), 1)))[k] for j in JOINTS]
            poses[pose_name] = (np.asarray(offset, dtype=float), quat.normalize(np.array(rots)))
            entries.append((float(key["at"]), pose_name, ""))
        placement = Placement(name, str(extras.get("behaviour", "walk")), str(extras.get("axis", "dz")),
                              dict(extras.get("at", {})), str(extras.get("family", "")) if extras.get("family") != name else "")
        manifest = add_animation_unchecked(set_dir, placement, entries, poses, path.name, skeleton, info)
        done += 1
    if done == 0:
        raise KeyframeError(f"{path}: no animation carries extras.jostle; nothing to import")
    KeyframeSet.load(manifest)
    return manifest


def add_animation_unchecked(set_dir: Path, placement: Placement, entries: list[tuple[float, str, str]],
                            poses: dict[str, tuple[np.ndarray, np.ndarray]], source: str, skeleton: str,
                            info: dict[str, Any]) -> Path:
    """``add_animation`` without loading the set after each one (an animation may refer to a family a
    later one defines); a new manifest takes the file's settings."""
    manifest = set_dir / "keyframes.toml"
    fresh = not manifest.exists()
    out = add_animation(set_dir, placement, entries, poses, source, skeleton, check=False)
    if fresh:
        text = out.read_text(encoding="utf-8")
        if "height" in info:
            text = _set_line(text, "height", f"{float(info['height']):.4f}")
        if "default_behaviour" in info:
            text = _set_line(text, "default_behaviour", f'"{info["default_behaviour"]}"')
        extra = ""
        if "cycle_weight" in info or "sharpness" in info:
            extra += f"\n[interpolation]\ncycle_weight = {float(info.get('cycle_weight', 0.5))!r}\n"
            extra += f"sharpness = {float(info.get('sharpness', 2.0))!r}\n"
        for dim, d in (info.get("dimensions") or {}).items():
            extra += f"\n[dimensions.{dim}]\n" + "".join(
                f"{k} = {str(v).lower() if isinstance(v, bool) else repr(float(v))}\n" for k, v in d.items())
        head, sep, rest = text.partition("\n[[animation]]")
        out.write_text(head.rstrip("\n") + "\n" + extra + "\n" + sep.lstrip("\n") + rest, encoding="utf-8")
    return out


def _set_line(text: str, key: str, value: str) -> str:
    import re

    return re.sub(rf"^{key}\s*=.*$", f"{key} = {value}", text, count=1, flags=re.M)
