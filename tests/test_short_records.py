"""Short records: identify and sweep adapt the residual tests' largest lag, or refuse in one line (exit 2)."""

from __future__ import annotations

import numpy as np
import pytest
from cli_fixtures import run

from motorid.cli import main
from motorid.validation import residual_max_lag, residual_tests


@pytest.fixture(scope="module")
def short_csv(tmp_path_factory):
    """5 s at the default rig's 25 Hz: 125 samples, fewer than 4 x (--skip 50 + --max-lag 25)."""
    path = tmp_path_factory.mktemp("short") / "r.csv"
    assert main(["simulate", "--duration", "5", "--out", str(path), "--seed", "1"]) == 0
    return path


def test_the_largest_lag_is_below_a_quarter_of_the_residuals():
    assert residual_max_lag(25, 1000) == 25
    assert residual_max_lag(25, 75) == 17  # 75 // 4 - 1: each lag averages at least 3/4 of them
    assert residual_max_lag(25, 8) == 1
    assert residual_max_lag(25, 7) is None
    for n in range(8, 200):  # what residual_tests accepts, at every length
        residual_tests(np.sin(np.arange(n)), np.cos(np.arange(n)), max_lag=residual_max_lag(25, n))
    with pytest.raises(ValueError, match="max_lag"):
        residual_max_lag(0, 100)


@pytest.mark.parametrize("estimator", ["hammerstein-rls", "arx-rls"])
def test_identify_on_a_short_record_tests_the_lags_it_allows(capsys, short_csv, estimator):
    code, out, err = run(capsys, "identify", str(short_csv), "--estimator", estimator, "--json")
    assert code == 0, err
    assert out["residual_tests_samples"] == 125 - 50
    assert "residual tests up to lag 17, not 25" in " ".join(out["notes"])
    assert len(out["residual_tests"]) == 5


def test_identify_with_a_span_shorter_than_the_skip_says_which_skip_fits(capsys, short_csv, tmp_path):
    code, _, err = run(capsys, "identify", str(short_csv), "--stop", "1")
    assert code == 2
    assert err.strip().count("\n") == 0
    assert "26 samples; --skip 50 leaves 0 to score" in err and "give --skip 6 or less" in err
    code, out, err = run(capsys, "identify", str(short_csv), "--stop", "1", "--skip", "6", "--json",
                         "--out", str(tmp_path))  # fmt: skip
    assert code == 0, err
    assert "residual tests up to lag 4, not 25" in " ".join(out["notes"])
    assert (tmp_path / "residual_tests.png").is_file()


def test_sweep_on_a_short_record_refuses_in_one_line_or_runs(capsys, short_csv):
    code, _, err = run(capsys, "sweep", str(short_csv), "--stop", "1.5")
    assert code == 2 and "38 samples; --skip 50 leaves 0 to score" in err and "give --skip 18 or less" in err
    code, out, err = run(capsys, "sweep", str(short_csv), "--orders", "1-2", "--degrees", "2", "--json")
    assert code == 0, err
    assert len(out["table1"]) == 2
