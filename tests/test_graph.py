"""Factor-graph estimators on simulated missions: consistency, outages, batch, gaps, recovery, API."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from graphnav.nets import AverageCompleter

from graphnav.core.config import DvlSpec, SensorConfig
from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import Outage, scenario_outage
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.graph.builder import GraphContext, mission_keyframes
from graphnav.estimators.keyframes import KeyframeOptions, Keyframer
from graphnav.estimators.runs import iterate_graph, run_graph
from graphnav.evaluation.metrics import nees_velocity, vrmse
from graphnav.sim.simulate import DEFAULT_LEVER_ARM_B, simulate_mission

NO_SYSTEMATIC_DVL = SensorConfig(dvl=DvlSpec(beam_bias=np.zeros(4), scale_factor=np.zeros(3),
                                             lever_arm_b=DEFAULT_LEVER_ARM_B))


@pytest.fixture(scope="module")
def steady_missions():
    """200 s, navigation-grade IMU, DVL without beam bias / scale error (white noise only)."""
    return [simulate_mission(200, seed=s, config=NO_SYSTEMATIC_DVL) for s in (0, 1)]


@pytest.fixture(scope="module")
def tactical_mission():
    return simulate_mission(160, imu_grade="tactical", seed=0)


@pytest.fixture(scope="module")
def nav_mission():
    return simulate_mission(160, seed=0)


def streamed_keyframes(imu_t, dvl_t, options=None, keyframer=None):
    """Keyframes of a stream of IMU stamps and DVL pings (all beams valid), in time order, no look-ahead, through
    ``keyframer`` (default a new one)."""
    k = keyframer or Keyframer(SensorConfig(), options)
    events = sorted([(t, 1, "dvl") for t in dvl_t] + [(t, 2, "imu") for t in imu_t])
    out = k.start(float(dvl_t[0]))
    for t, _, kind in events:
        if kind == "imu":
            out += k.add_imu(t, (0.0, 0.0, -9.8), (0.0, 0.0, 0.0))
        else:
            out += k.add_dvl(t, np.ones(4), np.ones(4, bool))
    return out + k.finish()


def test_keyframes_fill_dvl_gaps_without_look_ahead():
    imu_t = np.round(np.arange(0, 20.001, 0.01), 10)
    dvl_t = np.r_[np.arange(0.5, 5.0, 1.0), np.arange(12.5, 20.0, 1.0)]
    kfs = streamed_keyframes(imu_t, dvl_t, KeyframeOptions(max_keyframe_gap_s=2.0, imu_keyframe_interval_s=1.0))
    times = np.array([k.t for k in kfs])
    assert np.all(np.diff(times) > 0)
    assert np.all(np.diff(times) <= 2.0 + 1e-9)
    np.testing.assert_array_equal(times[[k.kind == "dvl" for k in kfs]], dvl_t)
    fill = times[[k.kind == "imu" for k in kfs]]
    np.testing.assert_allclose(fill, [5.5, 6.5, 7.5, 8.5, 9.5, 10.5, 11.5])
    # IMU-only keyframes also run up to half an interval before the end of the IMU data
    kfs = streamed_keyframes(imu_t, dvl_t[:3])
    np.testing.assert_allclose([k.t for k in kfs if k.kind == "imu"], np.arange(3.5, 19.6, 1.0))


def test_pings_after_the_imu_ends_are_warned_about_once_with_their_count_and_time():
    """Pings no IMU sample follows were dropped and counted (``pings_after_end``) without a word; now one warning names
    the stream, how many and how long after the IMU's end. A last ping within the span tolerance (a recording's usual
    end, 6-75 ms on the A-KIT trajectories) is counted quietly, as a mission drops it."""
    imu_t = np.round(np.arange(0, 20.001, 0.01), 10)
    k = Keyframer(SensorConfig())
    with pytest.warns(RuntimeWarning, match=r"^dvl: 5 ping\(s\) after the IMU's last sample at t = 20\.000 s \(the "
                                            r"last 4\.500 s after it\) dropped") as caught:
        streamed_keyframes(imu_t, np.arange(0.5, 25.0, 1.0), keyframer=k)
    assert k.stats.pings_after_end == 5
    assert len([w for w in caught if "after the IMU's last sample" in str(w.message)]) == 1
    k = Keyframer(SensorConfig())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        streamed_keyframes(imu_t, np.r_[np.arange(0.5, 20.0, 1.0), 20.05], keyframer=k)
    assert k.stats.pings_after_end == 1


def test_a_replayed_missions_pings_after_the_imu_ends_are_warned_about_once_by_the_mission():
    """A recorded mission's pings after the IMU's end are warned about and counted when it is built
    (``Mission.validate``, the count in summary.json); the replay's keyframer dropped them with a second warning naming
    a count not shown."""
    m = simulate_mission(20, seed=3)
    late = dataclasses.replace(m.dvl, t=m.dvl.t + 2.0)
    with pytest.warns(RuntimeWarning) as caught:
        mission = dataclasses.replace(m, dvl=late)
        list(mission_keyframes(mission, GraphOptions()))
        run_graph(mission, init="gt")
    said = [str(w.message) for w in caught if "ping(s)" in str(w.message)]
    assert len(said) == 1 and "outside the IMU span" in said[0], said


def test_split_preintegration_matches_truth_between_imu_samples():
    """Keyframes off the IMU grid: preintegrating the split intervals predicts the exact state."""
    m = simulate_mission(30, seed=3, noiseless=True)
    shifted = dataclasses.replace(m.dvl, t=m.dvl.t + 0.0037)
    kfs = list(mission_keyframes(dataclasses.replace(m, dvl=shifted), GraphOptions()))
    times = np.array([kf.t for kf in kfs])
    np.testing.assert_allclose(times, shifted.t[shifted.t <= m.imu.t[-1]])
    traj = m.meta["trajectory"]
    import gtsam
    checked = 0
    states = traj.state(times)
    p_n = traj.position_n(np.r_[0.0, times])[1:]
    ctx = GraphContext(m.config, GraphOptions())
    for kf in kfs:
        if kf.pim is None:
            continue
        k = kf.index
        ctx.set_gravity(kf, p_n[k - 1], states.v_n[k - 1])      # the gravity of the true position
        start = gtsam.NavState(gtsam.Rot3(states.C_b_n[k - 1]), p_n[k - 1], states.v_n[k - 1])
        pred = kf.pim.predict(start, gtsam.imuBias.ConstantBias())
        assert abs(kf.pim.deltaTij() - (times[k] - times[k - 1])) < 1e-9
        np.testing.assert_allclose(pred.velocity(), states.v_n[k], atol=2e-5)
        np.testing.assert_allclose(pred.attitude().matrix(), states.C_b_n[k], atol=1e-6)
        checked += 1
    assert checked == len(kfs) - 1


def test_noiseless_mission_recovers_truth():
    m = simulate_mission(60, seed=2, noiseless=True)
    sol = run_graph(m)
    assert vrmse(sol, m.gt) < 5e-4


@pytest.mark.parametrize("backend", ["isam2", "fixed-lag"])
def test_all_beams_filtered_velocity_is_consistent(steady_missions, backend):
    """Mean NEES of the filtered velocity in a loose band around 3 and VRMSE below one beam's noise."""
    for m in steady_missions:
        sol = run_graph(m, backend=backend)
        nees = nees_velocity(sol, m.gt, t_start=20.0)
        assert 1.5 < nees.mean() < 5.0, nees.mean()
        assert vrmse(sol, m.gt) < m.config.dvl.beam_noise_std
        assert len(sol) == len(m.dvl.t)
        assert sol.cov_v_n.shape == (len(sol), 3, 3)


