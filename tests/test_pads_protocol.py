"""The pad wire formats: COBS, CRC-16, the frame layout, the stream parser's resync and counting, CSV lines."""

from __future__ import annotations

import random
import struct

import pytest

from sensors.pads.protocol import (
    FRAMINGS,
    HEADER_PAD_SAMPLE,
    BadMessage,
    SequenceTracker,
    StreamParser,
    WireSample,
    binary_frame_size,
    cobs_decode,
    cobs_encode,
    crc16_ccitt_false,
    encode_binary,
    encode_csv,
)

# the worked examples of the COBS article (Cheshire & Baker's encoding), delimiters left out
COBS_EXAMPLES = [
    (b"", b"\x01"),
    (b"\x00", b"\x01\x01"),
    (b"\x00\x00", b"\x01\x01\x01"),
    (b"\x00\x11\x00", b"\x01\x02\x11\x01"),
    (b"\x11\x22\x00\x33", b"\x03\x11\x22\x02\x33"),
    (b"\x11\x22\x33\x44", b"\x05\x11\x22\x33\x44"),
    (b"\x11\x00\x00\x00", b"\x02\x11\x01\x01\x01"),
    (bytes(range(1, 255)), b"\xff" + bytes(range(1, 255))),
    (bytes(range(0, 255)), b"\x01\xff" + bytes(range(1, 255))),
    (bytes(range(1, 256)), b"\xff" + bytes(range(1, 255)) + b"\x02\xff"),
    (bytes(range(2, 256)) + b"\x00", b"\xff" + bytes(range(2, 256)) + b"\x01\x01"),
    (bytes(range(3, 256)) + b"\x00\x01", b"\xfe" + bytes(range(3, 256)) + b"\x02\x01"),
]


@pytest.mark.parametrize(("data", "encoded"), COBS_EXAMPLES)
def test_cobs_matches_the_worked_examples(data: bytes, encoded: bytes) -> None:
    assert cobs_encode(data) == encoded
    assert cobs_decode(encoded) == data


def test_cobs_round_trips_random_data_and_never_emits_zero() -> None:
    rng = random.Random(4)
    for _ in range(500):
        n = rng.choice([rng.randrange(0, 40), rng.randrange(240, 800)])
        data = bytes(0 if rng.random() < 0.2 else rng.randrange(1, 256) for _ in range(n))
        encoded = cobs_encode(data)
        assert 0 not in encoded
        assert len(encoded) <= n + n // 254 + 1
        assert cobs_decode(encoded) == data


def test_cobs_decode_rejects_truncation_and_inner_zeros() -> None:
    with pytest.raises(BadMessage, match="past the end"):
        cobs_decode(b"\x05\x11\x22")
    with pytest.raises(BadMessage, match="zero byte"):
        cobs_decode(b"\x02\x11\x00\x33")


def test_crc_is_ccitt_false() -> None:
    assert crc16_ccitt_false(b"123456789") == 0x29B1  # the published check value of CRC-16/CCITT-FALSE
    assert crc16_ccitt_false(b"") == 0xFFFF


def test_binary_frame_layout() -> None:
    wire = encode_binary(0x1234, [1, -2, 2**31 - 1])
    assert wire[0] == 0 and wire[-1] == 0 and 0 not in wire[1:-1]
    frame = cobs_decode(wire[1:-1])
    assert len(frame) == binary_frame_size(3) == 6 + 4 * 3
    assert frame[0] == HEADER_PAD_SAMPLE == 0x11
    assert frame[1:3] == b"\x34\x12"  # seq, little-endian
    assert frame[3] == 3
    assert struct.unpack("<3i", frame[4:16]) == (1, -2, 2**31 - 1)
    assert frame[16:] == crc16_ccitt_false(frame[:16]).to_bytes(2, "big")


def _stream(pads: int, n: int, seed: int) -> tuple[bytes, list[WireSample]]:
    rng = random.Random(seed)
    samples = [WireSample(i, tuple(rng.randrange(-(2**31), 2**31) for _ in range(pads))) for i in range(n)]
    return b"".join(encode_binary(s.seq or 0, s.counts) for s in samples), samples


def _feed_in(parser: StreamParser, data: bytes, size: int) -> list[WireSample]:
    out: list[WireSample] = []
    for k in range(0, len(data), size):
        out.extend(parser.feed(data[k : k + size]))
    return out


def test_parser_output_does_not_depend_on_how_bytes_arrive() -> None:
    rng = random.Random(9)
    clean, samples = _stream(4, 40, seed=1)
    mixed = rng.randbytes(17) + clean[:200] + rng.randbytes(300) + clean[200:] + b"\x07" * 50
    results = set()
    for size in (1, 2, 3, 7, 64, 4096):
        parser = StreamParser("binary", 4)
        got = _feed_in(parser, mixed, size)
        results.add((tuple(got), parser.bad, parser.bad_bytes, parser.skipped_bytes, parser.ignored))
    assert len(results) == 1
    delivered, bad, _, skipped, _ = results.pop()
    assert list(delivered) == samples  # the garbage ends at a frame's leading 0x00, so every frame survives
    assert skipped == 17  # bytes before the first delimiter: a frame joined mid-way, not "bad"
    assert bad >= 1


