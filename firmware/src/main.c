/* mckibben firmware for the Arduino Mega 2560 (ATmega2560, 16 MHz), plain avr-libc: N pressure
 * channels (N = MCK_N_CHANNELS, 1..3, compile-time; default 3, the endoscope's three muscles).
 *
 * Pins (Arduino names; docs/firmware.md, "Pin map"):
 *   A0, A1, A2    pressure transducers of channels 0, 1, 2 (0-5 V = 0-1 MPa, 10-bit ADC, AVcc)
 *   D6, D7        channel 0 inlet, bleed  (OC4A, OC4B)
 *   D8, D46       channel 1 inlet, bleed  (OC4C, OC5A)
 *   D45, D44      channel 2 inlet, bleed  (OC5B, OC5C)
 *                 Timers 4 and 5: 8-bit fast PWM at 7.8 kHz into the LM358 current drivers
 *   D2, D3        encoder channels A, B (INT4, INT5, any edge: 4x quadrature decoding)
 *   D0, D1        USART0 to the host, 1,000,000 baud 8N1 (docs/protocol.md)
 *   A3            load cell (optional, MCK_LOAD_CELL_MN > 0): INA125 amplifier, 0-5 V = 0..full scale
 *
 * Timing: Timer1 in CTC mode ticks at 1 kHz. Its compare match B, 400 us before each tick,
 * starts the conversion of A0; the ADC interrupt stores each result and starts the next
 * channel's (3 x 104 us), so at the tick all samples are fresh; a conversion that has not
 * completed counts as a missing sample for that channel's supervisor. The tick interrupt runs
 * mck_bank_run (all channels' supervisors and laws and the shared supply check, <= 4,000 cycles,
 * measured in simavr: make cycles) and writes the six PWM compare registers. The main loop
 * handles commands and streams telemetry; it never blocks the control interrupt for longer than
 * one channel's struct copy. With a load cell, the tick starts ADC3's conversion once it has
 * run (done 104 us later, long before compare B); the next tick streams that count. The
 * watchdog (60 ms) is fed by the control interrupt only: if control stops, the MCU resets and
 * the valve pins return to inputs (valves off). After every reset the firmware sends a HELLO
 * frame before anything else. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <util/atomic.h>

#include "controller.h"
#include "protocol.h"

#ifndef MCK_N_CHANNELS
#define MCK_N_CHANNELS 3
#endif
#if MCK_N_CHANNELS < 1 || MCK_N_CHANNELS > 3
#error "MCK_N_CHANNELS must be 1, 2 or 3"
#endif

#define TS_US 1000u
#define BAUD 1000000UL
#define UBRR_VALUE 1u         /* 16 MHz / (8 (UBRR + 1)) with U2X = 1 Mbaud exactly */
#define TIMER1_TOP 1999u      /* 16 MHz / 8 / 2000 = 1 kHz */
#define ADC_LEAD_COUNTS 800u  /* start the conversions 400 us before the tick */

/* --- the load cell (docs/firmware.md, "Load cell") ------------------------------------------ */
#ifndef MCK_LOAD_CELL_MN
#define MCK_LOAD_CELL_MN 0UL /* full scale of the load cell on ADC3 [mN]; 0: none fitted */
#endif
#define MCK_LOAD_CELL_ADC 3u
#define ADC_FORCE_SLOT 0x80u /* adc_next while ADC3 converts */

/* --- state shared with the interrupts ----------------------------------------------------- */
static volatile int32_t p_ref_pa[MCK_N_CHANNELS];
static volatile int32_t encoder;
static volatile uint16_t tick;
static volatile uint32_t t_us;
static volatile mck_telemetry_t latest;
static volatile uint16_t adc_val[MCK_N_CHANNELS];
static volatile uint8_t adc_ok, adc_next;
#if MCK_LOAD_CELL_MN > 0
static volatile uint16_t force_val; /* the last completed ADC3 count */
#endif
static uint8_t enc_prev;

/* --- USART0 with interrupt-driven ring buffers ------------------------------------------ */
#define RX_SIZE 256u /* a host's burst (a USB frame's worth of commands) waits here: 2.5 ms of line */
#define TX_SIZE 256u
static volatile uint8_t rx_buf[RX_SIZE];
static volatile uint8_t rx_head, rx_tail;
static volatile uint8_t tx_buf[TX_SIZE];
static volatile uint8_t tx_head, tx_tail;

