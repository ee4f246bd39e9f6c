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
# # From model to controller: python-control, friction compensation, a closed speed loop
#
# A model is identified so that a controller can be designed on it. This notebook goes the
# whole way on a simulated rig whose friction and dead zone are hidden from us:
#
# 1. measure a record of the rig and let the doctor find its model;
# 2. export the model's linear part to python-control and design a PI on it (Bode plot);
# 3. close the speed loop on a reversing reference, with and without the friction
#    compensation the doctor's model gives, against compensation from the datasheet and a
#    faster PI;
# 4. close the same loop over Modbus against the rig server.
#
# From a shell the same is `motorid doctor rec.csv --save-model drive.json`, then
# `motorid control --design drive.json --model plant.json --json` (add `--no-compensation`
# for the baseline, or `--daq modbus://127.0.0.1:5020` for a rig behind Modbus).

# %%
import logging
import tempfile
from pathlib import Path

import control
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import Image, display

from motorid.compensation import FrictionCompensation
from motorid.control_design import linearise, nonlinear_system, rest_state
from motorid.diagnose import diagnose
from motorid.drive import Amplifier, Friction, RigidDrive, paper_rig
from motorid.io import ModbusDAQ, RigServer, SimulatedDAQ
from motorid.signals import two_sine_signal
from motorid.speed_control import (
    SpeedController,
    design_speed_pi,
    reversing_reference,
    run_closed_loop,
    tracking_metrics,
)
from motorid.validation import rpm_to_rad_s

logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s", force=True)
pd.set_option("display.width", 160)
WORK = Path(tempfile.mkdtemp(prefix="motorid-06-"))
DT = 0.01
LOW_SPEED = float(rpm_to_rad_s(150.0))  # the paper's low-speed band, 15.7 rad/s

# %% [markdown]
# ## 1. The rig, and what the doctor makes of it
#
# The paper's two-mass rig with a stiff shaft at 100 Hz, with Coulomb friction on both
# masses, a Stribeck hump on the motor and a 0.8 V dead zone in the amplifier. We only look
# at a 60 s record of it, as on a real bench; the doctor, given no input gain, fits a rigid
# drive whose forces are in volts.

# %%
friction = (
    Friction(("coulomb_friction",), {"coulomb": 6e-3}, side="motor"),
    Friction(("coulomb_friction",), {"coulomb": 2e-3}, side="load"),
    Friction(("stribeck_friction",), {"stribeck": 3e-3, "stribeck_velocity": 5.0}, side="motor"),
)
rig = paper_rig(k_s=20.0, B_s=0.02, dt=DT, substeps=20, friction=friction,
                amplifier=Amplifier(dead_zone=0.8, v_max=12.0))  # fmt: skip
_, u = two_sine_signal(duration=60.0, dt=DT, seed=0)
record = rig.simulate(u, seed=1)
doctor = diagnose(record)
model = doctor.model
print("the doctor named:", doctor.named)
print({k: round(v, 5) for k, v in model.params.items()})

# %% [markdown]
# ## 2. The model in python-control, and the PI designed on it
#
# `linearise` gives the drive's linear part about a speed as a continuous `StateSpace` (at
# zero speed the friction's jump is not linear: that is what the compensation cancels).
# `design_speed_pi` tunes a PI for a crossover of 0.2 / dt = 20 rad/s: its integral zero
# cancels the mechanical pole, so the loop is ω_c / s and the closed loop first order.

# %%
plant = linearise(model, speed=20.0)
print(control.ss2tf(plant))
pi = design_speed_pi(model, DT)
print(pi)
loop = pi.transfer_function() * plant
gm, pm, _, wc = control.margin(loop)[:4]
print(f"crossover {wc:.1f} rad/s, phase margin {pm:.0f} degrees")
control.bode_plot([plant, loop], omega_limits=(0.1, 1000), label=["drive", "PI x drive"])
plt.savefig(WORK / "bode.png", dpi=80)
plt.close("all")
display(Image(filename=str(WORK / "bode.png")))

# %% [markdown]
# The whole model, friction and dead zone included, is a python-control `NonlinearIOSystem`
# too: `input_output_response` runs it one sample later than motorid's own simulation
# (python-control's output is the state at the start of a sample, motorid's at its end), to
# the last bit.

