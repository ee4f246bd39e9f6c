"""``motorid doctor``'s work on a record, or on the records of one drive, with typed options:
the command line and the fleet call it.

- :class:`DoctorOptions`: the options of ``motorid doctor`` by their names (the fleet's
  :class:`motorid.fleet.DoctorJob`); its :meth:`~DoctorOptions.diagnose` runs the doctor
  (:func:`motorid.diagnose.diagnose`) on one record or on several records of one drive fitted
  as one model;
- :func:`doctor`: on a DataFrame of the user's own (or several), columns and units named as on
  the command line: the ``--json`` payload of ``motorid doctor``;
- :func:`start_model_from_file`: the drive model of a ``--model`` file (a rigid drive or a
  two-mass rig), checked before any record is read.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import pandas as pd

from motorid.errors import DataError
from motorid.io.records import RecordOptions

if TYPE_CHECKING:
    from motorid.diagnose.results import Diagnosis
    from motorid.drive import RigidDrive, TwoMassRig


@dataclass(frozen=True)
class DoctorOptions:
    """``motorid doctor``'s options (:func:`motorid.diagnose.diagnose`'s arguments by the same names).

    Attributes
    ----------
    output_kind : {"velocity", "position"}
        What the output column is; a position is differentiated to a velocity.
    input_gain : float, optional
        Force or torque per input unit [N/V or N m/V], > 0; None: the forces come out per
        input unit.
    base : tuple of str, optional
        Effects already in the model (:func:`motorid.drive.effects.names`); None: the
        doctor's default base, or the effects of ``model``.
    candidates : tuple of str, optional
        Effects to try; None (or empty): every effect not in the base.
    holdout : float
        Share of the record held out for the held-out check, in (0, 0.9).
    max_steps : int
        Most effects added, >= 0.
    timing : {"hold", "sampled", "auto"}, optional
        Input/output timing; None: the record's ``attrs["timing"]``, else ``"hold"``.
    structure : bool
        Choose the input delay and lag from the record first; False is ``--no-structure``
        (the base as given).
    align : bool
        Where a record's input delay drifts along it (a logger's time base), put its input on
        its output's time and diagnose again (:func:`motorid.diagnose.diagnose`'s ``align``).
    model : Path, optional
        A drive model file to start from, a rigid drive (``motorid doctor --save-model`` writes
        one) or a two-mass rig (``motorid simulate --save-model``); its effects are the base, so
        ``base`` stays None.
    reference_column : str, optional
        The column of a closed loop's reference (:func:`motorid.diagnose.diagnose`'s
        ``reference_column``); default a column named ``reference`` or ``r``.
    """

    output_kind: Literal["velocity", "position"] = "velocity"
    input_gain: float | None = None
    base: tuple[str, ...] | None = None
    candidates: tuple[str, ...] | None = None
    holdout: float = 0.3
    max_steps: int = 3
    timing: Literal["hold", "sampled", "auto"] | None = None
    structure: bool = True
    align: bool = False
    model: Path | None = None
    reference_column: str | None = None

    #: The command whose work this is (a fleet's rows say it).
    command = "doctor"

    def __post_init__(self) -> None:
        from motorid.drive.effects import names as effect_names

        for key in ("base", "candidates"):
            names = getattr(self, key)
            if names is None:
                continue
            if isinstance(names, str):
                raise DataError(f"{key} must be a sequence of effect names, got the text {names!r}")
            object.__setattr__(self, key, tuple(names))
            for name in names:
                if name not in effect_names():
                    raise DataError(
                        f"{key}: unknown effect {name!r}; known effects: {', '.join(effect_names())}"
                    )
        if self.model is not None and self.base is not None:
            raise DataError("base cannot be combined with model: the model's effects are the base")

    def diagnose(
        self, records: pd.DataFrame | Sequence[pd.DataFrame], labels: Sequence[str] | None = None,
        progress: bool = False,
    ) -> Diagnosis:  # fmt: skip
        """The doctor on a record, or on several records of one drive fitted as one model.

        Parameters
        ----------
        records : pandas.DataFrame or sequence of DataFrame
            A record with columns ``t`` [s], ``u``, ``y`` (as :func:`motorid.io.records.read_record` reads a file),
            or the records of one drive.
        labels : sequence of str, optional
            A name for each record in the report (its file); default ``record 1``, ...
        progress : bool
            Show the doctor's progress bar on stderr.
        """
        from motorid.diagnose import diagnose

        def motorid_columns(record: pd.DataFrame) -> pd.DataFrame:  # a position beside a speed stays behind
            # ... and a closed loop's reference goes along (diagnose's reference_column)
            reference = self.reference_column or (record.attrs.get("loop") or {}).get("reference")
            kept = ("t", "u", "y", *([reference] if reference else ["reference", "r"]))
            part = record[[c for c in dict.fromkeys(kept) if c in record.columns]]
            part.attrs = dict(record.attrs)
            return part

        read = (
            motorid_columns(records)
            if isinstance(records, pd.DataFrame)
            else list(map(motorid_columns, records))
        )
        return diagnose(
            read, as_read=True, output_kind=self.output_kind, input_gain=self.input_gain,
            base=None if self.base is None else list(self.base),
            candidates=None if not self.candidates else list(self.candidates), holdout=self.holdout,
            max_steps=self.max_steps, progress=progress, timing=self.timing, model=self.start_model(),
            structure=self.structure, labels=labels, align=self.align, reference_column=self.reference_column,
        )  # fmt: skip

    def start_model(self) -> Any:
        """The drive model of the ``model`` file (None without one): a rigid drive, or a two-mass
        rig that has a rigid equivalent; DataError for another model or a rig without one."""
        if self.model is None:
            return None
        from motorid.drive import RigidDrive, TwoMassRig
        from motorid.estimators import load_model

        model = load_model(self.model)
        if not isinstance(model, RigidDrive | TwoMassRig):
            raise DataError(
                f"model={self.model}: holds a {type(model).__name__}; the doctor starts from a drive model "
                "(a rigid drive the doctor's save_model=... wrote, or a two-mass rig simulate's "
                "save_model=... wrote)"
            )
        if isinstance(model, TwoMassRig):
            try:
                model.rigid_equivalent()  # the doctor searches on it
            except ValueError as exc:
                raise DataError(f"model={self.model}: {exc}") from None
        return model

    def row(self, records: list[pd.DataFrame], labels: list[str], figures: Path | None) -> dict[str, Any]:
        """The ``--json`` payload of the doctor on ``records`` (with ``named``, ``figures``): a
        fleet's row (:class:`motorid.fleet.RecordTask`, :class:`motorid.fleet.DriveTask`).

        Parameters
        ----------
        records : list of DataFrame
            One record, or the records of one drive (columns ``t``, ``u``, ``y``).
        labels : list of str
            Each record's name (its file).
        figures : Path, optional
            The folder the doctor's figures are written into; None: none written.
        """
        diagnosis = self.diagnose(records[0] if len(records) == 1 else records, labels=labels)
        written = diagnosis.write_figures(figures) if figures is not None else []
        return {
            **diagnosis.to_dict(),
            "named": ",".join(diagnosis.named),
            "figures": [str(f) for f in written],
        }


def doctor(
    records: pd.DataFrame | Sequence[pd.DataFrame],
    *,
    labels: Sequence[str] | None = None,
    record_options: RecordOptions | None = None,
    **options: Any,
) -> dict[str, Any]:
    """``motorid doctor`` on a DataFrame of the user's own, or on several of one drive: its ``--json`` payload.

    Each record is read as the command line reads a file with the same options
    (:func:`motorid.io.records.normalise_record`: the named columns become ``t`` [s], ``u`` and
    ``y`` in motorid's units, as the payload's ``settings`` name them), then doctored by :meth:`DoctorOptions.diagnose`, so the result
    equals ``motorid doctor FILE... --json`` on the same data written to files (without its
    ``figures`` and ``segment``: a DataFrame is never a segment), when ``labels`` are the files'
    names.

    Parameters
    ----------
    records : pandas.DataFrame or sequence of DataFrame
        The samples, one row each, with the time (or ``dt``), input and output columns; several
        records of one drive are fitted as one model.
    labels : sequence of str, optional
        A name for each record in the payload; default ``record 1``, ``record 2`` ...
    record_options : RecordOptions, optional
        How the record is read (:class:`motorid.io.records.RecordOptions`: its columns, time,
        units and span), as the command line's record options say it; its fields may also be
        given one by one among the keyword arguments (``input="pwm"``, ``input_unit="%"``).
    **options :
        The fields of :class:`DoctorOptions` (``base``, ``candidates``, ``input_gain``,
        ``max_steps``, ``holdout``, ``timing``, ``structure``, ``model`` ...).

    Returns
    -------
    dict
        :meth:`motorid.diagnose.Diagnosis.to_dict`: the effects named, the gaps before and after
        [output unit], the final model and its units, the stop reason, the noise floors: what
        ``motorid doctor --json`` prints.

    Examples
    --------
    >>> doctor(df, input="pwm", input_unit="%", supply_voltage=24, output="rpm", output_unit="rpm")  # doctest: +SKIP
    """
    from motorid.io.records import normalise_record

    reading, options = RecordOptions.split(record_options, options)
    unknown = sorted(set(options) - {f.name for f in fields(DoctorOptions)})
    if unknown:
        raise DataError(f"doctor: unknown option {unknown[0]!r}")
    settings = DoctorOptions(**options)
    several = not isinstance(records, pd.DataFrame)
    normalised = [
        normalise_record(record, reading, min_samples=20) for record in (records if several else [records])
    ]
    diagnosis = settings.diagnose(normalised if several else normalised[0], labels=labels)
    return diagnosis.to_dict()


def best_model(diagnosis: Diagnosis) -> tuple[RigidDrive | TwoMassRig, str]:
    """The model ``motorid doctor --save-model`` writes, and words saying which it is.

    On position records the doctor refits its final model's parameters to the records' free-run
    position (:attr:`~motorid.diagnose.results.Diagnosis.position_model`): where that refit's RMS
    position error is the smaller, it is the model saved (the balance fit is named, with its error,
    in the words); else the improved model (:attr:`~motorid.diagnose.results.Diagnosis.improved_model`).

    Parameters
    ----------
    diagnosis : Diagnosis
        What the doctor found.
    """
    error = diagnosis.position_error
    if diagnosis.rig is None and diagnosis.position_model is not None and error is not None:
        if error.refitted < error.fitted:
            unit = diagnosis.units.get("v", "").removesuffix("/s")
            return diagnosis.position_model, (
                f"the model refitted in position (RMS free-run position error {error.refitted:.4g} {unit}; "
                f"the balance fit's {error.fitted:.4g} {unit})"
            )
    kind = "the improved two-mass rig" if diagnosis.rig is not None else "the improved model"
    return diagnosis.improved_model, kind


def save_doctor_model(
    diagnosis: Diagnosis,
    path: str | os.PathLike[str],
    records: Sequence[pd.DataFrame],
    paths: Sequence[str | os.PathLike[str] | None],
    *,
    supply_voltage: float | None = None,
    input_full_scale: float | None = None,
) -> str:
    """Write the doctor's best model (:func:`best_model`) at ``path``, with its card: the records'
    units, sample time and timing, files and SHA-256 (:func:`motorid.app.model_cards.record_card`),
    the sensor the doctor measured (quantisation step, noise floor per speed band) and each
    parameter's standard error [its unit] and whether the records determined it.

    Parameters
    ----------
    diagnosis : Diagnosis
        What the doctor found on ``records``.
    path : str or os.PathLike
        The model file to write (replaced).
    records : sequence of DataFrame
        The records the doctor ran on, as read.
    paths : sequence of path or None
        Their files (None: not a file).
    supply_voltage, input_full_scale : float, optional
        The reading's ``--supply-voltage`` [V] and ``--input-full-scale`` [counts].

    Returns
    -------
    str
        Which model was written, in words.

    Raises
    ------
    DataError
        A model the file cannot hold (a two-mass rig that cannot take the improved effects, a
        model that is not physical), naming ``path``.
    """
    from motorid.app.model_cards import record_card, with_parameters
    from motorid.drive.files import save_model

    what = (
        "the two-mass rig cannot take the improved model"
        if diagnosis.rig is not None
        else "the improved model is not physical"
    )
    try:
        model, words = best_model(diagnosis)  # a rig that cannot carry the improved effects: ValueError
        card = record_card(records, paths, supply_voltage=supply_voltage, input_full_scale=input_full_scale)
        bands = tuple(
            {"speed_from": b.speed_from, "speed_to": b.speed_to, "std": b.noise_floor}
            for b in diagnosis.noise_bands
            if all(map(math.isfinite, (b.speed_from, b.speed_to, b.noise_floor)))
        )
        card = dataclasses.replace(card, quantisation_step=diagnosis.quantisation_step, noise_bands=bands)
        std = diagnosis.param_std if model is diagnosis.model else {}  # the position refit has none
        card = with_parameters(card, std, list(getattr(model, "params", {})), list(diagnosis.undetermined))
        save_model(model, path, card=card)
    except ValueError as exc:
        raise DataError(f"save_model={path}: {what}: {exc}") from None
    return words


def start_model_from_file(path: Path) -> RigidDrive | TwoMassRig:
    """The drive model of the model file ``path`` (``--model``): a rigid drive or a two-mass rig;
    DataError for another model.

    Parameters
    ----------
    path : Path
        The model file.
    """
    return DoctorOptions(model=path).start_model()


__all__ = ["DoctorOptions", "best_model", "doctor", "save_doctor_model", "start_model_from_file"]
