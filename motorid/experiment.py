"""The paper's experiment on the simulated rig: ARX-RLS against Hammerstein-RLS.

The default rig (:func:`motorid.drive.paper_rig`) is driven by the paper's test
signal (two sinusoids around 0 V with low-amplitude stretches, Fig. 8), sampled
at 40 ms; a linear ARX model and the paper's Hammerstein model (cubic static
block) are identified online by RLS, and, going beyond the paper, a Hammerstein
model whose static block is a dead zone with its width found by a grid search.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from motorid import figures
from motorid.drive import TwoMassRig, paper_rig
from motorid.estimators import ARXRLS, Estimator, HammersteinRLS
from motorid.estimators.base import BatchResult
from motorid.signals import two_sine_signal
from motorid.units import UNNAMED_OUTPUT, input_unit_name, per
from motorid.validation import RPM_PER_RAD_S, rpm_to_rad_s, score_predictions

logger = logging.getLogger(__name__)


@dataclass
class ModelRun:
    """One identified model: the estimator, its online run and its free run."""

    label: str
    estimator: Estimator
    result: BatchResult
    free_run: np.ndarray
    scores: pd.DataFrame


@dataclass
class PaperExperiment:
    """Result of :func:`run_paper_experiment`.

    Attributes
    ----------
    record : DataFrame
        The simulated record (``t, u, y`` and the true states).
    runs : dict of str to ModelRun
        One entry per model, in the order identified.
    low_speed_threshold : float
        |y| below this counts as low speed [rad/s].
    skip : int
        Leading samples left out of the scores.
    """

    record: pd.DataFrame
    runs: dict[str, ModelRun] = field(default_factory=dict)
    low_speed_threshold: float = 0.0
    skip: int = 0

    def table(self) -> pd.DataFrame:
        """MSE and low-speed MSE [rpm^2] and FIT [%] per model and prediction kind."""
        rows = {}
        for label, run in self.runs.items():
            for kind in ("one_step", "free_run"):
                s = run.scores.loc[kind]
                rows[(label, kind)] = {
                    "mse_rpm2": s["mse"] * RPM_PER_RAD_S**2,
                    "low_speed_mse_rpm2": s["low_speed_mse"] * RPM_PER_RAD_S**2,
                    "fit_percent": s["fit_percent"],
                }
        table = pd.DataFrame.from_dict(rows, orient="index")
        table.index.names = ["model", "prediction"]
        return table

    def figures(self) -> dict[str, Figure]:
        """The paper's Figs. 8-15 for this run, by file name, in the record's units."""
        t = self.record["t"].to_numpy()
        u = self.record["u"].to_numpy()
        y = self.record["y"].to_numpy()
        units = self.record.attrs.get("units") or {}
        one_step = {label: run.result.y_hat for label, run in self.runs.items()}
        free = {f"{label} (free run)": run.free_run for label, run in self.runs.items()}
        dt = float(self.record.attrs.get("dt", t[1] - t[0]))
        window = figures.low_speed_window(y, round(5.0 / dt), self.low_speed_threshold, self.skip)
        out = {
            "fig08_input_response.png": figures.input_response_figure(t, u, y, units),
            "fig09_low_speed_one_step.png": figures.low_speed_figure(
                t,
                y,
                one_step,
                window,
                "Measured (solid) and one-step predicted (dashed) speed at low speed",
                units,
            ),
            "fig10_low_speed_free_run.png": figures.low_speed_figure(
                t,
                y,
                free,
                window,
                "Measured (solid) and free-run simulated (dashed) speed at low speed",
                units,
            ),
            "fig12_identification_error.png": figures.identification_error_figure(t, y, one_step, units),
        }
        u_unit, y_unit = input_unit_name(units.get("u")), units.get("y") or UNNAMED_OUTPUT
        for label, run in self.runs.items():
            est, hist = run.estimator, run.result.x
            na = getattr(est, "na", 0)
            names = est.state_names
            groups = [
                ("coefficients of A [-]", {names[i]: hist[:, i] for i in range(na)}),
                (
                    f"coefficients of B [{per(y_unit, u_unit)}]",
                    {n: hist[:, i] for i, n in enumerate(names) if n.startswith("b")},
                ),
            ]
            if isinstance(est, HammersteinRLS) and est.n_basis > 1:
                _, gamma = est.factorize(hist)
                # gamma_j weighs g_j(u) = u^j (the polynomial built above) against g_1(u) = u: [u]^(1-j)
                power = u_unit if " " not in u_unit else f"({u_unit})"
                groups.append(
                    (
                        f"nonlinearity gamma_j [{power}^(1-j)]",
                        {
                            f"gamma_{j + 1} ({est.basis_functions.names[j]})": gamma[:, j]
                            for j in range(1, est.n_basis)
                        },
                    )
                )
            slug = label.lower().replace(" ", "_").replace(",", "").replace("-", "_")
            out[f"fig13_estimates_{slug}.png"] = figures.estimates_figure(
                t, groups, f"Parameter estimates, {label}"
            )
        return out

    def write_figures(self, out: str | Path) -> list[Path]:
        """Write :meth:`figures` as PNG files in ``out``; the paths."""
        return [figures.save(fig, Path(out) / name) for name, fig in self.figures().items()]


def dead_zone_width_by_grid(
    u: np.ndarray, y: np.ndarray, order: int, widths: np.ndarray, lam: float = 1.0, skip: int = 0
) -> float:
    """The dead-zone half-width d [V] whose Hammerstein model (basis ``dead_zone(d)``)
    has the smallest one-step MSE on the record."""
    best_d, best_mse = float(widths[0]), np.inf
    for d in widths:
        est = HammersteinRLS(order, order, basis=f"dead_zone:{d}", lam=lam)
        y_hat = est.batch_filter(u, y).y_hat
        err = float(np.mean((y[skip:] - y_hat[skip:]) ** 2))
        if err < best_mse:
            best_d, best_mse = float(d), err
    return best_d


def run_paper_experiment(
    rig: TwoMassRig | None = None,
    duration: float = 120.0,
    seed: int = 0,
    order: int = 4,
    degree: int = 3,
    lam: float = 1.0,
    delta: float = 1e3,
    low_speed_rpm: float = 150.0,
    skip: int = 50,
    dead_zone_basis: bool = True,
) -> PaperExperiment:
    """Simulate the rig on the paper's test signal and identify the models online.

    Parameters
    ----------
    rig : TwoMassRig, optional
        The plant; :func:`~motorid.drive.paper_rig` by default.
    duration : float
        Record length [s].
    seed : int
        Seed of the test signal and the sensor noise.
    order, degree : int
        Model order na = nb (4 in the paper) and polynomial degree (3).
    lam, delta : float
        RLS forgetting factor and initial covariance scale.
    low_speed_rpm : float
        |y| below this counts as low speed [rpm].
    skip : int
        Leading samples left out of the scores (2 s at 40 ms).
    dead_zone_basis : bool
        Also identify the Hammerstein model with a dead-zone basis.
    """
    rig = paper_rig() if rig is None else rig
    _, u = two_sine_signal(duration=duration, dt=rig.dt, seed=seed)
    record = rig.simulate(u, seed=seed)
    y = record["y"].to_numpy()
    threshold = float(rpm_to_rad_s(low_speed_rpm))
    models: dict[str, Estimator] = {
        f"ARX-RLS, order {order}": ARXRLS(order, order, lam=lam, delta=delta),
        f"Hammerstein-RLS, order {order}, degree {degree}": HammersteinRLS(
            order, order, degree=degree, lam=lam, delta=delta
        ),
    }
    if dead_zone_basis:
        d = dead_zone_width_by_grid(u, y, order, np.round(np.arange(0.0, 2.01, 0.1), 2), lam, skip)
        logger.info("dead-zone basis: half-width %.2f V chosen by grid search", d)
        models[f"Hammerstein-RLS, order {order}, dead zone {d:g} V"] = HammersteinRLS(
            order, order, basis=f"dead_zone:{d}", lam=lam, delta=delta
        )
    experiment = PaperExperiment(record=record, low_speed_threshold=threshold, skip=skip)
    for label, est in models.items():
        result = est.batch_filter(u, y)
        free_run = est.simulate(u)
        scores = score_predictions(y, {"one_step": result.y_hat, "free_run": free_run}, threshold, skip)
        experiment.runs[label] = ModelRun(label, est, result, free_run, scores)
    return experiment
