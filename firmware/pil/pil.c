/* pil.c: processor in the loop. The firmware image that `make -C firmware` builds (and `make upload`
 * flashes) runs in simavr at 16 MHz against the project's plant physics, one plant per channel, and
 * talks to the host over a pseudo-terminal as a Mega does over /dev/ttyACM0.
 *
 * The plant is export/c/mk_plant.c (the C port the FMU compiles; mckibben.plant.physics is its
 * source of truth): this file links it, it does not copy it. Each channel's parameters (the packed
 * fields of mckibben.plant.params, the force law's index and theta, as the FMU packs them) are read
 * from a text file written by mckibben.rig.engines.avr.
 *
 * Every 0.1 ms of simulated time (1,600 CPU cycles, one RK4 substep of the plant):
 *   - the valve commands are read from the firmware's PWM compare outputs: a channel's inlet/bleed
 *     count is its OCRnx while the output pin is an output and its compare output is connected
 *     (COMnx1), else 0 (a pin left an input after a reset: the LM358 driver sees nothing, valve shut);
 *   - each plant advances 0.1 ms with those commands (mk_set_commands, mk_advance);
 *   - ADC0..2 get each channel's pressure through the sensor model (0-5 V = 0-1 MPa: the count of
 *     mckibben.hardware.adc_count with the plant's pa_per_count and adc_zero, as the millivolts that
 *     simavr's 10-bit conversion, count = mV * 1023 / AVcc, turns into that count);
 *   - with --load-cell FS, ADC3 gets channel 0's muscle tension (mk_outputs' force) through the load
 *     cell model (mckibben.hardware.LoadCell: force + offset + a Gaussian noise sample, the sensor
 *     model's count with FS/1023 N per count and zero 0, clipped: the rail at 0 below zero force);
 *   - the encoder pins D2/D3 (PE4/PE5) take one quadrature edge toward channel 0's length in counts
 *     (mckibben.hardware.encoder_count), so the firmware's INT4/INT5 decoding sees every edge;
 *   - the CPU runs 1,600 cycles.
 * USART0 is bridged to the pty's master. A process opening the port after nobody had it open resets
 * the MCU (DTR); for --boot-time the bootloader holds (valves off, input swallowed), then the
 * firmware runs and sends its HELLO. Bytes the host does not read pile up in a 4 KB buffer (the USB
 * bridge's); beyond it whole packets are dropped, so the host sees a gap in the sequence numbers.
 * Simulated time follows wall time (--unthrottled: as fast as it goes).
 *
 * usage: pil ELF PARAMS [--boot-time S] [--duration S] [--unthrottled] [--avcc MV] [--stall-at S]
 * --stall-at S: at simulated time S, mask Timer1's interrupts (a control tick that stalls), to
 * show the watchdog path: the MCU resets, the valve pins go back to inputs, HELLO follows.
 * --hold-adc C: channel 0's ADC reads count C whatever the pressure (a stuck sensor).
 * --load-cell FS [--load-cell-offset N] [--load-cell-noise N] [--load-cell-seed S]: a load cell of
 * full scale FS [N] on ADC3, its zero offset and noise standard deviation [N], the noise's seed.
 * --bench-dir D: serve the bench side channel (mckibben.rig.bench) on the Unix socket
 * D/<the pty's path, '/' as '_'>.sock: "load F" [N], "hold L" [m], "release", "state", one line each.
 * --adc-miss-at S [--adc-miss-n N]: from simulated time S, for N control periods (default 1), the
 * ADC's completion interrupt is masked (ADIE off): the conversions do not reach the firmware
 * before the tick, as a conversion that misses it.
 * --rings TXH,TXT,RXH,RXT[,RXSIZE]: data addresses of the firmware's ring indices (from the ELF's
 * symbols, mckibben.rig.engines.avr.ring_symbols): the counters report each ring's high-water mark.
 * --profile FILE: at the end, the CPU cycles spent at each program address ("0xADDR cycles" lines).
 * Measured always, from the CPU itself: each Timer1 compare-A interrupt's entry (the control tick;
 * its period's min and max in cycles) and the longest stretch with SREG's I bit clear (interrupts
 * masked: an ISR's whole run, or an ATOMIC block), counted from the first tick after a reset.
 * stdout: one JSON line {"port": ...} when ready, then one JSON line of counters every 0.2 s wall
 * and at the end. Exit 0; 2 with one line on stderr for bad input (a missing ELF, a bad PARAMS).
 */
#define _XOPEN_SOURCE 700
#define _DEFAULT_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <simavr/avr_adc.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_irq.h>

#include "mk_plant.h"

