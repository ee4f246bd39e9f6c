"""The card a command writes beside the model it fits (:class:`motorid.drive.files.ModelCard`), and
the check of a model's card against a record or a command's settings.

- :func:`record_card`: what the records a model is fitted on say: the input's unit (and the
  supply voltage that made a duty volts), the output's, the sample time and timing, and each
  record's file, SHA-256 and span.
- :func:`input_scale`: the factor that puts a record's input in the unit a model was fitted on
  (% duty <-> V with a supply voltage), or a one-line refusal naming the model file, the two units
  and what to give.
- :func:`check_output`: a record's output against the model's (a speed, or the position it
  integrates to).
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd

from motorid.drive.files import ModelCard, file_sha256
from motorid.errors import DataError
from motorid.io.records import record_timing

logger = logging.getLogger(__name__)

__all__ = ["check_output", "check_record", "input_scale", "record_card", "with_parameters"]

#: The speed whose integral each position unit is.
SPEED_OF_POSITION = {"rad": "rad/s", "m": "m/s"}


def record_card(
    records: Sequence[pd.DataFrame],
    paths: Sequence[str | os.PathLike[str] | None],
    *,
    supply_voltage: float | None = None,
    input_full_scale: float | None = None,
) -> ModelCard:
    """The card of a model fitted on ``records``, read from the files ``paths``.

    Parameters
    ----------
    records : sequence of DataFrame
        The records as read (columns ``t`` [s], ``u``, ``y``; ``attrs["units"]``, ``dt``, ``timing``).
    paths : sequence of path or None
        Each record's file; None (a DataFrame of the user's own) leaves the record out of the
        card's ``records``, which name files and their SHA-256.
    supply_voltage : float, optional
        The supply voltage [V] that made a duty volts on reading (``--supply-voltage``).
    input_full_scale : float, optional
        The count of full duty of an input read in counts.

    Returns
    -------
    ModelCard
        The output unit is a speed: a record of positions gives the speed it is the integral of
        (the model's free run is a speed, run in position where the record is one).
    """
    first = records[0]
    units = first.attrs.get("units") or {}
    input_unit = units.get("u") if units.get("u") in ("V", "%") else None
    output = units.get("y")
    output = SPEED_OF_POSITION.get(output, output) if output in ("rad/s", "m/s", "rad", "m") else None
    converted = (first.attrs.get("converted_from") or {}).get("u")
    listed = []
    for record, path in zip(records, paths, strict=True):
        if path is None or not Path(path).is_file():
            continue
        t = record["t"].to_numpy(dtype=float)
        listed.append({"file": Path(path).name, "sha256": file_sha256(path), "samples": len(record),
                       "start": float(t[0]), "stop": float(t[-1])})  # fmt: skip
    timing = record_timing(first.attrs)
    return ModelCard(
        input_unit=input_unit,
        supply_voltage=supply_voltage if (input_unit == "V" and converted in ("%", "counts")) else None,
        input_full_scale=input_full_scale if converted == "counts" else None,
        output_unit=output,
        dt=float(first.attrs["dt"]) if first.attrs.get("dt") else None,
        timing=timing,
        records=tuple(listed),
    )


def with_parameters(
    card: ModelCard, standard_errors: Mapping[str, float], params: Sequence[str], undetermined: Sequence[str]
) -> ModelCard:
    """``card`` with each parameter of ``params``: its standard error (None where none is known)
    and whether the records determined it (not in ``undetermined``).

    Parameters
    ----------
    card : ModelCard
        The card to complete.
    standard_errors : mapping of str to float
        Parameter name -> its standard error [the parameter's unit].
    params : sequence of str
        The model's parameters.
    undetermined : sequence of str
        The parameters the records did not determine.
    """
    table = {
        name: {"standard_error": standard_errors.get(name), "determined": name not in undetermined}
        for name in params
    }
    return dataclasses.replace(card, parameters=table)


def input_scale(
    card: ModelCard | None,
    units: Mapping[str, str] | None,
    name: str,
    supply_voltage: float | None = None,
    given_as: str = "this record is",
) -> tuple[float, str | None]:
    """The factor ``k`` such that ``k u`` is the record's input in the unit the model was fitted on,
    and a note when it is not 1.

    ``u_% = 100 u_V / V_s`` and ``u_V = u_% V_s / 100``, with the supply voltage ``V_s`` [V] the
    record was converted with (``supply_voltage``, ``--supply-voltage``) or the model's card holds.

    Parameters
    ----------
    card : ModelCard or None
        The model's card (None: nothing to check, factor 1).
    units : mapping, optional
        The record's ``attrs["units"]`` as read (``u`` in V or %).
    name : str
        The model file's name in the messages.
    supply_voltage : float, optional
        The supply voltage [V] that made the record's duty volts.
    given_as : str
        What gives the input, in the messages (``this record is``; a controller's commands).

    Raises
    ------
    DataError
        One line, naming the model file, the two units and what to give, where no supply voltage
        is known to convert.
    """
    fitted = None if card is None else card.input_unit
    given = (units or {}).get("u")
    if fitted is None or given is None or given == fitted or given not in ("V", "%"):
        return 1.0, None
    supply = supply_voltage if supply_voltage is not None else card.supply_voltage  # type: ignore[union-attr]
    fitted_words = "% duty" if fitted == "%" else fitted
    given_words = "% duty" if given == "%" else given
    if supply is None:
        raise DataError(
            f"{name} was fitted on {fitted_words}; {given_as} in {given_words}: give supply_voltage=... or "
            f"use a model fitted in {given_words}"
        )
    factor = 100.0 / supply if fitted == "%" else supply / 100.0
    whose = (
        "the record's input"
        if given_as == "this record is"
        else given_as.removesuffix(" commands") + "'s commands"
    )
    note = f"{name}: {whose} in {given_words} converted to the model's {fitted_words} ({supply:g} V supply)"
    logger.info(note)
    return factor, note


def check_output(card: ModelCard | None, units: Mapping[str, str] | None, name: str) -> None:
    """Refuse a record whose output is not the model's: another speed, or a position of another
    speed (a rigid drive runs in position on a record of positions).

    Parameters
    ----------
    card : ModelCard or None
        The model's card (None: nothing to check).
    units : mapping, optional
        The record's ``attrs["units"]`` as read (``y`` in SI units).
    name : str
        The model file's name in the message.

    Raises
    ------
    DataError
        One line naming the model file and the two units.
    """
    fitted = None if card is None else card.output_unit
    given = (units or {}).get("y")
    if fitted is None or given is None or SPEED_OF_POSITION.get(given, given) == fitted:
        return
    raise DataError(f"{name} was fitted on an output in {fitted}; this record's output is in {given}")


def check_record(
    cards: Mapping[str, ModelCard | None],
    units: Mapping[str, str] | None,
    supply_voltage: float | None = None,
) -> dict[str, tuple[float, str | None]]:
    """Each model's card against a record's units: its output checked (:func:`check_output`), and,
    for a card that names its input's unit, the factor and note of :func:`input_scale` (the
    ``input_scales`` of :func:`motorid.comparison.compare_models`).

    Parameters
    ----------
    cards : mapping of str to ModelCard or None
        Label (the model file's name) -> its card.
    units : mapping, optional
        The record's ``attrs["units"]`` as read.
    supply_voltage : float, optional
        The supply voltage [V] the record's duty was converted with.

    Raises
    ------
    DataError
        The first model whose card does not fit the record, in one line.
    """
    scales = {}
    for name, card in cards.items():
        check_output(card, units, name)
        if card is not None and card.input_unit is not None:
            scales[name] = input_scale(card, units, name, supply_voltage)
    return scales
