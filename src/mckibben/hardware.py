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
- Force (an optional load cell, in series with channel 0's muscle): a strain-gauge cell through an
  instrumentation amplifier (INA125) into ADC3, 0–5 V over ``0..full_scale``. A tension ``f`` with
  the amplifier's zero offset ``offset`` and noise sample ``e`` reads the pressure model's count
  with ``full_scale/ADC_MAX`` newtons per count and zero 0 (:func:`load_cell_count`): nearest,
  halves up, and clipped to the rails, so a cell in tension reads 0 below zero force.
- Length: the pulley's incremental encoder counts the muscle's shortening from its rest length,
  ``count = floor((l0 − l)/resolution + 1/2)``; a count reads back as ``l0 − count·resolution``.

The scalar kernels (``adc_count`` …) are Numba functions for compiled loops (plain Python until
the package loads Numba: :mod:`mckibben._kernels`); the array faces (``adc_from_pressure`` …)
apply the same kernels element-wise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mckibben._kernels import kernel, need_speed, register
from mckibben.errors import InputError

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
#: Full scale of the default load cell and amplifier: 0–5 V on ADC3 for 0–5 N, the paper rig's cell
#: ([mpam-characterization] §III.B: 5 N, 1 mN resolution; on the 10-bit ADC 4.9 mN per count). An
#: image is built for a cell with ``make LOAD_CELL_MN=5000``. [N]
LOAD_CELL_FULL_SCALE = 5.0
#: Largest full scale a load cell may be given: the HELLO frame carries it in mN as 32 bits, and
#: the Makefile's ``LOAD_CELL_MN``. [N]
LOAD_CELL_FULL_SCALE_MAX = 10_000.0
#: The ADC input of the load cell's amplifier (``MCK_LOAD_CELL_ADC`` in ``firmware/src/main.c``).
LOAD_CELL_ADC = 3


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
def load_cell_count(force, offset, noise, full_scale):
    """The ADC3 count of the load cell: the pressure sensor's model (:func:`adc_count`) on the force.

    The cell and its amplifier are linear, 0–5 V over ``0..full_scale``; the reading is
    ``force + offset + noise`` rounded to the nearest count and clipped to ``0..ADC_MAX``: a cell in
    tension reads 0 below zero force (the rail), ``ADC_MAX`` above its full scale.

    Parameters
    ----------
    force : float
        Tension on the cell. [N]
    offset : float
        The amplifier's zero offset, as a force. [N]
    noise : float
        This sample's noise. [N]
    full_scale : float
        Force at 5 V. [N]

    Returns
    -------
    int
        The count. [count]
    """
    return adc_count(force + offset + noise, full_scale / ADC_MAX, 0.0)


@dataclass(frozen=True)
class LoadCell:
    """A load cell in series with channel 0's muscle, as both device engines model it.

    The reading of a tension ``f`` is :func:`load_cell_count` of ``f``, ``offset`` and a fresh
    Gaussian sample of standard deviation ``noise``, with ``full_scale``: resolution
    ``full_scale/ADC_MAX``, the rail at 0 below zero force.

    Parameters
    ----------
    full_scale : float, default LOAD_CELL_FULL_SCALE
        Force at 5 V, above 0 and at most :data:`LOAD_CELL_FULL_SCALE_MAX`. [N]
    offset : float, default 0.0
        The amplifier's zero offset as a force, within ±``full_scale``. [N]
    noise : float, default 0.0
        Standard deviation of the noise, 0 up to ``full_scale``/10. [N]

    Raises
    ------
    InputError
        A value out of its range, named.
    """

    full_scale: float = LOAD_CELL_FULL_SCALE
    offset: float = 0.0
    noise: float = 0.0

    def __post_init__(self):
        # errors lead with the names the engines and ``rig emulate`` take these as
        for name, arg in (("full_scale", "load_cell"), ("offset", "load_cell_offset"), ("noise", "load_cell_noise")):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not math.isfinite(v):
                raise InputError(f"{arg}: {v!r} is not a finite force (the load cell's {name.replace('_', ' ')}) [N]")
        if not 0 < self.full_scale <= LOAD_CELL_FULL_SCALE_MAX or round(self.full_scale * 1e3) < 1:
            raise InputError(f"load_cell: {self.full_scale!r} is not a full scale above 0 and at most "
                             f"{LOAD_CELL_FULL_SCALE_MAX:g} N")
        if abs(self.offset) > self.full_scale:
            raise InputError(f"load_cell_offset: {self.offset!r} is outside ±{self.full_scale:g} N (the load cell's "
                             "full scale)")
        if not 0 <= self.noise <= self.full_scale / 10:
            raise InputError(f"load_cell_noise: {self.noise!r} must be 0..{self.full_scale / 10:g} N (a tenth of the "
                             "load cell's full scale)")

    @property
    def resolution(self) -> float:
        """Force per count. [N/count]"""
        return self.full_scale / ADC_MAX

    def count(self, force: float, noise_sample: float = 0.0) -> int:
        """The count of a tension with a noise sample (:func:`load_cell_count`). [count]

        Parameters
        ----------
        force : float
            Tension on the cell. [N]
        noise_sample : float, default 0.0
            A draw of the noise, already scaled. [N]
        """
        return int(load_cell_count(force, self.offset, noise_sample, self.full_scale))


def force_from_count(count, full_scale=LOAD_CELL_FULL_SCALE):
    """The force that load-cell counts read as (before any tare). [N]

    Parameters
    ----------
    count : array_like
        ADC3 counts. [count]
    full_scale : float, default LOAD_CELL_FULL_SCALE
        Force at 5 V. [N]
    """
    return np.asarray(count, dtype=float) * (float(full_scale) / ADC_MAX)


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
    "load_cell": ("A3",),
    "serial": ("D0", "D1"),
}
#: The timer output compare unit behind each valve pin (Timers 4 and 5, 8-bit fast PWM).
PWM_UNIT = {"D6": "OC4A", "D7": "OC4B", "D8": "OC4C", "D46": "OC5A", "D45": "OC5B", "D44": "OC5C"}


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
