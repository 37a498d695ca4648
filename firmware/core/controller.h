/* mckibben pressure-controller core (docs/controller.md, docs/firmware.md).
 *
 * One control step: ADC scaling, supervisor (reference clamp, overpressure vent, sensor faults),
 * sliding-mode law or PID (chosen at run time), PWM split into inlet and bleed counts.
 *
 * Portable C99, integer only: built with avr-gcc for the ATmega2560 (firmware/src/main.c) and
 * with gcc for the host tests, where it is checked bit for bit against the Python mirror
 * src/mckibben/control/core.py. No division and no 64-bit arithmetic in mck_ctrl_step: every
 * reciprocal is precomputed when a gain is set (mck_ctrl_set_gain, which may use 64-bit
 * division and is not meant for an interrupt handler).
 *
 * Integer conventions that the Python mirror reproduces:
 *   - right shifts of negative values are arithmetic (floor); gcc guarantees this;
 *   - mck_mulq16(x, c) = floor(x * c / 2^16) for c >= 0, computed from 16x16-bit products,
 *     wrapped to int32 (the value ranges below keep every true result inside int32);
 *   - rounding divisions at gain-setting time are rdiv(n, d) = floor((n + floor(d/2)) / d) on
 *     unsigned 64-bit integers.
 */
#ifndef MCK_CONTROLLER_H
#define MCK_CONTROLLER_H

#include <stdint.h>

/* Modes (SET_MODE, docs/protocol.md). */
#define MCK_MODE_OFF 0u       /* both valves closed */
#define MCK_MODE_SMC 1u       /* sliding mode */
#define MCK_MODE_PID 2u       /* PID */
#define MCK_MODE_OPEN_LOOP 3u /* the PWM counts given by mck_ctrl_set_open_loop */
/* Modes 4, 5, ...: the extension laws of core/laws.h (MCK_MODE_<NAME> there, generated from the
 * table of src/mckibben/control/laws/_table.py; the ids above are checked against it). */

/* Fault flags (TELEMETRY.faults). Bits 1-4 are latched until mck_ctrl_set_mode. */
#define MCK_FAULT_OVERPRESSURE 0x01u /* p > p_max + margin, cleared when p < p_max */
#define MCK_FAULT_ADC_RANGE 0x02u    /* reading outside [adc_min, adc_max] */
#define MCK_FAULT_STUCK 0x04u        /* no response: n_stuck readings unchanged while the valve model
                                        predicts a change (supervisor 3, docs/controller.md) */
#define MCK_FAULT_MISSING 0x08u      /* n_missing consecutive missing samples */
#define MCK_FAULT_VENT 0x10u         /* vent latched by command (VENT) */

/* Supervisor 2b: the inlet is shut and the bleed opened wide while p + MCK_LEAD_SAMPLES
 * (p - p_prev) > p_max, the pressure extrapolated over the inlet valve's closing time (~3 ms lag
 * + one period); below that the inlet is capped at (p_max - p) >> MCK_HEADROOM_SHIFT counts (255
 * from 65.3 kPa below p_max, 0 at p_max): a valve that opens near the maximum cannot carry the
 * pressure past it through its lag (docs/controller.md, Safety). */
#define MCK_LEAD_SAMPLES 4
#define MCK_HEADROOM_SHIFT 8
/* Supervisor 3, the response rule: the supervisor's valve model p = G_s (u - u0_s) (gains
 * SUP_G, SUP_U0: the identified model) predicts that the reading must move when
 *   - the bleed is at >= u0_s + MCK_RESP_DU counts (open past any plausible lift-off), the
 *     inlet shut, and p >= MCK_RESP_P_MIN: it must fall, the bleed vents to atmosphere whatever
 *     the supply; or
 *   - the inlet is at u >= u0_s + MCK_RESP_DU counts with G_s (u - u0_s - MCK_RESP_DU) >=
 *     2 p + MCK_RESP_P_MIN (the model's equilibrium for the command lies far above p: a steady
 *     holding command never qualifies) and p <= p_seen - MCK_RESP_P_MIN, p_seen being the
 *     highest pressure the supply has delivered (to any channel of a bank) since SET_MODE: at
 *     or near it the supply may be the limit, and a chamber at supply pressure is not a fault.
 * n_stuck consecutive valid readings equal to the previous one while a prediction holds latch
 * MCK_FAULT_STUCK. A reading that freezes during a rise to a new maximum is indistinguishable
 * from the supply's limit until the next bleed or a reading below p_seen (docs/controller.md). */
#define MCK_RESP_DU 24
#define MCK_RESP_P_MIN 20000L
#define MCK_P_NONE 2000000L /* p_prev before the first step: no cut on the first sample */

