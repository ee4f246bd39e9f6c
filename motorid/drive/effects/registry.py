"""The effect registry: the built-in effects, effects registered at run time, and plugins.

The rigid drive, its model files, the doctor, the friction filters and the command line
know an effect by its name through this registry (:func:`names`, :func:`get`). A package
adds an effect without touching motorid by declaring an entry point in the group
``motorid.effects``, e.g. in its ``pyproject.toml``::

    [project.entry-points."motorid.effects"]
    belt_drag = "my_package.effects:BeltDrag"

The entry point names an :class:`~motorid.drive.effects.base.Effect` subclass; its
name is the class's ``name``. The free run of a drive is compiled, so an effect added from
outside the package is a friction-type effect whose parameters each enter the balance
linearly through one of the compiled terms (``kernels.TERM_*``: ``B ω``, ``F sgn ω``, ``c ω
|ω|``, a constant, ...); the drive, the model files and the doctor then take it as they take
a built-in one.
"""

from __future__ import annotations

import logging
import sys
from importlib.metadata import entry_points

from motorid.drive.effects.asymmetric import AsymmetricFriction
from motorid.drive.effects.backlash import Backlash
from motorid.drive.effects.base import DRIVE_PARAMETERS, Effect, Parameter
from motorid.drive.effects.cogging import Cogging
from motorid.drive.effects.coulomb import CoulombFriction
from motorid.drive.effects.dead_zone import InputDeadZone
from motorid.drive.effects.delay import InputDelay
from motorid.drive.effects.lag import InputLag
from motorid.drive.effects.lugre import LuGreFriction
from motorid.drive.effects.offset import Offset
from motorid.drive.effects.position_friction import PositionFriction
from motorid.drive.effects.quadratic_drag import QuadraticDrag
from motorid.drive.effects.saturation import InputSaturation
from motorid.drive.effects.static_friction import StaticFriction
from motorid.drive.effects.stribeck import StribeckFriction
from motorid.drive.effects.viscous import ViscousFriction
from motorid.errors import ModelFileError
from motorid.json_input import key_path, shown, text

logger = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "motorid.effects"

#: The built-in effects, in the library's order (the order of a drive's effects and parameters).
_BUILT_IN: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        CoulombFriction,
        StribeckFriction,
        AsymmetricFriction,
        ViscousFriction,
        QuadraticDrag,
        InputDeadZone,
        InputSaturation,
        Backlash,
        Offset,
        InputDelay,
        InputLag,
        StaticFriction,
        Cogging,
        PositionFriction,
        LuGreFriction,
    )
}
_REGISTERED: dict[str, type[Effect]] = {}
#: The plugins found on the last ``sys.path`` searched: (that path, name -> class).
_plugin_cache: tuple[tuple[str, ...], dict[str, type[Effect]]] | None = None


def check_effect(effect: object, known: dict[str, type[Effect]]) -> type[Effect]:
    """``effect`` if it can join the effects ``known`` from outside the package; ValueError naming
    what is wrong otherwise.

    Parameters
    ----------
    effect : object
        An :class:`Effect` subclass.
    known : dict
        The effects it joins, by name (its name and parameters must be new to them).
    """
    if not (isinstance(effect, type) and issubclass(effect, Effect)):
        raise ValueError(f"an effect must be a subclass of motorid.drive.effects.Effect, got {effect!r}")
    name = effect.name
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"{effect.__name__}: name must be a snake_case identifier, got {name!r}")
    if (
        effect.kind != "friction"
        or effect.nonlinear
        or effect.rest_only
        or effect.structure
        or effect.position
    ):
        raise ValueError(
            f"effect {name!r}: an effect from outside motorid adds torque terms only (kind 'friction', "
            "every parameter entering the balance linearly through a compiled term)"
        )
    if not effect.parameters:
        raise ValueError(f"effect {name!r} has no parameters")
    taken = {p.name: n for n, cls in known.items() if n != name for p in cls.parameters}
    taken.update({p.name: "every drive" for p in DRIVE_PARAMETERS})
    for p in effect.parameters:
        if p.name in taken:
            raise ValueError(f"effect {name!r}: parameter {p.name!r} is taken by {taken[p.name]}")
    return effect


def register(effect: type[Effect], *, replace: bool = False) -> None:
    """Register ``effect`` (an :class:`Effect` subclass) under its ``name`` for this process.

    Parameters
    ----------
    effect : type
        The effect's class.
    replace : bool
        True takes over a name already registered (a built-in's excepted).

    Raises
    ------
    ValueError
        When it is not an effect the drive can run (see the module notes), its name is taken
        (unless ``replace``; a built-in name always is) or a parameter name is another effect's.
    """
    known = _effects()
    if isinstance(effect, type) and issubclass(effect, Effect):
        if effect.name in _BUILT_IN:
            raise ValueError(f"effect name {effect.name!r} is a built-in effect's")
        if not replace and effect.name in known:
            raise ValueError(f"effect name {effect.name!r} is taken; pass replace=True to override it")
    _REGISTERED[effect.name] = check_effect(effect, known)


def unregister(name: str) -> None:
    """Forget an effect registered with :func:`register` (built-ins and plugins stay).

    Parameters
    ----------
    name : str
        The registered effect's name.

    Raises
    ------
    ValueError
        For a name :func:`register` did not register.
    """
    if name not in _REGISTERED:
        raise ValueError(f"{name!r} was not registered with register()")
    del _REGISTERED[name]


