"""Images from outside: the size a JPEG or PNG header declares, checked before anything decodes it."""

from __future__ import annotations

import struct

from sensors.untrusted.errors import UntrustedInput
from sensors.untrusted.limits import IMAGE_MAX_PIXELS, RAW_IMAGE_MAX_PIXELS

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# Start-of-frame markers that carry the size: every SOFn but DHT (C4), JPG (C8) and DAC (CC).
_SOF = frozenset({0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF})
_NO_LENGTH = frozenset({0x01, *range(0xD0, 0xD8)})  # TEM and RST0–7 stand alone


def image_size_from_header(data: bytes) -> tuple[int, int] | None:
    """(width, height) in pixels that a JPEG (its first SOF marker) or PNG (IHDR) declares, without
    decoding; None for anything else, or a header cut short. Reads at most the marker segments
    before the first SOF, each skipped by its length, so the time is bounded by ``len(data)``."""
    view = memoryview(data)
    if bytes(view[:8]) == _PNG_SIGNATURE:
        if len(data) < 24 or bytes(view[12:16]) != b"IHDR":
            return None
        width, height = struct.unpack(">II", view[16:24])
        return int(width), int(height)
    if bytes(view[:2]) != b"\xff\xd8":
        return None
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None  # not a marker where one must be: not a JPEG we trust
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in _NO_LENGTH:
            i += 2
            continue
        if marker in (0xD9, 0xDA):  # end of image, or scan data before any frame header
            return None
        (length,) = struct.unpack(">H", view[i + 2:i + 4])
        if length < 2:
            return None
        if marker in _SOF:
            if i + 9 > len(data) or length < 7:
                return None
            height, width = struct.unpack(">HH", view[i + 5:i + 9])
            return int(width), int(height)
        i += 2 + length
    return None


def check_image(data: bytes, what: str, max_pixels: int = IMAGE_MAX_PIXELS) -> tuple[int, int]:
    """(width, height) of JPEG or PNG ``data`` from its header, refused (one line naming ``what``)
    before any decode if it is not a JPEG/PNG, declares 0 pixels either way, or more than
    ``max_pixels`` in all (a 14.5 KB JPEG can claim 30000 × 30000: 2.7 GB decoded)."""
    if not data:
        raise UntrustedInput(what, "the image is empty (0 bytes)")
    size = image_size_from_header(data)
    if size is None:
        raise UntrustedInput(what, f"not a JPEG or PNG image, or its header is cut short ({len(data)} bytes)")
    width, height = size
    if width == 0 or height == 0:
        raise UntrustedInput(what, f"the image header declares {width} × {height} pixels")
    if width * height > max_pixels:
        raise UntrustedInput(what, f"the image header declares {width} × {height} pixels, more than the "
                                   f"{max_pixels} allowed (checked before decoding)")
    return width, height


def check_raw_image(width: int, height: int, step: int, bytes_per_pixel: int, payload_size: int, what: str,
                    max_pixels: int = RAW_IMAGE_MAX_PIXELS) -> None:
    """An uncompressed image's declared shape against its payload, before any array is made: width and
    height ≥ 1 with width × height ≤ ``max_pixels``, ``step`` (bytes per row) ≥ width ×
    ``bytes_per_pixel`` (2 for 16UC1 depth, 3 for bgr8), and ``payload_size`` == step × height bytes."""
    if width <= 0 or height <= 0:
        raise UntrustedInput(what, f"the image declares {width} × {height} pixels")
    if width * height > max_pixels:
        raise UntrustedInput(what, f"the image declares {width} × {height} pixels, more than the {max_pixels} allowed")
    if step < width * bytes_per_pixel:
        raise UntrustedInput(what, f"a row step of {step} bytes is less than {width} pixels × {bytes_per_pixel} bytes")
    if step > width * bytes_per_pixel + 4096:  # rows padded for alignment, never by more than a page
        raise UntrustedInput(what, f"a row step of {step} bytes for {width} pixels × {bytes_per_pixel} bytes")
    if payload_size != step * height:
        raise UntrustedInput(what, f"{payload_size} bytes of pixels, but {width} × {height} at a step of {step} "
                                   f"needs {step * height}")
