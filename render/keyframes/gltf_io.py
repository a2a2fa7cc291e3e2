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
import json
import math
import warnings
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import numpy as np

from render.keyframes.clip_import import Placement, add_animation
from render.keyframes.keyframe_set import KeyframeSet
from render.keyframes.set_file import KeyframeError
from render.keyframes.set_staging import MANIFEST, StagedSet, checked_name, commit
from render.keyframes.skeletons import figure_for
from sensors.untrusted import (
    MissingInput,
    UntrustedInput,
    finite,
    one_line,
    parse_json,
    read_bytes,
    resolve_within,
    shorten,
    whole,
)
from sensors.untrusted.limits import GLTF_BUFFER, GLTF_JSON
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


class _Buffers:
    """The bytes of each glTF buffer, read once: a .glb's BIN chunk, a ``data:`` URI, or a file whose
    ``uri`` lies inside the glTF's folder (``resolve_within``), each within ``limits.GLTF_BUFFER``."""

    def __init__(self, doc: Any, path: Path) -> None:
        self.doc, self.path = doc, path
        self.read: dict[int, bytes] = {}

    def __getitem__(self, index: object) -> bytes:
        buffers = self.doc.buffers or []
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(buffers):
            raise KeyframeError(f"{self.path}: buffer {shorten(index)}: no such buffer ({len(buffers)} in the file)")
        if index not in self.read:
            self.read[index] = self._bytes(index, buffers[index].uri)
        return self.read[index]

    def _bytes(self, index: int, uri: object) -> bytes:
        what = f"{self.path}: buffer {index}"
        if uri is None:
            blob = self.doc.binary_blob()
            if blob is None:
                raise KeyframeError(f"{what}: no uri and no binary chunk")
            return bytes(blob)
        if not isinstance(uri, str):
            raise KeyframeError(f"{what}: uri: expected a string, got {shorten(uri)}")
        if uri.startswith("data:"):
            head, _, payload = uri.partition(",")
            if not head.endswith(";base64"):
                raise KeyframeError(f"{what}: a data: uri must be base64")
            try:
                return base64.b64decode(payload, validate=True)
            except ValueError:
                raise KeyframeError(f"{what}: the data: uri is not valid base64") from None
        try:
            target = resolve_within(self.path.parent, unquote(uri), "uri")
        except UntrustedInput as e:
            raise KeyframeError(f"{what}: {e.problem}") from None
        try:
            return read_bytes(target, GLTF_BUFFER.max_bytes, "glTF buffer")
        except UntrustedInput as e:
            raise KeyframeError(f"{what} ({shorten(uri, 80)}): {e.problem}") from None


_WIDTH = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}
_FLOAT = 5126  # glTF componentType FLOAT


def _read(doc: Any, index: object, path: Path, buffers: _Buffers) -> np.ndarray:
    """Accessor ``index`` as (count, width) floats, every index, offset, stride and length checked
    against what the file holds; KeyframeError (one line naming the file and the accessor) if not."""
    accessors = doc.accessors or []
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(accessors):
        raise KeyframeError(f"{path}: accessor {shorten(index)}: no such accessor ({len(accessors)} in the file)")

    def bad(problem: str) -> KeyframeError:
        return KeyframeError(f"{path}: accessor {index}: {problem}")

    acc = accessors[index]
    width = _WIDTH.get(acc.type) if isinstance(acc.type, str) else None
    if width is None:
        raise bad(f"type {shorten(acc.type)}: expected SCALAR, VEC3 or VEC4")
    if acc.componentType != _FLOAT:
        raise bad(f"expected float data, got component type {shorten(acc.componentType)}")
    views = doc.bufferViews or []
    if isinstance(acc.bufferView, bool) or not isinstance(acc.bufferView, int) or not 0 <= acc.bufferView < len(views):
        raise bad(f"bufferView {shorten(acc.bufferView)}: no such buffer view ({len(views)} in the file)")
    view = views[acc.bufferView]
    data = buffers[view.buffer]
    try:
        count = whole(acc.count, "count", 1, 1 << 24)
        item = 4 * width
        stride = item if view.byteStride is None else whole(view.byteStride, "byteStride", item, 252)
        view_start = whole(view.byteOffset or 0, "bufferView byteOffset", 0, len(data))
        view_length = whole(view.byteLength, "bufferView byteLength", 0, len(data) - view_start)
        offset = whole(acc.byteOffset or 0, "byteOffset", 0, view_length)
    except UntrustedInput as e:
        raise bad(f"{e.source}: {e.problem}") from None
    if offset + stride * (count - 1) + item > view_length:
        raise bad(f"{count} items of {item} bytes at a stride of {stride} run past its buffer view ({view_length} bytes)")
    values = np.ndarray((count, width), dtype="<f4", buffer=data, offset=view_start + offset, strides=(stride, 4))
    out = values.astype(float)
    if not np.all(np.isfinite(out)):
        raise bad("holds a value that is not a finite number")
    return out


