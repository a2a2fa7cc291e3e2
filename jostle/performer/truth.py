"""The ground-truth channel of a synthetic recording, and reading it (and the cameras) back.

Topic ``truth``, JSON messages with schema ``jostle.PerformerTruth`` (:data:`TRUTH_SCHEMA`), one
at the time of every camera frame of the recording. Each holds, for every person of the
performance: ``id`` (0, 1, …; the index of the puppet, the same in every message), ``size``
(body scale, 1.0 = the 1.6 m humanoid), ``mass_kg``, ``present`` (on the stage at all), and
while present ``joints`` and ``velocities``: every bone of ``sim.motion.mocap.HUMANOID`` by name, in
stage metres and m/s. With pads recorded it also holds ``pads``: the true force on each pad
(newtons, before the board's noise and rounding).

The recording's ``jostle`` metadata carries ``synth.cameras`` (JSON: each camera's size, pose,
field of view and near/far planes, enough to rebuild its :class:`PinholeCamera`) and
``synth.pads`` (the pad layout), read back by :func:`read_cameras` and :func:`read_pad_layout`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from jostle.performer.camera import PinholeCamera
from jostle.performer.pads import PadBoardConfig, PadLayout, PadPlacement
from jostle.performer.scene import PersonState
from sensors.base import RecordingCorrupt
from sensors.recording.info import describe_recording
from sensors.recording.stream import RecordingStream
from sensors.untrusted import UntrustedInput, parse_json
from sensors.untrusted.limits import JSON_SIDECAR, MESSAGE_JSON
from sim.motion.mocap import HUMANOID

TRUTH_TOPIC = "truth"
TRUTH_SCHEMA_NAME = "jostle.PerformerTruth"
CAMERAS_KEY = "synth.cameras"
PADS_KEY = "synth.pads"

_VEC3 = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}
_BONES = {"type": "object", "properties": {name: _VEC3 for name in HUMANOID.names}}
TRUTH_SCHEMA: dict[str, Any] = {
    "title": TRUTH_SCHEMA_NAME,
    "description": "What the virtual performer really did: every person's joints (stage metres, z up) and velocities.",
    "type": "object",
    "properties": {
        "people": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "id": {"type": "integer"},
                    "size": {"type": "number"},
                    "mass_kg": {"type": "number"},
                    "present": {"type": "boolean"},
                    "joints": _BONES,
                    "velocities": _BONES,
                },
                "required": ["id", "size", "mass_kg", "present", "joints", "velocities"],
            },
        },
        "pads": {"type": "array", "items": {"type": "number"}},
    },
    "required": ["people"],
}


@dataclass(frozen=True, eq=False)
class PersonTruth:
    """One person in one truth message: ``joints``/``velocities`` (B, 3) in ``HUMANOID.names``
    order, (0, 3) when not present."""

    id: int
    size: float
    mass_kg: float
    present: bool
    joints: np.ndarray
    velocities: np.ndarray

    def joint(self, name: str) -> np.ndarray:
        return self.joints[HUMANOID.names.index(name)]


@dataclass(frozen=True, eq=False)
class TruthFrame:
    t: float  # seconds, the recording's own times (as the frames of the same instant)
    seq: int
    people: tuple[PersonTruth, ...]
    pads: tuple[float, ...] = ()


def truth_message(people: tuple[PersonState, ...], pads: np.ndarray | None = None) -> dict[str, Any]:
    """The JSON body of one truth message."""
    out: list[dict[str, Any]] = []
    for p in people:
        joints = {n: [round(float(v), 6) for v in xyz] for n, xyz in zip(HUMANOID.names, p.joints, strict=False)}
        vel = {n: [round(float(v), 6) for v in xyz] for n, xyz in zip(HUMANOID.names, p.velocities, strict=False)}
        out.append({"id": p.id, "size": p.size, "mass_kg": round(p.mass_kg, 4), "present": p.present,
                    "joints": joints, "velocities": vel})
    body: dict[str, Any] = {"people": out}
    if pads is not None:
        body["pads"] = [round(float(f), 4) for f in pads]
    return body


def camera_description(camera: PinholeCamera) -> dict[str, Any]:
    return {"width": camera.width, "height": camera.height, "position": list(camera.position),
            "pitch_deg": camera.pitch_deg, "hfov_deg": camera.hfov_deg, "near": camera.near, "far": camera.far}


def pad_layout_description(layout: PadLayout) -> dict[str, Any]:
    b = layout.board
    return {"rate_hz": b.rate_hz, "newtons_per_count": b.newtons_per_count, "noise_counts": b.noise_counts,
            "zero_counts": b.zero_counts,
            "pads": [{"x": p.x, "y": p.y, "width": p.width, "depth": p.depth} for p in layout.pads]}


# ---------------------------------------------------------------- reading


def _bad(path: Path, what: str) -> RecordingCorrupt:
    return RecordingCorrupt(f"{path}: {TRUTH_TOPIC} channel: {what}")


def _vectors(path: Path, value: object, key: str) -> np.ndarray:
    if not isinstance(value, dict):
        raise _bad(path, f"{key}: expected an object of bone name → [x, y, z]")
    if not value:
        return np.zeros((0, 3))
    rows = []
    for name in HUMANOID.names:
        xyz = value.get(name)
        if (not isinstance(xyz, list) or len(xyz) != 3
                or not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in xyz)):
            raise _bad(path, f"{key}.{name}: expected [x, y, z] numbers, got {xyz!r}")
        rows.append([float(v) for v in xyz])
    return np.array(rows)


def _person(path: Path, item: object) -> PersonTruth:
    if not isinstance(item, dict):
        raise _bad(path, "people: expected objects")
    try:
        pid, size, mass, present = item["id"], item["size"], item["mass_kg"], item["present"]
    except KeyError as e:
        raise _bad(path, f"people: a person has no {e.args[0]!r}") from None
    if not isinstance(pid, int) or not isinstance(present, bool) \
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in (size, mass)):
        raise _bad(path, f"people: bad id/size/mass_kg/present {pid!r}, {size!r}, {mass!r}, {present!r}")
    return PersonTruth(pid, float(size), float(mass), present, _vectors(path, item.get("joints"), "joints"),
                       _vectors(path, item.get("velocities"), "velocities"))


def read_truth(path: Path, topic: str = TRUTH_TOPIC) -> list[TruthFrame]:
    """Every message of the ground-truth channel, in file order (JSON only; nothing is executed)."""
    path = Path(path)
    stream = RecordingStream(path)
    frames: list[TruthFrame] = []
    for msg in stream.messages():
        if msg.channel.topic != topic:
            continue
        try:
            body = parse_json(msg.data, f"{path}: message {len(frames)}", MESSAGE_JSON)  # bounded nesting and size
        except UntrustedInput as e:
            raise _bad(path, f"message {len(frames)} is not JSON I can read ({e.problem})") from None
        if not isinstance(body, dict) or not isinstance(body.get("people"), list):
            raise _bad(path, f'message {len(frames)}: expected {{"people": [...]}}')
        pads = body.get("pads", [])
        if not isinstance(pads, list) or not all(isinstance(v, int | float) for v in pads):
            raise _bad(path, f"message {len(frames)}: pads must be numbers")
        people = tuple(_person(path, item) for item in body["people"])
        frames.append(TruthFrame(msg.log_time_ns / 1e9, msg.sequence, people, tuple(float(v) for v in pads)))
    if stream.damage is not None:
        raise RecordingCorrupt(stream.damage.describe(path))
    if not frames:
        raise _bad(path, "not in the recording (make it with `jostle synth performer --truth`)")
    return frames


def _metadata_json(path: Path, key: str) -> Any:
    info = describe_recording(Path(path))
    text = info.metadata.get(key)
    if text is None:
        raise RecordingCorrupt(f"{path}: no {key!r} in the recording's metadata (not made by `jostle synth`?)")
    try:
        return parse_json(text, f"{path}: metadata {key!r}", JSON_SIDECAR)
    except UntrustedInput as e:
        raise RecordingCorrupt(f"{path}: metadata {key!r} is not JSON I can read ({e.problem})") from None


def read_cameras(path: Path) -> dict[str, PinholeCamera]:
    """The virtual cameras of a synthetic recording, by channel name (exact intrinsics and pose)."""
    doc = _metadata_json(path, CAMERAS_KEY)
    try:
        return {name: PinholeCamera(int(c["width"]), int(c["height"]), tuple(float(v) for v in c["position"]),  # type: ignore[arg-type]
                                    float(c["pitch_deg"]), float(c["hfov_deg"]), float(c["near"]), float(c["far"]))
                for name, c in doc.items()}
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        raise RecordingCorrupt(f"{path}: metadata {CAMERAS_KEY!r} does not describe cameras ({e})") from None


def read_pad_layout(path: Path) -> PadLayout:
    """The pad layout a synthetic recording's pads channel was made with."""
    doc = _metadata_json(path, PADS_KEY)
    try:
        board = PadBoardConfig(float(doc["rate_hz"]), float(doc["newtons_per_count"]), float(doc["noise_counts"]),
                               int(doc["zero_counts"]))
        pads = tuple(PadPlacement(float(p["x"]), float(p["y"]), float(p["width"]), float(p["depth"]))
                     for p in doc["pads"])
        return PadLayout(board, pads)
    except (KeyError, TypeError, ValueError) as e:
        raise RecordingCorrupt(f"{path}: metadata {PADS_KEY!r} does not describe pads ({e})") from None
