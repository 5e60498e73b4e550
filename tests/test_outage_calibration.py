"""Fitting outage sigma growth and error correlation (graphnav.nets.outage_calibration)."""
from __future__ import annotations

import numpy as np
import pytest

from graphnav.nets.outage_calibration import (
    GAUSSIAN_1SIGMA,
    error_correlation,
    fit_drift,
    history_sigma,
    integrated_autocorrelation,
    member_sigma,
)


def test_history_sigma_is_what_beam_history_hands_on():
    """The vectorised growth against the history class itself, fed raw sigmas that rise and fall."""
    from graphnav.estimators.history import BeamHistory

    raw = np.array([0.05, 0.04, 0.09, 0.02, 0.02, 0.15, 0.01])

    class Scripted:
        n_past, drift_std, calls = 2, 0.03, 0

        def complete(self, past, measured):
            s = raw[self.calls]
            self.calls += 1
            return np.where(np.isfinite(measured), measured, 1.0), np.where(np.isfinite(measured), 0.0, s)

    comp, h = Scripted(), BeamHistory(2)
    h.push(np.ones(4))
    h.push(np.ones(4))
    valid = np.array([True, False, True, True])
    handed = [h.complete(comp, np.ones(4), valid)[1][1] for _ in raw]
    np.testing.assert_allclose(history_sigma(raw[None, :, None], 0.03)[0, :, 0], handed, rtol=1e-12)


@pytest.mark.parametrize("target", ["variance", "coverage"])
def test_fit_drift_recovers_the_growth_of_gaussian_errors(target):
    """Errors drawn with sigma sqrt(s^2 + k d^2), d = 0.02 m/s per ping, over 30-ping windows: the fit of
    member_sigma finds d within 5 %, and its 1-sigma coverage is Gaussian."""
    rng = np.random.default_rng(3)
    raw = np.full((4000, 30, 2), 0.05)
    true = member_sigma(raw, 0.02)
    err = rng.normal(size=raw.shape) * true
    d = fit_drift(err, raw, member_sigma, target)
    assert abs(d / 0.02 - 1) < 0.05
    assert abs(np.mean(np.abs(err) <= member_sigma(raw, d)) - GAUSSIAN_1SIGMA) < 0.01


def test_fit_drift_ends_of_the_range():
    raw = np.full((10, 30, 1), 0.1)
    assert fit_drift(np.full(raw.shape, 0.01), raw) == 0.0              # already inside without growth
    assert fit_drift(np.full(raw.shape, 50.0), raw, upper=0.5) == 0.5    # no growth in range is enough
    with pytest.raises(ValueError, match="target"):
        fit_drift(raw, raw, target="median")


def test_error_correlation_of_known_correlated_errors():
    rng = np.random.default_rng(4)
    z1, z2 = rng.normal(size=(2, 100000))
    e1, e2 = 0.05 * z1, 0.2 * (0.4 * z1 + np.sqrt(1 - 0.16) * z2)
    assert abs(error_correlation(e1, np.full_like(e1, 0.05), e2, np.full_like(e2, 0.2)) - 0.4) < 0.01


def test_integrated_autocorrelation_of_white_and_ar1_errors():
    """tau of an AR(1) sequence z_t = phi z_t-1 + w_t is (1 + phi) / (1 - phi): 9 for phi 0.8; white errors give 1."""
    rng = np.random.default_rng(5)
    seqs = []
    for _ in range(40):
        z = np.zeros(2000)
        w = rng.normal(size=2000)
        for t in range(1, 2000):
            z[t] = 0.8 * z[t - 1] + w[t]
        seqs.append(z)
    assert integrated_autocorrelation(seqs, max_lag=100) == pytest.approx(9.0, rel=0.1)
    assert integrated_autocorrelation(list(rng.normal(size=(20, 500))), max_lag=100) < 1.1
    # an error that stays off for the whole sequence: tau grows with the lags summed
    biased = [np.full(100, 1.0) + 0.1 * rng.normal(size=100) for _ in range(5)]
    assert integrated_autocorrelation(biased, max_lag=60) > 50
    with pytest.raises(ValueError, match="no non-zero errors"):
        integrated_autocorrelation([np.zeros(10)])
