# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Linear ARX against the Hammerstein model: the paper's experiment on the simulated rig
#
# The paper (*Nonlinear modeling and identification of a DC motor for bidirectional
# operation with real time experiments*) drives a two-mass DC motor rig with a sum of
# two sinusoids around 0 V, samples the load speed every 40 ms, and identifies two
# models online by recursive least squares:
#
# - a linear **ARX** model `A(q^-1) y(t) = B(q^-1) u(t) + e(t)`;
# - a **Hammerstein** model: a static polynomial `x = u + gamma_2 u^2 + gamma_3 u^3`
#   followed by the same linear dynamics, by two-step RLS (its eqs. 15-23).
#
# It reports the mean squared error per model order (Table 1) and per polynomial degree
# (Table 2), and shows at low speed, where Coulomb friction and the amplifier's dead zone
# act, that the Hammerstein model follows the drive better (Figs. 9-15).
#
# This notebook repeats that experiment on motorid's simulated rig
# (`motorid.drive.paper_rig()`: Coulomb friction on both masses, a 0.6 V dead zone,
# tacho noise and a 12-bit A/D converter), with the numbers computed here, and goes one
# step beyond the paper: static blocks built from a **dead zone** and a **sign** function
# instead of powers of `u`.
#
# Everything runs in a few seconds; the figures are PNG files written to a temporary folder.

# %%
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from IPython.display import Image, display

from motorid.estimators import HammersteinRLS
from motorid.experiment import dead_zone_width_by_grid, run_paper_experiment
from motorid.validation import RPM_PER_RAD_S, compare_predictions, order_sweep

pd.set_option("display.width", 160)
pd.set_option("display.max_columns", 12)
FIGURES = Path(tempfile.mkdtemp(prefix="motorid-01-"))


def show(name: str) -> None:
    """Display one PNG figure written to FIGURES."""
    display(Image(filename=str(FIGURES / name)))


# %% [markdown]
# ## The test signal and the rig's response (the paper's Fig. 8)
#
# `run_paper_experiment` simulates the default rig for 120 s on the paper's test signal and
# identifies three models online on it: ARX-RLS of order 4, the paper's Hammerstein-RLS
# (order 4, cubic), and a Hammerstein-RLS whose static block is a dead zone, its width
# chosen by a grid search. This is exactly what `make demo` runs.

# %%
experiment = run_paper_experiment(duration=120.0, seed=0, low_speed_rpm=150.0)
record = experiment.record
u, y = record["u"].to_numpy(), record["y"].to_numpy()
rig = record.attrs["rig"]
print(f"{len(record)} samples at dt = {record.attrs['dt']} s")
print(f"amplifier dead zone: +/-{rig['amplifier']['dead_zone']} V; friction: {rig['friction']}")
slow = np.abs(y) < experiment.low_speed_threshold
print(f"|y| < 150 rpm in {slow.mean():.0%} of the samples; |y| max {np.abs(y).max() * RPM_PER_RAD_S:.0f} rpm")
experiment.write_figures(FIGURES)
show("fig08_input_response.png")

# %% [markdown]
# ## Table 1: MSE per model order, linear against Hammerstein
#
# The paper's Table 1 (MSE of the online one-step prediction, in its units, labelled rpm)
# falls steeply from order 1 to order 3 and is flat after; the Hammerstein model (cubic)
# is lower than the linear one at every order, best at order 4. Below, the same sweep on
# the simulated record: MSE in rpm² over the whole record (after a 2 s start-up) and over
# the low-speed samples (|y| < 150 rpm), with the paper's figures beside ours. The
# absolute values cannot match (a different motor, noise and scale); the shape can.

# %%
sweep = order_sweep(u, y, low_speed_threshold=experiment.low_speed_threshold, skip=experiment.skip)
paper_table1 = pd.DataFrame(
    {
        "paper_linear": [55.3203, 29.1033, 21.6595, 21.4769, 22.2718, 22.1547],
        "paper_nonlinear": [47.3696, 28.7214, 20.0978, 19.6518, 21.1327, 22.1244],
    },
    index=pd.Index(range(1, 7), name="order"),
)
table1 = sweep.orders.assign(
    ratio=sweep.orders["mse_nonlinear"] / sweep.orders["mse_linear"],
    low_speed_ratio=sweep.orders["low_speed_mse_nonlinear"] / sweep.orders["low_speed_mse_linear"],
).join(paper_table1.assign(paper_ratio=paper_table1["paper_nonlinear"] / paper_table1["paper_linear"]))
table1.round(3)

# %% [markdown]
# As in the paper, the error drops steeply up to order 2-3 and is flat after, and the
# Hammerstein model is below ARX at every order. Our ratio nonlinear/linear (0.92-0.95
# from order 2 on) is close to the paper's (0.91-1.0). The paper argues that the gain
# concentrates where the nonlinearity acts, around zero speed; on the simulated rig that
# shows directly: the ratio over the low-speed samples is smaller than over the whole record
# at every order. The checks below hold this text to the numbers.

