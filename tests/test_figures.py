"""Every figure motorid draws can be read on its own: a unit on every axis a value is read
from, in the record's own units (none invented for a record that names none), a legend
where several things are plotted, and no text past the figure's edge.

Each figure function is built here and checked as drawn (``FigureCanvasAgg.draw``), the
way a PNG is written.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text

from motorid import figures
from motorid.diagnose import diagnose
from motorid.diagnose.figures import residual_figure, simulation_figure
from motorid.diagnose.synthetic import planted_record
from motorid.experiment import run_paper_experiment
from motorid.fleet.trend import flag_drives, friction_trends, trend_figure
from motorid.units import UNNAMED_INPUT, UNNAMED_OUTPUT, shown_output
from motorid.validation import residual_tests, residual_tests_figure

#: A unit in brackets, e.g. "[rpm]", "[-]", "[N m s/rad]", "[output units]".
BRACKETED_UNIT = re.compile(r"\[[^\]]+\]")
#: The paper's three models, as the demo names them: the third one's Fig. 12 title was cut off.
MODELS = (
    "ARX-RLS, order 4",
    "Hammerstein-RLS, order 4, degree 3",
    "Hammerstein-RLS, order 4, dead zone 0.8 V",
)


def drawn(fig: Figure) -> Figure:
    FigureCanvasAgg(fig).draw()
    return fig


def axis_labels_read(fig: Figure) -> list[str]:
    """The label of every axis that shows values (tick labels drawn): an inner panel of a
    shared time axis shows none and is labelled by the panel below."""
    labels = []
    for ax in fig.axes:
        for axis, label in ((ax.xaxis, ax.get_xlabel()), (ax.yaxis, ax.get_ylabel())):
            if any(t.get_visible() and t.get_text() for t in axis.get_ticklabels()):
                labels.append(label)
    return labels


def drawn_texts(fig: Figure) -> list[Text]:
    """Every text the figure draws: titles, axis labels, the tick labels in view, legends."""
    found = list(fig.texts)  # the suptitle among them
    for ax in fig.axes:
        found += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label]
        for axis in (ax.xaxis, ax.yaxis):
            low, high = sorted(axis.get_view_interval())
            span = 1e-9 * (high - low)
            found += [t.label1 for t in axis.get_major_ticks() if low - span <= t.get_loc() <= high + span]
            found.append(axis.offsetText)
        found += ax.get_legend().get_texts() if ax.get_legend() else []
    for legend in fig.legends:
        found += legend.get_texts()
    return [t for t in found if t.get_visible() and t.get_text().strip()]


def data_artists(ax) -> int:
    """Lines of data on ``ax`` (more than the two points of a reference line), and error bars."""
    lines = [line for line in ax.get_lines() if np.size(line.get_xdata()) > 2]
    return len(lines) + len(ax.containers)


def check_readable(fig: Figure) -> None:
    """The three rules of the module docstring, on ``fig`` as drawn."""
    drawn(fig)
    labels = axis_labels_read(fig)
    assert labels, "no axis shows values"
    for label in labels:
        assert label.strip() and BRACKETED_UNIT.search(label), f"axis label without a unit: {label!r}"
    for ax in fig.axes:
        if data_artists(ax) >= 2:
            legend = ax.get_legend() or (fig.legends[0] if fig.legends else None)
            assert legend is not None, f"{ax.get_title()!r}: several lines and no legend"
            texts = [t.get_text() for t in legend.get_texts()]
            assert texts and all(t and not t.startswith("_") for t in texts), texts
    box = fig.bbox
    for text in drawn_texts(fig):
        extent = text.get_window_extent()
        inside = (
            extent.x0 >= box.x0 - 0.5 and extent.x1 <= box.x1 + 0.5 and extent.y0 >= box.y0 - 0.5
            and extent.y1 <= box.y1 + 0.5
        )  # fmt: skip
        assert inside, f"{text.get_text()!r} runs past the figure: {extent} not in {box}"


# --------------------------------------------------------------------------- the paper's figures
@pytest.fixture(scope="module")
def experiment():
    return run_paper_experiment(duration=20.0, seed=3)


def test_the_paper_figures_are_readable(experiment, tmp_path):
    made = experiment.figures()
    assert sorted(made)[:4] == [
        "fig08_input_response.png", "fig09_low_speed_one_step.png", "fig10_low_speed_free_run.png",
        "fig12_identification_error.png",
    ]  # fmt: skip
    assert len(made) == 4 + len(experiment.runs)
    for name, fig in made.items():
        check_readable(fig)
        speed_axes = [label for label in axis_labels_read(fig) if "speed" in label or "y - y_hat" in label]
        assert all("[rpm]" in label for label in speed_axes), (name, speed_axes)  # the rig's rad/s, as rpm
    estimates = made["fig13_estimates_hammerstein_rls_order_4_degree_3.png"]
    assert [ax.get_ylabel() for ax in estimates.axes] == [
        "coefficients of A [-]", "coefficients of B [rad/s per V]", "nonlinearity gamma_j [V^(1-j)]",
    ]  # fmt: skip


def test_fig12s_long_titles_wrap_inside_the_figure():
    t = np.arange(3000) * 0.04
    y = np.sin(t)
    rng = np.random.default_rng(0)
    predictions = {}
    for model in MODELS:
        y_hat = y + 0.01 * rng.standard_normal(t.size)
        y_hat[rng.integers(0, t.size, 9)] += 3.0  # a few samples beyond the common scale: the long note
        predictions[model] = y_hat
    fig = figures.identification_error_figure(t, y, predictions)
    check_readable(fig)
    titles = [ax.get_title() for ax in fig.axes]
    assert any("\n" in title for title in titles)  # the longest did not fit on one line
    for title, model in zip(titles, MODELS, strict=True):  # wrapped between words, nothing lost
        assert title.replace("\n", " ").startswith(f"identification error, {model} (y clipped to ±")
        assert title.replace("\n", " ").endswith(" samples outside)")


@pytest.mark.parametrize(
    ("units", "speed_unit", "input_words"),
    [({"u": "V", "y": "rad/s"}, "rpm", "armature voltage u [V]"),
     ({"u": "%", "y": "rev/s"}, "rev/s", "input u [%]"),
     ({}, UNNAMED_OUTPUT, f"input u [{UNNAMED_INPUT}]")],
    ids=["motorid's units", "duty and rev/s", "no units"],
)  # fmt: skip
def test_the_paper_figures_label_the_records_own_units(units, speed_unit, input_words):
    t = np.arange(500) * 0.01
    u = np.sin(t)
    y = 2.0 * np.sin(t - 0.1)
    predictions = {"model": 1.9 * np.sin(t - 0.1)}
    made = [
        figures.input_response_figure(t, u, y, units),
        figures.low_speed_figure(t, y, predictions, slice(0, 300), units=units),
        figures.identification_error_figure(t, y, predictions, units),
    ]
    for fig in made:
        check_readable(fig)
        y_labels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel() != input_words]
        assert all(label.endswith(f"[{speed_unit}]") for label in y_labels), y_labels
        if not units:  # nothing named: no rpm or rad/s invented anywhere
            assert not re.search(r"rpm|rad/s", " ".join(t.get_text() for t in drawn_texts(fig)))
    assert made[0].axes[0].get_ylabel() == input_words
    # the numbers are the record's, scaled only where a unit is shown in another (rad/s as rpm)
    factor = shown_output(units.get("y")).factor
    assert np.allclose(made[0].axes[1].get_lines()[0].get_ydata(), y * factor)


def test_set_title_keeps_a_short_title_on_one_line_and_wraps_a_long_one():
    fig, ax = figures.subplots(1, 1, figsize=(4, 3))
    figures.set_title(ax, "short")
    assert ax.get_title() == "short"
    long = "a title with many words that cannot fit across a figure only four inches wide, however it is set"
    figures.set_title(ax, long)
    figures.set_title(fig, long)
    assert ax.get_title().count("\n") >= 1 and ax.get_title().replace("\n", " ") == long
    ax.plot([0, 1, 2], [0, 1, 0])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    check_readable(fig)


# --------------------------------------------------------------------------- the residual tests
def test_the_residual_test_figure_has_units_and_a_legend_of_what_it_draws():
    rng = np.random.default_rng(1)
    tests = residual_tests(rng.standard_normal(800), rng.standard_normal(800), max_lag=20)
    fig = residual_tests_figure(
        tests, "Residuals of a model with a name long enough to test the wrapping too"
    )
    check_readable(fig)
    assert len(fig.legends) == 1
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == ["per-lag band", "band for all lags at once (the verdict)", "correlation at each lag"]
    assert all(
        ax.get_xlabel() == "lag tau [samples]" and ax.get_ylabel() == "correlation [-]" for ax in fig.axes
    )


# --------------------------------------------------------------------------- the doctor's figures
@pytest.mark.parametrize("units", ["the record's", "none"])
def test_the_doctors_figures_are_readable_in_the_records_units(units):
    planted = planted_record("coulomb_friction", 1)
    record = planted.record.copy()
    if units == "none":
        record.attrs = {k: v for k, v in planted.record.attrs.items() if k != "units"}
    d = diagnose(record, base=planted.base, max_steps=1)
    velocity = "rad/s" if units == "the record's" else UNNAMED_OUTPUT
    for fig in (residual_figure(d, d._pool.parts[0]), simulation_figure(d, d._pool.parts[0])):
        check_readable(fig)
        assert any(f"[{velocity}]" in label for label in axis_labels_read(fig))
        if units == "none":
            assert not re.search(r"rpm|rad/s", " ".join(t.get_text() for t in drawn_texts(fig)))


# --------------------------------------------------------------------------- the fleet's trends
def fleet_results(unit: str | None) -> pd.DataFrame:
    """Results as ``motorid fleet doctor`` stores them: drive-00 wears (+10 % a day) and grows a
    dead zone on day 4; drive-01 is steady."""
    rows = []
    for drive, growth in (("drive-00", 0.10), ("drive-01", 0.0)):
        for day in range(8):
            row = {"record": f"/r/{drive}_{day}.csv", "drive": drive, "time": pd.Timestamp("2025-03-01")
                   + pd.Timedelta(days=day), "status": "ok", "model.params.coulomb": 0.5 * (1 + growth) ** day,
                   "model.params_std.coulomb": 0.01, "model.params.viscous": 0.02, "model.params_std.viscous": 0.001,
                   "named": "input_dead_zone" if drive == "drive-00" and day >= 4 else ""}  # fmt: skip
            if unit is not None:
                row |= {"units.params.coulomb": unit, "units.params.viscous": f"{unit} s/(rad/s)"}
            rows.append(row)
    return pd.DataFrame(rows)


@pytest.mark.parametrize("unit", ["N m", None], ids=["units in the results", "no units"])
def test_the_trend_figures_label_each_parameters_unit_and_what_is_marked(unit):
    results = fleet_results(unit)
    trends = friction_trends(results)
    flags = flag_drives(trends, results).set_index("drive")
    assert flags.loc["drive-00", "flagged"] and not flags.loc["drive-01", "flagged"]
    for drive, own in trends.groupby("drive"):
        fig = trend_figure(drive, own, flags.loc[drive, "reason"], flags.loc[drive, "appeared"])
        check_readable(fig)
        ylabels = [ax.get_ylabel() for ax in fig.axes]
        if unit is None:
            assert ylabels == ["coulomb [unit not in the results]", "viscous [unit not in the results]"]
        else:
            assert ylabels == ["coulomb [N m]", "viscous [N m s/(rad/s)]"]
        assert fig.axes[-1].get_xlabel() == "record time [date]"
        legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert "estimate per record ±2σ" in legend
        assert ("input_dead_zone appeared" in legend) is (drive == "drive-00")
