"""The hand-off to control design: identified models and drive models as python-control systems.

- :func:`transfer_function` and :func:`state_space`: the linear part ``B(q^-1)/A(q^-1)`` of an
  identified ARX or Hammerstein model as a discrete ``control.TransferFunction`` (or
  ``control.StateSpace``) with its sample time. With a direct term, ``b_0`` is the system's
  feed-through (the record's ``y[k]`` answers ``u[k]`` held over the same sample, motorid's
  ``"hold"`` timing); without one, the numerator starts at ``z^-1``.
- :func:`linearise`: a drive model (the doctor's :class:`~motorid.drive.rigid.RigidDrive` or the
  two-mass :class:`~motorid.drive.two_mass.TwoMassRig`) linearised about a speed as a continuous
  ``control.StateSpace``; input the command u [V], output the (load) speed [rad/s].
- :func:`nonlinear_system`: the whole drive, friction and input path included, as a
  discrete-time ``control.NonlinearIOSystem`` at the drive's sample time, so that
  ``control.input_output_response`` simulates it inside a user's closed loop.

Timing. A python-control discrete system's output at step k is the one of its state at the
start of sample k; motorid's records hold the speed at the end of the sample (``"hold"``).
So for an input ``u``, python-control's ``y[k + 1]`` is motorid's ``y[k]`` for the state-space
exports of the drive, and the identified transfer function (whose direct term makes
``y[k]`` answer ``u[k]``) gives motorid's ``y[k]`` at step k.

Units. Each function takes ``units`` (the input's and the output's unit the system is wanted
in) and ``card`` (what the model is: :class:`~motorid.drive.files.ModelCard`,
``read_model_file(path).card``). The system's signals are named with their units (``u [V]``,
``y [rad/s]``: :func:`signal_names`), and where the card names the model's units and ``units``
asks for others, the system is converted where the conversion is known: % duty and volts with the
supply voltage (``supply_voltage``, or the card's), volts and millivolts, and any two speeds of
one kind (rad/s, rpm, rev/s, deg/s; m/s, mm/s); anything else is refused in one line
(:func:`unit_factors`).

python-control is imported where it is used: the rest of motorid never needs it.
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from motorid.drive.files import ModelCard
from motorid.drive.input_path import InputPathState
from motorid.drive.rigid import RigidDrive, check_sample_time
from motorid.drive.two_mass import TwoMassRig
from motorid.errors import DataError
from motorid.units import INPUT_UNITS, OUTPUT_UNITS

if TYPE_CHECKING:
    import control

logger = logging.getLogger(__name__)

__all__ = [
    "friction_slope",
    "linearise",
    "nonlinear_system",
    "rest_state",
    "signal_names",
    "state_space",
    "transfer_function",
    "unit_factors",
]  # fmt: skip


def _polynomials(estimator: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(num, den)`` in powers of z (highest first) of the estimator's ``B(q^-1)/A(q^-1)``."""
    params = getattr(estimator, "params", None)
    if not isinstance(params, dict) or "a" not in params or "b" not in params:
        raise ValueError(
            f"estimator: expected an ARX or Hammerstein estimator with params 'a' and 'b', got {type(estimator).__name__}"
        )
    a = np.asarray(params["a"], dtype=float).ravel()
    b = np.asarray(params["b"], dtype=float).ravel()
    k0 = int(getattr(estimator, "k0", 0))
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("estimator: its a or b holds NaN or inf (has it seen data yet?)")
    b_full = np.concatenate([np.zeros(k0), b])  # coefficients of q^0, q^-1, ..., q^-nb
    n = max(a.size, b_full.size - 1)
    num = np.zeros(n + 1)
    num[: b_full.size] = b_full
    den = np.zeros(n + 1)
    den[0] = 1.0
    den[1 : a.size + 1] = a
    return num, den


