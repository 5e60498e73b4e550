"""A DVL-frame velocity measured by the instrument (velocity-only DVLs, 3-beam solutions): the beam model with
T_d = identity, its Jacobians (model, GTSAM factor, batch, EKF) against numerical ones, the keyframer's
one-ping-one-measurement rule, the Navigator's checks, the JSON-lines record, and navigation with it."""
from __future__ import annotations

import dataclasses
import io
import warnings

import gtsam
import numpy as np
import pytest
from graphnav.factors import dvl_factor, dvl_velocity_factor
from gtsam.symbol_shorthand import B, D, L, V, X
from gtsam.utils.numerical_derivative import (
    numericalDerivative41,
    numericalDerivative42,
    numericalDerivative43,
    numericalDerivative44,
)

from graphnav.core.beam_model import BeamModel
from graphnav.core.config import DvlSpec, SensorConfig
from graphnav.core.dvl import DvlGeometry
from graphnav.core.errors import ConfigError
from graphnav.estimators import keyframes as kfs
from graphnav.estimators.ekf import IA, IE, IG, IV, EkfOptions, ErrorStateEkf
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.graph.batch import StackedBeams
from graphnav.estimators.graph.builder import BeamGroup, GraphContext
from graphnav.estimators.ins import StrapdownState
from graphnav.estimators.navigator import Navigator, feed_mission
from graphnav.estimators.options import PriorOptions
from graphnav.estimators.replay import mission_records, replay
from graphnav.estimators.runs import initial_state, run_ekf, run_graph
from graphnav.evaluation.metrics import vrmse
from graphnav.io.streamio import StreamReader, feed, write_records
from graphnav.sim.simulate import simulate_mission

LEVER = np.array([-1.86, -0.04, 0.2])
EPS = 1e-6


def random_C_d_b(rng) -> np.ndarray:
    return gtsam.Rot3.RzRyRx(*rng.uniform(-0.3, 0.3, 2), rng.uniform(-np.pi, np.pi)).matrix()


def random_state(rng, lever: bool) -> dict:
    return {"C_b_n": gtsam.Rot3.RzRyRx(*rng.uniform(-np.pi, np.pi, 3)).matrix(), "v_n": rng.normal(0, 1.5, 3),
            "omega_b": rng.normal(0, 0.3, 3), "gyro_bias": rng.normal(0, 1e-2, 3),
            "lever_arm_b": (LEVER + rng.normal(0, 0.1, 3)) if lever else np.zeros(3),
            "dvl_errors": np.r_[rng.normal(0, 0.01, 3), rng.normal(0, 0.02, 4)]}


def true_v_d(C_d_b, s) -> np.ndarray:
    """The DVL-frame head velocity C_d_b^T (C^T v_n + (omega - b_g) x l) of a state, written out."""
    return C_d_b.T @ (s["C_b_n"].T @ s["v_n"] + np.cross(s["omega_b"] - s["gyro_bias"], s["lever_arm_b"]))


# --- the model ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("lever", [False, True])
@pytest.mark.parametrize("dvl_errors", [False, True])
def test_velocity_model_prediction_and_every_jacobian(seed, lever, dvl_errors):
    rng = np.random.default_rng(seed)
    C_d_b = random_C_d_b(rng)
    s = random_state(rng, lever)
    model = BeamModel.dvl_velocity(C_d_b, dvl_errors)
    if not dvl_errors:
        del s["dvl_errors"]
    p = model.predict(**s)
    scale = 1.0 + s["dvl_errors"][:3] if dvl_errors else 1.0
    np.testing.assert_allclose(p.h, scale * true_v_d(C_d_b, s), atol=1e-12)
    blocks = {"C_b_n": p.d_rot(), "v_n": p.d_v(), "gyro_bias": p.d_gyro_bias(), "lever_arm_b": p.d_lever_arm()}
    if dvl_errors:
        blocks["dvl_errors"] = p.d_dvl_errors()
        np.testing.assert_array_equal(p.d_dvl_errors()[:, 3:], 0.0)      # no beam bias acts on a velocity
    for name, analytic in blocks.items():
        numeric = []
        for i in range(analytic.shape[1]):
            step = np.zeros(analytic.shape[1])
            step[i] = EPS
            hs = []
            for sign in (1.0, -1.0):
                t = dict(s)
                t[name] = (s[name] @ gtsam.Rot3.Expmap(sign * step).matrix() if name == "C_b_n"
                           else s[name] + sign * step)
                hs.append(model.predict(**t).h)
            numeric.append((hs[0] - hs[1]) / (2 * EPS))
        np.testing.assert_allclose(analytic, np.stack(numeric, axis=-1), atol=1e-7, err_msg=name)