def test_fixed_lag_filtered_output_equals_isam2(steady_missions):
    m = steady_missions[0]
    a = run_graph(m, backend="isam2")
    b = run_graph(m, backend="fixed-lag", options=GraphOptions(lag_s=10.0))
    np.testing.assert_allclose(a.v_n, b.v_n, atol=2e-4)
    # with the DVL error states (default) the marginalised D(k) prior moves the off-diagonal velocity
    # covariance by ~1e-7 (m/s)^2, 5e-5 of the diagonal (2e-3)
    np.testing.assert_allclose(a.cov_v_n, b.cov_v_n, rtol=0.05, atol=1e-6)


def test_per_beam_and_per_epoch_factors_agree(steady_missions):
    m = steady_missions[1].slice(0, 60)
    a = run_graph(m, options=GraphOptions(beam_factor_mode="epoch"))
    b = run_graph(m, options=GraphOptions(beam_factor_mode="beam"))
    np.testing.assert_allclose(a.v_n, b.v_n, atol=1e-8)


@pytest.mark.parametrize("scenario, n_past", [("2-missing", 3), ("3-missing", 5)])
def test_outage_hn_beats_tc_and_batch_beats_filter(tactical_mission, scenario, n_past):
    """30 s partial outage on a steady leg, tactical IMU (a navigation-grade IMU coasts through 30 s so
    well that the average estimator's stale beams help only sometimes; see the final report)."""
    m = tactical_mission.with_outage(scenario_outage(scenario, 100.0, 30.0))
    completer = AverageCompleter(n_past)
    tc = run_graph(m)
    hn = run_graph(m, completer=completer)
    batch = run_graph(m, batch=True, completer=completer)
    window = dict(t_start=100.0, t_end=130.0)
    assert hn.info["n_regressed"].sum() > 0
    assert vrmse(hn, m.gt, **window) < 0.8 * vrmse(tc, m.gt, **window)
    assert vrmse(batch, m.gt, **window) <= vrmse(hn, m.gt, **window)
    assert vrmse(batch, m.gt) <= vrmse(hn, m.gt)