ISR(USART0_RX_vect)
{
    uint8_t b = UDR0;
    uint8_t next = (uint8_t)((rx_head + 1u) % RX_SIZE);
    if (next != rx_tail) {
        rx_buf[rx_head] = b;
        rx_head = next;
    } /* else: overrun, the byte is lost and the frame's CRC will fail */
}

ISR(USART0_UDRE_vect)
{
    if (tx_head == tx_tail) {
        UCSR0B &= (uint8_t)~(1 << UDRIE0);
        return;
    }
    UDR0 = tx_buf[tx_tail];
    tx_tail = (uint8_t)(tx_tail + 1u); /* TX_SIZE is 256: wraps by itself */
}

/* Queue a whole packet or nothing. */
static uint8_t uart_send(const uint8_t *p, size_t n)
{
    uint8_t used, i, head = tx_head; /* only this loop writes tx_head: a register copy */
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { used = (uint8_t)(head - tx_tail); }
    if (n > (size_t)(TX_SIZE - 1u - used)) return 0;
    for (i = 0; i < n; i++) tx_buf[head++] = p[i]; /* wraps at 256 by itself */
    tx_head = head;
    UCSR0B |= (uint8_t)(1 << UDRIE0);
    return 1;
}

static int uart_recv(void)
{
    uint8_t b;
    if (rx_head == rx_tail) return -1;
    b = rx_buf[rx_tail];
    rx_tail = (uint8_t)((rx_tail + 1u) % RX_SIZE);
    return b;
}

/* --- encoder ----------------------------------------------------------------------------- */
static const int8_t quad_step[16] = {0, -1, 1, 0, 1, 0, 0, -1, -1, 0, 0, 1, 0, 1, -1, 0};

static void encoder_update(void)
{
    uint8_t cur = (uint8_t)((PINE >> PE4) & 0x03u); /* A = PE4 (D2), B = PE5 (D3) */
    encoder += quad_step[(enc_prev << 2) | cur];
    enc_prev = cur;
}
ISR(INT4_vect) { encoder_update(); }
ISR(INT5_vect) { encoder_update(); }

/* --- ADC: the channels converted one after the other, in the background ------------------- */
ISR(TIMER1_COMPB_vect)
{
    adc_next = 0;
    ADMUX = (uint8_t)(1 << REFS0); /* A0 */
    ADCSRA |= (uint8_t)(1 << ADSC);
}

ISR(ADC_vect)
{
    uint8_t i = adc_next;
    if (i < MCK_N_CHANNELS) {
        adc_val[i] = ADC;
        adc_ok |= (uint8_t)(1u << i);
        adc_next = ++i;
        if (i < MCK_N_CHANNELS) {
            ADMUX = (uint8_t)((1 << REFS0) | i); /* A1, A2 */
            ADCSRA |= (uint8_t)(1 << ADSC);
        }
    }
#if MCK_LOAD_CELL_MN > 0
    else if (i == ADC_FORCE_SLOT) {
        force_val = ADC;
        adc_next = ADC_FORCE_SLOT + 1u;
    }
#endif
}

/* --- valves ------------------------------------------------------------------------------ */
/* A count of 0 disconnects the output (fast PWM would still emit a 1/256 spike). */
#define PWM_OUT(ocr, tccr, com, value)                         \
    do {                                                       \
        if (value) {                                           \
            ocr = (value);                                     \
            tccr |= (uint8_t)(1 << (com));                     \
        } else {                                               \
            tccr &= (uint8_t)~(1 << (com));                    \
        }                                                      \
    } while (0)

static void set_valves(const mck_out_t *o)
{
    PWM_OUT(OCR4A, TCCR4A, COM4A1, o[0].inlet);
    PWM_OUT(OCR4B, TCCR4A, COM4B1, o[0].bleed);
#if MCK_N_CHANNELS > 1
    PWM_OUT(OCR4C, TCCR4A, COM4C1, o[1].inlet);
    PWM_OUT(OCR5A, TCCR5A, COM5A1, o[1].bleed);
#endif
#if MCK_N_CHANNELS > 2
    PWM_OUT(OCR5B, TCCR5A, COM5B1, o[2].inlet);
    PWM_OUT(OCR5C, TCCR5A, COM5C1, o[2].bleed);
#endif
}

