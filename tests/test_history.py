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


def _janus():
    """Four beams at 90 deg of azimuth, 30 deg off the vertical: (4, 3) body-frame unit vectors."""
    az = np.deg2rad([45.0, 135.0, 225.0, 315.0])
    return np.column_stack([0.5 * np.cos(az), 0.5 * np.sin(az), np.full(4, np.sqrt(0.75))])


def _run(mode, sway_step: float, valid, seed: int = 0, n: int = 40, step_at: int = 15, scale: float = 1.0):
    """The sigma handed on for beam 1 (missing) through a run where the vehicle's sway steps by ``sway_step``
    (m/s) at ping ``step_at``, beams with 0.042 m/s noise; the average estimator with ``run_sigma = mode`` (and
    ``run_sigma_scale``)."""
    rng = np.random.default_rng(seed)
    T = _janus()
    comp = AverageCompleter(3, noise_std=0.042)
    comp.run_sigma, comp.run_sigma_scale = mode, scale
    h = BeamHistory(3)
    for _ in range(3):
        h.complete(comp, T @ [1.0, 0.0, 0.1] + rng.normal(0, 0.042, 4), np.ones(4, bool))
    out = []
    for k in range(n):
        v = np.array([1.0, sway_step if k >= step_at else 0.0, 0.1])
        out.append(h.complete(comp, T @ v + rng.normal(0, 0.042, 4), valid)[1][0])
    return np.array(out)


def test_measured_change_sigma_follows_a_velocity_change_the_measured_beams_see():
    """With ``run_sigma = "measured-change"`` a steady run keeps the completer's own sigma where the fixed growth
    widens it; a sway step of 0.4 m/s (0.14 m/s along each beam) seen by the two measured beams raises the missing
    beam's sigma to about that within a few pings."""
    valid = np.array([0, 1, 0, 1], bool)
    growth = _run(None, 0.4, valid)
    steady = _run("measured-change", 0.0, valid)
    stepped = _run("measured-change", 0.4, valid)
    assert steady.max() < 0.07 and growth[14] > 0.1                   # steady: near the completer's 0.05
    np.testing.assert_allclose(stepped[:15], steady[:15])
    np.testing.assert_allclose(_run("measured-change", 0.4, valid, scale=2.0), 2 * stepped)
    assert 0.12 < np.median(stepped[22:]) < 0.18                         # the step's 0.14 m/s per beam
    assert stepped[15] < stepped[17] < stepped[22]                       # smoothed over a few pings


def test_measured_change_sigma_keeps_the_growth_in_a_total_outage_and_ends_with_the_run():
    total = np.zeros(4, bool)
    np.testing.assert_allclose(_run("measured-change", 0.4, total), _run(None, 0.4, total))
    rng = np.random.default_rng(1)
    comp = AverageCompleter(3, noise_std=0.042)
    comp.run_sigma = "measured-change"
    h = BeamHistory(3)
    T, valid = _janus(), np.array([0, 1, 1, 1], bool)
    for _ in range(3):
        h.complete(comp, T @ [1.0, 0.0, 0.1], np.ones(4, bool))
    for _ in range(10):
        h.complete(comp, T @ [1.0, 0.5, 0.1] + rng.normal(0, 0.042, 4), valid)
    for _ in range(3):                                                   # the beams return at the new velocity
        h.complete(comp, T @ [1.0, 0.5, 0.1], np.ones(4, bool))
    assert h.complete(comp, T @ [1.0, 0.5, 0.1], valid)[1][0] < 0.06     # a new run starts from its own past


def test_measured_change_sigma_judges_the_pivot_completer_with_its_turn_terms():
    """On a hull turning about its pivot the pivot completer is exact, and the measured beams' change from its
    own held completions (turn terms included) stays at the floor; the average, holding the old sway, is judged
    by the change it misses."""
    from graphnav.nets.pivot import PivotCompleter
    T, n_past, rate = _janus(), 5, 10
    comp = PivotCompleter(T, np.zeros(3), pivot_m=3.0, n_past=n_past, imu_rate_hz=rate, noise_std=0.042)
    average = AverageCompleter(n_past, noise_std=0.042)
    r = np.where(np.arange(60) < 25, 0.0, 0.15)                          # a turn starts in the outage
    beams = (np.array([1.5, 0.0, 0.1]) + np.outer(-3.0 * r, [0.0, 1.0, 0.0])) @ T.T
    omega = np.repeat(np.column_stack([np.zeros(60), np.zeros(60), r]), rate, axis=0)
    valid = np.array([0, 1, 0, 1], bool)
    sigmas = {}
    for name, c in (("pivot", comp), ("average", average)):
        c.run_sigma = "measured-change"
        h = BeamHistory(n_past)
        for k in range(60):
            imu = (np.zeros((comp.imu_samples, 3)), omega[(k + 1) * rate - comp.imu_samples:(k + 1) * rate])
            out = h.complete(c, beams[k], np.ones(4, bool) if k < 20 else valid, imu=imu)
        sigmas[name] = out[1][0]
    assert sigmas["pivot"] < 0.05 and sigmas["average"] > 0.12


def test_an_unknown_run_sigma_or_a_completer_that_cannot_rehearse_is_refused_before_any_ping():
    from graphnav.core.config import SensorConfig
    from graphnav.core.errors import ConfigError
    from graphnav.estimators.keyframes import Keyframer

    class Held:
        n_past = 3
        run_sigma = "measured-change"

        def complete(self, past, measured):
            return np.where(np.isfinite(measured), measured, past.mean(axis=0)), np.full(4, 0.1)
    comp = AverageCompleter(3)
    comp.run_sigma = "measured"
    with pytest.raises(ConfigError, match="run_sigma = 'measured'"):
        Keyframer(SensorConfig(), completer=comp)
    with pytest.raises(ConfigError, match="rehearse"):
        Keyframer(SensorConfig(), completer=Held())
    comp.run_sigma, comp.run_sigma_scale = "measured-change", 0.0
    with pytest.raises(ConfigError, match="run_sigma_scale = 0.0"):
        Keyframer(SensorConfig(), completer=comp)
    del comp.run_sigma_scale
    comp.run_sigma = None                                                # the default, the fixed growth
    Keyframer(SensorConfig(), completer=comp)
