// jostle_pads: reference firmware for a jostle force-pad board.
//
// Reads NUM_PADS load cells through HX711 amplifiers (one HX711 per pad, all sharing one clock
// pin) or NUM_PADS force-sensing resistors on analog pins, and sends every sample to jostle in
// the binary framing of docs/pads-protocol.md (COBS + CRC-16/CCITT-FALSE), or as CSV lines.
// Wiring: firmware/README.md. jostle config: [sensors.pads] type = "pads", port, pads = NUM_PADS,
// framing = "binary" (or "csv"), baudrate = 115200, rate_hz = the rate below.
//
// Counts are raw: the zero (tare) and the newtons per count are applied by jostle.

#include "pads_protocol.h"

// ---------------------------------------------------------------- choose here
#ifndef USE_HX711
#define USE_HX711 1    // 1: HX711 load cells; 0: FSRs on analog pins
#endif
#ifndef SEND_BINARY
#define SEND_BINARY 1  // 1: binary frames (recommended); 0: CSV lines "seq,raw0,raw1,...\n"
#endif
#define NUM_PADS 4
#define BAUD 115200

#if USE_HX711
// One HX711 per pad. All share SCK; each has its own DOUT. RATE pin high = 80 samples/s, low = 10.
const uint8_t HX711_SCK = 2;
const uint8_t HX711_DOUT[NUM_PADS] = {3, 4, 5, 6};
#else
// FSR + 10 kOhm resistor to GND as a voltage divider on each analog pin; sampled at FSR_RATE_HZ.
const uint8_t FSR_PIN[NUM_PADS] = {A0, A1, A2, A3};
const uint16_t FSR_RATE_HZ = 100;
#endif

// ---------------------------------------------------------------- state
static int32_t counts[NUM_PADS];
#if SEND_BINARY
static uint8_t scratch[JP_FRAME_SIZE(NUM_PADS)];
static uint8_t wire[JP_WIRE_MAX(NUM_PADS)];
#endif
static uint32_t seq = 0;  // binary frames carry its low 16 bits (wrapping), CSV lines all 32

#if USE_HX711
static bool hx711_ready() {
  for (uint8_t p = 0; p < NUM_PADS; p++) {
    if (digitalRead(HX711_DOUT[p]) == HIGH) return false;  // DOUT goes low when a sample is ready
  }
  return true;
}

// Clock 24 bits out of every HX711 at once (MSB first), then one more pulse: channel A, gain 128.
// Interrupts are off while clocking: SCK high for more than 60 us powers the HX711 down.
static void hx711_read_all() {
  uint32_t value[NUM_PADS] = {0};
  noInterrupts();
  for (uint8_t bit = 0; bit < 24; bit++) {
    digitalWrite(HX711_SCK, HIGH);
    delayMicroseconds(1);
    for (uint8_t p = 0; p < NUM_PADS; p++) {
      value[p] = (value[p] << 1) | (digitalRead(HX711_DOUT[p]) == HIGH ? 1u : 0u);
    }
    digitalWrite(HX711_SCK, LOW);
    delayMicroseconds(1);
  }
  digitalWrite(HX711_SCK, HIGH);
  delayMicroseconds(1);
  digitalWrite(HX711_SCK, LOW);
  interrupts();
  for (uint8_t p = 0; p < NUM_PADS; p++) {
    uint32_t v = value[p];
    if (v & 0x800000UL) v |= 0xFF000000UL;  // 24-bit two's complement -> 32-bit
    counts[p] = (int32_t)v;
  }
}
#endif

static void send_sample() {
#if SEND_BINARY
  size_t n = jp_pad_frame((uint16_t)seq, counts, NUM_PADS, scratch, wire);
  Serial.write(wire, n);
#else
  Serial.print(seq);
  for (uint8_t p = 0; p < NUM_PADS; p++) {
    Serial.print(',');
    Serial.print(counts[p]);
  }
  Serial.print('\n');
#endif
  seq++;
}

void setup() {
  Serial.begin(BAUD);
#if USE_HX711
  pinMode(HX711_SCK, OUTPUT);
  digitalWrite(HX711_SCK, LOW);
  for (uint8_t p = 0; p < NUM_PADS; p++) pinMode(HX711_DOUT[p], INPUT);
#endif
}

void loop() {
#if USE_HX711
  if (!hx711_ready()) return;
  hx711_read_all();
  send_sample();
#else
  static uint32_t next_us = 0;
  uint32_t now = micros();
  if ((int32_t)(now - next_us) < 0) return;
  next_us = now + 1000000UL / FSR_RATE_HZ;
  for (uint8_t p = 0; p < NUM_PADS; p++) counts[p] = analogRead(FSR_PIN[p]);  // 0..1023 on AVR
  send_sample();
#endif
}
