"""The sigma-weighted combination of two completers (graphnav.nets.fused)."""
from __future__ import annotations

import numpy as np

from graphnav.nets import AverageCompleter
from graphnav.nets.fused import FusedCompleter, fuse


def test_independent_errors_combine_to_the_inverse_variance_sigma():
    """Two unbiased completions with independent errors of 0.05 and 0.10 m/s: the combined error's RMS is
    (1/0.05^2 + 1/0.10^2)^-1/2 = 0.0447 m/s, its sigma says so and covers 68 % within one sigma."""
    rng = np.random.default_rng(0)
    truth = rng.normal(0.0, 1.0, 20000)
    s1, s2 = np.full_like(truth, 0.05), np.full_like(truth, 0.10)
    b, s = fuse(truth + rng.normal(0, 0.05, truth.size), s1, truth + rng.normal(0, 0.10, truth.size), s2)
    expected = (1 / 0.05 ** 2 + 1 / 0.10 ** 2) ** -0.5
    assert np.allclose(s, expected)
    rms = np.sqrt(np.mean((b - truth) ** 2))
    assert abs(rms / expected - 1) < 0.03
    assert abs(np.mean(np.abs(b - truth) < s) - 0.683) < 0.02


def test_measured_beams_pass_through_and_weights_follow_the_sigmas():
    b, s = fuse(np.array([1.0, 2.0, 3.0, 4.0]), np.array([0.0, 0.1, 0.1, 0.0]),
                np.array([9.0, 4.0, 3.0, 9.0]), np.array([0.0, 0.1, 0.2, 0.0]))
    assert b[0] == 1.0 and b[3] == 4.0 and s[0] == 0.0 and s[3] == 0.0     # measured: the first, sigma 0
    assert b[1] == 3.0                                                    # equal sigmas: the mean
    assert b[2] == 3.0 and np.isclose(s[2], (1 / 0.01 + 1 / 0.04) ** -0.5)


def test_fused_completer_is_fuse_of_its_members():
    rng = np.random.default_rng(1)
    past = rng.normal(1.0, 0.2, (5, 4))
    measured = np.array([0.9, np.nan, 1.1, np.nan])
    a3, a5 = AverageCompleter(3), AverageCompleter(5)
    fused = FusedCompleter(a3, a5)
    assert fused.n_past == 5 and not fused.needs_imu
    b, s = fused.complete(past, measured)
    expect = fuse(*a3.complete(past[-3:], measured), *a5.complete(past, measured))
    np.testing.assert_array_equal(b, expect[0])
    np.testing.assert_array_equal(s, expect[1])
    assert np.all(s[[1, 3]] > 0) and np.all(s[[0, 2]] == 0)


def _correlated(rng, n, s1, s2, rho):
    """Errors of two completions with sigmas s1, s2 and correlation rho."""
    z1, z2 = rng.normal(size=(2, n))
    return s1 * z1, s2 * (rho * z1 + np.sqrt(1 - rho ** 2) * z2)


def test_correlated_errors_weights_minimise_the_combined_error_and_sigma_is_its_rms():
    """Errors of 0.05 and 0.10 m/s correlated by 0.3: the weights from the formula give the smallest RMS of any
    fixed weight (grid, Monte Carlo), and the returned sigma is that RMS; the independent formula states a smaller
    sigma than its combination achieves."""
    rng = np.random.default_rng(2)
    n, s1, s2, rho = 200000, 0.05, 0.10, 0.3
    e1, e2 = _correlated(rng, n, s1, s2, rho)
    b, s = fuse(e1, np.full(n, s1), e2, np.full(n, s2), rho)
    rms = np.sqrt(np.mean(b ** 2))
    assert abs(rms / s[0] - 1) < 0.01
    grid = [np.sqrt(np.mean((w * e1 + (1 - w) * e2) ** 2)) for w in np.linspace(0, 1, 101)]
    assert rms <= min(grid) * 1.001
    b0, s0 = fuse(e1, np.full(n, s1), e2, np.full(n, s2))
    assert np.sqrt(np.mean(b0 ** 2)) > 1.05 * s0[0]


