/* mckibben serial protocol, version 3 (docs/protocol.md): COBS frames with CRC-16/CCITT-FALSE.
 * Portable C99, no allocation; builds for the ATmega2560 and for the host tests. */
#include "protocol.h"

#include <string.h>
#ifdef __AVR__
#include <util/crc16.h>
#endif

uint16_t mck_crc16(const uint8_t *data, size_t len)
{
    /* byte-wise, no table: the bit loop's eight shifts folded into one (x: the byte's top nibble
     * reduced); the same CRC, about 6x fewer AVR cycles. Measured in the processor-in-the-loop
     * bench: with the bit loop, three-channel telemetry at 1 kHz kept the main loop late for
     * about 7 % of the periods. */
    uint16_t crc = 0xFFFFu;
#ifdef __AVR__
    /* on the Mega, avr-libc's hand-written step of the same CRC (poly 0x1021, unreflected): ~20
     * cycles a byte against ~50 for the C below, which avr-gcc compiles with 16-bit shifts.
     * Measured in the processor-in-the-loop bench (benchmarks/bench_pil.py, profile): the C step
     * took 18 % of the CPU under three-channel telemetry at 1 kHz. */
    for (size_t i = 0; i < len; i++) crc = _crc_xmodem_update(crc, data[i]);
    return crc;
#endif
    for (size_t i = 0; i < len; i++) {
        uint8_t x = (uint8_t)((crc >> 8) ^ data[i]);
        x ^= (uint8_t)(x >> 4);
        crc = (uint16_t)((crc << 8) ^ ((uint16_t)x << 12) ^ ((uint16_t)x << 5) ^ x);
    }
    return crc;
}

/* COBS-encode n bytes of src into dst (no delimiter); returns the encoded length. */
static size_t cobs_encode(const uint8_t *src, size_t n, uint8_t *dst)
{
    size_t code_at = 0, out = 1;
    uint8_t code = 1;
    for (size_t i = 0; i < n; i++) {
        if (src[i] == 0u) {
            dst[code_at] = code;
            code_at = out++;
            code = 1;
        } else {
            dst[out++] = src[i];
            if (++code == 0xFFu) {
                dst[code_at] = code;
                code_at = out++;
                code = 1;
            }
        }
    }
    dst[code_at] = code;
    return out;
}

/* COBS-decode n bytes; returns the decoded length, or 0 on a malformed packet. */
static size_t cobs_decode(const uint8_t *src, size_t n, uint8_t *dst, size_t cap)
{
    size_t i = 0, out = 0;
    while (i < n) {
        uint8_t code = src[i++];
        if (code == 0u || i + code - 1u > n) return 0;
        for (uint8_t k = 1; k < code; k++) {
            if (out >= cap) return 0;
            dst[out++] = src[i++];
        }
        if (code != 0xFFu && i < n) {
            if (out >= cap) return 0;
            dst[out++] = 0u;
        }
    }
    return out;
}

size_t mck_encode_frame(uint8_t type, uint16_t seq, const uint8_t *body, size_t body_len, uint8_t *out,
                        size_t cap)
{
    uint8_t raw[MCK_MAX_FRAME];
    if (body_len + 6u > MCK_MAX_FRAME) return 0;
    raw[0] = MCK_PROTOCOL_VERSION;
    raw[1] = type;
    raw[2] = (uint8_t)(seq & 0xFFu);
    raw[3] = (uint8_t)(seq >> 8);
    if (body_len) memcpy(raw + 4, body, body_len);
    uint16_t crc = mck_crc16(raw, body_len + 4u);
    raw[body_len + 4u] = (uint8_t)(crc & 0xFFu);
    raw[body_len + 5u] = (uint8_t)(crc >> 8);
    size_t n = body_len + 6u;
    if (cap < n + n / 254u + 2u) return 0;
    size_t m = cobs_encode(raw, n, out);
    out[m++] = 0u;
    return m;
}

static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

