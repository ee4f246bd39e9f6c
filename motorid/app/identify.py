"""``motorid identify``'s work on a record, with typed options: the command line and the fleet call it.

- :class:`IdentifyOptions`: the options of ``motorid identify`` by their names;
- :func:`identify`: on a DataFrame of the user's own, columns and units named as on the command
  line (:func:`motorid.io.records.normalise_record`);
- :func:`identify_record`: on a motorid record (columns ``t``, ``u``, ``y``);
- :func:`identify_file`: on a record file read in blocks, in memory that does not grow with it;
- :func:`validate_on_record`: the identified model on a second record, without refitting.

Each returns the ``--json`` payload of ``motorid identify`` (parameters, scores, residual tests).
"""

from __future__ import annotations

import inspect
import itertools
import logging
import math
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError, quoted
from motorid.io.records import RecordOptions

logger = logging.getLogger(__name__)

#: The paper's model order (Table 1's best): the default of ``na`` and ``nb`` where an estimator needs them.
PAPER_ORDER = 4

#: The static block ``motorid identify`` gives ``hammerstein-rls`` when neither ``degree`` nor ``basis``
#: is given: u and sign(u), the shape Coulomb friction gives a drive's steady speed. The paper's cubic
#: (``degree=3``, the estimator's own default) fits sign(u) poorly, and on a duty of ±100 % its u^3
#: column reaches 10**6: identified on the 15 records of ``realmotors/`` its free-run FIT was
#: -160,000 % to 70 % (the models stable, their gain far off), against 78-92 % with u, sign(u)
#: (``tests/test_identify_defaults.py``).
IDENTIFY_BASIS = "u,sign"

#: A free run below this FIT [%] on the record the model was identified on is poor, and ``motorid
#: identify`` warns (:func:`poor_fit_words`): with its defaults it holds 81.6 % (a wheel motor's
#: validation record) to 92.3 % (the kit's chirp) on the real records of ``realmotors/``, ARX 94-95 %
#: on the kit's.
POOR_FIT_PERCENT = 80.0

#: The key of a record's attrs that holds the simulated rig (:meth:`motorid.drive.TwoMassRig.simulate`
#: writes it): a record that has it is motorid's own simulation.
SIMULATED_RIG_ATTR = "rig"


@dataclass(frozen=True)
class IdentifyOptions:
    """``motorid identify``'s options by their names.

    The estimator's arguments ``na`` ... ``gamma_method`` are passed only when given (None:
    the estimator's default); one given to an estimator that does not take it is refused.

    Attributes
    ----------
    estimator : str
        A registered estimator's name (:func:`motorid.estimators.available`).
    na, nb : int, optional
        Orders of A(q^-1) and B(q^-1); None: the estimator's default (the paper's 4 where
        it needs them).
    degree : int, optional
        Polynomial degree of the static block (3: the paper's cubic).
    basis : str, optional
        Basis of the static block, e.g. ``"u,sign"`` or ``"dead_zone:0.8"``. Without ``degree``
        and ``basis``, ``hammerstein-rls`` takes :data:`IDENTIFY_BASIS` (u, sign(u)): the paper's
        cubic gives models far off on measured records (see there), and a note says so.
    lam : float, optional
        Forgetting factor, 0 < lam <= 1.
    delta : float, optional
        Initial covariance ``P0 = delta I``, > 0.
    gamma_method : {"paper", "svd"}, optional
        Hammerstein step 2.
    param : tuple of str
        Further estimator arguments as ``KEY=VALUE`` texts (``--param``).
    low_speed_rpm : float
        The low-speed band of the scores, ``|y| <`` this [rpm].
    skip : int
        Leading samples left out of the scores.
    max_lag : int
        Largest lag of the residual tests [samples].
    model : Path, optional
        A drive model file a friction filter (friction-ekf/ukf) starts from.
    """

    estimator: str = "hammerstein-rls"
    na: int | None = None
    nb: int | None = None
    degree: int | None = None
    basis: str | None = None
    lam: float | None = None
    delta: float | None = None
    gamma_method: str | None = None
    param: tuple[str, ...] = ()
    low_speed_rpm: float = 150.0
    skip: int = 50
    max_lag: int = 25
    model: Path | None = None

    #: The command whose work this is (a fleet's rows say it).
    command = "identify"

    def __post_init__(self) -> None:
        from motorid.estimators import available

        if self.estimator not in available():
            raise DataError(
                f"estimator: unknown estimator {self.estimator!r}; known: {', '.join(available())}"
            )
        if isinstance(self.param, str):
            raise DataError(f"param must be a sequence of KEY=VALUE texts, got the text {self.param!r}")
        object.__setattr__(self, "param", tuple(self.param))

    def row(self, records: list[pd.DataFrame], labels: list[str], figures: Path | None) -> dict[str, Any]:
        """The ``--json`` payload of ``motorid identify`` on the one record of ``records`` (a fleet's
        row: :class:`motorid.fleet.RecordTask`), with ``figures``: the residual-test figure written
        into the folder ``figures`` (none when it is None); ``labels[0]`` names the record."""
        (record,) = records
        payload, tests, _ = identify_record(record, self, source=labels[0])
        written = [write_identify_figure(tests, figures, self.estimator)] if figures is not None else []
        return {**payload, "figures": [str(f) for f in written if f is not None]}


