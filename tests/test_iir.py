"""The digital low-pass filters of :mod:`motorid.iir` held against ``scipy.signal`` (``butter``,
``cheby1``, ``sosfilt_zi``, ``sosfiltfilt``), the independent reference, and the errors they raise.

Tolerances. The sections of an even order are built from SciPy's expressions in SciPy's order,
and the run does SciPy's operations in SciPy's order, its steady state solved as SciPy solves it:
measured over 6,000 random filters and signals, every even order gave SciPy's output to the last
bit (3,014 of 3,014), so did the doctor's filters (4th-order Butterworth, 8th-order Chebyshev) on
796 of 796 cut-offs. An odd order's first-order section is paired differently (the transfer
function is the same), and the rounding that leaves grows as the poles near the unit circle (a
low cut-off): at most 4.0e-13 of the signal's largest value down to 0.02 of the Nyquist
frequency, 2.3e-12 for a 9th-order Chebyshev filter at 0.005. Hence 1e-12 of the signal's
largest value for cut-offs from 0.02 (the doctor's decimation filters down to 0.005), and a few
units in the last place for the sections (for a SciPy that writes its expressions otherwise).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
from conftest import examples
from hypothesis import given
from hypothesis import strategies as st

from motorid.iir import butterworth, chebyshev1, steady_state, zero_phase

RIPPLE = 0.05  # dB, the doctor's decimation filter's (that of scipy.signal.decimate)


def designs(order: int, wn: float, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Ours and SciPy's sections of the same low-pass."""
    if kind == "butterworth":
        return butterworth(order, wn), scipy.signal.butter(order, wn, output="sos")
    return chebyshev1(order, RIPPLE, wn), scipy.signal.cheby1(order, RIPPLE, wn, output="sos")


def scipy_zero_phase(sos: np.ndarray, x: np.ndarray) -> np.ndarray:
    return scipy.signal.sosfiltfilt(sos, x, padlen=3 * (2 * sos.shape[0] + 1))


@pytest.mark.parametrize("kind", ["butterworth", "chebyshev1"])
@pytest.mark.parametrize("order", [2, 4, 6, 8, 10])
@pytest.mark.parametrize("wn", [0.005, 0.02, 0.08, 0.2, 0.5, 0.95])
def test_even_orders_give_scipys_sections(kind, order, wn):
    ours, theirs = designs(order, wn, kind)
    # a few units in the last place of each coefficient (the same formulas, rounded alike)
    assert ours == pytest.approx(theirs, rel=4e-15, abs=1e-300)


