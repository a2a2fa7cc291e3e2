"""Payload ⇄ MCAP message encoding, in Foxglove's schemas so a recording opens in Foxglove Studio.

One frame becomes one or more messages, all with the frame's time and sequence number:

- ``ColorImage`` → ``foxglove.CompressedImage`` on ``<sensor>`` (JPEG by default; PNG is lossless).
- ``DepthImage`` → ``foxglove.CameraCalibration`` on ``<sensor>/calibration`` (the intrinsics, K and P),
  then ``foxglove.RawImage`` ``bgr8`` on ``<sensor>/color`` if the frame has an aligned colour image,
  then ``foxglove.RawImage`` ``16UC1`` on ``<sensor>``. All lossless, so replay rebuilds the
  frame bit for bit; the chunk compression (zstd) keeps the files small.
- ``PadSample`` → JSON ``{"newtons": [...], "raw": [...]}`` (schema ``jostle.PadSample``) on ``<sensor>``.

Every channel carries metadata ``jostle.sensor``, ``jostle.role`` and ``jostle.kind`` so a reader
knows which channels belong together without guessing from topic names.

Decoding never runs anything from the file: protobuf classes are built from the embedded
descriptors by ``mcap_protobuf``'s ``DecoderFactory`` (data only), JSON through ``sensors.untrusted.parse_json``.
cv2 is imported only when an image is encoded or decoded, never at import.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
from google.protobuf.timestamp_pb2 import Timestamp
from mcap.records import Channel, Schema
from mcap_protobuf.decoder import DecoderFactory
from mcap_protobuf.schema import build_file_descriptor_set

from sensors.base import ColorImage, DepthImage, Frame, PadSample, Payload
from sensors.untrusted import UntrustedInput, check_image, check_raw_image, one_line, parse_json
from sensors.untrusted.limits import MESSAGE_JSON

ColorFormat = Literal["jpeg", "png"]
ChannelRole = Literal["frame", "calibration", "aligned_color", "other"]

SCHEMA_COMPRESSED_IMAGE = "foxglove.CompressedImage"
SCHEMA_RAW_IMAGE = "foxglove.RawImage"
SCHEMA_CALIBRATION = "foxglove.CameraCalibration"
SCHEMA_PADS = "jostle.PadSample"

META_SENSOR = "jostle.sensor"
META_ROLE = "jostle.role"
META_KIND = "jostle.kind"

CALIBRATION_SUFFIX = "/calibration"
ALIGNED_COLOR_SUFFIX = "/color"

PADS_JSON_SCHEMA: dict[str, Any] = {
    "title": SCHEMA_PADS,
    "description": "One reading of every force pad on a board: calibrated newtons and raw counts.",
    "type": "object",
    "properties": {
        "newtons": {"type": "array", "items": {"type": "number"}},
        "raw": {"type": "array", "items": {"type": "integer"}},
    },
    "required": ["newtons", "raw"],
}

_PROTOBUF_CLASSES: dict[str, Any] = {
    SCHEMA_COMPRESSED_IMAGE: CompressedImage,
    SCHEMA_RAW_IMAGE: RawImage,
    SCHEMA_CALIBRATION: CameraCalibration,
}


class CodecError(ValueError):
    """A message could not be turned back into a payload (bad data, unknown encoding)."""


# ---------------------------------------------------------------- encoding


@dataclass(frozen=True, slots=True)
class EncodedMessage:
    """One MCAP message ready to write: where it goes, in which schema, and its bytes."""

    topic: str
    sensor: str
    role: ChannelRole
    kind: str
    schema_name: str
    message_encoding: Literal["protobuf", "json"]
    data: bytes


@dataclass(frozen=True, slots=True)
class SchemaDefinition:
    """What goes into an MCAP Schema record."""

    name: str
    encoding: Literal["protobuf", "jsonschema"]
    data: bytes


def schema_definition(schema_name: str) -> SchemaDefinition:
    """The MCAP schema record for one of the schemas this codec writes."""
    if schema_name == SCHEMA_PADS:
        return SchemaDefinition(schema_name, "jsonschema", json.dumps(PADS_JSON_SCHEMA).encode())
    message_class = _PROTOBUF_CLASSES[schema_name]
    return SchemaDefinition(
        schema_name, "protobuf", build_file_descriptor_set(message_class).SerializeToString()
    )


def _timestamp(t_ns: int) -> Timestamp:
    return Timestamp(seconds=t_ns // 1_000_000_000, nanos=t_ns % 1_000_000_000)


def _cv2() -> Any:
    import cv2

    return cv2


def encode_color(image: np.ndarray, *, color_format: ColorFormat, jpeg_quality: int) -> bytes:
    """BGR uint8 (H, W, 3) → JPEG or PNG bytes."""
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"colour image: expected uint8 (H, W, 3) BGR, got {image.dtype} {image.shape}")
    cv2 = _cv2()
    if color_format == "jpeg":
        ok, buf = cv2.imencode(".jpg", np.ascontiguousarray(image), [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    else:
        ok, buf = cv2.imencode(".png", np.ascontiguousarray(image))
    if not ok:
        raise ValueError(f"colour image: OpenCV could not encode it as {color_format}")
    return bytes(buf.tobytes())


def _raw_bgr8(image: np.ndarray, t_ns: int, frame_id: str) -> RawImage:
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"aligned colour: expected uint8 (H, W, 3) BGR, got {image.dtype} {image.shape}")
    h, w = image.shape[:2]
    return RawImage(
        timestamp=_timestamp(t_ns), frame_id=frame_id, width=w, height=h, encoding="bgr8",
        step=w * 3, data=np.ascontiguousarray(image).tobytes(),
    )


def _calibration(depth: DepthImage, t_ns: int, frame_id: str) -> CameraCalibration:
    w, h = depth.size
    fx, fy, cx, cy = float(depth.fx), float(depth.fy), float(depth.cx), float(depth.cy)
    return CameraCalibration(
        timestamp=_timestamp(t_ns), frame_id=frame_id, width=w, height=h,
        distortion_model="plumb_bob", D=[0.0, 0.0, 0.0, 0.0, 0.0],
        K=[fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        R=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        P=[fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    )


def encode_frame(
    frame: Frame, t_ns: int, *, color_format: ColorFormat = "jpeg", jpeg_quality: int = 85
) -> list[EncodedMessage]:
    """The messages for one frame, companions (calibration, aligned colour) before the frame itself."""
    name, p = frame.sensor, frame.payload
    if isinstance(p, ColorImage):
        data = encode_color(p.bgr, color_format=color_format, jpeg_quality=jpeg_quality)
        msg = CompressedImage(timestamp=_timestamp(t_ns), frame_id=name, data=data, format=color_format)
        return [EncodedMessage(name, name, "frame", "color", SCHEMA_COMPRESSED_IMAGE, "protobuf",
                               msg.SerializeToString())]
    if isinstance(p, DepthImage):
        if p.depth_mm.dtype != np.uint16 or p.depth_mm.ndim != 2:
            raise ValueError(f"depth image: expected uint16 (H, W) millimetres, got {p.depth_mm.dtype} {p.depth_mm.shape}")
        w, h = p.size
        out = [EncodedMessage(name + CALIBRATION_SUFFIX, name, "calibration", "depth", SCHEMA_CALIBRATION,
                              "protobuf", _calibration(p, t_ns, name).SerializeToString())]
        if p.color is not None:
            out.append(EncodedMessage(name + ALIGNED_COLOR_SUFFIX, name, "aligned_color", "depth",
                                      SCHEMA_RAW_IMAGE, "protobuf",
                                      _raw_bgr8(p.color, t_ns, name).SerializeToString()))
        raw = RawImage(timestamp=_timestamp(t_ns), frame_id=name, width=w, height=h, encoding="16UC1",
                       step=w * 2, data=np.ascontiguousarray(p.depth_mm, dtype="<u2").tobytes())
        out.append(EncodedMessage(name, name, "frame", "depth", SCHEMA_RAW_IMAGE, "protobuf",
                                  raw.SerializeToString()))
        return out
    body = {"newtons": [float(x) for x in p.newtons], "raw": [int(x) for x in p.raw]}
    return [EncodedMessage(name, name, "frame", "pads", SCHEMA_PADS, "json", json.dumps(body).encode())]


# ---------------------------------------------------------------- reading


_ROLES: dict[str, ChannelRole] = {"frame": "frame", "calibration": "calibration", "aligned_color": "aligned_color"}


@dataclass(frozen=True, slots=True)
class ChannelRoleInfo:
    """What a channel holds: which sensor it belongs to, its role and payload kind."""

    sensor: str
    role: ChannelRole
    kind: str  # "color" | "depth" | "pads" for jostle channels; "" when unknown


def classify_channel(channel: Channel, schema: Schema | None) -> ChannelRoleInfo:
    """Read a channel's role from its jostle metadata, or infer it from the schema for other files."""
    md = channel.metadata or {}
    role = _ROLES.get(md.get(META_ROLE, ""))
    if role is not None:
        return ChannelRoleInfo(md.get(META_SENSOR, channel.topic), role, md.get(META_KIND, ""))
    name = schema.name if schema is not None else ""
    topic = channel.topic
    if name == SCHEMA_CALIBRATION and topic.endswith(CALIBRATION_SUFFIX):
        return ChannelRoleInfo(topic[: -len(CALIBRATION_SUFFIX)], "calibration", "depth")
    if name == SCHEMA_RAW_IMAGE and topic.endswith(ALIGNED_COLOR_SUFFIX):
        return ChannelRoleInfo(topic[: -len(ALIGNED_COLOR_SUFFIX)], "aligned_color", "depth")
    kind = {SCHEMA_COMPRESSED_IMAGE: "color", SCHEMA_RAW_IMAGE: "depth", SCHEMA_PADS: "pads"}.get(name)
    if kind is None:
        return ChannelRoleInfo(topic, "other", "")
    return ChannelRoleInfo(topic, "frame", kind)