def identify(
    record: pd.DataFrame,
    estimator: str = "hammerstein-rls",
    *,
    record_options: RecordOptions | None = None,
    **options: Any,
) -> dict[str, Any]:
    """``motorid identify`` on a DataFrame of the user's own: its ``--json`` payload.

    The record is read as the command line reads a file with the same options
    (:func:`motorid.io.records.normalise_record`: the named columns become ``t`` [s], ``u`` and
    ``y`` in motorid's units, jittered stamps put on a uniform grid), then identified by
    :func:`identify_record`, so the result equals ``motorid identify FILE --json`` on the
    same data written to a file (without its ``figure`` and ``model``).

    Parameters
    ----------
    record : pandas.DataFrame
        The samples, one row each, with the time (or ``dt``), input and output columns.
    estimator : str
        A registered estimator's name (:func:`motorid.estimators.available`).
    record_options : RecordOptions, optional
        How the record is read (:class:`motorid.io.records.RecordOptions`: its columns, time,
        units and span), as the command line's record options say it; its fields may also be
        given one by one among the keyword arguments (``input="pwm"``, ``input_unit="%"``).
    **options :
        The other fields of :class:`IdentifyOptions` (``na``, ``nb``, ``degree``, ``lam``,
        ``skip``, ``low_speed_rpm``, ``param`` ...).

    Returns
    -------
    dict
        ``estimator``, ``samples``, ``params``, ``scores`` (``one_step`` and ``free_run``: MSE,
        FIT %, low-speed MSE), ``residual_tests``, ``output_unit``, the low-speed threshold and
        ``notes``: what ``motorid identify --json`` prints.

    Examples
    --------
    >>> identify(df, input="pwm", input_unit="%", output="rpm", output_unit="rpm", na=2, nb=2)  # doctest: +SKIP
    """
    from motorid.io.records import normalise_record

    reading, options = RecordOptions.split(record_options, options)
    unknown = sorted(set(options) - {f.name for f in fields(IdentifyOptions)} - {"estimator"})
    if unknown:
        raise DataError(f"identify: unknown option {unknown[0]!r}")
    settings = IdentifyOptions(estimator=estimator, **options)
    normalised = normalise_record(record, reading, min_samples=20)
    payload, _, _ = identify_record(
        normalised, settings, source="the DataFrame", input=reading.input or "u", output=reading.output or "y"
    )
    return payload


def low_speed_band(record: pd.DataFrame, low_speed_rpm: float) -> tuple[str | None, float, str]:
    """The output's unit (None when the record names none), the low-speed threshold, and words for it.

    The band is judged on the output's speed: the output itself, or on a record of
    positions (rad, m) the speed derived from them (``motorid compare``). ``--low-speed-rpm``
    is a speed in rpm: it applies to a speed in rad/s. Any other speed, or one in
    no named unit, gets 10 % of its largest magnitude, and no rpm or rad/s label is
    given to numbers whose unit nobody named.
    """
    unit = (record.attrs.get("units") or {}).get("y")
    y = record["y"].to_numpy()
    if unit in ("rad", "m"):  # positions: the band is on their speed
        speed = np.gradient(y, float(record.attrs["dt"]))
        _, threshold, words = output_band(f"{unit}/s", low_speed_rpm, float(np.max(np.abs(speed))), "|dy/dt|")
        return unit, threshold, words
    largest = None if unit == "rad/s" else float(np.max(np.abs(y)))
    return output_band(unit, low_speed_rpm, largest)


def output_band(
    unit: str | None, low_speed_rpm: float, largest_output: float | None, name: str = "|y|"
) -> tuple[str | None, float, str]:
    """:func:`low_speed_band` of a record whose output (its speed, ``name``) is in ``unit`` and whose
    largest magnitude is ``largest_output`` (needed when ``unit`` is not rad/s): a record read in
    blocks gives the two without being held whole."""
    if unit == "rad/s":
        threshold = low_speed_rpm * 2.0 * math.pi / 60.0
    else:
        if largest_output is None:
            raise ValueError(f"an output in {unit or 'output units'} needs its largest magnitude")
        threshold = 0.1 * largest_output
    return unit, threshold, band_words(unit, threshold, low_speed_rpm, name)


def band_words(unit: str | None, threshold: float, low_speed_rpm: float, name: str = "|y|") -> str:
    """The low-speed band of :func:`low_speed_band` in words (``name``: what it is judged on)."""
    if unit == "rad/s":
        return f"{name} < {low_speed_rpm:g} rpm"
    label = unit or "output units"
    return f"{name} < {threshold:.4g} {label} (10 % of its max: low_speed_rpm=... needs an output in a speed unit)"