class OracleCompleter:
    """Fills missing beams with the true (error-free) beams plus seeded noise of known sigma."""

    drift_std = 0.0       # its errors do not compound through an outage (BeamHistory)

    def __init__(self, mission, sigma=0.03, seed=0):
        self.n_past = 3
        self.sigma = sigma
        rng = np.random.default_rng(seed)
        traj = mission.meta["trajectory"]
        from graphnav.core.dvl import DvlGeometry
        geo = DvlGeometry.from_spec(mission.config.dvl)
        state = traj.state(mission.dvl.t)
        clean = geo.beams_from_velocity(state.v_b, state.omega_nb_b)
        noisy = clean + rng.normal(0, sigma, clean.shape)
        # look a ping up by its measured beams (unique floats)
        self._by_measured = {}
        for j in range(len(mission.dvl.t)):
            valid = mission.dvl.valid[j]
            self._by_measured[tuple(np.round(mission.dvl.beams[j][valid], 12))] = noisy[j]

    def complete(self, past, measured):
        valid = np.isfinite(measured)
        truth = self._by_measured[tuple(np.round(measured[valid], 12))]
        return np.where(valid, measured, truth), np.where(valid, 0.0, self.sigma)


@pytest.mark.parametrize("scenario", ["2-missing", "3-missing"])
def test_accurate_regressed_beams_help_navigation_grade(nav_mission, scenario):
    """With accurate regressed beams (true beams + 0.03 m/s noise) Graph-HN beats Graph-TC and comes back to
    the all-beams accuracy (the floor set by the DVL bias and scale errors of the measured beams)."""
    m = nav_mission.with_outage(scenario_outage(scenario, 100.0, 30.0))
    tc = run_graph(m)
    hn = run_graph(m, completer=OracleCompleter(m))
    full = run_graph(nav_mission)
    window = dict(t_start=100.0, t_end=130.0)
    assert vrmse(hn, m.gt, **window) < 0.9 * vrmse(tc, m.gt, **window)
    assert vrmse(hn, m.gt, **window) < 1.15 * vrmse(full, m.gt, **window)


def test_batch_vectorized_equals_gtsam_lm(nav_mission):
    """The O(N) vectorised Gauss-Newton batch equals GTSAM's LM on the CustomFactor graph (with Huber)."""
    m = nav_mission.slice(0, 80).with_outage(scenario_outage("2-missing", 40.0, 20.0))
    opts = dict(huber_regressed_k=1.0)
    a = run_graph(m, batch=True, completer=AverageCompleter(3), options=GraphOptions(**opts))
    b = run_graph(m, batch=True, completer=AverageCompleter(3),
                  options=GraphOptions(batch_solver="lm", **opts))
    np.testing.assert_allclose(a.v_n, b.v_n, atol=1e-6)
    np.testing.assert_allclose(a.cov_v_n, b.cov_v_n, rtol=1e-4, atol=1e-12)
    assert a.info["batch_costs"][-1] <= a.info["batch_costs"][0]


def test_imu_only_gaps_do_not_crash(nav_mission):
    """60 s with every beam invalid, and 60 s with no DVL ping at all (IMU-only keyframes)."""
    m = nav_mission
    invalid = m.with_outage(Outage(60.0, 60.0, (0, 1, 2, 3)))
    keep = (m.dvl.t < 60.0) | (m.dvl.t >= 120.0)
    silent = dataclasses.replace(m, dvl=m.dvl.take(keep))
    for mission in (invalid, silent):
        for completer, batch, backend in [(None, False, "isam2"), (AverageCompleter(3), True, "fixed-lag")]:
            sol = run_graph(mission, completer=completer, batch=batch, backend=backend)
            assert np.all(np.isfinite(sol.v_n)) and np.all(np.isfinite(sol.cov_v_n))
            assert vrmse(sol, m.gt) < 0.5
    sol = run_graph(silent)
    kinds = np.array(sol.info["kind"])
    assert (kinds == "imu").sum() >= 55
    # the velocity uncertainty grows during the gap and shrinks after it (x2.0 with the DVL error states,
    # whose bias uncertainty is in the velocity's before the gap too; x2.4 without)
    sd = np.sqrt(np.trace(sol.cov_v_n, axis1=1, axis2=2))
    before, end_gap, after = (np.interp(t, sol.t, sd) for t in (59.0, 119.5, 150.0))
    assert end_gap > 1.7 * before and after < end_gap


def test_indeterminant_system_is_recovered_with_qr(nav_mission):
    """Cholesky with a 1e-8 integration covariance hits IndeterminantLinearSystem: the estimator warns,
    restarts with QR and matches a QR run from the start."""
    m = nav_mission.slice(0, 40)
    bad = GraphOptions(integration_sigma=1e-4, factorization="CHOLESKY")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = run_graph(m, options=bad)
    assert sol.info["recovered"] >= 1
    assert any("indeterminant" in str(w.message) for w in caught)
    ref = run_graph(m, options=dataclasses.replace(bad, factorization="QR"))
    assert vrmse(sol, m.gt) < 1.2 * vrmse(ref, m.gt) + 1e-3


def test_callback_iterator_and_errors(nav_mission):
    m = nav_mission.slice(0, 20)
    seen = []
    sol = run_graph(m, callback=seen.append)
    assert [e.index for e in seen] == list(range(len(sol)))
    streamed = list(iterate_graph(m))
    np.testing.assert_allclose([e.v_n for e in streamed], sol.v_n)
    assert sol.info["update_s"] and sol.runtime_s > 0
    with pytest.raises(TypeError):
        run_graph(m, "Graph-TC")
    assert sol.method == "Graph-TC" and run_graph(m, name="mine").method == "mine"
    with pytest.raises(ConfigError):
        run_graph(m, backend="sideways")
    with pytest.raises(ConfigError):
        GraphOptions(beam_factor_mode="per-ping")


