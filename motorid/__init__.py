"""motorid: nonlinear modelling and online identification of bidirectional DC motor drives.

>>> import motorid
>>> model = motorid.load_model("rig.json")   # doctest: +SKIP  (a model file: a rig or an estimator)
"""

from typing import Any

__version__ = "0.1.0"

__all__ = ["__version__", "load_model", "save_model"]


def __getattr__(name: str) -> Any:
    """``load_model`` and ``save_model`` of :mod:`motorid.drive.files`, with every kind of model
    file registered (the drive models' and the estimators'), imported on first use (they pull
    in the drive models and numba, which ``import motorid`` should not)."""
    if name in ("load_model", "save_model"):
        from motorid import estimators

        return getattr(estimators, name)
    raise AttributeError(f"module 'motorid' has no attribute {name!r}")