def require_finite_estimate(
    name: str, x: np.ndarray, u: np.ndarray, y: np.ndarray, first_row: int = 0
) -> None:
    """Refuse an estimate that stopped being finite, naming the first sample where it did
    (``first_row``: the record's row of ``x[0]``, when ``x`` is a block of it).

    A result with NaN or inf is never reported as a success: it means the record
    drove the estimator out of floating-point range (an outlier, a unit mistake).
    """
    bad = ~np.isfinite(x).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        row = first_row + k
        raise DataError(f"estimator {name!r}: its estimate is not finite from sample {row} on "
                        f"(u = {u[k]:.6g}, y = {y[k]:.6g} there); check the record around row {row}")  # fmt: skip


def _parse_value(text: str) -> Any:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


def takes_identify_basis(name: str, arguments: Any) -> bool:
    """Whether estimator ``name`` with these ``arguments`` (a mapping, or options with ``degree``,
    ``basis`` and ``param``) gets :data:`IDENTIFY_BASIS`: ``hammerstein-rls`` given no static block."""
    if name != "hammerstein-rls":
        return False
    if isinstance(arguments, dict):
        given = {key for key, value in arguments.items() if value is not None}
    else:
        given = {key for key in ("degree", "basis") if getattr(arguments, key, None) is not None}
        given |= {item.partition("=")[0].replace("-", "_") for item in arguments.param}
    return not given & {"degree", "basis"}


def create_estimator(name: str, options: Any, rig: Any = None) -> Any:
    """Build estimator ``name`` from the options; the paper's order 4 where it needs ``na``/``nb``.

    Parameters
    ----------
    name : str
        A registered estimator's name (:func:`motorid.estimators.available`).
    options : IdentifyOptions or argparse.Namespace
        Anything with the attributes ``na``, ``nb``, ``degree``, ``basis``, ``lam``, ``delta``,
        ``gamma_method`` (None: not given) and ``param`` (``KEY=VALUE`` texts); an argument is
        passed only when given, and one the estimator does not take is refused;
        ``hammerstein-rls`` without ``degree`` and ``basis`` gets :data:`IDENTIFY_BASIS`.
    rig : TwoMassRig or RigidDrive, optional
        A drive model: an estimator that has ``from_rig`` (the friction filters) starts from its
        constants and friction; the options override its friction prior.

    Returns
    -------
    Estimator
        The estimator, not yet run.
    """
    from motorid.estimators import available, factory

    if name not in available():
        raise DataError(f"unknown estimator {name!r} (estimator=...); known: {', '.join(available())}")
    make = factory(name)
    if rig is not None and not hasattr(make, "from_rig"):
        raise DataError(f"model=...: estimator {name!r} does not start from a drive model")
    try:
        accepted = inspect.signature(make).parameters
    except (TypeError, ValueError):  # a factory without a signature takes what it is given
        accepted = {}
    kwargs: dict[str, Any] = {}
    for key in ("na", "nb", "degree", "basis", "lam", "delta", "gamma_method"):
        value = getattr(options, key, None)
        option = "--" + key.replace("_", "-")
        if value is None:
            if key in ("na", "nb") and key in accepted and accepted[key].default is inspect.Parameter.empty:
                kwargs[key] = PAPER_ORDER
            continue
        if accepted and key not in accepted:
            raise DataError(f"{option}: estimator {name!r} takes no {key!r} argument")
        kwargs[key] = value
    takes_any = not accepted or any(p.kind is inspect.Parameter.VAR_KEYWORD for p in accepted.values())
    for item in options.param:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise DataError(f"param=... expects KEY=VALUE, got {item!r}")
        key = key.replace("-", "_")
        if not takes_any and key not in accepted:
            keys = ", ".join(k for k, p in accepted.items() if p.kind is not inspect.Parameter.VAR_POSITIONAL)
            raise DataError(
                f"param={quoted(item)}: estimator {name!r} takes no argument {quoted(key)}; it takes {keys}"
            )
        kwargs[key] = _parse_value(value)
    if takes_identify_basis(name, kwargs):
        kwargs["basis"] = IDENTIFY_BASIS
    try:
        return make(**kwargs) if rig is None else make.from_rig(rig, **kwargs)
    except (TypeError, ValueError) as exc:  # the estimator's own check of the arguments the user gave
        raise DataError(f"estimator {name!r}: {exc}") from None


def drive_model_from_file(path: Path, field: str = "model") -> Any:
    """The drive model in the model file ``path``: a two-mass rig or a rigid drive; DataError otherwise,
    naming the ``field`` that gave the file (``model=PATH``)."""
    from motorid.drive import RigidDrive, TwoMassRig
    from motorid.estimators import load_model

    model = load_model(path)
    if not isinstance(model, TwoMassRig | RigidDrive):
        raise DataError(f"{field}={path}: holds a {type(model).__name__}, not a drive model")
    return model


