"""The doctor's JSON on a few records, held in ``tests/data/doctor_golden/`` for
``tests/test_doctor_golden.py``: the same record must give the same report, names exactly and
numbers within the test's tolerance, whatever is reorganised inside :mod:`motorid.diagnose`.

The cases (:data:`CASES`): two wheel motors, the joint run of a third one's two records and the
L298N staircase of ``realmotors/``, a 12 s
segment of EMPS (position output, sampled timing), one joint run of two simulated records of one
drive, one simulated record with Coulomb friction planted, and a simulated kit-like motor with
stiction on a sine (rests at one input rate: the ranking's ``lag_test``). Each file holds
``Diagnosis.to_dict()`` as ``motorid doctor --json`` writes it (:func:`motorid.outputs.jsonable`).

Usage::

    python scripts/doctor_golden.py              # rewrite every case whose data are present
    python scripts/doctor_golden.py planted      # one case

Run it only when a change of the doctor's results is intended, and say why in the commit.
The data folder is ``$MOTORID_DATA`` (holding ``realmotors/`` and ``emps/``), else ``../shared/data``
beside the checkout.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "data" / "doctor_golden"
#: The EMPS segment [s]: the first 12 s of the estimation record (the whole takes 25 s).
EMPS_SECONDS = 12.0


def data_root() -> Path:
    """``$MOTORID_DATA`` or ``../shared/data`` beside the checkout."""
    root = os.environ.get("MOTORID_DATA")
    return Path(root) if root else ROOT.parent / "shared" / "data"


def _realmotor(name: str) -> Path:
    return data_root() / "realmotors" / name


def _wheel(name: str) -> Any:
    from motorid.diagnose import diagnose
    from motorid.io.records import read_record

    return diagnose(read_record(_realmotor(name)), input_unit="%", output_unit="rev/s")


def wheel_motor1_train() -> Any:
    """``motorid doctor wheel_free_train_motor1.csv --input-unit % --output-unit rev/s``."""
    return _wheel("wheel_free_train_motor1.csv")


def wheel_motor3_validation() -> Any:
    """``motorid doctor wheel_free_validation_motor3.csv --input-unit % --output-unit rev/s``."""
    return _wheel("wheel_free_validation_motor3.csv")


def l298n_staircase() -> Any:
    """``motorid doctor l298n_staircase.csv --input-unit V --output-unit rpm``."""
    from motorid.diagnose import diagnose
    from motorid.io.records import read_record

    return diagnose(read_record(_realmotor("l298n_staircase.csv")), input_unit="V", output_unit="rpm")


def emps_segment() -> Any:
    """The first :data:`EMPS_SECONDS` of EMPS's estimation record from viscous friction and an
    offset, position output, the motor's input gain."""
    from motorid.datasets import load_emps
    from motorid.diagnose import diagnose

    record = load_emps(_emps_folder(), which="estimation")
    segment = record[record["t"] < record["t"].iloc[0] + EMPS_SECONDS].copy()
    segment.attrs = dict(record.attrs)
    return diagnose(
        segment, output_kind="position", input_gain=record.attrs["input_gain"],
        base=("viscous_friction", "offset"),
    )  # fmt: skip


def wheel_motor2_joint() -> Any:
    """``motorid doctor wheel_free_train_motor2.csv wheel_free_validation_motor2.csv --input-unit %
    --output-unit rev/s``: one model of both records of the motor."""
    from motorid.diagnose import diagnose
    from motorid.io.records import read_record

    names = [f"wheel_free_{w}_motor2.csv" for w in ("train", "validation")]
    return diagnose(
        [read_record(_realmotor(n)) for n in names], input_unit="%", output_unit="rev/s", labels=names
    )


def joint_planted() -> Any:
    """One model of two simulated records of one drive with a dead zone planted (two excitations)."""
    from motorid.diagnose import diagnose
    from motorid.diagnose.synthetic import planted_record

    records = [planted_record("input_dead_zone", seed=7, excitation_seed=e).record for e in (7, 8)]
    return diagnose(records, labels=["first", "second"])


def planted() -> Any:
    """A simulated record with Coulomb friction planted."""
    from motorid.diagnose import diagnose
    from motorid.diagnose.synthetic import planted_record

    return diagnose(planted_record("coulomb_friction", seed=3).record)