@pytest.fixture(scope="module")
def biased_missions():
    """200 s, navigation IMU, beams with the default bias (0.01 m/s) and scale error (0.7 %)."""
    missions = [simulate_mission(200, seed=s) for s in range(4)]
    assert np.all(missions[0].config.dvl.beam_bias != 0) and np.all(missions[0].config.dvl.scale_factor != 0)
    return missions


@pytest.mark.parametrize("backend", ["isam2", "fixed-lag"])
def test_dvl_error_states_make_biased_beams_consistent(biased_missions, backend):
    """With beam bias and scale in the data, the DVL error states keep the filtered NEES (mean over four
    missions: one mission's mean is dominated by a few slow error excursions) in its band and estimate the
    common beam bias (observable through the depth factor)."""
    opts = GraphOptions(dvl_error_states=True, lag_s=10.0)
    nees, bias, err = [], [], []
    for m in biased_missions:
        seen = []
        sol = run_graph(m, backend=backend, options=opts, callback=seen.append)
        nees.append(nees_velocity(sol, m.gt, t_start=20.0).mean())
        err.append(vrmse(sol, m.gt))
        d = seen[-2].dvl_errors          # D(k) is read back when keyframe k + 1 is added
        assert d.shape == (7,)
        bias.append(d[3:].mean())
    assert 1.5 < np.mean(nees) < 4.5, nees
    assert np.mean(err) < biased_missions[0].config.dvl.beam_noise_std, err
    assert abs(np.mean(bias) - 0.01) < 0.004, bias


def test_dvl_error_states_batch_and_recovery(biased_missions):
    """Vectorised batch with the D(k) columns equals GTSAM's LM; the QR restart carries D(k)."""
    m = biased_missions[0].slice(0, 60).with_outage(scenario_outage("2-missing", 30.0, 15.0))
    opts = GraphOptions(dvl_error_states=True)
    a = run_graph(m, batch=True, completer=AverageCompleter(3), options=opts)
    b = run_graph(m, batch=True, completer=AverageCompleter(3),
                  options=dataclasses.replace(opts, batch_solver="lm"))
    np.testing.assert_allclose(a.v_n, b.v_n, atol=1e-6)
    np.testing.assert_allclose(a.cov_v_n, b.cov_v_n, rtol=1e-4, atol=1e-12)
    assert a.info["batch_dvl_errors"].shape == (len(a), 7)
    bad = dataclasses.replace(opts, integration_sigma=1e-4, factorization="CHOLESKY")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sol = run_graph(m.slice(0, 40), options=bad)
    ref = run_graph(m.slice(0, 40), options=dataclasses.replace(bad, factorization="QR"))
    assert sol.info["recovered"] >= 1
    assert vrmse(sol, m.gt) < 1.2 * vrmse(ref, m.gt) + 1e-3


def test_dvl_error_states_only_on_measured_beams_batch_equals_lm(biased_missions):
    """Regressed beams without the DVL error states (mixed rows in one keyframe) in the vectorised batch."""
    m = biased_missions[1].slice(0, 40).with_outage(scenario_outage("2-missing", 20.0, 10.0))
    opts = GraphOptions(dvl_error_states=True, dvl_errors_on_regressed=False)
    a = run_graph(m, batch=True, completer=AverageCompleter(3), options=opts)
    b = run_graph(m, batch=True, completer=AverageCompleter(3),
                  options=dataclasses.replace(opts, batch_solver="lm"))
    np.testing.assert_allclose(a.v_n, b.v_n, atol=1e-6)
    np.testing.assert_allclose(a.cov_v_n, b.cov_v_n, rtol=1e-4, atol=1e-12)


class SerialOracleCompleter(OracleCompleter):
    """True beams plus a first-order Gauss-Markov error per beam (sigma, correlation time tau pings), as a
    completer's errors through an outage: off by about the same amount for many pings together."""

    def __init__(self, mission, sigma=0.1, tau=20.0, seed=0):
        super().__init__(mission, sigma=0.0, seed=seed)
        rng = np.random.default_rng(seed)
        phi = np.exp(-1.0 / tau)
        e = np.zeros((len(mission.dvl.t), 4))
        e[0] = rng.normal(0, sigma, 4)
        for j in range(1, len(e)):
            e[j] = phi * e[j - 1] + np.sqrt(1 - phi ** 2) * rng.normal(0, sigma, 4)
        self._by_measured = {key: truth + e[j] for j, (key, truth) in enumerate(self._by_measured.items())}
        self.sigma = sigma


