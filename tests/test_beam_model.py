"""The one DVL beam model (graphnav.core.beam_model): analytic Jacobians == numerical ones for every block,
the vectorised paths == the one-state path, and the GTSAM factor, the batch and the EKF predict the same beams
with the same (mapped) Jacobians; the gyro rate at a ping is interpolated for every estimator."""
from __future__ import annotations

import gtsam
import numpy as np
import pytest
from graphnav.factors import dvl_factor
from gtsam.symbol_shorthand import B, D, V, X

from graphnav.core.beam_model import BeamModel
from graphnav.core.config import DvlSpec, SensorConfig
from graphnav.core.dvl import DvlGeometry
from graphnav.estimators import keyframes as kfs
from graphnav.estimators.ekf import IA, IE, IG, IP, IV, EkfOptions, ErrorStateEkf
from graphnav.estimators.graph.batch import StackedBeams
from graphnav.estimators.graph.builder import BeamGroup
from graphnav.estimators.ins import StrapdownState

LEVER = np.array([-1.86, -0.04, 0.2])
EPS = 1e-6


def geometry(rng) -> DvlGeometry:
    C_d_b = gtsam.Rot3.RzRyRx(*rng.uniform(-0.2, 0.2, 3)).matrix()
    return DvlGeometry.from_spec(DvlSpec(C_d_b=C_d_b, lever_arm_b=LEVER))


def random_state(rng) -> dict:
    return {"C_b_n": gtsam.Rot3.RzRyRx(*rng.uniform(-np.pi, np.pi, 3)).matrix(), "v_n": rng.normal(0, 1.5, 3),
            "omega_b": rng.normal(0, 0.3, 3), "gyro_bias": rng.normal(0, 1e-2, 3),
            "lever_arm_b": LEVER + rng.normal(0, 0.1, 3),
            "dvl_errors": np.r_[rng.normal(0, 0.01, 3), rng.normal(0, 0.02, 4)]}


def numerical(model, state, name, n):
    """Central differences of h along n tangent directions of argument ``name`` (rotation: C Exp(dtheta))."""
    cols = []
    for i in range(n):
        step = np.zeros(n)
        step[i] = EPS
        hs = []
        for sign in (1.0, -1.0):
            s = dict(state)
            if name == "C_b_n":
                s[name] = state[name] @ gtsam.Rot3.Expmap(sign * step).matrix()
            else:
                s[name] = state[name] + sign * step
            hs.append(model.predict(**s).h)
        cols.append((hs[0] - hs[1]) / (2 * EPS))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("beams", [[2], [0, 3], [0, 1, 2, 3]])
@pytest.mark.parametrize("dvl_errors", [False, True])
def test_every_jacobian_block_matches_numerical_derivatives(seed, beams, dvl_errors):
    rng = np.random.default_rng(seed)
    geo = geometry(rng)
    state = random_state(rng)
    if dvl_errors:
        model = BeamModel(geo.T_b[beams], beams, geo.C_d_b)
    else:
        model = BeamModel(geo.T_b[beams])
        del state["dvl_errors"]
    p = model.predict(**state)
    blocks = {"C_b_n": p.d_rot(), "v_n": p.d_v(), "gyro_bias": p.d_gyro_bias(), "lever_arm_b": p.d_lever_arm()}
    if dvl_errors:
        blocks["dvl_errors"] = p.d_dvl_errors()
    for name, analytic in blocks.items():
        np.testing.assert_allclose(analytic, numerical(model, state, name, analytic.shape[1]), atol=1e-7,
                                   err_msg=name)
    # the omega_b derivative is minus the gyro bias one: the rate enters as omega_b - b_g
    np.testing.assert_allclose(numerical(model, state, "omega_b", 3), -p.d_gyro_bias(), atol=1e-7)


def test_per_row_and_per_ping_states_equal_the_one_state_path():
    rng = np.random.default_rng(7)
    geo = geometry(rng)
    states = [random_state(rng) for _ in range(5)]
    beam = np.array([0, 1, 2, 3, 1])
    model = BeamModel(geo.T_b[beam], beam, geo.C_d_b)
    stacked = model.predict(*(np.array([s[k] for s in states]) for k in
                              ("C_b_n", "v_n", "omega_b", "gyro_bias", "lever_arm_b", "dvl_errors")))
    for r, s in enumerate(states):
        one = model.predict(**s)
        for name in ("h", "d_rot", "d_v", "d_gyro_bias", "d_lever_arm", "d_dvl_errors"):
            a, b = getattr(stacked, name), getattr(one, name)
            a, b = (a, b) if name == "h" else (a(), b())
            np.testing.assert_allclose(a[r], b[r], atol=1e-14, err_msg=name)
    # per ping (N,1,3) broadcast over the rows, as DvlGeometry.beams_from_velocity uses it
    v_b, w = rng.normal(0, 1, (6, 3)), rng.normal(0, 0.3, (6, 3))
    exact = np.array([geo.T_b @ (v + np.cross(o, geo.lever_arm_b)) for v, o in zip(v_b, w)])
    np.testing.assert_allclose(geo.beams_from_velocity(v_b, w), exact, atol=1e-14)
    np.testing.assert_allclose(geo.beams_from_velocity(v_b[0], w[0]), exact[0], atol=1e-14)


