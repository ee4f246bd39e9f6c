"""Find the missing effect: locate where simulation and measurement disagree, name the
missing physical effect, add it and show the gap shrink.

>>> from motorid.diagnose import diagnose
>>> d = diagnose(record, base=("viscous_friction", "offset"))   # doctest: +SKIP
>>> d.named, d.stop_reason                                      # doctest: +SKIP
(['coulomb_friction'], 'no candidate passes the evidence threshold: ...')

The effects it names are :mod:`motorid.drive.effects` (one class each, and the registry).
Modules: :mod:`.model` (the fit of
the rigid drive, :class:`motorid.drive.RigidDrive`, whose free run the drive compiles), :mod:`.kinematics`
(zero-phase differentiation and decimation, noise floors), :mod:`.artefacts` (a held start
and drop-out spikes, left out), :mod:`.locate`, :mod:`.workflow` (:func:`diagnose` of one
record or of several records of one drive, in named stages: :mod:`.prepare` the records,
:mod:`.measures` the gaps, residuals and evidence, :mod:`.search` the structure and the effects,
:mod:`.results` the :class:`Diagnosis`), :mod:`.figures`, :mod:`.synthetic` (records with planted
effects) and :mod:`.calibration` (false-alarm rate).
"""

from motorid.diagnose.locate import Region
from motorid.diagnose.model import fit_model
from motorid.diagnose.results import Diagnosis, Step
from motorid.diagnose.search import DEFAULT_BASE, DEFAULT_THRESHOLD
from motorid.diagnose.workflow import diagnose

__all__ = [
    "DEFAULT_BASE",
    "DEFAULT_THRESHOLD",
    "Diagnosis",
    "Region",
    "Step",
    "diagnose",
    "fit_model",
]