def decode_color(data: bytes) -> np.ndarray:
    """JPEG or PNG bytes → BGR uint8 (H, W, 3). The header's declared size is checked first
    (``check_image``: not 0, within the pixel budget); any refusal or OpenCV error is a CodecError."""
    try:
        check_image(data, "compressed image")
    except UntrustedInput as e:
        raise CodecError(e.message) from None
    cv2 = _cv2()
    try:
        img = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    except cv2.error as e:
        raise CodecError(f"compressed image of {len(data)} bytes cannot be decoded ({one_line(str(e), 120)})") from None
    if img is None:
        raise CodecError(f"compressed image of {len(data)} bytes cannot be decoded")
    return np.asarray(img, dtype=np.uint8)


def _decode_raw(msg: Any) -> np.ndarray:
    """A RawImage message → (H, W) uint16 for 16UC1/mono16, (H, W, 3) BGR uint8 for bgr8/rgb8."""
    w, h, step, enc, data = int(msg.width), int(msg.height), int(msg.step), str(msg.encoding), bytes(msg.data)
    dtype: np.dtype[Any]
    if enc in ("16UC1", "mono16"):
        channels, dtype = 1, np.dtype("<u2")
    elif enc in ("bgr8", "8UC3", "rgb8"):
        channels, dtype = 3, np.dtype(np.uint8)
    else:
        raise CodecError(f"raw image encoding {enc!r} is not supported (expected 16UC1, mono16, bgr8 or rgb8)")
    row = w * channels * dtype.itemsize
    try:  # declared shape against the payload and the pixel budget, before any array is made
        check_raw_image(w, h, step, channels * dtype.itemsize, len(data), f"raw image {enc}")
    except UntrustedInput as e:
        raise CodecError(e.message) from None
    if step % dtype.itemsize:
        raise CodecError(f"raw image {w}x{h} {enc} with step {step} does not fit its {len(data)} bytes")
    rows = np.frombuffer(data, dtype=np.uint8, count=step * h).reshape(h, step)[:, :row]
    img = np.ascontiguousarray(rows).view(dtype)
    if channels == 1:
        return img.reshape(h, w).astype(np.uint16)
    img = img.reshape(h, w, 3)
    return np.ascontiguousarray(img[:, :, ::-1] if enc == "rgb8" else img).copy()


