"""Plants: the two-mass DC motor rig, its nonlinear effects, sensors and excitation signals.

>>> from motorid.plants import paper_rig
>>> rig = paper_rig()                # the model: a description, saved with rig.save(path)
>>> sim = rig.simulation(seed=0)    # a running simulation of it
>>> y = sim.step(3.0)               # one 40 ms sample at 3 V; measured load speed [rad/s]
"""

from motorid.plants.amplifier import Amplifier
from motorid.plants.friction import (
    AsymmetricFriction,
    CoulombFriction,
    Friction,
    LuGreFriction,
    StaticFriction,
    StribeckFriction,
    ViscousFriction,
    friction_from_dict,
)
from motorid.plants.rig import (
    PHYSICAL_DEFAULTS,
    RECORD_UNITS,
    RigSimulation,
    TwoMassRig,
    paper_rig,
    steady_state_speed,
)
from motorid.plants.rigid import RIGID_EFFECTS, RigidDrive
from motorid.plants.sensors import ADConverter, Encoder, Tachogenerator, measure_speed

__all__ = [
    "PHYSICAL_DEFAULTS",
    "RECORD_UNITS",
    "RIGID_EFFECTS",
    "ADConverter",
    "Amplifier",
    "AsymmetricFriction",
    "CoulombFriction",
    "Encoder",
    "Friction",
    "LuGreFriction",
    "RigSimulation",
    "RigidDrive",
    "StaticFriction",
    "StribeckFriction",
    "Tachogenerator",
    "TwoMassRig",
    "ViscousFriction",
    "friction_from_dict",
    "measure_speed",
    "paper_rig",
    "steady_state_speed",
]
