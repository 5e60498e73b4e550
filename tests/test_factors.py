"""DVL / depth factors: zero residual at the true state, analytic Jacobians == gtsam numerical derivatives."""
from __future__ import annotations

import gtsam
import numpy as np
import pytest
from graphnav.factors import (
    beam_factor,
    beam_factor_dvl_errors,
    beam_factor_lever_arm,
    body_velocity_factor,
    depth_factor,
    predict_beams,
)
from gtsam.symbol_shorthand import B, D, L, V, X
from gtsam.utils.numerical_derivative import (
    numericalDerivative41,
    numericalDerivative42,
    numericalDerivative43,
    numericalDerivative44,
)

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry

LEVER = np.array([-1.86, -0.04, 0.2])


def random_state(rng):
    pose = gtsam.Pose3(gtsam.Rot3.RzRyRx(*rng.uniform(-np.pi, np.pi, 3)), rng.normal(0, 50, 3))
    v_n = rng.normal(0, 1.5, 3)
    bias = gtsam.imuBias.ConstantBias(rng.normal(0, 1e-2, 3), rng.normal(0, 1e-2, 3))
    return pose, v_n, bias


def geometry(rng):
    C_d_b = gtsam.Rot3.RzRyRx(*rng.uniform(-0.2, 0.2, 3)).matrix()
    return DvlGeometry.from_spec(DvlSpec(C_d_b=C_d_b, lever_arm_b=LEVER))


def values_of(pose, v_n, bias, lever=None):
    values = gtsam.Values()
    values.insert(X(0), pose)
    values.insert(V(0), v_n)
    values.insert(B(0), bias)
    if lever is not None:
        values.insert(L(0), gtsam.Point3(lever))
    return values


def check_jacobians(factor, values, keys):
    """Whitened Jacobians of factor.linearize (through the C++ CustomFactor path) vs numerical ones."""
    linear = factor.linearize(values)
    A = linear.jacobian()[0]
    args = [values.atPose3(keys[0]), values.atVector(keys[1]), values.atConstantBias(keys[2])]
    if len(keys) == 4:
        args.append(values.atPoint3(keys[3]))
    else:
        args.append(np.zeros(1))   # dummy 4th argument so the 4-argument helpers work for both factors

    def h(x, v, b, extra):
        vals = values_of(x, v, b, extra if len(keys) == 4 else None)
        return factor.whitenedError(vals)

    numeric = [numericalDerivative41(h, *args), numericalDerivative42(h, *args),
               numericalDerivative43(h, *args)]
    if len(keys) == 4:
        numeric.append(numericalDerivative44(h, *args))
    np.testing.assert_allclose(A, np.hstack(numeric), atol=1e-6, rtol=1e-6)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("beams", [[0], [1, 3], [0, 1, 2, 3]])
