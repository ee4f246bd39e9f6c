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
# # A fleet of drives on Dask: who wears, who grew a dead zone
#
# A plant has 50 drives of one design, each logging a record a day. The questions are the
# fleet's: whose friction is rising (wear, lubrication), which drive has an effect its model
# lacks. This notebook generates such a fleet, runs `motorid doctor` on every record on a
# `dask.distributed` cluster (what `motorid fleet doctor` does), and follows each drive's
# friction over 30 days (what `motorid fleet trend` does).
#
# **What is run, to stay within about a minute on a 2-core machine:** 50 drives over 30 days,
# one 30 s record (750 samples at 40 ms) every fifth day, so 6 records per drive and 300 in
# all. The doctor takes 0.1 s per 30 s record on an idle core of this machine (0.3-0.5 s
# while the machine is busy with other work), so a record every day (1500) would take two
# minutes or more on two workers. Shorter records (10-15 s) are faster but make the doctor
# name a spurious dead zone on a few healthy records, and miss the dead zone's first day.

# %%
import functools
import tempfile
import time
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd
from dask.distributed import Client, LocalCluster
from IPython.display import Image, display

from motorid.fleet import DoctorJob, load_results, run
from motorid.fleet.synthetic import make_fleet, write_fleet
from motorid.fleet.trend import flag_drives, friction_trends, plot_trends

pd.set_option("display.width", 160)
WORK = Path(tempfile.mkdtemp(prefix="motorid-05-"))
DAYS = list(range(0, 30, 5))

# %% [markdown]
# ## The fleet
#
# Every drive is the paper's rig without the amplifier dead zone, its constants (armature
# resistance, motor constant, inertias, Coulomb levels, viscous coefficients) each spread by
# ±5 %. Three drives wear: their Coulomb and viscous friction grow by 2 % a day (+50 % by the
# last record, day 25). One drive's amplifier grows a 0.8 V dead zone on day 15. The other 46
# stay as they are. This is the truth the trends should find.

# %%
fleet = make_fleet(
    50, seed=0, wearing=(5, 17, 33), friction_growth=0.02, dead_zone_drive=41, dead_zone_day=15
)
truth = pd.DataFrame(
    [
        {"drive": d.name, "friction growth per day": d.friction_growth, "dead zone from day": d.dead_zone_day}
        for d in fleet
        if not d.healthy
    ]
)
display(truth)

# %% [markdown]
# ## A cluster, the records, the doctor on every record
#
# A `LocalCluster` of two single-threaded worker processes (one per core here; on a real
# cluster, `Client("tcp://HOST:8786")`). The records are written by the workers too, one task
# per drive. Then `motorid.fleet.run` (what `motorid fleet doctor` runs) gives each record a task
# that runs the very work `motorid doctor` does, `DoctorJob` holding its options: the model starts
# from inertia, input gain, Coulomb and viscous friction and an offset; each row is stored in
# `results/results.parquet/` as soon as its record is done.

# %%
cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
client = Client(cluster)

start = time.perf_counter()
write_drive = functools.partial(write_fleet, WORK / "records", days=DAYS, duration=30.0)
paths = sorted(p for written in client.gather(client.map(write_drive, [[d] for d in fleet])) for p in written)
print(f"{len(paths)} records written in {time.perf_counter() - start:.1f} s, e.g. {paths[0].name}")

# %%
job = DoctorJob(base=("coulomb_friction", "viscous_friction", "offset"))  # motorid fleet doctor --base ...
done = run(paths, WORK / "results", job, client=client, figures=False)
print(
    f"doctor: {done.done} done, {done.failed} failed in {done.seconds:.1f} s ({done.done / done.seconds:.1f} records/s)"
)

# %%
results = load_results(WORK / "results")
columns = ["drive", "time", "status", "model.params.coulomb", "model.params.viscous", "named", "run_time_s"]
display(results[columns].head())

# %% [markdown]
# ## The flagged drives
#
# Per drive, the rise of Coulomb and viscous friction over the 30 days (on the least-squares
# line through the estimates, so the few per cent of record-to-record scatter does not flag a
# drive), and the effects that appeared: named by the doctor from some record on, on at least
# half of the records, having been named on fewer than half before. The flagged drives should
# be exactly the four of the truth table.

# %%
trends = friction_trends(results)
flags = flag_drives(trends, results, threshold=0.2, window_days=30)
flagged = flags[flags["flagged"]]
display(flagged)

# %%
found = set(flagged["drive"])
expected = set(truth["drive"])
print(
    "flagged as expected:",
    found == expected,
    "| missed:",
    sorted(expected - found),
    "| false:",
    sorted(found - expected),
)
healthy = flags[~flags["drive"].isin(expected)]
print(
    f"healthy drives: Coulomb rise between {healthy['coulomb_rise'].min():+.1%} and {healthy['coulomb_rise'].max():+.1%}"
)

# %% [markdown]
# ## Their trends
#
# The doctor's estimates are per input unit (the record has no input gain): Coulomb friction in
# V, viscous friction in V s/rad (that one includes the back-EMF, K_m + B R_a / K_m, which the
# wear hardly moves). The dead zone's day is marked; from then on the doctor's model carries a
# `dead_zone` parameter, and the Coulomb level drops as the dead zone takes part of its work.

# %%
figures = plot_trends(trends[trends["drive"].isin(found)], flags, WORK / "trend")
for path in figures:
    display(Image(filename=str(path)))

# %% [markdown]
# The whole fleet at a glance: each drive's Coulomb friction relative to its first record.

# %%
coulomb = trends[trends["parameter"] == "coulomb"].copy()
coulomb["relative"] = coulomb["value"] / coulomb.groupby("drive")["value"].transform("first")
fig, ax = plt.subplots(figsize=(8, 4))
for drive, own in coulomb.groupby("drive"):
    style = {"lw": 2, "label": drive} if drive in found else {"color": "0.8", "lw": 0.8}
    ax.plot(own["time"], own["relative"], **style)
ax.axhline(1.2, color="tab:red", ls=":", lw=1, label="+20 %")
ax.set_ylabel("Coulomb / first record")
ax.legend(ncol=3, fontsize=8)
fig.autofmt_xdate()
plt.show()

# %%
client.close()
cluster.close()
