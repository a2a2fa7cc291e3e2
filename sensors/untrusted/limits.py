"""Every default limit on input from outside, in one place, each with the reason for its size.

Sizes are bytes; times are nanoseconds (``_NS``) or seconds (``_S``). The files shipped in
``configs/`` are the yardstick: each limit leaves one to three orders of magnitude of room over the
largest real file of its kind, and stays small enough that a reader holding the whole parsed input
(Python objects cost ~50–100 bytes per TOML/JSON item) stays far under 512 MB.
"""

from __future__ import annotations

from dataclasses import dataclass

KiB = 1024
MiB = 1024 * KiB


@dataclass(frozen=True)
class InputLimits:
    """Limits for one kind of file: ``max_bytes`` read at most; for TOML/JSON, ``max_depth`` nested
    arrays/tables, ``max_key_parts`` parts in one dotted key, ``max_items`` keys + array items in
    total (counted before parsing, so an attacker's file costs no more than its size)."""

    max_bytes: int
    max_depth: int = 16
    max_key_parts: int = 16
    max_items: int = 50_000


# Configs (`jostle run CONFIG`): the shipped ones are 1–2 KB, nesting 2, under 60 items; 10,000 items
# is 150× that, and refuses a config of 10,000 sensors (5.5 GB and "can't start new thread") at once.
CONFIG_TOML = InputLimits(max_bytes=1 * MiB, max_items=10_000)
# Camera / depth calibrations: under 1 KB today; a dense lens or depth-correction table could grow.
CALIBRATION = InputLimits(max_bytes=1 * MiB, max_items=50_000)
# Keyframe set manifest (keyframes.toml): 7 KB and ~730 items for the shipped sets.
KEYFRAME_SET = InputLimits(max_bytes=4 * MiB, max_items=200_000)
# One pose file of a keyframe set: 29 KB / 2,600 items for a walk cycle; an imported clip of a
# minute at 120 Hz for 60 joints is ~2 M numbers, which this allows (~60 MB as Python floats).
POSE_FILE = InputLimits(max_bytes=16 * MiB, max_items=2_000_000)
# Character spec: 1–5 KB today.
CHARACTER_SPEC = InputLimits(max_bytes=1 * MiB, max_items=50_000)
# Terrain layout: 1 KB today; a generated layout of thousands of blocks still fits.
TERRAIN_LAYOUT = InputLimits(max_bytes=4 * MiB, max_items=200_000)
# BVH motion capture (text): CMU takes are 1–10 MB; an hour at 120 Hz of 30 joints is ~60 MB.
# max_depth bounds the joint hierarchy (a parser recursing per joint), max_items the joints.
BVH = InputLimits(max_bytes=64 * MiB, max_depth=64, max_key_parts=1, max_items=1_000)
# A DeepMimic motion clip (JSON, 44 numbers a frame): pybullet's are 10–60 KB; a minute at 120 Hz is ~320 K numbers.
MOTION_JSON = InputLimits(max_bytes=16 * MiB, max_depth=8, max_items=2_000_000)
# glTF JSON (a .gltf file or the JSON chunk of a .glb): a few MB for a rigged, animated character.
GLTF_JSON = InputLimits(max_bytes=16 * MiB, max_depth=32, max_items=1_000_000)
# One glTF buffer (.bin or a .glb's BIN chunk): the meshes and animation samples; 128 MiB is a long
# animated clip, and a reader holding it and one decoded copy stays under 512 MB.
GLTF_BUFFER = InputLimits(max_bytes=128 * MiB)
# JSON sidecars (a recording's .json notes, bench and truth files): small, machine-written.
JSON_SIDECAR = InputLimits(max_bytes=4 * MiB, max_depth=32, max_items=200_000)
# A JSON message inside a recording (a pad sample, a truth record): bytes, not megabytes.
MESSAGE_JSON = InputLimits(max_bytes=1 * MiB, max_depth=16, max_items=50_000)

# Images. 4096 × 4096 covers 4K UHD (3840 × 2160) and DCI 4K (4096 × 2160) with room; one decoded
# BGR image at the limit is 50 MB. A header claiming more (or 0) is refused before decoding.
IMAGE_MAX_PIXELS = 4096 * 4096
RAW_IMAGE_MAX_PIXELS = 4096 * 4096

# Decompression of one compressed block (an MCAP chunk), see ``budget_for``: any block may
# decompress to 64 MiB (one 4K colour + depth frame, 41 MB, however well it compressed), a larger
# one to 64 × its compressed size (the recordings here compress 1–4×; mostly-empty depth scenes
# more), never beyond 128 MiB (the recorder writes 512 KiB chunks; one decoded chunk and the
# messages copied out of it stay under 512 MB).
DECOMPRESS_FLOOR = 64 * MiB
DECOMPRESS_RATIO = 64
DECOMPRESS_CAP = 128 * MiB

# Time. Stamps are integer nanoseconds in int64 (MCAP's log_time is uint64, but nothing real is past
# 2262). Within one stream a stamp may not go back, nor jump forward more than 5 minutes: a sensor
# that stops for longer is reopened by its guard, so a longer gap in a recording is damage, and a
# replay would sit idle for the whole gap (10^19 ns is 317 years).
TIMESTAMP_MAX_NS = 2**63 - 1
TIMESTAMP_MAX_GAP_NS = 300 * 1_000_000_000

# Numbers at boundaries.
DURATION_MAX_S = 366 * 24 * 3600.0  # a run's --duration / duration_s: installations run for weeks
SEED_MAX = 2**32 - 1  # numpy's legacy seeding accepts 0 … 2^32 − 1; negative seeds are refused
SENSORS_MAX = 64  # sensors in one config: each has a thread and frame queues; real rigs have < 8
UNIT_VALUE_MAX_CHARS = 4095  # one value in a generated systemd unit: PATH_MAX − 1 (systemd's lines allow 1 MiB)

# Records in one MCAP chunk, each read into a Python object of ~200 bytes: jostle's 512 KiB chunks
# hold < 6,000 (pad samples are the smallest messages); 250,000 is ~50 MB of objects. A 22 KB file
# whose one chunk held 2 million empty messages ran out of 512 MB.
CHUNK_RECORDS_MAX = 250_000
