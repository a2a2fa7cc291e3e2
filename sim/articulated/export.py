"""What an articulated character did, saved for animators: link poses per frame → BVH or glTF 2.0.

A ``LinkTrack`` is one character's links (names, parent of each, root first) with their world poses
per frame in the stage frame (metres, z up; ``sim.snapshot.LinkPose``: the link frame's origin, i.e.
the joint, and its orientation). ``local_motion`` turns it into what both formats store: per link its
offset from the parent in the parent's frame (constant for a rigid joint; the mean over frames, with
the largest deviation reported) and its rotation relative to the parent, plus the root's position
and rotation — in the files' Y-up axes (x stays x, stage z becomes y, stage y becomes −z).

- BVH (``write_track_bvh``): ZYX Euler channels (degrees), root with 6 channels, centimetres by default
  (most tools' expectation; ``units="m"`` for metres). Blender, MotionBuilder, Maya read it.
- glTF (``write_track_gltf``, ``.gltf`` with the buffer embedded or ``.glb``): a node per link
  (translation = offset), one animation with a rotation channel per link and a translation channel for
  the root, linear, times in seconds; metres, Y up as glTF wants.

Nothing here imports pybullet; sim.articulated's characters fill the track from their snapshots.
"""

from __future__ import annotations

import base64
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sim.articulated.skeleton import ArticulatedSkeleton
from sim.motion import quaternion as quat
from sim.motion.bvh import write_bvh
from sim.motion.gltf_file import save_gltf
from sim.snapshot import WorldSnapshot

__all__ = ["ExportError", "LinkTrack", "LocalMotion", "STAGE_TO_Y_UP", "articulated_names", "infer_parents",
           "local_motion", "read_gltf_rotations", "shape_ends", "track_from_snapshots", "write_track", "write_track_bvh",
           "write_track_gltf"]

# stage (x right, y away, z up) → file axes (x right, y up, z toward the audience): −90° about x
STAGE_TO_Y_UP = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), -np.pi / 2)
UNITS = {"m": 1.0, "cm": 100.0}
RIGID_TOLERANCE_M = 1e-4  # infer_parents: offsets that vary less than this count as rigid


class ExportError(ValueError):
    """A track that cannot be written (no frames, unknown character, uneven frames); one line."""


@dataclass(frozen=True, eq=False)
class LinkTrack:
    """One character's link poses over time (stage frame). ``parents[i]`` < i, −1 for the root (index 0)."""

    character: str
    names: tuple[str, ...]
    parents: tuple[int, ...]
    times: np.ndarray  # (F,) seconds
    positions: np.ndarray  # (F, L, 3)
    orientations: np.ndarray  # (F, L, 4) x y z w

    def __post_init__(self) -> None:
        n = len(self.names)
        if len(self.parents) != n or self.parents[:1] != (-1,) or any(not -1 < p < i for i, p in
                                                                       enumerate(self.parents) if i):
            raise ExportError(f"{self.character}: parents: expected the root first and every parent before its "
                              f"child, got {self.parents}")
        f = len(self.times)
        if self.positions.shape != (f, n, 3) or self.orientations.shape != (f, n, 4):
            raise ExportError(f"{self.character}: expected {f} frames of {n} link poses, got positions "
                              f"{self.positions.shape} and orientations {self.orientations.shape}")

    @property
    def frame_time(self) -> float:
        """The median spacing of the frames (BVH has one frame time)."""
        return float(np.median(np.diff(self.times))) if len(self.times) > 1 else 1.0 / 30.0


@dataclass(frozen=True, eq=False)
class LocalMotion:
    """A track as parent-relative joint motion in Y-up file axes, metres."""

    offsets: np.ndarray  # (L, 3) from the parent's joint, in the parent's frame (root: 0)
    root_positions: np.ndarray  # (F, 3)
    rotations: np.ndarray  # (F, L, 4) root: world (file axes); others: relative to the parent
    offset_drift_m: float  # largest deviation of a frame's offset from the mean (0 for rigid joints)


def infer_parents(names: Sequence[str], positions: np.ndarray, orientations: np.ndarray) -> dict[str, str | None]:
    """Each link's parent from the motion alone (root: the first link): the earlier link in whose frame the
    link's origin (its joint) stays put over the frames — a rigid offset, which only a parent gives (or a
    link fixed to the parent, equally good for export). Needs frames in more than one pose."""
    out: dict[str, str | None] = {names[0]: None}
    for i in range(1, len(names)):
        spread = np.array([
            np.linalg.norm(off - off.mean(axis=0), axis=-1).max()
            for off in (quat.rotate(quat.conjugate(orientations[:, j]), positions[:, i] - positions[:, j])
                        for j in range(i))
        ])
        # links that did not move against each other tie: the earliest (highest in the tree) wins
        out[names[i]] = names[int(np.argmax(spread <= spread.min() + RIGID_TOLERANCE_M))]
    return out


