"""The example characterization campaign: SYNTHETIC data for three miniature muscles.

A user without a rig can run every command on it. It is generated deterministically
(``mckibben datasets generate [--out DIR] [--seed N]``) from the published parameter sets of
[mpam-characterization] (Tables I and II, eq. 3) with the paper's instrument limits; the bundled
copy (``mckibben/datasets/campaign/``) is ``--seed 0``. It is marked synthetic in its
``campaign.toml``, its README, every ``muscle.toml`` and in every report that uses it.

What is generated, per muscle (97, 117, 143 mm), and how
-------------------------------------------------------
Every experiment is drawn from one "truth" per muscle (:func:`campaign_truth`):

- ``isotonic.csv`` — length under hanging loads 0.6, 0.975, 1.35, 1.725, 2.1 N (inside the
  characterized 0.6–2.1 N, where the published map interpolates cos θ linearly in load) at
  0–800 kPa every 50 kPa, 3 trials. Length = eq. 2 of eq. 3 (the published cubics); each trial
  scatters by σ = 0.3 mm (the paper's maximum contraction standard deviation 0.003 of ~100 mm) and
  is read by the pulley encoder, 0.17 mm per count.
- ``braid_angle.csv`` — photographs at 0–0.8 MPa every 0.1 MPa under 0.6 and 2.1 N, 3 trials: the
  muscle's state scatters by σ = 0.003 in cos θ between trials; the angle is read with σ = 0.4°
  (within the paper's ±1° resolution), the length with σ = 0.8 mm (Fig. 9). Where the published
  cubic gives cos θ > 1 (97 mm at 0.6 N below ~0.1 MPa) no angle exists and no photograph is taken.
- ``blocked_force.csv`` — force at the rest length every 10 psi from 0 to 120 psi, 3 trials. The
  paper prints only the force at 0.8 MPa (4.2, 3.5, 3.0 N); the curve through it is ours:
  F = F₀.₈·(0.5x + 0.7x² − 0.2x³), x = P/0.8 MPa (zero at zero pressure, rising, concave at the
  top, like Fig. 3). Load cell: σ = 0.02 N between trials, 1 mN resolution, 5 N range.
- ``hysteresis.csv`` — inflate 0 → 0.8 MPa then deflate back, every 50 kPa, under 0.6 N, 3 trials.
  cos θ on the inflate branch is the published cubic + d·x(1 − x), on the deflate branch − d·x(1 − x)
  (x = P/0.8 MPa, d = 0.08 → about 2 mm between the branches mid-way): inflating needs more
  pressure for the same contraction, as in Fig. 6. Noise as isotonic.
- ``force_length.csv`` — the second paper's protocol: at 0.2, 0.3, 0.4, 0.5, 0.65, 0.8 MPa the muscle
  is pulled from its unstretched length Lu(P) to L0 (elongation) and let back (contraction), 15
  points each way, 2 trials. Spring-model truth: Lu = L0·(1 − 0.22·x²) and per direction and
  pressure range (split 0.45 MPa, the median pressure) K = c3·P + c2·P·Ls + c1·Ls + c0 chosen by
  least squares so that F(L0) is the blocked force above with a stiffening shape F ∝ (Ls/Ls,max)^1.3;
  contraction pulls 15 % less than elongation (the hysteresis). Force σ = 0.01 N, 1 mN resolution;
  length read to 1 µm.
- ``step_response.parquet`` — open-loop valve command steps 0.1 → 0.4, 0.7, 1.0 at t = 0.05 s, 2 trials
  each, 5 ms sampling to 0.6 s: first order, τ = 0.09 s (§IV.A), final pressure 0.8 MPa × command;
  transducer σ = 2 kPa, 1 kPa resolution (0–1 MPa). The same τ for all three muscles (the paper
  measured one 100 mm muscle).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mckibben.datasets.published import MUSCLES
from mckibben.errors import InputError
from mckibben.hardware import ENCODER_RESOLUTION, P_MAX_DEFAULT, quantize_length
from mckibben.models.kinematic import length_from_braid
from mckibben.models.mpam import MiniatureMuscle, braid_cos_theta
from mckibben.models.spring import CONTRACTION, DEFAULT_TERMS, ELONGATION, HIGH, LOW, SpringModel, spring_force
from mckibben.errors import unknown_name
from mckibben.atomic import as_path, atomic_dir, check_output_dir
import tomllib

if TYPE_CHECKING:  # annotations only; the modules are imported where used (deferred)
    import pandas as pd

#: Where the bundled campaign lives (package data).
BUNDLED = Path(__file__).with_name("campaign")

CAMPAIGN_MUSCLES = ("mpam97", "mpam117", "mpam143")

# instrument limits of [mpam-characterization]
ENCODER_STEP = ENCODER_RESOLUTION  #: pulley encoder [m per count] (§III.B, mckibben.hardware)
LENGTH_TRIAL_SD = 0.3e-3  #: trial-to-trial length scatter [m] (max contraction sd 0.003, §III.B)
PHOTO_LENGTH_SD = 0.8e-3  #: length error of the photographs [m] (§III.C, Fig. 9)
PHOTO_ANGLE_SD = np.deg2rad(0.4)  #: angle reading scatter [rad], within the ±1° resolution (§III.C)
PHOTO_COS_SD = 0.003  #: trial-to-trial scatter of the muscle's state in cos θ [-]
FORCE_SD = 0.02  #: blocked force scatter between trials [N]
LOADCELL_STEP = 1e-3  #: load-cell resolution [N] (§III.A)
LOADCELL_MAX = 5.0  #: load-cell range [N] (§III.A)
LOOP_FORCE_SD = 0.01  #: force scatter in force-length loops [N]
PRESSURE_STEP = 1e3  #: transducer resolution [Pa] (0–1 MPa, §III.B)
PRESSURE_SD = 2e3  #: transducer noise in step responses [Pa]
TAU = 0.09  #: open-loop pressure time constant [s] (§IV.A)
HYSTERESIS_D = 0.08  #: cos θ amplitude of the branch offset [-]
LU_CONTRACTION = 0.22  #: free contraction at 0.8 MPa of the spring-model truth [-]
SPRING_SPLIT = 0.45e6  #: low/high pressure split of the spring-model truth [Pa]
LOOP_PRESSURES = (0.2e6, 0.3e6, 0.4e6, 0.5e6, 0.65e6, 0.8e6)
ISOTONIC_LOADS = (0.6, 0.975, 1.35, 1.725, 2.1)
PHOTO_LOADS = (0.6, 2.1)
HYSTERESIS_LOAD = 0.6
STEP_COMMANDS = (0.4, 0.7, 1.0)
STEP_TIME = 0.05
STEP_BASE = 0.1  #: command before the step (80 kPa: the transducer never clips at zero) [-]
P_MAX = float(P_MAX_DEFAULT)


@dataclass(frozen=True)
class CampaignTruth:
    """The parameters one synthetic muscle's data are generated from.

    Attributes
    ----------
    muscle : MiniatureMuscle
        The published set (Table I, Table II / eq. 3).
    blocked_force : tuple of float
        Cubic of the blocked force in P (MPa): c3, c2, c1, c0. [N/MPa^i]
    hysteresis : dict
        ``direction -> cos θ cubic (P in MPa)`` of the two branches at :data:`HYSTERESIS_LOAD`.
    spring : SpringModel
        The force-length truth.
    tau : float
        Time constant of the pressure step response. [s]
    """

    muscle: MiniatureMuscle
    blocked_force: tuple
    hysteresis: dict
    spring: SpringModel
    tau: float = TAU

    def length_cubic(self, cos_cubic) -> np.ndarray:
        """Length cubic (P in MPa) of a cos θ cubic through eq. 2: k1·Ls·c + (0, 0, 0, k2).

        Parameters
        ----------
        cos_cubic : sequence of 4 float
            cos θ cubic (P³, P², P, 1; P in MPa). [-]
        """
        m = self.muscle
        return m.k1 * m.strand_length * np.asarray(cos_cubic, dtype=float) + np.array([0, 0, 0, m.k2])


def _blocked_force_cubic(force_at_08: float) -> tuple:
    pm = P_MAX / 1e6
    return (-0.2 * force_at_08 / pm**3, 0.7 * force_at_08 / pm**2, 0.5 * force_at_08 / pm, 0.0)


def _spring_truth(m: MiniatureMuscle, fb_cubic) -> SpringModel:
    l0 = m.nominal_length
    h = (-LU_CONTRACTION * l0 / P_MAX**2, 0.0, l0)
    coeffs = {}
    for rname, (lo, hi) in ((LOW, (0.15e6, SPRING_SPLIT)), (HIGH, (SPRING_SPLIT, P_MAX))):
        pg, sg = np.meshgrid(np.linspace(lo, hi, 12), np.linspace(0.05, 1.0, 12))
        lsmax = l0 - ((h[0] * pg + h[1]) * pg + h[2])
        stretch = sg * lsmax
        fb = np.polyval(fb_cubic, pg / 1e6)
        target = fb * sg**1.3
        x = np.column_stack([(pg**i * stretch**j * stretch).ravel() for i, j in DEFAULT_TERMS])
        c, *_ = np.linalg.lstsq(x / np.linalg.norm(x, axis=0), target.ravel(), rcond=None)
        c = c / np.linalg.norm(x, axis=0)
        coeffs[(ELONGATION, rname)] = tuple(float(v) for v in c)
        coeffs[(CONTRACTION, rname)] = tuple(float(0.85 * v) for v in c)
    return SpringModel(l0, h, coeffs, DEFAULT_TERMS, SPRING_SPLIT, (0.0, P_MAX), (0.0, LU_CONTRACTION * l0),
                       "SYNTHETIC truth of the example campaign (mckibben.datasets.campaign)")


def campaign_truth(name: str) -> CampaignTruth:
    """The generating parameters of one campaign muscle.

    Parameters
    ----------
    name : str
        ``"mpam97"``, ``"mpam117"`` or ``"mpam143"``.
    """
    if name not in CAMPAIGN_MUSCLES:
        raise unknown_name("campaign muscle", name, CAMPAIGN_MUSCLES)
    m = MUSCLES[name]
    fb = _blocked_force_cubic(m.blocked_force[0][1])
    centre = np.asarray(m.braid_map.coefficients_at(HYSTERESIS_LOAD))
    pm = P_MAX / 1e6
    offset = HYSTERESIS_D * np.array([0.0, -1.0 / pm**2, 1.0 / pm, 0.0])  # d·x(1 − x), x = P/pm
    hyst = {"inflate": tuple(centre + offset), "deflate": tuple(centre - offset)}
    return CampaignTruth(m, fb, hyst, _spring_truth(m, fb))


def _encoder(length, l0):
    return quantize_length(length, l0, ENCODER_STEP)


def _cos_cubic(c, p_pa):
    return np.polyval(c, np.asarray(p_pa) / 1e6)


def generate_muscle(name: str, seed: int = 0) -> dict[str, pd.DataFrame]:
    """Generate every experiment of one campaign muscle (tables with file columns, not SI).

    Parameters
    ----------
    name : str
        Campaign muscle name.
    seed : int, default 0
        Random seed; the same seed gives the same tables. [-]

    Returns
    -------
    dict
        file name -> pandas.DataFrame with ``quantity_unit`` columns.
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)
    truth = campaign_truth(name)
    m = truth.muscle
    idx = CAMPAIGN_MUSCLES.index(name)
    rng = lambda k: np.random.default_rng([seed, idx, k])  # noqa: E731  one stream per experiment
    l0 = m.nominal_length
    out: dict[str, pd.DataFrame] = {}

    # isotonic
    r = rng(1)
    rows = []
    pressures = np.arange(0, 801, 50) * 1e3
    for trial in (1, 2, 3):
        for load in ISOTONIC_LOADS:
            cos_t, _ = braid_cos_theta(pressures, load, m.braid_map)
            ell = length_from_braid(cos_t, m.strand_length, m.k1, m.k2) + r.normal(0, LENGTH_TRIAL_SD, pressures.size)
            ell = _encoder(ell, l0)
            rows += [(p / 1e3, load, e * 1e3, trial) for p, e in zip(pressures, ell)]
    out["isotonic.csv"] = pd.DataFrame(rows, columns=["pressure_kPa", "load_N", "length_mm", "trial"])

    # braid angle photographs
    r = rng(2)
    rows = []
    pressures = np.arange(0, 9) * 0.1e6
    for trial in (1, 2, 3):
        for load in PHOTO_LOADS:
            cos_t, _ = braid_cos_theta(pressures, load, m.braid_map)
            cos_t = cos_t + r.normal(0, PHOTO_COS_SD, pressures.size)
            ell = length_from_braid(cos_t, m.strand_length, m.k1, m.k2) + r.normal(0, PHOTO_LENGTH_SD, pressures.size)
            ang = np.arccos(np.minimum(cos_t, 1.0)) + r.normal(0, PHOTO_ANGLE_SD, pressures.size)
            for p, c, a, e in zip(pressures, cos_t, ang, ell):
                if c < 1.0:
                    rows.append((p / 1e6, load, np.rad2deg(a), e * 1e3, trial))
    out["braid_angle.csv"] = pd.DataFrame(rows, columns=["pressure_MPa", "load_N", "braid_angle_deg", "length_mm", "trial"])

    # blocked force
    r = rng(3)
    rows = []
    psi = np.arange(0, 121, 10)
    pressures = psi * 6894.757293168361
    for trial in (1, 2, 3):
        f = np.polyval(truth.blocked_force, pressures / 1e6) + r.normal(0, FORCE_SD, psi.size)
        f = np.clip(np.round(f / LOADCELL_STEP) * LOADCELL_STEP, -LOADCELL_MAX, LOADCELL_MAX)
        rows += [(p, ff, trial) for p, ff in zip(psi, f)]
    out["blocked_force.csv"] = pd.DataFrame(rows, columns=["pressure_psi", "force_N", "trial"])

    # hysteresis
    r = rng(4)
    rows = []
    up = np.arange(0, 801, 50) * 1e3
    for trial in (1, 2, 3):
        for direction, pressures in (("inflate", up), ("deflate", up[::-1])):
            cos_t = _cos_cubic(truth.hysteresis[direction], pressures)
            ell = length_from_braid(cos_t, m.strand_length, m.k1, m.k2) + r.normal(0, LENGTH_TRIAL_SD, pressures.size)
            ell = _encoder(ell, l0)
            rows += [(p / 1e6, HYSTERESIS_LOAD, e * 1e3, direction, trial) for p, e in zip(pressures, ell)]
    out["hysteresis.csv"] = pd.DataFrame(rows, columns=["pressure_MPa", "load_N", "length_mm", "direction", "trial"])

    # force-length loops
    r = rng(5)
    rows = []
    sm = truth.spring
    for trial in (1, 2):
        for p in LOOP_PRESSURES:
            lu = (sm.h[0] * p + sm.h[1]) * p + sm.h[2]
            for direction, ell in ((ELONGATION, np.linspace(lu, l0, 15)), (CONTRACTION, np.linspace(l0, lu, 15))):
                f, _ = spring_force(ell, p, sm, direction)
                f = np.round((f + r.normal(0, LOOP_FORCE_SD, ell.size)) / LOADCELL_STEP) * LOADCELL_STEP
                rows += [(p / 1e6, e * 1e3, ff, direction, trial) for e, ff in zip(ell, f)]
    out["force_length.csv"] = pd.DataFrame(rows, columns=["pressure_MPa", "length_mm", "force_N", "direction", "trial"])

    # pressure step responses
    r = rng(6)
    t = np.round(np.arange(0, 121) * 0.005, 6)
    frames = []
    trial = 0
    for cmd in STEP_COMMANDS:
        for _ in (1, 2):
            trial += 1
            rise = np.where(t >= STEP_TIME, -np.expm1(-(t - STEP_TIME) / truth.tau), 0.0)
            p = P_MAX * (STEP_BASE + (cmd - STEP_BASE) * rise)
            p = np.clip(np.round((p + r.normal(0, PRESSURE_SD, t.size)) / PRESSURE_STEP) * PRESSURE_STEP, 0, 1e6)
            frames.append(pd.DataFrame({"time_s": t, "pressure_kPa": p / 1e3,
                                        "command": np.where(t >= STEP_TIME, cmd, STEP_BASE), "trial": trial}))
    out["step_response.parquet"] = pd.concat(frames, ignore_index=True)
    return out


