"""Basis functions for the static block of a Hammerstein model.

The static nonlinearity is a weighted sum of basis functions of the input,

    x(t) = gamma_1 g_1(u(t)) + gamma_2 g_2(u(t)) + ... + gamma_n g_n(u(t)),

with gamma_1 = 1 fixing the scale the Hammerstein structure leaves free. The paper
uses powers, g_j(u) = u^j (eq. 16). A cubic polynomial fits a dead zone or a
sign-like (Coulomb) step poorly, so :func:`dead_zone` and :func:`sign` are
offered as basis functions too, and any element-wise function of ``u`` can be used.

One evaluation serves every path: every sample's basis values come from one
compiled function, :func:`builtin_row`, and every sample is computed on its own.
:meth:`Basis.evaluate` calls it for each sample of a record (``batch_filter``,
``simulate``); the per-sample
:meth:`~motorid.estimators.rls.LaggedRegressionRLS.predict` calls it for its one
sample inside its compiled kernel (after :meth:`Basis.evaluate` on a one-sample
array where the basis has a custom function). The values are computed:

- the built-in functions (:func:`power`, :func:`sign`, :func:`dead_zone`) by one
  compiled scalar function, :func:`builtin_value`, called once per sample and
  function. It uses only correctly rounded IEEE operations (products, differences,
  comparisons; no ``pow`` or other library call, whose SIMD variants round
  differently), so a sample gets the same bits whether it comes alone or inside a
  record, on every CPU and compiled target. (NumPy's vectorised ``u**3`` does
  not promise that: it dispatches SIMD code per CPU, and on AVX-512 it can differ
  in the last bit from a scalar power.)
- a custom Python function by one call per sample on a one-sample array, in the
  per-sample path and in ``batch_filter`` alike. It costs a Python call per
  sample in ``batch_filter`` (the built-ins are compiled), and makes the value of
  a sample independent of the SIMD path NumPy picks for a longer array.

So the regressors of the sample loop and of ``batch_filter`` are the same numbers
by construction, and so are their estimates (:mod:`motorid.estimators.rls`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit

#: kinds of built-in function understood by :func:`builtin_value`
POWER, SIGN, DEAD_ZONE = 0, 1, 2
#: kind of a custom (Python) function, evaluated outside the compiled code
CUSTOM = -1


@njit(cache=True)
def builtin_value(kind: int, parameter: float, u: float) -> float:
    """One built-in basis function at one input ``u`` [V].

    ``POWER``: ``u^j`` with j = ``parameter``, as the product ``u u ... u`` taken
    left to right (j - 1 correctly rounded multiplications); ``SIGN``: sgn(u),
    sgn(0) = 0 (paper eq. 10); ``DEAD_ZONE``: ``u - d`` for u > d, ``u + d`` for
    u < -d, else 0, with d = ``parameter`` [V] (paper Fig. 4).
    """
    if kind == POWER:
        value = u
        for _ in range(1, int(parameter)):
            value = value * u
        return value
    if kind == SIGN:
        if u > 0.0:
            return 1.0
        if u < 0.0:
            return -1.0
        return 0.0
    if u > parameter:
        return u - parameter
    if u < -parameter:
        return u + parameter
    return 0.0


@njit(cache=True)
def builtin_row(kinds: np.ndarray, parameters: np.ndarray, u: float, g: np.ndarray) -> int:
    """One sample: ``g[j] = builtin_value(kinds[j], parameters[j], u)`` for every
    built-in column; columns of kind ``CUSTOM`` keep what the caller put there.

    Returns the first column of ``g`` (built-in or custom) whose value is not
    finite, or -1. The per-sample RLS kernel and :func:`builtin_columns` both call
    it, so a sample's basis values are computed by one function on either path.
    """
    first_bad = -1
    for j in range(kinds.shape[0]):
        if kinds[j] != CUSTOM:
            g[j] = builtin_value(kinds[j], parameters[j], u)
        if first_bad < 0 and not math.isfinite(g[j]):
            first_bad = j
    return first_bad


@njit(cache=True)
def builtin_columns(kinds: np.ndarray, parameters: np.ndarray, u: np.ndarray, G: np.ndarray) -> int:
    """:func:`builtin_row` for every sample: ``G[t, j] = builtin_value(kinds[j],
    parameters[j], u[t])`` for every built-in column (columns of kind ``CUSTOM``
    keep their values).

    Returns the flat index ``t * n + j`` of the first non-finite value of ``G``, or -1.
    """
    n = kinds.shape[0]
    first_bad = -1
    for t in range(u.shape[0]):
        bad = builtin_row(kinds, parameters, u[t], G[t])
        if first_bad < 0 and bad >= 0:
            first_bad = t * n + bad
    return first_bad


@dataclass(frozen=True)
class BasisFunction:
    """One named function ``g(u)`` of the input [V], applied element by element.

    Parameters
    ----------
    name : str
        How it is shown in ``params`` and tables, e.g. ``"u^2"``.
    func : callable, optional
        A custom function: maps a float array of inputs to an array of the same
        shape, each element from the input element alone. None for a built-in.
    builtin : tuple of (int, float), optional
        The compiled form ``(kind, parameter)`` of a built-in function (see
        :func:`builtin_value`); set by :func:`power`, :func:`sign` and
        :func:`dead_zone`. Give ``func`` or ``builtin``, not both.
    """

    name: str
    func: Callable[[np.ndarray], np.ndarray] | None = None
    builtin: tuple[int, float] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if (self.func is None) == (self.builtin is None):
            raise ValueError(f"basis function {self.name!r} needs func or builtin, not both or neither")
        if self.func is not None and not callable(self.func):
            raise ValueError(f"func of basis function {self.name!r} must be callable, got {self.func!r}")
        if self.builtin is not None:
            kind, parameter = self.builtin
            valid = (
                (kind == POWER and float(parameter).is_integer() and parameter >= 1)
                or kind == SIGN
                or (kind == DEAD_ZONE and math.isfinite(parameter) and parameter >= 0.0)
            )
            if not valid:
                raise ValueError(f"basis function {self.name!r}: no built-in {self.builtin!r}")

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """``g(u)`` for an array of inputs [V], of the same shape."""
        arr = np.asarray(u, dtype=float)
        if self.func is not None:
            return np.asarray(self.func(arr), dtype=float)
        kind, parameter = self.builtin  # type: ignore[misc]
        flat = np.ascontiguousarray(arr.reshape(-1))
        out = np.empty((flat.shape[0], 1))
        builtin_columns(np.array([kind]), np.array([parameter], dtype=float), flat, out)
        return out.reshape(arr.shape)


#: Highest power of the input in a basis: u^j is a product of j factors per sample, and a drive's
#: static nonlinearity is a polynomial of a few terms (the paper's degrees go to 7).
MOST_POWER = 32


def power(j: int) -> BasisFunction:
    """``g(u) = u^j`` (paper eq. 16), the product of j factors u; 1 <= j <= :data:`MOST_POWER`.

    Parameters
    ----------
    j : int
        The power, 1 to :data:`MOST_POWER`.
    """
    if isinstance(j, bool) or not isinstance(j, (int, np.integer)) or not 1 <= j <= MOST_POWER:
        raise ValueError(f"power must be an integer in [1, {MOST_POWER}], got {j!r}")
    return BasisFunction("u" if j == 1 else f"u^{j}", builtin=(POWER, float(j)))


def sign() -> BasisFunction:
    """``g(u) = sgn(u)`` (paper eq. 10, sgn(0) = 0): a Coulomb-like step at zero input."""
    return BasisFunction("sign(u)", builtin=(SIGN, 0.0))


def dead_zone(d: float) -> BasisFunction:
    """The ideal dead zone of width ``2 d`` [V] (paper Fig. 4).

    ``g(u) = u - d`` for ``u > d``, ``u + d`` for ``u < -d`` and 0 in between.

    Parameters
    ----------
    d : float
        Half-width of the dead zone [V], finite and >= 0.
    """
    d = float(d)
    if not np.isfinite(d) or d < 0.0:
        raise ValueError(f"dead zone half-width d must be finite and >= 0, got {d}")
    return BasisFunction(f"dead_zone(u, {d:g})", builtin=(DEAD_ZONE, d))


class Basis(Sequence[BasisFunction]):
    """An ordered list of basis functions; the first one carries gamma_1 = 1.

    Parameters
    ----------
    functions : iterable of BasisFunction or callable
        Plain callables are custom functions named ``g1``, ``g2``, ... by position.
    """

    def __init__(self, functions: Iterable[BasisFunction | Callable[[np.ndarray], np.ndarray]]):
        items: list[BasisFunction] = []
        for j, f in enumerate(functions, start=1):
            if isinstance(f, BasisFunction):
                items.append(f)
            elif callable(f):
                items.append(BasisFunction(getattr(f, "__name__", f"g{j}").replace("<lambda>", f"g{j}"), f))
            else:
                raise ValueError(f"basis entry {j} must be callable, got {f!r}")
        if not items:
            raise ValueError("basis must hold at least one function")
        self._functions = tuple(items)
        self._custom = tuple(j for j, f in enumerate(items) if f.builtin is None)
        #: True when a function is a custom Python function, evaluated outside the compiled code
        self.has_custom = bool(self._custom)
        #: kind of each function for the compiled code (:func:`builtin_value`; ``CUSTOM``)
        self.kinds = np.array([CUSTOM if f.builtin is None else f.builtin[0] for f in items], dtype=np.int64)
        #: parameter of each built-in function for the compiled code (0.0 for a custom one)
        self.parameters = np.array([0.0 if f.builtin is None else f.builtin[1] for f in items])

    def __getitem__(self, index):  # type: ignore[override]
        return self._functions[index]

    def __len__(self) -> int:
        return len(self._functions)

    def __iter__(self) -> Iterator[BasisFunction]:
        return iter(self._functions)

    @property
    def names(self) -> tuple[str, ...]:
        """The name of each function."""
        return tuple(f.name for f in self._functions)

    def evaluate(self, u: np.ndarray, start: int = 0) -> np.ndarray:
        """``G[t, j] = g_j(u[t])``, shape ``(len(u), len(self))``, each sample on its own.

        The one evaluation of the basis (module docstring): the sample loop calls it
        with one sample, ``batch_filter`` with the record, and both get the same bits.

        Parameters
        ----------
        u : ndarray, shape (N,)
            Inputs [V].
        start : int
            Sample index of ``u[0]`` in the record, for the error message.

        Raises
        ------
        ValueError
            Naming the function and the sample where a function returns a wrong
            shape or a non-finite value.
        """
        u = np.ascontiguousarray(u, dtype=float)
        n = len(self._functions)
        columns = np.empty((u.shape[0], n))
        for j in self._custom:
            f = self._functions[j]
            for t in range(u.shape[0]):
                value = f(u[t : t + 1])
                if value.shape != (1,):
                    raise ValueError(
                        f"basis function {f.name!r} returned shape {value.shape} for one sample, expected (1,)"
                    )
                columns[t, j] = value[0]
        first_bad = builtin_columns(self.kinds, self.parameters, u, columns)
        if first_bad >= 0:
            t, j = divmod(first_bad, n)
            raise self.value_error(j, float(columns[t, j]), float(u[t]), start + t)
        return columns

    def value_error(self, column: int, value: float, u: float, sample: int) -> ValueError:
        """The error for a function that is not finite: names it, the sample and ``u`` [V]."""
        return ValueError(
            f"basis function {self._functions[column].name!r} is {value} at sample {sample} (u = {u} V)"
        )

    def spec(self) -> str:
        """The basis as the text :func:`basis_from_spec` reads back (``"u,u^2,sign"``).

        Raises
        ------
        ValueError
            For a custom basis function: only built-in ones have a text.
        """
        items = []
        for f in self:
            if f.builtin is None:
                raise ValueError(
                    f"cannot save the custom basis function {f.name!r}: only built-in ones are saved"
                )
            kind, parameter = f.builtin
            if kind == POWER:
                items.append(f"u^{int(parameter)}")
            elif kind == SIGN:
                items.append("sign")
            elif kind == DEAD_ZONE:
                items.append(f"dead_zone:{float(parameter)!r}")
        return ",".join(items)

    def __repr__(self) -> str:
        return f"Basis({', '.join(self.names)})"


def polynomial(degree: int) -> Basis:
    """The paper's polynomial basis ``u, u^2, ..., u^degree`` (eq. 16), degree <= :data:`MOST_POWER`.

    Parameters
    ----------
    degree : int
        The highest power, 1 to :data:`MOST_POWER`.
    """
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or not 1 <= degree <= MOST_POWER:
        raise ValueError(f"degree must be an integer in [1, {MOST_POWER}], got {degree!r}")
    return Basis(power(j) for j in range(1, int(degree) + 1))


_SPEC_ITEM = re.compile(r"^(?:u\^?(\d*)|sign|dead_zone[:(](.+?)\)?)$")


def basis_from_spec(spec: str) -> Basis:
    """A basis from a comma-separated text, as typed on the command line.

    Items: ``u``, ``u^j`` (or ``uj``), ``sign``, ``dead_zone:D`` (or ``dead_zone(D)``,
    D in volts); ``poly:N`` expands to ``u, ..., u^N``. Example: ``"u,sign"``.

    Parameters
    ----------
    spec : str
        The comma-separated items.
    """
    functions: list[BasisFunction] = []
    for raw in spec.split(","):
        item = raw.strip().replace(" ", "")
        if item.startswith("poly:"):
            functions.extend(polynomial(int(item[5:])))
            continue
        match = _SPEC_ITEM.match(item)
        if match is None:
            raise ValueError(
                f"unknown basis item {raw.strip()!r} in {spec!r}: use u, u^j, sign, dead_zone:D or poly:N"
            )
        if item == "sign":
            functions.append(sign())
        elif item.startswith("dead_zone"):
            functions.append(dead_zone(float(match.group(2))))
        else:
            functions.append(power(int(match.group(1) or 1)))
    return Basis(functions)
