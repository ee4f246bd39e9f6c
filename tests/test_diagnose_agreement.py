"""Whether the records of a joint run tell one story (:mod:`motorid.diagnose.agreement`): each
record fitted alone with the joint model's structure, Cochran's test of one common value, the
spread between the records beyond their errors, and the records that lie off."""

from __future__ import annotations

import math

import numpy as np
import pytest
from cli_fixtures import run
from drive_fixtures import COULOMB, one_drive_records

from motorid.diagnose import diagnose
from motorid.diagnose.agreement import AGREEMENT_LEVEL, homogeneity
from motorid.diagnose.model import fit_model
from motorid.diagnose.synthetic import planted_record
from motorid.io.records import write_record

LABELS = ["a.csv", "b.csv", "c.csv"]


def test_homogeneity_equals_its_closed_forms():
    """Independent reference: with equal errors the weighted mean is the plain mean; χ² on 2
    degrees of freedom has the survival function exp(-Q/2), on 1 erfc(sqrt(Q/2))."""
    q, p, tau = homogeneity(np.array([1.0, 2.0, 3.0]), np.ones(3))
    assert q == pytest.approx(2.0, rel=1e-12)
    assert p == pytest.approx(math.exp(-1.0), rel=1e-12)
    assert tau == 0.0  # Q equals its degrees of freedom: no spread beyond the errors
    # two records 4 errors apart: Q = 8, c = Σw - Σw²/Σw = 1, τ² = Q - 1
    q, p, tau = homogeneity(np.array([0.0, 4.0]), np.ones(2))
    assert q == pytest.approx(8.0, rel=1e-12)
    assert p == pytest.approx(math.erfc(2.0), rel=1e-10)
    assert tau == pytest.approx(math.sqrt(7.0), rel=1e-12)
    # unequal errors weigh by 1/σ²: the mean sits at the precise record
    q, _, _ = homogeneity(np.array([0.0, 1.0]), np.array([0.1, 1.0]))
    mean = 1.0 / 101.0
    assert q == pytest.approx(100.0 * mean**2 + (1.0 - mean) ** 2, rel=1e-12)


@pytest.fixture(scope="module")
def one_drive():
    """Three records of one drive with Coulomb friction: three excitations and noise draws."""
    return one_drive_records()


def test_records_of_one_drive_agree_and_each_is_the_record_fitted_alone_with_the_joint_structure(one_drive):
    d = diagnose([p.record for p in one_drive], input_gain=one_drive[0].input_gain, base=one_drive[0].base,
                 labels=LABELS)  # fmt: skip
    assert d.named == ["coulomb_friction"]
    found = {a.parameter: a for a in d.agreement}
    assert {"coulomb", "viscous"} <= set(found)
    for a in found.values():
        assert a.agree and a.p_value >= AGREEMENT_LEVEL, a
        assert a.drive_std >= a.joint_std  # equal where the records spread by no more than their errors
        assert a.labels == tuple(LABELS) and a.joint == pytest.approx(
            d.model.params.get(a.parameter, a.joint)
        )
    # each record's value is that record's own fit of the joint model's effects, shapes held
    shape = {p: d.model.params[p] for p in ("input_delay", "lag_time_constant") if p in d.model.params}
    for k, part in enumerate(d._pool.parts):
        alone = fit_model(part.data, d.model.effects, fixed=shape)
        assert found["coulomb"].values[k] == pytest.approx(alone.model.params["coulomb"], rel=1e-12)
        assert found["coulomb"].std[k] == pytest.approx(alone.param_std["coulomb"], rel=1e-12)
        # and each knows the planted level: within 4 of its own errors (measured within 2)
        assert abs(found["coulomb"].values[k] - COULOMB) < 4.0 * found["coulomb"].std[k]
    assert d.to_dict()["agreement"]["coulomb"]["agree"] is True


def test_a_record_of_another_drive_is_named_where_the_records_disagree(one_drive):
    """The third record from a drive with 30 % more Coulomb friction: the records disagree on
    the Coulomb level, the third is named above the joint level, and the spread between the
    records is of the size of the difference (the joint level lies between the two drives')."""
    other = planted_record("coulomb_friction", 3, sizes={"coulomb": 1.3 * COULOMB}, excitation_seed=3)
    records = [one_drive[0].record, one_drive[1].record, other.record]
    d = diagnose(records, input_gain=other.input_gain, base=other.base, labels=LABELS)
    coulomb = {a.parameter: a for a in d.agreement}["coulomb"]
    assert not coulomb.agree and coulomb.p_value < 1e-6, coulomb
    assert "c.csv" in coulomb.outliers and coulomb.z()[2] > 2.0
    assert 0.1 * COULOMB < coulomb.spread < 0.4 * COULOMB
    assert COULOMB < coulomb.joint < 1.3 * COULOMB
    # the drive's level with the spread counted: the pooled fit's error, which takes the three records
    # for one long record of one drive, widened as the spread widens a weighted mean's
    w, w_spread = 1.0 / np.square(coulomb.std), 1.0 / (np.square(coulomb.std) + coulomb.spread**2)
    widened = coulomb.joint_std * math.sqrt(w.sum() / w_spread.sum())
    assert coulomb.drive_std == pytest.approx(widened, rel=1e-12)
    assert coulomb.drive_std > 2.0 * coulomb.joint_std
    line = coulomb.describe("N m")
    assert line.startswith("coulomb: the records disagree beyond their errors (Q = ")
    assert "c.csv" in line and "standard errors above" in line
    assert f"the drive's level ± {coulomb.drive_std:.2g}" in line
    assert d.to_dict()["agreement"]["coulomb"]["outliers"] == list(coulomb.outliers)
    assert d.to_dict()["agreement"]["coulomb"]["drive_std"] == coulomb.drive_std


def test_one_record_has_no_agreement(one_drive):
    d = diagnose(one_drive[0].record, input_gain=one_drive[0].input_gain, base=one_drive[0].base)
    assert d.agreement == [] and "agreement" not in d.to_dict()


def test_motorid_doctor_on_several_records_prints_and_reports_the_agreement(tmp_path, capsys, one_drive):
    paths = []
    for label, planted in zip(LABELS, one_drive, strict=True):
        write_record(planted.record, tmp_path / label)
        paths.append(str(tmp_path / label))
    code, out, err = run(capsys, "doctor", *paths, "--input-gain", str(one_drive[0].input_gain), "--json")
    assert code == 0, err
    assert out["agreement"]["coulomb"]["records"] == paths
    assert out["agreement"]["coulomb"]["dof"] == 2
    # the keys README lists
    assert list(out["agreement"]["coulomb"]) == [
        "records", "values", "std", "joint", "joint_std", "q", "dof", "p_value", "spread", "drive_std",
        "agree", "outliers",
    ]  # fmt: skip
    assert "each record fitted alone with the joint model's structure" in err
    assert "    coulomb: the records agree within their errors (Q = " in err


def test_the_calibration_counts_the_false_alarms_of_one_drive(capsys):
    """``python -m motorid.diagnose.calibration --agreement``: one joint run of three records of
    one drive, every parameter tested, the count printed."""
    from motorid.diagnose.calibration import agreements, main

    ag = agreements([0])
    assert ag.tests >= 2 and 0 <= ag.alarms <= ag.tests
    assert set(ag.p_values[0]) >= {"coulomb", "viscous"}
    assert main(["--agreement", "--seeds", "1", "--first", "0"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("joint runs of 3 records of one drive: 1; the records said to disagree in ")
    assert f"{ag.alarms} of {ag.tests} parameter tests" in out
