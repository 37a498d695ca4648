/* mckibben firmware for the Arduino Mega 2560 (ATmega2560, 16 MHz), plain avr-libc.
 *
 * Pins (Arduino names):
 *   A0            pressure transducer (0-5 V = 0-1 MPa, 10-bit ADC, AVcc reference)
 *   D2, D3        encoder channels A, B (INT4, INT5, any edge: 4x quadrature decoding)
 *   D6, D7        inlet and bleed valve PWM (OC4A, OC4B; 8-bit fast PWM at 7.8 kHz) into the
 *                 LM358 current drivers
 *   D0, D1        USART0 to the host, 500000 baud 8N1 (docs/protocol.md)
 *
 * Timing: Timer1 in CTC mode ticks at 1 kHz. Compare match B, 120 us before each tick,
 * auto-triggers the ADC conversion (104 us), so at the tick the sample is fresh; a conversion
 * that has not completed counts as a missing sample for the supervisor. The tick interrupt
 * reads the ADC and the encoder, runs mck_ctrl_step (<= 1,600 cycles, measured in simavr:
 * make cycles) and writes the two PWM compare registers. The main loop handles commands and
 * streams telemetry; it never blocks the control interrupt for longer than a struct copy.
 * The watchdog (60 ms) is fed by the control interrupt only: if control stops, the MCU resets
 * and the valve pins return to inputs (valves off). */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <util/atomic.h>

#include "controller.h"
#include "protocol.h"

#define TS_US 1000u
#define TIMER1_TOP 1999u     /* 16 MHz / 8 / 2000 = 1 kHz */
#define ADC_LEAD_COUNTS 240u /* start the conversion 120 us before the tick */

/* --- state shared with the control interrupt ------------------------------------------ */
static mck_ctrl_t ctrl;
static volatile int32_t p_ref_pa;
static volatile int32_t encoder;
static volatile uint16_t tick;
static volatile uint32_t t_us;
static volatile mck_telemetry_t latest;
static uint8_t enc_prev;

/* --- USART0 with interrupt-driven ring buffers ------------------------------------------ */
#define RX_SIZE 128u
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
    uint8_t used, i;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { used = (uint8_t)(tx_head - tx_tail); }
    if (n > (size_t)(TX_SIZE - 1u - used)) return 0;
    for (i = 0; i < n; i++) {
        tx_buf[tx_head] = p[i];
        tx_head = (uint8_t)(tx_head + 1u);
    }
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

/* --- valves ------------------------------------------------------------------------------ */
/* A count of 0 disconnects the output (fast PWM would still emit a 1/256 spike). */
static void set_valves(uint8_t inlet, uint8_t bleed)
{
    if (inlet) {
        OCR4A = inlet;
        TCCR4A |= (uint8_t)(1 << COM4A1);
    } else {
        TCCR4A &= (uint8_t)~(1 << COM4A1);
    }
    if (bleed) {
        OCR4B = bleed;
        TCCR4A |= (uint8_t)(1 << COM4B1);
    } else {
        TCCR4A &= (uint8_t)~(1 << COM4B1);
    }
}

/* --- the control interrupt ---------------------------------------------------------------- */
ISR(TIMER1_COMPA_vect)
{
    uint16_t adc = 0;
    uint8_t ok = 0;
    int32_t enc;
    mck_out_t out;

    if (ADCSRA & (1 << ADIF)) { /* the conversion triggered 120 us ago has completed */
        adc = ADC;
        ok = 1;
        ADCSRA |= (uint8_t)(1 << ADIF); /* clear */
    }
    TIFR1 = (uint8_t)(1 << OCF1B); /* re-arm the ADC auto trigger */
    enc = encoder;                 /* this ISR is not interruptible: consistent read */
    mck_ctrl_step(&ctrl, adc, ok, p_ref_pa, &out);
    set_valves(out.inlet, out.bleed);
    wdt_reset();

    t_us += TS_US;
    latest.t_us = t_us;
    latest.pressure_adc = adc;
    latest.encoder = enc;
    latest.inlet_pwm = out.inlet;
    latest.bleed_pwm = out.bleed;
    latest.mode = ctrl.s.mode;
    latest.faults = out.faults;
    latest.reference_pa = out.reference;
    latest.surface_pa = out.surface;
    tick++;
}

/* --- commands ------------------------------------------------------------------------------ */
static uint16_t tx_seq;
static uint8_t stream_on;
static uint8_t decimation = 1;
static mck_ctrl_t shadow; /* gain changes are computed here, off the interrupt */

