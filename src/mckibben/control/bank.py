"""The controller core run step by step from Python: one instance (:class:`CoreController`) or a bank.

:class:`CoreController` wraps one instance of the core with the C core's setters (SET_MODE,
SET_GAIN, the open-loop command) and telemetry; :class:`CoreBank` is the firmware's bank of
channels (``mck_bank_step``), which share channel 0's supply estimate. The step itself is
:mod:`mckibben.control.step`.
"""

from __future__ import annotations

from collections.abc import Sequence


from mckibben.errors import InputError
from mckibben.control import registry as R
from mckibben.control.core_params import GAIN_IDS, GAINS, N_GAINS, CoreParams, fill_coefficients, pack_params
from mckibben.hardware import P_MAX_LIMIT
from mckibben.control.step import FAULT_VENT, STATUS_GAIN_ID, STATUS_OK, STATUS_RANGE, core_kernel, core_step
from mckibben.control.layout import (
    IP_GAIN0, IP_OL_BLEED,
    IP_OL_INLET, IP_P_MAX, IP_P_OVER, IS_DQ, IS_E_PREV, IS_FIRST,
    IS_ISUM, IS_IU, IS_LATCHED, IS_MISSING_N, IS_MODE, IS_P_SEEN, IS_PREF_PREV, IS_REFERENCE, IS_STUCK_N, IS_SURFACE)


class CoreController:
    """One instance of the firmware controller core, stepped from Python.

    The setters mirror the firmware commands and return their ACK status (0 ok, 3 value out of
    range, 4 bad gain id) instead of raising, as the device does.

    Parameters
    ----------
    params : CoreParams, optional
        Physical parameters. [SI]
    """

    def __init__(self, params: CoreParams = CoreParams()):
        self.istate, self.iparams, self.fstate, self.fparams = pack_params(params)

    def step(self, adc: int, sample_ok: bool = True, p_ref_pa: float = 0.0) -> tuple[int, int, int]:
        """One control step.

        Parameters
        ----------
        adc : int
            Raw pressure ADC count. [count]
        sample_ok : bool, default True
            False when no sample arrived this period. [-]
        p_ref_pa : float, default 0.0
            Pressure reference. [Pa]

        Returns
        -------
        tuple of int
            ``(inlet, bleed, faults)``: PWM counts 0..255 and fault flags. [-]
        """
        i, b, f = core_kernel(self.istate, self.iparams, self.fstate, self.fparams,
                              int(adc), 0, bool(sample_ok), float(p_ref_pa))
        return int(i), int(b), int(f)

    @property
    def surface_pa(self) -> int:
        """Sliding surface S (mode 1) or error e (other modes) of the last step. [Pa]"""
        return int(self.istate[IS_SURFACE])

    @property
    def reference_pa(self) -> int:
        """Reference of the last step after the supervisor's clamp. [Pa]"""
        return int(self.istate[IS_REFERENCE])

    @property
    def mode(self) -> int:
        """Current mode. [-]"""
        return int(self.istate[IS_MODE])

    def set_gain(self, gain_id: int, value: int) -> int:
        """SET_GAIN: one gain in its fixed-point scale (``GAINS``); returns the ACK status.

        Parameters
        ----------
        gain_id : int
            Gain id 0..N_GAINS-1. [-]
        value : int
            Value in the gain's SET_GAIN scale. [-]
        """
        if not 0 <= gain_id < N_GAINS:
            return STATUS_GAIN_ID
        g = GAINS[gain_id]
        if not g.lo <= value <= g.hi:
            return STATUS_RANGE
        self.iparams[IP_GAIN0 + gain_id] = value
        fill_coefficients(self.iparams)
        return STATUS_OK

    def set_mode(self, mode: int) -> int:
        """SET_MODE: resets the law state and clears the latched faults; returns the status.

        Parameters
        ----------
        mode : int
            0 off, 1 sliding mode, 2 PID, 3 open loop. [-]
        """
        if mode not in R.MODE_IDS:
            return STATUS_RANGE
        st = self.istate
        st[IS_MODE] = mode
        st[IS_LATCHED] = 0
        st[IS_FIRST] = 1
        for k in (IS_ISUM, IS_IU, IS_DQ, IS_E_PREV, IS_PREF_PREV, IS_STUCK_N, IS_MISSING_N, IS_P_SEEN):
            st[k] = 0
        st[R.CORE_N_ISTATE:] = 0  # the extension laws' state (their reset())
        return STATUS_OK

    def set_max_pressure(self, p_max_pa: int) -> int:
        """SET_MAX_PRESSURE; returns the status.

        Parameters
        ----------
        p_max_pa : int
            Maximum pressure, 0..P_MAX_LIMIT. [Pa]
        """
        if not 0 <= p_max_pa <= P_MAX_LIMIT:
            return STATUS_RANGE
        self.iparams[IP_P_MAX] = p_max_pa
        self.iparams[IP_P_OVER] = p_max_pa + self.iparams[IP_GAIN0 + GAIN_IDS["margin"]]
        return STATUS_OK

    def set_open_loop(self, inlet: int, bleed: int) -> None:
        """SET_OPEN_LOOP: the PWM counts of mode 3.

        Parameters
        ----------
        inlet, bleed : int
            PWM counts 0..255. [count]
        """
        self.iparams[IP_OL_INLET] = int(inlet) & 0xFF
        self.iparams[IP_OL_BLEED] = int(bleed) & 0xFF

    def vent(self) -> None:
        """VENT: latch the vent until the next :meth:`set_mode`."""
        self.istate[IS_LATCHED] |= FAULT_VENT


class CoreBank:
    """N channels of the core stepped together, as ``mck_bank_step`` in the firmware.

    Each channel is a :class:`CoreController` with its own gains and state; in one period
    channel i steps with ``adcs[i]``, ``oks[i]``, ``refs[i]`` in order, and all compare
    with and raise one supply estimate, channel 0's (the shared supply check of the response
    rule, ``docs/controller.md``).

    Parameters
    ----------
    params : sequence of CoreParams
        One parameter set per channel (1..3 on the firmware). [SI]
    """

    def __init__(self, params: Sequence[CoreParams]):
        plist = list(params)
        if not plist:
            raise InputError("CoreBank needs at least one channel")
        self.channels = [CoreController(p) for p in plist]

    def __len__(self) -> int:
        return len(self.channels)

    def __getitem__(self, i: int) -> CoreController:
        return self.channels[i]

    def step(self, adcs, oks, refs) -> list[tuple[int, int, int]]:
        """One period of every channel.

        Parameters
        ----------
        adcs : sequence of int
            Raw ADC count per channel. [count]
        oks : sequence of bool
            Whether each channel's sample arrived. [-]
        refs : sequence of float
            Pressure reference per channel. [Pa]

        Returns
        -------
        list of tuple of int
            ``(inlet, bleed, faults)`` per channel. [-]
        """
        shared = self.channels[0].istate
        out = []
        for c, a, ok, r in zip(self.channels, adcs, oks, refs, strict=True):
            i, b, f = core_step(c.istate, c.iparams, int(a), bool(ok), float(r), shared)
            out.append((int(i), int(b), int(f)))
        return out