/* The TELEMETRY body of t's head and channels into b; returns its length (9 + 14 n), 0 for a bad n. */
static size_t telemetry_body(const mck_telemetry_t *t, uint8_t *b)
{
    uint8_t i, n = t->n;
    if (n < 1u || n > MCK_MAX_CHANNELS_WIRE) return 0;
    put_u32(b, t->t_us);
    put_u32(b + 4, (uint32_t)t->encoder);
    b[8] = n;
    for (i = 0; i < n; i++) {
        uint8_t *c = b + 9u + 14u * i;
        const mck_channel_telemetry_t *ch = &t->ch[i];
        put_u16(c, ch->pressure_adc);
        c[2] = ch->inlet_pwm;
        c[3] = ch->bleed_pwm;
        c[4] = ch->mode;
        c[5] = ch->faults;
        put_u32(c + 6, (uint32_t)ch->reference_pa);
        put_u32(c + 10, (uint32_t)ch->surface_pa);
    }
    return 9u + 14u * n;
}

size_t mck_encode_telemetry(const mck_telemetry_t *t, uint16_t seq, uint8_t *out, size_t cap)
{
    uint8_t b[9u + 14u * MCK_MAX_CHANNELS_WIRE]; /* docs/protocol.md, TELEMETRY body */
    size_t len = telemetry_body(t, b);
    return len ? mck_encode_frame(MCK_TELEMETRY, seq, b, len, out, cap) : 0;
}

size_t mck_encode_telemetry_force(const mck_telemetry_t *t, uint16_t seq, uint8_t *out, size_t cap)
{
    uint8_t b[9u + 14u * MCK_MAX_CHANNELS_WIRE + 2u]; /* and the load cell's count */
    size_t len = telemetry_body(t, b);
    if (!len) return 0;
    put_u16(b + len, t->force_adc);
    return mck_encode_frame(MCK_TELEMETRY, seq, b, len + 2u, out, cap);
}

size_t mck_encode_ack(uint16_t seq, uint16_t cmd_seq, uint8_t cmd_type, uint8_t status, int32_t value,
                      uint8_t *out, size_t cap)
{
    uint8_t b[8];
    put_u16(b, cmd_seq);
    b[2] = cmd_type;
    b[3] = status;
    put_u32(b + 4, (uint32_t)value);
    return mck_encode_frame(MCK_ACK, seq, b, sizeof b, out, cap);
}

size_t mck_encode_hello(uint16_t seq, uint8_t n_channels, uint16_t ts_us, uint32_t baud, uint8_t n_gains,
                        uint32_t load_cell_mn, uint8_t *out, size_t cap)
{
    uint8_t b[12];
    b[0] = n_channels;
    put_u16(b + 1, ts_us);
    put_u32(b + 3, baud);
    b[7] = n_gains;
    put_u32(b + 8, load_cell_mn);
    return mck_encode_frame(MCK_HELLO, seq, b, sizeof b, out, cap);
}

void mck_rx_init(mck_rx_t *rx)
{
    memset(rx, 0, sizeof *rx);
}

int mck_rx_feed(mck_rx_t *rx, uint8_t byte)
{
    if (byte != 0u) {
        if (rx->len < sizeof rx->buf) {
            rx->buf[rx->len++] = byte;
        } else {
            rx->overflow = 1;
        }
        return 0;
    }
    /* delimiter: decode what was gathered */
    uint8_t raw[MCK_MAX_FRAME];
    size_t len = rx->len, n;
    int bad = rx->overflow;
    rx->len = 0;
    rx->overflow = 0;
    if (len == 0u && !bad) return 0; /* idle delimiters */
    n = bad ? 0u : cobs_decode(rx->buf, len, raw, sizeof raw);
    if (n < 6u || raw[0] < MCK_PROTOCOL_VERSION_MIN || raw[0] > MCK_PROTOCOL_VERSION ||
        mck_crc16(raw, n - 2u) != (uint16_t)(raw[n - 2u] | ((uint16_t)raw[n - 1u] << 8))) {
        rx->corrupt++;
        return 0;
    }
    rx->type = raw[1];
    rx->seq = (uint16_t)(raw[2] | ((uint16_t)raw[3] << 8));
    rx->body_len = (uint8_t)(n - 6u);
    memcpy(rx->body, raw + 4, rx->body_len);
    rx->frames++;
    return 1;
}