def start_model(options: IdentifyOptions) -> Any:
    """The drive model of ``options.model`` a friction filter starts from (None without one),
    checked before any record is read: the estimator must start from a model (have
    ``from_rig``), the file must hold a drive model, and a rigid drive needs ``--param R=``."""
    from motorid.drive import RigidDrive
    from motorid.estimators import available, factory

    model_file = options.model
    if model_file is None:
        return None
    if options.estimator not in available() or not hasattr(factory(options.estimator), "from_rig"):
        create_estimator(options.estimator, options)  # an unknown name is named first
        raise DataError(
            f"model=...: estimator {options.estimator!r} identifies its model from the record alone; "
            "model=... starts a friction filter (friction-ekf, friction-ukf) from a drive model"
        )
    model = drive_model_from_file(model_file)
    if isinstance(model, RigidDrive) and not any(p.partition("=")[0] == "R" for p in options.param):
        raise DataError(
            f"model={model_file} is a rigid drive, which has no sensor model: give the variance of the "
            "speed measurement with param=R=VALUE [(output unit)^2]"
        )
    return model


def model_input_scale(options: IdentifyOptions, record: pd.DataFrame) -> tuple[float, str | None]:
    """The factor that puts the record's input in the unit ``options.model``'s card says the model
    was fitted on, and a note where it converts (:func:`motorid.app.model_cards.input_scale`:
    % duty <-> V with the card's supply voltage); ``(1.0, None)`` without a model or a card.
    DataError in one line where no supply voltage is known to convert."""
    if options.model is None:
        return 1.0, None
    from motorid.app.model_cards import check_output, input_scale
    from motorid.drive.files import read_model_file

    card = read_model_file(options.model).card
    units = record.attrs.get("units")
    check_output(card, units, options.model.name)
    return input_scale(card, units, options.model.name)


def estimator_for_record(
    record: pd.DataFrame, options: IdentifyOptions, source: str = "the record"
) -> tuple[Any, list[str]]:
    """The estimator ``options.estimator`` names, for this record, and what it assumes (notes for the user).

    An estimator that starts from a drive model (a friction filter, which has ``from_rig``)
    takes the constants and friction of ``options.model`` (a two-mass rig or the doctor's rigid
    drive: :func:`start_model`). Without a model it runs on the default rig's
    constants, which only motorid's own simulation (a record whose attrs carry its rig) is
    known to share: any other record (``source`` names it) is refused, naming ``--model``. The
    record's input unit must be what the model takes (:func:`motorid.comparison.input_unit_note`):
    duty in % is refused by a model in volts; its output a velocity
    (:func:`motorid.comparison.check_output_unit`).
    """
    from motorid.comparison import check_output_unit, input_unit_note
    from motorid.drive import paper_rig
    from motorid.estimators import available, factory

    model = start_model(options)
    units = record.attrs.get("units")
    name = options.estimator
    if model is not None:
        check_output_unit(model, units, f"model={options.model}")
        note = input_unit_note(model, units, f"model={options.model}")
        return create_estimator(name, options, rig=model), [note] if note else []
    if name not in available() or not hasattr(factory(name), "from_rig"):
        notes = []
        if takes_identify_basis(name, options):
            notes.append(
                f"static block {IDENTIFY_BASIS} (u and sign(u), identify's default: the paper's cubic "
                "goes far off on measured records; degree=3 for it)"
            )
        return create_estimator(name, options), notes
    if SIMULATED_RIG_ATTR not in record.attrs:
        raise DataError(
            f"{source}: the {name} needs the drive's model, and this record (not motorid's own "
            "simulation) carries none: give it with model=FILE (the doctor's save_model=... writes one)"
        )
    check_output_unit(paper_rig(), units, "the default rig")
    note = input_unit_note(paper_rig(), units, "the default rig")
    notes = [note] if note else []
    notes.append(
        "without a model (model=...) the filter runs on the default rig's constants (the record is motorid's "
        "simulation)"
    )
    return create_estimator(name, options), notes