static int32_t get_i32(const uint8_t *b)
{
    return (int32_t)((uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
                     (uint32_t)b[3] << 24);
}

static void send_ack(uint16_t cmd_seq, uint8_t cmd_type, uint8_t status)
{
    uint8_t pkt[MCK_MAX_PACKET];
    size_t n = mck_encode_ack(tx_seq++, cmd_seq, cmd_type, status, pkt, sizeof pkt);
    if (n) (void)uart_send(pkt, n);
}

static uint8_t set_gain(uint8_t id, int32_t value)
{
    uint8_t status;
    /* mck_ctrl_set_gain takes ~15,000 cycles (64-bit divisions): run it on a copy with
     * interrupts on, then swap in the coefficients and gains, which follow the state in
     * mck_ctrl_t, with interrupts off. */
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { memcpy(&shadow, &ctrl, sizeof ctrl); }
    status = mck_ctrl_set_gain(&shadow, id, value);
    if (status == MCK_OK) {
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
        {
            memcpy(&ctrl.k, &shadow.k, sizeof ctrl - offsetof(mck_ctrl_t, k));
        }
    }
    return status;
}

static void handle(const mck_rx_t *rx)
{
    const uint8_t *b = rx->body;
    uint8_t n = rx->body_len, status = MCK_OK;
    switch (rx->type) {
    case MCK_SET_POINT:
        if (n != 4u) {
            status = 2;
            break;
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { p_ref_pa = get_i32(b); }
        break;
    case MCK_SET_GAIN:
        status = n != 5u ? 2u : set_gain(b[0], get_i32(b + 1));
        break;
    case MCK_SET_MODE:
        if (n != 1u) {
            status = 2;
            break;
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { status = mck_ctrl_set_mode(&ctrl, b[0]); }
        break;
    case MCK_SET_MAX_PRESSURE:
        if (n != 4u) {
            status = 2;
            break;
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { status = mck_ctrl_set_max_pressure(&ctrl, get_i32(b)); }
        break;
    case MCK_VENT:
        if (n != 0u) {
            status = 2;
            break;
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { mck_ctrl_vent(&ctrl); }
        break;
    case MCK_STREAM:
        if (n != 2u) {
            status = 2;
        } else if (b[1] == 0u) {
            status = MCK_ERR_RANGE;
        } else {
            stream_on = b[0] != 0u;
            decimation = b[1];
        }
        break;
    case MCK_SET_OPEN_LOOP:
        if (n != 2u) {
            status = 2;
            break;
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { mck_ctrl_set_open_loop(&ctrl, b[0], b[1]); }
        break;
    default:
        status = 1; /* unknown type */
        break;
    }
    send_ack(rx->seq, rx->type, status);
}

/* --- setup ---------------------------------------------------------------------------------- */
static void hw_init(void)
{
    /* USART0: 500000 baud = 16 MHz / (8 (UBRR + 1)) with U2X, UBRR = 3 (0 % error) */
    UBRR0 = 3;
    UCSR0A = (uint8_t)(1 << U2X0);
    UCSR0C = (uint8_t)(1 << UCSZ01 | 1 << UCSZ00);
    UCSR0B = (uint8_t)(1 << RXEN0 | 1 << TXEN0 | 1 << RXCIE0);

    /* valves: OC4A (PH3, D6), OC4B (PH4, D7); Timer4 8-bit fast PWM, prescaler 8 */
    PORTH &= (uint8_t)~(1 << PH3 | 1 << PH4);
    DDRH |= (uint8_t)(1 << PH3 | 1 << PH4);
    TCCR4A = (uint8_t)(1 << WGM40);
    TCCR4B = (uint8_t)(1 << WGM42 | 1 << CS41);

    /* encoder: D2/D3 inputs with pull-ups, INT4/INT5 on any edge */
    DDRE &= (uint8_t)~(1 << PE4 | 1 << PE5);
    PORTE |= (uint8_t)(1 << PE4 | 1 << PE5);
    enc_prev = (uint8_t)((PINE >> PE4) & 0x03u);
    EICRB = (uint8_t)(1 << ISC40 | 1 << ISC50);
    EIMSK = (uint8_t)(1 << INT4 | 1 << INT5);

    /* ADC0, AVcc reference, clock 125 kHz, auto trigger on Timer1 compare match B */
    ADMUX = (uint8_t)(1 << REFS0);
    ADCSRB = (uint8_t)(1 << ADTS2 | 1 << ADTS0);
    DIDR0 = (uint8_t)(1 << ADC0D);
    ADCSRA = (uint8_t)(1 << ADEN | 1 << ADATE | 1 << ADPS2 | 1 << ADPS1 | 1 << ADPS0);

    /* Timer1: CTC at 1 kHz; compare B starts the ADC 120 us before the tick */
    TCCR1A = 0;
    TCCR1B = (uint8_t)(1 << WGM12 | 1 << CS11);
    OCR1A = TIMER1_TOP;
    OCR1B = TIMER1_TOP - ADC_LEAD_COUNTS;
    TIMSK1 = (uint8_t)(1 << OCIE1A);
}

int main(void)
{
    static mck_rx_t rx;
    uint16_t last_tick = 0;

    mck_ctrl_init(&ctrl, TS_US); /* mode off, valves closed until SET_MODE */
    mck_rx_init(&rx);
    hw_init();
    wdt_enable(WDTO_60MS);
    sei();

    for (;;) {
        int c;
        uint16_t now;
        while ((c = uart_recv()) >= 0) {
            if (mck_rx_feed(&rx, (uint8_t)c)) handle(&rx);
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { now = tick; }
        if (stream_on && (uint16_t)(now - last_tick) >= decimation) {
            mck_telemetry_t t;
            uint8_t pkt[MCK_MAX_PACKET];
            size_t n;
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { memcpy(&t, (const void *)&latest, sizeof t); }
            last_tick = now;
            /* seq advances even when the queue is full, so the host sees the gap */
            n = mck_encode_telemetry(&t, tx_seq++, pkt, sizeof pkt);
            if (n) (void)uart_send(pkt, n);
        }
    }
}