def test_model_refuses_inconsistent_dvl_error_arguments():
    T_b = DvlGeometry.from_spec(DvlSpec()).T_b
    with pytest.raises(ValueError, match="both"):
        BeamModel(T_b, np.arange(4))
    with pytest.raises(ValueError, match="0..3"):
        BeamModel(T_b, [0, 1, 2, 4], np.eye(3))
    with pytest.raises(ValueError, match="without"):
        BeamModel(T_b).predict(np.eye(3), np.ones(3), np.zeros(3), np.zeros(3), LEVER, np.zeros(7))
    with pytest.raises(ValueError, match="no DVL error states"):
        BeamModel(T_b).predict(np.eye(3), np.ones(3), np.zeros(3), np.zeros(3), LEVER).d_dvl_errors()


@pytest.mark.parametrize("dvl_errors", [False, True])
def test_factor_batch_and_ekf_predict_the_same_beams_and_jacobians(dvl_errors):
    """One state, three users of the model: the GTSAM factor (unit noise: linearize gives -residual and the
    Jacobians in GTSAM's tangent layout), the vectorised batch (one row per beam) and the EKF's H (its
    error-state convention: H_v = dh/dv, H_eps = dh/dtheta C^T, H_bg = dh/db_g, H_dvl = dh/dd)."""
    rng = np.random.default_rng(11)
    config = SensorConfig()
    config.dvl.C_d_b = gtsam.Rot3.RzRyRx(0.02, -0.03, 0.7).matrix()
    config.dvl.lever_arm_b = LEVER.copy()
    geo = DvlGeometry.from_spec(config.dvl)
    s = random_state(rng)
    C, v_n, omega, b_g, d = s["C_b_n"], s["v_n"], s["omega_b"], s["gyro_bias"], s["dvl_errors"]
    if not dvl_errors:
        d = np.zeros(7)
    y = rng.normal(0, 1, 4)
    beams = np.arange(4)

    # factor
    factor = dvl_factor(X(0), V(0), B(0), geo.T_b, y, np.ones(4), omega, geo.lever_arm_b,
                        **({"d_key": D(0), "beam_index": beams, "C_d_b": geo.C_d_b} if dvl_errors else {}))
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose3(gtsam.Rot3(C), rng.normal(0, 10, 3)))
    values.insert(V(0), v_n)
    values.insert(B(0), gtsam.imuBias.ConstantBias(rng.normal(0, 1e-3, 3), b_g))
    if dvl_errors:
        values.insert(D(0), d)
    A, b = factor.linearize(values).jacobian()
    h_factor = y - b
    J_rot_f, J_v_f, J_bg_f = A[:, 0:3], A[:, 6:9], A[:, 12:15]
    np.testing.assert_allclose(A[:, 3:6], 0.0, atol=0)               # no position dependence
    np.testing.assert_allclose(A[:, 9:12], 0.0, atol=0)              # no accelerometer-bias dependence

    # batch
    group = BeamGroup(0, geo.T_b, y, np.ones(4), None, omega, geo.lever_arm_b, False,
                      beams if dvl_errors else None, geo.C_d_b if dvl_errors else None)
    e, J_rot_b, J_v_b, J_bg_b, J_d_b = StackedBeams([group]).linearize(C[None], v_n[None], b_g[None],
                                                                        d[None] if dvl_errors else None)

    # EKF
    ekf = ErrorStateEkf(config, StrapdownState(0.0, C, v_n, np.zeros(3)),
                        EkfOptions(dvl_error_states=dvl_errors, lever_arm=True), bias_gyro=b_g)
    if dvl_errors:
        ekf.dvl_scale, ekf.beam_bias = d[:3].copy(), d[3:].copy()
    h_ekf, H = ekf.predicted_beams(omega)

    np.testing.assert_allclose(h_factor, e + y, atol=1e-12)
    np.testing.assert_allclose(h_ekf, e + y, atol=1e-12)
    for f, bt, ek in ((J_rot_f, J_rot_b, H[:, IE] @ C), (J_v_f, J_v_b, H[:, IV]), (J_bg_f, J_bg_b, H[:, IG])):
        np.testing.assert_allclose(f, bt, atol=1e-12)
        np.testing.assert_allclose(ek, bt, atol=1e-12)
    np.testing.assert_allclose(H[:, IA], 0.0, atol=0)
    if dvl_errors:
        np.testing.assert_allclose(A[:, 15:22], J_d_b, atol=1e-12)
        np.testing.assert_allclose(H[:, ekf.n_nav:], J_d_b, atol=1e-12)
    else:
        assert J_d_b is None and H.shape[1] == ekf.n_nav


