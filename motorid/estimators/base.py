"""The one interface every motorid estimator follows.

The conventions are filterpy's: a recursive estimator is a Kalman-type filter with
an estimate ``x`` and its covariance ``P``; :meth:`Estimator.predict` applies the
time update and :meth:`Estimator.update` the measurement update. Unlike filterpy,
``x`` is a 1-D array of shape ``(n,)`` and the output is a scalar, so ``y``
(innovation), ``S`` (innovation variance) and the likelihoods are floats.

Inside a sample loop::

    y_hat = est.predict(u_t)   # time update with this sample's input [V]
    est.update(y_t)            # measurement update with the measured output (None skips)
"""

from __future__ import annotations

import inspect
import json
import logging
import math
import os
import warnings
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from motorid.drive.files import save_model
from motorid.errors import ModelFileError
from motorid.json_input import boolean, build, float_array, integer, key_path, number, object_keys
from motorid.outputs import jsonable

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchResult:
    """Per-sample arrays returned by :meth:`Estimator.batch_filter`.

    Attributes
    ----------
    x : ndarray, shape (N, n)
        Posterior estimate after each sample.
    P_diag : ndarray, shape (N, n)
        Diagonal of the posterior covariance after each sample.
    y_hat : ndarray, shape (N,)
        Prior (one-step-ahead) prediction of the output, in the output's unit.
    innovation : ndarray, shape (N,)
        ``z - y_hat``; NaN where the measurement was skipped.
    S : ndarray, shape (N,)
        Innovation variance, in the output's unit squared.
    names : tuple of str
        Name of each entry of ``x``.
    """

    x: np.ndarray
    P_diag: np.ndarray
    y_hat: np.ndarray
    innovation: np.ndarray
    S: np.ndarray
    names: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.y_hat)

    def to_frame(self) -> pd.DataFrame:
        """The result as a DataFrame: ``y_hat``, ``innovation``, ``S``, one column per
        estimate and ``var_<name>`` per covariance diagonal entry."""
        columns: dict[str, np.ndarray] = {
            "y_hat": self.y_hat,
            "innovation": self.innovation,
            "S": self.S,
        }
        for i, name in enumerate(self.names):
            columns[name] = self.x[:, i]
        for i, name in enumerate(self.names):
            columns[f"var_{name}"] = self.P_diag[:, i]
        return pd.DataFrame(columns)