def _load_document(path: Path) -> Any:
    """The glTF file (.gltf JSON or .glb) read within ``limits.GLTF_JSON`` / ``GLTF_BUFFER``, its JSON
    bounded before pygltflib parses it; KeyframeError (one line) for anything unreadable."""
    import pygltflib as g

    try:
        data = read_bytes(path, GLTF_BUFFER.max_bytes, "glTF file")
    except MissingInput:
        raise KeyframeError(f"{path}: no such glTF file") from None
    except UntrustedInput as e:
        raise KeyframeError(str(e)) from None
    glb = data[:4] == b"glTF"
    json_bytes = data[20:20 + int.from_bytes(data[12:16], "little")] if glb and len(data) >= 20 else data
    try:
        parse_json(json_bytes, path, GLTF_JSON)  # bounds: size, nesting, items (pygltflib recurses)
        doc = g.GLTF2.load_from_bytes(data) if glb else g.GLTF2.from_json(json_bytes.decode("utf-8"))
    except UntrustedInput as e:
        raise KeyframeError(str(e)) from None
    except Exception as e:  # pygltflib raises many unrelated types for a bad file
        raise KeyframeError(f"{path}: not a glTF file I can read ({type(e).__name__}: {one_line(str(e), 120)})") from None
    if doc is None:
        raise KeyframeError(f"{path}: not a glTF file I can read")
    return doc


def import_gltf(path: Path, set_dir: Path) -> Path:
    """Add every animation of a glTF file that carries ``extras.jostle`` to the set in ``set_dir``
    (made when missing, with the file's skeleton and settings); returns the manifest. One
    transaction: on any error the set is left exactly as it was."""
    path = Path(path)
    doc = _load_document(path)
    buffers = _Buffers(doc, path)
    info = ((doc.asset.extras or {}) if doc.asset else {}).get("jostle", {})
    if not isinstance(info, dict):
        raise KeyframeError(f"{path}: asset.extras.jostle: expected an object")
    skeleton = info.get("skeleton", "humanoid")
    node_of = {n.name: i for i, n in enumerate(doc.nodes or [])}
    staged = StagedSet(set_dir)
    done = 0
    for a, anim in enumerate(doc.animations or []):
        extras = (anim.extras or {}).get("jostle") if isinstance(anim.extras, dict | None) else None
        name = anim.name or f"animation_{a}"
        if not isinstance(extras, dict):
            warnings.warn(f"{path}: animation {shorten(name)}: no extras.jostle (where it lies in Q); skipped", stacklevel=2)
            continue
        try:
            _stage_animation(staged, anim, name, extras, doc, path, buffers, node_of, skeleton, info)
        except (IndexError, KeyError, TypeError, ValueError, AttributeError) as e:
            if isinstance(e, KeyframeError | UntrustedInput):
                raise
            raise KeyframeError(f"{path}: animation {shorten(name)}: malformed ({type(e).__name__}: "
                                f"{one_line(str(e), 80)})") from None
        done += 1
    if done == 0:
        raise KeyframeError(f"{path}: no animation carries extras.jostle; nothing to import")
    return commit(staged, path)