# %%
drive_system = nonlinear_system(model)
response = control.input_output_response(
    drive_system, record["t"].to_numpy(), u, initial_state=rest_state(model)
)
assert np.array_equal(response.outputs[1:], model.simulate(u)["y"].to_numpy()[:-1])
print("python-control's simulation of the model equals motorid's")

# %% [markdown]
# ## 3. The closed loop on the simulated rig
#
# A triangle reference of ±40 rad/s, reversing every 2 s. Four controllers, each run on the
# same rig (same noise):
#
# - the PI alone;
# - the PI with the doctor's compensation (from the reference speed);
# - the PI with compensation from the datasheet model: inertia, motor constant and rated
#   friction torque, no dead zone (the amplifier's) and no Stribeck effect;
# - a PI tuned for twice the bandwidth, without compensation.

# %%
_, reference = reversing_reference("triangle", amplitude=40.0, period=4.0, duration=12.0, dt=DT)
gain = rig.K_m / rig.R_a  # N m per volt at rest
datasheet = RigidDrive(
    ("viscous_friction", "coulomb_friction"),
    {"inertia": (rig.J_m + rig.J_l) / gain, "input_gain": 1.0,
     "viscous": (rig.K_m**2 / rig.R_a + rig.B_m + rig.B_l) / gain, "coulomb": 8e-3 / gain},
    DT,
)  # fmt: skip
controllers = {
    "PI": SpeedController(pi, DT),
    "PI + doctor's compensation": SpeedController(pi, DT, FrictionCompensation(model)),
    "PI + datasheet compensation": SpeedController(pi, DT, FrictionCompensation(datasheet)),
    "PI at 2x bandwidth": SpeedController(design_speed_pi(model, DT, bandwidth=2 * pi.bandwidth), DT),
}
runs = {
    name: run_closed_loop(SimulatedDAQ(rig, seed=2), c, reference, progress=False)
    for name, c in controllers.items()
}
table = pd.DataFrame({name: tracking_metrics(r, low_speed=LOW_SPEED) for name, r in runs.items()}).T
table[["rms_error", "low_speed_rms_error", "largest_stuck_after_reversal"]].round(3)

# %% [markdown]
# Tracking through two reversals: without compensation the drive sticks at each reversal
# until the integral has wound up past the friction and the dead zone; the doctor's
# compensation switches with the reference and the drive follows it through zero.

# %%
fig, ax = plt.subplots(figsize=(9, 4))
window = slice(round(1.6 / DT), round(6.4 / DT))
first = next(iter(runs.values()))
ax.plot(first["t"][window], first["reference"][window], "k--", label="reference")
for name, r in runs.items():
    ax.plot(r["t"][window], r["y"][window], label=name)
ax.axhspan(-LOW_SPEED, LOW_SPEED, color="0.9", label="low speed (150 rpm)")
ax.set(xlabel="t [s]", ylabel="speed [rad/s]", title="speed tracking through reversals")
ax.legend(loc="upper right", fontsize=8)
fig.savefig(WORK / "tracking.png", dpi=80)
plt.close(fig)
display(Image(filename=str(WORK / "tracking.png")))
assert (
    table.loc["PI + doctor's compensation", "low_speed_rms_error"]
    < 0.5 * table.loc["PI", "low_speed_rms_error"]
)

# %% [markdown]
# ## 4. The same loop over Modbus
#
# The rig behind a real Modbus TCP server (lock-step: a sample per command), and the
# compensated loop through `ModbusDAQ`. Each command the loop writes also feeds the rig's
# heartbeat watchdog (set to 50 periods here: a busy notebook kernel may pause); closing the DAQ
# commands 0 V. The speed and command registers are
# float32, so the figures equal the simulated ones within their rounding.

# %%
server = RigServer(rig, port=0, seed=2, watchdog_periods=50).start()  # 0.5 s of silence trips it
try:
    daq = ModbusDAQ("127.0.0.1", server.port, dt=DT, timeout=2.0)
    over_modbus = run_closed_loop(
        daq, SpeedController(pi, DT, FrictionCompensation(model)), reference, progress=False
    )
    print(f"voltage at the rig after the run: {server.voltage} V")
finally:
    server.stop()
pd.DataFrame(
    {
        "simulated": tracking_metrics(runs["PI + doctor's compensation"], low_speed=LOW_SPEED),
        "over Modbus": tracking_metrics(over_modbus, low_speed=LOW_SPEED),
    }
).T.round(4)
