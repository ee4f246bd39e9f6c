"""Simulated records shared by the tests of joint runs: three records of one drive."""

from __future__ import annotations

from motorid.diagnose.synthetic import Planted, planted_record

#: The planted Coulomb friction [N m] of :func:`one_drive_records`.
COULOMB = 8e-3


def one_drive_records() -> list[Planted]:
    """Three records of one drive with Coulomb friction :data:`COULOMB`: the same rig (seed 3),
    three excitations and noise draws."""
    return [
        planted_record("coulomb_friction", 3, sizes={"coulomb": COULOMB}, excitation_seed=k)
        for k in (1, 2, 3)
    ]