/* ACK status codes returned by the setters (docs/protocol.md). */
#define MCK_OK 0u
#define MCK_ERR_RANGE 3u
#define MCK_ERR_GAIN_ID 4u

/* Compiled limit of SET_MAX_PRESSURE [Pa]: the full scale of the 0-1 MPa transducer. */
#define MCK_P_MAX_LIMIT 1000000L
/* Control period limits [us] (mck_ctrl_init). The firmware uses 1000 us. */
#define MCK_TS_US_MIN 100u
#define MCK_TS_US_MAX 10000u

/* Gain ids of SET_GAIN and their fixed-point scales: the i32 value sent is
 * round(physical value * scale). The accepted range of the value is [lo, hi]; outside it the
 * setter returns MCK_ERR_RANGE and changes nothing.
 *
 *  id  name                   physical unit          scale   lo        hi            default value
 *   0  MCK_GAIN_SMC_BETA      beta, PWM counts       1e3     0         255000        120000
 *   1  MCK_GAIN_SMC_EPS       epsilon, Pa            1       1         1000000       20000
 *   2  MCK_GAIN_SMC_KI        Ki (SMC), 1/s          1e3     0         1000000       10000
 *   3  MCK_GAIN_SMC_TAU       tau, s                 1e6     0         10000000      90000
 *   4  MCK_GAIN_SMC_G         G, Pa per PWM count    1e3     0 (off)   100000000     3000000
 *   5  MCK_GAIN_SMC_IMAX      I_max, Pa s            1e3     0         2147483647    10000000
 *   6  MCK_GAIN_PID_KP        Kp, counts/Pa          1e9     0         1000000000    1000000
 *   7  MCK_GAIN_PID_KI        Ki (PID), counts/(Pa s) 1e9    0         2147483647    11000000
 *   8  MCK_GAIN_PID_KD        Kd, counts s/Pa        1e12    0         2147483647    0
 *   9  MCK_GAIN_PID_TF        Tf, s                  1e6     0         10000000      5000
 *  10  MCK_GAIN_ADC_ZERO      adc_zero, count        1       0         1023          0
 *  11  MCK_GAIN_PA_PER_COUNT  pa_per_count, Pa/count 1e3     1         2047999       977517
 *  12  MCK_GAIN_MARGIN        overpressure margin,Pa 1       0         200000        20000
 *  13  MCK_GAIN_ADC_MIN       adc_min, count         1       0         1023          0
 *  14  MCK_GAIN_ADC_MAX       adc_max, count         1       0         1023          1022
 *  15  MCK_GAIN_N_STUCK       n_stuck, samples       1       0 (off)   65535         250
 *  16  MCK_GAIN_N_MISSING     n_missing, samples     1       0 (off)   65535         10
 *  17  MCK_GAIN_SMC_U0        u0, PWM counts         1e3     0         255000        0
 *  18  MCK_GAIN_SUP_G         G_s, Pa per PWM count  1e3     0 (off)   100000000     3000000
 *  19  MCK_GAIN_SUP_U0        u0_s, PWM counts       1e3     0         255000        112000
 *
 * The sliding mode's model term is (p + tau (dp_ref/Ts + Ki e)) / G from the identified model
 * dp/dt = (G (u - u0) - p) / tau, with u0 the valves' lift-off: the command v = model term +
 * beta tanh(S/eps) is sent as v + u0 sign(v), the inverse of the valves' dead zone. G = 0
 * switches the model term and u0 off: u = beta tanh(S/eps) alone, the law as the paper ran it
 * (docs/controller.md).
 *
 * p_max is set by mck_ctrl_set_max_pressure (SET_MAX_PRESSURE), in Pa, 0..MCK_P_MAX_LIMIT,
 * default 800000.
 */
enum mck_gain_id {
    MCK_GAIN_SMC_BETA = 0,
    MCK_GAIN_SMC_EPS = 1,
    MCK_GAIN_SMC_KI = 2,
    MCK_GAIN_SMC_TAU = 3,
    MCK_GAIN_SMC_G = 4,
    MCK_GAIN_SMC_IMAX = 5,
    MCK_GAIN_PID_KP = 6,
    MCK_GAIN_PID_KI = 7,
    MCK_GAIN_PID_KD = 8,
    MCK_GAIN_PID_TF = 9,
    MCK_GAIN_ADC_ZERO = 10,
    MCK_GAIN_PA_PER_COUNT = 11,
    MCK_GAIN_MARGIN = 12,
    MCK_GAIN_ADC_MIN = 13,
    MCK_GAIN_ADC_MAX = 14,
    MCK_GAIN_N_STUCK = 15,
    MCK_GAIN_N_MISSING = 16,
    MCK_GAIN_SMC_U0 = 17,
    MCK_GAIN_SUP_G = 18,
    MCK_GAIN_SUP_U0 = 19,
    MCK_N_CORE_GAINS = 20 /* the extension laws' gains follow (core/laws.h) */
};

