"""identify on a record read in blocks: the estimate of one batch_filter over the whole record,
bit for bit, and its scores to rounding, in memory that does not grow with the record.

The reference is the whole-record computation written out here with the library's own
functions (``batch_filter`` and ``simulate`` on the whole arrays, :func:`score_predictions`,
:func:`residual_tests`), which is what ``motorid identify`` computed before it read in blocks.
Blocks of 997 rows divide no record length here, and ``--skip`` is set to end inside a block.

Tolerances: the estimate, the one-step residuals and hence the residual tests are equal bit for
bit (the filter carries its state from block to block and runs the same kernel in the same
order). The scores are sums of squares added block by block instead of at once: the rounding
of a sum of N positive terms moves its value by at most N * 2^-53 relative (N = 1500 here,
3e-13), so they are compared with rtol = 1e-12.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run

import motorid.validation
from motorid.app.identify import create_estimator, identify_record
from motorid.app.identify import identify_blocks as identify_blocks_of
from motorid.cli import build_parser
from motorid.cli.identification import identify_options_from_args
from motorid.cli.options import iter_record_from_args, read_record_from_args
from motorid.cli.report import jsonable
from motorid.drive import paper_rig
from motorid.errors import DataError
from motorid.estimators.rls import FreeRun
from motorid.io.records import read_record, write_record
from motorid.signals import two_sine_signal
from motorid.validation import (
    ResidualWindow,
    RunningScore,
    StridedSample,
    residual_tests,
    rpm_to_rad_s,
    score,
    score_predictions,
)

BLOCK = 997
SCORE_RTOL = 1e-12


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory):
    """60 s of the paper's rig at 40 ms (1500 samples)."""
    rig = paper_rig()
    _, u = two_sine_signal(duration=60.0, dt=rig.dt, seed=4)
    path = tmp_path_factory.mktemp("blocks") / "rec.csv"
    write_record(rig.simulate(u, seed=4), path)
    return path


def identify_args(path, *options: str):
    return build_parser().parse_args(["identify", str(path), *options])


def identify_blocks(blocks, args):
    """:func:`identify_blocks_of` on a record of motorid's simulation (output in rad/s): the
    estimator of ``args``, the low-speed band of ``--low-speed-rpm``."""
    est = create_estimator(args.estimator, args)
    options = identify_options_from_args(args)
    return identify_blocks_of(blocks, options, est, [], "rad/s", float(rpm_to_rad_s(args.low_speed_rpm)))


def in_blocks(args, rows: int = BLOCK):
    def blocks():
        for block in iter_record_from_args(args, chunk_rows=rows):
            yield block["u"].to_numpy(), block["y"].to_numpy()

    return blocks


@pytest.mark.cpu_sensitive
@pytest.mark.parametrize(
    "options",
    [("--skip", "1200"), ("--estimator", "arx-rls", "--na", "2", "--nb", "3", "--lam", "0.995"),
     ("--basis", "u,sign", "--skip", "0")],
)  # fmt: skip
def test_identify_in_blocks_equals_the_whole_record_computation(record_csv, options):
    args = identify_args(record_csv, *options)
    payload, tests, est = identify_blocks(in_blocks(args), args)

    record = read_record(record_csv)
    u, y = record["u"].to_numpy(), record["y"].to_numpy()
    whole = create_estimator(args.estimator, args)
    result = whole.batch_filter(u, y)
    threshold = float(rpm_to_rad_s(args.low_speed_rpm))
    expected = score_predictions(
        y, {"one_step": result.y_hat, "free_run": whole.simulate(u)}, threshold, args.skip
    )
    expected_tests = residual_tests(u[args.skip :], (y - result.y_hat)[args.skip :], max_lag=args.max_lag)

    assert payload["samples"] == len(record) == payload["residual_tests_samples"] + args.skip
    np.testing.assert_array_equal(est.x, whole.x)
    np.testing.assert_array_equal(est.P, whole.P)
    for name, value in whole.params.items():
        np.testing.assert_array_equal(payload["params"][name], value, err_msg=name)
    for kind in ("one_step", "free_run"):
        for column in ("mse", "rmse", "fit_percent", "low_speed_mse"):
            got, want = payload["scores"][kind][column], expected.loc[kind, column]
            assert got == pytest.approx(want, rel=SCORE_RTOL), (kind, column)
        assert payload["scores"][kind]["n_low_speed"] == expected.loc[kind, "n_low_speed"]
    assert payload["free_run_diverges_from_sample"] is None
    for got, want in zip(tests, expected_tests, strict=True):
        np.testing.assert_array_equal(got.values, want.values)
        assert (got.band, got.simultaneous_band, got.passed) == (
            want.band,
            want.simultaneous_band,
            want.passed,
        )


