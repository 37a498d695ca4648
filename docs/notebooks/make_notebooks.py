"""Write the example notebooks from the cells below (run: python docs/notebooks/make_notebooks.py).

The notebooks are kept without outputs; the documentation build executes each in a fresh
Jupyter kernel (myst-nb, tests/test_docs_site.py), so they never rot.
"""

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

HERE = Path(__file__).parent

NOTEBOOKS = {
    "characterize.ipynb": [
        ("md", """# Characterize a muscle, then control it

The whole flow from Python, with the public API only: load the bundled characterization
campaign, fit and compare static models, predict, simulate an open-loop step, identify the
plant, design a PID and a sliding-mode controller, run a closed-loop step, plot each step and
export a time series.

The bundled campaign is **synthetic** (generated from the published parameter sets of
Table I and II and eq. 3 of *Experimental Characterization and Control of Miniaturized
Pneumatic Artificial Muscle*, see [References](../references.md)), so fits land near the
published values."""),
        ("code", """import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import mckibben as mk
from mckibben.control import controller_params, design_pid, fit_step_response, plot_step_fit
from mckibben.datasets.campaign import campaign_muscle_dirs
from mckibben.fit.compare import compare_models
from mckibben.fit.static import fit_cubics, fit_first_order

mk.__version__"""),
        ("md", "## Load the bundled campaign\n\nOne folder per muscle; each holds a `muscle.toml` and the experiment tables."),
        ("code", """folders = {p.name: p for p in campaign_muscle_dirs()}
folder = folders["mpam97"]
spec = mk.read_muscle(folder / "muscle.toml")
iso = mk.read_table(folder / "isotonic.csv")
print(sorted(folders), spec.id, iso.kind)
iso.data.head()"""),
        ("md", "## Fit and compare models\n\nOne cubic in pressure per load (eq. 3), with standard errors and the range it is valid on; then every applicable model on the same data, cross-validated."),
        ("code", """fits = fit_cubics(iso)
pd.DataFrame([f.to_dict() for f in fits.values()])[["condition", "parameters", "r2", "n_points"]]"""),
        ("code", """braid = mk.read_table(folder / "braid_angle.csv")
comparison = compare_models(iso, spec, braid)
scores = pd.DataFrame([s.to_dict() for s in comparison["scores"]]).set_index("model")
scores[["n_parameters", "rmse_m", "cv_rmse_m", "within_20pct"]]"""),
        ("code", """fig, ax = plt.subplots()
(scores["cv_rmse_m"] * 1e3).sort_values().plot.barh(ax=ax)
ax.set_xlabel("cross-validated RMSE of the length [mm]");"""),
        ("md", "## Predict\n\nThe published muscle under 0.6 N, from every registered law with a published parameter set through one calling convention (`mckibben.models.length`), beside the campaign's measurements."),
        ("code", """from mckibben.models import force_laws, length

muscle = mk.get_muscle("mpam97")
pressure = np.linspace(0.05e6, 0.8e6, 76)
measured = iso.data[np.isclose(iso.data["load"], 0.6)]
fig, ax = plt.subplots()
for name in force_laws():  # every registered law with a published parameter set
    pred = length(pressure, "0.6N", muscle, model=name)
    ax.plot(pressure / 1e6, pred.length * 1e3, label=name)
ax.plot(measured["pressure"] / 1e6, measured["length"] * 1e3, ".", label="campaign (synthetic)")
ax.set_xlabel("pressure [MPa]"); ax.set_ylabel("length [mm]"); ax.legend();"""),
        ("md", "## Simulate an open-loop step\n\nThe inlet valve steps from rest; the paper measured a time constant of about 0.09 s (§IV.A)."),
        ("code", """ol = mk.open_loop(supply=0.8e6, load=0.6)
print(ol)
ol.plot();"""),
        ("md", "## Identify\n\nA first-order-plus-dead-time model of the campaign's recorded step, with standard errors, and the model identified on the simulated plant (two steps give the valves' lift-off too)."),
        ("code", """steps_table = mk.read_table(folder / "step_response.parquet")
by_command = fit_first_order(steps_table)          # p0, p_final, tau per command step, with standard errors
pd.DataFrame([f.to_dict() for f in by_command.values()])[["condition", "parameters", "stderr"]]"""),
        ("code", """trial = steps_table.data[steps_table.data["trial"] == 1]   # SI columns: time [s], pressure [Pa]
fit = fit_step_response(trial["time"].to_numpy(), trial["pressure"].to_numpy(), trial["command"].to_numpy())
plot_step_fit(trial["time"], trial["pressure"], [fit])
fit.params, fit.stderr"""),
        ("code", """_, model, _ = mk.identify_plant()
model"""),
        ("md", "## Design a PID and a sliding-mode controller"),
        ("code", """pid = design_pid(model.through_origin(0.55e6), model.tau / 3)   # lambda tuning on the paper's line through the origin
smc = controller_params("smc", model, law="paper", beta=150)    # the paper's law, beta = 150 (Fig. 13)
pid.kp, pid.ki, smc.beta, smc.eps"""),
        ("md", "## Run a closed-loop step and compare"),
        ("code", """steps = {
    "PID": mk.step_response("pid", target=0.55e6, model=model, duration=0.5),
    "SMC, paper's law": mk.step_response("smc", target=0.55e6, law="paper", beta=150, model=model, duration=0.5),
    "SMC, ours": mk.step_response("smc", target=0.55e6, model=model, duration=0.5),
}
fig, ax = plt.subplots()
for name, res in steps.items():
    ax.plot(res.record.t, res.record.pressure[0] / 1e6, label=name)
ax.axhline(0.55, color="k", ls="--", lw=1)
ax.set_xlabel("time [s]"); ax.set_ylabel("pressure [MPa]"); ax.legend()
pd.DataFrame({name: res.metrics for name, res in steps.items()}).T[["time_constant_s", "overshoot_pct", "settling_time_s"]]"""),
        ("code", """steps["SMC, paper's law"].plot();"""),
        ("md", "## Export a time series\n\nSI units, unit-suffixed columns; a Parquet file carries its provenance."),
        ("code", """from mckibben.results import read_provenance

out = Path(tempfile.mkdtemp()) / "smc_step.parquet"
steps["SMC, paper's law"].to_file(out)
back = pd.read_parquet(out)
print(read_provenance(out)["call"], list(back.columns))
back.head()"""),
    ],
    "controllers.ipynb": [
        ("md", """# Design and compare pressure controllers

Fig. 13 of *Experimental Characterization and Control of Miniaturized Pneumatic Artificial
Muscle* on the simulated plant: the paper's sliding-mode law β·tanh(S/ε) at β = 120 and 150,
beside our law with the model term; then the PID against both laws over step sizes and loads,
and a Monte Carlo over plant uncertainty."""),
        ("code", """import pandas as pd

import mckibben.control as mc
import mckibben.experiments as mx"""),
        ("code", """f13 = mx.fig13()
f13"""),
        ("code", """pd.DataFrame(f13.rows)[["law", "beta_counts", "paper_time_constant_s", "time_constant_s", "paper_overshoot_pct", "overshoot_pct"]]"""),
        ("code", """f13.plot();"""),
        ("md", "## PID against sliding mode, over step sizes and loads"),
        ("code", """cmp = mx.compare()
cmp"""),
        ("code", """cmp.plot();"""),
        ("md", "## Robustness: the same three controllers on random plants\n\n±30 % on valve gain, dead band, volumes and leak; supply 0.6–1.0 MPa; load 0–3 N."),
        ("code", """rob = mx.robustness(60, seed=0)
rob.plot()
pd.DataFrame({c: {k: v["median"] for k, v in s.items()} for c, s in rob.metrics.items()})"""),
        ("md", "## Track a pressure trajectory"),
        ("code", """tr = mx.track_pressure(mc.SineReference(0.4e6, 0.1e6, 2.0), duration=1.0)
print(tr.metrics)
tr.plot();"""),
    ],
    "tool.ipynb": [
        ("md", """# Steer the three-muscle tool

The endoscope of §V of *Experimental Characterization and Control of Miniaturized Pneumatic
Artificial Muscle*: three miniature muscles 120° apart bend a disc stack. From a tip target to
pressures (inverse), back to the pose (forward), the reachable workspace, and a tip path
followed by three simulated, pressure-controlled muscles."""),
        ("code", """import mckibben.experiments as mx
import mckibben.tool as mt

tool = mt.make_tool("mpam117", preload=1.0, bending_stiffness=2e-4)  # SI: N, N·m²
state = mt.inverse([0.02, 0.0, 0.11], tool)  # tip x, y, z in m
mt.state_dict(state)["pressures_Pa"]"""),
        ("code", """back = mt.forward(tool, pressures=state.pressures)
back.tip * 1e3  # mm"""),
        ("code", """ws = mt.map_workspace(tool, grid=7)
print(ws)
ws.plot();"""),
        ("md", "## Follow a circle at two speeds"),
        ("code", """trk = mx.track_tip(mt.parse_path("circle:radius=5mm,period=2s"), periods=[2.0, 1.0], tool=tool)
print(trk)
trk.plot();"""),
        ("code", """trk.to_pandas().head()"""),
    ],
    "sweep.ipynb": [
        ("md", """# Run a design sweep

The bundled example sweeps the paper's sliding-mode law over β and ε on random plants (supply,
load, valve dead band and conductance), runs in-process (or on a Dask cluster with
`scheduler=`), and summarizes: the best setting under an overshoot constraint, the Pareto front
and the sensitivities."""),
        ("code", """import tempfile
from pathlib import Path

from mckibben.examples import copy_example
from mckibben.sweep import best_setting, load_sweep, plot_pareto, plot_sensitivity, read_results, run_sweep

work = Path(tempfile.mkdtemp())
spec = load_sweep(copy_example("sweep.toml", work))
spec.n_runs"""),
        ("code", """stats = run_sweep(spec, work / "results")
table = read_results(work / "results")
stats["runs"], table.shape"""),
        ("code", """best_setting(table, "time_constant_s", "overshoot_pct<=10", 0.95)"""),
        ("code", """plot_pareto(table);"""),
        ("code", """plot_sensitivity(table);"""),
    ],
}


def main() -> None:
    for name, cells in NOTEBOOKS.items():
        nb = new_notebook(cells=[new_markdown_cell(src) if kind == "md" else new_code_cell(src) for kind, src in cells])
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        nb.metadata["language_info"] = {"name": "python"}
        nbformat.write(nb, HERE / name)


if __name__ == "__main__":
    main()