@given(
    kind=st.sampled_from(["butterworth", "chebyshev1"]),
    order=st.integers(1, 10),
    wn=st.floats(0.02, 0.99),
    extra=st.integers(1, 3000),
    walk=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
@examples(60, deadline=None)
def test_zero_phase_is_scipys_sosfiltfilt(kind, order, wn, extra, walk, seed):
    """Any order, cut-off and length (down to one sample more than the extension): SciPy's
    zero-phase run of SciPy's design, to rounding (module docstring)."""
    ours, theirs = designs(order, wn, kind)
    samples = 3 * (2 * theirs.shape[0] + 1) + extra
    x = np.random.default_rng(seed).normal(size=samples)
    x = x.cumsum() if walk else x
    reference = scipy_zero_phase(theirs, x)
    assert zero_phase(ours, x) == pytest.approx(reference, rel=0, abs=1e-12 * np.max(np.abs(x)))


@pytest.mark.parametrize("factor", [2, 5, 10, 20, 40, 80, 160])
def test_the_decimation_filters_are_scipys(factor):
    """The doctor's anti-alias filters (8th-order Chebyshev at 0.8 / factor of Nyquist, down to
    0.005) on a 16,000-sample record."""
    wn = 0.8 / factor
    x = np.random.default_rng(factor).normal(size=16_000).cumsum()
    reference = scipy_zero_phase(scipy.signal.cheby1(8, RIPPLE, wn, output="sos"), x)
    bound = 1e-12 * np.max(np.abs(x))
    assert zero_phase(chebyshev1(8, RIPPLE, wn), x) == pytest.approx(reference, rel=0, abs=bound)


@pytest.mark.parametrize(("order", "wn"), [(1, 0.5), (3, 0.1), (4, 0.2), (8, 0.01), (9, 0.9)])
def test_steady_state_is_scipys_sosfilt_zi(order, wn):
    theirs = scipy.signal.butter(order, wn, output="sos")
    # the same solve of the same 2 x 2 systems; 1e-12 of the states' scale for a SciPy that
    # changes how it solves them
    expected = scipy.signal.sosfilt_zi(theirs)
    assert steady_state(theirs) == pytest.approx(expected, rel=0, abs=1e-12 * np.max(np.abs(expected)))


def test_a_constant_comes_out_at_the_dc_gain_without_an_edge_transient():
    # the passes start in their steady state; Butterworth's DC gain is 1, an even-order Chebyshev
    # filter's the bottom of its ripple band, -r dB a pass (1e-12 is rounding over the sections'
    # few dozen operations per sample)
    for sos, gain in ((butterworth(4, 0.2), 1.0), (chebyshev1(8, RIPPLE, 0.08), 10 ** (-RIPPLE / 10))):
        edge = 3 * (2 * sos.shape[0] + 1)
        assert zero_phase(sos, np.full(edge + 1, 2.5)) == pytest.approx(
            np.full(edge + 1, 2.5 * gain), rel=1e-12
        )


def test_zero_phase_names_a_signal_shorter_than_its_extension():
    with pytest.raises(ValueError, match="has 27 samples; the zero-phase filter needs more than 27"):
        zero_phase(chebyshev1(8, RIPPLE, 0.08), np.zeros(27))
    # SciPy refuses the same signal
    with pytest.raises(ValueError, match="padlen"):
        scipy_zero_phase(scipy.signal.cheby1(8, RIPPLE, 0.08, output="sos"), np.zeros(27))


def test_zero_phase_leaves_its_input_alone():
    x = np.random.default_rng(3).normal(size=100)
    kept = x.copy()
    zero_phase(butterworth(4, 0.2), x)
    assert np.array_equal(x, kept)


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: butterworth(0, 0.2), "order must be an integer >= 1, got 0"),
        (lambda: butterworth(2.5, 0.2), "order must be an integer >= 1, got 2.5"),
        (lambda: butterworth(True, 0.2), "order must be an integer >= 1, got True"),
        (lambda: butterworth(4, 0.0), "wn must lie strictly between 0 and 1"),
        (lambda: butterworth(4, 1.0), "wn must lie strictly between 0 and 1 .*, got 1.0"),
        (lambda: butterworth(4, float("nan")), "wn must lie strictly between 0 and 1 .*, got nan"),
        (lambda: chebyshev1(8, 0.0, 0.1), "ripple must be a positive number of dB, got 0.0"),
        (lambda: chebyshev1(8, -1.0, 0.1), "ripple must be a positive number of dB, got -1.0"),
        (lambda: zero_phase(np.ones((2, 5)), np.zeros(100)), r"sos must have shape \(n_sections, 6\), got \(2, 5\)"),
        (lambda: zero_phase(np.zeros((0, 6)), np.zeros(100)), r"sos must have shape \(n_sections, 6\), got \(0, 6\)"),
        (lambda: zero_phase([[1, 2, 1, 2, 0, 0]], np.zeros(100)), r"a0 \(sos\[:, 3\]\) must be 1, got \[2.0\]"),
        (lambda: zero_phase(butterworth(4, 0.2), np.zeros((100, 2))), r"x must be one-dimensional, got shape \(100, 2\)"),
    ],
)  # fmt: skip
def test_bad_arguments_are_named(call, words):
    with pytest.raises(ValueError, match=words):
        call()