@pytest.mark.cpu_sensitive
def test_blocks_of_any_size_give_one_estimate(record_csv):
    args = identify_args(record_csv)
    params = [identify_blocks(in_blocks(args, rows), args)[0]["params"] for rows in (20, BLOCK, 1500)]
    for other in params[1:]:
        for name in ("a", "b", "gamma", "s"):
            np.testing.assert_array_equal(other[name], params[0][name])


def test_the_command_reads_beyond_max_samples_and_says_where_the_residual_tests_look(
    capsys, record_csv, monkeypatch
):
    """--max-samples limits what is held whole (sweep), not identify; a record longer than the
    residual window is tested on its last samples, and the output says so."""
    code, whole, _ = run(capsys, "identify", str(record_csv), "--json")
    assert code == 0 and whole["residual_tests_samples"] == 1500 - 50
    code, limited, err = run(capsys, "identify", str(record_csv), "--max-samples", "100", "--json")
    assert code == 0, err
    assert limited == whole
    assert "residual tests on the last" not in err
    code, _, err = run(
        capsys, "sweep", str(record_csv), "--orders", "2", "--degrees", "2", "--max-samples", "100"
    )
    assert code == 2 and "more than the limit of 100 samples" in err

    monkeypatch.setattr(motorid.validation, "RESIDUAL_WINDOW", 600)
    code, windowed, err = run(capsys, "identify", str(record_csv), "--json")
    assert code == 0 and windowed["residual_tests_samples"] == 600
    assert "residual tests on the last 600 samples of the record" in err
    assert windowed["params"] == whole["params"] and windowed["scores"] == whole["scores"]
    record = read_record(record_csv)
    est = create_estimator("hammerstein-rls", identify_args(record_csv))
    e = record["y"].to_numpy() - est.batch_filter(record["u"], record["y"]).y_hat
    expected = residual_tests(record["u"].to_numpy()[-600:], e[-600:], max_lag=25)
    assert windowed["residual_tests"] == {
        t.name: {"passed": t.passed, "fraction_outside": t.fraction_outside} for t in expected
    }


def test_a_bad_row_late_in_the_record_stops_identify_before_anything_is_written(capsys, record_csv, tmp_path):
    bad = tmp_path / "late_nan.csv"
    frame = pd.read_csv(record_csv, comment="#")[["t", "u", "y"]]
    frame.loc[1400, "y"] = float("nan")
    frame.to_csv(bad, index=False)
    out, model = tmp_path / "figures", tmp_path / "model.json"
    code, _, err = run(capsys, "identify", str(bad), "--out", str(out), "--save-model", str(model))
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1
    assert "column 'y' has a NaN value '' at row 1400 (line 1402 of" in lines[0]
    assert not out.exists() and not model.exists()


def test_an_outlier_in_a_later_block_is_named_by_its_row_in_the_record(record_csv):
    frame = pd.read_csv(record_csv, comment="#")[["t", "u", "y"]]
    u, y = frame["u"].to_numpy().copy(), frame["y"].to_numpy()
    u[1234] = 1e300
    args = identify_args(record_csv, "--estimator", "arx-rls")
    blocks = lambda: ((u[k : k + BLOCK], y[k : k + BLOCK]) for k in range(0, len(u), BLOCK))  # noqa: E731
    with pytest.raises(DataError, match=r"column 'u' has an outlier 1e\+300 at row 1234,"):
        identify_blocks(blocks, args)


@pytest.mark.parametrize("rows", [BLOCK, 1500])
def test_a_unit_slip_filling_most_of_a_block_is_named_as_in_the_whole_record(record_csv, rows):
    """From row 1100 on, u and y are 1e150 times too large: 400 of the last block's 503 rows, so
    that block's own median is among them; the record's median (of a strided sample of the whole
    record) is not, and the slip is named as check_signals names it on the whole record."""
    frame = pd.read_csv(record_csv, comment="#")
    u, y = frame["u"].to_numpy().copy(), frame["y"].to_numpy().copy()
    u[1100:] *= 1e150
    y[1100:] *= 1e150
    args = identify_args(record_csv, "--estimator", "arx-rls")
    blocks = lambda: ((u[k : k + rows], y[k : k + rows]) for k in range(0, len(u), rows))  # noqa: E731
    with pytest.raises(DataError, match=r"column 'u' has an outlier \S+e\+150 at row 1100,"):
        identify_blocks(blocks, args)


