/* Cycle count of one control step (mck_ctrl_step) on the ATmega2560, run in simavr:
 *   make -C firmware cycles
 * Timer1 runs at the CPU clock (prescaler 1) and is read around each step. The input sequence
 * (a 32-bit LCG, mode switches, gain changes) is reproduced in tests/test_firmware.py, which
 * also checks the checksum of the outputs against the Python mirror, so the image proves that
 * the AVR build computes what the host build and Python compute. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>
#include <stdio.h>

#include "controller.h"

#define N_STEPS 3000u

static int uart_put(char ch, FILE *f)
{
    (void)f;
    while (!(UCSR0A & (1 << UDRE0))) {
    }
    UDR0 = (uint8_t)ch;
    return 0;
}
static FILE uart_out = FDEV_SETUP_STREAM(uart_put, NULL, _FDEV_SETUP_WRITE);

static uint32_t lcg = 1u;
static uint16_t rnd(void)
{
    lcg = lcg * 1664525UL + 1013904223UL;
    return (uint16_t)(lcg >> 16);
}

/* mck_mulq16 (inline assembly on AVR) against the int64 definition floor(x c / 2^16). */
static uint16_t check_mulq16(uint16_t n)
{
    static const int32_t xs[6] = {0L, -1L, INT32_MIN, INT32_MAX, 65535L, -65536L};
    static const int32_t cs[5] = {0L, 1L, 65535L, 65536L, INT32_MAX};
    uint16_t bad = 0, i;
    uint8_t a, b;
    for (a = 0; a < 6; a++)
        for (b = 0; b < 5; b++)
            if (mck_mulq16(xs[a], cs[b]) != (int32_t)(((int64_t)xs[a] * cs[b]) >> 16)) bad++;
    for (i = 0; i < n; i++) {
        int32_t x = (int32_t)(((uint32_t)rnd() << 16) | rnd());
        int32_t c = (int32_t)((((uint32_t)rnd() << 16) | rnd()) >> (rnd() & 31u) >> 1);
        if (mck_mulq16(x, c) != (int32_t)(((int64_t)x * c) >> 16)) bad++;
    }
    return bad;
}

static const uint8_t phase_mode[6] = {1u, 2u, 1u, 2u, 3u, 0u};

static mck_ctrl_t ctrl;

int main(void)
{
    uint16_t k, t0, t1, overhead, cyc;
    uint16_t cmin[4] = {0xFFFFu, 0xFFFFu, 0xFFFFu, 0xFFFFu}, cmax[4] = {0, 0, 0, 0};
    uint32_t csum[4] = {0, 0, 0, 0}, hash = 0;
    uint16_t cnt[4] = {0, 0, 0, 0};
    int32_t pref = 0;
    mck_out_t o;
    uint8_t m;

    UBRR0 = 3; /* 500000 baud with U2X at 16 MHz */
    UCSR0A = (uint8_t)(1 << U2X0);
    UCSR0B = (uint8_t)(1 << TXEN0);
    UCSR0C = (uint8_t)(3 << UCSZ00);
    stdout = &uart_out;
    TCCR1A = 0;
    TCCR1B = (uint8_t)(1 << CS10); /* Timer1 at F_CPU */

    t0 = TCNT1;
    t1 = TCNT1;
    overhead = (uint16_t)(t1 - t0);

    printf("mulq16 check 2000 random + 30 edge cases, mismatches %u\n", check_mulq16(2000u));
    lcg = 1u;
    mck_ctrl_init(&ctrl, 1000u);
    mck_ctrl_set_open_loop(&ctrl, 200u, 30u);
    for (k = 0; k < N_STEPS; k++) {
        if (k % 500u == 0u) mck_ctrl_set_mode(&ctrl, phase_mode[k / 500u]);
        if (k == 1000u) {
            mck_ctrl_set_gain(&ctrl, MCK_GAIN_SMC_BETA, 150000L);
            mck_ctrl_set_gain(&ctrl, MCK_GAIN_SMC_EPS, 5000L);
            mck_ctrl_set_gain(&ctrl, MCK_GAIN_PID_KD, 20000000L);
        }
        uint16_t r1 = rnd(), r2 = rnd();
        uint16_t adc;
        if (k % 100u == 0u) pref = (int32_t)r1 * 15;
        if (r2 & 1u) {
            adc = (uint16_t)(100u + (r2 >> 6) % 800u);
        } else {
            int32_t a = (pref >> 10) + (int32_t)((r2 >> 8) & 31u) - 16;
            adc = a < 0 ? 0u : (uint16_t)a;
        }
        uint8_t ok = (r2 & 0x3Eu) != 0u;
        m = ctrl.mode;
        cli();
        t0 = TCNT1;
        mck_ctrl_step(&ctrl, adc, ok, pref, &o);
        t1 = TCNT1;
        sei();
        cyc = (uint16_t)(t1 - t0 - overhead);
        if (cyc < cmin[m]) cmin[m] = cyc;
        if (cyc > cmax[m]) cmax[m] = cyc;
        csum[m] += cyc;
        cnt[m]++;
        hash = hash * 31u + ((uint32_t)o.inlet | ((uint32_t)o.bleed << 8) | ((uint32_t)o.faults << 16));
        hash = hash * 31u + (uint32_t)o.surface;
        hash = hash * 31u + (uint32_t)o.reference;
    }
    printf("timer overhead %u cycles (subtracted)\n", overhead);
    for (m = 0; m < 4; m++) {
        printf("mode %u steps %u cycles min %u mean %lu max %u\n", m, cnt[m], cmin[m],
               (unsigned long)((csum[m] + cnt[m] / 2u) / cnt[m]), cmax[m]);
    }
    printf("checksum %lu\n", (unsigned long)hash);
    /* mck_ctrl_set_gain (main loop, not the interrupt): Timer1 at F_CPU/64 */
    TCCR1B = (uint8_t)(1 << CS11 | 1 << CS10);
    t0 = TCNT1;
    mck_ctrl_set_gain(&ctrl, MCK_GAIN_SMC_TAU, 100000L);
    t1 = TCNT1;
    printf("set_gain about %lu cycles\n", (unsigned long)(uint16_t)(t1 - t0) * 64UL);
    printf("done\n");
    cli();
    sleep_enable();
    sleep_cpu();
    for (;;) {
    }
}
