"""The drive: the two-mass DC motor rig, the rigid drive and its effects (:mod:`.effects`), sensors.

>>> from motorid.drive import paper_rig
>>> rig = paper_rig()                # the model: a description, saved with rig.save(path)
>>> sim = rig.simulation(seed=0)    # a running simulation of it
>>> y = sim.step(3.0)               # one 40 ms sample at 3 V; measured load speed [rad/s]
"""

from motorid.drive.components import ADConverter, Amplifier, Encoder, Tachogenerator, measure_speed
from motorid.drive.friction import Friction, friction_from_dict
from motorid.drive.rigid import RigidDrive
from motorid.drive.two_mass import (
    PHYSICAL_DEFAULTS,
    RECORD_UNITS,
    RigSimulation,
    TwoMassRig,
    paper_rig,
    steady_state_speed,
)

__all__ = [
    "PHYSICAL_DEFAULTS",
    "RECORD_UNITS",
    "ADConverter",
    "Amplifier",
    "Encoder",
    "Friction",
    "RigSimulation",
    "RigidDrive",
    "Tachogenerator",
    "TwoMassRig",
    "friction_from_dict",
    "measure_speed",
    "paper_rig",
    "steady_state_speed",
]
