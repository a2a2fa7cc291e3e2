"""Writing a built glTF document with its one binary buffer: ``.glb`` binary, anything else JSON with the
buffer embedded as a base64 data URI (one self-contained file either way; Blender opens both)."""

from __future__ import annotations

import base64
from pathlib import Path
from typing import Any

from sensors.untrusted import write_owned


def save_gltf(doc: Any, blob: bytes | bytearray, path: Path | str) -> Path:
    """Save the pygltflib ``doc`` whose ``buffers[0]`` is ``blob`` to ``path`` (parents made); returns it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".glb":
        doc.set_binary_blob(bytes(blob))
        data: bytes | str = b"".join(doc.save_to_bytes())
    else:
        doc.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()
        data = doc.gltf_to_json()
    write_owned(path, data)  # atomic; a FIFO or device at ``path`` is refused, never replaced
    return path
