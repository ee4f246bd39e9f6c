"""MATLAB ``.mat`` records (scipy.io): one variable per column, a row or column vector; a v7.3
file is HDF5 and read as such (:mod:`motorid.io.records.hdf5`). MATLAB objects (a ``timeseries``,
a Simulink ``Dataset``, a function handle) are no columns: asked for, they are refused saying how
to save their signals (:func:`motorid.io.records.hdf5.choose_columns`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.io.records.columns import Choose
from motorid.io.records.files import MAT_ATTRS_VARIABLE, attrs_from_json, one_line_reason
from motorid.io.records.hdf5 import choose_columns, read_hdf5

#: The classes :func:`scipy.io.whosmat` gives MATLAB objects: old-style class objects, classdef
#: objects (``opaque``: a ``timeseries``, a Simulink ``Dataset``) and function handles.
MATLAB_OBJECT_CLASSES = ("object", "opaque", "function")


def read_mat(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The columns ``choose`` takes from the MATLAB file ``name`` (a flat vector each) and its record
    attributes (the variable ``motorid_record``, JSON)."""
    import scipy.io

    try:
        listing = scipy.io.whosmat(name)
    except NotImplementedError:  # a MATLAB v7.3 file is an HDF5 file
        return read_hdf5(name, choose)
    except Exception as exc:  # scipy raises many kinds on a file that is not MATLAB's
        raise DataError(f"{name} is not a readable MATLAB file: {one_line_reason(exc)}") from None
    variables = [(var, tuple(shape), kind) for var, shape, kind in listing if var != MAT_ATTRS_VARIABLE]
    shapes = {var: shape for var, shape, kind in variables if kind not in MATLAB_OBJECT_CLASSES}
    objects = {var: "MATLAB" for var, _, kind in variables if kind in MATLAB_OBJECT_CLASSES}
    chosen = choose_columns(name, choose, shapes, objects)
    extra = [MAT_ATTRS_VARIABLE] if len(variables) < len(listing) else []
    try:
        mat = scipy.io.loadmat(name, variable_names=chosen + extra)
    except Exception as exc:  # a cut or corrupt file: zlib, struct, OSError ... depending on where
        raise DataError(
            f"{name}: its MATLAB data cannot be read (cut or corrupt?): {one_line_reason(exc)}"
        ) from None
    attrs = attrs_from_json(mat.get(MAT_ATTRS_VARIABLE), name, f"the variable {MAT_ATTRS_VARIABLE}")
    return {var: np.asarray(mat[var]).reshape(-1) for var in chosen}, attrs