def signal_names(units: tuple[str, str] | None) -> tuple[str, str]:
    """The input's and the output's names of a system: ``u`` and ``y``, with their units where known
    (``units`` = (input unit, output unit), e.g. ``("%", "rad/s")`` gives ``"u [%]"`` and
    ``"y [rad/s]"``: a model file's card, ``read_model_file(path).card``, says them).

    Parameters
    ----------
    units : (str, str) or None
        The input's and the output's units; None: the names alone.
    """
    if units is None:
        return "u", "y"
    if len(units) != 2 or not all(isinstance(unit, str) and unit for unit in units):
        raise ValueError(f"units must be (input unit, output unit), two non-empty texts, got {units!r}")
    return f"u [{units[0]}]", f"y [{units[1]}]"


def unit_factors(
    units: tuple[str, str] | None,
    card: ModelCard | None = None,
    supply_voltage: float | None = None,
    model: str = "the model",
) -> tuple[float, float, tuple[str, str] | None]:
    """The factors that put a model fitted in its card's units into the ``units`` asked for, and
    the units its signals are named with.

    With ``u_model = k_u u`` (the input asked for, in the model's input unit) and
    ``y = k_y y_model`` (the model's output in the unit asked for), a system in the units asked
    for is the model's with its input multiplied by ``k_u`` and its output by ``k_y``:

    - ``%`` duty and ``V`` with the supply voltage ``V_s`` [V]: ``u_% = (100 / V_s) u_V`` and
      ``u_V = (V_s / 100) u_%``; ``mV`` and ``V`` by 1000;
    - speeds of one kind by :data:`motorid.units.OUTPUT_UNITS` (rad/s, rpm, rev/s, deg/s; m/s, mm/s).

    Parameters
    ----------
    units : (str, str) or None
        The input's and the output's units asked for; None: the card's (or none).
    card : ModelCard, optional
        What the model is; None, or a card that names no unit: nothing to convert, ``units`` name
        the signals as given.
    supply_voltage : float, optional
        The drive's supply voltage [V] for % duty and volts; the card's where not given.
    model : str
        The model's name in the messages (its file).

    Returns
    -------
    (float, float, (str, str) or None)
        ``k_u``, ``k_y`` and the signals' units (None: unnamed).

    Raises
    ------
    DataError
        One line naming the model, the two units and what to give, where no conversion is known
        (% duty and volts without a supply voltage, counts, a speed asked of a position or of
        another kind).
    """
    fitted = (None, None) if card is None else (card.input_unit, card.output_unit)
    if units is None:
        return 1.0, 1.0, None if None in fitted else (str(fitted[0]), str(fitted[1]))
    signal_names(units)  # two non-empty texts, or a ValueError naming them
    asked_u, asked_y = units
    k_u = k_y = 1.0
    if fitted[0] is not None and asked_u != fitted[0]:
        supply = supply_voltage if supply_voltage is not None else card.supply_voltage  # type: ignore[union-attr]
        # volts per unit of each input unit a factor to volts is known for (% duty: with a supply)
        volts = {unit: factor for unit, factor in INPUT_UNITS.items() if factor is not None}
        if supply is not None:
            volts["%"] = supply / 100.0
        if asked_u in volts and fitted[0] in volts:
            k_u = volts[asked_u] / volts[fitted[0]]
        elif {asked_u, fitted[0]} <= {"%", *volts}:
            raise DataError(f"{model} was fitted on {card.input_words()}; the system asked for is in "  # type: ignore[union-attr]
                            f"{_words(asked_u)}: give supply_voltage= or ask for {_words(fitted[0])}")  # fmt: skip
        else:
            raise DataError(f"{model} was fitted on {card.input_words()}; no conversion to {asked_u!r} is "  # type: ignore[union-attr]
                            f"known (known: {_words(fitted[0])}, and % duty, V and mV with a supply voltage)")  # fmt: skip
    if fitted[1] is not None and asked_y != fitted[1]:
        factor, base = OUTPUT_UNITS.get(asked_y, (None, None))
        if base != fitted[1] or factor is None:
            same = sorted(u for u, (_, b) in OUTPUT_UNITS.items() if b == fitted[1])
            raise DataError(f"{model} was fitted on an output in {fitted[1]}; no conversion to {asked_y!r} is "
                            f"known (known: {', '.join(same)})")  # fmt: skip
        k_y = 1.0 / factor  # y_asked = y_SI / (SI per asked unit)
    if (k_u, k_y) != (1.0, 1.0):
        logger.info(
            "%s: converted from %s to %s (input x %.6g, output x %.6g)", model, fitted, units, k_u, k_y
        )
    return k_u, k_y, (asked_u, asked_y)


