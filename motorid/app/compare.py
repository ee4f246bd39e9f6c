"""``motorid compare``'s work on a record, with typed options: the command line calls it.

- :class:`CompareOptions`: the options of ``motorid compare`` by their names (the low-speed
  band and the samples skipped at the start);
- :func:`compare`: on a DataFrame of the user's own, columns and units named as on the command
  line: the ``--json`` payload of ``motorid compare``;
- :func:`compare_file`: on a record file, read in blocks when every model's free run carries
  from block to block (memory that does not grow with the record), else whole;
- :func:`load_models`: the models to compare, from model files or as given;
  :func:`load_model_files` with their cards, which are checked against the record.

The comparison itself, each model run free on the record's input and scored, is
:mod:`motorid.comparison`'s.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from motorid.app.identify import low_speed_band, output_band
from motorid.app.model_cards import check_record
from motorid.drive.files import ModelCard, ModelFile
from motorid.errors import DataError
from motorid.io.records import RecordOptions

if TYPE_CHECKING:
    from motorid.comparison import Comparison

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class CompareOptions:
    """``motorid compare``'s options by their names.

    Attributes
    ----------
    low_speed_rpm : float
        The low-speed band of the scores, ``|y| <`` this [rpm] on an output in rad/s
        (any other output: 10 % of its largest magnitude, :func:`motorid.app.identify.low_speed_band`).
    skip : int
        Leading samples left out of the scores (the models start from rest), >= 0.
    """

    low_speed_rpm: float = 150.0
    skip: int = 50

    #: The command whose work this is.
    command = "compare"

    def __post_init__(self) -> None:
        if not isinstance(self.skip, int) or isinstance(self.skip, bool) or self.skip < 0:
            raise DataError(f"skip must be an integer >= 0, got {self.skip!r}")
        if not (isinstance(self.low_speed_rpm, int | float) and 0.0 < self.low_speed_rpm < float("inf")):
            raise DataError(f"low_speed_rpm must be a speed > 0 [rpm], got {self.low_speed_rpm!r}")

    @property
    def min_samples(self) -> int:
        """Fewest samples a record must hold: ``skip`` and :data:`motorid.comparison.MIN_SCORED_SAMPLES` to score."""
        from motorid.comparison import MIN_SCORED_SAMPLES

        return self.skip + MIN_SCORED_SAMPLES


def load_models(models: Mapping[str, Any] | Sequence[str | os.PathLike[str]]) -> dict[str, Any]:
    """The models to compare, by name: each model file loaded (:func:`motorid.load_model`).

    Parameters
    ----------
    models : mapping or sequence
        As :func:`load_model_files`.
    """
    return {name: file.model for name, file in load_model_files(models).items()}


def load_model_files(models: Mapping[str, Any] | Sequence[str | os.PathLike[str]]) -> dict[str, ModelFile]:
    """The models to compare, by name, with their cards: each model file read
    (:func:`motorid.drive.files.read_model_file`); a model given as an object has no card.

    Parameters
    ----------
    models : mapping or sequence
        Model files, each named by its path as the command names it; or a mapping of names to
        models (a drive model or an identified estimator) or to model files.
    """
    import motorid.estimators  # noqa: F401  (registers the estimator kind of model file)
    from motorid.drive.files import VERSION, read_model_file

    if isinstance(models, str | os.PathLike):
        raise DataError(
            f"models must be a sequence of model files or a mapping of names to models, got {models!r}"
        )
    if not isinstance(models, Mapping):
        for model in models:
            if not isinstance(model, str | os.PathLike):
                raise DataError(
                    f"models: a {type(model).__name__} in a sequence has no name; give model files, "
                    "or a mapping of names to models"
                )
    named = dict(models) if isinstance(models, Mapping) else {str(path): path for path in models}
    return {
        name: read_model_file(model)
        if isinstance(model, str | os.PathLike)
        else ModelFile(model, None, VERSION, name)
        for name, model in named.items()
    }


def compare_file(
    path: str | os.PathLike[str],
    models: Mapping[str, Any],
    options: CompareOptions,
    read: RecordOptions,
    cards: Mapping[str, ModelCard | None] | None = None,
) -> tuple[Comparison, str, dict[str, str]]:
    """``motorid compare`` on the record file ``path``: the comparison, the low-speed band in
    words and the record's units.

    The record is compared in blocks (:func:`compare_in_blocks`) when it can be, else read
    whole (:func:`read_whole`) and compared by :func:`motorid.comparison.compare_models`.

    Parameters
    ----------
    path : str or os.PathLike
        The record file.
    models : mapping of str to model
        Label -> a drive model or an identified estimator (:func:`load_models`).
    options : CompareOptions
        The low-speed band and the samples skipped.
    read : RecordOptions
        How the record is read.
    cards : mapping of str to ModelCard or None, optional
        Each model's card (:func:`load_model_files`), checked against the record: its input
        converted (% duty <-> V with a supply voltage) or refused in one line
        (:func:`motorid.app.model_cards.check_record`).
    """
    from motorid.comparison import compare_models

    streamed = compare_in_blocks(path, models, options, read, cards)
    if streamed is not None:
        return streamed
    record = read_whole(path, models, options, read)
    units = record.attrs.get("units") or {}
    scales = check_record(cards or {}, units, read.supply_voltage)
    _, threshold, band = low_speed_band(record, options.low_speed_rpm)
    return compare_models(record, models, threshold, options.skip, scales), band, units


def compare_in_blocks(
    path: str | os.PathLike[str],
    models: Mapping[str, Any],
    options: CompareOptions,
    read: RecordOptions,
    cards: Mapping[str, ModelCard | None] | None = None,
) -> tuple[Comparison, str, dict[str, str]] | None:
    """:func:`motorid.comparison.compare_blocks` on the record ``path`` read in blocks
    (:func:`motorid.io.records.iter_record`), in memory that does not grow with the record:
    the comparison, the low-speed band in words and the record's units. A first pass finds the
    output's largest magnitude: the bound of a diverging free run
    (:func:`motorid.validation.free_run_divergence`) and, for an output in another unit than
    rad/s, the low-speed band (:func:`motorid.app.identify.output_band`).

    None when the record is compared whole instead (:func:`read_whole`): a span (``start``,
    ``stop``), a model whose free run takes the record whole (a friction filter), a record
    of positions (its band is judged on the speed derived from them) or one whose time stamps
    jitter (it is put on a uniform grid, whole); the log says why.

    Parameters
    ----------
    path : str or os.PathLike
        The record file.
    models : mapping of str to model
        Label -> model.
    options : CompareOptions
        The low-speed band and the samples skipped.
    read : RecordOptions
        How the record is read.
    cards : mapping of str to ModelCard or None, optional
        Each model's card, checked against the record (:func:`compare_file`).
    """
    from motorid.comparison import POSITION_UNITS, compare_blocks, runs_in_blocks
    from motorid.errors import UniformGridError
    from motorid.io.records import CHUNK_ROWS, iter_record

    if read.spanned or not all(map(runs_in_blocks, models.values())):
        return None
    if options.min_samples > CHUNK_ROWS:  # a first block must hold the samples skipped and scored
        logger.info("%s: skip=%d is more than a block holds: compared whole", path, options.skip)
        return None
    try:
        first = next(
            iter_record(path, read, min_samples=options.min_samples, chunk_rows=CHUNK_ROWS, speed=True)
        )
        units = dict(first.attrs.get("units") or {})
        scales = check_record(cards or {}, units, read.supply_voltage)
        unit = units.get("y")
        if unit in POSITION_UNITS:
            logger.info("%s: a record of positions, compared whole (max_samples=%s)", path, read.max_samples)
            return None
        largest = max(
            float(np.max(np.abs(b["y"].to_numpy())))
            for b in iter_record(path, read, min_samples=20, chunk_rows=CHUNK_ROWS, speed=True)
        )
        _, threshold, band = output_band(unit, options.low_speed_rpm, largest)
        blocks = iter_record(path, read, min_samples=options.min_samples, chunk_rows=CHUNK_ROWS, speed=True)
        return compare_blocks(blocks, models, threshold, options.skip, largest, scales), band, units
    except UniformGridError as exc:
        logger.info("%s: compare reads it whole (max_samples=%s)", exc, read.max_samples)
        return None


def read_whole(
    path: str | os.PathLike[str], models: Mapping[str, Any], options: CompareOptions, read: RecordOptions
) -> pd.DataFrame:
    """The record ``path`` read whole, for a comparison that cannot be made in blocks
    (:func:`compare_in_blocks`): a span of it (``start``, ``stop``) or, within
    ``max_samples``, the record.

    Parameters
    ----------
    path : str or os.PathLike
        The record file.
    models : mapping of str to model
        Label -> model (named in the message when one takes a long record whole).
    options : CompareOptions
        The samples skipped (the record must hold more).
    read : RecordOptions
        How the record is read.

    Raises
    ------
    DataError
        For a record longer than ``max_samples``, naming what takes it whole.
    """
    from motorid.comparison import model_kind, runs_in_blocks
    from motorid.io.records import read_head, read_record

    if read.spanned:
        return read_record(path, read, min_samples=options.min_samples, other_columns=False, speed=True)
    record, more = read_head(path, read, min_samples=options.min_samples, speed=True)
    if more:
        whole = [
            f"the free run of {name} ({model_kind(m)})" for name, m in models.items() if not runs_in_blocks(m)
        ]
        raise DataError(
            f"{path}: longer than max_samples={read.max_samples}, and "
            f"{whole[0] if whole else 'a record of positions'} takes the record whole: raise max_samples=..."
        )
    return record


def compare(
    record: pd.DataFrame,
    models: Mapping[str, Any] | Sequence[str | os.PathLike[str]],
    *,
    record_options: RecordOptions | None = None,
    **options: Any,
) -> dict[str, Any]:
    """``motorid compare`` on a DataFrame of the user's own: its ``--json`` payload.

    The record is read as the command line reads a file with the same options
    (:func:`motorid.io.records.normalise_record`: the named columns become ``t`` [s], ``u`` and
    ``y`` in motorid's units), then each model runs free on its input and is scored
    (:func:`motorid.comparison.compare_models`), so the result equals
    ``motorid compare FILE --model ... --json`` on the same data written to a file (without its
    ``record`` and ``figure``); the command reads a long file in blocks, whose scores are the
    whole record's up to the rounding of running sums.

    Parameters
    ----------
    record : pandas.DataFrame
        The samples, one row each, with the time (or ``dt``), input and output columns.
    models : mapping or sequence
        Model files (named by their paths, as the command names them), or a mapping of names
        to models or model files (:func:`load_models`).
    record_options : RecordOptions, optional
        How the record is read (:class:`motorid.io.records.RecordOptions`: its columns, time,
        units and span), as the command line's record options say it; its fields may also be
        given one by one among the keyword arguments (``input="pwm"``, ``input_unit="%"``).
    **options :
        The fields of :class:`CompareOptions` (``low_speed_rpm``, ``skip``).

    Returns
    -------
    dict
        ``samples``, ``scored_samples``, ``dt``, ``timing``, ``skip``, ``output_unit``,
        ``low_speed_threshold`` and per model its FIT %, RMSE and low-speed RMSE
        (:meth:`motorid.comparison.Comparison.to_dict`): what ``motorid compare --json`` prints.

    Examples
    --------
    >>> compare(df, ["rig.json", "arx.json"], input="pwm", input_unit="%", supply_voltage=24,
    ...         output="rpm", output_unit="rpm")  # doctest: +SKIP
    """
    from motorid.comparison import compare_models
    from motorid.io.records import normalise_record

    reading, options = RecordOptions.split(record_options, options)
    unknown = sorted(set(options) - {f.name for f in fields(CompareOptions)})
    if unknown:
        raise DataError(f"compare: unknown option {unknown[0]!r}")
    settings = CompareOptions(**options)
    files = load_model_files(models)
    loaded = {name: file.model for name, file in files.items()}
    normalised = normalise_record(record, reading, min_samples=settings.min_samples)
    scales = check_record({name: file.card for name, file in files.items()}, normalised.attrs.get("units"),
                          reading.supply_voltage)  # fmt: skip
    _, threshold, _ = low_speed_band(normalised, settings.low_speed_rpm)
    return compare_models(normalised, loaded, threshold, settings.skip, scales).to_dict()


__all__ = [
    "CompareOptions",
    "compare",
    "compare_file",
    "compare_in_blocks",
    "load_model_files",
    "load_models",
    "read_whole",
]