def track_from_snapshots(snapshots: Iterable[WorldSnapshot], character: str,
                         parents: dict[str, str | None] | None = None) -> LinkTrack:
    """The track of ``character`` over ``snapshots`` (those where it has links). ``parents``: each link
    name's parent link name (None for the root), or None to infer them (``infer_parents``); the links are
    reordered root first when needed."""
    times: list[float] = []
    frames: list[tuple[Any, ...]] = []
    for snap in snapshots:
        for c in snap.characters:
            if c.name == character and c.links:
                times.append(snap.t)
                frames.append(c.links)
    if not frames:
        raise ExportError(f"character {character!r}: no articulated links in the run (is it an articulated kind?)")
    names = tuple(link.name for link in frames[0])
    if any(tuple(link.name for link in f) != names for f in frames):
        raise ExportError(f"character {character!r}: its links change names or number during the run")
    if parents is None:
        parents = infer_parents(names, np.array([[lk.position for lk in f] for f in frames], dtype=float),
                                np.array([[lk.orientation for lk in f] for f in frames], dtype=float))
    missing = [n for n in names if n not in parents]
    if missing:
        raise ExportError(f"character {character!r}: no parent known for link(s) {', '.join(missing)}")
    order: list[str] = []
    pending = list(names)
    while pending:  # parents before children; the snapshot's order when it already is
        ready = next((n for n in pending if parents[n] is None or parents[n] in order), None)
        if ready is None:
            raise ExportError(f"character {character!r}: the links' parents do not form a tree: {pending}")
        order.append(ready)
        pending.remove(ready)
    index = {n: i for i, n in enumerate(names)}
    pick = [index[n] for n in order]
    if sum(parents[n] is None for n in order) != 1:
        raise ExportError(f"character {character!r}: expected exactly one root link")
    pos = np.array([[link.position for link in f] for f in frames], dtype=float)[:, pick]
    orn = np.array([[link.orientation for link in f] for f in frames], dtype=float)[:, pick]
    par = tuple(-1 if parents[n] is None else order.index(str(parents[n])) for n in order)
    return LinkTrack(character, tuple(order), par, np.array(times), pos, orn)


def local_motion(track: LinkTrack) -> LocalMotion:
    """Parent-relative rotations and constant offsets of a track, in Y-up file axes (metres)."""
    pos = quat.rotate(STAGE_TO_Y_UP, track.positions)
    rot = quat.normalize(quat.multiply(STAGE_TO_Y_UP, track.orientations))
    n = len(track.names)
    local = np.empty_like(rot)
    offsets = np.zeros((n, 3))
    drift = 0.0
    local[:, 0] = rot[:, 0]
    for b in range(1, n):
        p = track.parents[b]
        inv = quat.conjugate(rot[:, p])
        local[:, b] = quat.multiply(inv, rot[:, b])
        off = quat.rotate(inv, pos[:, b] - pos[:, p])  # (F, 3)
        offsets[b] = off.mean(axis=0)
        drift = max(drift, float(np.linalg.norm(off - offsets[b], axis=-1).max()))
    for f in range(1, len(local)):  # continuous signs: glTF's linear blend takes the short way
        local[f] = quat.align(local[f], local[f - 1])
    return LocalMotion(offsets, pos[:, 0], quat.normalize(local), drift)


def _end_sites(track: LinkTrack, offsets: np.ndarray, ends: Mapping[str, np.ndarray] | None) -> dict[int, np.ndarray]:
    """For leaf links: the given end (metres, link frame), else a stub continuing the bone into them by
    half its length."""
    leaves = [b for b in range(len(track.names)) if b not in track.parents]
    given = ends or {}
    return {b: np.asarray(given[track.names[b]], dtype=float) if track.names[b] in given else 0.5 * offsets[b]
            for b in leaves}


def shape_ends(skeleton: ArticulatedSkeleton) -> dict[str, np.ndarray]:
    """Where each leaf link's collision shape ends, farthest from its joint (link frame, metres): the top
    of the head, the tip of the toes, the hand — the BVH End Sites an animator expects."""
    parents = {link.parent for link in skeleton.links}
    out: dict[str, np.ndarray] = {}
    for i, link in enumerate(skeleton.links):
        if i in parents:
            continue
        c = np.array(link.shape_offset, dtype=float)
        turn = np.array(link.shape_rotation, dtype=float)
        if link.shape == "sphere":
            d = c / max(float(np.linalg.norm(c)), 1e-9)
            candidates = [c + link.size[0] * d]
        elif link.shape == "capsule":
            axis = quat.rotate(turn, np.array([0.0, 0.0, link.size[1] / 2.0 + link.size[0]]))
            candidates = [c + axis, c - axis]
        else:
            candidates = [c + quat.rotate(turn, sign * link.size[k] * np.eye(3)[k]) for k in range(3) for sign in (1, -1)]
        out[link.name] = max(candidates, key=lambda v: float(np.linalg.norm(v)))
    return out