#include "laws.h" /* the extension laws: their gain ids, modes, state and coefficients */

#define MCK_ADD_N_GAINS_(NAME, name) +MCK_##NAME##_N_GAINS
#define MCK_ADD_ONE_(NAME, name) +1
/* Every gain id, the extension laws' included. */
#define MCK_N_GAINS (MCK_N_CORE_GAINS MCK_EXT_LAWS(MCK_ADD_N_GAINS_))
/* Modes 0..MCK_N_MODES-1. */
#define MCK_N_MODES (MCK_MODE_OPEN_LOOP + 1 MCK_EXT_LAWS(MCK_ADD_ONE_))

/* Outputs of one step. */
typedef struct {
    uint8_t inlet;      /* inlet valve PWM count 0..255 */
    uint8_t bleed;      /* bleed valve PWM count 0..255 */
    uint8_t faults;     /* MCK_FAULT_* */
    int32_t reference;  /* reference after the supervisor's clamp [Pa] */
    int32_t surface;    /* sliding surface S (SMC) or error e (other modes) [Pa] */
} mck_out_t;

/* The step's state. It comes first in mck_ctrl_t and the step reaches it through its own
 * pointer: every member lies within the 63-byte displacement of the AVR's ldd/std, so each
 * access is one instruction (docs/firmware.md, "Cycle budget"). */
typedef struct {
    uint8_t mode;
    uint8_t latched;    /* latched fault flags */
    uint8_t over;       /* overpressure vent active */
    uint8_t first;      /* 1: the next law step initializes e_prev and pref_prev */
    uint8_t last_inlet, last_bleed; /* the command applied during the period now ending */
    uint16_t held_adc;  /* last valid sample */
    uint16_t stuck_n, missing_n;
    int32_t isum;       /* SMC: sum of e [Pa] (I = isum Ts) */
    int32_t iu;         /* PID: Ki I [counts Q16] */
    int32_t dq;         /* PID: 16 Ts D [Pa Q4] */
    int32_t e_prev;     /* [Pa] */
    int32_t pref_prev;  /* [Pa] */
    int32_t p_prev;     /* last step's measured pressure [Pa] */
    int32_t p_seen;     /* supply estimate: highest pressure shown since SET_MODE, shared by
                           the channels of a bank (mck_bank_step) [Pa] */
#define MCK_STATE_MEMBER_(NAME, name) mck_##name##_state_t name;
    MCK_EXT_LAWS(MCK_STATE_MEMBER_) /* the extension laws' states (core/laws.h) */
} mck_state_t;

/* Settings in the step's native widths and the derived coefficients (mck_ctrl_set_gain), in
 * the order the step reads them. */
typedef struct {
    /* the supervisor and the sliding mode (within the first 64 bytes: one ldd each) */
    int32_t ppc_q8;     /* Pa per count, Q8 */
    int32_t p_max;      /* [Pa] */
    int32_t p_over;     /* p_max + margin [Pa] */
    int32_t c_p;        /* 2^24 / G: p [Pa] -> u [counts Q8], Q16 */
    int32_t c_dref;     /* 2^24 tau / (G Ts): delta p_ref [Pa] -> u [counts Q8], Q16 */
    int32_t c_e;        /* 2^24 tau Ki / G: e [Pa] -> u [counts Q8], Q16 */
    int32_t c_u0;       /* u0 [counts Q8] (0 when G = 0) */
    int32_t c_ki;       /* 2^24 Ki Ts: sum of e [Pa] -> Ki I [Pa Q8], Q16 */
    int32_t c_eps;      /* floor(2^28 / eps): S [Pa] -> S/eps Q12, Q16 */
    int32_t s_sat;      /* 8 eps: |S| beyond which tanh is taken as 1 [Pa] */
    int32_t isum_max;   /* clamp of the sum of e: min(I_max/Ts, 2^46/c_ki, 2^30) [Pa] */
    int32_t isum_min;   /* -isum_max */
    uint16_t beta_q8;   /* beta, counts Q8 (<= 65280) */
    int16_t resp_u;     /* u0_s + MCK_RESP_DU [counts]: a valve below this is not "open" */
    int16_t adc_zero;
    uint16_t adc_min, adc_max, n_stuck, n_missing;
    int32_t gs_pa;      /* G_s rounded to Pa per count; 0: response rule off */
    /* the PID */
    int32_t c_kp;       /* 2^24 Kp, Q16 */
    int32_t c_kip;      /* 2^32 Ki Ts: e [Pa] -> integral [counts Q16], Q16 */
    int32_t c_kd;       /* 2^20 Kd / Ts: 16 Ts D [Pa Q4] -> u [counts Q8], Q16 */
    int32_t alpha;      /* 2^16 Ts / (Tf + Ts) */
    uint8_t ol_inlet, ol_bleed;
#define MCK_COEF_MEMBER_(NAME, name) mck_##name##_coef_t name;
    MCK_EXT_LAWS(MCK_COEF_MEMBER_) /* the extension laws' coefficients (core/laws.h) */
} mck_coef_t;