def test_regressed_error_correlation_chains_regressed_beams(tactical_mission):
    """With regressed_error_tau_s, a beam regressed at consecutive keyframes enters after its first ping as a
    whitened difference (counted, not screened): serially correlated completions then no longer pull the
    estimate as if each ping were new information, and the vectorised batch still equals GTSAM's LM."""
    m = tactical_mission.with_outage(scenario_outage("3-missing", 60.0, 60.0))
    comp = SerialOracleCompleter(m)
    window = dict(t_start=60.0, t_end=120.0)
    plain = run_graph(m, completer=comp)
    first = GraphOptions(regressed_runs="screen-first")
    chained = run_graph(m, completer=comp, options=dataclasses.replace(first, regressed_error_tau_s=20.0))
    n_regressed = int(chained.info["n_regressed"].sum())
    assert n_regressed == 3 * 60 and plain.info["regressed_screening"]["continued"] == 0
    assert chained.info["regressed_screening"]["continued"] == n_regressed - 3    # all but each beam's first ping
    e_plain, e_chained = vrmse(plain, m.gt, **window), vrmse(chained, m.gt, **window)
    assert e_chained < 0.8 * e_plain
    assert nees_velocity(chained, m.gt, **window).mean() < nees_velocity(plain, m.gt, **window).mean()
    # the fixed-lag smoother, restarted from its marginals inside the outage, holds the keyframe before each
    # difference: its filtered output follows ISAM2's
    lag = run_graph(m, completer=comp, backend="fixed-lag",
                    options=dataclasses.replace(first, regressed_error_tau_s=20.0, lag_s=10.0, reanchor_interval_s=25.0))
    assert lag.info["reanchored"] >= 2 and lag.info["regressed_screening"]["continued"] == n_regressed - 3
    assert np.abs(lag.v_n - chained.v_n).max() < 0.01 and vrmse(lag, m.gt, **window) < 1.1 * e_chained
    short = m.slice(0, 90)
    opts = dataclasses.replace(first, regressed_error_tau_s=20.0, huber_regressed_k=1.0)
    a = run_graph(short, batch=True, completer=comp, options=opts)
    b = run_graph(short, batch=True, completer=comp, options=dataclasses.replace(opts, batch_solver="lm"))
    np.testing.assert_allclose(a.v_n, b.v_n, atol=1e-6)
    assert a.info["regressed_screening"]["continued"] > 0
    for bad in ({"regressed_error_tau_s": 0.0, "regressed_runs": "screen-first"}, {"regressed_error_tau_s": 20.0},
                {"regressed_runs": "screen-all"}, {"regressed_error_tau_s": True, "regressed_runs": "screen-first"}):
        with pytest.raises(ConfigError):
            GraphOptions(**bad)


def test_regressed_error_correlation_by_measured_beams(tactical_mission):
    """A mapping of correlation times serves each ping by its number of measured beams: with 3 missing beams (one
    measured) ``{1: 20}`` is the scalar 20 s, and a mapping that names only other counts is independent errors."""
    m = tactical_mission.slice(0, 80).with_outage(scenario_outage("3-missing", 30.0, 40.0))
    comp = SerialOracleCompleter(m)
    first = GraphOptions(regressed_runs="screen-first")
    runs = {tau if not isinstance(tau, dict) else str(tau):
            run_graph(m, completer=comp, options=dataclasses.replace(first, regressed_error_tau_s=tau))
            for tau in (20.0, {1: 20.0, 2: None, 0: 3.0}, None, {0: 20.0, 2: 20.0})}
    assert np.abs(runs[20.0].v_n - runs[None].v_n).max() > 1e-3          # the correlation time changes the run
    np.testing.assert_array_equal(runs[str({1: 20.0, 2: None, 0: 3.0})].v_n, runs[20.0].v_n)
    np.testing.assert_array_equal(runs[str({0: 20.0, 2: 20.0})].v_n, runs[None].v_n)
    # as a configuration file gives it: keys as digits
    from_file = GraphOptions(regressed_runs="screen-first", regressed_error_tau_s={"0": 3.0, "1": None, "2": 10.0})
    assert from_file.regressed_error_tau_s == {0: 3.0, 1: None, 2: 10.0} and from_file.models_run_errors
    assert [from_file.error_tau_for(n) for n in range(4)] == [3.0, None, 10.0, None]
    assert not GraphOptions(regressed_error_tau_s={1: None}).models_run_errors   # nothing modelled: screen-each is fine
    for bad in ({1: 0.0}, {-1: 3.0}, {"one": 3.0}, {True: 3.0}, {1: float("inf")}, {2: 10.0, 1: "3"}, {1: 3.0, "1": 5.0}):
        with pytest.raises(ConfigError, match="regressed_error_tau_s"):
            GraphOptions(regressed_runs="screen-first", regressed_error_tau_s=bad)
    with pytest.raises(ConfigError, match="screen-first"):
        GraphOptions(regressed_error_tau_s={1: 3.0})


