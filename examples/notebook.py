# %% [markdown]
# # rover-power from a notebook
#
# The demo's three runs (a simulated Husky A200 on loose sand driving the thesis' turn set),
# loaded as DataFrames, their power plotted against R/R′ beside the fitted model, diagnosed,
# and a path planned with the model the diagnosis wrote. Runs as a script too:
#
#     host-tool demo                       # writes demo-out/
#     pip install ./python matplotlib
#     python examples/notebook.py demo-out power-vs-radius-python.png
#
# Each `# %%` is a cell (VS Code, Jupyter with jupytext, Spyder).

# %%
import sys
from pathlib import Path

try:
    import matplotlib
except ModuleNotFoundError:
    sys.exit("this example draws with matplotlib, which rover_power does not need: pip install matplotlib")

matplotlib.use("Agg")  # a file, not a window; drop this line in a notebook
import matplotlib.pyplot as plt
import pandas as pd

import rover_power as rp

demo = Path(sys.argv[1] if len(sys.argv) > 1 else "demo-out")
figure_path = Path(sys.argv[2] if len(sys.argv) > 2 else "power-vs-radius-python.png")
runs = sorted(demo.glob("run-?.mcap"))

# %% [markdown]
# ## The samples
# One row per sample, indexed by time; the run's events (recording started, wall clock,
# stopped) are in `attrs`.

# %%
first = rp.read_run(runs[0])
first["power_w"] = (
    first.left_bus_v * first.left_current_a + first.right_bus_v * first.right_current_a
)
print(f"{runs[0]}: {len(first)} samples over {first.index[-1] - first.index[0]:.1f} s")
print(f"energy drawn by both motor drivers: {first.power_w.sum() * 0.005 / 1e3:.2f} kJ")
print("events:", [e["kind"] for e in first.attrs["events"]])

# %% [markdown]
# ## Power against R/R′ (thesis Fig. 5.3's axes)
# `validate` cuts the runs into manoeuvres and fits the ICR model; its report is
# `host-tool validate --json`'s, as a dict.

# %%
report = rp.validate(None, runs)
turns = pd.DataFrame(
    {
        "run": m["run"],
        "r_over_r_prime": m["r_over_r_prime"],
        "measured_w": m["avg_power_w"]["total"],
        "model_w": (m["fit"] or {}).get("predicted_w"),
    }
    for m in report["manoeuvres"]
    if m["kind"] == "turn"
)
print(turns.groupby("r_over_r_prime")[["measured_w", "model_w"]].mean().round(1))

fig, ax = plt.subplots(figsize=(7, 4.5))
for (run, of), marker in zip(turns.groupby("run"), "osD^v"):
    ax.plot(of.r_over_r_prime, of.measured_w, marker, mfc="none", ms=8, label=f"measured, {Path(run).name}")
model = turns.groupby("r_over_r_prime").model_w.mean()
ax.plot(model.index, model.values, "k-", label="fitted ICR model")
ax.set_xlabel("R / R′")
ax.set_ylabel("average power, both sides [W]")
ax.set_title("Husky A200 on sand (simulated): power against turn radius")
ax.legend()
fig.tight_layout()
fig.savefig(figure_path, dpi=120)
print(f"figure: {figure_path}")

# %% [markdown]
# ## Where the model departs, and why
# The same report as `host-tool diagnose --json`.

# %%
diagnosis = rp.diagnose(None, runs)
print(f"verdict: {diagnosis['effect']} at {diagnosis['regime']}")
for next_run in diagnosis["next_runs"]:
    print("drive next:", next_run)

# %% [markdown]
# ## Plan with the diagnosed model
# `diagnose --out` writes `model.toml`; the demo wrote one in `demo-out/diagnosis/`.

# %%
plan = rp.plan(90, 90, 10, model=demo / "diagnosis" / "model.toml")
print(
    f"CLC path {plan['clc']['energy_j']:.0f} J against point turns {plan['plp']['energy_j']:.0f} J"
    f" (saves {plan['saving_pct']:.1f} %)"
)
