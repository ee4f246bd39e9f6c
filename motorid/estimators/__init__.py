"""Recursive estimators behind one filterpy-style interface, and their registry.

>>> from motorid.estimators import create
>>> est = create("hammerstein-rls", na=4, nb=4, degree=3, lam=0.99)

``load_model`` and ``save_model`` are those of :mod:`motorid.drive.files`, here with the
estimators' kind of model file registered (importing this package registers it).
"""

from motorid.drive.files import load_model, save_model
from motorid.estimators.arx import ARXRLS
from motorid.estimators.base import BatchResult, Estimator
from motorid.estimators.basis import Basis, BasisFunction, basis_from_spec, dead_zone, polynomial, power, sign
from motorid.estimators.friction_kf import FrictionEKF, FrictionUKF
from motorid.estimators.hammerstein import HammersteinRLS
from motorid.estimators.registry import (
    ENTRY_POINT_GROUP,
    available,
    create,
    factory,
    register,
    unregister,
)

__all__ = [
    "ARXRLS",
    "ENTRY_POINT_GROUP",
    "Basis",
    "BasisFunction",
    "BatchResult",
    "Estimator",
    "FrictionEKF",
    "FrictionUKF",
    "HammersteinRLS",
    "available",
    "basis_from_spec",
    "create",
    "dead_zone",
    "factory",
    "load_model",
    "polynomial",
    "power",
    "register",
    "save_model",
    "sign",
    "unregister",
]