/* Controller instance (one channel). Treat as opaque. The state comes first; everything a
 * setter changes (k and what follows it) comes after, so firmware/src/main.c can compute new
 * gains on a copy and swap in the bytes from offsetof(mck_ctrl_t, k) on. */
typedef struct {
    mck_state_t s;
    mck_coef_t k;
    int32_t gain[MCK_N_GAINS]; /* as set (SET_GAIN values) */
    uint16_t ts_us;            /* control period [us] */
} mck_ctrl_t;

/* Set every gain to its default, p_max to 800 kPa, mode off, no fault. ts_us is the control
 * period in microseconds (MCK_TS_US_MIN..MCK_TS_US_MAX; clamped). */
void mck_ctrl_init(mck_ctrl_t *c, uint16_t ts_us);

/* Set one gain (value in the fixed-point scale above); recomputes the derived coefficients.
 * Returns MCK_OK, MCK_ERR_GAIN_ID or MCK_ERR_RANGE. Uses 64-bit division: call it from the main
 * loop on a copy and swap it in with interrupts off, or with the control interrupt masked. */
uint8_t mck_ctrl_set_gain(mck_ctrl_t *c, uint8_t id, int32_t value);

/* Mode 0..MCK_N_MODES-1; resets the controller state and clears the latched faults. */
uint8_t mck_ctrl_set_mode(mck_ctrl_t *c, uint8_t mode);

/* Maximum pressure [Pa], 0..MCK_P_MAX_LIMIT. */
uint8_t mck_ctrl_set_max_pressure(mck_ctrl_t *c, int32_t p_max_pa);

/* PWM counts used in MCK_MODE_OPEN_LOOP. */
void mck_ctrl_set_open_loop(mck_ctrl_t *c, uint8_t inlet, uint8_t bleed);

/* Latch the vent (MCK_FAULT_VENT) until the next mck_ctrl_set_mode. */
void mck_ctrl_vent(mck_ctrl_t *c);

/* One control step. adc: raw count of the pressure transducer; sample_ok: 0 when no sample
 * arrived this period; p_ref_pa: set-point [Pa]. */
void mck_ctrl_step(mck_ctrl_t *c, uint16_t adc, uint8_t sample_ok, int32_t p_ref_pa,
                   mck_out_t *out);

/* N channels (a bank) stepped in one period: channel i gets adc[i], bit i of ok_mask and
 * p_ref_pa[i]; then the shared supply check: every channel's p_seen becomes the highest of the
 * bank's, so a supply that one channel shows to deliver counts for all. */
#define MCK_MAX_CHANNELS 3u
void mck_bank_step(mck_ctrl_t *ch, uint8_t n, const uint16_t *adc, uint8_t ok_mask,
                   const int32_t *p_ref_pa, mck_out_t *out);

/* The same on the global bank mck_bank[0..n-1] (what firmware/src/main.c runs): constant
 * addresses instead of pointers, the same results as mck_bank_step(mck_bank, n, ...). */
extern mck_ctrl_t mck_bank[MCK_MAX_CHANNELS];
void mck_bank_run(uint8_t n, const uint16_t *adc, uint8_t ok_mask, const int32_t *p_ref_pa,
                  mck_out_t *out);

/* Building blocks, exported for the tests. */
int32_t mck_mulq16(int32_t x, int32_t c);  /* floor(x c / 2^16), c >= 0 */
int32_t mck_mulq16s24(int32_t x, int32_t c); /* the same for -2^23 <= x < 2^23 */
uint16_t mck_tanh_q15(uint16_t x_q12);     /* tanh(x) Q15 for x in [0, 8), Q12 */
unsigned mck_ctrl_sizeof(void);            /* sizeof(mck_ctrl_t), for ctypes */

#endif
