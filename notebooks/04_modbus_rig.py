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
# # Online identification over Modbus: the simulated rig behind a real server
#
# On a real rig, motorid talks to the drive through a PLC's Modbus holding registers: it
# writes the voltage command and a heartbeat, and reads back a status word, a sequence
# counter and the measured speed, once per sample. `RigServer` puts the simulated rig
# behind exactly that interface, on a real Modbus TCP server (pymodbus), so the whole
# chain can be tried before a PLC is wired:
#
# 1. start the rig server on 127.0.0.1 (a free port);
# 2. connect a `ModbusDAQ` and identify the drive online with `run_online`;
# 3. look at the estimates and at the rig's watchdog;
# 4. stop the server.
#
# From a shell, the same is `motorid rig serve --port 5020` in one terminal and
# `motorid run --daq modbus://127.0.0.1:5020 --estimator arx-rls --na 4 --nb 4 --duration 60 --out run.csv`
# in another. The rig runs **lock-step** here: it advances one 40 ms sample each time the
# client's heartbeat changes, so a minute of rig time takes a second or two.

# %%
import logging
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from IPython.display import Image, display
from pymodbus.client import ModbusTcpClient

from motorid import figures
from motorid.estimators import create
from motorid.io import ModbusDAQ, RigServer, rig_map_toml, run_online
from motorid.signals import two_sine_signal
from motorid.validation import RPM_PER_RAD_S, rpm_to_rad_s, score_predictions

logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s", force=True)
pd.set_option("display.width", 160)
WORK = Path(tempfile.mkdtemp(prefix="motorid-04-"))

# %% [markdown]
# ## The register map
#
# What a PLC has to provide; `motorid rig map` prints the same TOML, and `--map FILE.toml`
# points both the server and the client at an edited copy (other addresses, CDAB word
# order, scaled 16-bit integers).

# %%
print(rig_map_toml())

# %% [markdown]
# ## 1. Start the rig server
#
# `port=0` lets the operating system pick a free port. The server runs in a background
# thread of this kernel (the command line runs the same class in the foreground). Its
# watchdog follows one rule: a command holds only while its own client heart-beats. In
# lock-step the plant waits for its client, so the watchdog counts commands, not time: more
# than `watchdog_periods` commands in a row without a heartbeat (3 by default, as `motorid rig
# serve`) force 0 V and latch a fault, and a pause of this kernel, however long, is none. (A
# real-time rig, `lockstep=False` or `motorid rig serve --realtime`, counts the clock: 3
# sample periods without a heartbeat.)

# %%
server = RigServer(port=0, seed=0).start()
print(server, "->", server.url)

# %% [markdown]
# One exchange by hand: command 3 V for one sample and read what the rig measured. Closing
# the DAQ commands 0 V.

# %%
with ModbusDAQ("127.0.0.1", server.port, dt=server.dt, timeout=2.0) as daq:
    daq.write(3.0)
    sample = daq.read()
print(sample)

# %% [markdown]
# A client that writes commands and forgets the heartbeat (here pymodbus's own client, writing
# the voltage register four times): the rig holds the first three, and the fourth trips the
# watchdog, which forces 0 V and raises the watchdog bit in the status word. The next client
# to connect acknowledges the latched fault, with a warning in the log.

# %%
volts = server.register_map["voltage_command"]
forgetful = ModbusTcpClient("127.0.0.1", port=server.port)
forgetful.connect()
for _ in range(4):  # commands, never a heartbeat
    forgetful.write_registers(volts.address, volts.encode(3.0), device_id=server.register_map.device_id)
forgetful.close()
print(
    f"watchdog trips: {server.watchdog_trips}, status word {server.status:#06x}, voltage {server.voltage} V"
)
assert server.watchdog_trips == 1 and server.voltage == 0.0

# %% [markdown]
# ## 2. Identify online over Modbus
#
# 60 s of the paper's test signal (1500 samples). Two estimators see every sample: the
# linear ARX model and a Hammerstein model with a dead-zone static block (0.8 V, the width
# notebook 01 finds for this rig). `run_online` appends each sample to a CSV file as it
# goes and returns the record.

# %%
_, u = two_sine_signal(duration=60.0, dt=server.dt, seed=0)
settings = {
    "arx-rls": {"na": 4, "nb": 4},
    "hammerstein-rls": {"na": 4, "nb": 4, "basis": "dead_zone:0.8"},
}
estimators = {name: create(name, **kw) for name, kw in settings.items()}
daq = ModbusDAQ("127.0.0.1", server.port, dt=server.dt, timeout=2.0)
start = time.perf_counter()
record = run_online(daq, estimators, u, duration=None, out=WORK / "run.csv", progress=False)
wall = time.perf_counter() - start
print(
    f"{len(record)} samples = {len(record) * server.dt:g} s of rig time in {wall:.2f} s "
    f"({len(record) / wall:.0f} samples/s over Modbus TCP)"
)
record.iloc[:, :8].head()

# %% [markdown]
# ## 3. The estimates
#
# The final estimates, and the one-step prediction error each estimator made on the way
# (columns `NAME.y_hat` of the record), over the record and at low speed (|y| < 150 rpm).

# %%
for name, est in estimators.items():
    print(f"{name}:")
    for key, value in est.params.items():
        print(f"  {key} = {np.array2string(np.asarray(value), precision=4)}")

y_rec = record["y"].to_numpy()
threshold = float(rpm_to_rad_s(150.0))
predictions = {name: record[f"{name}.y_hat"].to_numpy() for name in estimators}
scores = score_predictions(y_rec, predictions, threshold, skip=50)
(scores[["mse", "low_speed_mse"]] * RPM_PER_RAD_S**2).rename(columns=lambda c: f"{c} [rpm²]").round(1)

# %% [markdown]
# The record holds everything the estimators saw, so identifying from it offline, in one
# compiled pass (`batch_filter`), must give the same estimates as the online loop:

# %%
for name, est in estimators.items():
    offline = create(name, **settings[name])
    offline.batch_filter(record["u"].to_numpy(), y_rec)
    gap = np.max(np.abs(offline.x - est.x))
    print(f"{name}: online and offline estimates differ by at most {gap:.1e}")
    assert gap < 1e-9

# %% [markdown]
# How the Hammerstein estimates settled during the run (the columns the loop recorded), and
# the measured speed against the one-step predictions in the stretch with the most
# low-speed samples:

# %%
t = record["t"].to_numpy()
a_cols = [c for c in record.columns if c.startswith("hammerstein-rls.a")]
b_cols = [c for c in record.columns if c.startswith("hammerstein-rls.b")]
figures.plot_estimates(
    t,
    [("coefficients of A [-]", {c: record[c].to_numpy() for c in a_cols}),
     ("coefficients of B [rad/s per V]", {c: record[c].to_numpy() for c in b_cols})],
    WORK / "estimates.png",
    "Hammerstein-RLS (dead zone 0.8 V) identified over Modbus",
)  # fmt: skip
display(Image(filename=str(WORK / "estimates.png")))
window = figures.low_speed_window(y_rec, round(5.0 / server.dt), threshold, skip=50)
figures.plot_low_speed(t, y_rec, predictions, window, WORK / "low_speed.png")
display(Image(filename=str(WORK / "low_speed.png")))

# %% [markdown]
# ## 4. Stop the server
#
# `stop()` closes every connection and the listener and joins the server thread. (With
# `motorid rig serve`, Ctrl-C or SIGTERM does the same.)

# %%
server.stop()
print(f"running: {server.running}; the CSV of the run: {(WORK / 'run.csv').stat().st_size} bytes")
assert not server.running