# %%
assert (table1["ratio"] < 1).all(), "Hammerstein below ARX at every order"
assert (table1["low_speed_ratio"] < table1["ratio"]).all(), "the gain is larger at low speed"
assert table1.loc[1, "mse_linear"] > 2 * table1.loc[3, "mse_linear"], "steep drop up to order 3"

# %% [markdown]
# ## Table 2: MSE and gamma per polynomial degree (order 4)
#
# The paper's Table 2 varies the degree n of the static polynomial at order 4 and finds
# n = 3 best, with gamma_2 and gamma_3 of order 1e-2 (in units of 1e-3 below, as the paper
# prints them).

# %%
paper_table2 = pd.DataFrame(
    {
        "paper_mse": [21.8216, 19.6518, 21.0330, 34.5662],
        "paper_gamma_2": [0.43075e-3, 20.686e-3, -0.030586e-3, 0.030137e-3],
        "paper_gamma_3": [np.nan, 82.895e-3, 14.465e-3, -0.23844e-3],
    },
    index=pd.Index(range(2, 6), name="degree"),
)
table2 = sweep.degrees.join(paper_table2)
gammas = [c for c in table2.columns if "gamma" in c]
# gammas in units of 1e-3, as the paper prints gamma_2 and gamma_3
table2.assign(**{c: table2[c] * 1e3 for c in gammas}).rename(
    columns={c: f"{c} [1e-3]" for c in gammas}
).round(3)

# %% [markdown]
# Degree 3 beats degrees 2 and 4 here as in the paper; degree 5 comes close overall and is
# lower at low speed (a higher power bends more sharply near zero). The gammas are of the
# paper's order of magnitude, 1e-2; here both are negative, which makes the static curve
# turn back at large |u| (see the free run below).

# %%
assert table2.loc[3, "mse"] < table2.loc[2, "mse"] and table2.loc[3, "mse"] < table2.loc[4, "mse"]
assert table2.loc[5, "low_speed_mse"] < table2.loc[3, "low_speed_mse"]

# %% [markdown]
# ## One-step prediction flatters: the free run
#
# The paper's MSE is that of the online one-step prediction, which leans on the measured
# past output. A model is only good for simulation and control design if its **free run**
# (simulated from rest on the input alone, with its own past outputs) follows the drive.
# The same sweep, scored on the free run:

# %%
free = order_sweep(
    u, y, low_speed_threshold=experiment.low_speed_threshold, skip=experiment.skip, prediction="free_run"
)
free.orders.round(1)

# %% [markdown]
# In free run the cubic Hammerstein model is still far better than ARX at low speed, but
# over the whole record it is much worse. The reason is its static block: a cubic cannot
# bend sharply at the dead zone and stay monotone, and the identified one
# (gamma_1 = 1, gamma_2 and gamma_3 from Table 2) rises to a peak and then changes sign
# within the range of the test signal, so at large voltages the simulated drive is pushed
# the wrong way. One-step prediction hides this, since the measured output corrects it at
# every sample.

# %%
assert free.orders.loc[4, "mse_nonlinear"] > free.orders.loc[4, "mse_linear"]
assert free.orders.loc[4, "low_speed_mse_nonlinear"] < free.orders.loc[4, "low_speed_mse_linear"]
cubic = next(run.estimator for label, run in experiment.runs.items() if "degree 3" in label)
gamma = cubic.params["gamma"]
u_grid = np.linspace(-6.0, 6.0, 9)
static = pd.DataFrame(
    {"u [V]": u_grid, "x = u + g2 u^2 + g3 u^3": u_grid + gamma[1] * u_grid**2 + gamma[2] * u_grid**3}
)
print(f"gamma = {np.round(gamma, 4)}; test signal |u| <= {np.abs(u).max():.2f} V")
assert (np.sign(static.iloc[:, 1]) != np.sign(u_grid)).any(), "the static curve changes sign inside the range"
static.round(2).transpose()

# %% [markdown]
# ## Beyond the paper: dead-zone and sign bases in the same table
#
# `HammersteinRLS` takes any basis for its static block (`basis="u,sign"`,
# `"dead_zone:0.8"`, `"poly:3,sign"`, ...). The paper's physics suggests two: the
# amplifier's **dead zone** (no torque for |u| < d) and a **sign** term, the input-side
# image of Coulomb friction. The dead-zone width d is found by a grid search on the
# one-step error. All at order 4, on the same record; MSE in rpm².