#define F_CPU 16000000u
#define CHUNK_S 1e-4                        /* one RK4 substep of the plant */
#define CHUNK_CYCLES (F_CPU / 10000u)       /* 1,600 */
#define MAX_CH 3
#define OUT_CAP 4096                        /* the USB bridge's buffer [bytes] */
#define IN_CAP 65536

/* ATmega2560 data addresses (avr-libc iomxx0_1.h) */
#define A_PINE 0x2C
#define A_MCUSR 0x54
#define A_TIMSK1 0x6F
#define A_TCCR4A 0xA0
#define A_OCR4A 0xA8
#define A_OCR4B 0xAA
#define A_OCR4C 0xAC
#define A_DDRH 0x101
#define A_DDRL 0x10A
#define A_TCCR5A 0x120
#define A_OCR5A 0x128
#define A_OCR5B 0x12A
#define A_OCR5C 0x12C

static avr_t *avr;
static mk_plant plant[MAX_CH];
static int n_ch;
static int hold_adc = -1; /* channel 0's stuck reading [count], -1: none */
static avr_irq_t *uart_in, *adc_in[MAX_CH], *enc_a, *enc_b, *adc_force;
static double lc_full_scale = 0.0, lc_offset = 0.0, lc_noise = 0.0; /* the load cell [N]; 0: none */
static uint64_t lc_rng = 0x9E3779B97F4A7C15ull;
static uint8_t out_buf[OUT_CAP];
static size_t out_len;
static int out_dropping;
static uint8_t in_buf[IN_CAP];
static size_t in_head, in_len;
static int xoff;
static int valves_now[MAX_CH][2]; /* the valve commands last read from the PWM outputs [counts] */
static double wdt_reset_at = -1.0; /* simulated time of the last watchdog reset [s] */
static long long dropped_packets, dropped_bytes, rx_bytes, tx_bytes, resets, wdt_resets;
static avr_cycle_count_t last_tx_cycle, min_tx_gap = (avr_cycle_count_t)-1; /* the line rate, as simavr runs it */
static int enc_pos, enc_zero;
static volatile sig_atomic_t stop_flag;
/* instruments read off the CPU (see the usage above) */
#define TICK_VECTOR_PC (17u * 4u) /* TIMER1_COMPA_vect: vector 17, 4 bytes a vector (jmp) */
#define A_ADCSRA 0x7A
#define ADIE_BIT 3
static avr_cycle_count_t tick_last, tick_min = (avr_cycle_count_t)-1, tick_max, masked_since, masked_max;
static long long ticks;
static int masked;
static uint16_t ring_addr[4]; /* tx_head, tx_tail, rx_head, rx_tail; 0: not watched */
static unsigned rx_size = 128, tx_hwm, rx_hwm;
static uint32_t *profile; /* cycles per word address */

static void on_signal(int sig)
{
    (void)sig;
    stop_flag = 1;
}

/* --- USART0 <-> pty ------------------------------------------------------------------------ */
static void uart_out_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    uint8_t b = (uint8_t)value;
    (void)irq;
    (void)param;
    tx_bytes++;
    if (avr->cycle > last_tx_cycle && avr->cycle - last_tx_cycle < min_tx_gap) min_tx_gap = avr->cycle - last_tx_cycle;
    last_tx_cycle = avr->cycle;
    if (out_dropping) { /* drop the rest of a packet that did not fit */
        dropped_bytes++;
        if (b == 0) out_dropping = 0;
        return;
    }
    if (out_len >= OUT_CAP) {
        size_t keep = out_len; /* cut the packet in progress back to its last delimiter */
        while (keep > 0 && out_buf[keep - 1] != 0) keep--;
        dropped_bytes += (long long)(out_len - keep) + 1;
        out_len = keep;
        dropped_packets++;
        out_dropping = b != 0;
        return;
    }
    out_buf[out_len++] = b;
}

static void feed_uart(void)
{
    while (!xoff && in_len > 0) {
        uint8_t b = in_buf[in_head];
        in_head = (in_head + 1) % IN_CAP;
        in_len--;
        rx_bytes++;
        avr_raise_irq(uart_in, b);
    }
}

static void uart_xon_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    (void)param;
    xoff = 0;
    feed_uart();
}

static void uart_xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    (void)param;
    xoff = 1;
}

/* --- the MCU ---------------------------------------------------------------------------------- */
static uint8_t reg8(uint16_t a) { return avr->data[a]; }
static int ocr(uint16_t a)
{
    int v = avr->data[a] | avr->data[a + 1] << 8;
    return v > 255 ? 255 : v;
}

