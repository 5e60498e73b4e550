"""A network completer serves only pasts spaced as it was trained (:mod:`graphnav.nets.dvl_match`): past pings closer
together than the trained DVL period (a DVL pinging faster), or further apart than a few periods, leave the ping to
the average estimator, counted in ``fallbacks["period"]``; the estimators hand each ping's stamps on and warn."""
from __future__ import annotations

import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import PING_PERIOD_TOLERANCE, off_period
from graphnav.estimators.history import BeamHistory
from graphnav.nets import AverageCompleter, load_completer
from graphnav.nets.dvl_match import LONGEST_PAST_INTERVAL_PERIODS, beam_model_record, trained_ping_period_s
from test_nets_dvl_match import turning_past   # a vehicle whose sway and heave change: the network departs


def test_the_bounds_on_a_past_s_intervals():
    assert PING_PERIOD_TOLERANCE == 0.25 and LONGEST_PAST_INTERVAL_PERIODS == 5.0
    assert not off_period([1.0, 1.02, 0.98], 1.0)
    assert not off_period([0.76, 1.24], 1.0)
    assert off_period([1.0, 0.74], 1.0)                     # a DVL pinging 1.35x as fast
    assert off_period([1.0, 1.26], 1.0)                     # by default as many periods too long as too short
    assert not off_period([2.0, 3.0, 5.0], 1.0, longest=5.0)
    assert off_period([1.0, 5.01], 1.0, longest=5.0)
    assert not off_period([0.4, 0.45], 0.4) and off_period([0.2], 0.4)
    for unknown in (None, [1.0, np.nan]):
        with pytest.raises(ValueError, match="finite"):
            off_period(unknown, 1.0)
    # the period a card's network was trained for: its DVL's rate, the default spec's (1 Hz) without one
    assert trained_ping_period_s({}) == 1.0
    faster = dataclasses.replace(DvlSpec(), rate_hz=4.0)
    assert trained_ping_period_s({"data": {"beam_model": beam_model_record(faster)}}) == 0.25


@pytest.mark.parametrize("missing, kept", [("2-missing", [1, 3]), ("3-missing", [1])])
def test_a_network_leaves_a_past_spaced_otherwise_to_the_average(missing, kept):
    net = load_completer(missing)
    n = net.n_past
    past = turning_past(n)
    measured = np.full(4, np.nan)
    measured[kept] = past[-1, kept] + 0.01
    average = AverageCompleter(n).complete(past, measured)
    own = net.complete(past, measured)                      # no stamps: nothing to check
    assert not np.allclose(own[0], average[0])
    before = dict(net.fallbacks)
    for spacing in ([1.0] * n, [1.0, 2.0, 3.0, 5.0, 1.0][-n:], [0.9] * n):  # as trained, missed pings, jitter
        np.testing.assert_array_equal(net.complete(past, measured, past_dt_s=np.array(spacing))[0], own[0])
    for spacing in ([0.2] * n, [1.0] * (n - 1) + [0.5], [1.0] * (n - 1) + [10.0]):   # 5 Hz, one fast, a long gap
        np.testing.assert_array_equal(net.complete(past, measured, past_dt_s=np.array(spacing)), average)
    assert net.fallbacks["period"] == before["period"] + 3
    assert {k: v for k, v in net.fallbacks.items() if k != "period"} == \
        {k: v for k, v in before.items() if k != "period"}


def test_the_history_hands_on_its_pings_intervals_through_the_auto_completer():
    """BeamHistory keeps each ping's stamp; the auto completer cuts the intervals to the serving network's window."""
    auto = load_completer("auto")
    history = BeamHistory(auto.n_past)
    past = turning_past(auto.n_past)
    stamps = [0.0, 0.2, 0.4, 0.6, 0.8]                      # a DVL pinging at 5 Hz
    for t, beams in zip(stamps, past):
        history.complete(auto, beams, np.ones(4, bool), t=t)
    np.testing.assert_allclose(history.past_dt(1.0), [0.2] * 5)
    assert history.past_dt(None) is None
    two = past[-1] + 0.01
    before = auto.fallbacks["period"]
    full, _ = history.complete(auto, np.where(np.isfinite(two), two, 0.0), np.array([False, True, False, True]),
                               t=1.0)
    assert auto.fallbacks["period"] == before + 1
    np.testing.assert_allclose(full, AverageCompleter(3).complete(past[-3:], np.where([0, 1, 0, 1], two, np.nan))[0])
    unstamped = BeamHistory(3)
    unstamped.push(past[0])
    unstamped.push(past[1], 1.0)
    assert unstamped.past_dt(2.0) is None                  # a stamp not known: nothing to check


