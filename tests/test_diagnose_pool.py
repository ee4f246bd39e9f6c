"""Several records of one drive, one model (``diagnose([rec_a, rec_b, ...])``): the pooled fit is
the least squares of the stacked rows, each record keeps its own start, the pooled figures are
the records' pooled, and the pooled evidence names the planted effect more surely than one record."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from balance_reference import reference_columns, reference_target
from cli_fixtures import run
from drive_fixtures import COULOMB, one_drive_records

from motorid.diagnose import diagnose
from motorid.diagnose.model import PooledBalance, discrete_inertia, fit_model
from motorid.diagnose.workflow import free_run_error, prepare
from motorid.io.records import write_record


@pytest.fixture(scope="module")
def drive():
    """Three records of one drive with Coulomb friction: three excitations and noise draws."""
    return one_drive_records()


def test_a_pooled_fit_is_the_compensated_least_squares_of_the_stacked_rows(drive):
    """Independent reference: the normal equations of each record's moving rows stacked, solved by
    numpy, the inertia's entry less each record's noise on its rows (M_r σ_a,r²)."""
    effects = ("viscous_friction", "coulomb_friction", "offset")
    preps = [prepare(p.record, input_gain=p.input_gain) for p in drive]
    fit = fit_model(PooledBalance(tuple(q.data for q in preps), preps[0].kin.noise), effects)
    rows, target, noise = [], [], 0.0
    for q in preps:
        # each record's balance written out, g u in force units (the reference's columns are per unit gain)
        rows.append(reference_columns(q, ["coulomb", "viscous", "offset"])[q.data.moving])
        target.append(q.data.input_gain * reference_target(q)[q.data.moving])
        noise += int(q.data.moving.sum()) * q.data.accel_noise
    X, y = np.vstack(rows), np.concatenate(target)
    normal = X.T @ X
    normal[0, 0] -= noise
    theta = np.linalg.solve(normal, X.T @ y)
    assert noise > 0.0
    got = [fit.model.params[k] for k in ("inertia", "coulomb", "viscous", "offset")]
    got[0] = discrete_inertia(got[0], got[2], preps[0].kin.dt)  # the balance's coefficient J_b
    # two ways to the normal equations of a problem with condition number ~1e4 (the QR factor of
    # the unit columns; XᵀX written out in the columns' units) agree to ~1e-9 relative; the offset
    # is near 0, so it is held absolutely, at 1e-9 of the Coulomb level
    np.testing.assert_allclose(got[:3], theta[:3], rtol=1e-8)
    assert got[3] == pytest.approx(theta[3], abs=1e-9 * COULOMB)
    assert fit.n_rows == sum(int(q.data.moving.sum()) for q in preps)


def test_records_of_one_drive_are_diagnosed_as_one_model(drive):
    gain = drive[0].input_gain
    records = [p.record for p in drive]
    d = diagnose(records, input_gain=gain, base=drive[0].base, labels=["a.csv", "b.csv", "c.csv"])
    assert d.named == ["coulomb_friction"]
    # three records of 30 s each know the level to about 2 %; 5 % leaves room
    assert d.model.params["coulomb"] == pytest.approx(COULOMB, rel=0.05)
    assert [r.record for r in d.records] == ["a.csv", "b.csv", "c.csv"]
    assert d.settings.records == ("a.csv", "b.csv", "c.csv")
    # each record's final gap is that record's, computed anew (evaluate prepares the record again)
    for rec, summary in zip(records, d.records, strict=True):
        again = d.evaluate(rec)
        assert summary.final_gap.overall == pytest.approx(
            again.loc["+coulomb_friction", "overall"], rel=1e-12
        )
        assert summary.initial_gap.overall == pytest.approx(again.loc["initial", "overall"], rel=1e-12)
        assert summary.samples == len(rec)
    # the pooled gap is the RMS over every record's settled samples, each record's free run from its own start
    errors = np.concatenate([free_run_error(prepare(rec, input_gain=gain), d.model) for rec in records])
    pooled = math.sqrt(np.nanmean(errors**2))
    assert d.final_gap.overall == pytest.approx(pooled, rel=1e-12)
    assert d.steps[0].gap_after.overall == pytest.approx(pooled, rel=1e-12)
    assert [g.record for g in d.steps[0].record_gaps] == ["a.csv", "b.csv", "c.csv"]
    assert all(g.gap_after < 0.6 * g.gap_before for g in d.steps[0].record_gaps)
    # one record alone: its own standard error is larger than the pooled one by about sqrt(3)
    alone = diagnose(records[0], input_gain=gain, base=drive[0].base)
    assert alone.named == ["coulomb_friction"]
    assert d.param_std["coulomb"] < 0.8 * alone.param_std["coulomb"]
    assert d.steps[0].evidence.delta_bic > alone.steps[0].evidence.delta_bic
    out = d.to_dict()
    assert out["records"] == [r.to_dict() for r in d.records]
    assert out["steps"][0]["record_gaps"] == [g.to_dict() for g in d.steps[0].record_gaps]


def test_one_record_in_a_list_is_that_record(drive):
    rec = drive[0].record
    alone, listed = diagnose(rec, max_steps=1), diagnose([rec], max_steps=1)
    assert listed.to_dict() == alone.to_dict()
    assert "records" not in alone.to_dict() and alone.records == []


def test_records_that_cannot_be_pooled_are_named(drive):
    rec = drive[0].record
    slower = rec.iloc[::2].reset_index(drop=True)
    slower.attrs = {**rec.attrs, "dt": 2 * rec.attrs["dt"]}
    with pytest.raises(ValueError, match=r"second: sample time 0\.02 s .* first's 0\.01 s"):
        diagnose([rec, slower], labels=["first", "second"], max_steps=0)
    with pytest.raises(ValueError, match="non-empty sequence"):
        diagnose([])
    with pytest.raises(ValueError, match="2 labels for 3 records"):
        diagnose([rec, rec, rec], labels=["a", "b"])
    bad = rec.copy()
    bad.loc[5, "y"] = np.nan
    with pytest.raises(ValueError, match=r"b\.csv: column 'y' is not a finite number at sample 5"):
        diagnose([rec, bad], labels=["a.csv", "b.csv"])
    with pytest.raises(ValueError, match="different timings"):
        held = rec.copy()
        held.attrs = {**rec.attrs, "timing": "sampled"}
        diagnose([rec, held])
    with pytest.raises(ValueError, match="DataFrame"):
        diagnose([rec, pd.DataFrame({"u": [0.0]}).to_numpy()])  # type: ignore[list-item]


def test_the_doctor_command_takes_several_records_of_one_drive(capsys, drive, tmp_path):
    paths = []
    for k, p in enumerate(drive[:2]):
        paths.append(tmp_path / f"run{k}.csv")
        write_record(p.record, paths[-1])
    code, out, err = run(
        capsys, "doctor", *map(str, paths), "--input-gain", repr(drive[0].input_gain), "--base",
        "viscous_friction,offset", "--validate", str(paths[0]), "--json", "--out", str(tmp_path / "figs"),
    )  # fmt: skip
    assert code == 0, err
    assert [s["effect"] for s in out["steps"]] == ["coulomb_friction"]
    assert [r["record"] for r in out["records"]] == [str(p) for p in paths]
    assert "2 records of one drive" in err and "gaps per record" in err
    for path, r in zip(paths, out["records"], strict=True):
        assert str(path) in err and f"{r['final_gap']['overall']:.4f}".rstrip("0") in err
    # the models found are scored on the --validate record as for one record
    assert list(out["validation"]["models"]) == ["initial", "+coulomb_friction"]
    # one pair of figures per record
    names = sorted(p.split("/")[-1] for p in out["figures"])
    assert names == [f"doctor_{k}_{f}.png" for k in (1, 2) for f in ("residual_vs_speed", "simulation")]
    code, _, err = run(capsys, "doctor", str(paths[0]), str(tmp_path / "missing.csv"))
    assert code == 2 and "missing.csv" in err