def test_velocity_model_is_the_beam_model_with_identity_rows():
    """T_d = I: the four beams of the same state are T_d times the velocity prediction (with the scale)."""
    rng = np.random.default_rng(5)
    C_d_b = random_C_d_b(rng)
    s = random_state(rng, True)
    geo = DvlGeometry.from_spec(DvlSpec(C_d_b=C_d_b, lever_arm_b=LEVER))
    d = s["dvl_errors"].copy()
    d[3:] = 0.0                                    # beam biases off: the beams are then linear in v_d
    s["dvl_errors"] = d
    beams = geo.beam_model(dvl_errors=True).predict(**s).h
    v = geo.velocity_model(dvl_errors=True).predict(**s).h
    np.testing.assert_allclose(beams, geo.T_d @ v, atol=1e-12)
    with pytest.raises(ValueError, match="-1"):
        BeamModel(np.eye(3), [-2, 0, 1], np.eye(3))


# --- the GTSAM factor ---------------------------------------------------------------------------------
def _values(pose, v_n, bias, d=None, lever=None):
    values = gtsam.Values()
    values.insert(X(0), pose)
    values.insert(V(0), v_n)
    values.insert(B(0), bias)
    if d is not None:
        values.insert(D(0), d)
    if lever is not None:
        values.insert(L(0), gtsam.Point3(lever))
    return values


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("variant", ["fixed", "no-lever", "dvl-errors", "lever-variable"])
def test_velocity_factor_zero_residual_and_jacobians(seed, variant):
    rng = np.random.default_rng(20 + seed)
    C_d_b = random_C_d_b(rng)
    s = random_state(rng, variant != "no-lever")
    pose = gtsam.Pose3(gtsam.Rot3(s["C_b_n"]), rng.normal(0, 30, 3))
    bias = gtsam.imuBias.ConstantBias(rng.normal(0, 1e-2, 3), s["gyro_bias"])
    d = s["dvl_errors"] if variant == "dvl-errors" else None
    y = (1.0 + (d[:3] if d is not None else 0.0)) * true_v_d(C_d_b, s)
    sigma = rng.uniform(0.01, 0.1, 3)
    kw = {"d_key": D(0)} if d is not None else {}
    if variant == "lever-variable":
        factor = dvl_velocity_factor(X(0), V(0), B(0), C_d_b, y, sigma, s["omega_b"], l_key=L(0))
        fourth = gtsam.Point3(s["lever_arm_b"])
    else:
        factor = dvl_velocity_factor(X(0), V(0), B(0), C_d_b, y, sigma, s["omega_b"], s["lever_arm_b"], **kw)
        fourth = d if d is not None else np.zeros(1)        # a dummy 4th argument for the 4-argument helpers

    def vals(x, v, b, extra):
        if variant == "lever-variable":
            return _values(x, v, b, lever=extra)
        return _values(x, v, b, d=extra if d is not None else None)

    values = vals(pose, s["v_n"], bias, fourth)
    np.testing.assert_allclose(factor.unwhitenedError(values), 0.0, atol=1e-12)
    off = dvl_velocity_factor(X(0), V(0), B(0), C_d_b, y + [0.1, -0.2, 0.3], sigma, s["omega_b"],
                              **({"l_key": L(0)} if variant == "lever-variable" else {"lever_arm_b": s["lever_arm_b"]}),
                              **kw)
    np.testing.assert_allclose(off.unwhitenedError(values), [-0.1, 0.2, -0.3], atol=1e-12)   # prediction - y

    def h(x, v, b, extra):
        return factor.whitenedError(vals(x, v, b, extra))

    args = [pose, s["v_n"], bias, fourth]
    numeric = [numericalDerivative41(h, *args), numericalDerivative42(h, *args), numericalDerivative43(h, *args)]
    if variant in ("dvl-errors", "lever-variable"):
        numeric.append(numericalDerivative44(h, *args))
    A = factor.linearize(values).jacobian()[0]
    np.testing.assert_allclose(A, np.hstack(numeric), atol=1e-6, rtol=1e-6)
    if variant == "dvl-errors":
        np.testing.assert_array_equal(A[:, -4:], 0.0)            # beam-bias columns of D(0)