def as_float_vector(value: ArrayLike, name: str) -> np.ndarray:
    """``value`` as a 1-D float array; a ValueError naming ``name`` otherwise."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a 1-D array of numbers: {exc}") from None
    if array.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {array.shape}")
    return array


#: Largest variance a covariance may hold: an update forms P φ φᵀ P, which stays below 1e300
#: for regressors up to 1e50 only while P's entries stay below 1e100.
LARGEST_VARIANCE = 1e100
#: Largest magnitude of a lagged regression's estimate, past output or basis value read back: a
#: product of two (a term of φᵀx) stays below 1e200, far from overflow.
LARGEST_VALUE = 1e100
#: Relative tolerance of the symmetry and semi-definiteness of a covariance read back: a
#: covariance another program wrote with 10 significant digits is off by 5e-11 relative per
#: entry, and its eigenvalues by n times that; an edit or a wrong matrix is off by order 1.
COVARIANCE_RTOL = 1e-9


def check_covariance(name: str, P: np.ndarray) -> np.ndarray:
    """``P`` (square, finite) as an exactly symmetric covariance, or a ValueError naming ``name``.

    Accepted when ``|P - Pᵀ| <= rtol max|P|`` entry by entry, its smallest eigenvalue
    is ``>= -rtol n max|P|`` (positive semi-definite up to rounding) and its largest
    ``<= LARGEST_VARIANCE``, with ``rtol`` = :data:`COVARIANCE_RTOL`; returned as
    ``(P + Pᵀ)/2``, which is ``P`` bit for bit when ``P`` is exactly symmetric.
    """
    if not P.size:
        return P
    scale = float(np.max(np.abs(P)))
    if scale > LARGEST_VARIANCE:  # |P_ij| <= sqrt(P_ii P_jj) <= the largest eigenvalue of a covariance
        raise ValueError(
            f"{name} must have variances of at most {LARGEST_VARIANCE:g}, got an entry of {scale:.3g}"
        )
    asymmetry = float(np.max(np.abs(P - P.T)))
    if asymmetry > COVARIANCE_RTOL * scale:
        raise ValueError(
            f"{name} must be symmetric (within {COVARIANCE_RTOL:g} of its largest entry), "
            f"got max |P - P^T| = {asymmetry:.3g} beside max |P| = {scale:.3g}"
        )
    P = 0.5 * (P + P.T)
    eigenvalues = np.linalg.eigvalsh(P)
    if eigenvalues[0] < -COVARIANCE_RTOL * len(P) * scale:
        raise ValueError(f"{name} must be positive semi-definite, got an eigenvalue of {eigenvalues[0]:.3g}")
    if eigenvalues[-1] > LARGEST_VARIANCE:
        raise ValueError(
            f"{name} must have variances of at most {LARGEST_VARIANCE:g}, got an eigenvalue of {eigenvalues[-1]:.3g}"
        )
    return P


def constructor_parameters(cls: type) -> list[str]:
    """The names of the keyword arguments ``cls``'s constructor takes (``*args`` and ``**kwargs`` left out).

    Parameters
    ----------
    cls : type
        An estimator class.
    """
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return [
        name
        for name, p in inspect.signature(cls.__init__).parameters.items()  # type: ignore[misc]
        if name != "self" and p.kind in kinds
    ]


def first_bad_index(values: np.ndarray) -> int | None:
    """Index of the first non-finite entry of ``values``, or None."""
    bad = np.flatnonzero(~np.isfinite(values))
    return int(bad[0]) if bad.size else None


def measurement_array(z: ArrayLike | Sequence[float | None], n: int) -> tuple[np.ndarray, np.ndarray]:
    """Split a measurement record into values and a mask of the samples present.

    ``None`` entries (as in filterpy's ``batch_filter``) mark skipped samples; the
    returned value there is NaN and the mask False.
    """
    if isinstance(z, np.ndarray) and z.dtype != object:
        values = as_float_vector(z, "z")
        present = np.ones(values.shape, dtype=bool)
    else:
        items = list(z)  # type: ignore[arg-type]
        present = np.array([item is not None for item in items], dtype=bool)
        try:
            values = np.array([np.nan if item is None else item for item in items], dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"z must hold numbers or None: {exc}") from None
    if values.shape != (n,):
        raise ValueError(f"z must have the length of u ({n}), got shape {values.shape}")
    return values, present


class Estimator(ABC):
    """Base class of every recursive estimator of a single-input single-output drive.

    Subclasses implement :meth:`predict`, :meth:`update`, :attr:`params`,
    :meth:`simulate` and :meth:`reset`, keep the attributes below current, and may
    override :meth:`batch_filter` with a compiled path that gives the same numbers
    as the sample loop. One that implements :meth:`get_state` and :meth:`set_state`
    (and, where its constructor does not store its arguments under their own names,
    :meth:`get_params`) is saved as a model file and loaded back by its registered
    name (:meth:`to_dict`, :meth:`from_dict`).

    Attributes
    ----------
    x : ndarray, shape (n,)
        Current estimate.
    P : ndarray, shape (n, n)
        Covariance of ``x``, kept symmetric positive definite.
    x_prior, P_prior : ndarray
        Estimate and covariance after the last :meth:`predict`.
    x_post, P_post : ndarray
        Estimate and covariance after the last :meth:`update`. Each step makes new
        arrays and never changes these in place, so they may be the same objects
        as ``x`` and ``P``; copy before changing one in place.
    y : float
        Innovation ``z - y_hat`` of the last update (0.0 when it was skipped).
    S : float
        Innovation variance of the last update, in the output's unit squared.
    K : ndarray, shape (n,)
        Gain of the last update.
    z : float or None
        Last measurement given to :meth:`update`.
    sample_index : int
        Number of samples (calls of :meth:`predict`) processed since :meth:`reset`.
    """

    #: name under which the estimator is registered (``motorid.estimators.create``)
    name: ClassVar[str] = ""
    #: True where a NaN measurement is skipped with a warning instead of raising
    skips_nan_measurements: ClassVar[bool] = False

    x: np.ndarray
    P: np.ndarray
    x_prior: np.ndarray
    P_prior: np.ndarray
    x_post: np.ndarray
    P_post: np.ndarray
    y: float
    S: float
    K: np.ndarray
    z: float | None
    sample_index: int

    # ------------------------------------------------------------------ contract
    @abstractmethod
    def predict(self, u: float) -> float:
        """Time update with this sample's input ``u`` [V]; returns the predicted output."""

    @abstractmethod
    def update(self, z: float | None) -> None:
        """Measurement update with the measured output ``z``; ``None`` skips it."""

    @property
    @abstractmethod
    def params(self) -> dict[str, Any]:
        """Named estimates (floats or 1-D arrays), e.g. ``a``, ``b``, ``gamma``."""

    @property
    @abstractmethod
    def state_names(self) -> tuple[str, ...]:
        """Name of each entry of ``x``, e.g. ``("a1", "a2", "b0", ...)``."""

    @abstractmethod
    def simulate(self, u: ArrayLike) -> np.ndarray:
        """Free-run output of the identified model driven by the input record ``u`` [V]."""

    @abstractmethod
    def reset(self) -> None:
        """Return to the initial estimate, covariance and (empty) signal history."""

    # ------------------------------------------------------------------ shared
    @property
    def dim_x(self) -> int:
        """Number of estimated quantities."""
        return len(self.x)

    @property
    def log_likelihood(self) -> float:
        """Log-likelihood of the last innovation, ``-(y^2/S + log(2 pi S)) / 2``."""
        if self.S <= 0.0:
            return math.log(np.finfo(float).tiny)
        return -0.5 * (self.y * self.y / self.S + math.log(2.0 * math.pi * self.S))

    @property
    def likelihood(self) -> float:
        """Likelihood of the last innovation, floored at the smallest positive float."""
        return max(math.exp(self.log_likelihood), np.finfo(float).tiny)

    @property
    def mahalanobis(self) -> float:
        """Mahalanobis distance of the last innovation, ``|y| / sqrt(S)``."""
        if self.S <= 0.0:
            return 0.0
        return abs(self.y) / math.sqrt(self.S)

    def check_input(self, u: float) -> float:
        """``u`` as a float, or a ValueError naming the sample when it is not finite."""
        try:
            value = float(u)
        except (TypeError, ValueError):
            raise ValueError(f"u at sample {self.sample_index} must be a number, got {u!r}") from None
        if not math.isfinite(value):
            raise ValueError(f"u at sample {self.sample_index} is {value}: the input must be finite")
        return value

    def check_measurement(self, z: float) -> float | None:
        """``z`` as a float; a non-finite value raises, or is skipped with a warning
        (returning None) where the estimator :attr:`skips_nan_measurements`."""
        return self.check_measured_value("z", z)

    def check_measured_value(self, name: str, value: Any) -> float | None:
        """A measured signal ``name`` at the current sample as a float.

        NaN is skipped with a RuntimeWarning naming the signal and the sample (None is
        returned) where the estimator :attr:`skips_nan_measurements`; any other
        non-finite or non-numeric value raises ValueError naming them.
        """
        sample = self.sample_index - 1
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{name} at sample {sample} must be a number or None, got {value!r}") from None
        if math.isnan(number) and self.skips_nan_measurements:
            warnings.warn(
                f"{name} at sample {sample} is NaN: {name} update skipped", RuntimeWarning, stacklevel=4
            )
            return None
        if not math.isfinite(number):
            raise ValueError(f"{name} at sample {sample} is {number}: the measurement must be finite")
        return number

    def check_record(
        self, u: ArrayLike, z: ArrayLike | Sequence[float | None]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Validate a whole record before anything is changed.

        Returns ``(u, z, present)`` with ``z`` NaN and ``present`` False where the
        measurement is skipped.
        """
        u_arr = as_float_vector(u, "u")
        bad = first_bad_index(u_arr)
        if bad is not None:
            raise ValueError(f"u[{bad}] = {u_arr[bad]} is not finite: the input must be finite")
        z_arr, present = measurement_array(z, len(u_arr))
        nan_z = present & np.isnan(z_arr)
        if self.skips_nan_measurements:
            if nan_z.any():
                logger.warning("%d NaN measurements skipped", int(nan_z.sum()))
            present = present & ~nan_z
        bad = first_bad_index(np.where(present, z_arr, 0.0))
        if bad is not None:
            raise ValueError(f"z[{bad}] = {z_arr[bad]} is not finite: the measurement must be finite")
        return u_arr, z_arr, present

    def batch_filter(
        self,
        u: ArrayLike,
        z: ArrayLike | Sequence[float | None],
        saver: Any = None,
    ) -> BatchResult:
        """Run the estimator over a whole record, one :meth:`predict` and one
        :meth:`update` per sample, continuing from the current state.

        Parameters
        ----------
        u : array_like, shape (N,)
            Input record [V].
        z : array_like, shape (N,)
            Measured output; ``None`` entries are skipped, as in filterpy.
        saver : filterpy.common.Saver, optional
            Called with ``save()`` after every sample.

        Returns
        -------
        BatchResult
            Per-sample estimates, covariance diagonals, predictions, innovations.

        Raises
        ------
        ValueError
            When ``u`` or ``z`` holds a non-finite value (naming its index) or
            their lengths differ; nothing has been changed then.
        """
        u_arr, z_arr, present = self.check_record(u, z)
        n_samples, n = len(u_arr), self.dim_x
        x_hist = np.empty((n_samples, n))
        p_diag = np.empty((n_samples, n))
        y_hat = np.empty(n_samples)
        innovation = np.full(n_samples, np.nan)
        s_hist = np.empty(n_samples)
        for t in range(n_samples):
            y_hat[t] = self.predict(u_arr[t])
            self.update(z_arr[t] if present[t] else None)
            if present[t]:
                innovation[t] = self.y
            x_hist[t] = self.x
            p_diag[t] = np.diag(self.P)
            s_hist[t] = self.S
            if saver is not None:
                saver.save()
        return BatchResult(x_hist, p_diag, y_hat, innovation, s_hist, self.state_names)

    # ------------------------------------------------------------------ saving
    def get_params(self) -> dict[str, Any]:
        """The constructor arguments by name, as scikit-learn's ``BaseEstimator.get_params``:
        ``type(self)(**est.get_params())`` builds the same estimator at its prior.

        By default the attribute of each name in the constructor's signature (a constructor
        stores its arguments under their own names).
        """
        return {name: getattr(self, name) for name in constructor_parameters(type(self))}

    def get_state(self) -> dict[str, Any]:
        """What the estimator has learnt, by name (arrays, numbers, flags): what :meth:`set_state`
        needs to continue as this one would. A model file holds it (:meth:`to_dict`).

        Raises
        ------
        ValueError
            For an estimator that does not implement it (this base class's answer), or one
            that cannot be saved now (between ``predict`` and ``update``).
        """
        raise ValueError(
            f"cannot save a {type(self).__name__}: it does not implement get_state() and set_state()"
        )

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a :meth:`get_state` of an estimator built with the same parameters,
        every value checked (shape, finite, a covariance symmetric positive semi-definite).

        Parameters
        ----------
        state : dict
            A :meth:`get_state`, e.g. read back from a model file.

        Raises
        ------
        ValueError
            Naming the entry that does not fit (this base class: for any state).
        """
        raise ValueError(
            f"cannot restore a {type(self).__name__}: it does not implement get_state() and set_state()"
        )

    def params_to_json(self) -> dict[str, Any]:
        """:meth:`get_params` as JSON values, the ``settings`` of a model file (arrays as lists,
        NaN and infinities as null: :func:`motorid.outputs.jsonable`).

        Raises
        ------
        ValueError
            For a parameter that has no JSON form.
        """
        settings = jsonable(self.get_params())
        try:
            json.dumps(settings, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"cannot save a {type(self).__name__}: its parameters are not JSON ({exc})"
            ) from None
        return settings

    @classmethod
    def params_from_json(cls, settings: Any, where: str) -> dict[str, Any]:
        """The constructor arguments from a model file's ``settings`` (the inverse of
        :meth:`params_to_json`): by default every argument of the constructor's signature,
        required, as the JSON value (the constructor checks it).

        Parameters
        ----------
        settings : Any
            The JSON value of ``settings``.
        where : str
            Its path in the file, named in a :class:`~motorid.errors.ModelFileError`.
        """
        return dict(object_keys(settings, constructor_parameters(cls), where))

    def state_from_json(self, state: Any, where: str) -> dict[str, Any]:
        """A model file's ``state`` as a :meth:`set_state` argument, read against this estimator's
        own :meth:`get_state` (at its prior): the same keys, each array of the same shape (so no
        size comes from the file), each count an integer, each flag true or false, each number
        finite or null (NaN).

        Parameters
        ----------
        state : Any
            The JSON value of ``state``.
        where : str
            Its path in the file, named in a :class:`~motorid.errors.ModelFileError`.
        """
        template = self.get_state()
        object_keys(state, list(template), where)
        values: dict[str, Any] = {}
        for key, fresh in template.items():
            value, at = state[key], key_path(where, key)
            if isinstance(fresh, np.ndarray):
                values[key] = float_array(value, at, fresh.shape)
            elif isinstance(fresh, bool | np.bool_):
                values[key] = boolean(value, at)
            elif isinstance(fresh, int | np.integer):
                values[key] = integer(value, at)
            elif isinstance(fresh, float | np.floating):
                values[key] = number(value, at, none_is=math.nan)
            else:
                raise ModelFileError(at, f"{type(self).__name__} reads no {type(fresh).__name__} from a file")
        return values

    def to_dict(self) -> dict[str, Any]:
        """The estimator's description in a model file: ``{"estimator": NAME, "settings":
        {...}, "state": {...}}``, its registered name, :meth:`params_to_json` and
        :meth:`get_state` as JSON values (:mod:`motorid.drive.files` describes the format).

        Raises
        ------
        ValueError
            For an estimator that has no model file form (no registered name, no
            :meth:`get_state`, a :meth:`get_params` its constructor does not take, a custom
            basis function) or is between ``predict`` and ``update``.
        """
        cls = type(self)
        if not self.name:
            raise ValueError(
                f"cannot save a {cls.__name__}: it has no registered name (class attribute name)"
            )
        settings = self.params_to_json()
        signature = inspect.signature(cls.__init__).parameters.values()  # type: ignore[misc]
        extra = set(settings) - set(constructor_parameters(cls))
        if extra and not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in signature):
            raise ValueError(
                f"cannot save a {cls.__name__}: get_params() gives {', '.join(sorted(extra))}, which its "
                "constructor does not take; give it a get_params() of its own arguments"
            )
        state = {  # a finite array as its list straight away: a covariance holds up to 10**6 numbers
            key: value.tolist()
            if isinstance(value, np.ndarray) and np.isfinite(value).all()
            else jsonable(value)
            for key, value in self.get_state().items()
        }
        return {"estimator": self.name, "settings": settings, "state": state}

    @classmethod
    def from_dict(cls, data: Any, where: str = "") -> Estimator:
        """The estimator a model file's ``model`` describes (:meth:`to_dict`): built from
        :meth:`params_from_json`, then :meth:`set_state` with :meth:`state_from_json`; an
        error of :meth:`set_state` whose message starts with an entry's name is named at that
        entry (``model.state.P: P must be symmetric ...``).

        Parameters
        ----------
        data : Any
            The JSON value: ``estimator``, ``settings`` and ``state``.
        where : str
            Its path in the file, named in the errors.

        Raises
        ------
        ModelFileError
            Naming the key of a missing, unknown or bad value.
        """
        object_keys(data, ("estimator", "settings", "state"), where)
        s_where, x_where = key_path(where, "settings"), key_path(where, "state")
        try:
            estimator = build(cls, cls.params_from_json(data["settings"], s_where), s_where)
        except TypeError as exc:  # a constructor that does not take a setting's name
            raise ModelFileError(s_where, f"{cls.__name__} does not take these settings: {exc}") from None
        values = estimator.state_from_json(data["state"], x_where)
        try:
            estimator.set_state(values)
        except ValueError as exc:  # named at the entry where the message starts with one
            entry = str(exc).split(" ", 1)[0]
            raise ModelFileError(key_path(x_where, entry) if entry in values else x_where, str(exc)) from None
        return estimator

    def save(self, path: str | os.PathLike[str], *, overwrite: bool = True) -> None:
        """Write the estimator as a model file; ``motorid.load_model`` reads it back
        (the format and what is saved: :mod:`motorid.drive.files`).

        Written whole; ``overwrite=False`` refuses an existing file
        (:func:`motorid.drive.files.write_model_file`).

        Parameters
        ----------
        path : str or os.PathLike
            The file to write.
        overwrite : bool
            False refuses an existing file.
        """
        save_model(self, path, overwrite=overwrite)

    def __repr__(self) -> str:
        lines = [f"{type(self).__name__} object"]
        for attr in ("x", "P", "x_prior", "P_prior", "x_post", "P_post", "K", "y", "S", "z"):
            lines.append(_pretty(attr, getattr(self, attr, None)))
        lines.append(_pretty("sample_index", self.sample_index))
        lines.append(_pretty("log-likelihood", self.log_likelihood))
        lines.append(_pretty("mahalanobis", self.mahalanobis))
        return "\n".join(lines)


def _pretty(label: str, value: Any) -> str:
    """filterpy's ``pretty_str`` layout: ``label = value`` with arrays on new lines."""
    if isinstance(value, np.ndarray):
        text = np.array2string(value, precision=6, suppress_small=True)
        return f"{label} = " + ("\n" + text if "\n" in text else text)
    return f"{label} = {value}"