def decode_pads(data: bytes) -> PadSample:
    """A pad sample's JSON (bounded: ``MESSAGE_JSON``) → PadSample; newtons must be finite numbers and
    raw counts integers. Anything else is a CodecError (a damaged frame)."""
    try:
        body = parse_json(data, "pad sample", MESSAGE_JSON)
    except UntrustedInput as e:
        raise CodecError(e.message) from None
    if not isinstance(body, dict) or not isinstance(body.get("newtons"), list) or not isinstance(body.get("raw"), list):
        raise CodecError('pad sample: expected {"newtons": [...], "raw": [...]}')
    newtons, raw = body["newtons"], body["raw"]
    # json gives exactly int, float, bool, str, list, dict or None: compare types, not isinstance
    # (bool is an int subclass and must be refused)
    if not all(type(x) is float or type(x) is int for x in newtons):
        raise CodecError("pad sample: newtons must be numbers")
    try:
        values = tuple(map(float, newtons))
    except OverflowError:  # an integer beyond any float
        values = (math.inf,)
    if not all(math.isfinite(v) for v in values):
        raise CodecError("pad sample: newtons must be finite numbers")
    if not all(type(x) is int for x in raw):
        raise CodecError("pad sample: raw must be integers")
    return PadSample(newtons=values, raw=tuple(raw))


