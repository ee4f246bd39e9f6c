"""Plants: the two-mass DC motor rig, its nonlinear effects, sensors and excitation signals.

>>> from motorid.plants import paper_rig
>>> rig = paper_rig()                # the model: a description, saved with rig.save(path)
>>> sim = rig.simulation(seed=0)    # a running simulation of it
>>> y = sim.step(3.0)               # one 40 ms sample at 3 V; measured load speed [rad/s]
"""

from motorid.lazy import lazy_names

#: The module of each name: imported at the name's first use, so that a rigid drive (and the
#: doctor) runs without loading the two-mass rig and its compiled physics.
_HOMES = {
    "Amplifier": "amplifier",
    **dict.fromkeys(
        ("AsymmetricFriction", "CoulombFriction", "Friction", "LuGreFriction", "StaticFriction",
         "StribeckFriction", "ViscousFriction", "friction_from_dict"),
        "friction",
    ),
    **dict.fromkeys(
        ("PHYSICAL_DEFAULTS", "RECORD_UNITS", "RigSimulation", "TwoMassRig", "paper_rig", "steady_state_speed"),
        "rig",
    ),
    "RIGID_EFFECTS": "rigid",
    "RigidDrive": "rigid",
    **dict.fromkeys(("ADConverter", "Encoder", "Tachogenerator", "measure_speed"), "sensors"),
}  # fmt: skip

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
__all__ = sorted(_HOMES)
