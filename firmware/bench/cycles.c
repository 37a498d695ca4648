/* Cycle count of one control step on the ATmega2560, run in simavr:
 *   make -C firmware cycles
 * First one channel (mck_ctrl_step), then a bank of three channels with different gains
 * (mck_bank_step, what the firmware's interrupt runs). Timer1 runs at the CPU clock (prescaler
 * 1) and is read around each step. The input sequences (a 32-bit LCG, mode switches, gain
 * changes) are reproduced in tests/test_firmware.py, which also checks the checksums of the
 * outputs against the Python mirror, so the image proves that the AVR build computes what the
 * host build and Python compute. */
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
static uint16_t overhead_cycles;
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
    for (a = 0; a < 6; a++)
        for (b = 0; b < 5; b++) {
            int32_t x = xs[a] >> 8; /* in [-2^23, 2^23) */
            if (mck_mulq16s24(x, cs[b]) != (int32_t)(((int64_t)x * cs[b]) >> 16)) bad++;
        }
    for (i = 0; i < n; i++) {
        int32_t x = (int32_t)(((uint32_t)rnd() << 16) | rnd());
        int32_t c = (int32_t)((((uint32_t)rnd() << 16) | rnd()) >> (rnd() & 31u) >> 1);
        if (mck_mulq16s24(x >> 8, c) != (int32_t)(((int64_t)(x >> 8) * c) >> 16)) bad++;
        if (mck_mulq16(x, c) != (int32_t)(((int64_t)x * c) >> 16)) bad++;
    }
    return bad;
}

static const uint8_t phase_mode[6] = {1u, 2u, 1u, 2u, 3u, 0u};

static mck_ctrl_t ctrl;
#define bank mck_bank

static uint32_t mix(uint32_t hash, const mck_out_t *o)
{
    hash = hash * 31u + ((uint32_t)o->inlet | ((uint32_t)o->bleed << 8) | ((uint32_t)o->faults << 16));
    hash = hash * 31u + (uint32_t)o->surface;
    return hash * 31u + (uint32_t)o->reference;
}

/* Three channels, each with its own gains, in the modes of phase_mode (all channels at once:
 * the worst case is all three in the same law). */
static void run_bank(void)
{
    uint16_t k, t0, t1, cyc, cmin = 0xFFFFu, cmax = 0;
    uint32_t csum = 0, hash = 0;
    uint16_t adc[3];
    int32_t pref[3] = {0, 0, 0};
    mck_out_t o[3];
    uint8_t i, ok;
    for (i = 0; i < 3u; i++) {
        mck_ctrl_init(&bank[i], 1000u);
        mck_ctrl_set_open_loop(&bank[i], (uint8_t)(200u - 40u * i), (uint8_t)(30u + 10u * i));
    }
    mck_ctrl_set_gain(&bank[1], MCK_GAIN_SMC_BETA, 150000L);
    mck_ctrl_set_gain(&bank[1], MCK_GAIN_SMC_EPS, 5000L);
    mck_ctrl_set_gain(&bank[1], MCK_GAIN_PID_KD, 20000000L);
    mck_ctrl_set_gain(&bank[2], MCK_GAIN_SMC_G, 62000000L);
    mck_ctrl_set_gain(&bank[2], MCK_GAIN_SMC_U0, 109000L);
    mck_ctrl_set_gain(&bank[2], MCK_GAIN_SUP_G, 62000000L);
    mck_ctrl_set_gain(&bank[2], MCK_GAIN_SUP_U0, 109000L);
    mck_ctrl_set_gain(&bank[2], MCK_GAIN_N_STUCK, 20L);
    for (k = 0; k < N_STEPS; k++) {
        if (k % 500u == 0u)
            for (i = 0; i < 3u; i++) mck_ctrl_set_mode(&bank[i], phase_mode[k / 500u]);
        ok = 0;
        for (i = 0; i < 3u; i++) {
            uint16_t r1 = rnd(), r2 = rnd();
            if (k % 100u == 0u) pref[i] = (int32_t)r1 * 15;
            if ((r2 & 1u) && i != 2u) {
                adc[i] = (uint16_t)(100u + (r2 >> 6) % 800u);
            } else {
                int32_t a = (pref[i] >> 10) + (int32_t)((r2 >> 8) & 31u) - 16;
                adc[i] = a < 0 ? 0u : (uint16_t)a;
            }
            if (i == 2u && (k / 50u) % 4u == 3u) adc[i] = 200u; /* a frozen reading */
            if ((r2 & 0x3Eu) != 0u) ok |= (uint8_t)(1u << i);
        }
        cli();
        t0 = TCNT1;
        mck_bank_run(3u, adc, ok, pref, o);
        t1 = TCNT1;
        sei();
        cyc = (uint16_t)(t1 - t0 - overhead_cycles);
        if (cyc < cmin) cmin = cyc;
        if (cyc > cmax) cmax = cyc;
        csum += cyc;
        for (i = 0; i < 3u; i++) hash = mix(hash, &o[i]);
    }
    printf("bank 3 channels steps %u cycles min %u mean %lu max %u\n", N_STEPS, cmin,
           (unsigned long)((csum + N_STEPS / 2u) / N_STEPS), cmax);
    printf("bank checksum %lu\n", (unsigned long)hash);
}