def _words(unit: str) -> str:
    return "% duty" if unit == "%" else unit


def _scaled(sys: control.StateSpace, k_u: float, k_y: float, names: tuple[str, str]) -> control.StateSpace:
    """``sys`` with its input multiplied by ``k_u`` and its output by ``k_y``, named ``names``."""
    import control

    return control.ss(sys.A, sys.B * k_u, sys.C * k_y, sys.D * (k_u * k_y), inputs=names[0], outputs=names[1],
                      states=sys.state_labels, dt=sys.dt)  # fmt: skip


def transfer_function(
    estimator: Any,
    dt: float,
    units: tuple[str, str] | None = None,
    *,
    card: ModelCard | None = None,
    supply_voltage: float | None = None,
) -> control.TransferFunction:
    """The identified linear part ``B(q^-1)/A(q^-1)`` as a discrete transfer function.

    ``A(q^-1) = 1 + a_1 q^-1 + ... + a_na q^-na`` and ``B(q^-1) = b_0 + ... + b_nb q^-nb``
    (without a direct term ``b_1 q^-1 + ...``), multiplied through by ``z^n``,
    ``n = max(na, nb)``::

        H(z) = (b_0 z^n + b_1 z^(n-1) + ... + b_nb z^(n-nb)) / (z^n + a_1 z^(n-1) + ... + a_na z^(n-na))

    For a Hammerstein model this is the block after the static map: its input is
    ``x = Σ_j γ_j g_j(u)`` (``params["gamma"]``, γ_1 = 1), in the unit of u.

    Parameters
    ----------
    estimator : ARXRLS or HammersteinRLS
        An identified estimator (its current ``params``).
    dt : float
        Sample time of the record it was identified on [s].
    units : (str, str), optional
        The input's and the output's units, in the signals' names (:func:`signal_names`);
        converted from the card's (:func:`unit_factors`).
    card : ModelCard, optional
        What the model is (``read_model_file(path).card``): its units. A Hammerstein model's x
        is in the input's unit (γ_1 = 1), so the input's factor converts the block after the
        static map too (the map's γ_j of ``u^j`` then scale by ``k_u^(j-1)``, of ``sign(u)`` by
        ``1 / k_u``).
    supply_voltage : float, optional
        The supply voltage [V] for % duty and volts (the card's where not given).

    Returns
    -------
    control.TransferFunction
        Discrete, sample time ``dt``; input ``u`` (or x), output ``y``, named with their units.
    """
    import control

    dt = check_sample_time(dt)
    num, den = _polynomials(estimator)
    k_u, k_y, named = unit_factors(units, card, supply_voltage)
    u, y = signal_names(named)
    return control.tf(num * (k_u * k_y), den, dt, inputs=u, outputs=y)


def state_space(
    estimator: Any,
    dt: float,
    units: tuple[str, str] | None = None,
    *,
    card: ModelCard | None = None,
    supply_voltage: float | None = None,
) -> control.StateSpace:
    """:func:`transfer_function` as a discrete state-space system (a minimal realisation of it;
    ``D`` holds the direct term b_0).

    Parameters
    ----------
    estimator : Estimator
        An identified ARX or Hammerstein model (:func:`transfer_function`).
    dt : float
        Sample time [s].
    units : (str, str), optional
        The input's and the output's units, in the signals' names (:func:`signal_names`);
        converted from the card's (:func:`unit_factors`).
    card : ModelCard, optional
        What the model is: its units.
    supply_voltage : float, optional
        The supply voltage [V] for % duty and volts (the card's where not given).
    """
    import control

    return control.ss(transfer_function(estimator, dt, units, card=card, supply_voltage=supply_voltage))


