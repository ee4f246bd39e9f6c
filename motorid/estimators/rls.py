"""Recursive least squares with a forgetting factor, for models linear in their parameters.

The model is a lagged regression on past outputs and on basis functions of present
and past inputs (paper eqs. 14 and 20-22):

    y(t) = phi(t)^T theta + e(t),
    phi(t) = (-y(t-1), ..., -y(t-na), g_1(u(t-k0)), ..., g_1(u(t-nb)), ...,
              g_n(u(t-k0)), ..., g_n(u(t-nb)))^T,

with k0 = 0 when the model has a direct term and k0 = 1 otherwise. ARX is the
case of one basis function g_1(u) = u; the paper's Hammerstein regression is the
polynomial basis.

RLS with forgetting factor lambda is the Kalman filter with F = I, Q = 0,
H = phi(t)^T and measurement variance R (R = 1 in the paper):

    predict:  P_prior = P / lambda,                         y_hat = phi^T theta
    update:   S = phi^T P_prior phi + R,   K = P_prior phi / S,
              theta = theta + K (z - y_hat),
              P = P_prior - K S K^T.

Covariance windup. With lambda < 1 and no excitation P grows as lambda^-t. The
safeguard bounds the trace of P: the forgetting actually applied is

    lambda_eff = min(1, max(lambda, tr(P) / max_trace)),

so tr(P_prior) never exceeds ``max_trace`` (and P is never inflated when it already
does). P is only ever scaled by a positive number or reduced by the rank-1 update,
which is computed on one triangle and mirrored, so it stays exactly symmetric.

The kernels below are compiled with numba; the per-sample methods and the
batch path call the same kernels, so there is one implementation of the algorithm.
Both take the basis values g_j(u(t)) from the one evaluation of the basis,
:meth:`~motorid.estimators.basis.Basis.evaluate` (one sample in :meth:`predict`,
the record in :meth:`batch_filter`, the same bits either way), and the batch loop
performs the floating-point operations of :func:`rls_predict` and
:func:`rls_update` in their order. So ``batch_filter`` gives the sample loop's
numbers bit for bit, on every CPU and compiled target: nothing in either path is
vectorised differently or calls a library function whose rounding depends on the
CPU, and numba contracts no multiply-add into a fused one without ``fastmath``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from motorid.estimators.base import BatchResult, Estimator, as_float_vector, first_bad_index
from motorid.estimators.basis import Basis


# --------------------------------------------------------------------------- kernels
@njit(cache=True)
def _push(history: np.ndarray, value: np.ndarray | float) -> None:
    """Shift ``history`` one lag back along axis 0 and put ``value`` in front."""
    for k in range(history.shape[0] - 1, 0, -1):
        history[k] = history[k - 1]
    if history.shape[0] > 0:
        history[0] = value


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
def _prior_gain(P: np.ndarray, scale: float, phi: np.ndarray, r: float, Pphi: np.ndarray) -> float:
    """With P_prior = scale * P: leaves P_prior phi in ``Pphi`` and returns
    S = phi^T P_prior phi + R."""
    n = phi.shape[0]
    s = r
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += (P[i, j] * scale) * phi[j]
        Pphi[i] = acc
        s += phi[i] * acc
    return s


@njit(cache=True)
def _posterior(
    x: np.ndarray, P: np.ndarray, scale: float, Pphi: np.ndarray, s: float, e: float, K: np.ndarray
) -> None:
    """In place: K = P_prior phi / S, theta += K e, P = scale * P - (P_prior phi) K^T,
    on one triangle mirrored to the other."""
    n = x.shape[0]
    for i in range(n):
        K[i] = Pphi[i] / s
        x[i] += K[i] * e
    for i in range(n):
        for j in range(i, n):
            v = P[i, j] * scale - Pphi[i] * K[j]
            P[i, j] = v
            P[j, i] = v


@njit(cache=True)
def rls_predict(
    g: np.ndarray,
    y_hist: np.ndarray,
    g_hist: np.ndarray,
    x: np.ndarray,
    P: np.ndarray,
    lam: float,
    max_trace: float,
    r: float,
    k0: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """Time update: push ``g`` into ``g_hist`` (in place), form phi, forget.

    Returns ``(phi, P_prior, P_prior phi, y_hat, S)``.
    """
    n = x.shape[0]
    _push(g_hist, g)
    phi = np.empty(n)
    _fill_regressor(y_hist, g_hist, k0, phi)
    scale = _forgetting_scale(P, lam, max_trace)
    Pphi = np.empty(n)
    s = _prior_gain(P, scale, phi, r, Pphi)
    P_prior = P * scale
    y_hat = 0.0
    for i in range(n):
        y_hat += phi[i] * x[i]
    return phi, P_prior, Pphi, y_hat, s


@njit(cache=True)
def rls_update(
    x: np.ndarray, P_prior: np.ndarray, Pphi: np.ndarray, s: float, e: float, y_hist: np.ndarray, y_t: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Measurement update on copies, returning ``(x_post, P_post, K)``; pushes the
    output ``y_t`` into ``y_hist`` (in place)."""
    x_post = x.copy()
    P_post = P_prior.copy()
    K = np.empty(x.shape[0])
    _posterior(x_post, P_post, 1.0, Pphi, s, e, K)
    _push(y_hist, y_t)
    return x_post, P_post, K


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
):
    """The sample loop of :func:`rls_predict` and :func:`rls_update` over a record,
    with the forgetting folded into the covariance update (the same floating-point
    operations, so the same numbers, without forming P_prior each sample).

    ``y_hist``, ``g_hist``, ``x`` and ``P`` are advanced in place. Returns the
    per-sample arrays and the last sample's prior, gain, innovation and S.
    """
    N = G.shape[0]
    n = x.shape[0]
    X = np.empty((N, n))
    P_diag = np.empty((N, n))
    y_hat = np.empty(N)
    innovation = np.full(N, np.nan)
    S = np.empty(N)
    phi = np.empty(n)
    Pphi = np.empty(n)
    K = np.zeros(n)
    x_prior = x.copy()
    P_prior = P.copy()
    e = 0.0
    for t in range(N):
        _push(g_hist, G[t])
        _fill_regressor(y_hist, g_hist, k0, phi)
        scale = _forgetting_scale(P, lam, max_trace)
        s = _prior_gain(P, scale, phi, r, Pphi)
        yh = 0.0
        for i in range(n):
            yh += phi[i] * x[i]
        y_hat[t] = yh
        S[t] = s
        if t == N - 1:
            x_prior[:] = x
            P_prior[:, :] = P * scale
        if present[t]:
            e = z[t] - yh
            innovation[t] = e
            _posterior(x, P, scale, Pphi, s, e, K)
            _push(y_hist, z[t])
        else:
            e = 0.0
            K[:] = 0.0
            for i in range(n):
                for j in range(n):
                    P[i, j] *= scale
            _push(y_hist, yh)
        for i in range(n):
            X[t, i] = x[i]
            P_diag[t, i] = P[i, i]
    return X, P_diag, y_hat, innovation, S, x_prior, P_prior, K, e