def test_velocity_factor_equals_the_generic_dvl_factor_with_its_rows():
    rng = np.random.default_rng(9)
    C_d_b = random_C_d_b(rng)
    s = random_state(rng, True)
    values = _values(gtsam.Pose3(gtsam.Rot3(s["C_b_n"]), np.zeros(3)), s["v_n"],
                     gtsam.imuBias.ConstantBias(np.zeros(3), s["gyro_bias"]))
    y = rng.normal(0, 1, 3)
    a = dvl_velocity_factor(X(0), V(0), B(0), C_d_b, y, np.ones(3), s["omega_b"], LEVER)
    b = dvl_factor(X(0), V(0), B(0), C_d_b.T, y, np.ones(3), s["omega_b"], LEVER)
    np.testing.assert_allclose(a.unwhitenedError(values), b.unwhitenedError(values), atol=1e-14)


# --- one model for the factor, the batch and the EKF --------------------------------------------------
@pytest.mark.parametrize("dvl_errors", [False, True])
def test_factor_batch_and_ekf_use_the_same_velocity_model(dvl_errors):
    rng = np.random.default_rng(13)
    config = SensorConfig()
    config.dvl.C_d_b = gtsam.Rot3.RzRyRx(0.02, -0.03, 0.7).matrix()
    config.dvl.lever_arm_b = LEVER.copy()
    geo = DvlGeometry.from_spec(config.dvl)
    s = random_state(rng, True)
    C, v_n, omega, b_g = s["C_b_n"], s["v_n"], s["omega_b"], s["gyro_bias"]
    d = s["dvl_errors"] if dvl_errors else np.zeros(7)
    y = rng.normal(0, 1, 3)
    group = BeamGroup(0, geo.C_d_b.T, y, np.ones(3), None, omega, geo.lever_arm_b, False,
                      np.full(3, -1) if dvl_errors else None, geo.C_d_b if dvl_errors else None, velocity=True)
    values = _values(gtsam.Pose3(gtsam.Rot3(C), rng.normal(0, 10, 3)), v_n,
                     gtsam.imuBias.ConstantBias(rng.normal(0, 1e-3, 3), b_g), d if dvl_errors else None)
    A, b = group.factor().linearize(values).jacobian()
    e, J_rot, J_v, J_bg, J_d = StackedBeams([group]).linearize(C[None], v_n[None], b_g[None],
                                                               d[None] if dvl_errors else None)
    ekf = ErrorStateEkf(config, StrapdownState(0.0, C, v_n, np.zeros(3)),
                        EkfOptions(dvl_error_states=dvl_errors, lever_arm=True), bias_gyro=b_g)
    if dvl_errors:
        ekf.dvl_scale, ekf.beam_bias = d[:3].copy(), d[3:].copy()
    h_ekf, H = ekf.predicted_velocity(omega)
    np.testing.assert_allclose(y - b, e + y, atol=1e-12)
    np.testing.assert_allclose(h_ekf, e + y, atol=1e-12)
    for f, bt, ek in ((A[:, 0:3], J_rot, H[:, IE] @ C), (A[:, 6:9], J_v, H[:, IV]), (A[:, 12:15], J_bg, H[:, IG])):
        np.testing.assert_allclose(f, bt, atol=1e-12)
        np.testing.assert_allclose(ek, bt, atol=1e-12)
    np.testing.assert_array_equal(H[:, IA], 0.0)
    if dvl_errors:
        np.testing.assert_allclose(A[:, 15:22], J_d, atol=1e-12)
        np.testing.assert_allclose(H[:, ekf.n_nav:], J_d, atol=1e-12)