/* --- the control interrupt ---------------------------------------------------------------- */
ISR(TIMER1_COMPA_vect)
{
    uint16_t adc[MCK_N_CHANNELS];
    int32_t ref[MCK_N_CHANNELS];
    mck_out_t out[MCK_N_CHANNELS];
    uint8_t ok, i;

    for (i = 0; i < MCK_N_CHANNELS; i++) {
        adc[i] = adc_val[i];
        ref[i] = p_ref_pa[i];
    }
    ok = adc_ok; /* the conversions started 400 us ago that have completed */
    adc_ok = 0;
    mck_bank_run(MCK_N_CHANNELS, adc, ok, ref, out);
    set_valves(out);
    wdt_reset();
#if MCK_LOAD_CELL_MN > 0
    latest.force_adc = force_val; /* converted after the last tick */
    if (!(ADCSRA & (1 << ADSC))) { /* a pressure conversion still running (a missing sample) keeps the ADC */
        adc_next = ADC_FORCE_SLOT;
        ADMUX = (uint8_t)((1 << REFS0) | MCK_LOAD_CELL_ADC);
        ADCSRA |= (uint8_t)(1 << ADSC);
    }
#endif

    t_us += TS_US;
    latest.t_us = t_us;
    latest.encoder = encoder; /* this ISR is not interruptible: consistent read */
    for (i = 0; i < MCK_N_CHANNELS; i++) {
        latest.ch[i].pressure_adc = (ok >> i) & 1u ? adc[i] : 0u;
        latest.ch[i].inlet_pwm = out[i].inlet;
        latest.ch[i].bleed_pwm = out[i].bleed;
        latest.ch[i].mode = mck_bank[i].s.mode;
        latest.ch[i].faults = out[i].faults;
        latest.ch[i].reference_pa = out[i].reference;
        latest.ch[i].surface_pa = out[i].surface;
    }
    tick++;
}

/* --- commands ------------------------------------------------------------------------------ */
static uint16_t tx_seq;
static uint8_t stream_on;
static uint8_t decimation = 1;
static uint16_t last_tick; /* the tick of the last telemetry frame (or of the STREAM command) */
static mck_ctrl_t shadow; /* gain changes are computed here, off the interrupt */

