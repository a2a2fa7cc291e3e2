"""Decompression from outside: a declared size is a claim, checked against a budget and then held to."""

from __future__ import annotations

from collections.abc import Callable

from sensors.untrusted.errors import UntrustedInput, one_line, shorten
from sensors.untrusted.files import size_text
from sensors.untrusted.limits import DECOMPRESS_CAP, DECOMPRESS_FLOOR, DECOMPRESS_RATIO

_STEP = 1 << 20  # output is produced and counted 1 MiB at a time


def budget_for(input_size: int) -> int:
    """Bytes that ``input_size`` compressed bytes (one MCAP chunk) may decompress to:
    min(DECOMPRESS_CAP, max(DECOMPRESS_FLOOR, DECOMPRESS_RATIO × input_size)) — any block may give
    64 MiB, a larger one 64× its size, none more than 128 MiB (see ``limits``)."""
    return min(DECOMPRESS_CAP, max(DECOMPRESS_FLOOR, DECOMPRESS_RATIO * max(0, input_size)))


def decompress(data: bytes, compression: str, declared_size: int, budget: int, what: str) -> bytes:
    """``data`` decompressed by MCAP's ``compression`` ("zstd", "lz4" frame, or "" for none), which
    must give exactly ``declared_size`` bytes. Refused with one line naming ``what`` if the claim is
    over ``budget`` bytes (nothing allocated), if the data gives more than it claims (caught after
    ``declared_size`` + 1 bytes, whatever the frame header says) or less, or is corrupt."""
    if declared_size < 0 or declared_size > budget:
        raise UntrustedInput(what, f"claims {size_text(declared_size)} uncompressed from {size_text(len(data))}, "
                                   f"more than the {size_text(budget)} allowed")
    if compression == "":
        out = bytes(data)
    elif compression == "zstd":
        out = _zstd(data, declared_size + 1, what)
    elif compression == "lz4":
        out = _lz4(data, declared_size + 1, what)
    else:
        raise UntrustedInput(what, f"compression {shorten(compression)} is not supported (expected zstd, lz4 or none)")
    if len(out) > declared_size:
        raise UntrustedInput(what, f"decompresses to more than the {size_text(declared_size)} it claims")
    if len(out) < declared_size:
        raise UntrustedInput(what, f"decompresses to {len(out)} bytes, not the {declared_size} it claims")
    return out


def _zstd(data: bytes, most: int, what: str) -> bytes:
    import zstandard

    # The window a frame may ask the decoder to hold: enough for any frame of ``most`` bytes, and never
    # more than zstd's own default cap (128 MiB).
    window = min(1 << 27, max(1 << 20, 1 << (most - 1).bit_length()))
    try:
        reader = zstandard.ZstdDecompressor(max_window_size=window).stream_reader(data, read_across_frames=True)
        return _drain(reader.read, most)
    except zstandard.ZstdError as e:
        raise UntrustedInput(what, f"corrupt zstd data: {one_line(str(e), 120)}") from None


def _lz4(data: bytes, most: int, what: str) -> bytes:
    import lz4.frame  # type: ignore[import-untyped]  # no stubs; pyproject is not ours to edit here

    decoder = lz4.frame.LZ4FrameDecompressor()
    pending = [bytes(data)]
    ended = [False]

    def read(n: int) -> bytes:
        if ended[0]:  # asking again after the end would start a new frame
            return b""
        chunk = decoder.decompress(pending.pop() if pending else b"", max_length=n)
        if decoder.eof:
            ended[0] = True
            if decoder.unused_data:
                raise UntrustedInput(what, f"{len(decoder.unused_data)} bytes after the end of the lz4 frame")
        return chunk

    try:
        out = _drain(read, most)
    except RuntimeError as e:  # lz4.frame reports corrupt data as RuntimeError
        raise UntrustedInput(what, f"corrupt lz4 data: {one_line(str(e), 120)}") from None
    if not ended[0] and len(out) < most:
        raise UntrustedInput(what, f"the lz4 frame is cut short after {len(out)} bytes")
    return out


def _drain(read: Callable[[int], bytes], most: int) -> bytes:
    """Call ``read(n)`` until it gives nothing or ``most`` bytes are out; never asks for more."""
    parts: list[bytes] = []
    total = 0
    while total < most:
        chunk = read(min(_STEP, most - total))
        if not chunk:
            break
        parts.append(chunk)
        total += len(chunk)
    return b"".join(parts)