def test_a_constant_input_over_every_block_is_refused_as_check_signals_refuses_it(record_csv):
    frame = pd.read_csv(record_csv, comment="#")
    u, y = np.full(len(frame), 0.5), frame["y"].to_numpy()
    args = identify_args(record_csv, "--estimator", "arx-rls")
    blocks = lambda: ((u[k : k + BLOCK], y[k : k + BLOCK]) for k in range(0, len(u), BLOCK))  # noqa: E731
    with pytest.raises(DataError, match=r"column 'u' is constant \(0.5 in every one of its 1500 rows\)"):
        identify_blocks(blocks, args)


# --------------------------------------------------------------------------- the pieces
@pytest.mark.cpu_sensitive
def test_free_run_in_blocks_is_simulate_bit_for_bit(record_csv):
    record = read_record(record_csv)
    est = create_estimator("hammerstein-rls", identify_args(record_csv, "--basis", "u,sign,dead_zone:0.5"))
    est.batch_filter(record["u"], record["y"])
    u = record["u"].to_numpy()
    run_blocks = FreeRun(est)
    joined = np.concatenate([run_blocks(u[k : k + 7]) for k in range(0, len(u), 7)])
    np.testing.assert_array_equal(joined, est.simulate(u))
    with pytest.raises(ValueError, match=r"u\[1503\] = nan is not finite"):
        run_blocks(np.array([1.0, 2.0, 3.0, np.nan]))


def test_running_score_equals_score_to_rounding():
    rng = np.random.default_rng(5)
    y = 100.0 + 30.0 * rng.normal(size=10_000)  # a large mean: the deviations' merge must not lose them
    y_hat = y + rng.normal(size=10_000)
    running = RunningScore(low_speed_threshold=95.0)
    for k in range(0, len(y), BLOCK):
        running.add(y[k : k + BLOCK], y_hat[k : k + BLOCK])
    got, want = running.result(), score(y, y_hat, 95.0)
    for name in ("mse", "rmse", "fit_percent", "low_speed_mse"):
        assert getattr(got, name) == pytest.approx(getattr(want, name), rel=SCORE_RTOL), name
    assert got.n_low_speed == want.n_low_speed > 0


def test_strided_sample_keeps_every_stride_th_sample_in_bounded_memory():
    x = np.arange(10_000.0)
    sample = StridedSample(1000)
    for k in range(0, len(x), BLOCK):
        sample.add(x[k : k + BLOCK])
    assert sample.stride == 16 and sample.samples == len(x)
    np.testing.assert_array_equal(sample.values, x[::16])
    whole = StridedSample(1000)
    whole.add(x[:700])
    whole.add(x[700:1000])
    np.testing.assert_array_equal(whole.values, x[:1000])  # a short signal is kept whole
    assert whole.stride == 1


def test_residual_window_keeps_the_last_samples_in_order():
    u, e = np.arange(5000.0), -np.arange(5000.0)
    window = ResidualWindow(1000)
    for k in range(0, 5000, BLOCK):
        window.add(u[k : k + BLOCK], e[k : k + BLOCK])
    got_u, got_e = window.arrays()
    np.testing.assert_array_equal(got_u, u[-1000:])
    np.testing.assert_array_equal(got_e, e[-1000:])
    short = ResidualWindow(1000)
    short.add(u[:300], e[:300])
    np.testing.assert_array_equal(short.arrays()[0], u[:300])
    big = ResidualWindow(1000)
    big.add(u, e)  # one block longer than the window
    np.testing.assert_array_equal(big.arrays()[1], e[-1000:])


def test_rows_appended_between_the_two_passes_are_left_out(record_csv):
    """A logger may still be appending to the file: the free run scores the rows the filter saw."""
    frame = pd.read_csv(record_csv, comment="#")
    u, y = frame["u"].to_numpy(), frame["y"].to_numpy()
    args = identify_args(record_csv)
    calls = []

    def growing():
        rows = 1200 if not calls else len(u)  # the second pass finds 300 more rows
        calls.append(rows)
        return ((u[k : min(k + BLOCK, rows)], y[k : min(k + BLOCK, rows)]) for k in range(0, rows, BLOCK))

    got = identify_blocks(growing, args)[0]
    fixed = identify_blocks(lambda: ((u[k : min(k + BLOCK, 1200)], y[k : min(k + BLOCK, 1200)])
                                     for k in range(0, 1200, BLOCK)), args)[0]  # fmt: skip
    assert calls == [1200, len(u)]
    assert got["samples"] == 1200 and got["scores"] == fixed["scores"]