def identify_record(
    record: pd.DataFrame,
    options: IdentifyOptions,
    *,
    source: str = "the record",
    input: str = "u",
    output: str = "y",
) -> tuple[dict[str, Any], list, Any]:
    """What ``motorid identify`` computes on a record with columns ``t``, ``u``, ``y``.

    ``motorid identify`` and ``motorid fleet identify`` call this very function on each record
    they hold whole, so a fleet's rows equal the single-record command's output. An estimator
    that runs in blocks (:func:`runs_in_blocks`) is run over the record in the blocks
    ``motorid identify`` reads a file in (:func:`identify_blocks`), so the numbers are those of
    the file read in blocks.

    Parameters
    ----------
    record : pandas.DataFrame
        The record, columns ``t`` [s], ``u``, ``y`` and its attrs (units, timing), as
        :func:`motorid.io.records.read_record` gives it.
    options : IdentifyOptions
        The estimator and the scores' options.
    source : str
        What the record is called in messages (its file).
    input, output : str
        The names of its input and output columns as the user knows them, in messages.

    Returns
    -------
    tuple
        The ``--json`` payload (without ``figure``), the residual tests (for the figure) and
        the identified estimator (for ``--save-model``).
    """
    from motorid.comparison import holds_input
    from motorid.io.records import CHUNK_ROWS, record_timing
    from motorid.validation import (
        RPM_PER_RAD_S,
        check_scored_samples,
        check_signals,
        free_run_divergence,
        score_predictions,
    )

    est, notes = estimator_for_record(record, options, source)
    if runs_in_blocks(est):
        u_all, y_all = record["u"].to_numpy(), record["y"].to_numpy()
        unit, threshold, _ = low_speed_band(record, options.low_speed_rpm)
        return identify_blocks(
            lambda: (
                (u_all[k : k + CHUNK_ROWS], y_all[k : k + CHUNK_ROWS])
                for k in range(0, len(record), CHUNK_ROWS)
            ),
            options, est, notes, unit, threshold, (input, output), source,
        )  # fmt: skip
    u, y = record["u"].to_numpy(), record["y"].to_numpy()
    check_scored_samples(len(u), options.skip, source)
    check_signals({input: u, output: y})
    scale, note = model_input_scale(options, record)
    if note:
        u = u * scale
        notes.append(note)
    if holds_input(est) and record_timing(record.attrs) == "sampled":
        # a physical model's output is at the end of the sample its input is held over
        u, y = u[:-1], y[1:]
        notes.append("the record's timing is sampled: u[k] is paired with y[k+1], the output it drives")
    position = measured_position(est, record, source)
    if position is not None and len(position) > len(u):  # the sampled timing's pairing, as y's
        position = position[1:]
    result = est.batch_filter(u, y) if position is None else est.batch_filter(u, y, position=position)
    require_finite_estimate(options.estimator, result.x, u, y)
    predictions = {"one_step": result.y_hat}
    free_run = est.simulate(u)
    diverged = free_run_divergence(free_run, float(np.max(np.abs(y))))
    if np.isfinite(free_run).all():  # a bounded run is scored, also one beyond the divergence bound
        predictions["free_run"] = free_run
    unit, threshold, _ = low_speed_band(record, options.low_speed_rpm)
    scores = score_predictions(y, predictions, threshold, options.skip)
    in_rpm = unit == "rad/s"
    tests = record_residual_tests(
        u[options.skip :], (y - result.y_hat)[options.skip :], options.max_lag, notes
    )
    payload = {
        "estimator": options.estimator,
        "samples": len(record),
        "residual_tests_samples": len(record) - options.skip,
        "params": est.params,
        "scores": {
            kind: {**row, **({"mse_rpm2": row["mse"] * RPM_PER_RAD_S**2} if in_rpm else {})}
            for kind, row in scores.to_dict("index").items()
        },
        "free_run_diverges_from_sample": diverged,
        "output_unit": unit,
        ("low_speed_threshold_rad_s" if in_rpm else "low_speed_threshold"): threshold,
        "residual_tests": {
            t.name: {"passed": t.passed, "fraction_outside": t.fraction_outside} for t in tests
        },
        "notes": notes,
    }
    param_units = getattr(est, "param_units", None)  # declared by the friction filters
    if param_units:
        payload["units"] = {"params": dict(param_units)}
    payload["free_run_warnings"] = free_run_warnings(payload)
    return payload, tests, est


def free_run_warnings(payload: dict[str, Any]) -> list[str]:
    """The one-line warnings on the identified model's free run (the payload's ``free_run_warnings``,
    printed by ``motorid identify``; a fleet's ``warnings`` column holds the Python warnings of its work): where it diverges
    (:func:`motorid.validation.divergence_words`) and where it fits poorly (:func:`poor_fit_words`).

    Parameters
    ----------
    payload : dict
        :func:`identify_record`'s payload.
    """
    from motorid.validation import divergence_words

    warnings = []
    diverged = payload["free_run_diverges_from_sample"]
    if diverged is not None:
        scored = "free_run" in payload["scores"]
        warnings.append(f"{divergence_words(payload['estimator'], diverged, scored)}; try basis='u,sign' or "
                        "estimator='arx-rls'")  # fmt: skip
    poor = poor_fit_words(payload)
    if poor is not None:
        warnings.append(poor)
    return warnings