# %%
d = dead_zone_width_by_grid(u, y, 4, np.round(np.arange(0.0, 2.01, 0.1), 2), skip=experiment.skip)
bases = {
    "u (linear: ARX)": "u",
    "u, u^2": "poly:2",
    "u, u^2, u^3 (the paper)": "poly:3",
    "u .. u^5": "poly:5",
    "u, sign(u)": "u,sign",
    "u, u^2, u^3, sign(u)": "poly:3,sign",
    f"dead zone d = {d:g} V": f"dead_zone:{d}",
    f"dead zone d = {d:g} V, sign(u)": f"dead_zone:{d},sign",
}
rows = {}
for label, spec in bases.items():
    est = HammersteinRLS(4, 4, basis=spec)
    scores = compare_predictions(est, u, y, experiment.low_speed_threshold, skip=experiment.skip)
    rows[label] = {
        "parameters": est.dim_x,
        "one_step_mse": scores.loc["one_step", "mse"] * RPM_PER_RAD_S**2,
        "one_step_low_speed_mse": scores.loc["one_step", "low_speed_mse"] * RPM_PER_RAD_S**2,
        "free_run_mse": scores.loc["free_run", "mse"] * RPM_PER_RAD_S**2,
        "free_run_low_speed_mse": scores.loc["free_run", "low_speed_mse"] * RPM_PER_RAD_S**2,
        "gamma": np.round(est.params["gamma"], 4),
    }
basis_table = pd.DataFrame.from_dict(rows, orient="index")
basis_table.index.name = "static block (order 4)"
basis_table.round(1)

# %% [markdown]
# The dead-zone block wins on every column with fewer parameters than the cubic: the
# one-step error falls by more than half against ARX and the free-run error by a factor of
# about 50, at low speed as well as overall. The width found, about 0.8 V, is more than the
# amplifier's 0.6 V: Coulomb friction holds the drive still until the torque exceeds it,
# which for this motor takes about another 0.3 V (T_c R_a / K_m), so friction and dead zone
# act together as one wider dead zone seen from the input (the field's known hard case: in
# the equation error the two look alike). A sign term lowers the one-step error of the
# linear and the cubic block but raises their free-run error at low speed, and on top of
# the dead zone it makes the model slightly worse.

# %%
best = basis_table.drop(columns=["parameters", "gamma"]).idxmin()
assert (best == f"dead zone d = {d:g} V").all(), best
assert 0.6 <= d <= 1.0
b = basis_table
for plain, signed in [("u (linear: ARX)", "u, sign(u)"), ("u, u^2, u^3 (the paper)", "u, u^2, u^3, sign(u)")]:
    assert b.loc[signed, "one_step_mse"] < b.loc[plain, "one_step_mse"]
    assert b.loc[signed, "free_run_low_speed_mse"] > b.loc[plain, "free_run_low_speed_mse"]

# %% [markdown]
# ## Figures like the paper's Figs. 9-15
#
# **Figs. 9-11** of the paper: measured speed (solid) and identified output (dashed) over
# stretches of very low speed, linear model above, nonlinear below. Ours: the 5 s window
# with the most low-speed samples, one panel per model, first the online one-step prediction
# (the paper's), then the free run.

# %%
show("fig09_low_speed_one_step.png")

# %%
show("fig10_low_speed_free_run.png")

# %% [markdown]
# In one-step prediction the ARX and cubic models ring around zero while the drive sits
# still and overshoot where it stops; the dead-zone model stays quiet with the drive. In
# free run the difference is plain: ARX and the cubic model never stop, they swing through
# the stuck phases as if the drive turned freely, while the dead-zone model holds still
# with it.
#
# **Fig. 12** of the paper: the identification error y - y_hat over the whole record, linear
# above, nonlinear below; the nonlinear error is smaller and settles sooner.

# %%
show("fig12_identification_error.png")

# %% [markdown]
# **Figs. 13-15** of the paper: the estimates converging, coefficients of A and B for the
# linear model (Fig. 13), of Ã and B̃ for the nonlinear one (Fig. 14) and its gammas (Fig. 15).
# The paper notes that the linear estimates take longer to settle.

# %%
for label in experiment.runs:
    slug = label.lower().replace(" ", "_").replace(",", "").replace("-", "_")
    show(f"fig13_estimates_{slug}.png")

# %% [markdown]
# ## Summary
#
# - Table 1 and Table 2 come out in the paper's shape: error flat from order 3, Hammerstein
#   below ARX at every order, degree 3 better than 2 and 4, and the gain concentrated at low
#   speed.
# - Scored on the free run rather than the one-step prediction, the cubic static block is a
#   poor model of a dead zone; a dead-zone static block (with d found by a grid search) is
#   the best model on every measure here, with 9 parameters.
# - The same comparison from the command line: `motorid demo --out out` and
#   `motorid sweep out/demo_record.csv --prediction free_run`.

# %%
experiment.table().round(1)
