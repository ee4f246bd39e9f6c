"""Hammerstein model identified online by two-step RLS (paper eqs. 15-23, steps i-v)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from motorid.estimators.basis import Basis, BasisFunction, basis_from_spec, polynomial
from motorid.estimators.rls import LaggedRegressionRLS, check_order

GammaMethod = Literal["paper", "svd"]


class HammersteinRLS(LaggedRegressionRLS):
    """Static nonlinearity followed by linear dynamics, by two-step RLS.

    The model (paper eqs. 15-17, 20) is

        A(q^-1) y(t) = B(q^-1) x(t) + e(t),   x(t) = sum_j gamma_j g_j(u(t)),

    with gamma_1 = 1 fixing the scale (eq. 18). Step 1 is RLS on the over-
    parameterised regression ``y(t) = phi(t)^T theta`` with
    ``phi = (-y(t-1..t-na), g_1(u(t..t-nb)), ..., g_n(u(t..t-nb)))`` and
    ``theta = (a_1..a_na, b_0..b_nb, s_20..s_2nb, ..., s_n0..s_nnb)``,
    ``s_jk = gamma_j b_k`` (eqs. 19, 22, 23). Step 2 recovers ``b`` and ``gamma``
    from the products, by one of two methods:

    ``"paper"`` (step iv)
        ``b_k`` is read directly from theta and
        ``gamma_j = sum_{k=1}^{nb} b_k s_jk / sum_{k=1}^{nb} b_k^2``; the sums start
        at k = 1 exactly as printed, so the direct term b_0 does not enter. Cheap
        and exact on noise-free data, but every gamma inherits the error of the b
        row, so it is the better choice only when the linear term dominates and the
        noise is low.
    ``"svd"`` (Bai 1998)
        The best rank-1 approximation ``gamma b^T`` of the whole matrix
        ``[b; s_2; ...; s_n]`` (all lags including b_0), from its singular value
        decomposition, normalised to gamma_1 = 1. It uses every product, so it
        averages the noise of all rows and is the better choice with noisy data,
        strong higher-order terms or a poorly excited lag; it costs one small SVD.

    Both leave gamma undefined (NaN) while the b row is zero, e.g. before the
    first update.

    Parameters
    ----------
    na, nb : int
        Orders of A and B (nb >= 1 for ``gamma_method="paper"``).
    degree : int, optional
        Degree of the paper's polynomial basis ``u, ..., u^degree`` (default 3).
        Give ``degree`` or ``basis``, not both.
    lam : float
        Forgetting factor, 0 < lam <= 1.
    delta : float
        Initial covariance ``P0 = delta I``.
    basis : Basis, sequence of callables or str, optional
        The static block's functions instead of the polynomial; the first carries
        gamma_1 = 1. Ship-in functions: :func:`~motorid.estimators.basis.dead_zone`
        and :func:`~motorid.estimators.basis.sign`; a string is parsed by
        :func:`~motorid.estimators.basis.basis_from_spec` (e.g. ``"u,sign"``).
        The built-ins are compiled; a custom (Python) function is called on
        one-sample arrays, in ``batch_filter`` as in the sample loop, so both give
        the same numbers (at a Python call per sample).
    gamma_method : {"paper", "svd"}
        How step 2 recovers b and gamma.
    direct_term : bool
        Keep b_0 (paper); False drops it for a strictly causal model.
    max_trace : float, optional
        Bound on tr(P); None: the initial trace, ``np.inf``: no bound.
    R : float
        Equation-error variance [output unit^2].
    x0 : array_like, optional
        Initial estimate.
    """

    name = "hammerstein-rls"
    text_settings = ("basis", "gamma_method")

    def __init__(
        self,
        na: int,
        nb: int,
        degree: int | None = None,
        lam: float = 1.0,
        delta: float = 1e3,
        basis: Basis | Sequence[BasisFunction | Callable[[np.ndarray], np.ndarray]] | str | None = None,
        gamma_method: GammaMethod = "paper",
        direct_term: bool = True,
        max_trace: float | None = None,
        R: float = 1.0,
        x0: ArrayLike | None = None,
    ):
        self.degree = degree
        self.gamma_method = gamma_method
        super().__init__(
            na, nb, basis, lam=lam, delta=delta, direct_term=direct_term,
            max_trace=max_trace, R=R, x0=x0,
        )  # fmt: skip

    def resolve_basis(self) -> Basis:
        """The basis functions ``degree`` or ``basis`` describe (the polynomial of degree 3 by
        default), with ``gamma_method`` checked.

        Raises
        ------
        ValueError
            For both ``degree`` and ``basis``, an unknown ``gamma_method``, or ``nb`` < 1
            with ``gamma_method="paper"`` and the direct term.
        """
        if self.basis is None:
            resolved = polynomial(3 if self.degree is None else check_order("degree", self.degree, 1))
        elif self.degree is not None:
            raise ValueError("give degree or basis, not both: degree sets the polynomial basis")
        elif isinstance(self.basis, str):
            resolved = basis_from_spec(self.basis)
        else:
            resolved = self.basis if isinstance(self.basis, Basis) else Basis(self.basis)
        if self.gamma_method not in ("paper", "svd"):
            raise ValueError(f"gamma_method must be 'paper' or 'svd', got {self.gamma_method!r}")
        if self.gamma_method == "paper" and self._direct_term and self._nb < 1:
            raise ValueError("nb must be >= 1 for gamma_method='paper': its sums run over k = 1..nb")
        return resolved

    @property
    def n_basis(self) -> int:
        """Number of basis functions n of the static block."""
        return len(self.basis_functions)

    @property
    def state_names(self) -> tuple[str, ...]:
        lags = range(self.k0, self._nb + 1)
        names = [f"a{i}" for i in range(1, self._na + 1)] + [f"b{k}" for k in lags]
        for j in range(2, self.n_basis + 1):
            names += [f"s{j}_{k}" for k in lags]
        return tuple(names)

    def factorize(self, theta: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Step 2: ``(b, gamma)`` from theta (the current estimate by default).

        Accepts a stack of estimates, shape (..., n), e.g. ``result.x`` of
        :meth:`batch_filter`, and returns b of shape (..., nb + 1 - k0) and gamma
        of shape (..., n_basis), gamma[..., 0] = 1.
        """
        M = self.lagged_coefficients(None if theta is None else np.asarray(theta, dtype=float))
        with np.errstate(invalid="ignore", divide="ignore"):
            if self.gamma_method == "paper":
                b = M[..., 0, :]
                first = 1 - self.k0  # column of lag k = 1
                num = np.einsum("...k,...jk->...j", b[..., first:], M[..., first:])
                den = np.einsum("...k,...k->...", b[..., first:], b[..., first:])
                gamma = num / den[..., None]
                gamma[..., 0] = np.where(den > 0, 1.0, np.nan)
            else:
                U, sv, Vt = np.linalg.svd(M, full_matrices=False)
                u0 = U[..., 0, 0]
                gamma = U[..., :, 0] / u0[..., None]
                b = (sv[..., 0] * u0)[..., None] * Vt[..., 0, :]
        return b, gamma

    def simulation_theta(self) -> np.ndarray:
        """theta of the factored model: a, then ``gamma_j b_k`` (the identified
        Hammerstein structure, not the over-parameterised step-1 products)."""
        b, gamma = self.factorize()
        return np.concatenate([self.a, np.outer(gamma, b).ravel()])

    def params_to_json(self) -> dict[str, Any]:
        """As :meth:`LaggedRegressionRLS.params_to_json
        <motorid.estimators.rls.LaggedRegressionRLS.params_to_json>`, with the basis functions in
        use as text (:meth:`Basis.spec <motorid.estimators.basis.Basis.spec>`; ``degree`` is left
        out) and ``gamma_method``.

        Raises
        ------
        ValueError
            For a custom basis function.
        """
        return {
            **super().params_to_json(),
            "basis": self.basis_functions.spec(),
            "gamma_method": self.gamma_method,
        }

    @property
    def params(self) -> dict[str, Any]:
        """``a``; ``b`` (lags k0..nb) and ``gamma`` (gamma_1 = 1) from step 2;
        ``s`` the raw step-1 products [b; s_2; ...; s_n]; ``basis`` the function names."""
        b, gamma = self.factorize()
        return {
            "a": self.a,
            "b": b,
            "gamma": gamma,
            "s": self.lagged_coefficients().copy(),
            "basis": self.basis_functions.names,
        }
