"""The effects of a drive: one class per effect, one file each, and the registry.

>>> from motorid.drive import effects
>>> effects.names()[:2]
('coulomb_friction', 'stribeck_friction')
>>> effects.get("viscous_friction").units
{'viscous': 'F s/v'}

:mod:`.base` defines :class:`Effect` (what the drive, its model files, the doctor, the
friction filters and the command line need of an effect) and :class:`Parameter` (one
spelling per parameter, with its unit, sign and compiled term); :mod:`.registry` holds the
built-in effects, those registered at run time (:func:`register`) and plugins of the
entry-point group ``motorid.effects``.
"""

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
from motorid.drive.effects.registry import (
    ENTRY_POINT_GROUP,
    effect_names_read,
    effect_order,
    get,
    names,
    param_unit,
    parameter,
    parameter_names,
    parameter_owner,
    register,
    unregister,
)
from motorid.drive.effects.saturation import InputSaturation
from motorid.drive.effects.static_friction import StaticFriction
from motorid.drive.effects.stribeck import StribeckFriction
from motorid.drive.effects.viscous import ViscousFriction

__all__ = [
    "DRIVE_PARAMETERS",
    "ENTRY_POINT_GROUP",
    "AsymmetricFriction",
    "Backlash",
    "Cogging",
    "CoulombFriction",
    "Effect",
    "InputDeadZone",
    "InputDelay",
    "InputLag",
    "InputSaturation",
    "LuGreFriction",
    "Offset",
    "Parameter",
    "PositionFriction",
    "QuadraticDrag",
    "StaticFriction",
    "StribeckFriction",
    "ViscousFriction",
    "effect_names_read",
    "effect_order",
    "get",
    "names",
    "param_unit",
    "parameter",
    "parameter_names",
    "parameter_owner",
    "register",
    "unregister",
]
