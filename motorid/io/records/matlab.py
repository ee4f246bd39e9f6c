"""MATLAB ``.mat`` records (scipy.io): one variable per column, a row or column vector; a v7.3
file is HDF5 and read as such (:mod:`motorid.io.records.hdf5`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.io.records.columns import Choose
from motorid.io.records.files import MAT_ATTRS_VARIABLE, attrs_from_json, one_line_reason
from motorid.io.records.hdf5 import read_hdf5


def read_mat(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    import scipy.io

    try:
        listing = scipy.io.whosmat(name)
    except NotImplementedError:  # a MATLAB v7.3 file is an HDF5 file
        return read_hdf5(name, choose)
    except Exception as exc:  # scipy raises many kinds on a file that is not MATLAB's
        raise DataError(f"{name} is not a readable MATLAB file: {one_line_reason(exc)}") from None
    shapes = {var: tuple(shape) for var, shape, _ in listing if var != MAT_ATTRS_VARIABLE}
    chosen = choose(shapes)
    extra = [MAT_ATTRS_VARIABLE] if len(shapes) < len(listing) else []
    try:
        mat = scipy.io.loadmat(name, variable_names=chosen + extra)
    except Exception as exc:  # a cut or corrupt file: zlib, struct, OSError ... depending on where
        raise DataError(
            f"{name}: its MATLAB data cannot be read (cut or corrupt?): {one_line_reason(exc)}"
        ) from None
    attrs = attrs_from_json(mat.get(MAT_ATTRS_VARIABLE), name, f"the variable {MAT_ATTRS_VARIABLE}")
    return {var: np.asarray(mat[var]).reshape(-1) for var in chosen}, attrs
