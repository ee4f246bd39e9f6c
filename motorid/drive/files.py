"""The envelope of a model file, and its writer.

A model file is one JSON object ``{"format": FORMAT, "version": VERSION, "kind":
KIND, "model": {...}}`` (:mod:`motorid.models` reads every kind). A drive model
writes itself here (``TwoMassRig.save``, ``RigidDrive.save``), so the drive models
need nothing above them to be saved.
"""

from __future__ import annotations

import json
import logging
import os
from typing import Any

from motorid.outputs import write_file

logger = logging.getLogger(__name__)

__all__ = ["FORMAT", "KIND_ESTIMATOR", "KIND_RIG", "KIND_RIGID", "VERSION", "model_file", "write_model_file"]

#: The ``format`` name of a model file.
FORMAT = "motorid-model"
#: The newest ``version`` this motorid writes and reads.
VERSION = 1
#: The ``kind`` of a model file for each kind of model.
KIND_RIG = "two-mass-rig"
KIND_RIGID = "rigid-drive"
KIND_ESTIMATOR = "estimator"


def model_file(kind: str, body: dict[str, Any]) -> dict[str, Any]:
    """The JSON object of a model file of ``kind`` holding ``body``.

    Parameters
    ----------
    kind : str
        :data:`KIND_RIG`, :data:`KIND_RIGID` or :data:`KIND_ESTIMATOR`.
    body : dict
        The model's description (its ``to_dict()``), the file's ``model``.

    Returns
    -------
    dict
        ``{"format": FORMAT, "version": VERSION, "kind": kind, "model": body}``.
    """
    return {"format": FORMAT, "version": VERSION, "kind": kind, "model": body}


def write_model_file(file: dict[str, Any], path: str | os.PathLike[str], *, overwrite: bool = True) -> None:
    """Write the model file ``file`` (:func:`model_file`) at ``path``, whole (:func:`motorid.outputs.write_file`).

    Parameters
    ----------
    file : dict
        The model file's JSON object.
    path : str or os.PathLike
        Where to write it.
    overwrite : bool
        False refuses an existing file, also one another process created meanwhile
        (:class:`~motorid.errors.OutputError`, as for a full disk; ``path`` is then as it
        was).
    """
    text = json.dumps(file, indent=2, allow_nan=False) + "\n"
    write_file(path, lambda fh: fh.write(text), overwrite=overwrite)
    logger.info("wrote model file %s (%s)", path, file["kind"])