FORMATS = {"length_mm": "%.3f", "force_N": "%.3f", "braid_angle_deg": "%.1f", "pressure_MPa": "%.3f",
           "pressure_kPa": "%.0f", "load_N": "%.3f"}


def _muscle_toml(name: str, seed: int) -> str:
    m = MUSCLES[name]
    g = m.geometry
    return (
        f'id = "{name}"\n'
        f"nominal_length_mm = {m.nominal_length * 1e3:g}\n"
        f"strand_length_mm = {m.strand_length * 1e3:g}\n"
        f"outer_diameter_mm = {g.outer_diameter * 1e3:g}\n"
        f"tube_inner_diameter_mm = {g.tube_inner_diameter * 1e3:g}\n"
        f"tube_outer_diameter_mm = {g.tube_outer_diameter * 1e3:g}\n"
        f"strand_diameter_mm = {g.strand_diameter * 1e3:g}\n"
        f"braid_angle_deg = {np.rad2deg(g.braid_angle):g}\n"
        "synthetic = true\n"
        f'notes = "SYNTHETIC: generated by `mckibben datasets generate --seed {seed}` from the published set'
        f' {name} of [mpam-characterization] (Table I, Table II); not a measurement."\n'
    )


README = """# Example characterization campaign — SYNTHETIC

**These data are synthetic.** They were generated by `mckibben datasets generate --seed {seed}` from
the published parameter sets of the miniature muscles of [mpam-characterization] (Table I, Table II,
eq. 3) with that paper's instrument limits, hysteresis and repeated trials. They are not
measurements. They exist so that every command (`mckibben fit`, `compare`, `reproduce`) can be run
without a rig. How each experiment is generated: `mckibben.datasets.campaign` (module docstring);
the file schemas: docs/data.md.

One folder per muscle (mpam97, mpam117, mpam143), each with:

| file | kind | what |
| --- | --- | --- |
| muscle.toml | muscle file | id, nominal and strand length, diameters, braid angle, `synthetic = true` |
| isotonic.csv | isotonic | length under 5 hanging loads vs pressure, 3 trials (Fig. 5, 10) |
| braid_angle.csv | braid_angle | braid angle and length from photographs at 0.6 and 2.1 N (Fig. 9, 10) |
| blocked_force.csv | blocked_force | blocked force vs pressure every 10 psi (Fig. 3) |
| hysteresis.csv | hysteresis | inflate / deflate under 0.6 N (Fig. 6) |
| force_length.csv | force_length | force-length loops at constant pressure (Wickramatunge & Leephakpreeda (2010) [wickramatunge2010]) |
| step_response.parquet | step_response | open-loop valve steps, first order τ = 0.09 s (§IV.A) |
"""