/* Every law (sliding mode, PID and the extension laws of core/laws.h: every mode but OFF and
 * OPEN_LOOP): the bank of three channels of
 * run_bank, all in that mode for the whole run (each channel with its gains' defaults, the LCG
 * restarted at 1), so that a controller added to the registry is measured and checked without a change
 * here; tests/test_firmware.py computes each checksum with the Python mirror. */
static void run_bank_modes(void)
{
    uint16_t k, t0, t1, cyc, cmin, cmax;
    uint32_t csum, hash;
    uint16_t adc[3];
    int32_t pref[3];
    mck_out_t o[3];
    uint8_t i, ok, m;
    for (m = MCK_MODE_OFF + 1u; m < MCK_N_MODES; m++) {
        if (m == MCK_MODE_OPEN_LOOP) continue;
        lcg = 1u;
        cmin = 0xFFFFu;
        cmax = 0;
        csum = 0;
        hash = 0;
        for (i = 0; i < 3u; i++) {
            mck_ctrl_init(&bank[i], 1000u);
            mck_ctrl_set_mode(&bank[i], m);
            pref[i] = 0;
        }
        mck_ctrl_set_gain(&bank[2], MCK_GAIN_N_STUCK, 20L);
        for (k = 0; k < N_STEPS; k++) {
            ok = 0;
            for (i = 0; i < 3u; i++) {
                uint16_t r1 = rnd(), r2 = rnd();
                if (k % 100u == 0u) pref[i] = (int32_t)r1 * 15;
                if ((r2 & 1u) && i != 2u) {
                    adc[i] = (uint16_t)(100u + (r2 >> 6) % 800u);
                } else {
                    int32_t a = (pref[i] >> 10) + (int32_t)((r2 >> 8) & 31u) - 16;
                    adc[i] = a < 0 ? 0u : (uint16_t)a;
                }
                if (i == 2u && (k / 50u) % 4u == 3u) adc[i] = 200u; /* a frozen reading */
                if ((r2 & 0x3Eu) != 0u) ok |= (uint8_t)(1u << i);
            }
            if (k % 500u == 250u)
                for (i = 0; i < 3u; i++) mck_ctrl_set_mode(&bank[i], m); /* clears latched faults */
            cli();
            t0 = TCNT1;
            mck_bank_run(3u, adc, ok, pref, o);
            t1 = TCNT1;
            sei();
            cyc = (uint16_t)(t1 - t0 - overhead_cycles);
            if (cyc < cmin) cmin = cyc;
            if (cyc > cmax) cmax = cyc;
            csum += cyc;
            for (i = 0; i < 3u; i++) hash = mix(hash, &o[i]);
        }
        printf("bank in mode %u: %u steps, cycles min %u mean %lu max %u\n", m, N_STEPS, cmin,
               (unsigned long)((csum + N_STEPS / 2u) / N_STEPS), cmax);
        printf("bank in mode %u: checksum %lu\n", m, (unsigned long)hash);
    }
}

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
    overhead_cycles = overhead;

    printf("mulq16 check 2000 random + 30 edge cases (and the 24-bit variant), mismatches %u\n", check_mulq16(2000u));
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
        m = ctrl.s.mode;
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
        hash = mix(hash, &o);
    }
    printf("timer overhead %u cycles (subtracted)\n", overhead);
    for (m = 0; m < 4; m++) {
        printf("mode %u steps %u cycles min %u mean %lu max %u\n", m, cnt[m], cmin[m],
               (unsigned long)((csum[m] + cnt[m] / 2u) / cnt[m]), cmax[m]);
    }
    printf("checksum %lu\n", (unsigned long)hash);
    run_bank();
    run_bank_modes();
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