/* The count a valve's driver sees: OCRnx while the pin drives and the compare output is on. */
static int valve(uint16_t ddr, int pin, uint16_t tccr, int com1_bit, uint16_t ocr_addr)
{
    if (!((reg8(ddr) >> pin) & 1) || !((reg8(tccr) >> com1_bit) & 1)) return 0;
    return ocr(ocr_addr);
}

static void read_valves(int booting, int inlet[], int bleed[])
{
    int i;
    for (i = 0; i < MAX_CH; i++) inlet[i] = bleed[i] = 0;
    if (booting) return;
    inlet[0] = valve(A_DDRH, 3, A_TCCR4A, 7, A_OCR4A); /* D6 OC4A */
    bleed[0] = valve(A_DDRH, 4, A_TCCR4A, 5, A_OCR4B); /* D7 OC4B */
    inlet[1] = valve(A_DDRH, 5, A_TCCR4A, 3, A_OCR4C); /* D8 OC4C */
    bleed[1] = valve(A_DDRL, 3, A_TCCR5A, 7, A_OCR5A); /* D46 OC5A */
    inlet[2] = valve(A_DDRL, 4, A_TCCR5A, 5, A_OCR5B); /* D45 OC5B */
    bleed[2] = valve(A_DDRL, 5, A_TCCR5A, 3, A_OCR5C); /* D44 OC5C */
}

/* mckibben.hardware.adc_count (the sensor model), with the plant's scale and zero. */
static int adc_count(double pressure, double pa_per_count, double adc_zero)
{
    double x = floor(pressure / pa_per_count + adc_zero + 0.5);
    return x < 0.0 ? 0 : (x > MK_ADC_MAX ? MK_ADC_MAX : (int)x);
}

/* mckibben.hardware.encoder_count: shortening from the rest length, in counts. */
static int encoder_count(double length, double nominal_length, double resolution)
{
    return (int)floor((nominal_length - length) / resolution + 0.5);
}

/* a standard normal draw: xorshift64* into Box-Muller */
static double uniform01(void)
{
    lc_rng ^= lc_rng >> 12;
    lc_rng ^= lc_rng << 25;
    lc_rng ^= lc_rng >> 27;
    return ((double)((lc_rng * 0x2545F4914F6CDD1Dull) >> 11) + 0.5) / 9007199254740992.0;
}

static double gauss(void)
{
    double u = uniform01(), v = uniform01();
    return sqrt(-2.0 * log(u)) * cos(6.283185307179586 * v);
}

/* the load cell's count of channel 0's tension (mckibben.hardware.load_cell_count) */
static int load_cell_count(void)
{
    double pg, len, force;
    mk_outputs(&plant[0], &pg, &len, &force);
    return adc_count(force + lc_offset + (lc_noise > 0.0 ? lc_noise * gauss() : 0.0), lc_full_scale / MK_ADC_MAX, 0.0);
}

static void sense(void)
{
    int i;
    if (lc_full_scale > 0.0) {
        int c = load_cell_count();
        avr_raise_irq(adc_force, (uint32_t)(((uint64_t)c * avr->avcc + 1022u) / 1023u));
    }
    for (i = 0; i < n_ch; i++) {
        double p = plant[i].s[MK_S_P] - MK_P_ATM;
        int c = adc_count(p, plant[i].prm[MK_C_pa_per_count], plant[i].prm[MK_C_adc_zero]);
        if (i == 0 && hold_adc >= 0) c = hold_adc;
        /* simavr: count = mV * 1023 / AVcc (integer): the smallest mV that gives count c */
        uint32_t mv = (uint32_t)(((uint64_t)c * avr->avcc + 1022u) / 1023u);
        avr_raise_irq(adc_in[i], mv);
    }
}

/* gray code sequence the firmware's quad_step counts +1 along: A = bit 0, B = bit 1 */
static const int GRAY[4] = {0, 2, 3, 1};
/* the sequence's index at count 0: both channels high (GRAY[2] = 3), the level of the pull-ups */
#define ENC_PHASE 2

static void encoder_edge(void)
{
    int target = encoder_count(plant[0].s[MK_S_LEN], plant[0].prm[MK_C_nominal_length],
                               plant[0].prm[MK_C_encoder_resolution]) - enc_zero;
    int code;
    if (target == enc_pos) return;
    enc_pos += target > enc_pos ? 1 : -1;
    code = GRAY[(((enc_pos + ENC_PHASE) % 4) + 4) % 4];
    avr_raise_irq(enc_a, (uint32_t)(code & 1));
    avr_raise_irq(enc_b, (uint32_t)((code >> 1) & 1));
}

