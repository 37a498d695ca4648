"""rig characterize, stepped against ramped: the controller's overshoot, the run time, the measured loop.

Runs the example protocol (``mckibben examples copy characterize.toml``) unattended on a device engine
(the Python emulator in real time, or the firmware image in simavr, unthrottled) with the calibrated
``mpam97`` muscle, once with each ``[isotonic] ramp`` asked for (``step``: the set-point jumps), and
prints per run

- each inflating step's excursion past its set-point, ``pressure_max_Pa − set_point_Pa`` (mean, max);
- the run's wall time (the device's boot not counted) and the sweeps' device time;
- per load the measured up/down gap and the muscle file's (``fit.hysteresis``), and how far apart;
- per load, at the set-points where both branches moved and the plant's loop is off its stops, the
  plant's own gap (its Dahl slip limit, ``mckibben.plant.simulator.static_branch_lengths``) against
  the muscle file's (``--branch``): the issue's gap bar (20 %).

Run: python benchmarks/bench_characterize_ramp.py [--engine=python|avr] [--ramps=step,0.25MPa/s] [--repeat=N]
"""

from __future__ import annotations

import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mckibben.data.io import read_muscle
from mckibben.errors import UnreachableError
from mckibben.examples import copy_example
from mckibben.models.muscle import Muscle
from mckibben.plant import params as PP
from mckibben.plant.simulator import static_branch_lengths
from mckibben.rig.characterize import _moving, collect_steps, run_characterization
from mckibben.rig.engines import start_device

MUSCLE = Path(__file__).resolve().parents[1] / "src" / "mckibben" / "datasets" / "campaign" / "mpam97" / "muscle.toml"


def run(engine: str, ramp: str, folder: Path) -> None:
    proto = copy_example("characterize.toml", folder)
    text = re.sub(r"^ramp = .*$", f'ramp = "{ramp}"', proto.read_text(), flags=re.M)
    proto.write_text(text)
    with start_device(engine, n_channels=1, boot_time=0.1, **({"unthrottled": True} if engine == "avr" else {})) as dev:
        t0 = time.monotonic()
        r = run_characterization(dev.port, proto, folder / "run", unattended=True, muscle_file=MUSCLE)
        wall = time.monotonic() - t0
    st = collect_steps(folder / "run")
    up = st[(st["direction"] == "inflate") & (st["set_point_Pa"] > 0)]
    over = up["pressure_max_Pa"] - up["set_point_Pa"]
    device = st.groupby("load_index")["time_s"].agg(lambda t: t.max() - t.min()).sum()
    fit = r.summary["fit"]
    print(f"{engine} ramp={ramp}: run {wall:.1f} s wall, sweeps {device:.1f} s device time; inflating overshoot "
          f"mean {over.mean() / 1e3:.1f} kPa, max {over.max() / 1e3:.1f} kPa ({len(over)} steps); peak "
          f"{r.summary['peak_pressure_Pa'] / 1e6:.4f} MPa; friction A_f {fit['friction'].get('friction_area_m2', 0):.3g} m2"
          + (f" (fitted with F_0: F_0 {wc['friction_force_N'] * 1e3:.0f} mN, A_f {wc['friction_area_m2']:.3g} m2)"
             if (wc := fit["friction"].get("with_constant")) else "")
          + (f" (on the loop's width: F_0 {ow['friction_force_N'] * 1e3:.0f} mN [{ow['ci95_N'][0] * 1e3:.0f}, {ow['ci95_N'][1] * 1e3:.0f}], "
             f"A_f {ow['friction_area_m2']:.3g} m2 [{ow['ci95_m2'][0]:.2g}, {ow['ci95_m2'][1]:.2g}], "
             f"{ow['n_widths']} widths, flags {ow['flags'] or 'none'})" if (ow := fit["friction"].get("on_width")) else "")
          + (f" NOT WRITTEN ({fit['friction']['error']})" if "error" in fit["friction"] else ""))
    print("  gap measured / file [mm] (off by): " + ", ".join(
        f"{h['load_N']:.2f} N {h['gap_measured_m'] * 1e3:.3f} / {h['gap_model_m'] * 1e3:.3f} "
        f"({abs(h['gap_model_m'] - h['gap_measured_m']) / h['gap_measured_m'] * 100:.1f} %)"
        for h in fit["hysteresis"].values() if "error" not in h), flush=True)
    print("  gap plant / file at the set-points [mm] (off by): " + ", ".join(
        f"{f:.2f} N {a[:, 0].mean() * 1e3:.2f} / {a[:, 1].mean() * 1e3:.2f} "
        f"({abs(a[:, 1].mean() - a[:, 0].mean()) / a[:, 0].mean() * 100:.0f} %)"
        for f, a in plant_gaps(folder / "run", st).items()), flush=True)


def plant_gaps(out: Path, steps) -> dict:
    """Per load: (plant's gap, muscle file's gap) at each set-point where both branches moved off the vented length
    and the plant's both branches are off its stops. [m]"""
    steps = steps.assign(moved=_moving(steps))
    m = Muscle.from_spec(read_muscle(out / "muscle.toml"))
    gaps = {}
    for f, g in steps.groupby("load_N"):
        rows = []
        for p, h in g.groupby("set_point_Pa"):
            if p == 0 or not h["moved"].all() or set(h["direction"]) != {"inflate", "deflate"}:
                continue
            try:
                up, down = static_branch_lengths(PP.PlantParams(load_force=f), p)
            except UnreachableError:
                continue
            rows.append((float(up[0] - down[0]), float(m.length_for_pressure(p, f, "inflate").length)
                         - float(m.length_for_pressure(p, f, "deflate").length)))
        if rows:
            gaps[float(f)] = np.array(rows)
    return gaps


def main(argv: list[str]) -> None:
    opts = dict(a[2:].split("=", 1) for a in argv if a.startswith("--") and "=" in a)
    engines = opts.get("engine", "python,avr").split(",")
    ramps = opts.get("ramps", "step,0.25MPa/s").split(",")
    for _ in range(int(opts.get("repeat", 1))):
        for engine in engines:
            for ramp in ramps:
                with tempfile.TemporaryDirectory(prefix="bench-ramp-") as tmp:
                    run(engine, ramp, Path(tmp))


if __name__ == "__main__":
    main(sys.argv[1:])