@njit(cache=True)
def free_run(G: np.ndarray, theta: np.ndarray, na: int, n_lags: int, k0: int) -> np.ndarray:
    """Free-run output of the lagged regression from rest: y(t) = phi(t)^T theta with
    phi built from the model's own past outputs."""
    N = G.shape[0]
    y = np.empty(N)
    y_hist = np.zeros(na)
    g_hist = np.zeros((n_lags, G.shape[1]))
    phi = np.empty(theta.shape[0])
    for t in range(N):
        _push(g_hist, G[t])
        _fill_regressor(y_hist, g_hist, k0, phi)
        yt = 0.0
        for i in range(theta.shape[0]):
            yt += phi[i] * theta[i]
        y[t] = yt
        _push(y_hist, yt)
    return y


# --------------------------------------------------------------------------- checks
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

    Parameters
    ----------
    na : int
        Order of A(q^-1): number of past outputs, >= 0.
    nb : int
        Order of B(q^-1): the oldest input lag, >= 0 (>= 1 without direct term).
    basis : Basis
        Functions of the input forming the static block.
    lam : float
        Forgetting factor, 0 < lam <= 1 (1: ordinary least squares).
    delta : float
        Initial covariance P0 = delta * I (large: little trust in ``x0``).
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
        self.na = check_order("na", na, 0)
        self.direct_term = bool(direct_term)
        self.nb = check_order("nb", nb, 0 if self.direct_term else 1)
        if not isinstance(basis, Basis):
            raise ValueError(f"basis must be a motorid Basis, got {type(basis).__name__}")
        self.basis = basis
        self.lam = check_positive("lam", lam)
        if self.lam > 1.0:
            raise ValueError(f"lam must satisfy 0 < lam <= 1, got {lam!r}")
        self.delta = check_positive("delta", delta)
        self.R = check_positive("R", R)
        n = self.na + len(basis) * self.n_lags_used
        self.max_trace = (
            self.delta * n if max_trace is None else check_positive("max_trace", max_trace, allow_inf=True)
        )
        if x0 is None:
            self.x0 = np.zeros(n)
        else:
            self.x0 = as_float_vector(x0, "x0")
            if self.x0.shape != (n,):
                raise ValueError(
                    f"x0 must have shape ({n},) for na={self.na}, nb={self.nb}, got {self.x0.shape}"
                )
            bad = first_bad_index(self.x0)
            if bad is not None:
                raise ValueError(f"x0[{bad}] is not finite")
        self.reset()

    # ------------------------------------------------------------------ structure
    @property
    def k0(self) -> int:
        """First input lag in the regressor: 0 with the direct term, else 1."""
        return 0 if self.direct_term else 1

    @property
    def n_lags_used(self) -> int:
        """Input lags per basis function in the regressor, nb + 1 - k0."""
        return self.nb + 1 - self.k0

    def reset(self) -> None:
        n = len(self.x0)
        self.x = self.x0.copy()
        self.P = self.delta * np.eye(n)
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()
        self.x_post, self.P_post = self.x.copy(), self.P.copy()
        self.K = np.zeros(n)
        self.y = 0.0
        self.S = 0.0
        self.z = None
        self.sample_index = 0
        self.y_history = np.zeros(self.na)
        self.g_history = np.zeros((self.nb + 1, len(self.basis)))
        self._pending: tuple[np.ndarray, float] | None = None

    # ------------------------------------------------------------------ filter
    def predict(self, u: float) -> float:
        """Time update: form phi(t) with this sample's input ``u`` [V], apply the
        forgetting ``P_prior = P / lambda_eff`` and return ``y_hat = phi^T x``.

        A previous sample still waiting for its :meth:`update` is closed as skipped.
        """
        u = self.check_input(u)
        g = self.basis.evaluate(np.array([u]), start=self.sample_index)[0]
        if self._pending is not None:
            self.update(None)
        phi, P_prior, Pphi, y_hat, s = rls_predict(
            g, self.y_history, self.g_history, self.x, self.P, self.lam, self.max_trace, self.R, self.k0
        )
        self.phi = phi
        self.P = self.P_prior = P_prior
        self.x_prior = self.x
        self.S = s
        self.sample_index += 1
        self._pending = (Pphi, y_hat)
        return y_hat

    def update(self, z: float | None) -> None:
        """Measurement update with the measured output ``z``.

        ``theta += K (z - y_hat)``, ``P = P_prior - K S K^T``. ``None`` skips the
        update: ``x`` and ``P`` stay at the prior, and the prediction stands in for
        the missing output in later regressors.
        """
        if self._pending is None:
            raise RuntimeError("update() needs a predict(u) for this sample first")
        Pphi, y_hat = self._pending
        value = None if z is None else self.check_measurement(z)
        if value is None:
            self.z = None
            self.y = 0.0
            self.K = np.zeros(self.dim_x)
            self.x_post, self.P_post = self.x, self.P
            _push(self.y_history, y_hat)
        else:
            self.z = value
            self.y = value - y_hat
            self.x, self.P, self.K = rls_update(self.x, self.P, Pphi, self.S, self.y, self.y_history, value)
            self.x_post, self.P_post = self.x, self.P
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
        G = self.basis.evaluate(u_arr, start=self.sample_index)
        if self._pending is not None:
            self.update(None)
        x, P = self.x.copy(), self.P.copy()
        X, P_diag, y_hat, innovation, S, x_prior, P_prior, K, e = rls_batch(
            G, z_arr, present, self.y_history, self.g_history, x, P,
            self.lam, self.max_trace, self.R, self.k0,
        )  # fmt: skip
        if len(u_arr):
            self.x, self.P = x, P
            self.x_prior, self.P_prior = x_prior, P_prior
            self.x_post, self.P_post = x, P
            self.K, self.y, self.S = K, float(e), float(S[-1])
            self.z = float(z_arr[-1]) if present[-1] else None
            self.sample_index += len(u_arr)
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
        u_arr = as_float_vector(u, "u")
        bad = first_bad_index(u_arr)
        if bad is not None:
            raise ValueError(f"u[{bad}] = {u_arr[bad]} is not finite: the input must be finite")
        G = self.basis.evaluate(u_arr)
        return free_run(G, self.simulation_theta(), self.na, self.nb + 1, self.k0)

    @property
    def a(self) -> np.ndarray:
        """Coefficients a_1..a_na of A(q^-1) = 1 + a_1 q^-1 + ... (current estimate)."""
        return self.x[: self.na].copy()

    def lagged_coefficients(self, theta: np.ndarray | None = None) -> np.ndarray:
        """The input coefficients as a matrix, row j = basis function j, column k =
        lag k0..nb: ``[b; s_2; ...; s_n]`` of paper eq. 19. Works on stacks of
        estimates, shape (..., n) -> (..., n_basis, n_lags)."""
        theta = self.x if theta is None else np.asarray(theta)
        return theta[..., self.na :].reshape(*theta.shape[:-1], len(self.basis), self.n_lags_used)

    def __repr__(self) -> str:
        head = (
            f"{type(self).__name__}(na={self.na}, nb={self.nb}, basis={self.basis!r}, lam={self.lam}, "
            f"delta={self.delta}, direct_term={self.direct_term}, max_trace={self.max_trace}, R={self.R})"
        )
        return head + "\n" + super().__repr__()