def friction_slope(drive: RigidDrive, speed: float, direction: float = 1.0) -> float:
    """d/dω of the rigid drive's friction Σ θ_t T_t(ω) at ``speed`` [F s/v].

    For motion in the direction sgn(speed), or ``direction`` (±1) at zero speed: the
    one-sided slope on that side (viscous, the viscous asymmetry, twice the quadratic drag
    times |ω|, and the Stribeck decay's slope). Levels (Coulomb, asymmetry, offset) have
    no slope: their jump at zero speed is not linear.

    Parameters
    ----------
    drive : RigidDrive
        The drive model.
    speed : float
        The speed ω [v] (rad/s for a drive in SI units).
    direction : float
        ±1: the side taken at zero speed.
    """
    from motorid.drive import kernels

    p = drive.params
    s = math.copysign(1.0, speed) if speed != 0.0 else math.copysign(1.0, direction)
    slope = p.get("viscous", 0.0) + s * p.get("viscous_asymmetry", 0.0)
    slope += 2.0 * p.get("quadratic_drag", 0.0) * abs(speed)
    if "stribeck_friction" in drive.effects:
        rate = 1.0 / p["stribeck_velocity"]
        shape = kernels.STRIBECK_SHAPES.index(drive.stribeck_shape)
        slope += p["stribeck"] * s * kernels.stribeck_decay_slope(float(speed), rate, shape, s)
    return float(slope)


def linearise(
    drive: RigidDrive | TwoMassRig,
    speed: float = 0.0,
    direction: float = 1.0,
    pade_order: int = 1,
    units: tuple[str, str] | None = None,
    *,
    card: ModelCard | None = None,
    supply_voltage: float | None = None,
) -> control.StateSpace:
    """A drive model linearised about the constant ``speed`` [rad/s], as a continuous system.

    Rigid drive (input lag T_l and delay τ_d when the model has them)::

        J dω/dt = g z - β ω,      T_l dz/dt = u - z   (z = u without a lag),
        β = dF/dω at the speed (:func:`friction_slope`)

    and the delay as a Padé approximant of ``pade_order`` in front. Two-mass rig: the
    linear part of eqs. (1)-(7) (:meth:`TwoMassRig.linear_system`, state
    ``[i_a, ω_m, ω_L, δ]``, θ_L dropped) with the slope of each mass's friction
    at the speed added to its viscous term, input ``G u`` (the amplifier's gain).

    What is linear here: the drive beyond its dead zone and inside its saturation (slope
    1 of the input map), where the friction is smooth. At zero speed the friction has a
    jump (Coulomb, Stribeck, asymmetry), which no linear model holds: the slope is the
    one-sided slope for motion in ``direction``, and the jump, with the dead zone, is what
    :class:`~motorid.compensation.FrictionCompensation` cancels ahead of the linear part
    the controller is designed on. Backlash (the rigid drive's dwell or the rig's gap) is
    left out.

    Parameters
    ----------
    drive : RigidDrive or TwoMassRig
    speed : float
        Operating speed ω_0 [rad/s] (the load speed on the rig).
    direction : float
        Side of zero speed to take the slopes on when ``speed == 0``: +1 or -1.
    pade_order : int
        Order of the Padé approximant of the rigid drive's input delay (>= 1).
    units : (str, str), optional
        The input's and the output's units, in the signals' names (:func:`signal_names`; a
        two-mass rig's are V and rad/s); converted from the card's (:func:`unit_factors`).
    card : ModelCard, optional
        What the model is (``read_model_file(path).card``): its units.
    supply_voltage : float, optional
        The supply voltage [V] for % duty and volts (the card's where not given).

    Returns
    -------
    control.StateSpace
        Continuous; input ``u``, output ``y`` (the speed deviation from ω_0 for a deviation of u
        from its value there), named with their units.
    """
    if card is None and isinstance(drive, TwoMassRig):
        card = ModelCard(input_unit="V", output_unit="rad/s")  # the rig's own units
    sys = _linearised(drive, speed, direction, pade_order)
    k_u, k_y, named = unit_factors(units, card, supply_voltage)
    return _scaled(sys, k_u, k_y, signal_names(named))


