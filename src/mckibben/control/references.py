"""Pressure references as objects: what :func:`~mckibben.experiments.track_pressure` follows.

The library takes a reference as an object in SI: a :class:`SineReference` (mean and amplitude
[Pa], frequency [Hz]), a CSV/Parquet file with ``time_<unit>`` and ``pressure_<unit>`` columns
(its path), or an array of one pressure per control period [Pa]. The command line's text
(``--reference sine:0.4MPa,0.1MPa,2Hz`` or a file name) becomes one of these through
:func:`parse_reference`, the one parser of that text.

>>> parse_reference("sine:0.4MPa,0.1MPa,2Hz")
SineReference(mean=400000.0, amplitude=100000.0, frequency=2.0)
>>> SineReference(0.4e6, 0.1e6, 2.0).text
'sine:400000.0Pa,100000.0Pa,2.0Hz'
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError
from mckibben.units import parse_quantity, si

__all__ = ["SINE_PREFIX", "SineReference", "parse_reference", "refuse_text"]

#: How the command line writes a sine reference: ``sine:MEAN,AMPLITUDE,FREQUENCY``.
SINE_PREFIX = "sine:"


@dataclass(frozen=True)
class SineReference:
    """A sinusoidal pressure reference, ``mean + amplitude · sin(2π · frequency · t)``.

    Parameters
    ----------
    mean : float
        Mean pressure (gauge), at least 0. [Pa]
    amplitude : float
        Amplitude, at least 0. [Pa]
    frequency : float
        Frequency, above 0 (the 1 kHz controller follows at most 500 Hz:
        :func:`~mckibben.control.experiment_setup.pressure_reference` checks it). [Hz]
    """

    mean: float
    amplitude: float
    frequency: float

    def __post_init__(self):
        object.__setattr__(self, "mean", si(self.mean, "pressure", "mean"))
        object.__setattr__(self, "amplitude", si(self.amplitude, "pressure", "amplitude"))
        object.__setattr__(self, "frequency", si(self.frequency, "frequency", "frequency", allow_zero=False))

    def sample(self, t) -> np.ndarray:
        """The reference at the times ``t``.

        Parameters
        ----------
        t : array_like
            Times. [s]

        Returns
        -------
        numpy.ndarray
            Pressures. [Pa]
        """
        return self.mean + self.amplitude * np.sin(2 * np.pi * self.frequency * np.asarray(t, dtype=float))

    @property
    def text(self) -> str:
        """The command line's form in SI units, which :func:`parse_reference` reads back exactly. [-]"""
        return f"{SINE_PREFIX}{self.mean!r}Pa,{self.amplitude!r}Pa,{self.frequency!r}Hz"


def parse_reference(text: str, name: str = "reference"):
    """A pressure reference from the command line's text: a :class:`SineReference` or a file's path.

    Parameters
    ----------
    text : str
        ``sine:MEAN,AMPLITUDE,FREQUENCY`` with units (``sine:0.4MPa,0.2MPa,2Hz``), or the path of
        a CSV/Parquet file with ``time_<unit>`` and ``pressure_<unit>`` columns. [-]
    name : str, default "reference"
        The argument, for messages. [-]

    Returns
    -------
    SineReference or pathlib.Path
        The reference the library takes.

    Raises
    ------
    InputError
        A sine that is not three quantities, or one that is not a pressure, pressure, frequency
        (negative, zero frequency, not finite); the message names ``name``.
    """
    if not isinstance(text, str):
        raise ArgumentTypeError(f"{name} = {text!r}: parse_reference reads text (sine:MEAN,AMPLITUDE,FREQUENCY "
                                "or a file name)")
    if not text.startswith(SINE_PREFIX):
        return Path(text)
    parts = text[len(SINE_PREFIX):].split(",")
    if len(parts) != 3:
        raise InputError(f"{name}: {text!r} must be sine:MEAN,AMPLITUDE,FREQUENCY")
    mean = parse_quantity(parts[0], "pressure", f"{name} mean")
    amp = parse_quantity(parts[1], "pressure", f"{name} amplitude")
    freq = parse_quantity(parts[2], "frequency", f"{name} frequency", allow_zero=False)
    return SineReference(mean, amp, freq)


def refuse_text(reference, name: str = "reference") -> None:
    """Refuse the command line's text where the library takes a reference object, with the object to pass.

    Parameters
    ----------
    reference : object
        The argument. [-]
    name : str
        Its Python name. [-]
    """
    if isinstance(reference, str) and reference.startswith(SINE_PREFIX):
        try:
            hint = f"; pass {parse_reference(reference, name)!r}"
        except InputError:
            hint = ""
        raise ArgumentTypeError(f"{name} = {reference!r}: the library takes a SineReference(mean, amplitude, "
                                f"frequency) in SI, not text{hint} (mckibben.control.parse_reference converts "
                                "text)")

