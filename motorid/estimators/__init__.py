"""Recursive estimators behind one filterpy-style interface, and their registry.

>>> from motorid.estimators import create
>>> est = create("hammerstein-rls", na=4, nb=4, degree=3, lam=0.99)
"""

from motorid.lazy import lazy_names

#: The module of each name, imported at the name's first use (the doctor checks its signals
#: with :mod:`motorid.estimators.base` without loading the compiled estimators).
_HOMES = {
    "ARXRLS": "arx",
    "BatchResult": "base",
    "Estimator": "base",
    **dict.fromkeys(
        ("Basis", "BasisFunction", "basis_from_spec", "dead_zone", "polynomial", "power", "sign"), "basis"
    ),
    **dict.fromkeys(("FilterDivergenceError", "FrictionEKF", "FrictionUKF"), "friction_kf"),
    "HammersteinRLS": "hammerstein",
    **dict.fromkeys(
        ("ENTRY_POINT_GROUP", "available", "create", "factory", "register", "unregister"), "registry"
    ),
}
__getattr__, __dir__ = lazy_names(__name__, _HOMES)
__all__ = sorted(_HOMES)