@pytest.mark.parametrize("dvl_errors", [False, True])
def test_ekf_velocity_h_matches_a_numerical_derivative_in_its_error_convention(dvl_errors):
    rng = np.random.default_rng(4)
    config = SensorConfig()
    config.dvl.C_d_b = random_C_d_b(rng)
    config.dvl.lever_arm_b = LEVER.copy()
    s = random_state(rng, True)
    opts = EkfOptions(dvl_error_states=dvl_errors, lever_arm=True)

    def make(dx=None):
        e = ErrorStateEkf(config, StrapdownState(0.0, s["C_b_n"], s["v_n"], np.zeros(3)), opts,
                          bias_gyro=s["gyro_bias"])
        e.dvl_scale, e.beam_bias = s["dvl_errors"][:3].copy(), s["dvl_errors"][3:].copy()
        if not dvl_errors:
            e.dvl_scale, e.beam_bias = np.zeros(3), np.zeros(4)
        if dx is not None:
            e.state.v_n = e.state.v_n - dx[IV]
            e.state.C_b_n = gtsam.Rot3.Expmap(-dx[IE]).matrix() @ e.state.C_b_n
            e.bias_gyro = e.bias_gyro - dx[IG]
            if dvl_errors:
                e.dvl_scale = e.dvl_scale - dx[e.i_scale]
                e.beam_bias = e.beam_bias - dx[e.i_bias]
        return e

    ekf = make()
    _, H = ekf.predicted_velocity(s["omega_b"])
    numeric = np.zeros_like(H)
    for i in range(ekf.n_states):
        hs = []
        for sign in (1.0, -1.0):
            dx = np.zeros(ekf.n_states)
            dx[i] = sign * EPS
            hs.append(make(dx).predicted_velocity(s["omega_b"])[0])
        numeric[:, i] = -(hs[0] - hs[1]) / (2 * EPS)
    np.testing.assert_allclose(H, numeric, atol=1e-7)


def test_default_velocity_sigma_is_the_four_beam_least_squares_sigma():
    config = SensorConfig()
    geo = DvlGeometry.from_spec(config.dvl)
    sigma = geo.velocity_sigma_d(0.042)
    theta = config.dvl.theta_rad
    np.testing.assert_allclose(sigma, [0.042 / (np.sqrt(2) * np.sin(theta))] * 2 + [0.042 / (2 * np.cos(theta))])
    # the covariance of the least-squares velocity of four beams with that noise, by sampling
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 0.042, (20000, 4))
    v = np.linalg.lstsq(geo.T_d, noise.T, rcond=None)[0].T
    np.testing.assert_allclose(v.std(axis=0), sigma, rtol=0.03)
    ctx = GraphContext(config, GraphOptions())
    np.testing.assert_allclose(ctx.velocity_sigma, sigma)
    config.dvl.velocity_noise_std = [0.02, 0.02, 0.01]
    np.testing.assert_allclose(GraphContext(config, GraphOptions()).velocity_sigma, [0.02, 0.02, 0.01])
    with pytest.raises(ConfigError, match="velocity_noise_std"):
        DvlSpec(velocity_noise_std=[0.1, 0.0, 0.1])
    assert SensorConfig.from_dict(config.to_dict()).dvl.velocity_noise_std.tolist() == [0.02, 0.02, 0.01]


# --- keyframer and Navigator --------------------------------------------------------------------------
def _keyframer(completer=None):
    config = SensorConfig()
    k = kfs.Keyframer(config, completer=completer)
    k.add_imu(0.0, (0.0, 0.0, -9.8), (0.0, 0.0, 0.0))
    k.start(0.0)
    return k


def _close(k, t):
    """IMU samples at 100 Hz from the newest one to just past t: the keyframes with a ping they close."""
    out = []
    t_imu = k.samples[-1][0]
    while t_imu <= t + 0.02:
        t_imu = round(t_imu + 0.01, 6)
        out += k.add_imu(t_imu, (0.0, 0.0, -9.8), (0.0, 0.0, 0.01))
    return [kf for kf in out if kf.ping is not None]