def poor_fit_words(payload: dict[str, Any]) -> str | None:
    """One line on a free run that stays bounded but fits its own record below
    :data:`POOR_FIT_PERCENT` (None otherwise, and for a run that diverges, which
    :func:`motorid.validation.divergence_words` words), with what to try. Only the models of a
    lagged regression (ARX, Hammerstein: ``params`` with ``a``) are judged so; a friction filter
    warns of its own divergence (its innovations' test).

    A static block ``u, sign(u)`` whose sign weight is negative, ``x = u - |γ_2| sign(u)``, drives
    the drive backwards at inputs below ``|γ_2|``: no motor does that. It is how least squares
    bends ``u, sign(u)`` towards an input dead zone (no motion at small inputs), which the basis
    cannot hold (the L298N staircase: γ_2 = -0.73 V, free-run FIT 78.3 %; ``--basis
    dead_zone:2`` gives 94.2 %); the line then names the dead zone.

    Parameters
    ----------
    payload : dict
        :func:`identify_record`'s payload (``estimator``, ``scores``, ``params``,
        ``free_run_diverges_from_sample``).
    """
    row = payload["scores"].get("free_run")
    params = payload["params"]
    if row is None or payload["free_run_diverges_from_sample"] is not None or "a" not in params:
        return None
    fit = row["fit_percent"]
    if not fit < POOR_FIT_PERCENT:
        return None
    one_step = payload["scores"]["one_step"]["fit_percent"]
    words = (
        f"{payload['estimator']}: its free run fits {fit:.1f} %, below {POOR_FIT_PERCENT:g} % (one step ahead "
        f"{one_step:.1f} %): the model predicts a sample ahead but does not hold on its own"
    )
    basis = list(params.get("basis", ()))
    if "sign(u)" in basis:
        weight = float(np.asarray(params["gamma"])[basis.index("sign(u)")])
        if weight < 0:
            return (
                f"{words}; its sign(u) weight is negative ({weight:.3g}), so it drives backwards at small "
                "inputs: the mark of an input dead zone, which u,sign cannot hold; try basis='dead_zone:D', D "
                "the input the drive starts to move at (motorid doctor measures it)"
            )
    return f"{words}; try other na=... and nb=... or basis=..., or motorid doctor for the physics it misses"


def record_residual_tests(u: np.ndarray, residual: np.ndarray, max_lag: int, notes: list[str]) -> list:
    """:func:`motorid.validation.residual_tests` of a record's one-step residuals, up to the largest lag
    the record allows (:func:`motorid.validation.residual_max_lag`): a shorter lag than ``max_lag``
    [samples], or no test on a record too short for any, is said in ``notes`` (appended)."""
    from motorid.validation import residual_max_lag, residual_tests

    lag = residual_max_lag(max_lag, len(residual))
    if lag is None:
        notes.append(
            f"no residual tests: {len(residual)} residuals are too few for a correlation at any lag "
            "(at least 8 are needed)"
        )
        return []
    if lag < max_lag:
        notes.append(
            f"residual tests up to lag {lag}, not {max_lag}: the largest below a quarter of the "
            f"{len(residual)} residuals"
        )
    return residual_tests(u, residual, max_lag=lag)


def measured_position(estimator: Any, record: pd.DataFrame, source: str) -> np.ndarray | None:
    """The record's ``position`` column for a friction filter whose drive has a torque that
    depends on the position (``position_effect``: cogging, position friction); None for any
    other estimator. DataError naming the effect and the record when the column is missing.

    Parameters
    ----------
    estimator : Any
        The estimator to run.
    record : DataFrame
        The record (a ``position`` column [rad or m] where its sensor is an encoder).
    source : str
        The record's name in messages.
    """
    effect = getattr(estimator, "position_effect", "")
    if not effect:
        return None
    if "position" not in record.columns:
        raise DataError(
            f"{source}: the model's {effect} torque depends on the position, and the record read has no "
            "position column [rad or m] (an encoder's; motorid identify reads t, u and y only): the "
            "friction filter needs it at every sample"
        )
    return record["position"].to_numpy(dtype=float)


def runs_in_blocks(estimator: Any) -> bool:
    """Whether ``estimator`` is identified on a record in blocks (:func:`identify_blocks`): an RLS
    on a lagged regression, whose state (estimate, covariance, past outputs and inputs) carries
    from one ``batch_filter`` call to the next and whose free run carries its own
    (:class:`motorid.estimators.rls.FreeRun`). The friction filters need the whole record."""
    from motorid.estimators.rls import LaggedRegressionRLS

    return isinstance(estimator, LaggedRegressionRLS)