def test_every_single_bit_flip_is_rejected_and_the_neighbours_survive() -> None:
    first, middle, last = (encode_binary(i, [i * 1000, -i, 70_000 + i, 5]) for i in (1, 2, 3))
    expected = [WireSample(1, (1000, -1, 70_001, 5)), WireSample(3, (3000, -3, 70_003, 5))]
    for bit in range(len(middle) * 8):
        flipped = bytearray(middle)
        flipped[bit // 8] ^= 1 << (bit % 8)
        parser = StreamParser("binary", 4)
        assert parser.feed(first + bytes(flipped) + last) == expected, f"bit {bit}"
        assert parser.bad >= 1 and parser.last_bad


def test_random_multi_bit_flips_are_never_accepted() -> None:
    rng = random.Random(21)
    accepted = 0
    for trial in range(3000):
        counts = [rng.randrange(0, 1 << 18) for _ in range(8)]
        wire = bytearray(encode_binary(trial, counts))
        for p in rng.sample(range(8, (len(wire) - 1) * 8), rng.randint(2, 4)):  # inside the frame body
            wire[p // 8] ^= 1 << (p % 8)
        parser = StreamParser("binary", 8)
        accepted += len(parser.feed(bytes(wire)))
    assert accepted == 0


def test_every_truncation_is_rejected_and_counted_once() -> None:
    first, middle, last = (encode_binary(i, [i, 2 * i]) for i in (10, 11, 12))
    for cut in range(2, len(middle) - 1):  # the leading 0x00 and at least one byte, never the whole body
        parser = StreamParser("binary", 2)
        got = parser.feed(first + middle[:cut] + last)
        assert [s.seq for s in got] == [10, 12], f"cut at {cut}"
        assert parser.bad == 1 and parser.bad_bytes == cut - 1


def test_a_run_with_no_delimiter_is_one_bad_message_and_the_stream_recovers() -> None:
    parser = StreamParser("binary", 2)
    noise = bytes(range(1, 256)) * 40  # 10,200 bytes, no zero
    after = encode_binary(5, [1, 2])
    got = _feed_in(parser, encode_binary(4, [0, 0]) + noise + after, 100)
    assert [s.seq for s in got] == [4, 5]
    assert parser.bad == 1 and parser.bad_bytes == len(noise)
    assert "no delimiter" in parser.last_bad


def test_frames_that_do_not_fit_the_config_say_why() -> None:
    parser = StreamParser("binary", 4)
    assert parser.feed(encode_binary(1, [1, 2, 3])) == []
    assert parser.bad == 1 and "sends 3 pads, the config says pads = 4" in parser.last_bad

    def framed(frame: bytes) -> bytes:
        frame += crc16_ccitt_false(frame).to_bytes(2, "big")
        return b"\x00" + cobs_encode(frame) + b"\x00"

    counts = struct.pack("<4i", 1, 2, 3, 4)
    assert parser.feed(framed(bytes((0x21, 0, 0, 4)) + counts)) == []  # version 2
    assert "protocol version 2" in parser.last_bad and parser.bad == 2
    assert parser.feed(framed(bytes((0x12, 0, 0, 4)) + counts)) == []  # version 1, another frame type
    assert parser.ignored == 1 and parser.bad == 2
    assert parser.feed(framed(bytes((0x11, 0, 0, 4)) + counts)) == [WireSample(0, (1, 2, 3, 4))]


def test_csv_lines() -> None:
    parser = StreamParser("csv", 2)
    text = b"# board v1 ready\r\n0,10,20\r\n\r\n1, 11 ,-21\n2\t12\t22\r\n3 13 23\nx,1,2\n4,14\n5,14,24,34\n6,1.5,2\n15,25\n"
    got = parser.feed(text)
    assert [s.seq for s in got] == [0, 1, 2, 3, None, None]  # two fields for two pads: counts with no seq
    assert [s.counts for s in got] == [(10, 20), (11, -21), (12, 22), (13, 23), (4, 14), (15, 25)]
    assert parser.ignored == 2  # the comment and the blank line
    assert parser.bad == 3  # "x,1,2", "5,14,24,34" (4 fields), "6,1.5,2"
    assert "not a whole number" in parser.last_bad


def test_csv_rejects_values_outside_their_range_and_over_long_lines() -> None:
    parser = StreamParser("csv", 1)
    got = parser.feed(b"0,0\n1,2147483648\n-1,5\n1,-2147483648\n")
    assert got == [WireSample(0, (0,)), WireSample(1, (-(2**31),))]
    assert parser.bad == 2
    assert parser.feed(b"7" * 500 + b"\n2,3\n") == [WireSample(2, (3,))]
    assert parser.bad == 3
    assert parser.feed(encode_csv(9, [4])) == [WireSample(9, (4,))]


def test_framings_table() -> None:
    assert set(FRAMINGS) == {"binary", "csv"}
    for framing in FRAMINGS.values():
        wire = framing.encode(7, [1, -1, 300])
        assert StreamParser(framing, 3).feed(wire) == [WireSample(7, (1, -1, 300))]
        assert len(wire.strip(bytes((framing.delimiter,)))) <= framing.max_message(3)


def test_sequence_tracker_counts_gaps_across_the_wrap() -> None:
    tracker = SequenceTracker(2**16)
    steps = [tracker.advance(s) for s in (65533, 65534, 65535, 0, 3, 4, 4, 5)]
    assert steps == [0, 0, 0, 0, 2, 0, None, 0]
    assert (tracker.dropped, tracker.repeats, tracker.restarts) == (2, 1, 0)
    assert tracker.advance(2) == 0 and tracker.restarts == 1  # back by 3: the board restarted
    assert tracker.advance(500, max_gap=100) == 0 and tracker.restarts == 2  # too far for the time passed
    assert tracker.advance(503, max_gap=100) == 2 and tracker.dropped == 4
    assert tracker.advance(None) == 0  # a CSV board that sends no seq: nothing known
    tracker.reset()
    assert tracker.advance(40_000) == 0 and tracker.dropped == 4
