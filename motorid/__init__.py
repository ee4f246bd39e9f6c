"""motorid: nonlinear modelling and online identification of bidirectional DC motor drives.

>>> import motorid
>>> model = motorid.load_model("rig.json")   # doctest: +SKIP  (a model file: a rig or an estimator)
"""

from motorid.exports import lazy_exports

__version__ = "0.1.0"

__all__ = ["__version__", "load_model", "save_model"]

# load_model and save_model of motorid.drive.files, with every kind of model file registered (the
# drive models' and the estimators'), imported on first use: they pull in the drive models and
# numba, which ``import motorid`` should not.
__getattr__, __dir__ = lazy_exports(
    __name__, {"load_model": "motorid.estimators", "save_model": "motorid.estimators"}
)
