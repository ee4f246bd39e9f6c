"""The doctor on the real motors of ``realmotors/``: each record alone, then one joint run per motor.

For the teaching-kit motor (six records: two runs each of a 0.5 Hz sine, a 1 Hz sine and a chirp)
and each of the four wheel motors (a train and a validation record), prints one markdown table
row per run: the base structure, the effects named (``~`` marks a lookalike the rule named, the
other one in brackets), the kinetic friction level and the inertia with one standard error (the
inertia with the share of the input force its term carries, ``n.d.`` where the record does not
determine it: :attr:`~motorid.diagnose.results.Diagnosis.undetermined`; where it trades with the
input delay, ``J + B τ_d``, what the record determines), the final free-run gap, the noise floor, the gap in noise floors, and the wall time. The joint run
fits one model to all records of the motor (``motorid doctor A.csv B.csv ...``), and adds the
spread τ between its records beyond their errors where there is one, with the error of the motor's
level it gives (:attr:`~motorid.diagnose.agreement.Agreement.drive_std`).

Usage::

    python scripts/realmotors_doctor.py                 # every motor
    python scripts/realmotors_doctor.py --motors kit    # the kit motor only
    python scripts/realmotors_doctor.py --write         # and replace the table in docs/guide/realmotors.md

The data folder is ``$MOTORID_DATA`` (holding ``realmotors/``), else ``../shared/data`` beside
the checkout. Units as ``motorid doctor`` reads them: the kit's input in % duty, its speed in
rad/s; the wheels' ``--input-unit % --output-unit rev/s``. Forces are per input unit (%).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "guide" / "realmotors.md"  # the user guide's page on real motors
BEGIN, END = "<!-- realmotors:begin -->", "<!-- realmotors:end -->"

#: Motor -> (record names, output unit as read by ``--output-unit``).
MOTORS = {
    "kit": (
        [f"kit_{s}_run{r}" for s in ("sine_0.5hz", "sine_1hz", "chirp") for r in (1, 2)],
        None,
    ),
    **{
        f"wheel {m}": ([f"wheel_free_{w}_motor{m}" for w in ("train", "validation")], "rev/s")
        for m in (1, 2, 3, 4)
    },
}


def data_folder() -> Path:
    """``$MOTORID_DATA/realmotors`` or ``../shared/data/realmotors`` beside the checkout."""
    root = os.environ.get("MOTORID_DATA")
    return Path(root) / "realmotors" if root else ROOT.parent / "shared" / "data" / "realmotors"


def read(name: str, output_unit: str | None):
    """A record as ``motorid doctor NAME.csv --input-unit % [--output-unit UNIT]`` reads it."""
    from motorid.io.records import read_record
    from motorid.units import convert_record

    return convert_record(read_record(data_folder() / f"{name}.csv"), "%", output_unit)


def row(motor: str, run: str, d, seconds: float) -> str:
    """One markdown row of a diagnosis."""
    looks = {x.named: [n for n in x.gaps if n != x.named] for x in d.lookalikes}
    named = (
        ", ".join(f"{n}" + (f" ~({', '.join(looks[n])})" if n in looks else "") for n in d.named) or "none"
    )
    structure = ", ".join(f"{v * 1e3:.1f} ms" for v in d.structure.params.values()) or "none"
    params, std = d.model.params, d.param_std
    kinetic = params.get("coulomb", params.get("input_gain", 1.0) * params.get("dead_zone", float("nan")))
    k_std = std.get("coulomb", float("nan"))
    kinetic_cell = f"{kinetic:.3g} ± {k_std:.2g}"
    runs_of = {a.parameter: a for a in d.agreement}  # the joint run: how its records spread
    spread = runs_of.get("coulomb")
    if spread is not None and spread.spread > 0.0:  # the joint run: the spread between the runs
        kinetic_cell += f" (runs spread {spread.spread:.2g}: ± {spread.drive_std:.2g})"
    floors = d.final_gap.overall / d.noise_floor
    inertia = f"{params['inertia']:.3g} ± {std.get('inertia', float('nan')):.2g}"
    share = f"{100 * d.param_share.get('inertia', float('nan')):.1f} %"
    trade = d.delay_trade
    if "inertia" in d.undetermined and trade is not None and trade.inertia_traded:
        effective = f"{trade.effective_inertia:.3g} ± {trade.effective_inertia_std:.2g}"
        runs = runs_of.get("effective_inertia")
        if runs is not None and runs.spread > 0.0:
            effective += f" (runs spread {runs.spread:.2g}: ± {runs.drive_std:.2g})"
        inertia = f"n.d. ({share}; fit {inertia}; J + B τ_d = {effective})"
    elif "inertia" in d.undetermined:
        inertia = f"n.d. ({share}; fit {inertia})"
    else:
        inertia = f"{inertia} ({share})"
    return (
        f"| {motor} | {run} | {structure} | {named} | {kinetic_cell} | {inertia} | "
        f"{d.initial_gap.overall:.3g} → {d.final_gap.overall:.3g} | {d.noise_floor:.3g} | {floors:.1f} | "
        f"{rests(d)} | {seconds:.1f} |"
    )


def rests(d) -> str:
    """The rests of a run: how many, and the breakaway above the final model's kinetic level (with
    one standard error; ``lag?`` where the input rose alike at every breakaway, so that a level
    cannot be told from a lag between input and force; ``bracketed N`` where fewer than 3 read it
    and N of them the input stepped past it within a sample)."""
    from motorid.diagnose.measures import breakaway

    count = sum(r.count for r in d.rests)
    found = breakaway(d._pool, d.model)  # a joint run's pooled rests, as the doctor judged them
    if not count:
        return "0"
    if not math.isfinite(found.excess) and found.bracketed:
        return f"{count}, bracketed {found.bracketed}"
    if found.one_rate or not math.isfinite(found.excess):
        return f"{count}, lag?"
    return f"{count}, {found.excess:.2g} ± {found.standard_error:.1g}"


def joint_label(count: int) -> str:
    return f"**joint, {count} records**"


def motor_rows(motor: str) -> list[str]:
    """The rows of one motor: each record's run, then the joint run."""
    from motorid.diagnose import diagnose

    names, unit = MOTORS[motor]
    records = [read(name, unit) for name in names]
    runs = [(name, record, {}) for name, record in zip(names, records, strict=True)]
    runs.append((joint_label(len(names)), records, {"labels": names}))
    rows = []
    for name, record, options in runs:
        start = time.perf_counter()
        d = diagnose(record, **options)
        rows.append(row(motor, name, d, time.perf_counter() - start))
        print(rows[-1], file=sys.stderr, flush=True)
    return rows