/* After each instruction: the tick's entry, the I bit, the rings' fill, the profile. */
static void instrument(avr_cycle_count_t before, avr_flashaddr_t pc)
{
    int i_bit = avr->sreg[S_I];
    if (profile) profile[(pc >> 1) & 0x1FFFFu] += (uint32_t)(avr->cycle - before);
    if (avr->pc == TICK_VECTOR_PC) {
        if (ticks > 0) {
            avr_cycle_count_t d = avr->cycle - tick_last;
            if (d < tick_min) tick_min = d;
            if (d > tick_max) tick_max = d;
        }
        tick_last = avr->cycle;
        ticks++;
    }
    if (!i_bit && !masked) {
        masked = 1;
        masked_since = before;
    } else if (i_bit && masked) {
        masked = 0;
        if (ticks > 0 && avr->cycle - masked_since > masked_max) masked_max = avr->cycle - masked_since;
    }
    if (ring_addr[0]) {
        unsigned tx = (uint8_t)(avr->data[ring_addr[0]] - avr->data[ring_addr[1]]);
        unsigned rx = (avr->data[ring_addr[2]] + rx_size - avr->data[ring_addr[3]]) % rx_size;
        if (tx > tx_hwm) tx_hwm = tx;
        if (rx > rx_hwm) rx_hwm = rx;
    }
}

static void mcu_reset(void)
{
    ticks = 0;
    masked = 0;
    avr_reset(avr);
    xoff = 0;
    /* the encoder counts from where the muscle is at reset (an incremental encoder) */
    enc_zero = encoder_count(plant[0].s[MK_S_LEN], plant[0].prm[MK_C_nominal_length],
                             plant[0].prm[MK_C_encoder_resolution]);
    enc_pos = 0;
    /* both channels high at count 0 (ENC_PHASE): the firmware turns on D2/D3's pull-ups at start-up,
       which in simavr sets the pins high whatever was driven before; at another phase its first
       decodes would miss counts (2-3 were lost after each reset). Through 0 to 1: an irq keeps its
       value over avr_reset, and raising the value it holds is no edge. */
    avr_raise_irq(enc_a, 0);
    avr_raise_irq(enc_b, 0);
    avr_raise_irq(enc_a, 1);
    avr_raise_irq(enc_b, 1);
}

/* --- parameters --------------------------------------------------------------------------------- */
static int read_params(const char *path, char *msg, size_t size)
{
    FILE *f = fopen(path, "r");
    int i, j, nf, nth;
    if (!f) {
        snprintf(msg, size, "PARAMS: cannot open %s (%s)", path, strerror(errno));
        return 1;
    }
    if (fscanf(f, "%d %d %d", &n_ch, &nf, &nth) != 3 || n_ch < 1 || n_ch > MAX_CH || nf != MK_NF
        || nth != MK_NTH) {
        snprintf(msg, size, "PARAMS: %s: header 'channels %d fields %d theta %d' expected", path, MAX_CH, MK_NF,
                 MK_NTH);
        fclose(f);
        return 1;
    }
    for (i = 0; i < n_ch; i++) {
        mk_defaults(&plant[i]);
        if (fscanf(f, "%d", &plant[i].law) != 1) goto bad;
        for (j = 0; j < MK_NF; j++)
            if (fscanf(f, "%lf", &plant[i].prm[j]) != 1) goto bad;
        for (j = 0; j < MK_NTH; j++)
            if (fscanf(f, "%lf", &plant[i].th[j]) != 1) goto bad;
        mk_derive(&plant[i]);
        if (mk_check(&plant[i], msg, (int)size)) {
            fclose(f);
            return 1;
        }
        mk_set_commands(&plant[i], 0, 0);
        mk_initial_state(&plant[i]);
    }
    fclose(f);
    return 0;
bad:
    snprintf(msg, size, "PARAMS: %s: channel %d: expected the law, %d fields and %d theta values", path, i, MK_NF,
             MK_NTH);
    fclose(f);
    return 1;
}