def _linearised(
    drive: RigidDrive | TwoMassRig, speed: float, direction: float, pade_order: int
) -> control.StateSpace:
    """:func:`linearise` in the model's own units, its signals named ``u`` and ``y``."""
    import control

    u_name, y_name = signal_names(None)

    speed = float(speed)
    if not math.isfinite(speed):
        raise ValueError(f"speed must be finite [rad/s], got {speed!r}")
    if direction not in (1, -1, 1.0, -1.0):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if isinstance(drive, RigidDrive):
        J, g = drive.inertia, drive.input_gain
        beta = friction_slope(drive, speed, direction)
        T_l = drive.params.get("lag_time_constant", 0.0)
        if T_l > 0.0:
            A = np.array([[-beta / J, g / J], [0.0, -1.0 / T_l]])
            B = np.array([[0.0], [1.0 / T_l]])
            C = np.array([[1.0, 0.0]])
            states = ["omega", "lag"]
        else:
            A, B, C, states = np.array([[-beta / J]]), np.array([[g / J]]), np.array([[1.0]]), ["omega"]
        sys = control.ss(A, B, C, np.zeros((1, 1)), inputs=u_name, outputs=y_name, states=states)
        delay = drive.params.get("input_delay", 0.0)
        if delay > 0.0:
            if isinstance(pade_order, bool) or not isinstance(pade_order, int) or pade_order < 1:
                raise ValueError(f"pade_order must be an integer >= 1, got {pade_order!r}")
            num, den = control.pade(delay, pade_order)
            sys = control.series(control.ss(control.tf(num, den)), sys)
            sys = control.ss(sys.A, sys.B, sys.C, sys.D, inputs=u_name, outputs=y_name)
        if "backlash" in drive.effects:
            logger.info("linearise: the rigid drive's backlash dwell is not in the linear model")
        return sys
    if isinstance(drive, TwoMassRig):
        if drive.has_lugre:
            raise ValueError("linearise: LuGre friction has an internal state; it is not linearised here")
        A5, B5 = drive.linear_system()
        A = A5[:4, :4].copy()
        for k, (side, J) in ((1, ("motor", drive.J_m)), (2, ("load", drive.J_l))):
            A[k, k] -= _rig_static_slope(drive, side, speed, direction) / J
        B = B5[:4, :1] * drive.amplifier.gain
        C = np.array([[0.0, 0.0, 1.0, 0.0]])
        return control.ss(A, B, C, np.zeros((1, 1)), inputs=u_name, outputs=y_name,
                          states=["i_a", "omega_m", "omega_l", "twist"])  # fmt: skip
    raise ValueError(f"drive must be a RigidDrive or a TwoMassRig, got {type(drive).__name__}")


def _rig_static_slope(rig: TwoMassRig, side: str, speed: float, direction: float) -> float:
    """d/dω of the friction on ``side`` of the rig at ``speed`` [N m s/rad], its viscous terms
    (in the linear part) excluded."""
    return sum(f.slope(speed, direction) for f in rig.friction if side in f.sides())


