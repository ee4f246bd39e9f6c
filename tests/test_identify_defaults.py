"""``motorid identify`` with its defaults on measured records: a model that holds, or a warning.

The default estimator (``hammerstein-rls``, order 4) takes the static block u, sign(u)
(:data:`motorid.app.identify.IDENTIFY_BASIS`); the paper's cubic, asked for with ``--degree 3``,
goes far off on a duty of ±100 % and must say so (``free_run_diverges_from_sample`` and a
one-line warning, in ``identify`` and in ``compare``).
"""

from __future__ import annotations

import numpy as np
import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file

from motorid.validation import DIVERGENCE_FACTOR, free_run_divergence

#: Each record of ``realmotors/`` with the units its README gives.
REAL_RECORDS = {
    **{f"kit_{signal}_run{k}.csv": ("%", "rad/s") for signal in ("chirp", "sine_0.5hz", "sine_1hz")
       for k in (1, 2)},
    **{f"wheel_free_{part}_motor{k}.csv": ("%", "rev/s") for part in ("train", "validation")
       for k in range(1, 5)},
    "l298n_staircase.csv": ("V", "rpm"),
}  # fmt: skip


def units(name: str) -> list[str]:
    input_unit, output_unit = REAL_RECORDS[name]
    return ["--input-unit", input_unit, "--output-unit", output_unit]


def test_the_divergence_bound():
    y_sim = np.array([0.0, 5.0, -10.0, 10.5, np.nan])
    assert free_run_divergence(y_sim, 1.0) == 3  # |y_sim| > 10 x 1.0
    assert free_run_divergence(y_sim[:3], 1.0) is None
    assert free_run_divergence(np.array([0.0, np.inf]), 1e300, first=7) == 8
    assert free_run_divergence(np.array([1.0, np.nan]), 1.0) == 1
    assert DIVERGENCE_FACTOR == 10.0


@pytest.mark.parametrize("name", sorted(REAL_RECORDS))
def test_identify_defaults_hold_on_every_real_record_or_warn(capsys, name):
    path = real_motor_file(name)
    if not path.is_file():
        pytest.skip(f"real motor data not found at {path} (set MOTORID_DATA)")
    code, out, err = run(capsys, "identify", str(path), *units(name), "--json")
    assert code == 0, err
    assert out["params"]["basis"] == ["u", "sign(u)"] and "static block u,sign" in out["notes"][0]
    fit = out["scores"]["free_run"]["fit_percent"]
    if name == "l298n_staircase.csv":
        # the staircase has no motion up to ±2 V and a 31 ms delay (its README): at order 4 neither
        # model holds 80 %; measured 78.3 % against ARX's 71.8 %
        code, arx, err = run(capsys, "identify", str(path), *units(name), "--estimator", "arx-rls", "--json")
        assert code == 0, err
        assert fit > arx["scores"]["free_run"]["fit_percent"] and out["free_run_diverges_from_sample"] is None
    else:  # measured 81.6 % (a wheel's validation record) to 92.3 % (the kit's chirp)
        assert fit > 80.0 or ("free run diverges" in err and out["free_run_diverges_from_sample"] is not None)


def test_the_papers_cubic_on_a_duty_record_warns_in_identify_and_compare(capsys, tmp_path):
    train, other = real_motor_file("kit_chirp_run1.csv"), real_motor_file("kit_chirp_run2.csv")
    if not (train.is_file() and other.is_file()):
        pytest.skip(f"real motor data not found at {train.parent} (set MOTORID_DATA)")
    model = tmp_path / "cubic.json"
    code, out, err = run(capsys, "identify", str(train), *units(train.name), "--degree", "3", "--json",
                         "--save-model", str(model))  # fmt: skip
    assert code == 0, err
    # measured: FIT -158,161 %, the run beyond 10 x max |y| from sample 257 on
    diverged = out["free_run_diverges_from_sample"]
    assert diverged is not None and 50 < diverged < 1000
    warnings = [line for line in err.splitlines() if line.startswith("motorid: warning:")]
    assert (
        len(warnings) == 1 and f"diverges from sample {diverged}" in warnings[0] and "--basis" in warnings[0]
    )
    code, out, err = run(capsys, "compare", str(other), *units(other.name), "--model", str(model), "--json")
    assert code == 0, err
    row = out["models"][str(model)]
    assert row["diverges_from_sample"] is not None and row["fit_percent"] < 0
    warnings = [line for line in err.splitlines() if line.startswith("motorid: warning:")]
    assert len(warnings) == 1 and f"diverges from sample {row['diverges_from_sample']}" in warnings[0]
