"""Recursive least squares with a forgetting factor, for models linear in their parameters.

The model is a lagged regression on past outputs and on basis functions of present
and past inputs (paper eqs. 14 and 20-22)::

    y(t) = phi(t)^T theta + e(t),
    phi(t) = (-y(t-1), ..., -y(t-na), g_1(u(t-k0)), ..., g_1(u(t-nb)), ...,
              g_n(u(t-k0)), ..., g_n(u(t-nb)))^T,

with k0 = 0 when the model has a direct term and k0 = 1 otherwise. ARX is the
case of one basis function g_1(u) = u; the paper's Hammerstein regression is the
polynomial basis.

RLS with forgetting factor lambda is the Kalman filter with F = I, Q = 0,
H = phi(t)^T and measurement variance R (R = 1 in the paper)::

    predict:  P_prior = P / lambda,                         y_hat = phi^T theta
    update:   S = phi^T P_prior phi + R,   K = P_prior phi / S,
              theta = theta + K (z - y_hat),
              P = P_prior - K S K^T.

Covariance windup. With lambda < 1 and no excitation P grows as lambda^-t. The
safeguard bounds the trace of P: the forgetting actually applied is::

    lambda_eff = min(1, max(lambda, tr(P) / max_trace)),

so tr(P_prior) never exceeds ``max_trace`` (and P is never inflated when it already
does).

Symmetry of P. P is only ever scaled by a positive number or reduced by the rank-1
update, and the update computes entry (i, j) and entry (j, i) by the same
operations on the same numbers, ``P_prior[i, j] - (P_prior phi)[i] K[j]`` with
i <= j, so P stays exactly symmetric. The kernels rely on it: they read column j
of P_prior as its row j, which keeps every loop over contiguous memory.

The kernels below are compiled with numba; the per-sample methods (one compiled
call each) and the batch path call the same kernels, so there is one
implementation of the algorithm. Both take the basis values g_j(u(t)) from one
function, :func:`~motorid.estimators.basis.builtin_row` (module docstring of
:mod:`motorid.estimators.basis`), and the batch loop performs the floating-point
operations of :func:`rls_predict` and :func:`rls_update` in their order. So
``batch_filter`` gives the sample loop's numbers bit for bit, on every CPU and
compiled target: every sum runs in one fixed order, and a vectorised loop only
does in each lane what a scalar loop does (no reduction is reordered, and numba
contracts no multiply-add into a fused one without ``fastmath``).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from motorid.errors import ModelFileError
from motorid.estimators.base import (
    LARGEST_VALUE,
    LARGEST_VARIANCE,
    BatchResult,
    Estimator,
    as_float_vector,
    check_covariance,
    first_bad_index,
)
from motorid.estimators.basis import Basis, builtin_row
from motorid.json_input import boolean, float_array, integer, key_path, number, object_keys, shown, text
from motorid.outputs import jsonable


# --------------------------------------------------------------------------- kernels
@njit(cache=True)
def _copy(src: np.ndarray, dst: np.ndarray) -> None:
    """``dst[...] = src`` for arrays of one size, ``dst`` C-contiguous, as one flat loop."""
    flat_src = src.ravel()
    flat_dst = dst.reshape(-1)
    for k in range(flat_dst.shape[0]):
        flat_dst[k] = flat_src[k]


@njit(cache=True)
def _push(history: np.ndarray, value: float) -> None:
    """Shift the 1-D ``history`` one lag back and put ``value`` in front."""
    for k in range(history.shape[0] - 1, 0, -1):
        history[k] = history[k - 1]
    if history.shape[0] > 0:
        history[0] = value


@njit(cache=True)
def _push_row(history: np.ndarray, row: np.ndarray) -> None:
    """Shift the rows of ``history`` one lag back and put ``row`` in front."""
    for k in range(history.shape[0] - 1, 0, -1):
        for j in range(history.shape[1]):
            history[k, j] = history[k - 1, j]
    if history.shape[0] > 0:
        for j in range(history.shape[1]):
            history[0, j] = row[j]


@njit(cache=True)
def _fill_regressor(y_hist: np.ndarray, g_hist: np.ndarray, k0: int, phi: np.ndarray) -> None:
    """phi = (-y(t-1..t-na), g_1(u(t-k0..t-nb)), ..., g_n(u(t-k0..t-nb)))."""
    na = y_hist.shape[0]
    for i in range(na):
        phi[i] = -y_hist[i]
    m = na
    for j in range(g_hist.shape[1]):
        for k in range(k0, g_hist.shape[0]):
            phi[m] = g_hist[k, j]
            m += 1


@njit(cache=True)
def _forgetting_scale(P: np.ndarray, lam: float, max_trace: float) -> float:
    """1 / lambda_eff for the trace bound of the module docstring."""
    trace = 0.0
    for i in range(P.shape[0]):
        trace += P[i, i]
    lam_eff = lam
    if trace > lam * max_trace:
        lam_eff = min(1.0, trace / max_trace)
    return 1.0 / lam_eff


@njit(cache=True)
def _forget_and_gain(P: np.ndarray, scale: float, phi: np.ndarray, r: float, Pphi: np.ndarray) -> float:
    """In place ``P <- scale P`` (P_prior); leaves P_prior phi in ``Pphi`` and
    returns S = phi^T P_prior phi + R.

    ``(P_prior phi)_i = sum_j P_prior[i, j] phi_j`` is summed over j in order; with
    P symmetric, row j of P_prior holds column j, so the loop over i runs along
    contiguous memory.
    """
    n = phi.shape[0]
    for i in range(n):
        Pphi[i] = 0.0
    for j in range(n):
        phi_j = phi[j]
        for i in range(n):
            p = P[j, i] * scale
            P[j, i] = p
            Pphi[i] += p * phi_j
    s = r
    for i in range(n):
        s += phi[i] * Pphi[i]
    return s


@njit(cache=True)
def _correct(P: np.ndarray, Pphi: np.ndarray, s: float, e: float, x: np.ndarray, K: np.ndarray) -> None:
    """In place, from P = P_prior and the innovation ``e``: K = P_prior phi / S,
    theta += K e, P = P_prior - (P_prior phi) K^T.

    Entry (i, j) and entry (j, i) are both ``P_prior[i, j] - (P_prior phi)[i] K[j]``
    with i <= j (the same two factors, picked without a branch), so P stays exactly
    symmetric and each row is one loop over contiguous memory.
    """
    n = x.shape[0]
    for i in range(n):
        K[i] = Pphi[i] / s
    for i in range(n):
        x[i] += K[i] * e
    for i in range(n):
        Pphi_i = Pphi[i]
        K_i = K[i]
        for j in range(n):
            below = j < i
            a = Pphi[j] if below else Pphi_i
            b = K_i if below else K[j]
            P[i, j] = P[i, j] - a * b


@njit(cache=True)
def _predicted_output(phi: np.ndarray, x: np.ndarray) -> float:
    """y_hat = phi^T x, summed in order."""
    y_hat = 0.0
    for i in range(x.shape[0]):
        y_hat += phi[i] * x[i]
    return y_hat


@njit(cache=True)
def rls_predict(
    u: float,
    g: np.ndarray,
    kinds: np.ndarray,
    parameters: np.ndarray,
    y_hist: np.ndarray,
    g_hist: np.ndarray,
    x: np.ndarray,
    P: np.ndarray,
    lam: float,
    max_trace: float,
    r: float,
    k0: int,
    phi: np.ndarray,
    P_prior: np.ndarray,
    Pphi: np.ndarray,
    out: np.ndarray,
) -> float:
    """Time update of one sample with input ``u``, in one compiled call.

    Evaluates the basis into ``g`` (:func:`~motorid.estimators.basis.builtin_row`;
    custom columns as the caller filled them), pushes it into ``g_hist``, forms
    ``phi``, writes P_prior into ``P_prior`` and P_prior phi into ``Pphi``, and
    returns ``y_hat = phi^T x`` with ``out[0] = S``. ``x`` and ``P`` are not
    changed. Where a basis value is not finite nothing is changed: ``out[1]`` is
    its column and NaN is returned (``out[1] = -1`` otherwise).
    """
    bad = builtin_row(kinds, parameters, u, g)
    out[1] = bad
    if bad >= 0:
        return np.nan
    _push_row(g_hist, g)
    _fill_regressor(y_hist, g_hist, k0, phi)
    scale = _forgetting_scale(P, lam, max_trace)
    _copy(P, P_prior)
    out[0] = _forget_and_gain(P_prior, scale, phi, r, Pphi)
    return _predicted_output(phi, x)


@njit(cache=True)
def rls_update(
    z: float,
    y_hat: float,
    x: np.ndarray,
    P_prior: np.ndarray,
    Pphi: np.ndarray,
    s: float,
    y_hist: np.ndarray,
    x_post: np.ndarray,
    P_post: np.ndarray,
    K: np.ndarray,
) -> float:
    """Measurement update with ``z`` into the new arrays ``x_post`` and ``P_post``
    and the gain into ``K``, in one compiled call; pushes ``z`` into ``y_hist`` and
    returns the innovation ``z - y_hat``. ``x`` and ``P_prior`` are not changed."""
    e = z - y_hat
    _copy(x, x_post)
    _copy(P_prior, P_post)
    _correct(P_post, Pphi, s, e, x_post, K)
    _push(y_hist, z)
    return e


@njit(cache=True)
def rls_batch(
    G: np.ndarray,
    z: np.ndarray,
    present: np.ndarray,
    y_hist: np.ndarray,
    g_hist: np.ndarray,
    x: np.ndarray,
    P: np.ndarray,
    lam: float,
    max_trace: float,
    r: float,
    k0: int,
    X: np.ndarray,
    P_diag: np.ndarray,
    y_hat: np.ndarray,
    innovation: np.ndarray,
    S: np.ndarray,
    x_prior: np.ndarray,
    P_prior: np.ndarray,
    K: np.ndarray,
) -> float:
    """The sample loop of :func:`rls_predict` and :func:`rls_update` over a record:
    the same kernels in the same order, on ``x`` and ``P`` in place.

    ``y_hist``, ``g_hist``, ``x`` and ``P`` are advanced in place. Fills the
    per-sample arrays ``X``, ``P_diag``, ``y_hat``, ``innovation`` (NaN where
    skipped) and ``S`` (allocated by the caller, so NumPy's allocator serves the
    large ones), the last sample's prior ``x_prior``, ``P_prior`` and gain ``K``;
    returns the last innovation (0.0 when skipped).
    """
    n = x.shape[0]
    phi = np.empty(n)
    Pphi = np.empty(n)
    e = 0.0
    for t in range(G.shape[0]):
        _push_row(g_hist, G[t])
        _fill_regressor(y_hist, g_hist, k0, phi)
        scale = _forgetting_scale(P, lam, max_trace)
        s = _forget_and_gain(P, scale, phi, r, Pphi)
        yh = _predicted_output(phi, x)
        y_hat[t] = yh
        S[t] = s
        if t == G.shape[0] - 1:
            _copy(x, x_prior)
            _copy(P, P_prior)
        if present[t]:
            e = z[t] - yh
            innovation[t] = e
            _correct(P, Pphi, s, e, x, K)
            _push(y_hist, z[t])
        else:
            e = 0.0
            innovation[t] = np.nan
            K[:] = 0.0
            _push(y_hist, yh)
        for i in range(n):
            X[t, i] = x[i]
            P_diag[t, i] = P[i, i]
    return e


@njit(cache=True)
def free_run(G: np.ndarray, theta: np.ndarray, y_hist: np.ndarray, g_hist: np.ndarray, k0: int) -> np.ndarray:
    """Free-run output of the lagged regression: y(t) = phi(t)^T theta with phi built
    from the model's own past outputs.

    ``y_hist`` (na) and ``g_hist`` (nb + 1 lags, one column per basis function) hold
    the past outputs and basis values before ``G[0]`` (zeros: from rest) and are
    advanced in place, so consecutive blocks of an input continue one free run.
    """
    N = G.shape[0]
    y = np.empty(N)
    phi = np.empty(theta.shape[0])
    for t in range(N):
        _push_row(g_hist, G[t])
        _fill_regressor(y_hist, g_hist, k0, phi)
        yt = _predicted_output(phi, theta)
        y[t] = yt
        _push(y_hist, yt)
    return y


# --------------------------------------------------------------------------- checks
#: Most parameters of a lagged regression: its covariance takes 8 n² bytes (8 MB at the bound), and
#: a drive's model has tens (the paper's orders go to 6).
MOST_PARAMETERS = 1000


def check_order(name: str, value: Any, minimum: int) -> int:
    """An integer argument >= ``minimum``, or a ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_positive(name: str, value: Any, *, allow_inf: bool = False) -> float:
    """A positive float argument, or a ValueError naming it."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if math.isnan(number) or number <= 0.0 or (math.isinf(number) and not allow_inf):
        raise ValueError(f"{name} must be a positive {'' if allow_inf else 'finite '}number, got {value!r}")
    return number


# --------------------------------------------------------------------------- estimator
class LaggedRegressionRLS(Estimator):
    """RLS on the lagged regression of the module docstring; the common core of
    :class:`~motorid.estimators.arx.ARXRLS` and
    :class:`~motorid.estimators.hammerstein.HammersteinRLS`.

    As in scikit-learn, the constructor stores its arguments unchanged under their own
    names (:meth:`get_params` gives them back) and :meth:`reset` checks and resolves them:
    the basis functions in use are :attr:`basis_functions`, the bound on tr(P) in use
    :attr:`trace_bound`. Change an argument's attribute, then call :meth:`reset`.

    Parameters
    ----------
    na : int
        Order of A(q^-1): number of past outputs, >= 0. The model has at most
        :data:`MOST_PARAMETERS` parameters.
    nb : int
        Order of B(q^-1): the oldest input lag, >= 0 (>= 1 without direct term).
    basis : Basis
        Functions of the input forming the static block.
    lam : float
        Forgetting factor, 0 < lam <= 1 (1: ordinary least squares).
    delta : float
        Initial covariance P0 = delta * I (large: little trust in ``x0``), at most
        :data:`~motorid.estimators.base.LARGEST_VARIANCE` (as ``R``).
    direct_term : bool
        Keep the lag-0 input term b0 (the paper's regressor, eq. 22); False gives a
        strictly causal model.
    max_trace : float, optional
        Upper bound on tr(P) against covariance windup (module docstring). None
        (default) uses the initial trace ``delta * n``, so P never grows past its
        prior; ``np.inf`` turns the bound off.
    R : float
        Variance of the equation error e(t) [output unit^2]. The estimate does not
        depend on it when ``delta`` is scaled alike; it sets the scale of S and of
        the likelihoods.
    x0 : array_like, optional
        Initial estimate (zeros by default).
    """

    #: The settings of a model file read as text beside the common ones (a subclass's arguments).
    text_settings: ClassVar[tuple[str, ...]] = ()

    def __init__(
        self,
        na: int,
        nb: int,
        basis: Basis,
        lam: float = 1.0,
        delta: float = 1e3,
        direct_term: bool = True,
        max_trace: float | None = None,
        R: float = 1.0,
        x0: ArrayLike | None = None,
    ):
        self.na = na
        self.nb = nb
        self.basis = basis
        self.lam = lam
        self.delta = delta
        self.direct_term = direct_term
        self.max_trace = max_trace
        self.R = R
        self.x0 = x0
        self.reset()

    def resolve_basis(self) -> Basis:
        """The basis functions the constructor's arguments describe (here ``basis`` itself).

        Raises
        ------
        ValueError
            For a ``basis`` that is not a :class:`~motorid.estimators.basis.Basis`.
        """
        if not isinstance(self.basis, Basis):
            raise ValueError(f"basis must be a motorid Basis, got {type(self.basis).__name__}")
        return self.basis

    def _configure(self) -> None:
        """Validate the stored arguments (errors name the argument) and resolve them: the basis
        functions in use (:attr:`basis_functions`), the orders, the floats the kernels take,
        the trace bound in use (:attr:`trace_bound`) and the initial estimate."""
        self._direct_term = bool(self.direct_term)
        self._na = check_order("na", self.na, 0)
        self._nb = check_order("nb", self.nb, 0 if self._direct_term else 1)
        basis = self.resolve_basis()
        lam = check_positive("lam", self.lam)
        if lam > 1.0:
            raise ValueError(f"lam must satisfy 0 < lam <= 1, got {self.lam!r}")
        delta = check_positive("delta", self.delta)
        r = check_positive("R", self.R)
        for name, value in (("delta", delta), ("R", r)):
            if value > LARGEST_VARIANCE:
                raise ValueError(f"{name} must be at most {LARGEST_VARIANCE:g} (a variance), got {value!r}")
        n = self._na + len(basis) * (self._nb + 1 - (0 if self._direct_term else 1))
        if n > MOST_PARAMETERS:  # before P (n x n) is allocated
            raise ValueError(
                f"na, nb: the model would have {n} parameters (na + basis functions x input lags), "
                f"more than {MOST_PARAMETERS}"
            )
        max_trace = (
            delta * n
            if self.max_trace is None
            else check_positive("max_trace", self.max_trace, allow_inf=True)
        )
        if self.x0 is None:
            x0 = np.zeros(n)
        else:
            x0 = as_float_vector(self.x0, "x0")
            if x0.shape != (n,):
                raise ValueError(
                    f"x0 must have shape ({n},) for na={self._na}, nb={self._nb}, got {x0.shape}"
                )
            bad = first_bad_index(x0)
            if bad is not None:
                raise ValueError(f"x0[{bad}] is not finite")
        #: The basis functions in use (:class:`~motorid.estimators.basis.Basis`).
        self.basis_functions = basis
        self._lam, self._delta, self._R, self._max_trace, self._x0 = lam, delta, r, max_trace, x0

    @property
    def trace_bound(self) -> float:
        """The bound on tr(P) in use: ``max_trace``, or ``delta * n`` where it is None."""
        return self._max_trace

    # ------------------------------------------------------------------ structure
    @property
    def k0(self) -> int:
        """First input lag in the regressor: 0 with the direct term, else 1."""
        return 0 if self._direct_term else 1

    @property
    def n_lags_used(self) -> int:
        """Input lags per basis function in the regressor, nb + 1 - k0."""
        return self._nb + 1 - self.k0

    def reset(self) -> None:
        """Validate the arguments and return to the prior: ``x0`` with covariance ``delta I`` and
        an empty history. Change an argument's attribute, then call ``reset()`` for it to take
        effect."""
        self._configure()
        n = len(self._x0)
        self.x = self._x0.copy()
        self.P = self._delta * np.eye(n)
        self._own_x, self._own_P = self.x, self.P
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()
        self.x_post, self.P_post = self.x.copy(), self.P.copy()
        self.K = np.zeros(n)
        self.y = 0.0
        self.S = 0.0
        self.z = None
        self.sample_index = 0
        self.y_history = np.zeros(self._na)
        self.g_history = np.zeros((self._nb + 1, len(self.basis_functions)))
        # work arrays of the compiled per-sample kernels: basis values, regressor,
        # P_prior phi, and (S, column of a non-finite basis value)
        self._g = np.zeros(len(self.basis_functions))
        self._phi = np.zeros(n)
        self._Pphi = np.zeros(n)
        self._out = np.zeros(2)
        self._gain = np.zeros(n)
        #: y_hat of the sample whose predict still waits for its update, else None
        self._pending: float | None = None

    def _check_state(self) -> None:
        """Check ``x`` and ``P``, called where they are not the arrays this estimator
        made last (a user assigned them): the kernels need x of shape (n,) and P of
        shape (n, n), exactly symmetric (module docstring)."""
        n = len(self._x0)
        x = np.ascontiguousarray(as_float_vector(self.x, "x"))
        P = np.ascontiguousarray(np.asarray(self.P, dtype=float))
        if x.shape != (n,):
            raise ValueError(f"x must have shape ({n},), got {x.shape}")
        if P.shape != (n, n):
            raise ValueError(f"P must have shape ({n}, {n}), got {P.shape}")
        if not np.array_equal(P, P.T):
            raise ValueError(f"P must be symmetric, got max |P - P^T| = {float(np.max(np.abs(P - P.T))):g}")
        self.x, self.P = x, P
        self._own_x, self._own_P = x, P

    @property
    def phi(self) -> np.ndarray:
        """The regressor phi(t) of the last :meth:`predict` (a copy)."""
        return self._phi.copy()

    @property
    def K(self) -> np.ndarray:
        """Gain of the last update (zeros when it was skipped). The per-sample update
        leaves it in a work array; it is copied from there when first read, since a
        sample loop seldom reads it."""
        if self._K is None:
            self._K = self._gain.copy()
        return self._K

    @K.setter
    def K(self, value: np.ndarray) -> None:
        self._K = value

    # ------------------------------------------------------------------ filter
    def predict(self, u: float) -> float:
        """Time update: form phi(t) with this sample's input ``u`` [V], apply the
        forgetting ``P_prior = P / lambda_eff`` and return ``y_hat = phi^T x``.

        A previous sample still waiting for its :meth:`update` is closed as skipped.
        """
        u = self.check_input(u)
        if self.x is not self._own_x or self.P is not self._own_P:
            self._check_state()
        basis = self.basis_functions
        if self._pending is not None or basis.has_custom:
            # raises on a non-finite basis value before anything is changed
            self._g[:] = basis.evaluate(np.array([u]), start=self.sample_index)[0]
        if self._pending is not None:
            self.update(None)
        P_prior = np.empty(self.P.shape)
        y_hat = rls_predict(
            u, self._g, basis.kinds, basis.parameters, self.y_history, self.g_history,
            self.x, self.P, self._lam, self._max_trace, self._R, self.k0, self._phi, P_prior, self._Pphi, self._out,
        )  # fmt: skip
        if math.isnan(y_hat) and self._out[1] >= 0:
            column = int(self._out[1])
            raise basis.value_error(column, float(self._g[column]), u, self.sample_index)
        self.P = self.P_prior = self._own_P = P_prior
        self.x_prior = self.x
        self.S = float(self._out[0])
        self.sample_index += 1
        self._pending = y_hat
        return y_hat

    def update(self, z: float | None) -> None:
        """Measurement update with the measured output ``z``.

        ``theta += K (z - y_hat)``, ``P = P_prior - K S K^T``. ``None`` skips the
        update: ``x`` and ``P`` stay at the prior, and the prediction stands in for
        the missing output in later regressors.
        """
        y_hat = self._pending
        if y_hat is None:
            raise RuntimeError("update() needs a predict(u) for this sample first")
        value = None if z is None else self.check_measurement(z)
        if value is None:
            self.z = None
            self.y = 0.0
            self.K = np.zeros(len(self.x))
            self.x_post, self.P_post = self.x, self.P
            _push(self.y_history, y_hat)
        else:
            if self.x is not self._own_x or self.P is not self._own_P:
                self._check_state()
            x_post, P_post = np.empty(self.x.shape), np.empty(self.P.shape)
            self.y = rls_update(
                value, y_hat, self.x, self.P, self._Pphi, self.S, self.y_history, x_post, P_post, self._gain
            )
            self.z = value
            self.x = self.x_post = self._own_x = x_post
            self.P = self.P_post = self._own_P = P_post
            self._K = None
        self._pending = None

    def batch_filter(self, u: ArrayLike, z: ArrayLike, saver: Any = None) -> BatchResult:
        """Run over a whole record (see :meth:`Estimator.batch_filter`).

        Without a ``saver`` this is one compiled loop over the same kernels as
        :meth:`predict` and :meth:`update`, on the same basis values, and gives the
        same numbers bit for bit (module docstring).
        """
        if saver is not None:
            return super().batch_filter(u, z, saver)
        u_arr, z_arr, present = self.check_record(u, z)
        if self.x is not self._own_x or self.P is not self._own_P:
            self._check_state()
        G = self.basis_functions.evaluate(u_arr, start=self.sample_index)
        if self._pending is not None:
            self.update(None)
        N, n = len(u_arr), len(self.x)
        x, P = self.x.copy(), self.P.copy()
        x_prior, P_prior, K = x.copy(), P.copy(), np.zeros(n)
        X, P_diag = np.empty((N, n)), np.empty((N, n))
        y_hat, innovation, S = np.empty(N), np.empty(N), np.empty(N)
        e = rls_batch(
            G, z_arr, present, self.y_history, self.g_history, x, P,
            self._lam, self._max_trace, self._R, self.k0,
            X, P_diag, y_hat, innovation, S, x_prior, P_prior, K,
        )  # fmt: skip
        if N:
            self.x, self.P = self._own_x, self._own_P = x, P
            self.x_prior, self.P_prior = x_prior, P_prior
            self.x_post, self.P_post = x, P
            self.K, self.y, self.S = K, float(e), float(S[-1])
            self.z = float(z_arr[-1]) if present[-1] else None
            self.sample_index += N
        return BatchResult(X, P_diag, y_hat, innovation, S, self.state_names)

    # ------------------------------------------------------------------ model
    def simulation_theta(self) -> np.ndarray:
        """The parameter vector the free-run model uses (the estimate itself here)."""
        return self.x

    def simulate(self, u: ArrayLike) -> np.ndarray:
        """Free-run output [output unit] of the identified model from rest:

        ``y(t) = -sum_i a_i y(t-i) + sum_j sum_k s_jk g_j(u(t-k))`` with the model's
        own past outputs (never the measured ones).
        """
        return FreeRun(self)(u)

    @property
    def a(self) -> np.ndarray:
        """Coefficients a_1..a_na of A(q^-1) = 1 + a_1 q^-1 + ... (current estimate)."""
        return self.x[: self._na].copy()

    def lagged_coefficients(self, theta: np.ndarray | None = None) -> np.ndarray:
        """The input coefficients as a matrix, row j = basis function j, column k =
        lag k0..nb: ``[b; s_2; ...; s_n]`` of paper eq. 19. Works on stacks of
        estimates, shape (..., n) -> (..., n_basis, n_lags)."""
        theta = self.x if theta is None else np.asarray(theta)
        return theta[..., self._na :].reshape(*theta.shape[:-1], len(self.basis_functions), self.n_lags_used)

    # ------------------------------------------------------------------ saving
    def params_to_json(self) -> dict[str, Any]:
        """The ``settings`` of a model file: the arguments as resolved, which build the same
        estimator (``na``, ``nb``, ``lam``, ``delta``, ``direct_term``, ``max_trace`` the
        bound in use, null for none, ``R`` and ``x0`` the initial estimate)."""
        return jsonable(
            {
                "na": self._na,
                "nb": self._nb,
                "lam": self._lam,
                "delta": self._delta,
                "direct_term": self._direct_term,
                "max_trace": self._max_trace,
                "R": self._R,
                "x0": self._x0,
            }
        )

    @classmethod
    def params_from_json(cls, settings: Any, where: str) -> dict[str, Any]:
        """The constructor arguments from a model file's ``settings`` (:meth:`params_to_json`,
        ``max_trace`` null for no bound, and a subclass's :attr:`text_settings`), each checked
        for its type.

        Parameters
        ----------
        settings : Any
            The JSON value of ``settings``.
        where : str
            Its path in the file, named in a :class:`~motorid.errors.ModelFileError`.
        """
        names = ["na", "nb", "lam", "delta", "direct_term", "max_trace", "R", "x0", *cls.text_settings]
        object_keys(settings, names, where)
        x0 = settings["x0"]
        if not isinstance(x0, list):
            raise ModelFileError(key_path(where, "x0"), f"must be a list of numbers, got {shown(x0)}")
        return {
            "na": integer(settings["na"], key_path(where, "na")),
            "nb": integer(settings["nb"], key_path(where, "nb")),
            "lam": number(settings["lam"], key_path(where, "lam")),
            "delta": number(settings["delta"], key_path(where, "delta")),
            "direct_term": boolean(settings["direct_term"], key_path(where, "direct_term")),
            "max_trace": number(settings["max_trace"], key_path(where, "max_trace"), none_is=math.inf),
            "R": number(settings["R"], key_path(where, "R")),
            "x0": float_array(x0, key_path(where, "x0"), (len(x0),), LARGEST_VALUE),
            **{name: text(settings[name], key_path(where, name)) for name in cls.text_settings},
        }

    def get_state(self) -> dict[str, Any]:
        """What the filter has learnt: ``x``, ``P``, the lagged outputs ``y_history`` (na) and
        basis values ``g_history`` (nb + 1 lags by basis functions), and ``sample_index``.

        Raises
        ------
        ValueError
            Between :meth:`predict` and :meth:`update`.
        """
        if self._pending is not None:
            raise ValueError(f"{self.name} is between predict() and update(): call update() first")
        return {
            "x": self.x.copy(),
            "P": self.P.copy(),
            "y_history": self.y_history.copy(),
            "g_history": self.g_history.copy(),
            "sample_index": self.sample_index,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a :meth:`get_state` of an estimator built with the same parameters.

        Parameters
        ----------
        state : dict
            ``x``, ``P``, ``y_history``, ``g_history`` and ``sample_index``.

        Raises
        ------
        ValueError
            Naming the entry of the wrong shape, a value that is not finite or beyond
            :data:`~motorid.estimators.base.LARGEST_VALUE`, a covariance that is not symmetric
            positive semi-definite (:func:`~motorid.estimators.base.check_covariance`), a
            negative sample index.
        """
        n = len(self._x0)
        shapes = {
            "x": (n,),
            "P": (n, n),
            "y_history": self.y_history.shape,
            "g_history": self.g_history.shape,
        }
        missing = [key for key in (*shapes, "sample_index") if key not in state]
        if missing:
            raise ValueError(f"{missing[0]} is missing from the state")
        arrays = {}
        for key, shape in shapes.items():
            value = np.array(state[key], dtype=float)
            if value.shape != shape:
                raise ValueError(f"{key} must have shape {shape} for this estimator, got {value.shape}")
            bad = first_bad_index(value.reshape(-1))
            if bad is not None:
                raise ValueError(f"{key} must be finite, got {value.reshape(-1)[bad]!r}")
            if key != "P" and value.size and float(np.max(np.abs(value))) > LARGEST_VALUE:
                raise ValueError(f"{key} must be within ±{LARGEST_VALUE:g}")
            arrays[key] = np.ascontiguousarray(value)
        P = check_covariance("P", arrays["P"])
        index = state["sample_index"]
        if isinstance(index, bool) or not isinstance(index, int | np.integer) or index < 0:
            raise ValueError(f"sample_index must be an integer >= 0, got {index!r}")
        self.x = self.x_prior = self.x_post = self._own_x = arrays["x"]
        self.P = self.P_prior = self.P_post = self._own_P = P
        self.y_history, self.g_history = arrays["y_history"], arrays["g_history"]
        self.sample_index = int(index)
        self._pending = None

    def __repr__(self) -> str:
        head = (
            f"{type(self).__name__}(na={self._na}, nb={self._nb}, basis={self.basis_functions!r}, lam={self._lam}, "
            f"delta={self._delta}, direct_term={self._direct_term}, max_trace={self._max_trace}, R={self._R})"
        )
        return head + "\n" + super().__repr__()


class FreeRun:
    """The free run of an identified lagged regression (:meth:`LaggedRegressionRLS.simulate`),
    over an input given in consecutive blocks.

    Calling it on ``u1``, then on ``u2``, gives ``estimator.simulate(concatenate((u1, u2)))``
    bit for bit: the model's past outputs and basis values are carried from one block to the
    next (one kernel, :func:`free_run`). The model is the estimator's when the free run is made
    (:meth:`LaggedRegressionRLS.simulation_theta`), starting from rest.

    Parameters
    ----------
    estimator : LaggedRegressionRLS
        The identified model.
    """

    def __init__(self, estimator: LaggedRegressionRLS):
        self.basis = estimator.basis_functions
        self.theta = np.array(estimator.simulation_theta(), dtype=float)
        self.k0 = estimator.k0
        self.y_history = np.zeros(len(estimator.y_history))
        self.g_history = np.zeros(estimator.g_history.shape)
        #: Samples simulated so far (the index of the next block's first sample).
        self.sample_index = 0

    def __call__(self, u: ArrayLike) -> np.ndarray:
        """The free-run output [output unit] over the next block ``u`` [V] of the input."""
        u_arr = as_float_vector(u, "u")
        bad = first_bad_index(u_arr)
        if bad is not None:
            raise ValueError(
                f"u[{self.sample_index + bad}] = {u_arr[bad]} is not finite: the input must be finite"
            )
        G = self.basis.evaluate(u_arr, start=self.sample_index)
        y = free_run(G, self.theta, self.y_history, self.g_history, self.k0)
        self.sample_index += len(u_arr)
        return y
