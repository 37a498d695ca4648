"""The rig's hardware facts, shared with the firmware, and its one sensor model.

Everything here is a fact of the paper's rig ([mpam-characterization] §III.B) or of the
firmware that runs it (``firmware/core/controller.h``, ``firmware/core/controller.c``,
``firmware/src/main.c``); ``tests/test_hardware.py`` parses those files and holds the numbers
below equal to theirs. The plant, the controllers, the rig emulator and recorder and the
generated datasets import them from here.

Sensor model
------------
- Pressure: a 0–1 MPa transducer on the ATmega2560's 10-bit ADC. A gauge pressure ``p`` reads
  ``count = floor(p/pa_per_count + adc_zero + 1/2)`` (nearest count, halves up), saturated to
  ``0..ADC_MAX``; a count reads back as ``(count − adc_zero)·pa_per_count``.
- Length: the pulley's incremental encoder counts the muscle's shortening from its rest length,
  ``count = floor((l0 − l)/resolution + 1/2)``; a count reads back as ``l0 − count·resolution``.

The scalar kernels (``adc_count`` …) are Numba functions for compiled loops (plain Python until
the package loads Numba: :mod:`mckibben._kernels`); the array faces (``adc_from_pressure`` …)
apply the same kernels element-wise.
"""

from __future__ import annotations

import math

import numpy as np

from mckibben._kernels import kernel, need_speed, register

#: Compiled limit of the maximum pressure, the transducer's full scale (``MCK_P_MAX_LIMIT``). [Pa]
P_MAX_LIMIT = 1_000_000
#: Default maximum pressure, the paper's safe limit (``mck_ctrl_init``: ``c->p_max = 800000L``). [Pa]
P_MAX_DEFAULT = 800_000
#: Resolution of the ATmega2560's ADC. [bits]
ADC_BITS = 10
#: Largest ADC count. [count]
ADC_MAX = (1 << ADC_BITS) - 1
#: Pressure per ADC count: the transducer's full scale over the ADC's range (the firmware's
#: default gain ``pa_per_count`` = 977517 in units of 1e-3 Pa/count). [Pa/count]
PA_PER_COUNT = P_MAX_LIMIT / ADC_MAX
#: Control period of the firmware (``TS_US`` in ``firmware/src/main.c``). [µs]
CONTROL_PERIOD_US = 1000
#: Control period. [s]
CONTROL_PERIOD = CONTROL_PERIOD_US / 1e6
#: Limits of the control period accepted by ``mck_ctrl_init`` (``MCK_TS_US_MIN``/``MAX``). [µs]
TS_US_MIN, TS_US_MAX = 100, 10_000
#: Belt travel per encoder count: 500 counts per pulley turn (§III.B). [m/count]
ENCODER_RESOLUTION = 0.17e-3


@kernel
def adc_count(pressure, pa_per_count, adc_zero):
    """The ADC count of a gauge pressure: nearest count, halves up, saturated to 0..ADC_MAX.

    Parameters
    ----------
    pressure : float
        Gauge pressure. [Pa]
    pa_per_count : float
        Transducer scale. [Pa/count]
    adc_zero : float
        Count at zero gauge pressure. [count]

    Returns
    -------
    int
        The count. [count]
    """
    x = math.floor(pressure / pa_per_count + adc_zero + 0.5)
    if x < 0.0:
        return 0
    if x > ADC_MAX:
        return ADC_MAX
    return int(x)


@kernel
def adc_pressure(count, pa_per_count, adc_zero):
    """The gauge pressure an ADC count reads as. [Pa]

    Parameters
    ----------
    count : int
        ADC count. [count]
    pa_per_count : float
        Transducer scale. [Pa/count]
    adc_zero : float
        Count at zero gauge pressure. [count]
    """
    return (count - adc_zero) * pa_per_count


@kernel
def encoder_count(length, nominal_length, resolution):
    """The encoder count of a muscle length: its shortening in counts, nearest, halves up.

    Parameters
    ----------
    length : float
        Muscle length. [m]
    nominal_length : float
        Rest length, where the count is 0. [m]
    resolution : float
        Belt travel per count. [m/count]

    Returns
    -------
    int
        The count (negative when the muscle is longer than at rest). [count]
    """
    return int(math.floor((nominal_length - length) / resolution + 0.5))


@kernel
def encoder_length(count, nominal_length, resolution):
    """The muscle length an encoder count reads as. [m]

    Parameters
    ----------
    count : int
        Encoder count. [count]
    nominal_length : float
        Rest length. [m]
    resolution : float
        Belt travel per count. [m/count]
    """
    return nominal_length - count * resolution


