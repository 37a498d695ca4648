/* mckibben serial protocol, version 3 (docs/protocol.md): COBS frames with CRC-16/CCITT-FALSE.
 * Portable C99: built for the ATmega2560 and, in the tests, for the host. */
#ifndef MCK_PROTOCOL_H
#define MCK_PROTOCOL_H

#include <stddef.h>
#include <stdint.h>

#define MCK_PROTOCOL_VERSION 3u
#define MCK_PROTOCOL_VERSION_MIN 2u /* commands of version 2 hosts are read too (the same bodies) */
#define MCK_MAX_CHANNELS_WIRE 3u /* channels a TELEMETRY frame can carry */
#define MCK_MAX_FRAME 64u  /* largest decoded frame (version..crc) */
#define MCK_MAX_PACKET (MCK_MAX_FRAME + MCK_MAX_FRAME / 254u + 2u) /* COBS + delimiter */

enum mck_type {
    MCK_TELEMETRY = 0x01,
    MCK_ACK = 0x02,
    MCK_HELLO = 0x03,
    MCK_SET_POINT = 0x10,
    MCK_SET_GAIN = 0x11,
    MCK_SET_MODE = 0x12,
    MCK_SET_MAX_PRESSURE = 0x13,
    MCK_VENT = 0x14,
    MCK_STREAM = 0x15,
    MCK_SET_OPEN_LOOP = 0x16,
    MCK_SET_POINTS = 0x17,
    MCK_GET_GAIN = 0x18,
};
#define MCK_ALL_CHANNELS 0xFFu /* channel byte of SET_MODE and VENT: every channel */

/* One channel's part of a TELEMETRY frame (14 bytes on the wire). */
typedef struct {
    uint16_t pressure_adc;
    uint8_t inlet_pwm;
    uint8_t bleed_pwm;
    uint8_t mode;
    uint8_t faults;
    int32_t reference_pa;
    int32_t surface_pa;
} mck_channel_telemetry_t;

typedef struct {
    uint32_t t_us;
    int32_t encoder;
    uint8_t n;          /* channels 1..MCK_MAX_CHANNELS_WIRE */
    mck_channel_telemetry_t ch[MCK_MAX_CHANNELS_WIRE];
    uint16_t force_adc; /* the load cell's ADC count (sent by mck_encode_telemetry_force) */
} mck_telemetry_t;

/* CRC-16/CCITT-FALSE over len bytes. */
uint16_t mck_crc16(const uint8_t *data, size_t len);

/* Encode one frame (version, type, seq, body, crc) as a COBS packet ending in 0x00.
 * Returns the number of bytes written to out, or 0 if cap is too small or body too long. */
size_t mck_encode_frame(uint8_t type, uint16_t seq, const uint8_t *body, size_t body_len,
                        uint8_t *out, size_t cap);

/* Encode a telemetry frame: body 9 + 14 n bytes (n = 3: 51; 59 bytes on the wire). */
size_t mck_encode_telemetry(const mck_telemetry_t *t, uint16_t seq, uint8_t *out, size_t cap);

/* The same with the load cell's count t->force_adc after the channels (2 more bytes; version 3,
 * a device with a load cell). */
size_t mck_encode_telemetry_force(const mck_telemetry_t *t, uint16_t seq, uint8_t *out, size_t cap);

/* Encode an acknowledgement for the command (cmd_seq, cmd_type) with a status code and a value
 * (GET_GAIN: the gain; otherwise 0). */
size_t mck_encode_ack(uint16_t seq, uint16_t cmd_seq, uint8_t cmd_type, uint8_t status, int32_t value,
                      uint8_t *out, size_t cap);

/* Encode the HELLO frame the firmware sends once it runs: its channels, control period, baud
 * rate, number of gains and its load cell's full scale in mN (0: no load cell). */
size_t mck_encode_hello(uint16_t seq, uint8_t n_channels, uint16_t ts_us, uint32_t baud, uint8_t n_gains,
                        uint32_t load_cell_mn, uint8_t *out, size_t cap);

/* Incremental receiver: feed bytes one at a time. */
typedef struct {
    uint8_t buf[MCK_MAX_PACKET];
    uint8_t len;
    uint8_t overflow;
    /* the last complete, valid frame: */
    uint8_t type;
    uint16_t seq;
    uint8_t body[MCK_MAX_FRAME];
    uint8_t body_len;
    /* counters */
    uint16_t frames;
    uint16_t corrupt;
} mck_rx_t;

void mck_rx_init(mck_rx_t *rx);

/* Returns 1 when byte completes a valid frame (then type/seq/body are set), else 0. */
int mck_rx_feed(mck_rx_t *rx, uint8_t byte);

#endif