def test_regressed_runs_by_measured_beams(tactical_mission):
    """A mapping of run settings serves each ping by its number of measured beams: with 3 missing beams (one
    measured) ``{1: "screen-first"}`` is the plain "screen-first", and one that names only other counts screens each
    ping; a correlation time needs "screen-first" at every count it models."""
    from graphnav.estimators.options import RegressedScreeningOptions
    m = tactical_mission.slice(0, 80).with_outage(scenario_outage("3-missing", 30.0, 40.0))
    comp = SerialOracleCompleter(m, sigma=0.05)
    screening = RegressedScreeningOptions(correlation=0.5, adaptive=True)
    runs = {str(r): run_graph(m, completer=comp, options=GraphOptions(screening=screening, regressed_runs=r))
            for r in ("screen-first", "screen-each", {1: "screen-first", 0: "screen-each"}, {0: "screen-first"})}
    assert runs["screen-first"].info["regressed_screening"]["continued"] > 0
    assert np.abs(runs["screen-first"].v_n - runs["screen-each"].v_n).max() > 1e-4
    np.testing.assert_array_equal(runs[str({1: "screen-first", 0: "screen-each"})].v_n, runs["screen-first"].v_n)
    np.testing.assert_array_equal(runs[str({0: "screen-first"})].v_n, runs["screen-each"].v_n)
    from_file = GraphOptions(regressed_runs={"0": "screen-each", "1": "screen-first"},
                             regressed_error_tau_s={"1": 10.0})
    assert from_file.regressed_runs == {0: "screen-each", 1: "screen-first"}
    assert [from_file.runs_for(n) for n in range(3)] == ["screen-each", "screen-first", "screen-each"]
    for bad in ({1: "screen-all"}, {"one": "screen-first"}, {1: "screen-first", "1": "screen-each"}):
        with pytest.raises(ConfigError, match="regressed_runs"):
            GraphOptions(regressed_runs=bad)
    with pytest.raises(ConfigError, match="with 0 measured beams"):
        GraphOptions(regressed_runs={0: "screen-each", 1: "screen-first"}, regressed_error_tau_s={0: 3.0, 1: 10.0})
    with pytest.raises(ConfigError, match="regressed_runs does not name"):   # a scalar time reaches every count
        GraphOptions(regressed_runs={1: "screen-first"}, regressed_error_tau_s=10.0)
    with pytest.raises(ConfigError, match="regressed_runs"):
        GraphOptions(regressed_runs={"\u00b2": "screen-first"})