def spreadsheet_export(path, rec, jitter_ms=None):
    """``rec`` as a spreadsheet in much of Europe exports a logger's file: ';', decimal commas,
    names with units, time in integer ms since boot, duty in % of a supply, speed in rpm."""
    supply = 1.25 * float(np.max(np.abs(rec["u"])))
    stamps = 123_456 + np.arange(len(rec)) * 40
    if jitter_ms is not None:
        stamps = stamps + jitter_ms
    frame = pd.DataFrame(
        {
            "Zeit [ms]": stamps,
            "PWM [%]": rec["u"] / supply * 100.0,
            "Drehzahl [rpm]": rec["y"] * 60 / (2 * np.pi),
        }
    )
    frame.to_csv(path, sep=";", decimal=",", index=False)
    return ["--time", "Zeit [ms]", "--time-unit", "ms", "--input", "PWM [%]", "--input-unit", "%",
            "--supply-voltage", repr(supply), "--output", "Drehzahl [rpm]", "--output-unit", "rpm"]  # fmt: skip


def test_a_semicolon_decimal_comma_export_in_ms_identifies_alike_streamed_and_whole(
    capsys, tmp_path, monkeypatch
):
    """The command reads the file in blocks of 997 rows (separator and decimal mark detected from
    its header once, time in ms, duty and rpm converted per block); the same file read whole by
    read_record and identified by identify_record (as fleet identify does) gives the same
    payload, key for key: both run the estimator over blocks of 997 rows of the same numbers."""
    import motorid.io.records

    rig = paper_rig()
    _, u = two_sine_signal(duration=60.0, dt=rig.dt, seed=4)
    path = tmp_path / "export.csv"
    options = spreadsheet_export(path, rig.simulate(u, seed=4))
    monkeypatch.setattr(motorid.io.records, "CHUNK_ROWS", BLOCK)
    code, streamed, err = run(capsys, "identify", str(path), *options, "--json")
    assert code == 0, err
    assert "reads it whole" not in err  # the uniform stamps are read in blocks

    args = identify_args(path, *options)
    record = read_record_from_args(args)
    blocks = list(iter_record_from_args(args))
    assert len(blocks) == 2  # 1500 rows in blocks of 997
    pd.testing.assert_frame_equal(pd.concat(blocks), record, check_exact=True)
    assert record.attrs["units"] == {"t": "s", "u": "V", "y": "rad/s"} == blocks[1].attrs["units"]
    assert record.attrs["time_origin"] == pytest.approx(123.456) and record.attrs["dt"] == pytest.approx(0.04)
    whole = json.loads(json.dumps(jsonable(identify_record(record, identify_options_from_args(args))[0])))
    assert streamed.pop("figure") is None and streamed.pop("model") is None
    assert streamed == whole
    assert (
        whole["output_unit"] == "rad/s"
        and whole["samples"] == 1500
        and "mse_rpm2" in whole["scores"]["one_step"]
    )


def test_jittered_stamps_are_identified_on_the_whole_record_and_the_output_says_so(capsys, caplog, tmp_path):
    """millis() jitter puts the record on a uniform grid, which the whole-record read does: the
    command falls back to it (logged at -v), the reader says how it resampled in one line, and it
    gives what identify_record gives on the record read_record resamples."""
    import logging

    caplog.set_level(logging.INFO, logger="motorid")

    rig = paper_rig()
    _, u = two_sine_signal(duration=60.0, dt=rig.dt, seed=4)
    path = tmp_path / "jitter.csv"
    jitter = np.random.default_rng(3).integers(-4, 5, 1500)  # +-4 ms on 40 ms: 10 %
    options = spreadsheet_export(path, rig.simulate(u, seed=4), jitter_ms=jitter)
    code, streamed, err = run(capsys, "identify", str(path), *options, "--json")
    assert code == 0, err
    assert "identify reads it whole" not in err  # one line on stderr: the reader's
    assert "are off the uniform 0.04 s grid from row 1 (line 3 of" in caplog.text
    assert "identify reads it whole" in caplog.text
    assert "resampled to a uniform 40 ms grid" in caplog.text  # the reader's own warning
    args = identify_args(path, *options)
    whole = json.loads(
        json.dumps(
            jsonable(identify_record(read_record_from_args(args), identify_options_from_args(args))[0])
        )
    )
    streamed.pop("figure"), streamed.pop("model")
    assert streamed == whole
    with pytest.raises(DataError, match="reads it whole"):
        list(iter_record_from_args(args))
