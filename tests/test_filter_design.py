"""The doctor's own filter design and bounded search against scipy's, which they replace on the
command's path (scipy.signal and scipy.optimize take about 1 s and 55 MB to import).

The doctor's figures must not depend on which of the two ran, so every comparison is exact
(``np.array_equal``, ``==``): the same operations in the same order give the same bits.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.optimize
import scipy.signal

from motorid.diagnose.kinematics import (
    _anti_alias,
    _butterworth,
    butterworth_prototype,
    chebyshev1_prototype,
    decimation_factor,
    default_band,
    lowpass_sections,
    steady_state,
)
from motorid.diagnose.model import bounded_minimum

#: Cut-offs (fraction of Nyquist) from far below the doctor's to its clip at 0.95 and beyond.
CUTOFFS = [*np.geomspace(1e-4, 0.999, 40).tolist(), 0.2, 0.5, 0.95]


@pytest.mark.parametrize("order", [2, 4, 6, 8, 10])
def test_butterworth_sections_and_initial_states_equal_scipy_bit_for_bit(order):
    for wn in CUTOFFS:
        sos = lowpass_sections(*butterworth_prototype(order), wn)
        reference = scipy.signal.butter(order, wn, output="sos")
        assert np.array_equal(sos, reference), (order, wn)
        assert np.array_equal(steady_state(sos), scipy.signal.sosfilt_zi(reference)), (order, wn)


@pytest.mark.parametrize("order", [2, 4, 8])
@pytest.mark.parametrize("ripple", [0.05, 0.5, 3.0])
def test_chebyshev_sections_and_initial_states_equal_scipy_bit_for_bit(order, ripple):
    for wn in CUTOFFS:
        sos = lowpass_sections(*chebyshev1_prototype(order, ripple), wn)
        reference = scipy.signal.cheby1(order, ripple, wn, output="sos")
        assert np.array_equal(sos, reference), (order, ripple, wn)
        assert np.array_equal(steady_state(sos), scipy.signal.sosfilt_zi(reference)), (order, ripple, wn)


@pytest.mark.parametrize("dt", [0.0005, 0.001, 0.005, 0.01, 0.04])
def test_the_doctors_filters_equal_scipys_designs(dt):
    """The designs the doctor uses at common sample times: the smoothing low-passes at their
    cut-offs (2.5, 10 and 12.5 f_b, clipped at 0.95 of Nyquist) and the decimation filter."""
    band = default_band(dt)
    for cutoff in (2.5 * band, 10.0 * band, 12.5 * band):
        wn = min(cutoff * 2.0 * dt, 0.95)
        sos, zi = _butterworth(4, wn)
        assert np.array_equal(sos, scipy.signal.butter(4, wn, output="sos"))
        assert np.array_equal(zi, scipy.signal.sosfilt_zi(sos))
    factor = decimation_factor(dt, band)
    if factor > 1:
        sos, zi = _anti_alias(factor)
        assert np.array_equal(sos, scipy.signal.cheby1(8, 0.05, 0.8 / factor, output="sos"))
        assert np.array_equal(zi, scipy.signal.sosfilt_zi(sos))


def test_lowpass_sections_name_an_odd_order_and_a_cutoff_out_of_range():
    with pytest.raises(ValueError, match=r"order must be even and 0 < wn < 1; got order 3, wn 0\.2"):
        lowpass_sections(*butterworth_prototype(3), 0.2)
    for wn in (0.0, 1.0, -0.1, math.nan):
        with pytest.raises(ValueError, match=r"order must be even and 0 < wn < 1; got order 4, wn "):
            lowpass_sections(*butterworth_prototype(4), wn)


#: Functions with an interior minimum, a minimum on a bound, a kink, a plateau, several minima
#: and the wall the doctor's search meets (1e300 where a shape needs a negative level).
FUNCTIONS = {
    "parabola": lambda z: (z - 0.3) ** 2,
    "rising": lambda z: math.exp(z),
    "kink": lambda z: abs(z - 0.1),
    "plateau": lambda z: 5.0,
    "wavy": lambda z: math.cos(3.0 * z) + 0.1 * z,
    "wall": lambda z: 1e300 if z > 0.2 else (z + 1.0) ** 4,
}


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_bounded_minimum_equals_scipys_bounded_search_bit_for_bit(name):
    """Same points called in the same order, same result, on random brackets and tolerances."""
    func = FUNCTIONS[name]
    rng = np.random.default_rng(sorted(FUNCTIONS).index(name))
    for _ in range(60):
        lo = float(rng.uniform(-5.0, 1.0))
        hi = lo + float(rng.uniform(0.0, 4.0))
        xatol = float(10 ** rng.uniform(-8.0, -1.0))
        ours: list[float] = []
        theirs: list[float] = []
        x, fx = bounded_minimum(lambda z, seen=ours: seen.append(z) or func(z), lo, hi, xatol)
        reference = scipy.optimize.minimize_scalar(
            lambda z, seen=theirs: seen.append(z) or func(z),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": xatol},
        )
        assert ours == theirs
        assert x == reference.x and fx == reference.fun


def test_bounded_minimum_stops_after_max_calls_as_scipy_does():
    calls: list[float] = []
    x, _ = bounded_minimum(lambda z: calls.append(z) or math.cos(3.0 * z), -5.0, 5.0, 1e-12, max_calls=7)
    reference = scipy.optimize.minimize_scalar(
        lambda z: math.cos(3.0 * z),
        bounds=(-5.0, 5.0),
        method="bounded",
        options={"xatol": 1e-12, "maxiter": 7},
    )
    assert len(calls) == 7 and x == reference.x


@pytest.mark.parametrize("bounds", [(1.0, 0.0), (0.0, math.inf), (math.nan, 1.0)])
def test_bounded_minimum_names_bad_bounds(bounds):
    with pytest.raises(ValueError, match=r"bounds must be finite with lo <= hi, got \["):
        bounded_minimum(lambda z: z, *bounds, 1e-3)
