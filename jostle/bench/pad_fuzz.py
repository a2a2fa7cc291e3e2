"""Fuzz and time the force-pad stream parser (``jostle bench sensors``).

:func:`fuzz_parser` builds a byte stream of known valid frames interleaved with damage — random
noise, long runs without a delimiter, frames with bit flips, truncated frames, and frames spliced
from the head of one and the tail of another — feeds it to a :class:`StreamParser` in random
chunk sizes, and reports what came out. The damaged frames carry random contents of their own,
never those of a valid frame, so any of them that is delivered counts as a bad frame accepted.
The stream is a function of ``seed`` alone; only the timing varies between runs.

Every message is sent between two delimiters, as the reference firmware does (0x00 before and
after each binary frame), so damage never takes the next valid frame down with it.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable, Sequence
from typing import TypedDict

from sensors.pads.protocol import FRAMINGS, Framing, StreamParser, WireSample

_WEIGHTS = {"valid": 50, "noise": 10, "long_noise": 3, "flip": 15, "truncate": 11, "splice": 11}
_CLEAN_CHUNK = 4096  # bytes per feed when timing a clean stream (a serial read's worth)


class FuzzReport(TypedDict):
    framing: str
    pads: int
    seed: int
    fuzz_bytes: int
    crashes: int
    bad_frames_accepted: int
    good_frames_accepted: int
    good_frames_sent: int
    bad_counted: int
    pad_frames_per_s: float
    first_crash: str


def _random_counts(rng: random.Random, pads: int) -> tuple[int, ...]:
    """Load-cell-like counts: mostly small (so their encodings hold zero bytes), some full-range."""
    out = []
    for _ in range(pads):
        r = rng.random()
        if r < 0.5:
            out.append(rng.randrange(0, 1 << 17))
        elif r < 0.7:
            out.append(-rng.randrange(0, 1 << 17))
        else:
            out.append(rng.randrange(-(2**31), 2**31))
    return tuple(out)


def _body(framing: Framing, seq: int, counts: Sequence[int]) -> bytes:
    """One message without its delimiters."""
    return framing.encode(seq, counts).strip(bytes((framing.delimiter,)))


def _flip_bits(rng: random.Random, data: bytes) -> bytes:
    out = bytearray(data)
    positions = rng.sample(range(len(out) * 8), rng.randint(1, min(3, len(out) * 8)))
    for p in positions:
        out[p // 8] ^= 1 << (p % 8)
    return bytes(out)


def build_fuzz_stream(n_bytes: int, seed: int, framing: Framing, pads: int) -> tuple[bytes, set[WireSample], int]:
    """(stream of at least ``n_bytes``, the valid samples in it, how many valid frames were sent)."""
    rng = random.Random(seed)
    d = bytes((framing.delimiter,))
    kinds = list(_WEIGHTS)
    weights = list(_WEIGHTS.values())
    out = bytearray()
    valid: set[WireSample] = set()
    sent = 0
    seq = rng.randrange(framing.seq_modulus)

    def damaged() -> bytes:  # a frame with contents of its own, never sent intact
        return _body(framing, rng.randrange(framing.seq_modulus), _random_counts(rng, pads))

    while len(out) < n_bytes:
        kind = rng.choices(kinds, weights)[0]
        if kind == "valid":
            counts = _random_counts(rng, pads)
            out += d + _body(framing, seq, counts) + d
            valid.add(WireSample(seq, counts))
            sent += 1
            seq = (seq + 1) % framing.seq_modulus
        elif kind == "noise":
            out += rng.randbytes(rng.randint(1, 80))
        elif kind == "long_noise":  # no delimiter for longer than any message
            out += bytes(b if b != framing.delimiter else 0x55 for b in rng.randbytes(rng.randint(100, 2500)))
        elif kind == "flip":
            out += d + _flip_bits(rng, damaged()) + d
        elif kind == "truncate":
            body = damaged()
            out += d + body[: rng.randrange(1, len(body))]
        else:  # splice: the head of one frame and the tail of another, often cut at the same place
            a, b = damaged(), damaged()
            spliced = b
            while spliced in (a, b):  # a head equal to b's own (same first bytes) is no damage: cut again
                i = rng.randrange(1, len(a))
                j = i if rng.random() < 0.5 and i < len(b) else rng.randrange(1, len(b))
                spliced = a[:i] + b[j:]
            out += d + spliced + d
    return bytes(out), valid, sent


def _clean_rate(framing: Framing, pads: int, frames: int, seed: int, repeats: int = 3) -> float:
    """Samples per second decoded from a clean stream (best of ``repeats``)."""
    rng = random.Random(seed)
    stream = b"".join(framing.encode(i % framing.seq_modulus, _random_counts(rng, pads)) for i in range(frames))
    best = 0.0
    for _ in range(repeats):
        parser = StreamParser(framing, pads)
        feed: Callable[[bytes], list[WireSample]] = parser.feed
        got = 0
        start = time.perf_counter()
        for k in range(0, len(stream), _CLEAN_CHUNK):
            got += len(feed(stream[k : k + _CLEAN_CHUNK]))
        took = time.perf_counter() - start
        if got != frames:
            raise RuntimeError(f"a clean stream of {frames} frames decoded to {got} (parser bad: {parser.last_bad})")
        best = max(best, frames / took if took > 0 else float("inf"))
    return best


def fuzz_parser(
    n_bytes: int, seed: int, *, framing: str = "binary", pads: int = 8, rate_frames: int = 20_000
) -> FuzzReport:
    """Fuzz the stream parser with ``n_bytes`` of mixed valid and damaged bytes; time a clean stream.

    Keys: ``fuzz_bytes``, ``crashes`` (exceptions escaping the parser), ``bad_frames_accepted``
    (delivered samples that were not among the valid ones sent), ``good_frames_accepted``,
    ``good_frames_sent``, ``bad_counted`` (messages the parser rejected), ``pad_frames_per_s``
    (decode rate of a clean stream of ``rate_frames`` frames of ``pads`` pads, best of 3), and
    ``first_crash`` (empty when none). Targets for binary: 0 crashes, 0 bad frames accepted,
    ≥ 50,000 pad frames/s. The CSV framing has no integrity check: a flipped digit is a valid line,
    so it accepts some damaged lines by design.
    """
    if n_bytes <= 0:
        raise ValueError(f"n_bytes: expected bytes > 0, got {n_bytes}")
    wire = FRAMINGS.get(framing)
    if wire is None:
        raise ValueError(f"framing: expected one of {', '.join(FRAMINGS)}, got {framing!r}")
    stream, valid, sent = build_fuzz_stream(n_bytes, seed, wire, pads)
    rng = random.Random(seed ^ 0x5EED)
    parser = StreamParser(wire, pads)
    crashes = 0
    first_crash = ""
    accepted_good: set[WireSample] = set()
    accepted_bad = 0
    at = 0
    while at < len(stream):
        size = rng.randint(1, 64) if rng.random() < 0.8 else rng.randint(65, 2048)
        chunk = stream[at : at + size]
        at += size
        try:
            samples = parser.feed(chunk)
        except Exception as e:  # the point of the fuzz: count anything that escapes
            crashes += 1
            first_crash = first_crash or f"{type(e).__name__}: {e}"
            continue
        for s in samples:
            if s in valid:
                accepted_good.add(s)
            else:
                accepted_bad += 1
    return {
        "framing": framing,
        "pads": pads,
        "seed": seed,
        "fuzz_bytes": len(stream),
        "crashes": crashes,
        "bad_frames_accepted": accepted_bad,
        "good_frames_accepted": len(accepted_good),
        "good_frames_sent": sent,
        "bad_counted": parser.bad,
        "pad_frames_per_s": round(_clean_rate(wire, pads, rate_frames, seed), 1),
        "first_crash": first_crash,
    }