def test_beam_factor_zero_residual_and_jacobians(seed, beams):
    rng = np.random.default_rng(seed)
    geo = geometry(rng)
    pose, v_n, bias = random_state(rng)
    omega = rng.normal(0, 0.2, 3)
    # the true measurement: beams of the DVL head, whose body rate is omega minus the gyro bias
    y_all = geo.beams_from_velocity(pose.rotation().matrix().T @ v_n, omega - bias.gyroscope())
    sigmas = rng.uniform(0.02, 0.3, len(beams))
    factor = beam_factor(X(0), V(0), B(0), geo.T_b[beams], y_all[beams], sigmas, omega, geo.lever_arm_b)
    values = values_of(pose, v_n, bias)
    np.testing.assert_allclose(factor.unwhitenedError(values), 0.0, atol=1e-12)
    check_jacobians(factor, values, [X(0), V(0), B(0)])
    # the residual is prediction minus measurement
    y_off = y_all[beams] + 0.1
    off = beam_factor(X(0), V(0), B(0), geo.T_b[beams], y_off, sigmas, omega, geo.lever_arm_b)
    np.testing.assert_allclose(off.unwhitenedError(values), -0.1, atol=1e-12)
    pred = predict_beams(geo.T_b[beams], pose.rotation().matrix(), v_n, omega, bias.gyroscope(),
                         geo.lever_arm_b)
    np.testing.assert_allclose(pred, y_all[beams], atol=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_body_velocity_factor(seed):
    rng = np.random.default_rng(seed)
    pose, v_n, bias = random_state(rng)
    omega = rng.normal(0, 0.2, 3)
    v_dvl_b = pose.rotation().matrix().T @ v_n + np.cross(omega - bias.gyroscope(), LEVER)
    factor = body_velocity_factor(X(0), V(0), B(0), v_dvl_b, np.full(3, 0.02), omega, LEVER)
    values = values_of(pose, v_n, bias)
    np.testing.assert_allclose(factor.unwhitenedError(values), 0.0, atol=1e-12)
    check_jacobians(factor, values, [X(0), V(0), B(0)])
    cov = np.diag([1e-4, 2e-4, 3e-4]) + 5e-5
    full = body_velocity_factor(X(0), V(0), B(0), v_dvl_b, gtsam.noiseModel.Gaussian.Covariance(cov),
                                omega, LEVER)
    check_jacobians(full, values, [X(0), V(0), B(0)])


@pytest.mark.parametrize("seed", range(3))
def test_lever_arm_variable_factor(seed):
    rng = np.random.default_rng(seed)
    geo = geometry(rng)
    pose, v_n, bias = random_state(rng)
    omega = rng.normal(0, 0.3, 3)
    y = geo.beams_from_velocity(pose.rotation().matrix().T @ v_n, omega - bias.gyroscope())
    factor = beam_factor_lever_arm(X(0), V(0), B(0), L(0), geo.T_b, y, np.full(4, 0.05), omega)
    values = values_of(pose, v_n, bias, geo.lever_arm_b)
    np.testing.assert_allclose(factor.unwhitenedError(values), 0.0, atol=1e-12)
    check_jacobians(factor, values, [X(0), V(0), B(0), L(0)])
    # a wrong lever arm gives a nonzero residual when the vehicle turns
    wrong = values_of(pose, v_n, bias, geo.lever_arm_b + np.array([0.5, 0.0, 0.0]))
    assert np.abs(factor.unwhitenedError(wrong)).max() > 1e-3


def test_lever_arm_is_recovered_by_optimisation():
    """With attitude, velocity and bias held by priors, beams over varied turn rates recover l_b."""
    rng = np.random.default_rng(7)
    geo = geometry(rng)
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    values.insert(L(0), gtsam.Point3(0.0, 0.0, 0.0))
    tight = gtsam.noiseModel.Isotropic.Sigma(6, 1e-6)
    for k in range(30):
        pose, v_n, bias = random_state(rng)
        omega = rng.normal(0, 0.3, 3)
        y = geo.beams_from_velocity(pose.rotation().matrix().T @ v_n, omega - bias.gyroscope())
        y += rng.normal(0, 0.002, 4)
        graph.add(beam_factor_lever_arm(X(k), V(k), B(k), L(0), geo.T_b, y, np.full(4, 0.002), omega))
        graph.add(gtsam.PriorFactorPose3(X(k), pose, tight))
        graph.add(gtsam.PriorFactorVector(V(k), v_n, gtsam.noiseModel.Isotropic.Sigma(3, 1e-6)))
        graph.add(gtsam.PriorFactorConstantBias(B(k), bias, tight))
        values.insert(X(k), pose)
        values.insert(V(k), v_n)
        values.insert(B(k), bias)
    result = gtsam.LevenbergMarquardtOptimizer(graph, values).optimize()
    np.testing.assert_allclose(result.atPoint3(L(0)), geo.lever_arm_b, atol=0.03)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("beams", [[2], [0, 3], [0, 1, 2, 3]])
def test_dvl_error_state_factor_zero_residual_and_jacobians(seed, beams):
    """Beams made with scale s and bias b (the EKF's model y = T_d[(1+s) v_d] + b): zero residual at the true
    (state, d); every Jacobian block, including the scale and bias columns, equals the numerical one."""
    rng = np.random.default_rng(100 + seed)
    geo = geometry(rng)
    pose, v_n, bias = random_state(rng)
    omega = rng.normal(0, 0.3, 3)
    d = np.r_[rng.normal(0, 0.02, 3), rng.normal(0, 0.05, 4)]
    v_head_b = geo.dvl_velocity_b(pose.rotation().matrix().T @ v_n, omega - bias.gyroscope())
    v_d = geo.C_d_b.T @ v_head_b
    y_all = geo.T_d @ ((1.0 + d[:3]) * v_d) + d[3:]
    sigmas = rng.uniform(0.02, 0.3, len(beams))
    factor = beam_factor_dvl_errors(X(0), V(0), B(0), D(0), geo.T_b[beams], beams, geo.C_d_b, y_all[beams],
                                    sigmas, omega, geo.lever_arm_b)
    values = values_of(pose, v_n, bias)
    values.insert(D(0), d)
    np.testing.assert_allclose(factor.unwhitenedError(values), 0.0, atol=1e-12)

    def h(x, v, b, dd):
        vals = values_of(x, v, b)
        vals.insert(D(0), dd)
        return factor.whitenedError(vals)

    args = [pose, v_n, bias, d]
    numeric = np.hstack([numericalDerivative41(h, *args), numericalDerivative42(h, *args),
                         numericalDerivative43(h, *args), numericalDerivative44(h, *args)])
    A = factor.linearize(values).jacobian()[0]
    np.testing.assert_allclose(A, numeric, atol=1e-6, rtol=1e-6)
    # with d = 0 the factor is the plain beam factor
    values.update(D(0), np.zeros(7))
    plain = beam_factor(X(0), V(0), B(0), geo.T_b[beams], y_all[beams], sigmas, omega, geo.lever_arm_b)
    np.testing.assert_allclose(factor.unwhitenedError(values), plain.unwhitenedError(values), atol=1e-12)
    with pytest.raises(ValueError, match="beam_index"):
        beam_factor_dvl_errors(X(0), V(0), B(0), D(0), geo.T_b[beams], [4] * len(beams), geo.C_d_b,
                               y_all[beams], sigmas, omega, geo.lever_arm_b)


def test_beam_factor_rejects_mismatched_sizes():
    with pytest.raises(ValueError):
        beam_factor(X(0), V(0), B(0), np.eye(3), np.zeros(2), np.ones(2), np.zeros(3), LEVER)


def test_depth_factor_observes_down_only():
    rng = np.random.default_rng(3)
    pose, _, _ = random_state(rng)
    factor = depth_factor(X(0), pose.translation()[2] + 0.3, 0.05, pose.translation()[:2])
    values = gtsam.Values()
    values.insert(X(0), pose)
    np.testing.assert_allclose(factor.unwhitenedError(values), [0.0, 0.0, -0.3], atol=1e-12)
    A = factor.linearize(values).jacobian()[0]
    h = lambda x: factor.whitenedError(_pose_values(x))   # noqa: E731
    from gtsam.utils.numerical_derivative import numericalDerivative11
    np.testing.assert_allclose(A, numericalDerivative11(h, pose), atol=1e-6)


def _pose_values(pose):
    values = gtsam.Values()
    values.insert(X(0), pose)
    return values


# --- model-aided motion priors (factors/motion.py) -------------------------------------------------------
def _numeric_jacobian(factor, values, keys):
    """Whitened Jacobian by central differences on each variable's tangent space (Pose3 / Vector3)."""
    cols = []
    for key in keys:
        is_pose = gtsam.Symbol(key).chr() == ord("x")
        for d in range(6 if is_pose else 3):
            delta = np.zeros(6 if is_pose else 3)
            delta[d] = 1e-6
            out = []
            for sign in (1.0, -1.0):
                vals = gtsam.Values(values)
                if is_pose:
                    vals.update(key, values.atPose3(key).retract(sign * delta))
                else:
                    vals.update(key, values.atVector(key) + sign * delta)
                out.append(factor.whitenedError(vals))
            cols.append((out[0] - out[1]) / 2e-6)
    return np.column_stack(cols)


@pytest.mark.parametrize("seed", range(4))
def test_motion_prior_factors_residual_and_jacobians(seed):
    from graphnav.factors import body_velocity_change_factor, nonholonomic_factor
    rng = np.random.default_rng(seed)
    pose_i, v_i, _ = random_state(rng)
    pose_j, v_j, _ = random_state(rng)
    values = gtsam.Values()
    for k, (p, v) in enumerate(((pose_i, v_i), (pose_j, v_j))):
        values.insert(X(k), p)
        values.insert(V(k), v)
    v_bi = pose_i.rotation().matrix().T @ v_i
    v_bj = pose_j.rotation().matrix().T @ v_j
    nhc = nonholonomic_factor(X(0), V(0), [0.05, 0.02])
    np.testing.assert_allclose(nhc.unwhitenedError(values), v_bi[1:], atol=1e-12)
    np.testing.assert_allclose(nhc.linearize(values).jacobian()[0],
                               _numeric_jacobian(nhc, values, [X(0), V(0)]), atol=1e-5)
    # a mean equal to the true body velocity gives a zero residual
    zero = nonholonomic_factor(X(1), V(1), 0.1, axes=(0, 1, 2), mean=v_bj)
    np.testing.assert_allclose(zero.unwhitenedError(values), 0.0, atol=1e-12)
    change = body_velocity_change_factor(X(0), V(0), X(1), V(1), [0.1, 0.03, 0.03])
    np.testing.assert_allclose(change.unwhitenedError(values), v_bj - v_bi, atol=1e-12)
    np.testing.assert_allclose(change.linearize(values).jacobian()[0],
                               _numeric_jacobian(change, values, [X(0), V(0), X(1), V(1)]), atol=1e-5)
    with pytest.raises(ValueError):
        nonholonomic_factor(X(0), V(0), [0.0, 0.1])


def test_heading_variance_matches_a_sampled_attitude_cloud():
    """heading_variance (the yaw Jacobian of a right perturbation) against the spread of yaw over attitudes
    drawn from the body-frame covariance, at a pitched and rolled attitude."""
    from graphnav.core.rotations import C_b_n_to_euler, euler_to_C_b_n, heading_variance, so3_exp_batch
    rng = np.random.default_rng(3)
    C = np.asarray(euler_to_C_b_n(np.deg2rad(12.0), np.deg2rad(-25.0), np.deg2rad(140.0))).reshape(3, 3)
    A = rng.normal(size=(3, 3)) * 1e-3
    cov = A @ A.T
    theta = rng.multivariate_normal(np.zeros(3), cov, size=20000)
    yaw = C_b_n_to_euler(C[None] @ so3_exp_batch(theta))[:, 2]
    yaw0 = C_b_n_to_euler(C)[2]
    d = np.remainder(yaw - yaw0 + np.pi, 2 * np.pi) - np.pi
    assert float(heading_variance(C, cov)) == pytest.approx(float(np.var(d)), rel=0.05)


# --- serially correlated beams: the whitened difference of two keyframes (factors/dvl.py) ---------------------
def _numeric_jacobian_any(factor, values, keys):
    """Whitened Jacobian by central differences on each variable's tangent space (Pose3, ConstantBias, Vector)."""
    cols = []
    for key in keys:
        kind = chr(gtsam.Symbol(key).chr())
        base = {"x": values.atPose3, "b": values.atConstantBias}.get(kind, values.atVector)(key)
        dim = 6 if kind in "xb" else len(base)
        for d in range(dim):
            delta = np.zeros(dim)
            delta[d] = 1e-6
            out = []
            for sign in (1.0, -1.0):
                vals = gtsam.Values(values)
                vals.update(key, base.retract(sign * delta) if kind in "xb" else base + sign * delta)
                out.append(factor.whitenedError(vals))
            cols.append((out[0] - out[1]) / 2e-6)
    return np.column_stack(cols)


@pytest.mark.parametrize("seed,with_d", [(0, False), (1, True), (2, True)])
def test_beam_difference_factor_residual_and_jacobians(seed, with_d):
    """The whitened difference of two pings' beams: residual (h_k - phi h_k-1) - (y_k - phi y_k-1) from the one beam
    model, every Jacobian block equal to central differences, and with phi = 0 the plain factor at keyframe k."""
    from graphnav.core.beam_model import BeamModel
    from graphnav.factors import beam_difference_factor
    rng = np.random.default_rng(seed)
    geo = geometry(rng)
    beams = np.array([0, 2, 3])
    rows = geo.T_b[beams]
    values = gtsam.Values()
    states, omegas, ds = [], [rng.normal(0, 0.1, 3) for _ in range(2)], []
    for k in range(2):
        pose, v_n, bias = random_state(rng)
        d = np.r_[rng.normal(0, 0.01, 3), rng.normal(0, 0.02, 4)]
        values.insert(X(k), pose)
        values.insert(V(k), v_n)
        values.insert(B(k), bias)
        if with_d:
            values.insert(D(k), d)
        states.append((pose, v_n, bias))
        ds.append(d)
    model = BeamModel(rows, beams, geo.C_d_b) if with_d else BeamModel(rows)
    h = [model.predict(s[0].rotation().matrix(), s[1], omegas[k], s[2].gyroscope(), LEVER,
                       ds[k] if with_d else None).h for k, s in enumerate(states)]
    y_prev, y = rng.normal(0, 1, 3), rng.normal(0, 1, 3)
    keys = [(X(k), V(k), B(k)) + ((D(k),) if with_d else ()) for k in range(2)]
    extra = {"beam_index": beams, "C_d_b": geo.C_d_b} if with_d else {}
    phi, sigmas = 0.93, np.array([0.02, 0.03, 0.05])
    f = beam_difference_factor(keys[0], keys[1], rows, y_prev, y, phi, sigmas, omegas[0], omegas[1], LEVER, **extra)
    np.testing.assert_allclose(f.unwhitenedError(values), (h[1] - phi * h[0]) - (y - phi * y_prev), atol=1e-12)
    all_keys = [*keys[0], *keys[1]]
    np.testing.assert_allclose(f.linearize(values).jacobian()[0], _numeric_jacobian_any(f, values, all_keys),
                               rtol=1e-5, atol=1e-4)
    # phi = 0: the plain beam factor of keyframe k, nothing on keyframe k-1
    plain = beam_difference_factor(keys[0], keys[1], rows, y_prev, y, 0.0, sigmas, omegas[0], omegas[1], LEVER,
                                   **extra)
    single = (beam_factor_dvl_errors(*keys[1], rows, beams, geo.C_d_b, y, sigmas, omegas[1], LEVER) if with_d
              else beam_factor(*keys[1], rows, y, sigmas, omegas[1], LEVER))
    np.testing.assert_allclose(plain.unwhitenedError(values), single.unwhitenedError(values), atol=1e-12)
    A = plain.linearize(values).jacobian()[0]
    n_prev = sum(6 if chr(gtsam.Symbol(k).chr()) in "xb" else 3 if chr(gtsam.Symbol(k).chr()) == "v" else 7
                 for k in keys[0])
    np.testing.assert_allclose(A[:, :n_prev], 0.0, atol=1e-12)
    np.testing.assert_allclose(A[:, n_prev:], single.linearize(values).jacobian()[0], atol=1e-9)
    with pytest.raises(ValueError):
        beam_difference_factor(keys[0], keys[1][:3] if with_d else keys[1] + (D(1),), rows, y_prev, y, phi, sigmas,
                               omegas[0], omegas[1], LEVER, **extra)


def test_beam_difference_chain_is_the_gauss_markov_likelihood():
    """A plain factor at the first ping and whitened differences after it give, at any states, the Mahalanobis
    distance of the beam errors under the Gauss-Markov covariance cov(e_i, e_j) = phi^|i-j| s_min(i,j)^2 (a
    sigma growing through the run, as a completer's does): the chain is that likelihood, not an approximation."""
    from graphnav.factors import beam_difference_factor
    rng = np.random.default_rng(7)
    geo = geometry(rng)
    rows = geo.T_b[[1, 2]]
    n, phi = 6, 0.9
    sigma = 0.05 + 0.01 * np.arange(n)              # the completer's sigma, growing through the run
    values, omegas, e = gtsam.Values(), [], []
    y = rng.normal(0, 1, (n, 2))
    for k in range(n):
        pose, v_n, bias = random_state(rng)
        for key, val in ((X(k), pose), (V(k), v_n), (B(k), bias)):
            values.insert(key, val)
        omegas.append(rng.normal(0, 0.1, 3))
        e.append(predict_beams(rows, pose.rotation().matrix(), v_n, omegas[k], bias.gyroscope(), LEVER) - y[k])
    graph = gtsam.NonlinearFactorGraph()
    graph.add(beam_factor(X(0), V(0), B(0), rows, y[0], np.full(2, sigma[0]), omegas[0], LEVER))
    for k in range(1, n):
        s_w = np.sqrt(sigma[k] ** 2 - phi ** 2 * sigma[k - 1] ** 2)
        graph.add(beam_difference_factor((X(k - 1), V(k - 1), B(k - 1)), (X(k), V(k), B(k)), rows, y[k - 1], y[k],
                                         phi, np.full(2, s_w), omegas[k - 1], omegas[k], LEVER))
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    cov = phi ** np.abs(i - j) * sigma[np.minimum(i, j)] ** 2
    e = np.array(e)
    expected = sum(e[:, b] @ np.linalg.solve(cov, e[:, b]) for b in range(2))
    assert 2 * graph.error(values) == pytest.approx(expected, rel=1e-10)