static int32_t get_i32(const uint8_t *b)
{
    return (int32_t)((uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
                     (uint32_t)b[3] << 24);
}

static void send_ack(uint16_t cmd_seq, uint8_t cmd_type, uint8_t status, int32_t value)
{
    uint8_t pkt[MCK_MAX_PACKET];
    size_t n = mck_encode_ack(tx_seq++, cmd_seq, cmd_type, status, value, pkt, sizeof pkt);
    if (n) (void)uart_send(pkt, n);
}

static uint8_t set_gain(uint8_t ch, uint8_t id, int32_t value)
{
    uint8_t status;
    /* mck_ctrl_set_gain takes ~15,000 cycles (64-bit divisions): run it on a copy with
     * interrupts on, then swap in the coefficients and gains, which follow the state in
     * mck_ctrl_t, with interrupts off. */
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { memcpy(&shadow, &mck_bank[ch], sizeof shadow); }
    status = mck_ctrl_set_gain(&shadow, id, value);
    if (status == MCK_OK) {
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
        {
            memcpy(&mck_bank[ch].k, &shadow.k, sizeof shadow - offsetof(mck_ctrl_t, k));
        }
    }
    return status;
}

/* Channel byte check: a channel, or MCK_ALL_CHANNELS where allowed. */
#define BAD_CHANNEL(c, all_ok) ((c) >= MCK_N_CHANNELS && !((all_ok) && (c) == MCK_ALL_CHANNELS))

static void handle(const mck_rx_t *rx)
{
    const uint8_t *b = rx->body;
    uint8_t n = rx->body_len, status = MCK_OK, i;
    int32_t value = 0;
    switch (rx->type) {
    case MCK_SET_POINT:
        if (n != 5u) {
            status = 2;
        } else if (BAD_CHANNEL(b[0], 0)) {
            status = MCK_ERR_RANGE;
        } else {
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { p_ref_pa[b[0]] = get_i32(b + 1); }
        }
        break;
    case MCK_SET_POINTS:
        if (n != 4u * MCK_N_CHANNELS) {
            status = 2;
        } else {
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
            {
                for (i = 0; i < MCK_N_CHANNELS; i++) p_ref_pa[i] = get_i32(b + 4u * i);
            }
        }
        break;
    case MCK_SET_GAIN:
        if (n != 6u) {
            status = 2;
        } else if (BAD_CHANNEL(b[0], 0)) {
            status = MCK_ERR_RANGE;
        } else {
            status = set_gain(b[0], b[1], get_i32(b + 2));
        }
        break;
    case MCK_GET_GAIN:
        if (n != 2u) {
            status = 2;
        } else if (BAD_CHANNEL(b[0], 0)) {
            status = MCK_ERR_RANGE;
        } else if (b[1] >= MCK_N_GAINS) {
            status = MCK_ERR_GAIN_ID;
        } else {
            value = mck_bank[b[0]].gain[b[1]]; /* written by the main loop only */
        }
        break;
    case MCK_SET_MODE:
        if (n != 2u) {
            status = 2;
        } else if (BAD_CHANNEL(b[0], 1)) {
            status = MCK_ERR_RANGE;
        } else {
            for (i = 0; i < MCK_N_CHANNELS; i++)
                if (b[0] == i || b[0] == MCK_ALL_CHANNELS)
                    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { status |= mck_ctrl_set_mode(&mck_bank[i], b[1]); }
        }
        break;
    case MCK_SET_MAX_PRESSURE:
        if (n != 5u) {
            status = 2;
        } else if (BAD_CHANNEL(b[0], 1)) {
            status = MCK_ERR_RANGE;
        } else {
            for (i = 0; i < MCK_N_CHANNELS; i++)
                if (b[0] == i || b[0] == MCK_ALL_CHANNELS)
                    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
                    {
                        status |= mck_ctrl_set_max_pressure(&mck_bank[i], get_i32(b + 1));
                    }
        }
        break;
    case MCK_VENT:
        if (n != 1u) {
            status = 2;
        } else if (BAD_CHANNEL(b[0], 1)) {
            status = MCK_ERR_RANGE;
        } else {
            for (i = 0; i < MCK_N_CHANNELS; i++)
                if (b[0] == i || b[0] == MCK_ALL_CHANNELS)
                    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { mck_ctrl_vent(&mck_bank[i]); }
        }
        break;
    case MCK_STREAM:
        if (n != 2u) {
            status = 2;
        } else if (b[1] == 0u) {
            status = MCK_ERR_RANGE;
        } else {
            stream_on = b[0] != 0u;
            decimation = b[1];
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { last_tick = tick; } /* frames count from now */
        }
        break;
    case MCK_SET_OPEN_LOOP:
        if (n != 3u) {
            status = 2;
        } else if (BAD_CHANNEL(b[0], 0)) {
            status = MCK_ERR_RANGE;
        } else {
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { mck_ctrl_set_open_loop(&mck_bank[b[0]], b[1], b[2]); }
        }
        break;
    default:
        status = 1; /* unknown type */
        break;
    }
    send_ack(rx->seq, rx->type, status, value);
}

/* --- setup ---------------------------------------------------------------------------------- */
static void hw_init(void)
{
    /* USART0: 1,000,000 baud = 16 MHz / (8 (UBRR + 1)) with U2X, UBRR = 1 (0 % error). U2X first:
     * the Mega does not care about the order, but simavr latches the line rate when UBRR0 is
     * written, so UBRR0 before U2X0 ran the processor-in-the-loop bench at half the rate. */
    UCSR0A = (uint8_t)(1 << U2X0);
    UBRR0 = UBRR_VALUE;
    UCSR0C = (uint8_t)(1 << UCSZ01 | 1 << UCSZ00);
    UCSR0B = (uint8_t)(1 << RXEN0 | 1 << TXEN0 | 1 << RXCIE0);

    /* valves: Timer4 OC4A/B/C (PH3, PH4, PH5: D6, D7, D8), Timer5 OC5A/B/C (PL3, PL4, PL5:
     * D46, D45, D44); 8-bit fast PWM (WGM 5), prescaler 8: 7.8 kHz */
    PORTH &= (uint8_t)~(1 << PH3 | 1 << PH4 | 1 << PH5);
    DDRH |= (uint8_t)(1 << PH3 | 1 << PH4 | 1 << PH5);
    TCCR4A = (uint8_t)(1 << WGM40);
    TCCR4B = (uint8_t)(1 << WGM42 | 1 << CS41);
    PORTL &= (uint8_t)~(1 << PL3 | 1 << PL4 | 1 << PL5);
    DDRL |= (uint8_t)(1 << PL3 | 1 << PL4 | 1 << PL5);
    TCCR5A = (uint8_t)(1 << WGM50);
    TCCR5B = (uint8_t)(1 << WGM52 | 1 << CS51);

    /* encoder: D2/D3 inputs with pull-ups, INT4/INT5 on any edge */
    DDRE &= (uint8_t)~(1 << PE4 | 1 << PE5);
    PORTE |= (uint8_t)(1 << PE4 | 1 << PE5);
    enc_prev = (uint8_t)((PINE >> PE4) & 0x03u);
    EICRB = (uint8_t)(1 << ISC40 | 1 << ISC50);
    EIMSK = (uint8_t)(1 << INT4 | 1 << INT5);

    /* ADC0..2, AVcc reference, clock 125 kHz (104 us per conversion), interrupt on completion */
    ADMUX = (uint8_t)(1 << REFS0);
    DIDR0 = (uint8_t)((1 << MCK_N_CHANNELS) - 1);
#if MCK_LOAD_CELL_MN > 0
    DIDR0 |= (uint8_t)(1 << MCK_LOAD_CELL_ADC);
#endif
    ADCSRA = (uint8_t)(1 << ADEN | 1 << ADIE | 1 << ADPS2 | 1 << ADPS1 | 1 << ADPS0);

    /* Timer1: CTC at 1 kHz; compare B starts the conversions 400 us before the tick */
    TCCR1A = 0;
    TCCR1B = (uint8_t)(1 << WGM12 | 1 << CS11);
    OCR1A = TIMER1_TOP;
    OCR1B = TIMER1_TOP - ADC_LEAD_COUNTS;
    TIMSK1 = (uint8_t)(1 << OCIE1A | 1 << OCIE1B);
}

int main(void)
{
    static mck_rx_t rx;
    uint8_t i;

    for (i = 0; i < MCK_N_CHANNELS; i++) mck_ctrl_init(&mck_bank[i], TS_US); /* off, valves shut */
    latest.n = MCK_N_CHANNELS;
    mck_rx_init(&rx);
    hw_init();
    wdt_enable(WDTO_60MS);
    sei();
    {
        uint8_t pkt[MCK_MAX_PACKET];
        size_t n = mck_encode_hello(tx_seq++, MCK_N_CHANNELS, TS_US, BAUD, MCK_N_GAINS, MCK_LOAD_CELL_MN, pkt,
                                    sizeof pkt);
        if (n) (void)uart_send(pkt, n);
    }

    for (;;) {
        int c;
        uint16_t now;
        while ((c = uart_recv()) >= 0) {
            if (mck_rx_feed(&rx, (uint8_t)c)) {
                handle(&rx);
                break; /* one command, then the telemetry's turn: a burst must not starve it */
            }
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { now = tick; }
        if (stream_on && (uint16_t)(now - last_tick) >= decimation) {
            mck_telemetry_t t;
            uint8_t pkt[MCK_MAX_PACKET];
            size_t n;
            /* the tick read with the copy: a tick between the test above and the copy would
             * otherwise send its frame under the previous tick's seq, and again at the next */
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
            {
                memcpy(&t, (const void *)&latest, sizeof t);
                now = tick;
            }
            /* a frame per decimation period: the periods this loop came too late for (a command's
             * handling) spend their frames' seqs, as a full queue does, so the host sees the gap */
            tx_seq = (uint16_t)(tx_seq + (uint16_t)(now - last_tick) / decimation - 1u);
            last_tick = now;
            /* seq advances even when the queue is full, so the host sees the gap */
#if MCK_LOAD_CELL_MN > 0
            n = mck_encode_telemetry_force(&t, tx_seq++, pkt, sizeof pkt);
#else
            n = mck_encode_telemetry(&t, tx_seq++, pkt, sizeof pkt);
#endif
            if (n) (void)uart_send(pkt, n);
        }
    }
}