def write_track_bvh(track: LinkTrack, path: Path, *, units: str = "cm", order: str = "ZYX",
                    ends: Mapping[str, np.ndarray] | None = None) -> Path:
    """The track as a BVH file (one skeleton, one frame per snapshot); ``ends``: End Sites of leaf links by
    name (``shape_ends``), metres in the link frame — stubs along the bone otherwise."""
    if units not in UNITS:
        raise ExportError(f"units: expected one of {', '.join(UNITS)}, got {units!r}")
    k = UNITS[units]
    m = local_motion(track)
    return write_bvh(path, track.names, track.parents, k * m.offsets, k * m.root_positions, m.rotations,
                     track.frame_time, order=order,
                     end_sites={b: k * v for b, v in _end_sites(track, m.offsets, ends).items()})


def write_track_gltf(track: LinkTrack, path: Path) -> Path:
    """The track as glTF 2.0: ``.glb`` (binary) or ``.gltf`` (JSON with the buffer embedded)."""
    import pygltflib as g

    m = local_motion(track)
    n = len(track.names)
    nodes = []
    for b, name in enumerate(track.names):
        kids = [c for c in range(n) if track.parents[c] == b]
        t = m.root_positions[0] if b == 0 else m.offsets[b]
        nodes.append(g.Node(name=name, translation=[float(v) for v in t],
                            rotation=[float(v) for v in m.rotations[0, b]], children=kids or None))
    blob = bytearray()
    accessors: list[Any] = []
    views: list[Any] = []

    def add(data: np.ndarray, kind: str, minmax: bool = False) -> int:
        arr = np.ascontiguousarray(data, dtype="<f4")
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=arr.nbytes))
        blob.extend(arr.tobytes())
        while len(blob) % 4:
            blob.append(0)
        acc = g.Accessor(bufferView=len(views) - 1, componentType=g.FLOAT, count=len(arr), type=kind)
        if minmax:
            acc.min, acc.max = [float(arr.min())], [float(arr.max())]
        accessors.append(acc)
        return len(accessors) - 1

    times = add(track.times - track.times[0], g.SCALAR, minmax=True)
    tracks: list[tuple[int, str, np.ndarray, str]] = [(0, "translation", m.root_positions, g.VEC3)]
    tracks += [(b, "rotation", m.rotations[:, b], g.VEC4) for b in range(n)]
    samplers, channels = [], []
    for node, target, values, kind in tracks:
        samplers.append(g.AnimationSampler(input=times, output=add(values, kind), interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=len(samplers) - 1,
                                           target=g.AnimationChannelTarget(node=node, path=target)))
    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator="jostle ragdoll export"),
        scene=0, scenes=[g.Scene(nodes=[0])], nodes=nodes,
        animations=[g.Animation(name=track.character, samplers=samplers, channels=channels)],
        accessors=accessors, bufferViews=views, buffers=[g.Buffer(byteLength=len(blob))],
    )
    return save_gltf(doc, blob, path)


def write_track(track: LinkTrack, path: Path, *, units: str = "cm", ends: Mapping[str, np.ndarray] | None = None) -> Path:
    """BVH or glTF by the file's extension (.bvh, .gltf, .glb)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".bvh":
        return write_track_bvh(track, path, units=units, ends=ends)
    if suffix in (".gltf", ".glb"):
        return write_track_gltf(track, path)
    raise ExportError(f"{path}: expected a .bvh, .gltf or .glb file name")


def read_gltf_rotations(path: Path) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """Back from a file written by ``write_track_gltf``: node names, times (F,), rotations (F, L, 4)."""
    import pygltflib as g

    doc = g.GLTF2().load(str(path))
    blob = doc.binary_blob()
    if blob is None:
        blob = base64.b64decode(str(doc.buffers[0].uri).split(",", 1)[1])

    def read(index: int) -> np.ndarray:
        acc = doc.accessors[index]
        view = doc.bufferViews[acc.bufferView]
        width = {g.SCALAR: 1, g.VEC3: 3, g.VEC4: 4}[acc.type]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        return np.frombuffer(blob, dtype="<f4", count=acc.count * width, offset=start).reshape(acc.count, width)

    names = tuple(str(node.name) for node in doc.nodes)
    anim = doc.animations[0]
    times = read(doc.animations[0].samplers[0].input)[:, 0].astype(float)
    rot = np.zeros((len(times), len(names), 4))
    for ch in anim.channels:
        if ch.target.path == "rotation":
            rot[:, ch.target.node] = read(anim.samplers[ch.sampler].output)
    return names, times, rot


def articulated_names(snapshots: Iterable[WorldSnapshot]) -> list[str]:
    """The names of the characters that have links, in the order they first appear."""
    names: list[str] = []
    for snap in snapshots:
        for c in snap.characters:
            if c.links and c.name not in names:
                names.append(c.name)
    return names