def identify_blocks(
    blocks: Callable[[], Iterable[tuple[np.ndarray, np.ndarray]]],
    options: IdentifyOptions,
    est: Any,
    notes: list[str],
    unit: str | None,
    threshold: float,
    names: tuple[str, str] = ("u", "y"),
    source: str = "the record",
) -> tuple[dict[str, Any], list, Any]:
    """:func:`identify_record` over a record given in consecutive blocks, in memory that does not
    grow with the record.

    Parameters
    ----------
    blocks : callable
        ``blocks()`` yields the record's ``(u, y)`` blocks from its start; it is called twice.
    options : IdentifyOptions
        The estimator's name, ``skip`` and ``max_lag``.
    est : Estimator
        The estimator to identify (:func:`runs_in_blocks`), built from ``options``.
    notes : list of str
        What the estimator assumes (:func:`estimator_for_record`), passed to the payload.
    unit : str, optional
        The record's output unit (None: none named).
    threshold : float
        The low-speed threshold [output unit] (:func:`low_speed_band`).
    names : (str, str)
        The input and output columns' names, for the messages about bad samples.
    source : str
        What the record is called in messages (its file).

    Notes
    -----
    1. The first pass runs ``batch_filter`` block after block (the estimator carries its state,
       so the estimate is that of one call on the whole record, bit for bit) and scores the
       one-step prediction with running sums (:class:`motorid.validation.RunningScore`). Each
       block is checked as :func:`motorid.validation.check_signals` checks a record, against the
       block's own median and spread (a corrupt cell stops the work at once); a strided sample
       of each signal (:class:`motorid.validation.StridedSample`, the whole signal up to
       :data:`motorid.validation.REFERENCE_SAMPLES` samples) gives the record's median and spread.
    2. The second pass checks every block against the record's median and spread (what
       :func:`~motorid.validation.check_signals` does on a whole record: it catches a unit slip
       that fills most of a block), and runs and scores the identified model's free run
       (:class:`motorid.estimators.rls.FreeRun`), up to the samples the first pass saw (a logger
       may still be appending to the file).

    The residual tests are computed on the last :data:`motorid.validation.RESIDUAL_WINDOW`
    samples of the one-step residual (the whole record when it is no longer;
    ``residual_tests_samples`` in the payload says how many).

    Returns
    -------
    tuple
        What :func:`identify_record` returns.
    """
    from motorid.estimators.rls import FreeRun
    from motorid.validation import (
        REFERENCE_SAMPLES,
        RESIDUAL_WINDOW,
        RPM_PER_RAD_S,
        ResidualWindow,
        RunningScore,
        StridedSample,
        check_outliers,
        check_scored_samples,
        check_signal_block,
        free_run_divergence,
        outlier_reference,
        raise_constant,
    )

    one_step, window = RunningScore(threshold), ResidualWindow(RESIDUAL_WINDOW)
    strided = (StridedSample(REFERENCE_SAMPLES), StridedSample(REFERENCE_SAMPLES))
    first: tuple[float, float] | None = None  # the first sample, to tell a constant column
    varies = [False, False]
    samples = 0
    largest = 0.0  # the largest measured |y|, the free run's bound (free_run_divergence)
    for u, y in blocks():
        for name, values, sample in zip(names, (u, y), strided, strict=True):
            check_signal_block(name, values, samples)
            sample.add(values)
        if first is None and len(u):
            first = (float(u[0]), float(y[0]))
        if first is not None:
            varies = [v or bool(np.any(x != x0)) for v, x, x0 in zip(varies, (u, y), first, strict=True)]
        if len(y):
            largest = max(largest, float(np.max(np.abs(y))))
        result = est.batch_filter(u, y)
        if len(u) and not np.isfinite(result.x[-1]).all():  # a non-finite estimate stays so: the last tells
            require_finite_estimate(options.estimator, result.x, u, y, samples)
        scored = slice(max(0, options.skip - samples), None)
        one_step.add(y[scored], result.y_hat[scored])
        window.add(u[scored], (y - result.y_hat)[scored])
        samples += len(u)
    check_scored_samples(samples, options.skip, source)
    for name, changes, value in zip(names, varies, first or (0.0, 0.0), strict=True):
        if not changes:
            raise_constant(name, value, samples)
    references = [outlier_reference(sample.values) for sample in strided]
    free_run, simulate = RunningScore(threshold), FreeRun(est)
    diverged = None
    finite = True  # a bounded run is scored, also one beyond the divergence bound
    start = 0
    for u, y in blocks():
        if start >= samples:  # a file still being written has grown since the first pass
            break
        u, y = u[: samples - start], y[: samples - start]
        for name, values, reference in zip(names, (u, y), references, strict=True):
            check_outliers(name, values, start, reference)
        if finite:
            y_sim = simulate(u)
            if diverged is None:
                diverged = free_run_divergence(y_sim, largest, start)
            finite = bool(np.isfinite(y_sim).all())
            if finite:
                scored = slice(max(0, options.skip - start), None)
                free_run.add(y[scored], y_sim[scored])
        start += len(u)
    scores = {
        "one_step": one_step.result(),
        **({"free_run": free_run.result()} if finite else {}),
    }
    tests = record_residual_tests(*window.arrays(), options.max_lag, notes)
    in_rpm = unit == "rad/s"
    payload = {
        "estimator": options.estimator,
        "samples": samples,
        "residual_tests_samples": min(window.samples, window.size),
        "params": est.params,
        "scores": {
            kind: {**vars(row), **({"mse_rpm2": row.mse * RPM_PER_RAD_S**2} if in_rpm else {})}
            for kind, row in scores.items()
        },
        "free_run_diverges_from_sample": diverged,
        "output_unit": unit,
        ("low_speed_threshold_rad_s" if in_rpm else "low_speed_threshold"): threshold,
        "residual_tests": {
            t.name: {"passed": t.passed, "fraction_outside": t.fraction_outside} for t in tests
        },
        "notes": notes,
    }
    param_units = getattr(est, "param_units", None)
    if param_units:
        payload["units"] = {"params": dict(param_units)}
    payload["free_run_warnings"] = free_run_warnings(payload)
    return payload, tests, est