def table(motors: list[str]) -> str:
    """The markdown table: each record's run, then the motor's joint run."""
    from motorid.diagnose.model import DELAY_TRADE_LIMIT, DELAY_TRADE_SHARE
    from motorid.diagnose.results import INERTIA_SHARE_LIMIT

    lines = [
        "| motor | run | input delay | effects named | kinetic friction [%] | inertia [% s²/rad] "
        "| gap [rad/s] | noise floor [rad/s] | final gap [floors] | rests, breakaway above kinetic [%] | time [s] |",
        "| --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for motor in motors:
        lines += motor_rows(motor)
    lines += [
        "",
        "Forces per input unit (% duty); ± one standard error (a block sandwich over 20 blocks of each run's "
        "fitted rows); joint runs: where the records, each fitted alone with the joint structure, spread "
        "beyond their errors, that spread τ and the error of the motor's level with it (`runs spread τ: ± "
        "σ`); inertia: with the share of the input force that goes into acceleration, `n.d.` (not "
        f"determined) below {100 * INERTIA_SHARE_LIMIT:g} % or where it trades with the input delay through the "
        "viscous friction (set free in the balance, the delay moves it by more than "
        f"{DELAY_TRADE_LIMIT:g} standard errors and {100 * DELAY_TRADE_SHARE:g} %: then `J + B τ_d`, what the run "
        "determines), its fitted value kept "
        "for the free run; `~(...)`: a "
        "lookalike the rule named "
        "(the other in brackets); rests: how many, and the force at breakaway above the final model's "
        "kinetic level at an input rising infinitely slowly (`lag?`: every breakaway came at one input rate, "
        "where a breakaway level and a lag between input and force look alike; `bracketed N`: fewer than 3 "
        "rests read it, and at N the input stepped past it within a sample). Generated by "
        "`python scripts/realmotors_doctor.py`.",
    ]
    return "\n".join(lines)


def page_rows(text: str) -> dict[tuple[str, str], str]:
    """The table rows between the markers of ``text``, by (motor, run), without the time column
    (the one figure that changes from run to run)."""
    block = text.split(BEGIN, 1)[1].split(END, 1)[0]
    rows = [line for line in block.splitlines() if line.startswith("| ") and not line.startswith("| motor")]
    return {tuple(cell.strip() for cell in line.split("|")[1:3]): without_time(line) for line in rows}


def without_time(line: str) -> str:
    """A table row without its last cell (the wall time)."""
    return line.rstrip(" |").rsplit("|", 1)[0]


def replace_block(text: str, block: str) -> str:
    """``text`` with the lines between the markers replaced by ``block``."""
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return f"{head}{BEGIN}\n{block}\n{END}{tail}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--motors", nargs="+", choices=[*MOTORS, "wheel"], default=None,
                        help="motors to run (default: all; 'wheel' for the four wheel motors)")  # fmt: skip
    parser.add_argument("--write", action="store_true", help="replace the table in docs/guide/realmotors.md")
    args = parser.parse_args(argv)
    if not data_folder().is_dir():
        print(f"no real motor data at {data_folder()} (set MOTORID_DATA)", file=sys.stderr)
        return 2
    chosen = args.motors or list(MOTORS)
    motors = [m for m in MOTORS if m in chosen or ("wheel" in chosen and m.startswith("wheel"))]
    block = table(motors)
    print(block)
    if args.write:
        PAGE.write_text(replace_block(PAGE.read_text(encoding="utf-8"), block), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