/* --- the pty -------------------------------------------------------------------------------- */
static int host_present(int master)
{
    struct pollfd p = {master, POLLIN, 0};
    if (poll(&p, 1, 0) < 0) return 0;
    return !(p.revents & POLLHUP);
}

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void report(double t_sim, double t_dev, double wall, int present, long long sim_ms_lost)
{
    printf("{\"t_sim\": %.4f, \"t_dev\": %.4f, \"wall\": %.4f, \"resets\": %lld, \"wdt_resets\": %lld, \"host\": %d, "
           "\"rx_bytes\": %lld, \"tx_bytes\": %lld, \"dropped_packets\": %lld, \"dropped_bytes\": %lld, "
           "\"late_ms\": %lld, \"min_byte_cycles\": %lld, \"wdt_reset_at\": %.4f, \"pressure_pa\": [",
           t_sim, t_dev > 0.0 ? t_dev : 0.0, wall, resets, wdt_resets, present, rx_bytes, tx_bytes, dropped_packets, dropped_bytes,
           sim_ms_lost, min_tx_gap == (avr_cycle_count_t)-1 ? -1LL : (long long)min_tx_gap, wdt_reset_at);
    for (int i = 0; i < n_ch; i++)
        printf("%s%.1f", i ? ", " : "", plant[i].s[MK_S_P] - MK_P_ATM);
    printf("], \"tension_n\": [");
    for (int i = 0; i < n_ch; i++) {
        double pg, len, force;
        mk_outputs(&plant[i], &pg, &len, &force);
        printf("%s%.6f", i ? ", " : "", force);
    }
    printf("], \"ticks\": %lld, \"tick_min_cycles\": %lld, \"tick_max_cycles\": %lld, "
           "\"masked_max_cycles\": %lld, \"tx_hwm\": %d, \"rx_hwm\": %d", ticks,
           tick_min == (avr_cycle_count_t)-1 ? -1LL : (long long)tick_min, (long long)tick_max,
           (long long)masked_max, ring_addr[0] ? (int)tx_hwm : -1, ring_addr[0] ? (int)rx_hwm : -1);
    printf(", \"valves\": [");
    for (int i = 0; i < n_ch; i++)
        printf("%s[%d, %d]", i ? ", " : "", valves_now[i][0], valves_now[i][1]);
    printf("]}\n");
    fflush(stdout);
}

static void usage_error(const char *what)
{
    fprintf(stderr, "error: %s\n", what);
    exit(2);
}

/* --- the bench side channel (mckibben.rig.bench): channel 0's load, or its end held ------------- */
static const char *bench_dir;
static int bench_sock = -1, bench_conn = -1;
static struct sockaddr_un bench_addr;
static char bench_line[256];
static size_t bench_len;

static int bench_open(const char *dir, const char *pty, char *msg, size_t size)
{
    const char *p = pty;
    size_t k;
    while (*p == '/') p++;
    memset(&bench_addr, 0, sizeof bench_addr);
    bench_addr.sun_family = AF_UNIX;
    if (strlen(dir) + strlen(p) + 7 >= sizeof bench_addr.sun_path) {
        snprintf(msg, size, "pil: --bench-dir %s: the socket path is too long", dir);
        return 1;
    }
    snprintf(bench_addr.sun_path, sizeof bench_addr.sun_path, "%s/%s.sock", dir, p);
    for (k = strlen(dir) + 1; bench_addr.sun_path[k]; k++)
        if (bench_addr.sun_path[k] == '/') bench_addr.sun_path[k] = '_';
    unlink(bench_addr.sun_path); /* a socket left by a killed device on a reused pty number */
    bench_sock = socket(AF_UNIX, SOCK_STREAM, 0);
    if (bench_sock < 0 || bind(bench_sock, (struct sockaddr *)&bench_addr, sizeof bench_addr) != 0
        || listen(bench_sock, 4) != 0) {
        snprintf(msg, size, "pil: cannot serve the bench socket %s (%s)", bench_addr.sun_path, strerror(errno));
        return 1;
    }
    fcntl(bench_sock, F_SETFL, fcntl(bench_sock, F_GETFL) | O_NONBLOCK);
    return 0;
}

