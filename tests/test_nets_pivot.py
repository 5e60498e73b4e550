"""The pivot completer (:mod:`graphnav.nets.pivot`): the average estimator when there is no turn to model, exact on a
hull that turns about its pivot point, its pivot length fitted from measured pings (offline and online, through the
keyframer), and on the Snapir the pivot length from the DVL against the one the reference trajectory gives."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry
from graphnav.core.errors import ConfigError
from graphnav.nets import AverageCompleter
from graphnav.nets.pivot import DEFAULT_AXES, PivotCompleter, PivotFit, fit_pivot_length, ping_rates

RATE_HZ = 100.0
N_PAST = 5


def turning_hull(pivot_m: float, lever_b: np.ndarray, n_pings: int, seed: int, noise: float = 0.0,
                 pitch_pivot_m: float = 0.0):
    """A hull that holds its surge and turns about its pivots (sway ``-L r``, heave ``+L_q q``): (t (K,), rates
    (K, 3) per DVL period, beams (K, 4), IMU rates (K * 100, 3) constant over each period, T_b). Yaw rate changes
    every few pings; the pitch rate is small and changes every ping."""
    rng = np.random.default_rng(seed)
    T_b = DvlGeometry.from_spec(DvlSpec()).T_b
    rates = np.zeros((n_pings, 3))
    r = 0.0
    for k in range(n_pings):
        if k % 7 == 0:
            r = rng.uniform(-0.08, 0.08)
        rates[k] = [rng.normal(0, 0.01), rng.normal(0, 0.01), r]
    v_b = (np.array([1.8, -0.05, 0.02]) + np.outer(-pivot_m * rates[:, 2], [0.0, 1.0, 0.0])
           + np.outer(pitch_pivot_m * rates[:, 1], [0.0, 0.0, 1.0]))
    beams = (v_b + np.cross(rates, lever_b)) @ T_b.T + rng.normal(0.0, noise, (n_pings, 4))
    imu = np.repeat(rates, int(RATE_HZ), axis=0)
    return np.arange(n_pings, dtype=float), rates, beams, imu, T_b


def window(imu_rates: np.ndarray, k: int, samples: int):
    """The IMU window a keyframer hands over for ping ``k`` (its last sample ends ping k's period); None before
    there are ``samples``."""
    if (k + 1) * int(RATE_HZ) < samples:
        return None
    omega = imu_rates[(k + 1) * int(RATE_HZ) - samples:(k + 1) * int(RATE_HZ)]
    return np.zeros_like(omega), omega


def test_without_a_pivot_or_lever_arm_it_is_the_average_estimator():
    rng = np.random.default_rng(3)
    T_b = DvlGeometry.from_spec(DvlSpec()).T_b
    pivot = PivotCompleter(T_b, np.zeros(3), 0.0, n_past=N_PAST)
    average = AverageCompleter(n_past=N_PAST)
    for _ in range(20):
        past = rng.normal(0.5, 0.3, (N_PAST, 4))
        measured = rng.normal(0.5, 0.3, 4)
        measured[rng.choice(4, rng.integers(1, 5), replace=False)] = np.nan
        imu = (np.zeros((pivot.imu_samples, 3)), rng.normal(0, 0.1, (pivot.imu_samples, 3)))
        b_p, s_p = pivot.complete(past, measured, imu=imu)
        b_a, s_a = average.complete(past, measured)
        np.testing.assert_allclose(b_p, b_a, atol=1e-12)
        np.testing.assert_allclose(s_p, s_a, atol=1e-12)
    assert pivot.usage == {"imu": 20, "no_imu": 0, "imu_not_finite": 0}
    # without an IMU window a ping is the average's, counted
    b, s = pivot.complete(past, measured)
    assert np.array_equal(b, average.complete(past, measured)[0]) and pivot.usage["no_imu"] == 1
    # so is a window with a non-finite rate, counted apart
    imu[1][3, 2] = np.nan
    b, s = pivot.complete(past, measured, imu=imu)
    assert np.array_equal(b, average.complete(past, measured)[0]) and pivot.usage["imu_not_finite"] == 1


def test_a_hull_turning_about_its_pivot_is_completed_exactly_where_the_average_holds_the_old_sway():
    lever = np.array([0.6, 0.1, 0.3])
    t, rates, beams, imu, T_b = turning_hull(2.5, lever, 60, seed=1, pitch_pivot_m=1.5)
    completer = PivotCompleter(T_b, lever, 2.5, n_past=N_PAST, pitch_pivot_m=1.5)
    average = AverageCompleter(n_past=N_PAST)
    np.testing.assert_allclose(ping_rates(window(imu, 20, completer.imu_samples)[1], N_PAST + 1, 100),
                               rates[15:21], atol=1e-12)
    worst_average = 0.0
    for k in range(N_PAST, 60):
        measured = beams[k].copy()
        measured[[0, 2, 3]] = np.nan
        got, sigma = completer.complete(beams[k - N_PAST:k], measured, imu=window(imu, k, completer.imu_samples))
        np.testing.assert_allclose(got, beams[k], atol=1e-12)
        assert sigma[1] == 0.0 and np.all(sigma[[0, 2, 3]] > 0)
        worst_average = max(worst_average, np.abs(average.complete(beams[k - N_PAST:k], measured)[0] - beams[k]).max())
    assert worst_average > 0.05       # the turns are there to be modelled
    # without its pitch term the same hull is not completed exactly
    yaw_only = PivotCompleter(T_b, lever, 2.5, n_past=N_PAST)
    measured = beams[30].copy()
    measured[[0, 2, 3]] = np.nan
    got, _ = yaw_only.complete(beams[30 - N_PAST:30], measured, imu=window(imu, 30, yaw_only.imu_samples))
    assert np.abs(got - beams[30]).max() > 1e-3
    with pytest.raises(ConfigError, match="IMU window"):
        completer.complete(beams[:N_PAST], measured, imu=(np.zeros((10, 3)), np.zeros((10, 3))))


def test_the_pivot_length_is_fitted_from_noisy_measured_pings_and_a_gap_starts_a_new_run():
    lever = np.array([0.4, 0.0, 0.2])
    t, rates, beams, imu, T_b = turning_hull(3.0, lever, 400, seed=7, noise=0.02)
    fit = PivotFit(T_b, lever, N_PAST)
    for k in range(400):
        fit.add(t[k], beams[k], rates[k])
    assert fit.length() == pytest.approx(3.0, abs=0.15)
    assert fit.lengths()[1] == pytest.approx(0.0, abs=0.5)       # this hull does not heave as it pitches
    # a hull that does is fitted in both; the yaw-only fit of the same pings leaves its heave out
    t, rates, beams, imu, T_b = turning_hull(3.0, lever, 400, seed=7, noise=0.02, pitch_pivot_m=2.0)
    both, yaw_only = PivotFit(T_b, lever, N_PAST), PivotFit(T_b, lever, N_PAST, axes=("yaw",))
    for k in range(400):
        both.add(t[k], beams[k], rates[k])
        yaw_only.add(t[k], beams[k], rates[k])
    assert both.lengths() == pytest.approx([3.0, 2.0], abs=0.3), both.lengths()
    assert yaw_only.lengths()[1] == 0.0 and yaw_only.length() == pytest.approx(3.0, abs=0.15)
    with pytest.raises(ConfigError, match="axes"):
        PivotFit(T_b, lever, N_PAST, axes=("pitch",))
    # a hull that never pitches: the yaw is still fitted, unshrunk, and the pitch length is 0
    level = PivotFit(T_b, lever, N_PAST)
    level_rates = rates * [1.0, 0.0, 1.0]
    for k in range(400):
        level.add(t[k], beams[k] - (rates[k, 1] * 2.0) * T_b[:, 2], level_rates[k])
    assert level.den[1, 1] == 0.0 and level.lengths()[1] == 0.0
    assert level.lengths()[0] == pytest.approx(3.0, abs=0.15)
    t, rates, beams, imu, T_b = turning_hull(3.0, lever, 400, seed=7, noise=0.02)
    assert fit.pairs == sum(min(30, k - N_PAST + 1) for k in range(N_PAST, 400))
    # pings not one DVL period apart are not held together
    gapped = PivotFit(T_b, lever, N_PAST)
    for k in range(20):
        gapped.add(2.0 * k, beams[k], rates[k])
    assert gapped.pairs == 0 and gapped.length() is None
    # online: the completer learns L from the pings it is shown, then completes with it
    online = PivotCompleter(T_b, lever, None, n_past=N_PAST, prior_turn=0.0)
    assert online.length_m == 0.0     # nothing seen yet: the average
    for k in range(200):
        online.observe(t[k], beams[k], window(imu, k, online.imu_samples))
    assert online.length_m == pytest.approx(3.0, abs=0.2)
    yaw_only = PivotCompleter(T_b, lever, None, n_past=N_PAST, prior_turn=0.0, axes=("yaw",))
    for k in range(200):
        yaw_only.observe(t[k], beams[k], window(imu, k, yaw_only.imu_samples))
    shrunk = PivotCompleter(T_b, lever, None, n_past=N_PAST, prior_turn=yaw_only.fit.den[0, 0], axes=("yaw",))
    for k in range(200):
        shrunk.observe(t[k], beams[k], window(imu, k, shrunk.imu_samples))
    assert shrunk.length_m == pytest.approx(yaw_only.length_m / 2) and shrunk.lengths_m[1] == 0.0
    with pytest.raises(ConfigError, match="prior_turn"):
        PivotCompleter(T_b, lever, None, prior_turn=-1.0)


def test_a_straight_run_with_gyro_noise_does_not_make_a_wild_pivot_and_bad_samples_stay_out_of_the_fit():
    lever = np.array([0.4, 0.0, 0.2])
    t, rates, beams, imu, T_b = turning_hull(0.0, lever, 40, seed=5, noise=0.02)
    rng = np.random.default_rng(5)
    imu = rng.normal(0.0, 1e-3, imu.shape)                  # no turn: the yaw rate is gyro noise
    lengths = {}
    for prior in (0.0, None):
        kwargs = {} if prior is None else {"prior_turn": prior}
        straight = PivotCompleter(T_b, lever, None, n_past=N_PAST, **kwargs)
        for k in range(40):
            straight.observe(t[k], beams[k], window(imu, k, straight.imu_samples))
        lengths[prior] = straight.length_m
    # unshrunk, noise alone gives a pivot of metres; the default shrinkage keeps it near the average's 0
    assert abs(lengths[0.0]) > 1.0 and abs(lengths[None]) < 0.05
    # a fully measured ping with a non-finite beam or rate is counted and left out of the fit
    bad = PivotCompleter(T_b, lever, None, n_past=N_PAST)
    bad_beams = beams.copy()
    bad_beams[20, 1] = np.nan
    bad_imu = imu.copy()
    bad_imu[30 * int(RATE_HZ) + 5, 2] = np.inf
    for k in range(40):
        bad.observe(t[k], bad_beams[k], window(bad_imu, k, bad.imu_samples))
    assert bad.observations_refused == 2 and np.isfinite(bad.lengths_m).all() and np.isfinite(bad.fit.num).all()
    with pytest.raises(ConfigError, match="shape"):
        bad.observe(41.0, 0.5, window(imu, 39, bad.imu_samples))


def test_the_keyframer_shows_the_completer_every_fully_measured_ping_with_its_imu_window():
    from graphnav.core.scenarios import scenario_outage
    from graphnav.estimators.keyframes import Keyframer
    from graphnav.estimators.replay import replay
    from graphnav.nets.imu_window import imu_window_at
    from graphnav.sim.simulate import simulate_mission
    mission = simulate_mission(40.0, "navigation", 1).with_outage(scenario_outage("3-missing", 25.0, 10.0))
    geometry = DvlGeometry.from_spec(mission.config.dvl)

    class Spy(PivotCompleter):
        def __init__(self):
            super().__init__(geometry.T_b, geometry.lever_arm_b, None, n_past=N_PAST)
            self.seen = []

        def observe(self, t, beams, imu=None):
            self.seen.append((t, beams.copy(), imu))
            super().observe(t, beams, imu)

    spy = Spy()
    kfr = Keyframer(mission.config, completer=spy)
    kfr.start(float(mission.imu.t[0]))
    for kind, t, payload in replay(mission, depth=False):
        getattr(kfr, "add_" + kind)(t, *payload)
    kfr.finish()
    full = mission.dvl.valid.all(axis=1)
    assert [s[0] for s in spy.seen] == list(mission.dvl.t[full])
    for t, beams, imu in spy.seen:
        np.testing.assert_array_equal(beams, mission.dvl.beams[mission.dvl.t == t][0])
        want = imu_window_at(mission.imu, t, spy.imu_samples)
        assert (imu is None) == (want is None)
        if imu is not None:
            np.testing.assert_array_equal(imu[1], want[1])
    assert spy.fit.pairs > 100 and spy.usage["imu"] == int((~full).sum())


def test_on_the_snapir_the_pivot_from_the_dvl_agrees_with_the_reference_trajectorys(akit_dir):
    """The reference trajectory is another system's (the A-KIT ground truth): its sway at the IMU against the yaw
    rate, and its heave against the pitch rate, give the pivot lengths without the DVL beams the fit uses."""
    from graphnav.missions import load_akit
    from graphnav.nets.pivot import fit_pivot_lengths, measured_series
    for k in (1, 4):
        mission = load_akit(akit_dir / f"Trajectory{k}")
        from_dvl = fit_pivot_length([mission])
        yaw, pitch = fit_pivot_lengths([mission])
        _, rates, usable = measured_series(mission)
        t = mission.dvl.t
        inside = usable & (t >= mission.gt.t[0]) & (t <= mission.gt.t[-1])
        _, v_n, C_b_n = mission.gt.at(t[inside])
        v_b = np.einsum("kji,kj->ki", C_b_n, v_n)
        from_reference = -np.polyfit(rates[inside, 2], v_b[:, 1], 1)[0]
        pitch_from_reference = np.polyfit(rates[inside, 1], v_b[:, 2], 1)[0]
        assert 2.5 < from_dvl < 4.5, k
        assert from_dvl == pytest.approx(from_reference, abs=0.4), k
        assert yaw == pytest.approx(from_reference, abs=0.4), k
        # the hull heaves as it pitches, about a point as far ahead (3.1-3.4 m)
        assert 2.5 < pitch < 4.5, k
        assert pitch == pytest.approx(pitch_from_reference, abs=0.4), k


def test_graph_hnp_runs_the_pivot_completer_built_for_the_missions_sensors():
    import graphnav
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation import methods
    mission = graphnav.simulate_mission(90.0, seed=2)
    config = copy.deepcopy(mission.config)        # another installation of the DVL
    config.dvl.lever_arm_b = np.array([0.5, 0.0, 0.2])
    completer, described = methods.completer_for("Graph-HNP", "2-missing", config.dvl.beam_noise_std, config)
    # the completer's own hold with 2 missing beams, one ping longer than the average's
    assert isinstance(completer, PivotCompleter) and completer.n_past == 4 and "online" in described
    assert "n_past=4" in described and methods.PIVOT_N_PAST["3-missing"] == 5
    np.testing.assert_array_equal(completer.lever_arm_b, config.dvl.lever_arm_b)
    assert completer.pivot_m is None and completer.prior_turn == methods.PIVOT_PRIOR_TURN
    assert completer.axes == methods.PIVOT_AXES == ("yaw",)
    assert "Graph-HNP" in methods.BENCH_METHODS
    options = methods.estimator_options("Graph-HNP")
    # a total outage screened at each ping; with a beam measured a run screened once, its errors correlated over 10 s
    # with one or two measured, independent with three (each taken out at the next ping that measures three)
    assert options.runs_for(0) == "screen-each" and options.error_tau_for(0) is None
    assert all(options.runs_for(n) == "screen-first" and options.error_tau_for(n) == 10.0 for n in (1, 2))
    assert options.runs_for(3) == "screen-first" and options.error_tau_for(3) is None
    # every hybrid graph method takes its completions out when the beams return
    assert all(methods.estimator_options(m).retire_completions
               for m in ("Graph-HNP", "Graph-HN", "Graph-HN-batch", "Graph-HNI", "Graph-HNI-batch"))
    sol = graphnav.run_method(mission.with_outage(scenario_outage("3-missing", 50.0, 20.0)), "Graph-HNP", "3-missing")
    assert sol.info["completer_usage"] == {"imu": 20, "no_imu": 0, "imu_not_finite": 0}
    assert sol.info["completions_retired"] == sol.info["regressed_screening"]["entered"]
    # the simulated vehicle turns without sideslip: the online fit finds (nearly) no pivot
    assert abs(sol.info["completer_state"]["pivot_length_m"]) < 0.5
    assert np.all(np.isfinite(sol.v_n))


def test_the_commands_report_the_pivot_length_they_fitted(tmp_path, capsys):
    import json

    from graphnav.cli import main
    out = tmp_path / "hnp"
    assert main(["online", "--duration", "90", "--scenario", "3-missing", "--method", "Graph-HNP",
                 "--out", str(out), "--no-progress", "--no-plots"]) == 0
    state = json.loads((out / "summary.json").read_text())["completer_state"]
    assert state["pivot_fit_pairs"] > 100 and abs(state["pivot_length_m"]) < 0.5
    assert "pivot length" in capsys.readouterr().out
    # the post-mission command reports it the same way
    assert main(["smooth", "--duration", "90", "--scenario", "3-missing", "--method", "Graph-HNP",
                 "--out", str(tmp_path / "smooth"), "--no-plots"]) == 0
    smoothed = json.loads((tmp_path / "smooth" / "summary.json").read_text())["completer_state"]
    assert smoothed["pivot_fit_pairs"] > 100 and "pivot length" in capsys.readouterr().out


def test_the_ekf_hybrid_feeds_the_online_fit_through_the_same_keyframer():
    import graphnav
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation import methods
    mission = graphnav.simulate_mission(90.0, seed=3)
    completer, _ = methods.completer_for("Graph-HNP", "3-missing", mission.config.dvl.beam_noise_std, mission.config)
    sol = graphnav.run_method(mission.with_outage(scenario_outage("3-missing", 50.0, 20.0)), "Average-TC",
                              "3-missing", completer=completer)
    assert completer.fit.pairs > 100 and completer.usage == {"imu": 20, "no_imu": 0, "imu_not_finite": 0}
    assert sol.info["completer_state"]["pivot_length_m"] == completer.length_m and np.all(np.isfinite(sol.v_n))


def test_on_a_simulated_hull_with_a_pivot_the_estimator_fits_its_length():
    """The whole path on another hull than the Snapir: the simulator's sideslip in turns (``pivot_m``) and heave in
    pitch (``pitch_pivot_m``), IMU and DVL errors, the lever arm, the keyframer's IMU windows and the shrinkage. Our
    simulator shares the turn model, so this checks the plumbing and the fit, not that real hulls turn this way (the
    A-KIT test does)."""
    import graphnav
    from graphnav.evaluation.methods import pivot_completer
    fitted, pitch = {}, {}
    for pivot_m in (0.0, 3.0):
        mission = graphnav.simulate_mission(600.0, imu_grade="mems", seed=4, pivot_m=pivot_m, pitch_pivot_m=pivot_m)
        v_b = mission.meta["trajectory"].state(mission.dvl.t).v_b
        assert (np.ptp(v_b[:, 1]) > 0.4) == (pivot_m > 0) and (np.ptp(v_b[:, 2]) > 0.3) == (pivot_m > 0)
        sol = graphnav.run_method(mission, "Graph-HNP", "none")
        fitted[pivot_m] = sol.info["completer_state"]["pivot_length_m"]
        assert "pitch_pivot_length_m" not in sol.info["completer_state"]     # Graph-HNP models the yaw alone
        # the completer's own default models the pitch too
        both = pivot_completer("none", mission.config, axes=DEFAULT_AXES)
        state = graphnav.run_method(mission, "Graph-HNP", "none", completer=both).info["completer_state"]
        assert state["pivot_length_m"] == pytest.approx(fitted[pivot_m], abs=0.3)
        pitch[pivot_m] = state["pitch_pivot_length_m"]
    assert abs(fitted[0.0]) < 0.5 and fitted[3.0] == pytest.approx(3.0, abs=0.5)
    assert abs(pitch[0.0]) < 0.5 and pitch[3.0] == pytest.approx(3.0, abs=0.5)


def test_the_other_platforms_study_takes_the_yaw_rate_from_the_heading_and_the_hull_axis_from_the_course():
    """experiments/pivot_other_platforms.py on the shared RiverPro file: the rate stream over a ping's period is the
    heading's change over it (as the gyro's mean would be), the DVL's period is the file's, and the head, mounted with
    its forward axis across the boat, is turned so that the body x axis is the course."""
    import sys
    import warnings
    from pathlib import Path

    from graphnav.core.dvl import DvlGeometry
    from graphnav.io.paths import data_root
    from graphnav.io.pd0 import read_pd0_log
    from graphnav.nets.imu_window import imu_window_at
    from graphnav.nets.pivot import ping_rates
    pytest.importorskip("mhkit.dolfyn", reason="graphnav[pd0] not installed")
    root = data_root()
    path = None if root is None else root / "real-formats" / "pd0" / "RiverPro_test01.PD0"
    if path is None or not path.is_file():
        pytest.skip("shared PD0 file RiverPro_test01.PD0 not found (GRAPHNAV_DATA or ../shared/data)")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    from pivot_other_platforms import RATE_HZ, platform_mission
    mission, period = platform_mission(path)
    assert period == pytest.approx(0.67, abs=0.01) and mission.config.dvl.rate_hz == pytest.approx(1.0 / period)
    np.testing.assert_allclose(mission.config.dvl.C_d_b[:, :2], [[0, -1], [1, 0], [0, 0]], atol=1e-12)
    v_b = mission.dvl.beams[np.all(mission.dvl.valid, axis=1)] @ np.linalg.pinv(
        DvlGeometry.from_spec(mission.config.dvl).T_b).T
    assert np.median(v_b[:, 0]) > 0.5 > abs(np.median(v_b[:, 1]))          # moving along its body x
    k = 100
    t = mission.dvl.t
    window = imu_window_at(mission.imu, t[k], int(round(RATE_HZ * (t[k] - t[k - 1]))))
    assert window is not None
    rate = ping_rates(window[1], 1, len(window[1]))[0, 2]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log = read_pd0_log(path)
    psi = np.unwrap(np.radians(log.attitude_deg[:, 0]))
    assert rate == pytest.approx((psi[k] - psi[k - 1]) / (t[k] - t[k - 1]), rel=0.1, abs=2e-3)
