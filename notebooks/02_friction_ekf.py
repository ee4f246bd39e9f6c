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
# # Learning friction online: the friction EKF and UKF
#
# The RLS estimators of notebook 01 fit a black-box input-output model. The friction
# filters keep the physics instead: they track the two-mass drive's state (motor speed,
# load speed, shaft twist) and, appended to it as random walks, the friction parameters
# to learn: the Coulomb level $T_c$ [N m] and the viscous coefficient $B$ [N m s/rad]
# (Stribeck and asymmetry as options). The rest of the drive (armature, inertias, shaft,
# amplifier, tacho) is taken as known from the rig's data sheet: `FrictionEKF.from_rig`.
#
# Per 40 ms sample the filter integrates the nonlinear model in sub-steps, with the
# Karnopp stick/slip rule at zero speed, and sets its own Jacobian F. The UKF uses the
# same compiled model and needs no Jacobian.
#
# Here:
# 1. a rig whose friction law is the filters' (Coulomb + viscous on the motor) and the
#    paper's two-sine test signal, 60 s;
# 2. both filters learning $T_c$ and $B$, against the truth, with their ±2σ bands;
# 3. the consistency check: the normalised innovation squared (NIS) against its χ² band;
# 4. what the NIS shows when the rig has an effect the model lacks (Stribeck friction).

# %%
import time
import warnings

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import display

from motorid.drive import Friction, paper_rig
from motorid.estimators import FrictionEKF, FrictionUKF
from motorid.signals import two_sine_signal

pd.set_option("display.width", 160)
CHI2_1_BAND = (0.000982, 5.0239)  # two-sided 95 % band of chi-square with 1 degree of freedom

# %% [markdown]
# ## The rig and the record
#
# The paper's rig with its friction on the motor mass: Coulomb 6 mN m, viscous
# 3e-5 N m s/rad. The output is the load speed from the tachogenerator (10 mV noise)
# through the 12-bit A/D converter, sampled every 40 ms.

# %%
TRUE = {"coulomb": 6e-3, "viscous": 3e-5}
brushes = Friction(("coulomb_friction",), {"coulomb": TRUE["coulomb"]}, side="motor")
rig = paper_rig(friction=(brushes,), B_m=TRUE["viscous"], B_l=0.0)
t, u = two_sine_signal(60.0, rig.dt, seed=1)
record = rig.simulate(u, seed=1)
y = record["y"].to_numpy()

fig, ax = plt.subplots(2, 1, figsize=(10, 4.5), sharex=True)
ax[0].plot(t, u, lw=0.8)
ax[0].set_ylabel("u [V]")
ax[1].plot(t, y, lw=0.8)
ax[1].set_ylabel("load speed [rad/s]")
ax[1].set_xlabel("t [s]")
fig.suptitle("The two-sine test signal with its quiet stretches, and the measured speed")
fig.tight_layout()

# %% [markdown]
# ## Both filters on the same record
#
# The priors are deliberately off: $T_c$ starts at 5 mN m and $B$ at 5e-5 N m s/rad
# (`from_rig` alone would start from the rig's own friction, here the truth).
# `batch_filter` returns the estimate and the diagonal of P after every sample, which is
# what the bands below are drawn from.

# %%
GUESS = {"coulomb0": 5e-3, "viscous0": 5e-5}
results, timings = {}, {}
for name, cls in (("EKF", FrictionEKF), ("UKF", FrictionUKF)):
    est = cls.from_rig(rig, **GUESS)
    start = time.perf_counter()
    results[name] = (est, est.batch_filter(u, y))
    timings[name] = (time.perf_counter() - start) / len(u) * 1e6

rows = []
for name, (est, _) in results.items():
    for key, truth in TRUE.items():
        rows.append(
            {
                "filter": name,
                "parameter": key,
                "truth": truth,
                "estimate": est.params[key],
                "std": est.params[f"{key}_std"],
                "error %": 100 * (est.params[key] - truth) / truth,
                "unit": est.param_units[key],
            }
        )
summary = pd.DataFrame(rows)
print({name: f"{us:.0f} us/sample" for name, us in timings.items()})
display(summary)

