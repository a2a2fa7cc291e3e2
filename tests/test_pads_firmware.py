"""The reference firmware, compiled on the host against simulated HX711s / FSRs, speaks what the driver reads.

The sketch (firmware/jostle_pads/jostle_pads.ino and pads_protocol.h) is built with g++ and a small
stand-in for the Arduino core: digitalRead/digitalWrite drive simulated HX711 chips that shift out
known 24-bit two's-complement values bit by bit, analogRead returns known FSR readings, and
Serial writes to stdout. The Python parser must decode exactly those values, in order, with no
bad frames — in both framings, and across the 16-bit sequence wrap.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from sensors.pads.protocol import SequenceTracker, StreamParser, crc16_ccitt_false

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware" / "jostle_pads"
PADS = 4  # NUM_PADS in the sketch

ARDUINO_STUB = r"""
#pragma once
#include <stdint.h>
#include <stddef.h>
#include <stdio.h>
#define HIGH 1
#define LOW 0
#define INPUT 0
#define OUTPUT 1
#define A0 14
#define A1 15
#define A2 16
#define A3 17

/* four simulated HX711s on DOUT pins 3..6 sharing SCK on pin 2 */
inline uint32_t sim_sample = 0;
inline int sim_pulses = 0;
inline int sim_sck = LOW;
inline uint32_t sim_hx711(uint32_t i, int p) { return (i * 7919u + (uint32_t)p * 104729u + 0x7FFF00u) & 0xFFFFFFu; }
inline uint32_t sim_fsr(uint32_t i, int p) { return (i * 13u + (uint32_t)p * 101u) % 1024u; }
inline uint32_t sim_micros = 0;
inline uint32_t sim_fsr_reads = 0;

static inline void pinMode(uint8_t, uint8_t) {}
static inline void noInterrupts() {}
static inline void interrupts() {}
static inline void delayMicroseconds(unsigned) {}
static inline uint32_t micros() { sim_micros += 10000; return sim_micros; } /* one FSR period per loop */
static inline int analogRead(uint8_t pin) { return (int)sim_fsr(sim_fsr_reads++ / 4, pin - A0); }
static inline void digitalWrite(uint8_t pin, uint8_t v) {
    if (pin != 2) return;
    if (v == HIGH && sim_sck == LOW) sim_pulses++;
    if (v == LOW && sim_sck == HIGH && sim_pulses == 25) { sim_pulses = 0; sim_sample++; }
    sim_sck = v;
}
static inline int digitalRead(uint8_t pin) {
    int p = pin - 3;
    if (sim_pulses == 0) return LOW; /* a conversion is ready */
    if (sim_pulses > 24) return HIGH;
    return (int)((sim_hx711(sim_sample, p) >> (24 - sim_pulses)) & 1u);
}
struct SimSerial {
    void begin(long) {}
    void write(const uint8_t *b, size_t n) { fwrite(b, 1, n, stdout); }
    void print(char c) { fputc(c, stdout); }
    void print(uint32_t v) { printf("%lu", (unsigned long)v); }
    void print(int32_t v) { printf("%ld", (long)v); }
};
inline SimSerial Serial;
"""

MAIN = r"""
#include <stdlib.h>
void setup();
void loop();
int main(int argc, char **argv) {
    long frames = argc > 1 ? atol(argv[1]) : 0;
    setup();
    for (long i = 0; i < frames; i++) loop();
    return 0;
}
"""


def _sign24(v: int) -> int:
    return v - (1 << 24) if v & 0x800000 else v


def expected_hx711(i: int) -> tuple[int, ...]:
    return tuple(_sign24((i * 7919 + p * 104729 + 0x7FFF00) & 0xFFFFFF) for p in range(PADS))


def expected_fsr(i: int) -> tuple[int, ...]:
    return tuple((i * 13 + p * 101) % 1024 for p in range(PADS))


@pytest.fixture(scope="module")
def compiler() -> str:
    cxx = shutil.which("g++") or shutil.which("clang++")
    if cxx is None:
        pytest.skip("no C++ compiler to build the firmware on the host")
    return cxx


def build(compiler: str, out: Path, *, hx711: bool, binary: bool) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    (out / "Arduino.h").write_text(ARDUINO_STUB)
    (out / "main.cpp").write_text(MAIN)
    exe = out / "sketch"
    cmd = [compiler, "-std=c++17", "-O1", "-Wall", "-Wextra", "-Werror", "-Wno-unused-function",
           f"-DUSE_HX711={int(hx711)}", f"-DSEND_BINARY={int(binary)}", f"-I{out}", f"-I{FIRMWARE}",
           "-include", "Arduino.h", "-x", "c++", str(FIRMWARE / "jostle_pads.ino"),
           "-x", "c++", str(out / "main.cpp"), "-o", str(exe)]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    if result.returncode != 0:
        pytest.fail(f"the firmware does not compile:\n{result.stderr}")
    return exe


def run(exe: Path, loops: int) -> bytes:
    return subprocess.run([str(exe), str(loops)], capture_output=True, timeout=60, check=True).stdout


def test_c_crc_matches_the_published_check_value(compiler: str, tmp_path: Path) -> None:
    src = tmp_path / "crc.c"
    src.write_text('#include <stdio.h>\n#include "pads_protocol.h"\n'
                   'int main(void){printf("%04X", jp_crc16((const uint8_t*)"123456789", 9));return 0;}\n')
    exe = tmp_path / "crc"
    subprocess.run([compiler, "-x", "c++", f"-I{FIRMWARE}", str(src), "-o", str(exe)], check=True, timeout=60)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    assert out == "29B1" == f"{crc16_ccitt_false(b'123456789'):04X}"


def test_hx711_binary_firmware_round_trip_across_the_sequence_wrap(compiler: str, tmp_path: Path) -> None:
    exe = build(compiler, tmp_path / "hx711_binary", hx711=True, binary=True)
    frames = 66_000  # past 65535, so the 16-bit sequence wraps once
    stream = run(exe, frames)
    parser = StreamParser("binary", PADS)
    tracker = SequenceTracker(parser.framing.seq_modulus)
    got = []
    for k in range(0, len(stream), 4096):
        got.extend(parser.feed(stream[k : k + 4096]))
    assert (parser.bad, parser.ignored, parser.skipped_bytes) == (0, 0, 0)
    assert len(got) == frames
    assert [s.seq for s in got[65_534:65_538]] == [65534, 65535, 0, 1]
    for i in (0, 1, 2, 1000, 65_535, 65_536, frames - 1):
        assert got[i].counts == expected_hx711(i)
    assert all(s.counts == expected_hx711(i) for i, s in enumerate(got))
    assert any(min(s.counts) < 0 for s in got[:100])  # two's complement 24-bit values did occur
    assert [tracker.advance(s.seq) for s in got] == [0] * frames
    assert (tracker.dropped, tracker.restarts) == (0, 0)


def test_fsr_csv_firmware_round_trip(compiler: str, tmp_path: Path) -> None:
    exe = build(compiler, tmp_path / "fsr_csv", hx711=False, binary=False)
    stream = run(exe, 500)
    parser = StreamParser("csv", PADS)
    got = parser.feed(stream)
    assert parser.bad == 0
    assert len(got) == 500  # the stand-in micros() moves one sampling period per call: every loop sends
    assert [s.seq for s in got] == list(range(500))
    assert [s.counts for s in got] == [expected_fsr(i) for i in range(500)]
    assert stream.count(b"\n") == 500 and stream.startswith(b"0,0,101,202,303\n")