def test_correlation_above_the_sigma_ratio_takes_the_sharper_completion_alone():
    b, s = fuse(np.array([1.0]), np.array([0.05]), np.array([2.0]), np.array([0.10]), rho=0.6)
    assert b[0] == 1.0 and np.isclose(s[0], 0.05)
    b, s = fuse(np.array([1.0]), np.array([0.20]), np.array([2.0]), np.array([0.10]), rho=0.6)
    assert b[0] == 2.0 and np.isclose(s[0], 0.10)


def test_rho_outside_the_open_interval_is_refused():
    import pytest
    with pytest.raises(ValueError, match="rho"):
        fuse(np.ones(1), np.ones(1), np.ones(1), np.ones(1), rho=1.0)
    with pytest.raises(ValueError, match="growth"):
        FusedCompleter(AverageCompleter(3), AverageCompleter(5), growth=(0.01, -1.0))


def test_member_growth_through_a_history_run_shifts_the_weight_to_the_slower_growing_member():
    """Through BeamHistory, a fused completer with growth is handed the run length: at the k-th regressed ping
    each member's sigma is sqrt(s^2 + k d^2) before fusing; a full ping ends the run."""
    from graphnav.estimators.history import BeamHistory

    class Fixed:
        def __init__(self, value, sigma):
            self.value, self.sigma, self.n_past = value, sigma, 3

        def complete(self, past, measured):
            miss = ~np.isfinite(measured)
            return np.where(miss, self.value, measured), np.where(miss, self.sigma, 0.0)

    fused = FusedCompleter(Fixed(1.0, 0.05), Fixed(2.0, 0.05), growth=(0.05, 0.0))
    assert fused.takes_run_steps and fused.drift_std == 0.0
    h = BeamHistory(3)
    for _ in range(3):
        h.push(np.ones(4))
    valid = np.array([True, True, False, True])
    got = [h.complete(fused, np.ones(4), valid) for _ in range(4)]
    for k, (b, s) in enumerate(got):
        expect = fuse(np.array([1.0]), np.array([np.sqrt(0.05 ** 2 + k * 0.05 ** 2)]),
                      np.array([2.0]), np.array([0.05]))
        assert np.isclose(b[2], expect[0][0]) and np.isclose(s[2], expect[1][0])
    assert got[0][0][2] == 1.5 and got[3][0][2] > 1.7      # equal at first, then the non-growing member leads
    h.complete(fused, np.ones(4), np.ones(4, bool))         # a full ping ends the run
    b, _ = h.complete(fused, np.ones(4), valid)
    assert b[2] == 1.5


def test_inverse_variance_weights_with_the_sigma_of_correlated_errors():
    """Weights made as if independent (rho 0) and the sigma with the errors' correlation (sigma_rho 0.8): the
    completion is the inverse-variance one, and the sigma is the RMS that combination reaches (Monte Carlo), where
    rho 0 alone states a sigma 18 % too small."""
    rng = np.random.default_rng(4)
    n, s1, s2, rho = 200000, 0.05, 0.06, 0.8
    e1, e2 = _correlated(rng, n, s1, s2, rho)
    b0, s0 = fuse(e1, np.full(n, s1), e2, np.full(n, s2))
    b, s = fuse(e1, np.full(n, s1), e2, np.full(n, s2), 0.0, sigma_rho=rho)
    np.testing.assert_array_equal(b, b0)
    rms = np.sqrt(np.mean(b ** 2))
    assert abs(rms / s[0] - 1) < 0.01 and rms > 1.15 * s0[0]
    fused = FusedCompleter(AverageCompleter(3), AverageCompleter(5), sigma_rho=rho)
    past = np.random.default_rng(5).normal(1.0, 0.2, (5, 4))
    measured = np.array([0.9, np.nan, 1.1, np.nan])
    expect = fuse(*AverageCompleter(3).complete(past[-3:], measured), *AverageCompleter(5).complete(past, measured),
                  0.0, rho)
    np.testing.assert_array_equal(fused.complete(past, measured)[1], expect[1])
    import pytest
    with pytest.raises(ValueError, match="sigma_rho"):
        FusedCompleter(AverageCompleter(3), AverageCompleter(5), sigma_rho=-1.0)
