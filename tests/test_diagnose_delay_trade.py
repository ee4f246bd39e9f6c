"""The inertia and the input delay trade through the viscous friction (issue 23): the balance
determines J + B τ_d, and the doctor says where a record's inertia depends on the delay taken
(:class:`motorid.diagnose.model.DelayTrade`). Calibrated on simulated records with a known truth
and realistic sensors (an encoder's speed: quantised, noise growing with speed)."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.diagnose.calibration import delay_trades

SEEDS = range(5000, 5020)


@pytest.fixture(scope="module")
def planted_delays():
    return delay_trades(SEEDS, "input_delay")


def test_with_the_delay_set_free_the_standard_errors_hold_the_truth(planted_delays):
    """On 20 records with a planted input delay, the truth lies within 2 standard errors of the fit
    with the delay set free: the inertia on 19 (measured; 28 of 30 on seeds 5000-5029), the viscous
    and Coulomb levels on all 20 (30 of 30); the stated fit, its delay held at what the structure
    search took, holds the inertia's truth on 11 only (17 of 30): its errors leave out the delay's."""
    z, z_free = np.abs(planted_delays.z), np.abs(planted_delays.z_free)
    assert np.sum(z_free <= 2.0) >= 18, z_free  # about 95 % of 20, one more left for the draw
    assert np.sum(np.abs(planted_delays.z_free_viscous) <= 2.0) >= 18
    assert np.sum(np.abs(planted_delays.z_free_coulomb) <= 2.0) >= 18
    assert np.sum(z <= 2.0) < np.sum(z_free <= 2.0)


def test_the_inertia_is_flagged_where_it_depends_on_the_delay_taken_and_only_there(planted_delays):
    """The records whose inertia the doctor flags as trading with the delay (2 of 20: the structure
    search missed the delay on one, took 30 ms for 32.6 on the other) are those whose stated
    inertia lies far from the truth (6 % and 16 %, 17 and 30 standard errors); on 20 records with no
    delay planted (the rig's electrical lag and shaft only) it flags none (measured: the largest
    move 2.7 standard errors, under the limit of 3)."""
    traded = np.array(planted_delays.traded)
    assert 1 <= traded.sum() <= 4, traded
    assert np.all(np.abs(np.array(planted_delays.error)[traded]) > 0.03)
    assert np.all(np.abs(np.array(planted_delays.z)[traded]) > 5.0)
    plain = delay_trades(SEEDS, None)
    assert not any(plain.traded), plain.traded