def test_a_ping_uses_its_beams_or_its_velocity_never_both():
    k = _keyframer()
    _close(k, 0.0)
    v = np.array([1.0, 0.1, -0.05])
    # a velocity alone
    k.add_dvl_velocity(1.0, v, [0.02, 0.02, 0.01])
    (kf,) = _close(k, 1.0)
    assert kf.ping.is_velocity and not kf.ping.measured.any() and np.all(np.isnan(kf.ping.beams))
    np.testing.assert_array_equal(kf.ping.v_d, v)
    np.testing.assert_array_equal(kf.ping.v_d_sigma, [0.02, 0.02, 0.01])
    # three valid beams and a velocity at the same stamp: the beams
    k.add_dvl(2.0, [0.3, 0.2, np.nan, 0.1], [True, True, False, True])
    k.add_dvl_velocity(2.0, v, [np.nan] * 3)
    (kf,) = _close(k, 2.0)
    assert not kf.ping.is_velocity and kf.ping.n_measured == 3
    # two valid beams and a velocity (either order): the velocity, the beams counted and warned about
    k.add_dvl_velocity(3.0, v, [np.nan] * 3)
    k.add_dvl(3.0, [0.3, np.nan, np.nan, 0.1], [True, False, False, True])
    with pytest.warns(RuntimeWarning, match="beams_superseded"):
        (kf,) = _close(k, 3.0)
    assert kf.ping.is_velocity and kf.ping.n_measured == 0
    assert (k.stats.velocity_pings, k.stats.velocity_superseded, k.stats.beams_superseded) == (2, 1, 2)


def test_velocity_ping_feeds_the_completer_history_as_measured_beams():
    class Mean:
        n_past = 2

        def complete(self, past, measured):
            full = np.where(np.isfinite(measured), measured, past.mean(axis=0))
            return full, np.where(np.isfinite(measured), 0.0, 0.1)

    k = _keyframer(Mean())
    v = np.array([1.0, 0.2, 0.1])
    T_d = DvlGeometry.from_spec(SensorConfig().dvl).T_d
    for t in (1.0, 2.0):
        k.add_dvl_velocity(t, v, [np.nan] * 3)
        (kf,) = _close(k, t)
        assert not kf.ping.has_regressed                     # no completer on a velocity ping
    np.testing.assert_allclose(k.history.past(), [T_d @ v, T_d @ v])
    k.add_dvl(3.0, [np.nan, 0.5, 0.5, 0.5], [False, True, True, True])
    (kf,) = _close(k, 3.0)
    assert kf.ping.has_regressed and kf.ping.beams[0] == pytest.approx((T_d @ v)[0])


def test_init_gt_without_a_reference_is_refused_naming_the_mission():
    mission = simulate_mission(10.0, seed=1)
    mission.gt = None
    with pytest.raises(ConfigError, match="has no ground truth to initialise the graph from"):
        initial_state(mission, None, "gt", 0.0)
    assert initial_state(mission, None, "auto", 0.0) is None


