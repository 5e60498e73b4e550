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
