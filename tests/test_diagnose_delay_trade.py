"""The inertia and the input delay trade through the viscous friction (issue 23): the balance
determines J + B τ_d, and the doctor says where a record's inertia depends on the delay taken
(:class:`motorid.diagnose.model.DelayTrade`). Calibrated on simulated records with a known truth
and realistic sensors (an encoder's speed: quantised, noise growing with speed)."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.diagnose.calibration import TRADE_PARAMS, delay_trades

SEEDS = range(5000, 5020)


@pytest.fixture(scope="module")
def planted_delays():
    return delay_trades(SEEDS, "input_delay")


def test_the_reported_standard_errors_hold_the_truth_where_a_delay_was_estimated(planted_delays):
    """On 20 records with a planted input delay (taken by the structure search on 19), the truth
    lies within 2 reported standard errors on 19 of 20 for each of the inertia, the viscous and the
    Coulomb level (measured; 28 of 30 each on seeds 5000-5029): with a delay in the model they are
    the errors with the delay set free, since it was estimated with them (17-19 of 20 measured).
    Held at the delay taken, the same fits' errors hold the inertia's truth on 17 of 30 only."""
    assert (
        sum(planted_delays.delayed) >= 15
    )  # measured 20: the structure search or the final stage takes the delay
    for name in TRADE_PARAMS:
        # intervals of 95 % cover 17 or more of 20 with probability 0.984 (binomial)
        assert planted_delays.covered(name) >= 17, (name, planted_delays.z[name])
        assert planted_delays.covered(name, free=True) >= 17, (name, planted_delays.z_free[name])


def test_the_inertia_is_flagged_where_it_depends_on_the_delay_taken_and_only_there(planted_delays):
    """The records whose inertia the doctor flags as trading with the delay are those whose stated
    inertia lies far from the truth; on 20 records with no delay planted (the rig's electrical lag
    and shaft only) it flags none. On the 20 with a delay it now flags none either: the one whose
    delay the structure search missed (its inertia 16 % off, flagged) is given it on the final
    model, where its balance and free run read it alike. The record where it took 30 ms for 32.6
    moves its inertia by 2.97 standard errors with the delay free, just under the limit of 3, and
    states it 5.2 % from the truth. (The wheel and kit motors' runs, flagged, are the real case:
    ``tests/test_diagnose_realmotors.py``.)"""
    traded = np.array(planted_delays.traded)
    assert traded.sum() <= 4, traded
    assert np.all(np.abs(np.array(planted_delays.error)[traded]) > 0.03)
    # and the records it does not flag hold the inertia within 6 % (measured: 5.2 % on the one
    # above, 1.3 % at most on the others)
    assert np.all(np.abs(np.array(planted_delays.error)[~traded]) < 0.06)
    plain = delay_trades(SEEDS, None)
    assert not any(plain.traded), plain.traded


def test_the_sensitivity_to_the_delay_is_the_fits_own_slope():
    """``DelayTrade.sensitivity`` (``∂θ/∂τ_d = -(XᵀX - D)⁻¹ Xᵀ Ḟ``, which the reported errors
    carry the delay's uncertainty through) against the fit itself, refitted at the delay ± 0.1
    sample: within 2 % (measured 0.4-0.7 %; the central difference's own error and the delay's
    interpolation between samples)."""
    from motorid.diagnose.model import fit_model
    from motorid.diagnose.synthetic import planted_record
    from motorid.diagnose.workflow import prepare

    p = planted_record("input_delay", 5001, sensor="encoder")
    data = prepare(p.record, input_gain=p.input_gain).data
    effects = (*p.base, "input_delay")
    delay, h = p.effects["input_delay"]["input_delay"], 0.1 * data.dt
    slope = fit_model(data, effects, fixed={"input_delay": delay}).delay_trade.sensitivity
    low, high = (fit_model(data, effects, fixed={"input_delay": delay + s}).model.params for s in (-h, h))
    for name in ("inertia", "viscous", "coulomb"):
        assert slope[name] == pytest.approx((high[name] - low[name]) / (2 * h), rel=0.02), name
