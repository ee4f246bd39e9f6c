"""The EMPS benchmark's own figure for the doctor's models, beside the published ones.

Runs ``motorid doctor`` on the train set (``DATA_EMPS``: position output, force = gtau * vir,
starting from inertia + viscous friction + offset) and scores each model of its sequence
by the benchmark's protocol (:func:`motorid.datasets.emps_benchmark_rmse`): the position of
the test set ``DATA_EMPS_PULSES`` simulated from vir alone, the state read from its first 20
positions, RMSE in mm after them. Each model is scored as the doctor fits it (to the torque
balance) and with its parameters refitted to the train set's position
(:func:`motorid.diagnose.position.refit_in_position`), then the doctor's own last stage: its
final model refitted to the train set's free-run position by the doctor
(:attr:`Diagnosis.position_model <motorid.diagnose.results.Diagnosis.position_model>`, on the
settled span of the low-passed position it prepared). The test set is never fitted. Prints
the markdown table docs/guide/emps.md shows between the markers ``<!-- emps:begin -->`` and
``<!-- emps:end -->``.

Usage::

    python scripts/emps_benchmark.py [FOLDER]   # FOLDER holds the .mat files; default $MOTORID_DATA

``tests/test_diagnose_emps.py`` holds that page's table to this script's output.
"""

from __future__ import annotations

import argparse
import sys

import pandas as pd

from motorid.datasets import EMPS_BENCHMARK_RESULTS, emps_benchmark_rmse, load_emps_benchmark

BEGIN, END = "<!-- emps:begin -->", "<!-- emps:end -->"
#: The doctor's starting model on EMPS: what an engineer who forgot friction at rest writes.
BASE = ("viscous_friction", "offset")


def run_doctor(train: pd.DataFrame):
    """``motorid doctor`` on the train set, as the EMPS page's command runs it."""
    from motorid.diagnose import diagnose

    return diagnose(train, output_kind="position", input_gain=train.attrs["input_gain"], base=BASE)


def benchmark_table(diagnosis, train: pd.DataFrame, test: pd.DataFrame) -> str:
    """Each model of the doctor's sequence by the benchmark's protocol, as fitted and refitted in
    position on ``train``, the doctor's final model refitted in position by the doctor, then the
    published figures."""
    from motorid.diagnose.position import refit_in_position

    lines = [
        "| model | effects | test-set RMSE [mm], doctor's fit | refitted in position on the train set |",
        "| --- | --- | ---: | ---: |",
    ]
    for label, model in diagnosis.models:
        name = "doctor, start" if label == "initial" else f"doctor, {label}"
        fitted = emps_benchmark_rmse(model, test)
        refitted = emps_benchmark_rmse(refit_in_position(model, train), test)
        lines.append(f"| {name} | {', '.join(model.effects)} | {fitted:.2f} | {refitted:.2f} |")
    final = diagnosis.position_model
    figure = emps_benchmark_rmse(final, test)
    lines.append(
        f"| doctor, final, refitted in position by the doctor | {', '.join(final.effects)} | | {figure:.2f} |"
    )
    for name, figure in EMPS_BENCHMARK_RESULTS.items():
        lines.append(f"| {name} (published) | black box | {figure:g} | |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "folder", nargs="?", help="folder holding the EMPS .mat files (default: $MOTORID_DATA)"
    )
    args = parser.parse_args(argv)
    train, test = load_emps_benchmark(args.folder)
    print(benchmark_table(run_doctor(train), train, test))
    return 0


if __name__ == "__main__":
    sys.exit(main())
