"""BeamHistory: what goes into the past window, and how sigma grows through a run of filled pings."""
import numpy as np
import pytest
from graphnav.nets import AverageCompleter

from graphnav.estimators.history import BeamHistory


def test_not_ready_until_full_pings_then_completes_and_feeds_back():
    h = BeamHistory(3)
    comp = AverageCompleter(3, sigma=0.05)
    assert h.complete(comp, np.array([1.0, np.nan, 2.0, 3.0]), np.array([1, 0, 1, 1], bool)) is None
    for k in range(3):
        beams, sigma = h.complete(comp, np.array([1.0, 2.0 + k, 3.0, 4.0]), np.ones(4, bool))
        assert np.all(sigma == 0)
    assert h.ready
    beams, sigma = h.complete(comp, np.array([np.nan, 9.0, np.nan, 4.0]), np.array([0, 1, 0, 1], bool))
    np.testing.assert_allclose(beams, [1.0, 9.0, 3.0, 4.0])
    np.testing.assert_allclose(sigma, [0.05, 0.0, 0.05, 0.0])
    np.testing.assert_allclose(h.past()[-1], beams)            # the completion stands in for the past


def test_sigma_grows_like_a_random_walk_through_an_outage_and_resets():
    h = BeamHistory(3, drift_std=0.02)
    comp = AverageCompleter(3, sigma=0.05)
    for _ in range(3):
        h.push(np.ones(4))
    valid = np.array([0, 1, 1, 1], bool)
    sig = [h.complete(comp, np.ones(4), valid)[1][0] for _ in range(10)]
    expected = np.sqrt(0.05 ** 2 + 0.02 ** 2 * np.arange(10))
    np.testing.assert_allclose(sig, expected)
    h.complete(comp, np.ones(4), np.ones(4, bool))              # the beam returns: the run ends
    assert h.complete(comp, np.ones(4), valid)[1][0] == pytest.approx(0.05)


def test_push_rejects_non_finite():
    with pytest.raises(ValueError):
        BeamHistory(2).push([1.0, np.nan, 0.0, 0.0])


def test_completer_drift_std_overrides_the_history_default():
    class Exact(AverageCompleter):
        drift_std = 0.0
    h = BeamHistory(3, drift_std=0.5)
    for _ in range(3):
        h.push(np.ones(4))
    valid = np.array([0, 1, 1, 1], bool)
    sig = [h.complete(Exact(3, sigma=0.05), np.ones(4), valid)[1][0] for _ in range(5)]
    np.testing.assert_allclose(sig, 0.05)


def test_average_completer_drift_std_none_leaves_the_history_default_and_a_value_replaces_it():
    """``AverageCompleter(drift_std=None)`` grows like the history's default; a value (the out-of-fold fit of
    docs/decisions/completers.md) replaces it; a negative one is refused."""
    valid = np.array([0, 1, 1, 1], bool)
    for drift, expected in ((None, 0.02), (0.01, 0.01)):
        h = BeamHistory(3, drift_std=0.02)
        for _ in range(3):
            h.push(np.ones(4))
        comp = AverageCompleter(3, sigma=0.05, drift_std=drift)
        sig = [h.complete(comp, np.ones(4), valid)[1][0] for _ in range(4)]
        np.testing.assert_allclose(sig, np.sqrt(0.05 ** 2 + expected ** 2 * np.arange(4)))
    with pytest.raises(ValueError, match="drift_std"):
        AverageCompleter(3, drift_std=-0.01)