def test_completions_retired_when_the_beams_return_leave_the_graph_without_a_completer(tactical_mission):
    """retire_completions: the regressed beams' factors leave the graph at the first ping whose measured beams give
    the velocity. The filtered estimates up to it are those made with the completions; the graph left is the graph
    without a completer, so ISAM2's estimate of every state, the outage's too, is Graph-TC's (to the linearisation
    points: relinearised at every step they agree to 0.1 mm/s), while with the completions kept it is not."""
    from graphnav.estimators.graph.builder import V, X
    from graphnav.estimators.navigator import feed_mission
    from graphnav.estimators.runs import graph_navigator
    m = tactical_mission.slice(0, 90).with_outage(scenario_outage("3-missing", 30.0, 30.0))
    comp = SerialOracleCompleter(m)
    exact = GraphOptions(regressed_runs="screen-first", regressed_error_tau_s=10.0, relin_window_s=None,
                         relinearize_skip=1, relin_rot=1e-9, relin_pos=1e-9, relin_vel=1e-9, relin_bias_acc=1e-9,
                         relin_bias_gyro=1e-9, wildfire_threshold=0.0)

    def replay(completer, options, backend="isam2"):
        nav = graph_navigator(m, completer=completer, options=options, backend=backend)
        return nav, feed_mission(nav, m)
    tc, _ = replay(None, exact)
    kept, e_kept = replay(comp, exact)
    retired, e_retired = replay(comp, dataclasses.replace(exact, retire_completions=True))
    # every regressed beam of the outage: its runs' first ping as one group, then the differences
    assert retired.info["completions_retired"] == 3 * 30 and kept.info["completions_retired"] == 0
    k_return = next(i for i, e in enumerate(e_retired) if e.t >= 60.0 and e.n_measured >= 3)
    for a, b in zip(e_retired[:k_return], e_kept[:k_return]):
        np.testing.assert_array_equal(a.v_n, b.v_n)
    final = [nav.backend.estimator._estimates() for nav in (tc, kept, retired)]

    def largest(a, b):
        return (max(np.abs(a.atVector(V(k)) - b.atVector(V(k))).max() for k in range(len(e_kept))),
                max(np.abs(a.atPose3(X(k)).translation() - b.atPose3(X(k)).translation()).max()
                    for k in range(len(e_kept))))
    dv, dp = largest(final[2], final[0])
    assert dv < 1e-4 and dp < 1e-3
    dv_kept, dp_kept = largest(final[1], final[0])
    assert dv_kept > 1e-3 and dp_kept > 0.05
    # the fixed-lag smoother holds the outage's keyframes beyond its 10 s lag until the return, and then answers as
    # ISAM2 does; held for at most retire_hold_s, or restarted inside the outage, it takes out only the later ones
    lag = dataclasses.replace(exact, retire_completions=True, lag_s=10.0, reanchor_interval_s=None)
    nav, e_lag = replay(comp, lag, backend="fixed-lag")
    assert nav.info["completions_retired"] == 3 * 30
    assert np.abs(e_lag[-1].v_n - e_retired[-1].v_n).max() < 1e-4
    _, e_lag_kept = replay(comp, dataclasses.replace(lag, retire_completions=False), backend="fixed-lag")
    assert np.abs(e_lag_kept[-1].v_n - e_retired[-1].v_n).max() > 1e-3
    # before the return, holding keyframes instead of marginalising them moves the estimates only through their
    # linearisation points (a marginal freezes them): under 1 mm/s
    assert max(np.abs(a.v_n - b.v_n).max() for a, b in zip(e_lag[:k_return], e_lag_kept[:k_return])) < 1e-3
    short_hold, _ = replay(comp, dataclasses.replace(lag, retire_hold_s=5.0), backend="fixed-lag")
    assert 3 * 10 <= short_hold.info["completions_retired"] <= 3 * 17
    # beams that never return: what the smoother holds and remembers stays within the hold and the lag
    endless = tactical_mission.slice(0, 90).with_outage(scenario_outage("3-missing", 30.0, 100.0))
    never = graph_navigator(endless, completer=SerialOracleCompleter(endless),
                            options=dataclasses.replace(lag, retire_hold_s=5.0), backend="fixed-lag")
    feed_mission(never, endless)
    held = never.backend.estimator
    assert held.n_completions_retired == 0 and len(held._held) <= 6 and 0 < len(held._completions) <= 16 * 4
    restarted, _ = replay(comp, dataclasses.replace(lag, reanchor_interval_s=45.0), backend="fixed-lag")
    assert restarted.info["reanchored"] >= 1 and 3 * 10 <= restarted.info["completions_retired"] <= 3 * 16
    with pytest.raises(ConfigError, match="retire_hold_s"):
        GraphOptions(retire_hold_s=-1.0)
    # what a user reads: the run's record of its regressed beams counts those taken out
    from graphnav.commands.common import regressed_beams_line, regressed_beams_summary
    record = regressed_beams_summary(run_graph(m, completer=comp, options=lag, backend="fixed-lag").info)
    assert record["retired"] == 3 * 30
    assert regressed_beams_line(record).endswith("90 taken out again when the measured beams returned")
    assert "retired" not in regressed_beams_summary(run_graph(m, completer=comp).info)
    # the batch smoother leaves out the completions of an outage the measured beams end: it smooths the graph
    # without a completer, to its convergence; it keeps those of an outage the mission ends in
    short = m.slice(0, 75)
    batch_tc = run_graph(short, batch=True, options=exact)
    batch = run_graph(short, completer=comp, batch=True, options=dataclasses.replace(exact, retire_completions=True))
    assert batch.info["completions_retired"] == 3 * 30 and regressed_beams_summary(batch.info)["retired"] == 3 * 30
    assert np.abs(batch.v_n - batch_tc.v_n).max() < 1e-5 and np.abs(batch.p_n - batch_tc.p_n).max() < 1e-3
    batch_kept = run_graph(short, completer=comp, batch=True, options=exact)
    assert batch_kept.info["completions_retired"] == 0 and "retired" not in regressed_beams_summary(batch_kept.info)
    assert np.abs(batch_kept.v_n - batch_tc.v_n).max() > 1e-3 and np.abs(batch_kept.p_n - batch_tc.p_n).max() > 0.05
    # ... and keeps those of an outage the mission ends in
    unended = m.slice(0, 50)
    batch_end = run_graph(unended, completer=comp, batch=True, options=dataclasses.replace(exact, retire_completions=True))
    assert batch_end.info["completions_retired"] == 0
    assert np.abs(batch_end.v_n - run_graph(unended, batch=True, options=exact).v_n).max() > 1e-3
    # outages the beams end, and a beam lost with 3 measured up to the mission's end (its completions go at the next
    # such ping, so the last one stays): the batch leaves out what ISAM2 took out by the mission's end, no more
    from graphnav.core.scenarios import Outage
    mixed = tactical_mission.slice(0, 85).with_outage(Outage(20.0, 15.0, (0, 1, 2)), Outage(45.0, 10.0, (1,)),
                                                      Outage(60.0, 10.0, (0, 1, 2)), Outage(75.0, 20.0, (1,)))
    on = dataclasses.replace(exact, retire_completions=True)
    online = graph_navigator(mixed, completer=SerialOracleCompleter(mixed), options=on)
    feed_mission(online, mixed)
    batch_mixed = run_graph(mixed, completer=SerialOracleCompleter(mixed), batch=True, options=on)
    assert batch_mixed.info["n_regressed"][-1] == 1 and batch_mixed.info["n_measured"][-1] == 3
    assert batch_mixed.info["completions_retired"] == online.info["completions_retired"] > 3 * 15 + 10 + 3 * 10