def test_navigator_refuses_bad_velocities_and_counts_them():
    nav = Navigator(SensorConfig(), "ekf", initial=initial_state(simulate_mission(10.0, seed=1), None, "gt", 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        nav.add_dvl_velocity(1.0, [np.nan, 0.0, 0.0])
        nav.add_dvl_velocity(2.0, [1.0, 0.0, 0.0], [0.1, -0.1, 0.1])
        nav.add_dvl_velocity(2.5, [1.0, 0.0, 0.0], [0.1, np.inf, np.nan])
        nav.add_dvl_velocity(3.0, [40.0, 0.0, 0.0])
        nav.add_dvl_velocity(4.0, [1.0, 0.0])
        nav.add_dvl_velocity(5.0, [1.0, 0.0, 0.0])
        nav.add_dvl_velocity(5.0, [1.0, 0.0, 0.0])
    assert nav.refused["dvl_velocity"] == {"v_d": 3, "sigma": 2, "t": 1}


# --- navigation with a velocity-only DVL ----------------------------------------------------------------
DURATION = 150.0


@pytest.fixture(scope="module")
def missions():
    """The same simulated mission (seed 2, DVL at 45 deg yaw to the body so that a frame mistake shows)
    with its four beams, and as a velocity-only DVL reporting its own least-squares v_d of those beams."""
    config = SensorConfig()
    config.dvl.C_d_b = gtsam.Rot3.Yaw(np.deg2rad(45.0)).matrix()
    beams = simulate_mission(DURATION, seed=2, config=config)
    velocity = simulate_mission(DURATION, seed=2, config=config, dvl_output="velocity")
    wrong = dataclasses.replace(velocity, dvl=dataclasses.replace(
        velocity.dvl, v_d=velocity.dvl.v_d @ config.dvl.C_d_b.T))     # body axes, labelled as the DVL frame
    return beams, velocity, wrong


def test_velocity_only_mission_is_the_same_mission_without_beams(missions):
    beams, velocity, _ = missions
    assert not velocity.dvl.valid.any() and velocity.dvl.v_d_valid.all()
    np.testing.assert_array_equal(velocity.imu.f_b, beams.imu.f_b)
    kinds = {kind for kind, _, _ in replay(velocity)}
    assert "dvl_velocity" in kinds
    # the velocity is the beams' own least-squares solution, in the DVL frame
    geo = DvlGeometry.from_spec(beams.config.dvl)
    np.testing.assert_allclose(velocity.dvl.v_d, geo.velocity_from_beams(beams.dvl.beams) @ geo.C_d_b, atol=1e-12)


def test_velocity_only_navigates_like_all_beams_and_a_wrong_frame_does_not(missions):
    """Graph-TC (ISAM2), its batch smoother and EKF-TC: velocity-only VRMSE within 15 % of the all-beams run
    (the same information: the instrument's v_d is the least-squares solution of the same beams), and the
    velocity given in body axes instead of the DVL frame (45 deg yaw) at least 3x worse."""
    beams, velocity, wrong = missions
    runs = {"Graph-TC": lambda m: run_graph(m), "Graph-TC-batch": lambda m: run_graph(m, batch=True),
            "EKF-TC": lambda m: run_ekf(m)}
    for name, run in runs.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            ref, vel, bad = (vrmse(run(m), beams.gt) for m in (beams, velocity, wrong))
        assert vel < 1.15 * ref, (name, ref, vel)
        assert bad > 3.0 * vel, (name, vel, bad)


@pytest.mark.parametrize("tight", [True, False])
def test_velocity_pings_are_counted_and_the_ekf_uses_them(missions, tight):
    beams, velocity, _ = missions
    m = velocity.slice(0.0, 40.0)
    sol = run_ekf(m, tight=tight)
    n = int(m.dvl.v_d_valid.sum())
    assert n - 1 <= sol.info["velocity_pings"] <= n
    assert sol.info["n_velocity_updates"] == sol.info["velocity_pings"]
    ref = run_ekf(beams.slice(0.0, 40.0), tight=tight)
    assert ref.info["velocity_pings"] == 0
    assert vrmse(sol, m.gt) < 1.1 * vrmse(ref, m.gt)


def test_stream_replay_equals_the_mission_replay(missions):
    """The JSON-lines records of a velocity-only mission (with its dvl_velocity records) fed through the
    stream reader give the same estimates as the mission replay."""
    _, velocity, _ = missions
    m = velocity.slice(0.0, 30.0)
    init = initial_state(m, None, "gt", float(m.dvl.t[0]))
    buf = io.StringIO()
    write_records(mission_records(m), buf)
    lines = buf.getvalue().splitlines()
    assert any('"type":"dvl_velocity"' in line for line in lines)
    direct = feed_mission(Navigator(m.config, "fixed-lag", initial=init), m)
    nav = Navigator(m.config, "fixed-lag", initial=init)
    streamed = []
    reader = StreamReader(lines)
    for rec in reader:
        streamed += feed(nav, rec)
    streamed += nav.finish()
    assert reader.n_bad == 0 and len(streamed) == len(direct) > 20
    assert nav.info["velocity_pings"] > 20
    for a, b in zip(direct, streamed):
        assert a.t == b.t
        np.testing.assert_allclose(a.v_n, b.v_n, atol=1e-9)


def test_hybrid_methods_run_through_velocity_pings(missions):
    """A DVL that loses two beams for 20 s and then reports only its velocity for 20 s (a 3-beam log turning
    into a velocity-only one): the completer fills the two-beam pings, never the velocity pings, and the
    hybrid graph and EKF navigate through both."""
    from graphnav.nets import AverageCompleter
    beams, velocity, _ = missions
    m = beams.slice(0.0, 60.0)
    dvl = m.dvl
    valid = dvl.valid.copy()
    two = (dvl.t >= 15.0) & (dvl.t < 35.0)
    vel = dvl.t >= 35.0
    valid[two, :2] = False
    valid[vel] = False
    v_d_valid = vel.copy()
    v_d = np.where(v_d_valid[:, None], velocity.slice(0.0, 60.0).dvl.v_d, np.nan)
    m = dataclasses.replace(m, dvl=dataclasses.replace(dvl, beams=np.where(valid, dvl.beams, np.nan), valid=valid,
                                                       v_b=None, v_d=v_d, v_d_valid=v_d_valid))
    m.dvl.validate()
    full = beams.slice(0.0, 60.0)
    for run in (run_graph, run_ekf):
        sol = run(m, completer=AverageCompleter(3))
        assert sol.info["velocity_pings"] == int(vel.sum())
        assert int(two.sum()) - 3 <= sol.info["regressed_pings"] <= int(two.sum())
        ref = vrmse(run(full), full.gt)                    # all beams all the time
        assert vrmse(sol, m.gt) < 1.5 * ref


def test_ekf_locked_out_by_velocities_reacquires_from_the_velocity():
    """A filter 3 m/s off with a tight covariance gates every velocity; after the lockout it re-initialises its
    velocity from the instrument's own velocity (through C_d_b and the lever arm) and accepts again."""
    rng = np.random.default_rng(8)
    config = SensorConfig()
    config.dvl.C_d_b = random_C_d_b(rng)
    config.dvl.lever_arm_b = LEVER.copy()
    C = gtsam.Rot3.RzRyRx(0.02, -0.01, 1.2).matrix()
    v_true = np.array([1.5, -0.3, 0.1])
    omega = np.array([0.0, 0.0, 0.05])
    v_d = config.dvl.C_d_b.T @ (C.T @ v_true + np.cross(omega, LEVER))
    ekf = ErrorStateEkf(config, StrapdownState(0.0, C, v_true + [3.0, 0.0, 0.0], np.zeros(3)),
                        EkfOptions(priors=PriorOptions(velocity_sigma=0.01), lever_arm=True, relevel=False))
    with pytest.warns(RuntimeWarning, match="re-acquired after a lockout"):
        accepted = [ekf.update_velocity(v_d, omega) for _ in range(ekf.options.health.lockout_rejections)]
    assert not any(accepted[:-1]) and accepted[-1]
    assert ekf.health.n_reacquired == 1
    assert "instrument's DVL-frame velocity" in ekf.health.reacquisitions[0][1]
    np.testing.assert_allclose(ekf.state.v_n, v_true, atol=1e-3)
    assert ekf.update_velocity(v_d, omega)


def test_alignment_from_the_sensors_uses_the_velocity_pings(missions):
    """Without an initial state the aligner levels and gyrocompasses with the velocity pings as with >= 3-beam
    pings: the same pings' information, so the same heading to well within its sigma."""
    beams, velocity, _ = missions
    out, yaw = {}, {}
    for name, m in (("beams", beams), ("velocity", velocity)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            sol = run_ekf(m, init="sensors")
        out[name] = sol.info["alignment"]
        yaw[name] = np.arctan2(sol.C_b_n[0][1, 0], sol.C_b_n[0][0, 0])
    assert out["velocity"]["n_dvl"] == out["beams"]["n_dvl"] > 100
    assert out["velocity"]["heading_sigma_rad"] == pytest.approx(out["beams"]["heading_sigma_rad"], rel=0.05)
    assert abs(yaw["velocity"] - yaw["beams"]) < 0.2 * out["beams"]["heading_sigma_rad"]