/* One request (mckibben.rig.bench.parse_request's grammar) applied to channel 0; the reply into out. */
static void bench_request(char *line, char *out, size_t size)
{
    char verb[16], extra[8];
    double v = 0.0;
    int n = sscanf(line, "%15s %lf %7s", verb, &v, extra);
    mk_plant *pl = &plant[0];
    if (n < 1) {
        snprintf(out, size, "error: empty request");
    } else if (!strcmp(verb, "state") || !strcmp(verb, "release")) {
        char rest[8];
        if (sscanf(line, "%15s %7s", verb, rest) == 2) {
            snprintf(out, size, "error: %s takes no value", verb);
        } else if (!strcmp(verb, "state")) {
            snprintf(out, size, "ok load %.17g length %.17g pressure %.17g held %d",
                     (int)pl->prm[MK_C_load_kind] == MK_LOAD_SPRING ? 0.0 : pl->prm[MK_C_load_force],
                     pl->s[MK_S_LEN], pl->s[MK_S_P] - MK_P_ATM, pl->prm[MK_C_mobile] == 0.0);
        } else {
            pl->prm[MK_C_load_kind] = MK_LOAD_HANGING;
            mk_derive(pl);
            snprintf(out, size, "ok");
        }
    } else if (strcmp(verb, "load") && strcmp(verb, "hold")) {
        snprintf(out, size, "error: unknown request '%s' (load F, hold L, release, state)", verb);
    } else if (n != 2) {
        snprintf(out, size, "error: %s takes one number (%s)", verb, verb[0] == 'l' ? "newtons" : "metres");
    } else if (!isfinite(v) || v < 0.0 || (verb[0] == 'h' && v == 0.0)) {
        snprintf(out, size, "error: %s: %g must be a finite number %s", verb, v, verb[0] == 'l' ? ">= 0" : "> 0");
    } else if (verb[0] == 'l') {
        pl->prm[MK_C_load_force] = v;
        mk_derive(pl);
        snprintf(out, size, "ok");
    } else if (v < pl->prm[MK_C_l_min] || v > pl->prm[MK_C_l_max]) {
        snprintf(out, size, "error: hold %.17g is outside the muscle's travel %.17g..%.17g m", v, pl->prm[MK_C_l_min],
                 pl->prm[MK_C_l_max]);
    } else {
        pl->prm[MK_C_load_kind] = MK_LOAD_BLOCKED;
        mk_derive(pl); /* the one place mobile and inv_mass come from */
        pl->s[MK_S_LEN] = v;
        pl->s[MK_S_VEL] = 0.0;
        snprintf(out, size, "ok");
    }
}

/* Every simulated millisecond: take a client, answer its complete lines. */
static void bench_poll(void)
{
    char tmp[256], out[256];
    ssize_t n;
    if (bench_sock < 0) return;
    if (bench_conn < 0) {
        bench_conn = accept(bench_sock, NULL, NULL);
        if (bench_conn < 0) return;
        fcntl(bench_conn, F_SETFL, fcntl(bench_conn, F_GETFL) | O_NONBLOCK);
        bench_len = 0;
    }
    n = read(bench_conn, tmp, sizeof tmp);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)) {
        close(bench_conn);
        bench_conn = -1;
        return;
    }
    for (ssize_t k = 0; k < n; k++) {
        if (tmp[k] != '\n') {
            if (bench_len < sizeof bench_line - 1) bench_line[bench_len++] = tmp[k];
            continue;
        }
        bench_line[bench_len] = 0;
        bench_request(bench_line, out, sizeof out);
        strcat(out, "\n");
        if (write(bench_conn, out, strlen(out)) < 0) break;
        bench_len = 0;
    }
}

static void bench_close(void)
{
    if (bench_conn >= 0) close(bench_conn);
    if (bench_sock >= 0) {
        close(bench_sock);
        unlink(bench_addr.sun_path);
    }
}