def test_screen_first_keeps_a_run_once_one_completion_is_kept(tactical_mission):
    """regressed_runs="screen-first": the screening decides per ping until one completion of a beam's run is kept;
    the rest of the run enters at the completer's sigma, unscreened. With a screening that drops whatever the graph
    predicts well (correlation 0.5), "screen-first" drops completions only before each run's first kept one; without
    any screening the two are the same graph."""
    from graphnav.estimators.options import RegressedScreeningOptions
    m = tactical_mission.with_outage(scenario_outage("3-missing", 60.0, 60.0))
    comp = SerialOracleCompleter(m, sigma=0.05)
    screening = RegressedScreeningOptions(correlation=0.5, adaptive=True)
    each = run_graph(m, completer=comp, options=GraphOptions(screening=screening))
    first = run_graph(m, completer=comp, options=GraphOptions(screening=screening, regressed_runs="screen-first"))
    n = int(first.info["n_regressed"].sum())
    s_each, s_first = each.info["regressed_screening"], first.info["regressed_screening"]
    dropped_first = s_first["decorrelated_out"] + s_first["gated"]
    assert s_first["continued"] > 0 and s_each["continued"] == 0
    # each beam's run: pings dropped by the screening, at most one kept by it, then the run continued unscreened
    assert 1 <= n - dropped_first - s_first["continued"] <= 3
    # what became factors: every offered completion is either dropped or entered
    assert s_first["entered"] == n - dropped_first
    assert s_each["entered"] == int(each.info["n_regressed"].sum()) - s_each["decorrelated_out"] - s_each["gated"]
    plain = run_graph(m, completer=comp)
    unscreened_first = run_graph(m, completer=comp, options=GraphOptions(regressed_runs="screen-first"))
    np.testing.assert_allclose(unscreened_first.v_n, plain.v_n, atol=1e-9)


def test_completions_the_motion_prior_replaces_are_neither_entered_nor_dropped(tactical_mission):
    """With motion_prior="total" a ping without any measured beam gets the motion prior instead of its completions:
    the run's record counts them as regressed, entered by none, dropped by none, and says so."""
    from graphnav.commands.common import regressed_beams_line, regressed_beams_summary
    m = tactical_mission.with_outage(scenario_outage("0-beams", 60.0, 20.0))
    sol = run_graph(m, completer=AverageCompleter(3), options=GraphOptions(motion_prior="total"))
    record = regressed_beams_summary(sol.info)
    assert record["regressed"] == 4 * 20 and record["entered"] == 0
    assert record["decorrelated_out"] == record["gated"] == 0
    assert regressed_beams_line(record).endswith("80 replaced by the motion prior")
    assert regressed_beams_summary(run_graph(m, options=GraphOptions(motion_prior="total")).info) is None


@pytest.mark.parametrize("huber", [1.5, None])
def test_run_differences_are_one_factor_per_beam_under_a_huber_kernel(huber):
    """With a Huber kernel on regressed beams, each continued beam's whitened difference is a factor of its own: the
    graph's nonlinear error (the batch step test's, Levenberg-Marquardt's) is then the sum of the per-beam Huber
    losses the linearisation reweights by, not one loss of the ping's whole residual. Without a kernel the ping's
    continued beams are one factor."""
    import gtsam
    from types import SimpleNamespace
    from graphnav.estimators.graph.builder import BeamRows, RegressedLink, continue_regressed_runs
    from gtsam.symbol_shorthand import B, V, X
    config = simulate_mission(5, seed=1).config
    ctx = GraphContext(config, GraphOptions(regressed_runs="screen-first", regressed_error_tau_s=3.0,
                                            huber_regressed_k=huber))
    T_b = ctx.geometry.T_b
    omega_b = np.array([0.01, -0.02, 0.03])
    y_prev, y, sigma = np.array([0.5, -0.3, 0.2]), np.array([0.6, -0.1, 1.5]), np.array([0.05, 0.05, 0.05])
    ctx.regressed_links = {j: RegressedLink(3, 3.0, y_prev[i], sigma[i], omega_b, False) for i, j in enumerate((0, 1, 2))}
    m = BeamRows(T_b[:3], y, sigma, np.ones(3, dtype=bool))
    left, plain, factors, links = continue_regressed_runs(SimpleNamespace(index=4, t=4.0), ctx, m, np.arange(3),
                                                          omega_b, False)
    assert left.size == 0 and plain.size == 0 and sorted(links) == [0, 1, 2]
    assert [f.dim() for f in factors] == ([1, 1, 1] if huber else [3])
    values = gtsam.Values()
    for k in (3, 4):
        values.insert(X(k), gtsam.Pose3())
        values.insert(V(k), np.array([1.0, 0.0, 0.0]))
        values.insert(B(k), gtsam.imuBias.ConstantBias())
    sigma_w = sigma * np.sqrt(1.0 - np.exp(-2.0 * 1.0 / 3.0))      # steady sigma, 1 s apart, tau 3 s
    whitened = np.concatenate([f.unwhitenedError(values) for f in factors]) / sigma_w
    assert np.abs(whitened).max() > 5.0        # one beam far out: where a block and per-beam losses differ
    expected = sum((0.5 * z ** 2 if abs(z) <= huber else huber * abs(z) - 0.5 * huber ** 2) for z in whitened) \
        if huber else 0.5 * np.sum(whitened ** 2)
    assert sum(f.error(values) for f in factors) == pytest.approx(expected, rel=1e-9)