@dataclass(frozen=True, slots=True)
class _Companion:
    sequence: int
    log_time_ns: int
    value: Any


class PayloadAssembler:
    """Turns the messages of one sensor's channels back into payloads.

    Feed it every message of the sensor's channels in file order; a frame channel's message returns
    the payload, a companion's (calibration, aligned colour) returns None and is kept for the frame
    with the same sequence number and time. A depth frame with no calibration at all gets zero
    intrinsics (Foxglove's convention for "uncalibrated").
    """

    def __init__(self) -> None:
        self._factory = DecoderFactory()
        self._decoders: dict[int, Callable[[bytes], Any]] = {}
        self._calibration: _Companion | None = None
        self._color: _Companion | None = None

    def _protobuf(self, channel: Channel, schema: Schema | None, data: bytes) -> Any:
        if schema is None:
            raise CodecError(f"channel {channel.topic!r} has no schema")
        decoder = self._decoders.get(schema.id)
        if decoder is None:
            try:
                found = self._factory.decoder_for(channel.message_encoding, schema)
            except Exception as e:  # the descriptor set is data from the file: report, never crash
                raise CodecError(f"schema {schema.name!r} cannot be loaded ({e})") from e
            if found is None:
                raise CodecError(f"channel {channel.topic!r}: encoding {channel.message_encoding!r} "
                                 f"with schema encoding {schema.encoding!r} is not protobuf")
            decoder = found
            self._decoders[schema.id] = decoder
        try:
            return decoder(data)
        except Exception as e:
            raise CodecError(f"{schema.name} message cannot be parsed ({e})") from e

    def feed(self, role: ChannelRoleInfo, channel: Channel, schema: Schema | None,
             sequence: int, log_time_ns: int, data: bytes) -> Payload | None:
        if role.role == "calibration":
            self._calibration = _Companion(sequence, log_time_ns, self._protobuf(channel, schema, data))
            return None
        if role.role == "aligned_color":
            msg = self._protobuf(channel, schema, data)
            self._color = _Companion(sequence, log_time_ns, _decode_raw(msg))
            return None
        if role.role != "frame":
            return None
        if channel.message_encoding == "json":
            return decode_pads(data)
        msg = self._protobuf(channel, schema, data)
        name = schema.name if schema is not None else ""
        if name == SCHEMA_COMPRESSED_IMAGE:
            return ColorImage(bgr=decode_color(bytes(msg.data)))
        if name == SCHEMA_RAW_IMAGE:
            return self._depth(msg, sequence, log_time_ns)
        raise CodecError(f"channel {channel.topic!r}: schema {name!r} is not a jostle payload")

    def _depth(self, msg: Any, sequence: int, log_time_ns: int) -> DepthImage:
        depth = _decode_raw(msg)
        if depth.ndim != 2:
            raise CodecError(f"depth image has encoding {msg.encoding!r}; expected 16UC1")
        fx = fy = cx = cy = 0.0
        if self._calibration is not None:
            k = list(self._calibration.value.K)
            if len(k) != 9 or not all(math.isfinite(v) for v in k):
                raise CodecError(f"camera calibration K has {len(k)} values; expected 9 finite numbers")
            cw, ch = int(self._calibration.value.width), int(self._calibration.value.height)
            if cw and ch and (cw, ch) != (depth.shape[1], depth.shape[0]):  # 0 × 0: size not given
                raise CodecError(f"camera calibration for {cw}x{ch} pixels, but the depth image is "
                                 f"{depth.shape[1]}x{depth.shape[0]}")
            fx, cx, fy, cy = k[0], k[2], k[4], k[5]
        color = None
        c = self._color
        if c is not None and c.sequence == sequence and c.log_time_ns == log_time_ns:
            color = c.value
        self._color = None
        return DepthImage(depth_mm=depth, fx=fx, fy=fy, cx=cx, cy=cy, color=color)
