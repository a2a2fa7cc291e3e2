"""The pad parser fuzz benchmark (`jostle bench sensors`) on ~50 kB: no crash, no bad frame accepted."""

from __future__ import annotations

from jostle.bench.pad_fuzz import build_fuzz_stream, fuzz_parser
from sensors.pads.protocol import FRAMINGS, StreamParser


def test_fuzz_binary_accepts_every_valid_frame_and_nothing_else() -> None:
    result = fuzz_parser(50_000, seed=11, rate_frames=5_000)
    assert result["fuzz_bytes"] >= 50_000
    assert result["crashes"] == 0 and result["first_crash"] == ""
    assert result["bad_frames_accepted"] == 0
    # every valid frame is sent between two delimiters, so no damage can take one down with it
    assert result["good_frames_accepted"] == result["good_frames_sent"] > 300
    assert result["bad_counted"] > 300  # the damage was really there, and was counted
    # the target is 50,000/s (measured ~180,000-300,000/s here); this only catches a collapse
    assert result["pad_frames_per_s"] > 25_000


def test_fuzz_is_a_function_of_the_seed() -> None:
    a = fuzz_parser(20_000, seed=5, rate_frames=500)
    b = fuzz_parser(20_000, seed=5, rate_frames=500)
    c = fuzz_parser(20_000, seed=6, rate_frames=500)
    timing = "pad_frames_per_s"
    assert {k: v for k, v in a.items() if k != timing} == {k: v for k, v in b.items() if k != timing}
    assert {k: v for k, v in a.items() if k != timing} != {k: v for k, v in c.items() if k != timing}


def test_the_fuzz_stream_really_holds_damage() -> None:
    stream, valid, sent = build_fuzz_stream(30_000, 2, FRAMINGS["binary"], 8)
    parser = StreamParser("binary", 8)
    got = parser.feed(stream)
    assert len(valid) == sent == len(got)
    assert parser.bad > 100 and parser.bad_bytes > 5_000


def test_fuzz_csv_never_crashes() -> None:
    result = fuzz_parser(30_000, seed=3, framing="csv", rate_frames=500)
    assert result["crashes"] == 0
    assert result["good_frames_accepted"] == result["good_frames_sent"] > 50
