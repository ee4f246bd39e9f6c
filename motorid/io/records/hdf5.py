"""HDF5 records (h5py), MATLAB v7.3 files included: a column per one-dimensional dataset,
named by its path; the "structure with time" Simulink logs read by signal name; MATLAB objects
(a ``timeseries``, a Simulink ``Dataset``) refused, saying how to save their signals. Read whole,
or in blocks by slices of the datasets.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.io.records.columns import Blocks, Choose, binary_column, column_chooser, samples_of
from motorid.io.records.files import ATTRS_KEY, attrs_from_json, one_line_reason, regular_file_size
from motorid.io.records.options import quoted

#: What h5py raises on a damaged HDF5 file.
HDF5_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError)


#: What a MATLAB file is read as, in the messages that refuse the objects one holds.
MATLAB_READ = (
    "a MATLAB record is read as a numeric vector per variable (any version of MAT-file, v7.3 included) or "
    "as Simulink's 'Structure With Time' by signal name"
)
#: How to save what a MATLAB object holds so that it is read.
MATLAB_OBJECT_ADVICE = (
    "log the signals as 'Structure With Time' (a To Workspace block's Save format, or the model's Data "
    "Import/Export), or save each signal's time and values as variables (ts = logsout.get('speed').Values; "
    "t = ts.Time; y = ts.Data; save('record.mat', 't', 'y'))"
)


def _hdf5_file(
    name: str,
) -> tuple[Any, dict[str, tuple[int, ...]], dict[str, Any], dict[str, str], dict[str, str]]:
    """An HDF5 file opened (an ``h5py.File``, to be closed by the caller), the shape of each of
    its columns, its record attributes, and each column's dataset path.

    A column is a dataset, named by its path; a MATLAB v7.3 structure that Simulink logs
    ("structure with time": ``sig.time``, ``sig.signals.values``, ``sig.signals.label``) is
    also the column ``sig`` (and its label), and its time the column ``t`` when the file has
    none and every such structure has as many samples. A MATLAB object (a ``timeseries``, a
    Simulink ``Dataset`` that ``sim`` logs: any dataset MATLAB marks with ``MATLAB_object_decode``)
    is no column (:func:`choose_columns` refuses it).

    Returns
    -------
    tuple
        The open file, the shape of each column, the record attributes, each column's dataset
        path, and the MATLAB objects of the file (path -> class name).
    """
    import h5py

    try:
        handle = h5py.File(name, "r")
    except OSError as exc:
        raise DataError(f"{name} is not a readable HDF5 file: {one_line_reason(exc)}") from None
    shapes: dict[str, tuple[int, ...]] = {}
    objects: dict[str, str] = {}
    elsewhere: list[
        str
    ] = []  # what keeps data in other files (raised after the visit: h5py's callbacks must return)

    def visit(key: str, item: Any) -> None:
        if isinstance(item, h5py.Dataset) and not key.startswith("#"):  # '#refs#': MATLAB's own
            if item.external or item.is_virtual:
                elsewhere.append(
                    f"the dataset {quoted(key)} keeps its data in other files "
                    f"({'virtual' if item.is_virtual else 'external storage'})"
                )
            if int(item.attrs.get("MATLAB_object_decode", 0)) > 0:
                objects[key] = _matlab_class(item) or "MATLAB"
            else:
                shapes[key] = tuple(item.shape)

    def visit_link(key: str, link: Any) -> None:
        if isinstance(link, h5py.ExternalLink):
            elsewhere.append(f"{quoted(key)} is a link to {quoted(link.filename)}")

    try:
        try:
            handle.visititems_links(visit_link)
            if not elsewhere:  # an external link is not followed
                handle.visititems(visit)
            text = handle.attrs.get(ATTRS_KEY)
        except HDF5_ERRORS as exc:  # a damaged file
            raise DataError(
                f"{name}: its HDF5 structure cannot be read (corrupt?): {one_line_reason(exc)}"
            ) from None
        if elsewhere:
            raise DataError(
                f"{name}: {elsewhere[0]}: a record is read from its own file only; copy the data into it"
            )
        attrs = attrs_from_json(text, name, f"the root attribute {ATTRS_KEY!r}")
        paths = {key: key for key in shapes}
        signals = _simulink_structures(handle, shapes)
        for signal, (values, _) in signals.items():
            if signal not in shapes:
                shapes[signal], paths[signal] = shapes[values], values
        times = {shapes[time] for _, time in signals.values()}
        if signals and "t" not in shapes and len(times) == 1:
            first = next(iter(signals.values()))[1]
            shapes["t"], paths["t"] = shapes[first], first
    except BaseException:
        handle.close()
        raise
    return handle, shapes, attrs, paths, objects


def _objects_words(objects: dict[str, str]) -> str:
    """The MATLAB objects of a file (name -> class), what is read instead and how to save their signals."""
    listed = [f"{quoted(path)} (a {kind} object)" for path, kind in objects.items()]
    more = f" and {len(listed) - 3} more" if len(listed) > 3 else ""
    return f"{', '.join(listed[:3])}{more}; {MATLAB_READ}: {MATLAB_OBJECT_ADVICE}"


def choose_columns(
    name: str, choose: Choose, shapes: dict[str, tuple[int, ...]], objects: dict[str, str]
) -> list[str]:
    """The columns ``choose`` takes from ``shapes`` in the file ``name`` that also holds the MATLAB
    ``objects`` (variable or dataset name -> class), which are no columns.

    A file of objects alone, and a column asked for that is an object, are refused naming the
    objects, what is read and how to save their signals; any other refusal of ``choose`` names
    the objects too.

    Parameters
    ----------
    name : str
        The file, for the messages.
    choose : Choose
        The chooser of the columns asked for (:func:`~motorid.io.records.columns.column_chooser`).
    shapes : dict
        Column name -> shape of the data the file holds.
    objects : dict
        MATLAB object name -> its class ("MATLAB" when the file does not say).
    """
    if objects and not shapes:
        raise DataError(f"{name} holds only MATLAB objects, which are not read: {_objects_words(objects)}")
    try:
        return choose(shapes)
    except DataError as exc:
        if not objects:
            raise
        for path, kind in objects.items():
            if any(f"column {quoted(key)} is missing" in str(exc) for key in (path, path.rsplit("/", 1)[-1])):
                raise DataError(
                    f"{name}: {quoted(path)} is a {kind} object, which is not read; {MATLAB_READ}: "
                    f"{MATLAB_OBJECT_ADVICE}"
                ) from None
        raise DataError(
            f"{exc}; {name} also holds MATLAB objects, which are not read: {_objects_words(objects)}"
        ) from None


def _matlab_class(item: Any) -> str:
    """The ``MATLAB_class`` attribute of an HDF5 item of a v7.3 MAT-file ('' when it has none)."""
    value = item.attrs.get("MATLAB_class", b"")
    return value.decode("ascii", "replace") if isinstance(value, bytes) else str(value)


def _simulink_structures(handle: Any, shapes: dict[str, tuple[int, ...]]) -> dict[str, tuple[str, str]]:
    """Signal name -> (values path, time path) of the structures with time that Simulink logs in a
    v7.3 MAT-file (a top-level group ``sig`` holding ``time`` and ``signals/values``); a
    structure whose ``signals/label`` names it (MATLAB char, UTF-16 codes) is named by that too."""
    signals: dict[str, tuple[str, str]] = {}
    for key in handle:
        values, time = f"{key}/signals/values", f"{key}/time"
        if (
            values not in shapes
            or time not in shapes
            or samples_of(shapes[values]) != samples_of(shapes[time])
        ):
            continue
        signals[key] = (values, time)
        label = f"{key}/signals/label"
        if label in shapes and shapes[label] and 0 < math.prod(shapes[label]) <= 200:
            text = "".join(map(chr, np.asarray(handle[label][()]).reshape(-1))).strip()
            if text and text not in signals:
                signals[text] = (values, time)
    return signals


def read_hdf5(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    handle, shapes, attrs, paths, objects = _hdf5_file(name)
    with handle:
        chosen = choose_columns(name, choose, shapes, objects)
        try:
            return {key: np.asarray(handle[paths[key]][()]).reshape(-1) for key in chosen}, attrs
        except HDF5_ERRORS as exc:
            raise DataError(
                f"{name}: its HDF5 data cannot be read (corrupt?): {one_line_reason(exc)}"
            ) from None


def hdf5_blocks(name: str, kind: str, mapping: dict[str, str], optional: set[str], chunk_rows: int) -> Blocks:
    """An HDF5 record by slices of ``chunk_rows`` samples of its datasets."""
    if regular_file_size(name) == 0:
        raise DataError(f"{name} is empty")
    handle, shapes, attrs, paths, objects = _hdf5_file(name)
    with handle:
        found: dict[str, str] = {}
        chosen = choose_columns(
            name, column_chooser(name, mapping, False, None, found, optional), shapes, objects
        )
        yield attrs
        yield None
        rows = samples_of(shapes[chosen[0]]) or 0
        for first_row in range(0, rows, chunk_rows):
            block = {}
            for key in chosen:
                shape = shapes[key]
                axis = next((i for i, n in enumerate(shape) if n > 1), 0)  # the one axis along the samples
                where = tuple(
                    slice(first_row, first_row + chunk_rows) if i == axis else 0 for i in range(len(shape))
                )
                try:
                    values = np.asarray(handle[paths[key]][where]).reshape(-1)
                except HDF5_ERRORS as exc:
                    raise DataError(
                        f"{name}: its HDF5 data cannot be read (corrupt?): {one_line_reason(exc)}"
                    ) from None
                block[found[key]] = binary_column(name, key, values, found[key] == "t", first_row)
            yield block