def _stage_animation(staged: StagedSet, anim: Any, name: str, extras: dict[str, Any], doc: Any, path: Path,
                     buffers: _Buffers, node_of: dict[str, int], skeleton: str, info: dict[str, Any]) -> None:
    samplers = anim.samplers or []
    tracks: dict[tuple[int, str], np.ndarray] = {}
    for c, ch in enumerate(anim.channels or []):
        if not isinstance(ch.sampler, int) or not 0 <= ch.sampler < len(samplers) or ch.target is None:
            raise KeyframeError(f"{path}: animation {shorten(name)}: channel {c}: no such sampler or no target")
        if not isinstance(ch.target.node, int) or not 0 <= ch.target.node < len(doc.nodes or []):
            raise KeyframeError(f"{path}: animation {shorten(name)}: channel {c}: target node "
                                f"{shorten(ch.target.node)} is not one of the file's {len(doc.nodes or [])} nodes")
        tracks[(ch.target.node, ch.target.path)] = _read(doc, samplers[ch.sampler].output, path, buffers)
    keys = extras.get("keys", [])
    if not isinstance(keys, list) or not all(isinstance(k, dict) for k in keys):
        raise KeyframeError(f"{path}: animation {shorten(name)}: extras.jostle.keys: expected a list of objects")
    root = node_of.get("root")
    if root is None:
        raise KeyframeError(f"{path}: no node named 'root' (the skeleton's bones are nodes named as the bones)")
    missing = [j for j in JOINTS if j not in node_of]
    if missing:
        raise KeyframeError(f"{path}: animation {shorten(name)}: no node for joint(s) {', '.join(missing)}")
    short = [f"{n} {p}" for (n, p), v in tracks.items() if len(v) < len(keys)]
    if short:
        raise KeyframeError(f"{path}: animation {shorten(name)}: the {short[0]} track has fewer samples than its "
                            f"{len(keys)} keys")
    poses: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    entries = []
    for k, key in enumerate(keys):
        at = finite(key.get("at"), f"{path}: animation {shorten(name)}: key {k}: at")
        if "family" in key:
            entries.append((float(at), "", checked_name(key["family"], f"{path}: key {k}: family")))
            continue
        pose_name = checked_name(key.get("pose", f"{name}_{k:02d}"), f"{path}: key {k}: pose")
        offset = tracks.get((root, "translation"), np.zeros((len(keys), 3)))[k]
        rots = [tracks.get((root, "rotation"), np.tile(quat.IDENTITY, (len(keys), 1)))[k]]
        rots += [tracks.get((node_of[j], "rotation"), np.tile(quat.IDENTITY, (len(keys), 1)))[k] for j in JOINTS]
        poses[pose_name] = (np.asarray(offset, dtype=float), quat.normalize(np.array(rots)))
        entries.append((float(at), pose_name, ""))
    placement = Placement(checked_name(name, f"{path}: animation name"), str(extras.get("behaviour", "walk")),
                          str(extras.get("axis", "dz")), dict(extras.get("at", {})),
                          str(extras.get("family", "")) if extras.get("family") != name else "")
    fresh = staged.text(MANIFEST) is None
    add_animation(staged, placement, entries, poses, path.name, skeleton)
    if fresh:
        staged.write(MANIFEST, _with_settings(staged.changed[MANIFEST], info))


def _with_settings(text: str, info: dict[str, Any]) -> str:
    """A new manifest's text with the glTF file's own settings (height, behaviour, interpolation, dimensions)."""
    if "height" in info:
        text = _set_line(text, "height", f"{finite(info['height'], 'extras.jostle.height'):.4f}")
    if "default_behaviour" in info:
        text = _set_line(text, "default_behaviour", json.dumps(str(info["default_behaviour"])))
    extra = ""
    if "cycle_weight" in info or "sharpness" in info:
        extra += f"\n[interpolation]\ncycle_weight = {float(finite(info.get('cycle_weight', 0.5), 'cycle_weight'))!r}\n"
        extra += f"sharpness = {float(finite(info.get('sharpness', 2.0), 'sharpness'))!r}\n"
    for dim, d in (info.get("dimensions") or {}).items():
        extra += f"\n[dimensions.{checked_name(dim, 'extras.jostle.dimensions')}]\n" + "".join(
            f"{checked_name(k, 'dimension key')} = "
            f"{str(v).lower() if isinstance(v, bool) else repr(float(finite(v, str(k))))}\n" for k, v in d.items())
    head, sep, rest = text.partition("\n[[animation]]")
    return head.rstrip("\n") + "\n" + extra + "\n" + sep.lstrip("\n") + rest


def _set_line(text: str, key: str, value: str) -> str:
    import re

    return re.sub(rf"^{key}\s*=.*$", f"{key} = {value}", text, count=1, flags=re.M)