def identify_file(
    path: str | os.PathLike[str], options: IdentifyOptions, read: RecordOptions
) -> tuple[dict[str, Any], list, Any]:
    """:func:`identify_blocks` on the record file ``path``, read in blocks
    (:func:`motorid.io.records.iter_record`): memory does not grow with the record.

    The first block gives the record's attrs (its units, whether it is motorid's simulation);
    an output in another unit than rad/s takes one more pass, for its largest magnitude (the
    low-speed band, :func:`output_band`). A record whose time stamps jitter
    is put on a uniform grid, which takes it whole: it is then read and identified as
    :func:`identify_record` does (within ``read.max_samples``); the reader's one line says how
    the stamps were resampled, and the log (``-v``) why the record is held whole.

    Parameters
    ----------
    path : str or os.PathLike
        The record file (any format :func:`motorid.io.records.read_record` reads).
    options : IdentifyOptions
        The estimator and the scores' options.
    read : RecordOptions
        How the record is read (columns, units, sample time; ``max_samples``: most rows of a
        record that must be held whole, one whose stamps jitter). A span (``start``, ``stop``)
        is cut from the record read whole, which is then identified as :func:`identify_record` does.

    Returns
    -------
    tuple
        What :func:`identify_record` returns.
    """
    from motorid.errors import UniformGridError
    from motorid.io.records import CHUNK_ROWS, iter_record, read_record

    names = (read.input or "u", read.output or "y")
    if read.spanned:  # a span is cut from the record read whole
        record = read_record(path, read, min_samples=20, other_columns=False, speed=True)
        return identify_record(record, options, source=str(path), input=names[0], output=names[1])

    def read_blocks() -> Iterator[pd.DataFrame]:
        return iter_record(path, read, min_samples=20, chunk_rows=CHUNK_ROWS, speed=True)

    try:
        passes: Iterator[pd.DataFrame] | None = read_blocks()
        first = next(passes)
        est, notes = estimator_for_record(first, options, str(path))
        unit = (first.attrs.get("units") or {}).get("y")
        largest = None
        if unit != "rad/s":
            largest = max(float(np.max(np.abs(block["y"].to_numpy()))) for block in read_blocks())
        _, threshold, _ = output_band(unit, options.low_speed_rpm, largest)

        def blocks() -> Iterator[tuple[np.ndarray, np.ndarray]]:
            nonlocal passes
            source = read_blocks() if passes is None else itertools.chain([first], passes)
            passes = None
            for block in source:
                yield block["u"].to_numpy(), block["y"].to_numpy()

        return identify_blocks(blocks, options, est, notes, unit, threshold, names, str(path))
    except UniformGridError as exc:
        logger.info("%s: identify reads it whole (max_samples=%s)", exc, read.max_samples)
        record = read_record(path, read, min_samples=20, other_columns=False, speed=True)
        return identify_record(record, options, source=str(path), input=names[0], output=names[1])


def validate_on_record(
    est: Any, record: pd.DataFrame, options: IdentifyOptions, source: str
) -> dict[str, Any]:
    """The identified model ``est`` on a second record, without refitting: its free run on that
    record's input scored as ``identify`` scores its own (``validation`` of the ``--json`` output;
    ``source`` names the record in it).

    The free run is :func:`motorid.comparison.compare_models`'s (the record's timing and the
    model's input unit minded, the first ``options.skip`` samples left out).
    """
    from motorid.comparison import compare_models
    from motorid.validation import RPM_PER_RAD_S

    unit, threshold, _ = low_speed_band(record, options.low_speed_rpm)
    run = compare_models(record, {options.estimator: est}, threshold, options.skip)
    model = run.models[0]
    scores = {}
    if math.isfinite(model.mse):  # a bounded run is scored, also one beyond the divergence bound
        row = {"mse": model.mse, "rmse": model.rmse, "fit_percent": model.fit_percent,
               "low_speed_mse": model.low_speed_mse, "n_low_speed": model.n_low_speed}  # fmt: skip
        scores["free_run"] = {
            **row,
            **({"mse_rpm2": row["mse"] * RPM_PER_RAD_S**2} if unit == "rad/s" else {}),
        }
    return {
        "record": source,
        "samples": len(record),
        "scores": scores,
        "free_run_diverges_from_sample": model.diverges_from,
        "output_unit": unit,
        "notes": list(model.notes),
    }


def write_identify_figure(tests: list, folder: Path, estimator: str) -> Path | None:
    """The residual-test figure of :func:`identify_record` as ``folder/residual_tests.png``; None (no
    figure) when the record was too short for any test (the payload's notes say so)."""
    from motorid.validation import plot_residual_tests

    if not tests:
        return None
    figure = folder / "residual_tests.png"
    plot_residual_tests(tests, str(figure), f"Residuals of {estimator} (one-step)")
    return figure


__all__ = [
    "IDENTIFY_BASIS",
    "PAPER_ORDER",
    "POOR_FIT_PERCENT",
    "IdentifyOptions",
    "create_estimator",
    "free_run_warnings",
    "identify",
    "identify_blocks",
    "identify_file",
    "identify_record",
    "poor_fit_words",
]