def campaign_toml(seed: int) -> str:
    """The campaign's metadata file: synthetic, seed, instruments.

    Parameters
    ----------
    seed : int
        The seed it was generated with. [-]
    """
    return (
        "# SYNTHETIC example campaign: generated, not measured.\n"
        "synthetic = true\n"
        f"seed = {seed}\n"
        f'generator = "mckibben datasets generate --seed {seed}"\n'
        'source = "published parameter sets of [mpam-characterization] (Tables I and II, eq. 3)"\n'
        f'muscles = [{", ".join(repr(n).replace(chr(39), chr(34)) for n in CAMPAIGN_MUSCLES)}]\n'
        "\n[instruments]\n"
        f"encoder_m_per_count = {ENCODER_STEP}\n"
        f"length_trial_sd_m = {LENGTH_TRIAL_SD}\n"
        f"photo_length_sd_m = {PHOTO_LENGTH_SD}\n"
        f"photo_angle_sd_rad = {PHOTO_ANGLE_SD:.6g}\n"
        f"load_cell_resolution_N = {LOADCELL_STEP}\n"
        f"load_cell_range_N = {LOADCELL_MAX}\n"
        f"pressure_resolution_Pa = {PRESSURE_STEP}\n"
        "pressure_range_Pa = [0.0, 1000000.0]\n"
        f"step_time_constant_s = {TAU}\n"
    )


