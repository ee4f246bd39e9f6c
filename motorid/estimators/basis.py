"""Basis functions for the static block of a Hammerstein model.

The static nonlinearity is a weighted sum of basis functions of the input,

    x(t) = gamma_1 g_1(u(t)) + gamma_2 g_2(u(t)) + ... + gamma_n g_n(u(t)),

with gamma_1 = 1 fixing the scale the Hammerstein structure leaves free. The paper
uses powers, g_j(u) = u^j (eq. 16). A cubic polynomial fits a dead zone or a
sign-like (Coulomb) step poorly, so :func:`dead_zone` and :func:`sign` are
offered as basis functions too, and any vectorised function of ``u`` can be used.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BasisFunction:
    """One named, vectorised function ``g(u)`` of the input [V].

    Parameters
    ----------
    name : str
        How it is shown in ``params`` and tables, e.g. ``"u^2"``.
    func : callable
        Maps a float array of inputs to an array of the same shape.
    """

    name: str
    func: Callable[[np.ndarray], np.ndarray]

    def __call__(self, u: np.ndarray) -> np.ndarray:
        return np.asarray(self.func(np.asarray(u, dtype=float)), dtype=float)


def power(j: int) -> BasisFunction:
    """``g(u) = u^j`` (paper eq. 16)."""
    if j < 1:
        raise ValueError(f"power must be >= 1, got {j}")
    if j == 1:
        return BasisFunction("u", lambda u: u)
    return BasisFunction(f"u^{j}", lambda u: u**j)


def sign() -> BasisFunction:
    """``g(u) = sgn(u)`` (paper eq. 10, sgn(0) = 0): a Coulomb-like step at zero input."""
    return BasisFunction("sign(u)", np.sign)


def dead_zone(d: float) -> BasisFunction:
    """The ideal dead zone of width ``2 d`` [V] (paper Fig. 4).

    ``g(u) = u - d`` for ``u > d``, ``u + d`` for ``u < -d`` and 0 in between.
    """
    d = float(d)
    if not np.isfinite(d) or d < 0.0:
        raise ValueError(f"dead zone half-width d must be finite and >= 0, got {d}")
    return BasisFunction(f"dead_zone(u, {d:g})", lambda u: np.sign(u) * np.maximum(np.abs(u) - d, 0.0))


class Basis(Sequence[BasisFunction]):
    """An ordered list of basis functions; the first one carries gamma_1 = 1.

    Parameters
    ----------
    functions : iterable of BasisFunction or callable
        Plain callables are named ``g1``, ``g2``, ... by position.
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

    def evaluate(self, u: np.ndarray) -> np.ndarray:
        """``G[t, j] = g_j(u[t])``, shape ``(len(u), len(self))``; ValueError naming
        the function and sample where one returns a wrong shape or a non-finite value."""
        u = np.asarray(u, dtype=float)
        columns = np.empty((u.shape[0], len(self._functions)))
        for j, f in enumerate(self._functions):
            values = f(u)
            if values.shape != u.shape:
                raise ValueError(
                    f"basis function {f.name!r} returned shape {values.shape} for input {u.shape}"
                )
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                raise ValueError(f"basis function {f.name!r} is not finite at sample {int(bad[0])}")
            columns[:, j] = values
        return columns

    def evaluate_scalar(self, u: float) -> np.ndarray:
        """``g_j(u)`` for one input value, shape ``(len(self),)`` (the per-sample path)."""
        values = [float(f.func(u)) for f in self._functions]
        if not math.isfinite(sum(values)):
            j = next(j for j, value in enumerate(values) if not math.isfinite(value))
            raise ValueError(f"basis function {self._functions[j].name!r} is {values[j]} at u = {u}")
        return np.array(values)

    def __repr__(self) -> str:
        return f"Basis({', '.join(self.names)})"


def polynomial(degree: int) -> Basis:
    """The paper's polynomial basis ``u, u^2, ..., u^degree`` (eq. 16)."""
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 1:
        raise ValueError(f"degree must be an integer >= 1, got {degree!r}")
    return Basis(power(j) for j in range(1, int(degree) + 1))


_SPEC_ITEM = re.compile(r"^(?:u\^?(\d*)|sign|dead_zone[:(](.+?)\)?)$")


def basis_from_spec(spec: str) -> Basis:
    """A basis from a comma-separated text, as typed on the command line.

    Items: ``u``, ``u^j`` (or ``uj``), ``sign``, ``dead_zone:D`` (or ``dead_zone(D)``,
    D in volts); ``poly:N`` expands to ``u, ..., u^N``. Example: ``"u,sign"``.
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