@kernel
def _adc_array(p, ppc, zero, out):
    for i in range(p.size):
        out[i] = adc_count(p[i], ppc[i], zero[i])


@kernel
def _enc_array(length, l0, res, out):
    for i in range(length.size):
        out[i] = encoder_count(length[i], l0[i], res[i])


def _flat(*args):
    b = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    # copies: a compiled call reading a broadcast view's writeable flag warns (NumPy FutureWarning)
    return b[0].shape, [np.array(x, order="C").ravel() for x in b]


def adc_from_pressure(pressure, adc_zero=0, pa_per_count=PA_PER_COUNT):
    """ADC counts of gauge pressures (:func:`adc_count` element-wise).

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    adc_zero : array_like, default 0
        Count at zero gauge pressure. [count]
    pa_per_count : array_like, default PA_PER_COUNT
        Transducer scale. [Pa/count]

    Returns
    -------
    numpy.ndarray of int64 or int
        Counts 0..ADC_MAX (an int for scalar input). [count]

    Examples
    --------
    >>> int(adc_from_pressure(0.55e6))
    563
    """
    shape, (p, ppc, zero) = _flat(pressure, pa_per_count, adc_zero)
    need_speed(p.size)
    out = np.empty(p.size, dtype=np.int64)
    _adc_array(p, ppc, zero, out)
    return out.reshape(shape) if shape else int(out[0])


def pressure_from_adc(count, adc_zero=0, pa_per_count=PA_PER_COUNT):
    """Gauge pressures that ADC counts read as (:func:`adc_pressure` element-wise). [Pa]

    Parameters
    ----------
    count : array_like
        ADC counts. [count]
    adc_zero : array_like, default 0
        Count at zero gauge pressure. [count]
    pa_per_count : array_like, default PA_PER_COUNT
        Transducer scale. [Pa/count]
    """
    return (np.asarray(count, dtype=float) - adc_zero) * pa_per_count


def encoder_from_length(length, nominal_length, resolution=ENCODER_RESOLUTION):
    """Encoder counts of muscle lengths (:func:`encoder_count` element-wise).

    Parameters
    ----------
    length : array_like
        Muscle length. [m]
    nominal_length : array_like
        Rest length. [m]
    resolution : array_like, default ENCODER_RESOLUTION
        Belt travel per count. [m/count]

    Returns
    -------
    numpy.ndarray of int64 or int
        Counts (an int for scalar input). [count]
    """
    shape, (x, l0, res) = _flat(length, nominal_length, resolution)
    need_speed(x.size)
    out = np.empty(x.size, dtype=np.int64)
    _enc_array(x, l0, res, out)
    return out.reshape(shape) if shape else int(out[0])


def length_from_encoder(count, nominal_length, resolution=ENCODER_RESOLUTION):
    """Muscle lengths that encoder counts read as. [m]

    Parameters
    ----------
    count : array_like
        Encoder counts. [count]
    nominal_length : array_like
        Rest length. [m]
    resolution : array_like, default ENCODER_RESOLUTION
        Belt travel per count. [m/count]
    """
    return np.asarray(nominal_length, dtype=float) - np.asarray(count, dtype=float) * resolution


def quantize_length(length, nominal_length, resolution=ENCODER_RESOLUTION):
    """A length as the encoder reports it: counted, then read back. [m]

    Parameters
    ----------
    length : array_like
        Muscle length. [m]
    nominal_length : array_like
        Rest length. [m]
    resolution : array_like, default ENCODER_RESOLUTION
        Belt travel per count. [m/count]
    """
    return length_from_encoder(encoder_from_length(length, nominal_length, resolution), nominal_length, resolution)


# --- the three-channel bench (firmware/src/main.c) -------------------------------------------

#: Pressure channels of the firmware (``MCK_N_CHANNELS``): the endoscope's three muscles.
N_CHANNELS = 3
#: Serial line rate (``BAUD``): 16 MHz / (8·(UBRR + 1)) with U2X and UBRR = 1, 0 % error. [1/s]
BAUD = 1_000_000
#: Arduino pin of each signal (``firmware/src/main.c``; ``docs/firmware.md``, "Pin map").
PIN_MAP = {
    "pressure": ("A0", "A1", "A2"),
    "inlet": ("D6", "D8", "D45"),
    "bleed": ("D7", "D46", "D44"),
    "encoder": ("D2", "D3"),
    "serial": ("D0", "D1"),
}
#: The timer output compare unit behind each valve pin (Timers 4 and 5, 8-bit fast PWM).
PWM_UNIT = {"D6": "OC4A", "D7": "OC4B", "D8": "OC4C", "D46": "OC5A", "D45": "OC5B", "D44": "OC5C"}


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
