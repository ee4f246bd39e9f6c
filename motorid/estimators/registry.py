"""The estimator registry: built-in names, names registered at run time, and plugins.

A package adds an estimator without touching motorid by declaring an entry point in
the group ``motorid.estimators``, e.g. in its ``pyproject.toml``::

    [project.entry-points."motorid.estimators"]
    my-estimator = "my_package.module:MyEstimator"

The entry point names a class (or any factory) whose call with keyword arguments
returns an :class:`~motorid.estimators.base.Estimator`.

This module registers the ``estimator`` kind of model files
(:mod:`motorid.drive.files`): a file names its estimator by the registered name, and
:func:`estimator_from_dict` builds that class from the saved parameters and restores
its state, so a registered class (a plugin's included) that implements ``get_state``
and ``set_state`` is saved and loaded like the built-in ones.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any

from motorid.drive.files import KIND_ESTIMATOR, register_kind
from motorid.errors import ModelFileError
from motorid.estimators.arx import ARXRLS
from motorid.estimators.base import Estimator
from motorid.estimators.friction_kf import FrictionEKF, FrictionUKF
from motorid.estimators.hammerstein import HammersteinRLS
from motorid.json_input import key_path, object_keys, text

logger = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "motorid.estimators"

EstimatorFactory = Callable[..., Estimator]

_BUILT_IN: dict[str, EstimatorFactory] = {
    ARXRLS.name: ARXRLS,
    HammersteinRLS.name: HammersteinRLS,
    FrictionEKF.name: FrictionEKF,
    FrictionUKF.name: FrictionUKF,
}
_REGISTERED: dict[str, EstimatorFactory] = {}
#: The plugins found on the last ``sys.path`` searched: (that path, name -> factory or None).
_plugin_cache: tuple[tuple[str, ...], dict[str, EstimatorFactory | None]] | None = None


def register(name: str, factory: EstimatorFactory, *, replace: bool = False) -> None:
    """Register ``factory`` under ``name`` for this process.

    Parameters
    ----------
    name : str
        The name :func:`create` builds it by.
    factory : callable
        Keyword arguments -> a new :class:`Estimator` (a class, or a function).
    replace : bool
        True takes over a name already registered (a built-in's included).

    Raises
    ------
    ValueError
        When the name is empty or taken (unless ``replace``), or the factory is not callable.
    """
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    if not callable(factory):
        raise ValueError(f"factory for {name!r} must be callable, got {factory!r}")
    if not replace and name in _factories():
        raise ValueError(f"estimator name {name!r} is taken; pass replace=True to override it")
    _REGISTERED[name] = factory


def unregister(name: str) -> None:
    """Forget a name registered with :func:`register` (built-ins and plugins stay).

    Parameters
    ----------
    name : str
        The registered name.

    Raises
    ------
    ValueError
        For a name :func:`register` did not register.
    """
    if name not in _REGISTERED:
        raise ValueError(f"{name!r} was not registered with register()")
    del _REGISTERED[name]


def _plugins() -> dict[str, EstimatorFactory | None]:
    """Entry points of the group, loaded once for each ``sys.path`` (the search reads every
    installed package's metadata: 20-25 ms, and the command line asks for the names three times
    when it builds its parser); a plugin that fails to load is logged and left out."""
    global _plugin_cache
    path = tuple(sys.path)
    if _plugin_cache is not None and _plugin_cache[0] == path:
        return _plugin_cache[1]
    found: dict[str, EstimatorFactory | None] = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in _BUILT_IN:
            continue
        try:
            found[ep.name] = ep.load()
        except Exception as exc:  # a broken plugin must not break the library
            logger.warning("estimator plugin %r (%s) failed to load: %s", ep.name, ep.value, exc)
    _plugin_cache = (path, found)
    return found


def _factories() -> dict[str, EstimatorFactory]:
    merged: dict[str, EstimatorFactory] = dict(_BUILT_IN)
    merged.update({name: f for name, f in _plugins().items() if f is not None})
    merged.update(_REGISTERED)
    return merged


def available() -> list[str]:
    """Sorted names of every estimator that :func:`create` can build."""
    return sorted(_factories())


def create(name: str, **kwargs: Any) -> Estimator:
    """Build the estimator registered as ``name`` with keyword arguments ``kwargs``.

    Parameters
    ----------
    name : str
        A name of :func:`available`.
    **kwargs : Any
        The factory's arguments (``na``, ``nb``, ``lam``, ...; see :func:`factory`).

    Raises
    ------
    ValueError
        For an unknown name (listing the known ones), or when the factory does
        not return an :class:`Estimator`.
    """
    estimator = factory(name)(**kwargs)
    if not isinstance(estimator, Estimator):
        raise ValueError(f"estimator {name!r} built a {type(estimator).__name__}, not a motorid Estimator")
    return estimator


def factory(name: str) -> EstimatorFactory:
    """The factory registered as ``name`` (its signature tells which arguments it takes).

    Parameters
    ----------
    name : str
        A name of :func:`available`.

    Raises
    ------
    ValueError
        For an unknown name, listing the known ones.
    """
    factories = _factories()
    if name not in factories:
        raise ValueError(f"unknown estimator {name!r}; available: {', '.join(sorted(factories))}")
    return factories[name]


def estimator_from_dict(data: Any, where: str = "") -> Estimator:
    """The estimator of a model file's ``model`` (``{"estimator": NAME, "settings": {...},
    "state": {...}}``): the class registered as NAME reads the rest
    (:meth:`Estimator.from_dict <motorid.estimators.base.Estimator.from_dict>`).

    Parameters
    ----------
    data : Any
        The JSON value of the file's ``model``.
    where : str
        Its path in the file, named in the errors.

    Raises
    ------
    ModelFileError
        Naming the key: an unknown name, a name registered by a function (which has no
        reader), or a bad setting or state.
    """
    object_keys(data, ("estimator", "settings", "state"), where)
    at = key_path(where, "estimator")
    name = text(data["estimator"], at)
    factories = _factories()
    if name not in factories:
        raise ModelFileError(at, f"unknown estimator {name!r} (known: {', '.join(sorted(factories))})")
    cls = factories[name]
    if not (isinstance(cls, type) and issubclass(cls, Estimator)):
        raise ModelFileError(
            at,
            f"estimator {name!r} is registered as a function, not an Estimator class: no reader of its files",
        )
    return cls.from_dict(data, where)


register_kind(KIND_ESTIMATOR, Estimator, estimator_from_dict)
