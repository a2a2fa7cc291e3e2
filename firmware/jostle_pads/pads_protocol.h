/*
 * jostle force-pad wire protocol, binary framing, version 1 (see docs/pads-protocol.md).
 *
 * Plain C99, no Arduino calls: the sketch uses it, and jostle's tests compile it on the host
 * and check that the Python driver decodes what it writes.
 *
 * Frame before COBS (6 + 4*N bytes):
 *   [0]      header = (version << 4) | type      0x11: version 1, pad sample
 *   [1..2]   sequence number, u16 little-endian, +1 per frame, wraps 65535 -> 0
 *   [3]      N, the number of pads (1..255)
 *   [4..]    N raw counts, int32 little-endian
 *   [last 2] CRC-16/CCITT-FALSE of all bytes before it, BIG-endian (high byte first)
 * On the wire: 0x00, COBS(frame), 0x00.
 */
#ifndef JOSTLE_PADS_PROTOCOL_H
#define JOSTLE_PADS_PROTOCOL_H

#include <stddef.h>
#include <stdint.h>

#define JP_VERSION 1
#define JP_TYPE_PAD_SAMPLE 1
#define JP_HEADER_PAD_SAMPLE ((JP_VERSION << 4) | JP_TYPE_PAD_SAMPLE)
#define JP_FRAME_SIZE(n) (6 + 4 * (size_t)(n))
/* COBS adds one byte per started 254-byte block; plus the two 0x00 delimiters */
#define JP_WIRE_MAX(n) (JP_FRAME_SIZE(n) + JP_FRAME_SIZE(n) / 254 + 1 + 2)

/* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no final XOR ("123456789" -> 0x29B1). */
static inline uint16_t jp_crc16(const uint8_t *data, size_t len) {
    uint16_t crc = 0xFFFF;
    for (size_t i = 0; i < len; i++) {
        crc ^= (uint16_t)data[i] << 8;
        for (uint8_t bit = 0; bit < 8; bit++) {
            crc = (crc & 0x8000) ? (uint16_t)((crc << 1) ^ 0x1021) : (uint16_t)(crc << 1);
        }
    }
    return crc;
}

/* COBS-encode len bytes of in into out (room for len + len/254 + 1); returns the encoded length. */
static inline size_t jp_cobs_encode(const uint8_t *in, size_t len, uint8_t *out) {
    size_t code_at = 0, o = 1;
    uint8_t code = 1;
    for (size_t i = 0; i < len; i++) {
        if (in[i] != 0) {
            out[o++] = in[i];
            code++;
        }
        if (in[i] == 0 || code == 0xFF) {
            out[code_at] = code;
            code = 1;
            code_at = o;
            if (in[i] == 0 || i + 1 < len) {
                o++;
            }
        }
    }
    out[code_at] = code;
    return o;
}

/*
 * Build one pad-sample frame ready to send: 0x00, COBS(frame), 0x00.
 * out needs JP_WIRE_MAX(n) bytes, scratch JP_FRAME_SIZE(n). Returns the bytes to send.
 */
static inline size_t jp_pad_frame(uint16_t seq, const int32_t *counts, uint8_t n, uint8_t *scratch, uint8_t *out) {
    size_t k = 0;
    scratch[k++] = JP_HEADER_PAD_SAMPLE;
    scratch[k++] = (uint8_t)(seq & 0xFF);
    scratch[k++] = (uint8_t)(seq >> 8);
    scratch[k++] = n;
    for (uint8_t p = 0; p < n; p++) {
        uint32_t v = (uint32_t)counts[p];
        scratch[k++] = (uint8_t)(v & 0xFF);
        scratch[k++] = (uint8_t)((v >> 8) & 0xFF);
        scratch[k++] = (uint8_t)((v >> 16) & 0xFF);
        scratch[k++] = (uint8_t)((v >> 24) & 0xFF);
    }
    uint16_t crc = jp_crc16(scratch, k);
    scratch[k++] = (uint8_t)(crc >> 8);
    scratch[k++] = (uint8_t)(crc & 0xFF);
    out[0] = 0x00;
    size_t m = jp_cobs_encode(scratch, k, out + 1);
    out[1 + m] = 0x00;
    return m + 2;
}

#endif /* JOSTLE_PADS_PROTOCOL_H */