def write_campaign(out, seed: int = 0) -> Path:
    """Generate the whole campaign into a folder, atomically (temp folder, then rename).

    Parameters
    ----------
    out : str or pathlib.Path
        Target folder; must not exist or be empty, or be a campaign folder written before (it is
        replaced).
    seed : int, default 0
        Random seed. [-]

    Returns
    -------
    pathlib.Path
        The folder.
    """

    out = check_output_dir(out, "out")
    if out.is_dir() and any(out.iterdir()) and not (out / "campaign.toml").is_file():
        raise InputError(f"out: {out} exists and is not an empty folder or a campaign written before")
    with atomic_dir(out, "out") as tmp:
        (tmp / "campaign.toml").write_text(campaign_toml(seed), encoding="utf-8")
        (tmp / "README.md").write_text(README.format(seed=seed), encoding="utf-8")
        for name in CAMPAIGN_MUSCLES:
            folder = tmp / name
            folder.mkdir()
            (folder / "muscle.toml").write_text(_muscle_toml(name, seed), encoding="utf-8")
            for fname, df in generate_muscle(name, seed).items():
                if fname.endswith(".parquet"):
                    df.to_parquet(folder / fname, index=False)
                else:
                    _write_csv(df, folder / fname)
    return out


def _write_csv(df: pd.DataFrame, path: Path) -> None:
    body = df.copy()
    for col, fmt in FORMATS.items():
        if col in body:
            body[col] = [fmt % v for v in body[col]]
    body.to_csv(path, index=False, lineterminator="\n")


def campaign_muscle_dirs(root=None) -> list[Path]:
    """The muscle folders of a campaign (default: the bundled one).

    Parameters
    ----------
    root : str or pathlib.Path, optional
        A campaign folder (one sub-folder with a ``muscle.toml`` per muscle).
    """
    root = as_path(root, "data", "folder") if root is not None else BUNDLED
    if not root.is_dir():
        raise InputError(f"data: {root} is not a folder")
    dirs = sorted(p for p in root.iterdir() if p.is_dir() and (p / "muscle.toml").is_file())
    if not dirs:
        raise InputError(f"data: {root} holds no muscle folders (sub-folders with a muscle.toml)")
    return dirs


def is_synthetic(root=None) -> bool:
    """Whether a campaign folder says it is synthetic (``synthetic = true`` in campaign.toml).

    Parameters
    ----------
    root : str or pathlib.Path, optional
        The campaign folder (default: the bundled one).
    """

    root = Path(root) if root is not None else BUNDLED
    meta = root / "campaign.toml"
    if not meta.is_file():
        return False
    try:
        return bool(tomllib.loads(meta.read_text(encoding="utf-8")).get("synthetic", False))
    except tomllib.TOMLDecodeError:
        raise InputError(f"{meta}: not a valid TOML file") from None