@pytest.mark.parametrize("dvl_errors", [False, True])
def test_ekf_h_matches_a_numerical_derivative_in_its_own_error_convention(dvl_errors):
    """dz = h(x_hat) - h(x_true) ~= H dx with x_true = x_hat corrected by dx the way the filter corrects it
    (v -= dv, C = Exp(-eps) C, b -= db, s -= ds, bias -= dbias)."""
    rng = np.random.default_rng(3)
    config = SensorConfig()
    config.dvl.lever_arm_b = LEVER.copy()
    s = random_state(rng)
    ekf = ErrorStateEkf(config, StrapdownState(0.0, s["C_b_n"], s["v_n"], np.zeros(3)),
                        EkfOptions(dvl_error_states=dvl_errors, lever_arm=True), bias_gyro=s["gyro_bias"])
    if dvl_errors:
        ekf.dvl_scale, ekf.beam_bias = s["dvl_errors"][:3].copy(), s["dvl_errors"][3:].copy()
    omega = s["omega_b"]
    h0, H = ekf.predicted_beams(omega)
    numeric = np.zeros_like(H)
    for i in range(ekf.n_states):
        hs = []
        for sign in (1.0, -1.0):
            dx = np.zeros(ekf.n_states)
            dx[i] = sign * EPS
            e = ErrorStateEkf(config, StrapdownState(0.0, s["C_b_n"], s["v_n"], np.zeros(3)), ekf.options,
                              bias_gyro=s["gyro_bias"])
            e.dvl_scale, e.beam_bias = ekf.dvl_scale.copy(), ekf.beam_bias.copy()
            e.state.v_n = e.state.v_n - dx[IV]
            e.state.C_b_n = gtsam.Rot3.Expmap(-dx[IE]).matrix() @ e.state.C_b_n
            e.bias_gyro = e.bias_gyro - dx[IG]
            e.state.p_n = e.state.p_n - dx[IP]                # no beam depends on the position
            if dvl_errors:
                e.dvl_scale = e.dvl_scale - dx[e.i_scale]
                e.beam_bias = e.beam_bias - dx[e.i_bias]
            hs.append(e.predicted_beams(omega)[0])
        numeric[:, i] = -(hs[0] - hs[1]) / (2 * EPS)         # dz = h(x_hat) - h(x_true(dx))
    np.testing.assert_allclose(H, numeric, atol=1e-7)


def test_gyro_rate_at_a_ping_is_interpolated_between_the_imu_interval_centres():
    """IMU samples are mean rates over [t_k, t_k+1] (for a linear rate: the rate at the interval's centre), so
    a linear rate is recovered exactly at a ping between samples; the Keyframer's Ping carries that rate to
    the graph's keyframe and to the EKF."""
    config = SensorConfig()
    keyframer = kfs.Keyframer(config)
    rate = lambda t: np.array([0.1 * t, -0.2 * t, 0.05 + 0.3 * t])  # noqa: E731
    mean = lambda k: rate(0.01 * k + 0.005)  # noqa: E731
    for k in range(3):
        keyframer.add_imu(0.01 * k, (0.0, 0.0, -9.8), tuple(mean(k)))
    keyframer.start(0.0)
    out = keyframer.add_dvl(0.0237, np.ones(4), np.ones(4, bool))
    out += keyframer.add_dvl(0.0312, np.ones(4), np.ones(4, bool))   # before the centre of its interval
    for k in range(3, 6):
        out += keyframer.add_imu(0.01 * k, (0.0, 0.0, -9.8), tuple(mean(k)))
    pings = [kf.ping for kf in out if kf.ping is not None]
    assert [p.t for p in pings] == [0.0237, 0.0312]
    for p in pings:
        np.testing.assert_allclose(p.omega_b, rate(p.t), atol=1e-15)
    # edges: before the first centre, or a single sample -> held; later samples change nothing
    samples = [(0.01 * k, (0.0, 0.0, 0.0), tuple(mean(k))) for k in range(6)]
    np.testing.assert_array_equal(kfs.gyro_at(0.002, samples), mean(0))
    np.testing.assert_array_equal(kfs.gyro_at(-1.0, samples), mean(0))
    np.testing.assert_array_equal(kfs.gyro_at(0.5, samples[:1]), mean(0))
    np.testing.assert_array_equal(kfs.gyro_at(0.0312, samples[:5]), kfs.gyro_at(0.0312, samples))
    from graphnav.estimators.graph.builder import GraphContext, graph_keyframe
    from graphnav.estimators.graph.options import GraphOptions
    gkf = graph_keyframe(next(kf for kf in out if kf.ping is not None), GraphContext(config, GraphOptions()))
    np.testing.assert_array_equal(gkf.ping.omega_b, pings[0].omega_b)