def stiction_one_rate() -> Any:
    """A kit-like motor (as ``tests/test_diagnose_stiction_lag.py``: τ = J/B = 27 ms, kinetic
    friction 0.73 V, breakaway 1.25 V) on a 6 V 1 Hz sine at 1 kHz, its speed quantised in
    0.767 rad/s with noise of 2 % of the speed: every rest breaks away at one input rate, and the
    moving drive tells the level from a lag (the static friction candidate's ``lag_test``)."""
    import numpy as np
    import pandas as pd

    from motorid.diagnose import diagnose
    from motorid.drive.rigid import RigidDrive

    dt, gain = 0.001, 0.0298 / 3.6  # s, K_m / R [N m/V]
    params = {"inertia": 6.7e-6, "input_gain": gain, "viscous": 0.0298 * gain, "coulomb": 0.73 * gain,
              "offset": 0.0, "breakaway_excess": (1.25 - 0.73) * gain}  # fmt: skip
    effects = ("viscous_friction", "coulomb_friction", "offset", "static_friction")
    t = np.arange(30_000) * dt
    u = 6.0 * np.sin(2 * np.pi * t)
    w = RigidDrive(effects, params, dt).free_run(u, substeps=10)
    noisy = w + 0.02 * np.abs(w) * np.random.default_rng(0).standard_normal(w.size)
    record = pd.DataFrame({"t": t, "u": u, "y": 0.767 * np.round(noisy / 0.767)})
    record.attrs.update(dt=dt, units={"t": "s", "u": "V", "y": "rad/s"})
    return diagnose(record)


def _emps_folder() -> Path | None:
    from motorid.datasets import EMPS_FILES

    for folder in (data_root(), data_root() / "emps"):
        if all((folder / name).is_file() for name in EMPS_FILES.values()):
            return folder
    return None


def _realmotors(*names: str) -> Callable[[], list[Path | None]]:
    return lambda: [_realmotor(n) for n in names]


#: Case name -> (the diagnosis, the files or folders it reads).
CASES: dict[str, tuple[Callable[[], Any], Callable[[], list[Path | None]]]] = {
    "wheel_motor1_train": (wheel_motor1_train, _realmotors("wheel_free_train_motor1.csv")),
    "wheel_motor3_validation": (wheel_motor3_validation, _realmotors("wheel_free_validation_motor3.csv")),
    "wheel_motor2_joint": (
        wheel_motor2_joint,
        _realmotors("wheel_free_train_motor2.csv", "wheel_free_validation_motor2.csv"),
    ),
    "l298n_staircase": (l298n_staircase, _realmotors("l298n_staircase.csv")),
    "emps_segment": (emps_segment, lambda: [_emps_folder()]),
    "joint_planted": (joint_planted, list),
    "planted": (planted, list),
    "stiction_one_rate": (stiction_one_rate, list),
}


def missing_data(name: str) -> str | None:
    """Why case ``name`` cannot run here (its data absent), or None."""
    if all(path is not None and path.exists() for path in CASES[name][1]()):
        return None
    return f"{name}: its data are not found under {data_root()} (set MOTORID_DATA)"


def report(name: str) -> dict[str, Any]:
    """Case ``name``'s ``Diagnosis.to_dict()`` as plain JSON values."""
    from motorid.outputs import jsonable

    return json.loads(json.dumps(jsonable(CASES[name][0]().to_dict())))


def main(argv: list[str] | None = None) -> int:
    """Write the golden files of the cases named (default: every case whose data are present)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="*", help=f"cases to rewrite (default: all): {', '.join(CASES)}")
    args = parser.parse_args(argv)
    unknown = [name for name in args.cases if name not in CASES]
    if unknown:
        parser.error(f"unknown case {unknown[0]!r}; cases are {', '.join(CASES)}")
    GOLDEN.mkdir(parents=True, exist_ok=True)
    for name in args.cases or list(CASES):
        why = missing_data(name)
        if why:
            print(f"skipped {why}", file=sys.stderr)
            continue
        path = GOLDEN / f"{name}.json"
        path.write_text(json.dumps(report(name), indent=1) + "\n", encoding="utf-8")
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