def nonlinear_system(
    drive: RigidDrive | TwoMassRig,
    name: str | None = None,
    units: tuple[str, str] | None = None,
    *,
    card: ModelCard | None = None,
    supply_voltage: float | None = None,
) -> control.NonlinearIOSystem:
    """The whole drive as a discrete-time ``control.NonlinearIOSystem`` at its sample time.

    Its state update is one sample of motorid's own simulation (the same compiled
    functions, :meth:`RigidDrive.simulation` and :meth:`TwoMassRig.simulation`), so
    ``control.input_output_response`` of it equals motorid's record bit for bit, one step
    later (see the module notes): friction with stick/slip, the input path (dead zone,
    saturation, delay, lag, backlash) and, on the rig, the shaft.

    State: the rigid drive's ``[ω, (θ), the input path's memory...]`` (θ the position [v s] of a
    drive whose torque depends on it, cogging or position friction; its delay ring, lag and
    dwell clock, :class:`~motorid.drive.input_path.InputPathState`), or the rig's 7 states
    ``[i_a, ω_m, ω_L, δ, θ_L, z_m, z_L]``. Input ``u`` [V]; output ``y``: the speed [rad/s]
    (the rig's true load speed, without the tachogenerator's noise and quantisation). Start
    from :func:`rest_state` (``initial_state=`` of ``input_output_response``), the drive at
    rest before its first input.

    Parameters
    ----------
    drive : RigidDrive or TwoMassRig
        The drive model (its sample time is the system's).
    name : str, optional
        The system's name in an ``interconnect`` (python-control names it otherwise).
    units : (str, str), optional
        The input's and the output's units, in the signals' names (:func:`signal_names`);
        converted from the card's (:func:`unit_factors`). None and no card: ``u`` and ``y``.
    card : ModelCard, optional
        What the model is (``read_model_file(path).card``): its units.
    supply_voltage : float, optional
        The supply voltage [V] for % duty and volts (the card's where not given).

    Returns
    -------
    control.NonlinearIOSystem
        Discrete, ``dt = drive.dt``; input ``u``, output ``y``, named with their units where
        ``units`` or ``card`` give them.
    """
    import control

    k_u, k_y, named = unit_factors(units, card, supply_voltage)
    u_label, y_label = signal_names(named)

    if isinstance(drive, RigidDrive):
        fresh = drive.input_state()
        sizes = (fresh.ring.size, fresh.lag.size, fresh.clock.size)
        setup = drive._free_run_setup(None)
        moved = bool(drive.position_effects)  # the position is a state where the speed depends on it
        head = 2 if moved else 1

        def update(t: float, x: np.ndarray, u: np.ndarray, params: dict) -> np.ndarray:
            n1, n2 = head + sizes[0], head + sizes[0] + sizes[1]
            state = InputPathState(ring=x[head:n1].copy(), lag=x[n1:n2].copy(), clock=x[n2:].copy())
            force = drive.input_force(np.array([k_u * float(u[0])]), state)
            if moved:
                w, q = drive._motion_force(setup, force, float(x[0]), float(x[1]))
                return np.concatenate([w, q, state.ring, state.lag, state.clock])
            w = drive._free_run_force(setup, force, float(x[0]))[0]
            return np.concatenate([[w], state.ring, state.lag, state.clock])

        n_states = head + sum(sizes)
        names = ["omega", *(["position"] if moved else []), *(f"ring{i}" for i in range(sizes[0])), "lag",
                 "lag_samples", "clock_sign", "clock_samples", "clock_reversed"]  # fmt: skip
    elif isinstance(drive, TwoMassRig):
        from motorid.drive import kernels

        phi, gam, p, fric, lug = drive._compiled

        def update(t: float, x: np.ndarray, u: np.ndarray, params: dict) -> np.ndarray:
            xn = np.array(x, dtype=float)
            kernels.advance_sample(
                xn, k_u * float(u[0]), drive.T_d, 0.0, phi, gam, p, fric, lug, np.zeros(kernels.N_OUT)
            )
            return xn

        n_states = kernels.N_STATE
        names = ["i_a", "omega_m", "omega_l", "twist", "theta_l", "z_m", "z_l"]
    else:
        raise ValueError(f"drive must be a RigidDrive or a TwoMassRig, got {type(drive).__name__}")
    speed_index = 0 if isinstance(drive, RigidDrive) else 2

    def output(t: float, x: np.ndarray, u: np.ndarray, params: dict) -> np.ndarray:
        return np.array([k_y * x[speed_index]])

    return control.nlsys(update, output, inputs=[u_label], outputs=[y_label], states=names[:n_states],
                         dt=drive.dt, name=name)  # fmt: skip


def rest_state(drive: RigidDrive | TwoMassRig) -> np.ndarray:
    """The state of :func:`nonlinear_system` for the drive at rest before its first input.

    Parameters
    ----------
    drive : RigidDrive or TwoMassRig
        The drive model.
    """
    if isinstance(drive, RigidDrive):
        fresh = drive.input_state()
        start = [0.0, 0.0] if drive.position_effects else [0.0]  # speed (and position) 0
        return np.concatenate([start, fresh.ring, fresh.lag, fresh.clock])
    if isinstance(drive, TwoMassRig):
        from motorid.drive import kernels

        return np.zeros(kernels.N_STATE)
    raise ValueError(f"drive must be a RigidDrive or a TwoMassRig, got {type(drive).__name__}")