int main(int argc, char **argv)
{
    const char *elf = NULL, *params = NULL;
    double boot_time = 0.3, duration = -1.0, stall_at = -1.0, t_sim = 0.0, booting_until, t0, next_report, wall;
    double adc_miss_at = -1.0, adc_miss_until = -1.0;
    int adc_miss_n = 1;
    const char *profile_path = NULL;
    int unthrottled = 0, master, slave, present, i, chunk = 0;
    uint32_t avcc = 5000;
    long long late_ms = 0;
    char msg[512], name[128];
    elf_firmware_t fw;
    struct termios tio;

    for (i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--boot-time") && i + 1 < argc) boot_time = atof(argv[++i]);
        else if (!strcmp(argv[i], "--duration") && i + 1 < argc) duration = atof(argv[++i]);
        else if (!strcmp(argv[i], "--avcc") && i + 1 < argc) avcc = (uint32_t)atoi(argv[++i]);
        else if (!strcmp(argv[i], "--stall-at") && i + 1 < argc) stall_at = atof(argv[++i]);
        else if (!strcmp(argv[i], "--hold-adc") && i + 1 < argc) hold_adc = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--load-cell") && i + 1 < argc) lc_full_scale = atof(argv[++i]);
        else if (!strcmp(argv[i], "--load-cell-offset") && i + 1 < argc) lc_offset = atof(argv[++i]);
        else if (!strcmp(argv[i], "--load-cell-noise") && i + 1 < argc) lc_noise = atof(argv[++i]);
        else if (!strcmp(argv[i], "--load-cell-seed") && i + 1 < argc) lc_rng ^= strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--bench-dir") && i + 1 < argc) bench_dir = argv[++i];
        else if (!strcmp(argv[i], "--unthrottled")) unthrottled = 1;
        else if (!strcmp(argv[i], "--adc-miss-at") && i + 1 < argc) adc_miss_at = atof(argv[++i]);
        else if (!strcmp(argv[i], "--adc-miss-n") && i + 1 < argc) adc_miss_n = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--profile") && i + 1 < argc) profile_path = argv[++i];
        else if (!strcmp(argv[i], "--rings") && i + 1 < argc) {
            unsigned a[5] = {0, 0, 0, 0, 128};
            if (sscanf(argv[++i], "%u,%u,%u,%u,%u", &a[0], &a[1], &a[2], &a[3], &a[4]) < 4 || !a[0] || !a[4])
                usage_error("pil: --rings takes TXH,TXT,RXH,RXT[,RXSIZE] data addresses");
            for (int k = 0; k < 4; k++) ring_addr[k] = (uint16_t)a[k];
            rx_size = a[4];
        }
        else if (argv[i][0] == '-') {
            snprintf(msg, sizeof msg, "pil: unknown option %s", argv[i]);
            usage_error(msg);
        } else if (!elf) elf = argv[i];
        else if (!params) params = argv[i];
        else usage_error("pil: usage: pil ELF PARAMS [--boot-time S] [--duration S] [--unthrottled]");
    }
    if (!elf || !params) usage_error("pil: usage: pil ELF PARAMS [--boot-time S] [--duration S] [--unthrottled]");
    if (read_params(params, msg, sizeof msg)) usage_error(msg);
    if (lc_full_scale < 0.0 || lc_noise < 0.0 || (lc_full_scale == 0.0 && (lc_offset != 0.0 || lc_noise != 0.0)))
        usage_error("pil: --load-cell needs a full scale above 0 N, and a noise of 0 N or more");
    if (lc_rng == 0) lc_rng = 1;
    if (access(elf, R_OK) != 0) {
        snprintf(msg, sizeof msg, "ELF: cannot read %s (%s)", elf, strerror(errno));
        usage_error(msg);
    }
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(elf, &fw) != 0) {
        snprintf(msg, sizeof msg, "ELF: %s is not an AVR image simavr can load", elf);
        usage_error(msg);
    }
    if (profile_path && !(profile = calloc(1u << 17, sizeof *profile))) usage_error("pil: no memory for --profile");
    avr = avr_make_mcu_by_name("atmega2560");
    if (!avr) usage_error("simavr has no atmega2560 core");
    avr_init(avr);
    avr->log = 0;
    avr_load_firmware(avr, &fw);
    avr->frequency = F_CPU;
    avr->avcc = avr->vcc = avr->aref = avcc;

    uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff_hook, NULL);
    for (i = 0; i < n_ch; i++) adc_in[i] = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + i);
    adc_force = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC3);
    enc_a = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('E'), 4);
    enc_b = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('E'), 5);
    {
        /* the UART model's "sleep while the firmware polls": off, the harness keeps the time */
        uint32_t f = 0;
        avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &f);
        f &= ~(uint32_t)AVR_UART_FLAG_POLL_SLEEP;
        avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &f);
    }

    if (openpty(&master, &slave, name, NULL, NULL) != 0) {
        snprintf(msg, sizeof msg, "pil: cannot open a pseudo-terminal (%s)", strerror(errno));
        usage_error(msg);
    }
    tcgetattr(slave, &tio);
    cfmakeraw(&tio);
    tcsetattr(slave, TCSANOW, &tio);
    tcgetattr(master, &tio);
    cfmakeraw(&tio);
    tcsetattr(master, TCSANOW, &tio);
    close(slave); /* the port is closed until a host opens it */
    fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
    signal(SIGTERM, on_signal);
    signal(SIGINT, on_signal);
    signal(SIGPIPE, SIG_IGN);
    if (bench_dir && bench_open(bench_dir, name, msg, sizeof msg)) { /* the device runs without a bench */
        if (bench_sock >= 0) close(bench_sock);
        bench_sock = -1;
    }
    /* Nobody can have the port open before its name is printed: the first open is always a transition
       (and a reset), however soon after the line the host opens it. */
    present = host_present(master);
    printf("{\"port\": \"%s\", \"channels\": %d, \"fields\": %d, \"bench\": \"%s\"}\n", name, n_ch, MK_NF,
           bench_sock >= 0 ? bench_addr.sun_path : "");
    fflush(stdout);

    mcu_reset();
    t0 = now_s();
    booting_until = boot_time; /* power-on: the bootloader first */
    next_report = 0.2;
    while (!stop_flag) {
        int inlet[MAX_CH], bleed[MAX_CH], booting = t_sim < booting_until;
        uint8_t mcusr_before;
        read_valves(booting, inlet, bleed);
        for (i = 0; i < n_ch; i++) {
            valves_now[i][0] = inlet[i];
            valves_now[i][1] = bleed[i];
            mk_set_commands(&plant[i], inlet[i], bleed[i]);
            mk_advance(&plant[i], CHUNK_S);
        }
        sense();
        if (adc_miss_at >= 0.0 && t_sim >= adc_miss_at) { /* conversions miss the tick */
            avr->data[A_ADCSRA] &= (uint8_t)~(1u << ADIE_BIT);
            adc_miss_until = adc_miss_at + adc_miss_n * 1e-3;
            adc_miss_at = -1.0;
        } else if (adc_miss_until >= 0.0 && t_sim >= adc_miss_until) {
            avr->data[A_ADCSRA] |= (uint8_t)(1u << ADIE_BIT);
            adc_miss_until = -1.0;
        }
        if (stall_at >= 0.0 && t_sim >= stall_at) { /* the control tick stalls, once */
            avr->data[A_TIMSK1] = 0;
            stall_at = -1.0;
        }
        if (!booting) {
            avr_cycle_count_t end = avr->cycle + CHUNK_CYCLES;
            encoder_edge();
            mcusr_before = reg8(A_MCUSR);
            while (avr->cycle < end) {
                avr_cycle_count_t before = avr->cycle;
                avr_flashaddr_t pc = avr->pc;
                int st = avr_run(avr);
                instrument(before, pc);
                if (st == cpu_Done || st == cpu_Crashed) {
                    /* the image stopped (sleep with interrupts off, or a crash): a Mega would hang
                       until its watchdog: reset it as the watchdog would */
                    wdt_resets++;
                    mcu_reset();
                    booting_until = t_sim;
                    break;
                }
            }
            if (!(mcusr_before & 0x08) && (reg8(A_MCUSR) & 0x08)) { /* WDRF: a watchdog reset */
                wdt_resets++;
                wdt_reset_at = t_sim;
                booting_until = t_sim;
            }
        }
        t_sim += CHUNK_S;
        chunk++;
        if (chunk % 10 == 0) { /* every simulated millisecond: the link and the clock */
            int was = present;
            ssize_t n;
            present = host_present(master);
            if (present && !was) { /* DTR: the host opened the port */
                resets++;
                mcu_reset();
                booting_until = t_sim + boot_time;
                out_len = 0;
                out_dropping = 0;
                in_len = 0;
            }
            if (present) {
                uint8_t tmp[4096];
                while ((n = read(master, tmp, sizeof tmp)) > 0) {
                    if (t_sim < booting_until) continue; /* the bootloader swallows it */
                    for (ssize_t k = 0; k < n && in_len < IN_CAP; k++) {
                        in_buf[(in_head + in_len) % IN_CAP] = tmp[k];
                        in_len++;
                    }
                }
                feed_uart();
                if (out_len) {
                    n = write(master, out_buf, out_len);
                    if (n > 0) {
                        memmove(out_buf, out_buf + n, out_len - (size_t)n);
                        out_len -= (size_t)n;
                    }
                }
            } else {
                out_len = 0; /* the UART shifts out to nobody */
                in_len = 0;
            }
            bench_poll();
            wall = now_s() - t0;
            if (!unthrottled) {
                double ahead = t_sim - wall;
                if (ahead > 0.002) {
                    struct timespec ts = {0, (long)(ahead * 1e9)};
                    nanosleep(&ts, NULL);
                } else if (ahead < -0.02) {
                    /* starved of CPU: the simulation does not race to catch up (a device never
                       runs fast, and a burst would overflow the host's buffers); its clock slips */
                    late_ms += (long long)(-ahead * 1e3);
                    t0 -= ahead; /* ahead < 0: wall time restarts from the simulated */
                }
            }
            if (wall >= next_report) {
                report(t_sim, t_sim - booting_until, wall, present, late_ms);
                next_report = wall + 0.2;
            }
            if (duration >= 0 && (unthrottled ? t_sim : wall) >= duration) break;
        }
    }
    report(t_sim, t_sim - booting_until, now_s() - t0, present, late_ms);
    if (profile) {
        FILE *pf = fopen(profile_path, "w");
        if (pf) {
            for (uint32_t w = 0; w < (1u << 17); w++)
                if (profile[w]) fprintf(pf, "0x%x %u\n", w << 1, profile[w]);
            fclose(pf);
        }
    }
    close(master);
    bench_close();
    return 0;
}