def _plugins() -> dict[str, type[Effect]]:
    """The entry points of the group, loaded once for each ``sys.path``; a plugin that fails to
    load, or is not an effect the drive can run, is logged and left out."""
    global _plugin_cache
    path = tuple(sys.path)
    if _plugin_cache is not None and _plugin_cache[0] == path:
        return _plugin_cache[1]
    found: dict[str, type[Effect]] = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in _BUILT_IN:
            continue
        try:
            effect = check_effect(ep.load(), {**_BUILT_IN, **found})
            if effect.name != ep.name:
                raise ValueError(f"the class is named {effect.name!r}, the entry point {ep.name!r}")
        except Exception as exc:  # a broken plugin must not break the library
            logger.warning("effect plugin %r (%s) failed to load: %s", ep.name, ep.value, exc)
            continue
        found[ep.name] = effect
    _plugin_cache = (path, found)
    return found


def _effects() -> dict[str, type[Effect]]:
    merged = dict(_BUILT_IN)
    merged.update(_plugins())
    merged.update(_REGISTERED)
    return merged


def names() -> tuple[str, ...]:
    """Every effect's name: the built-ins in the library's order, then plugins and registered ones."""
    return tuple(_effects())


def get(name: str) -> Effect:
    """The effect called ``name``; ValueError naming the known ones otherwise.

    Parameters
    ----------
    name : str
        An effect's snake_case name (``coulomb_friction``, ...).
    """
    effects = _effects()
    if name not in effects:
        raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(effects)}")
    return effects[name]()


def effect_names_read(value: object, where: str) -> tuple[str, ...]:
    """The effect names of a model file's list ``value`` at ``where``, each a known effect's;
    :class:`~motorid.errors.ModelFileError` naming the item otherwise.

    Parameters
    ----------
    value : object
        What the file holds there (a list of names).
    where : str
        Its place in the file (``"model.effects"``).
    """
    if not isinstance(value, list):
        raise ModelFileError(where, f"must be a list of effect names, got {shown(value)}")
    known = names()
    for k, name in enumerate(value):
        if text(name, key_path(where, k)) not in known:
            raise ModelFileError(key_path(where, k), f"unknown effect {name!r} (known: {', '.join(known)})")
    return tuple(value)


def effect_order(effects: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """``effects`` without repeats in the library's order; ValueError naming an unknown one.

    Parameters
    ----------
    effects : sequence of str
        Effect names.
    """
    order = list(_effects())
    for name in effects:
        if name not in order:
            raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(order)}")
    return tuple(sorted(dict.fromkeys(effects), key=order.index))


def parameter_names(effects: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """The parameters of a rigid drive with ``effects``: ``inertia``, ``input_gain``, then each
    effect's in the order given.

    Parameters
    ----------
    effects : sequence of str
        Effect names (known ones).
    """
    known = _effects()
    return (
        *(p.name for p in DRIVE_PARAMETERS),
        *(p.name for e in effects for p in known[e].parameters),
    )


def parameter(name: str) -> Parameter:
    """The parameter called ``name``: ``inertia``, ``input_gain`` or any effect's; ValueError
    otherwise.

    Parameters
    ----------
    name : str
        The parameter's name.
    """
    for p in DRIVE_PARAMETERS:
        if p.name == name:
            return p
    for cls in _effects().values():
        for p in cls.parameters:
            if p.name == name:
                return p
    raise ValueError(f"unknown parameter {name!r}: neither a drive's nor any effect's")


def parameter_owner(name: str) -> str:
    """The name of the effect whose parameter ``name`` is; ValueError for none.

    Parameters
    ----------
    name : str
        An effect's parameter name (``coulomb``, ``stribeck_velocity``, ...).
    """
    for effect, cls in _effects().items():
        if any(p.name == name for p in cls.parameters):
            return effect
    raise ValueError(f"unknown parameter {name!r}: no effect's")


def parameter_unit(name: str) -> str:
    """The unit of parameter ``name`` or of a figure an effect derives from its parameters
    (:attr:`Effect.derived_units <motorid.drive.effects.base.Effect.derived_units>`), in the
    model's ``F``, ``v``, ``q`` and ``u``; ValueError for neither.

    Parameters
    ----------
    name : str
        The parameter's or figure's name.
    """
    for cls in _effects().values():
        if name in cls.derived_units:
            return cls.derived_units[name]
    return parameter(name).unit


def param_unit(name: str, units: dict[str, str]) -> str:
    """Concrete unit of parameter ``name`` (of any effect, or ``inertia``/``input_gain``), or of a
    figure an effect derives from its parameters (the cogging's amplitude and phase).

    Parameters
    ----------
    name : str
        Parameter name, e.g. ``"viscous"``.
    units : dict
        Concrete ``F``, ``v`` and ``u`` (:attr:`motorid.diagnose.Diagnosis.units`); the position
        unit ``q`` is the velocity's with the "/s" taken off (``v s`` otherwise) unless given.

    Returns
    -------
    str
        E.g. ``"N m s/(rad/s)"`` for ``viscous`` of a rotary drive with a known
        input gain, ``"V"`` for ``coulomb`` without one (forces per volt).
    """
    if "q" not in units:  # the position unit: the velocity's per second taken off
        v = units.get("v", "v")
        units = {**units, "q": v[: -len("/s")] if v.endswith("/s") else f"{v} s"}
    out = []
    after_slash = False
    for token in parameter_unit(name).replace("/", " / ").split():
        base = token.rstrip("²")
        power = token[len(base) :]
        unit = units.get(base, base)
        compound = " " in unit or "/" in unit
        out.append(f"({unit}){power}" if compound and (power or after_slash) else unit + power)
        after_slash = token == "/"
    return " ".join(out).replace(" / ", "/")


__all__ = [
    "ENTRY_POINT_GROUP",
    "check_effect",
    "effect_names_read",
    "effect_order",
    "get",
    "names",
    "param_unit",
    "parameter",
    "parameter_names",
    "parameter_owner",
    "parameter_unit",
    "register",
    "unregister",
]