# %%
fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
for ax, key in zip(axes, TRUE, strict=True):
    for name, colour in (("EKF", "C0"), ("UKF", "C1")):
        est, res = results[name]
        i = est.state_names.index(key)
        mean, std = res.x[:, i], np.sqrt(res.P_diag[:, i])
        ax.plot(t, mean, colour, lw=1.0, label=f"{name} estimate")
        ax.fill_between(t, mean - 2 * std, mean + 2 * std, color=colour, alpha=0.2, label=f"{name} ±2σ")
    ax.axhline(TRUE[key], color="k", ls="--", lw=1.0, label="truth")
    ax.set_ylabel(f"{key} [{est.param_units[key]}]")
axes[0].legend(ncol=5, fontsize=8, loc="upper right")
axes[0].set_ylim(0, 2.5 * TRUE["coulomb"])
axes[1].set_ylim(0, 3 * TRUE["viscous"])
axes[1].set_xlabel("t [s]")
fig.suptitle("Friction learned online against the truth")
fig.tight_layout()

# %% [markdown]
# The Coulomb level is learned during the reversals and the slow stretches, where it is
# most of the torque balance; while the drive is stuck (speed exactly zero) the filter
# learns nothing about friction, which is the Karnopp rule's consequence, stated in the
# model's docstring. The viscous coefficient needs the fast stretches.
#
# ## Consistency: the normalised innovation squared
#
# With a correct model, NIS = y²/S is χ²(1): inside its two-sided 95 % band on about
# 95 % of samples.

# %%
for name, (_, res) in results.items():
    nis = res.innovation**2 / res.S
    inside = np.mean((nis >= CHI2_1_BAND[0]) & (nis <= CHI2_1_BAND[1]))
    print(f"{name}: NIS inside its 95 % band on {100 * inside:.1f} % of samples, mean NIS {nis.mean():.2f}")

# %% [markdown]
# ## A rig the model does not describe
#
# The same rig with Stribeck friction: a breakaway torque twice the Coulomb level,
# decaying as exp(-α2 |ω|) with α2 = 0.5 s/rad. A filter told only of Coulomb + viscous
# friction still returns numbers; the NIS says not to trust them: its mean over a window
# stays well above its expectation of 1. The default `divergence_nis = 25` catches a
# filter that has lost track; a tighter threshold turns a steady misfit like this one
# into a warning (`on_divergence="warn"`) or a `FilterDivergenceError` naming the sample
# (`"raise"`). Adding the missing term (`stribeck=True`, with α2 known) brings the NIS
# back to 1 and learns the Stribeck excess α1 as well.

# %%
stribeck_rig = rig.replace(
    friction=(
        Friction(
            ("coulomb_friction", "stribeck_friction"),
            {"coulomb": TRUE["coulomb"], "stribeck": TRUE["coulomb"], "stribeck_velocity": 2.0},
            side="motor",
        ),
    )
)
y_stribeck = stribeck_rig.simulate(u, seed=1)["y"].to_numpy()
mismatched = FrictionEKF.from_rig(
    stribeck_rig, stribeck=False, divergence_nis=2.0, on_divergence="warn", **GUESS
)
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    res_mismatched = mismatched.batch_filter(u, y_stribeck)
print("first warning:", str(caught[0].message) if caught else None)
matched = FrictionEKF.from_rig(stribeck_rig, stribeck0=0.0, **GUESS)  # Stribeck on, α2 = 0.5 from the rig
res_matched = matched.batch_filter(u, y_stribeck)
display(
    pd.DataFrame(
        {
            "model": ["Coulomb + viscous", "Coulomb + viscous + Stribeck"],
            "mean NIS": [np.mean(r.innovation**2 / r.S) for r in (res_mismatched, res_matched)],
            "coulomb [N m]": [mismatched.params["coulomb"], matched.params["coulomb"]],
            "stribeck [N m]": [np.nan, matched.params["stribeck"]],
            "viscous [N m s/rad]": [mismatched.params["viscous"], matched.params["viscous"]],
        }
    )
)

# %%
window = 50
fig, ax = plt.subplots(figsize=(10, 3))
for label, res in (
    ("rig = model (Coulomb + viscous)", results["EKF"][1]),
    ("rig has Stribeck friction, model does not", res_mismatched),
    ("Stribeck added to the model", res_matched),
):
    ax.semilogy(t, pd.Series(res.innovation**2 / res.S).rolling(window).mean(), lw=1.0, label=label)
ax.axhline(1.0, color="k", ls="--", lw=1.0, label="expectation")
ax.set_xlabel("t [s]")
ax.set_ylabel(f"NIS, mean over {window} samples")
ax.legend(fontsize=8)
fig.tight_layout()