def test_the_keyframer_stamps_beam_and_velocity_pings_alike():
    """A velocity ping (a DVL-frame velocity the instrument solved itself) enters the completer's history as a measured
    ping with its stamp, so that the pings after it are checked as any."""
    from graphnav.estimators.keyframes import Keyframer
    from graphnav.sim.simulate import default_config
    auto = load_completer("auto")
    kfr = Keyframer(default_config(), completer=auto)
    kfr.start(0.0)
    past = turning_past(auto.n_past)
    for k in range(1, 1101):                                # 11 s of IMU at 100 Hz, at rest
        t = k / 100.0
        if k % 100 == 0 and t <= 5.0:
            kfr.add_dvl(t, past[k // 100 - 1], np.ones(4, bool))
        if k == 600:
            kfr.add_dvl_velocity(6.0, np.array([1.5, 0.1, 0.05]), np.full(3, np.nan))
        kfr.add_imu(t, (0.0, 0.0, -9.81), (0.0, 0.0, 0.0))
    assert kfr.stats.velocity_pings == 1
    np.testing.assert_allclose(kfr.history.past_dt(7.0), [1.0] * auto.n_past)   # beams at 2-5 s, velocity at 6 s


def test_the_imu_aware_network_takes_no_interval_but_its_own():
    """It propagates each past ping over one period: an interval of 2 periods (which a beam-only network still takes)
    leaves the ping to the average."""
    from graphnav.nets import load_imu_completer
    net = load_imu_completer(2)
    past = turning_past(net.n_past)
    two = past[-1] + 0.01
    two[[0, 2]] = np.nan
    imu = (np.tile([0.0, 0.0, -9.8], (net.imu_samples, 1)), np.zeros((net.imu_samples, 3)))
    own = net.complete(past, two, imu=imu, past_dt_s=np.ones(net.n_past))
    before = net.fallbacks["period"]
    spaced = net.complete(past, two, imu=imu, past_dt_s=np.r_[np.ones(net.n_past - 1), 2.0])
    assert net.fallbacks["period"] == before + 1
    np.testing.assert_array_equal(spaced, net.fallback.complete(past[-net.fallback.n_past:], two))
    assert not np.allclose(own[0], spaced[0])


class WithoutStamps:
    """A completer as it ran before the past's intervals were checked: everything but ``takes_past_dt``."""

    takes_past_dt = False

    def __init__(self, completer):
        self._completer = completer

    def __getattr__(self, name):
        return getattr(self._completer, name)


def test_an_estimator_on_a_dvl_pinging_faster_completes_with_the_average_and_says_so():
    """HNTC (the paper's hybrid EKF, network completer; its screening of regressed beams off, so that every completion
    reaches the filter) on a simulated MEMS mission whose DVL pings at 4 Hz: without the stamps (as it ran before) it
    is not Average-TC; with them every regressed ping is counted in ``completer_fallbacks["period"]``, the keyframer
    warns once, and it is Average-TC to the bit. At 1 Hz nothing is counted or said."""
    from graphnav.evaluation import faults
    from graphnav.evaluation.methods import network_completer, run_method
    from graphnav.sim.simulate import default_config, simulate_mission
    unscreened = {"screening.correlation": 0.0, "screening.adaptive": False}
    config = default_config()
    config = dataclasses.replace(config, dvl=dataclasses.replace(config.dvl, rate_hz=4.0))
    run = simulate_mission(120.0, "mems", seed=1, config=config).with_outage(faults.Outage(60.0, 30.0, (0, 2, 3)))
    average = run_method(run, "Average-TC", "3-missing", options=unscreened)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        unstamped = run_method(run, "HNTC", "3-missing", options=unscreened,
                               completer=WithoutStamps(network_completer("3-missing")[0]))
    assert np.abs(unstamped.v_n - average.v_n).max() > 1e-3
    said = r"intervals of its past pings \(the newest one's to the ping\) are 0.25, .*completer_fallbacks\['period'\]"
    with (pytest.warns(RuntimeWarning, match=said),
          pytest.warns(RuntimeWarning, match="120 for past pings not spaced as it was trained for")):
        hybrid = run_method(run, "HNTC", "3-missing", options=unscreened)
    assert hybrid.info["completer_fallbacks"]["period"] == 120            # a 30 s outage at 4 Hz
    np.testing.assert_array_equal(hybrid.v_n, average.v_n)
    one_hz = simulate_mission(120.0, "mems", seed=1).with_outage(faults.Outage(60.0, 30.0, (0, 2, 3)))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        counts = run_method(one_hz, "HNTC", "3-missing", options=unscreened).info["completer_fallbacks"]
    assert counts == {"envelope": 0, "pattern": 0, "dvl": 0, "period": 0}


def test_the_ping_rate_study_reports_bound_rows():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    import network_on_other_dvl as study
    rows = study.ping_rate_rows([5.0], duration_s=120.0)
    assert len(rows) == 2 and all(r.startswith("| simulated, 5 Hz |") for r in rows)
    assert all("| 1.00 / 1.00 | 100 % | - |" in r for r in rows)           # bound: every ping the average's


def test_online_on_a_dvl_pinging_faster_says_it_once_and_counts_it(tmp_path, capsys):
    """`graphnav online` aligning from the sensors on a simulated DVL pinging at 4 Hz: one warning in the whole run
    (not one a ping), and the summary counts the run's pings under "period" and prints them."""
    import json

    from graphnav.cli import main
    config = tmp_path / "fast.json"
    config.write_text(json.dumps({"dvl": {"rate_hz": 4.0}}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["online", "--duration", "200", "--config", str(config), "--scenario", "3-missing",
                     "--method", "HNTC", "--init", "sensors", "--out", str(tmp_path / "out"), "--no-plots"]) == 0
    said = [w for w in caught if "completer_fallbacks['period']" in str(w.message)]
    assert len(said) == 1
    counts = json.loads((tmp_path / "out" / "summary.json").read_text())["completer_fallbacks"]
    assert counts["period"] > 0 and counts["dvl"] == 0
    assert f"{counts['period']} for past pings not spaced as it was trained for" in capsys.readouterr().out
