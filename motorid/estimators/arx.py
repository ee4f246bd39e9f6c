"""ARX model identified online by recursive least squares (paper eq. 14, step iii)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from motorid.estimators.basis import Basis, power
from motorid.estimators.rls import LaggedRegressionRLS


class ARXRLS(LaggedRegressionRLS):
    """Linear ARX model ``A(q^-1) y(t) = B(q^-1) u(t) + e(t)`` by RLS with forgetting.

    ``A(q^-1) = 1 + a_1 q^-1 + ... + a_na q^-na`` and
    ``B(q^-1) = b_0 + b_1 q^-1 + ... + b_nb q^-nb`` (paper eq. 14), identified with
    the regressor ``phi(t) = (-y(t-1), ..., -y(t-na), u(t), ..., u(t-nb))^T`` and
    ``x = theta = (a_1, ..., a_na, b_0, ..., b_nb)``. The algorithm, its Kalman-filter
    form and the covariance-windup bound are described in :mod:`motorid.estimators.rls`.

    Parameters
    ----------
    na, nb : int
        Orders of A and B.
    lam : float
        Forgetting factor, 0 < lam <= 1.
    delta : float
        Initial covariance ``P0 = delta I``.
    direct_term : bool
        Keep b_0 (paper); False drops it for a strictly causal model.
    max_trace : float, optional
        Bound on tr(P); None: the initial trace, ``np.inf``: no bound.
    R : float
        Equation-error variance [output unit^2].
    x0 : array_like, optional
        Initial estimate.

    Examples
    --------
    >>> est = ARXRLS(na=2, nb=2, lam=0.99)
    >>> for u_t, y_t in zip(u, y):          # doctest: +SKIP
    ...     y_hat = est.predict(u_t)
    ...     est.update(y_t)
    >>> est.params["a"], est.params["b"]    # doctest: +SKIP
    """

    name = "arx-rls"

    def __init__(
        self,
        na: int,
        nb: int,
        lam: float = 1.0,
        delta: float = 1e3,
        direct_term: bool = True,
        max_trace: float | None = None,
        R: float = 1.0,
        x0: ArrayLike | None = None,
    ):
        super().__init__(
            na, nb, Basis([power(1)]), lam=lam, delta=delta, direct_term=direct_term,
            max_trace=max_trace, R=R, x0=x0,
        )  # fmt: skip

    @property
    def state_names(self) -> tuple[str, ...]:
        return tuple(f"a{i}" for i in range(1, self._na + 1)) + tuple(
            f"b{k}" for k in range(self.k0, self._nb + 1)
        )

    @property
    def b(self) -> np.ndarray:
        """Coefficients b_k0..b_nb of B(q^-1) (current estimate)."""
        return self.x[self._na :].copy()

    @property
    def params(self) -> dict[str, Any]:
        """``a`` (a_1..a_na) and ``b`` (b_k0..b_nb), dimensionless and [output unit / V]."""
        return {"a": self.a, "b": self.b}
