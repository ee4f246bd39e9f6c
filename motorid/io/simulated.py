"""The default DAQ backend: the simulated rig, in process."""

from __future__ import annotations

import logging
import time

from .base import DAQ, Plant, Sample

logger = logging.getLogger(__name__)

__all__ = ["SimulatedDAQ", "plant_to_step"]


def plant_to_step(plant: object | None) -> Plant:
    """The running plant a simulated DAQ or the rig server steps.

    A drive model (a description with ``simulation()``, such as
    ``motorid.drive.paper_rig()`` or a ``RigidDrive``, the doctor's model) gives
    a new simulation of its own, so two
    DAQs of one model never share a state; a :class:`Plant` (``dt``,
    ``reset``, ``step``) is stepped as it is; None is the paper's rig.

    Parameters
    ----------
    plant : object or None
        A drive model, a :class:`Plant`, or None.
    """
    if plant is None:
        from motorid.drive import paper_rig  # the drive models load only when used

        plant = paper_rig()
    simulation = getattr(plant, "simulation", None)
    return simulation() if callable(simulation) else plant  # type: ignore[return-value]


def steps_per_sample(plant_dt: float, dt: float | None) -> int:
    """Number of plant steps in one DAQ sample.

    Parameters
    ----------
    plant_dt : float
        Sample time of the plant [s].
    dt : float or None
        Requested DAQ sample time [s]; None takes the plant's.

    Returns
    -------
    int
        ``dt / plant_dt``, which must be a whole number >= 1.
    """
    if dt is None:
        return 1
    ratio = float(dt) / float(plant_dt)
    n = round(ratio)
    if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
        raise ValueError(f"dt={dt!r} s must be a whole multiple of the plant's sample time {plant_dt!r} s")
    return n


class SimulatedDAQ(DAQ):
    """DAQ backend hosting the simulated rig in process (the default backend).

    Lock-step by default: each :meth:`write` applies the command to the plant
    for one sample (zero-order hold) and :meth:`read` returns the speed
    measured at the end of that sample. With ``realtime=True`` the same
    happens but :meth:`write` also waits for the wall clock, so a loop runs
    at one sample per ``dt`` as on a real rig.

    Parameters
    ----------
    plant : drive model or Plant, optional
        The simulated rig: a model such as ``motorid.drive.paper_rig()`` (the
        default), run in a simulation of the DAQ's own, or a running
        :class:`Plant` (``dt``, ``reset(seed)``, ``step(u)``).
    dt : float, optional
        Sample time [s]; a whole multiple of ``plant.dt`` (default: ``plant.dt``).
    realtime : bool
        Pace samples at the wall clock.
    seed : int, optional
        Seed passed to ``plant.reset`` when the DAQ is opened.
    u_max : float
        Rating of the drive [V]; commands are clamped to ``[-u_max, u_max]``.

    Examples
    --------
    >>> from motorid.io import SimulatedDAQ
    >>> with SimulatedDAQ(seed=0) as daq:            # doctest: +SKIP
    ...     daq.write(3.0)
    ...     sample = daq.read()
    """

    def __init__(
        self,
        plant: object | None = None,
        dt: float | None = None,
        realtime: bool = False,
        seed: int | None = None,
        *,
        u_max: float = 12.0,
    ) -> None:
        super().__init__(u_max=u_max)
        self.plant = plant_to_step(plant)
        self._steps = steps_per_sample(self.plant.dt, dt)
        self._dt = float(self.plant.dt) * self._steps
        self.realtime = bool(realtime)
        self.seed = seed
        self._seq = 0
        self._y = 0.0
        self._clamped = False
        self._t0 = 0.0

    def __repr__(self) -> str:
        return f"SimulatedDAQ(dt={self._dt!r}, realtime={self.realtime!r}, seed={self.seed!r})"

    @property
    def dt(self) -> float:
        """Sample time [s]."""
        return self._dt

    def _open(self) -> None:
        self.plant.reset(seed=self.seed)
        self._seq = 0
        self._y = 0.0
        self._clamped = False
        self._t0 = time.perf_counter()

    def _close(self) -> None:
        pass

    def _write(self, u: float) -> None:
        if not self._is_open:  # close() commanding 0 V after the run: no more steps
            return
        for _ in range(self._steps):
            y = self.plant.step(u)
        self._y = float(y)
        self._seq += 1
        self._clamped = self._last_clamped
        if self.realtime:
            wait = self._t0 + self._seq * self._dt - time.perf_counter()
            if wait > 0:
                time.sleep(wait)

    def read(self) -> Sample:
        """Return the speed measured at the end of the last sample.

        Returns
        -------
        Sample
            ``t = seq * dt`` [s], ``y`` [rad/s], ``u`` the command in force [V].
        """
        return Sample(
            t=self._seq * self._dt,
            seq=self._seq,
            y=self._y,
            u=self._u,
            clamped=self._clamped,
            status=0,
        )
