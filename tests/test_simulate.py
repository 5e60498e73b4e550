"""The simulator: determinism, injected IMU error statistics, and consistency of the IMU with the ground truth."""
from __future__ import annotations

import dataclasses
import warnings

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphnav.core.config import ImuSpec, SensorConfig, imu_grade
from graphnav.core.dvl import DvlGeometry
from graphnav.core.errors import ConfigError
from graphnav.core.earth import EarthModel, gravity_magnitude
from graphnav.estimators.graph.builder import preintegration_gravity
from graphnav.core.mission import ImuData
from graphnav.core.rotations import C_b_n_to_euler, attitude_error
from graphnav.sim.imu_errors import corrupt_imu
from graphnav.sim.simulate import DEFAULT_LEVER_ARM_B, START_DEPTH_M, SmoothSteps, simulate_mission

DEG = np.pi / 180


@pytest.fixture(scope="module")
def noiseless():
    return simulate_mission(400.0, noiseless=True, seed=0)


@pytest.fixture(scope="module")
def noiseless_no_earth_rate():
    config = SensorConfig(earth_rotation=False, lat_rad=32.85 * DEG, gravity_mps2=gravity_magnitude(32.85 * DEG))
    return simulate_mission(400.0, noiseless=True, seed=0, config=config)


# --- determinism and shape of the mission ------------------------------------------------------------

def test_same_seed_same_mission_other_seed_other_mission():
    a = simulate_mission(60.0, "tactical", seed=5, dropout=True)
    b = simulate_mission(60.0, "tactical", seed=5, dropout=True)
    c = simulate_mission(60.0, "tactical", seed=6, dropout=True)
    for x, y in [(a.imu.f_b, b.imu.f_b), (a.imu.omega_b, b.imu.omega_b), (a.dvl.beams, b.dvl.beams),
                 (a.dvl.valid, b.dvl.valid), (a.gt.p_n, b.gt.p_n), (a.depth.depth, b.depth.depth)]:
        np.testing.assert_array_equal(x, y)
    assert not np.allclose(a.imu.f_b, c.imu.f_b)
    assert a.name == "sim-60s-tactical-seed5-dropout"


def test_noiseless_keeps_the_trajectory_of_its_seed(noiseless):
    noisy = simulate_mission(400.0, seed=0)
    np.testing.assert_array_equal(noisy.gt.p_n, noiseless.gt.p_n)
    assert noisy.meta["imu_errors"] is not None and noiseless.meta["imu_errors"] is None


def test_mission_has_the_advertised_shape(noiseless):
    m = noiseless
    assert m.imu.t[-1] == pytest.approx(400.0) and len(m.imu.t) == 40001
    assert np.allclose(np.diff(m.imu.t), 0.01) and np.allclose(np.diff(m.dvl.t), 1.0)
    assert np.allclose(np.diff(m.gt.t), 0.1) and np.allclose(np.diff(m.depth.t), 0.1)
    assert np.isin(m.dvl.t, m.imu.t).all() and np.isin(m.gt.t, m.imu.t).all()
    depth = m.gt.p_n[:, 2]
    assert depth[0] == pytest.approx(2.0) and 20.0 < depth.max() < 35.0
    euler = C_b_n_to_euler(m.gt.C_b_n)
    assert -20.5 * DEG < euler[:, 1].min() < -14 * DEG                 # nose-down descent
    assert 1.5 * DEG < np.abs(euler[:, 0]).max() < 8 * DEG             # roll oscillation of a few degrees
    speed = np.linalg.norm(m.gt.v_n, axis=1)
    assert speed.min() > 1.0 and speed.max() < 2.5
    yaw_rate = np.abs(m.meta["trajectory"].state(m.gt.t).omega_nb_b[:, 2])
    assert 0.05 < yaw_rate.max() <= 0.105                                # turns happen, and are not violent
    assert np.ptp(np.unwrap(euler[:, 2])) > np.pi / 2                   # at least one lawnmower turn
    cfg = m.config
    assert cfg.lat_rad == pytest.approx(32.85 * DEG) and cfg.gravity_mps2 == pytest.approx(
        gravity_magnitude(32.85 * DEG))
    np.testing.assert_allclose(cfg.dvl.lever_arm_b, DEFAULT_LEVER_ARM_B)
    assert cfg.imu == imu_grade("navigation")


def test_long_mission_keeps_its_envelope():
    m = simulate_mission(1800.0, "mems", seed=2, gt_rate_hz=1.0)
    assert len(m.gt.t) == 1801
    depth = m.gt.p_n[:, 2]
    assert depth[60:].min() > 10.0 and depth.max() < 40.0
    speed = np.linalg.norm(m.gt.v_n, axis=1)
    assert speed.min() > 1.0 and speed.max() < 2.5
    turns = np.abs(np.diff(np.unwrap(C_b_n_to_euler(m.gt.C_b_n)[:, 2])))
    assert turns.sum() > 8 * np.pi / 2                                  # keeps turning: a survey, not a line


@pytest.mark.slow
def test_four_hour_mission():
    m = simulate_mission(4 * 3600.0, "tactical", seed=3)
    assert len(m.imu.t) == 4 * 3600 * 100 + 1
    assert 10.0 < m.gt.p_n[600:, 2].min() and m.gt.p_n[:, 2].max() < 40.0


def test_smooth_steps_derivatives_match_finite_differences():
    steps = SmoothSteps()
    steps.add(1.0, 3.0, 2.0)
    steps.add(2.0, 1.5, -1.0)
    t = np.linspace(0.0, 6.0, 6001)
    value, rate, acc = steps.evaluate(t)
    assert value[0] == 0.0 and value[-1] == pytest.approx(1.0)
    np.testing.assert_allclose(np.gradient(value, t), rate, atol=1e-5)
    # the third derivative jumps at step edges, where central differences of the rate are off by ~5e-3
    np.testing.assert_allclose(np.gradient(rate, t), acc, atol=1e-2)


def test_invalid_arguments_raise():
    from graphnav.core.errors import ConfigError
    with pytest.raises(ConfigError):
        simulate_mission(0.0)
    with pytest.raises(ConfigError):
        simulate_mission(10.0, "consumer")
    with pytest.raises(ConfigError):
        simulate_mission(10.0, gt_rate_hz=3.0)


# --- IMU error injection -----------------------------------------------------------------------------

def _still_imu(n: int, rate: float) -> ImuData:
    t = np.arange(n) / rate
    return ImuData(t, np.zeros((n, 3)), np.zeros((n, 3)))


def test_white_noise_matches_density():
    rate = 100.0
    spec = ImuSpec(accel_noise_density=1e-3, gyro_noise_density=2e-4, accel_bias_rw=0.0, gyro_bias_rw=0.0,
                   accel_bias_sigma=0.0, gyro_bias_sigma=0.0)
    imu, truth = corrupt_imu(_still_imu(40000, rate), spec, seed=1)
    # 120 000 samples per sensor: the sample std is within ~0.4 % (1 sigma) of the true one.
    assert np.std(imu.f_b) == pytest.approx(1e-3 * np.sqrt(rate), rel=0.02)
    assert np.std(imu.omega_b) == pytest.approx(2e-4 * np.sqrt(rate), rel=0.02)
    assert np.all(truth.bias_acc == 0.0) and np.all(truth.bias_gyro == 0.0)


def test_bias_random_walk_and_turn_on_bias_statistics():
    rate = 50.0
    spec = ImuSpec(accel_noise_density=1e-3, gyro_noise_density=1e-4, accel_bias_rw=3e-4, gyro_bias_rw=2e-6,
                   accel_bias_sigma=0.02, gyro_bias_sigma=1e-4)
    steps_acc, steps_gyro, b0_acc, b0_gyro = [], [], [], []
    for seed in range(200):
        imu, truth = corrupt_imu(_still_imu(200, rate), spec, seed=seed)
        steps_acc.append(np.diff(truth.bias_acc, axis=0))
        steps_gyro.append(np.diff(truth.bias_gyro, axis=0))
        b0_acc.append(truth.bias_acc[0])
        b0_gyro.append(truth.bias_gyro[0])
        # measured = true (zero) + bias + white noise
        np.testing.assert_allclose(np.std(imu.f_b - truth.bias_acc), 1e-3 * np.sqrt(rate), rtol=0.2)
    dt = 1.0 / rate
    assert np.std(steps_acc) == pytest.approx(3e-4 * np.sqrt(dt), rel=0.03)
    assert np.std(steps_gyro) == pytest.approx(2e-6 * np.sqrt(dt), rel=0.03)
    # 600 turn-on draws: std within ~3 % (1 sigma) of the spec.
    assert np.std(b0_acc) == pytest.approx(0.02, rel=0.12)
    assert np.std(b0_gyro) == pytest.approx(1e-4, rel=0.12)
    assert abs(np.mean(b0_acc)) < 4 * 0.02 / np.sqrt(600)


def test_simulated_imu_errors_are_the_grade_errors(noiseless):
    noisy = simulate_mission(400.0, "tactical", seed=0)
    truth = noisy.meta["imu_errors"]
    residual = noisy.imu.omega_b - noiseless.imu.omega_b - truth.bias_gyro
    spec = imu_grade("tactical")
    assert np.std(residual) == pytest.approx(spec.gyro_noise_density * 10.0, rel=0.02)
    residual = noisy.imu.f_b - noiseless.imu.f_b - truth.bias_acc
    assert np.std(residual) == pytest.approx(spec.accel_noise_density * 10.0, rel=0.02)


# --- the IMU is consistent with the ground truth -----------------------------------------------------

def _integrate_with_gtsam(mission, stride: int = 10):
    """Preintegrate ``stride`` samples at a time from the GT initial state; states at the GT stamps.

    Each preintegration gets the Earth model's gravity at the middle of its stretch (predicted from the state
    at its start), as the graph estimators do."""
    cfg = mission.config
    earth = EarthModel.from_config(cfg)
    gt, imu = mission.gt, mission.imu
    state = gtsam.NavState(gtsam.Rot3(gt.C_b_n[0]), gt.p_n[0], gt.v_n[0])
    bias = gtsam.imuBias.ConstantBias()
    states = [state]
    for k0 in range(0, len(imu.t) - stride, stride):
        params = gtsam.PreintegrationParams.MakeSharedD(cfg.gravity_mps2)
        params.setOmegaCoriolis(earth.omega_ie_n)
        # use2ndOrderCoriolis stays at its default, False (the shared conventions; no Python setter)
        stretch = imu.t[k0 + stride] - imu.t[k0]
        params.n_gravity = preintegration_gravity(earth, state.position(), state.velocity(), stretch)
        pim = gtsam.PreintegratedImuMeasurements(params, bias)
        for k in range(k0, k0 + stride):
            pim.integrateMeasurement(imu.f_b[k], imu.omega_b[k], imu.t[k + 1] - imu.t[k])
        state = pim.predict(state, bias)
        states.append(state)
    C = np.array([s.attitude().matrix() for s in states])
    return C, np.array([s.velocity() for s in states]), np.array([s.position() for s in states])


def _errors(mission, C, v, p):
    gt = mission.gt
    att = np.rad2deg(np.linalg.norm(attitude_error(C, gt.C_b_n), axis=1))
    return att.max(), np.linalg.norm(v - gt.v_n, axis=1).max(), np.linalg.norm(p - gt.p_n, axis=1).max()


def test_noiseless_imu_integrates_onto_ground_truth_without_earth_rate(noiseless_no_earth_rate):
    # Increment-type samples held over [t_k, t_k+1] are exactly what GTSAM's preintegration assumes, so
    # the only errors left are quadrature and float round-off (measured: 4e-8 deg, 8e-7 m/s, 2e-4 m).
    att, vel, pos = _errors(noiseless_no_earth_rate, *_integrate_with_gtsam(noiseless_no_earth_rate))
    assert att < 1e-6 and vel < 1e-5 and pos < 2e-3


def test_noiseless_imu_integrates_onto_ground_truth_with_gtsam(noiseless):
    # With Earth rotation, the inertially frozen sample axes (what an IMU integrates and GTSAM's preintegration
    # assumes) and each stretch's gravity from the Earth model (with GTSAM's centrifugal term undone,
    # preintegration_gravity), GTSAM 4.3 stays on the truth: measured 7.8e-7 m/s, 1.3e-4 m after 400 s,
    # attitude 2e-8 deg. Before (NED-frozen sample axes, constant gravity, GTSAM's centrifugal term left in)
    # the same check drifted 1.2 mm/s and 0.23 m.
    att, vel, pos = _errors(noiseless, *_integrate_with_gtsam(noiseless))
    assert att < 1e-5 and vel < 1e-5 and pos < 2e-3


def test_mission_far_from_the_origin_integrates_as_well_as_at_it():
    """22 km from the origin gravity is tilted by 0.2 deg (0.034 m/s^2 horizontal) and the tangent plane is 39 m
    above the sea: the simulated IMU and depth follow it, and GTSAM with the Earth model's gravity integrates
    onto the truth exactly as at the origin (measured: 7.8e-7 m/s, 1.3e-4 m in both places)."""
    far = simulate_mission(100.0, noiseless=True, seed=4, start_ne_m=(20000.0, 10000.0))
    near = simulate_mission(100.0, noiseless=True, seed=4)
    earth = EarthModel.from_config(far.config)
    # the start is on the sea's curve: 2 m deep, 41 m below the tangent plane
    drop = -float(earth.depth_of(far.gt.p_n[0] * [1.0, 1.0, 0.0]))
    assert 39.0 < drop < 40.0 and far.gt.p_n[0, 2] == pytest.approx(START_DEPTH_M + drop, abs=1e-3)
    assert far.depth.depth[0] == pytest.approx(START_DEPTH_M, abs=1e-6)
    errors_far = _errors(far, *_integrate_with_gtsam(far))
    errors_near = _errors(near, *_integrate_with_gtsam(near))
    assert errors_far[1] < 1e-5 and errors_far[2] < 1e-3
    assert errors_far[1] < 2 * errors_near[1] + 1e-7


def _integrate_exactly(mission):
    """Strapdown integration that follows the increment convention with Earth rotation exactly.

    ``C_{k+1} = Exp(-omega_ie dt) C_k Exp(omega_k dt)``; ``v_{k+1} = v_k + Exp(-omega_ie dt / 2) C_k f_k dt
    + g(p_k) dt - 2 omega_ie x (trapezoid of v) dt`` (the sample's axes are frozen in inertial space: half the
    Earth's turn over the step, on average); ``p`` by the trapezoid rule. Truncation errors are O(dt^2).
    """
    cfg = mission.config
    imu, gt = mission.imu, mission.gt
    dt = 0.01
    earth = EarthModel.from_config(cfg)
    w_ie = earth.omega_ie_n
    half_turn = Rotation.from_rotvec(-w_ie * dt / 2).as_matrix()
    earth_step = Rotation.from_rotvec(-w_ie * dt).as_matrix()
    body_steps = Rotation.from_rotvec(imu.omega_b * dt).as_matrix()
    C, v, p = gt.C_b_n[0].copy(), gt.v_n[0].copy(), gt.p_n[0].copy()
    out_C, out_v, out_p = [C], [v], [p]
    for k in range(len(imu.t) - 1):
        dv_specific = half_turn @ C @ imu.f_b[k] * dt + earth.gravity_n(p) * dt
        v_pred = v + dv_specific - 2 * np.cross(w_ie, v) * dt
        v_new = v + dv_specific - np.cross(w_ie, v + v_pred) * dt
        p = p + 0.5 * (v + v_new) * dt
        v = v_new
        C = earth_step @ C @ body_steps[k]
        if (k + 1) % 10 == 0:
            out_C.append(C)
            out_v.append(v)
            out_p.append(p)
    return np.array(out_C), np.array(out_v), np.array(out_p)


def test_noiseless_imu_integrates_onto_ground_truth_with_earth_rate(noiseless):
    # Independent of GTSAM: the exact increment integration stays on the truth over the whole 400 s
    # (measured: 2e-10 deg, 2e-6 m/s, 4e-4 m; the simulator interpolates its gravity track over 1 s).
    att, vel, pos = _errors(noiseless, *_integrate_exactly(noiseless))
    assert att < 1e-6 and vel < 1e-5 and pos < 1e-3


# --- DVL and depth -----------------------------------------------------------------------------------

def test_noiseless_beams_are_the_body_velocity_plus_lever_arm(noiseless):
    m = noiseless
    geometry = DvlGeometry.from_spec(m.config.dvl)
    idx = np.searchsorted(m.gt.t, m.dvl.t)
    v_b = m.gt.v_b[idx]
    omega_nb = m.meta["trajectory"].state(m.dvl.t).omega_nb_b
    expected = (v_b + np.cross(omega_nb, geometry.lever_arm_b)) @ geometry.T_b.T
    np.testing.assert_allclose(m.dvl.beams, expected, atol=1e-12)
    np.testing.assert_allclose(m.dvl.v_b - np.cross(omega_nb, geometry.lever_arm_b), v_b, atol=1e-12)
    # The gyro (an increment over the next 10 ms, Earth rate included) gives the lever-arm term to < 1 mm/s.
    k = np.searchsorted(m.imu.t, m.dvl.t)
    np.testing.assert_allclose(m.dvl.v_b - np.cross(m.imu.omega_b[k], geometry.lever_arm_b), v_b, atol=1e-3)
    lever_term = np.linalg.norm(np.cross(omega_nb, geometry.lever_arm_b), axis=1)
    assert lever_term.max() > 0.1      # the lever arm matters in turns (as on the real vehicle)
    # the depth sensor reads the pressure depth: the tangent plane's down less the curvature drop (2 mm at 270 m)
    earth = EarthModel.from_config(m.config)
    np.testing.assert_allclose(m.depth.depth, earth.depth_of(m.gt.p_n), atol=1e-9)
    drop = m.gt.p_n[:, 2] - m.depth.depth
    np.testing.assert_allclose(drop, np.sum(m.gt.p_n[:, :2] ** 2, axis=1) / (2 * 6.37e6), rtol=0.01, atol=1e-8)


def test_dvl_and_depth_errors_follow_the_config(noiseless):
    noisy = simulate_mission(400.0, seed=0)
    geometry = DvlGeometry.from_spec(noisy.config.dvl)
    spec = noisy.config.dvl
    v_head_b = noiseless.dvl.v_b
    clean_with_scale = ((v_head_b @ geometry.C_d_b) * (1 + spec.scale_factor)) @ geometry.T_d.T
    residual = noisy.dvl.beams - clean_with_scale - spec.beam_bias
    # 1604 residuals: mean within 4 sigma of 0, std within 10 % of the configured noise.
    assert abs(residual.mean()) < 4 * spec.beam_noise_std / np.sqrt(residual.size)
    assert residual.std() == pytest.approx(spec.beam_noise_std, rel=0.1)
    depth_noise = noisy.depth.depth - noiseless.depth.depth
    assert depth_noise.std() == pytest.approx(noisy.config.depth_noise_std, rel=0.1)


def test_drawn_dvl_errors_are_drawn_per_seed_from_the_priors_sigmas(noiseless):
    """``dvl_errors="drawn"``: each seed its own beam biases and scale factors, about the configuration's values in
    size; the beams are made with them (the same residual check as above) while the configuration keeps the given
    values the estimators' priors come from; the default mission is unchanged by the option's stream."""
    draws = [simulate_mission(400.0, seed=s, dvl_errors="drawn") for s in (0, 1)]
    spec = noiseless.config.dvl
    biases = np.array([m.meta["dvl_errors"]["beam_bias"] for m in draws])
    assert not np.allclose(biases[0], biases[1]) and np.ptp(biases[0]) > 0      # not four equal biases
    pooled = np.r_[biases.ravel() / spec.beam_bias[0],
                   np.ravel([m.meta["dvl_errors"]["scale_factor"] for m in draws]) / spec.scale_factor[0]]
    assert 0.3 < np.std(pooled) < 2.0                                            # 14 draws of unit sigma
    m = draws[0]
    assert np.array_equal(m.config.dvl.beam_bias, spec.beam_bias) and "dvlerrorsdrawn" in m.name
    geometry = DvlGeometry.from_spec(m.config.dvl)
    truth = m.meta["dvl_errors"]
    clean = ((noiseless.dvl.v_b @ geometry.C_d_b) * (1 + truth["scale_factor"])) @ geometry.T_d.T
    residual = m.dvl.beams - clean - truth["beam_bias"]
    assert abs(residual.mean()) < 4 * spec.beam_noise_std / np.sqrt(residual.size)
    default = simulate_mission(400.0, seed=0)
    assert np.array_equal(default.meta["dvl_errors"]["beam_bias"], spec.beam_bias)
    assert np.array_equal(default.imu.f_b, m.imu.f_b)             # the draws' own stream: the IMU errors stay
    with pytest.raises(ConfigError, match="dvl_errors"):
        simulate_mission(10.0, dvl_errors="random")


def test_dropout_sets_invalid_beams_to_nan():
    m = simulate_mission(300.0, seed=4, dropout=True)
    assert (~m.dvl.valid).any() and m.dvl.valid.any()
    assert np.isnan(m.dvl.beams[~m.dvl.valid]).all() and np.isfinite(m.dvl.beams[m.dvl.valid]).all()
    few = m.dvl.n_valid < 3
    assert np.isnan(m.dvl.v_b[few]).all() and np.isfinite(m.dvl.v_b[~few]).all()


def test_config_is_respected_and_not_mutated():
    config = SensorConfig()
    config.dvl.C_d_b = Rotation.from_euler("z", 2.0, degrees=True).as_matrix()
    config.imu_rate_hz = 200.0
    before = config.to_dict()
    m = simulate_mission(20.0, "mems", seed=1, config=config, lever_arm_b=(1.0, 0.0, 0.5), noiseless=True)
    assert config.to_dict() == before
    assert len(m.imu.t) == 4001 and m.config.imu.name == "mems"
    np.testing.assert_allclose(m.config.dvl.lever_arm_b, [1.0, 0.0, 0.5])
    geometry = DvlGeometry.from_spec(m.config.dvl)
    omega_nb = m.meta["trajectory"].state(m.dvl.t).omega_nb_b
    v_b = m.gt.v_b[np.searchsorted(m.gt.t, m.dvl.t)]
    np.testing.assert_allclose(m.dvl.beams, geometry.beams_from_velocity(v_b, omega_nb), atol=1e-12)
    assert dataclasses.asdict(m.config.imu) == dataclasses.asdict(imu_grade("mems"))


# --- CLI and export in the published layout -----------------------------------------------------------

def test_cli_writes_the_akit_layout_and_a_plot(tmp_path, capsys):
    from graphnav.cli import main
    assert main(["simulate", "--duration", "30", "--seed", "1", "--dropout", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert "sim-30s-navigation-seed1-dropout" in printed and "max yaw rate" in printed
    folder = tmp_path / "Trajectory1"
    for kind in ("IMU", "DVL", "GT"):
        assert (folder / f"{kind}_trajectory1.csv").is_file()
    assert (tmp_path / "trajectory1.png").stat().st_size > 10_000
    assert SensorConfig.load(folder / "config_trajectory1.json").imu.name == "navigation"
    # drawn DVL errors: the written configuration keeps the paper's values (the estimators' prior sigmas)
    assert main(["simulate", "--duration", "30", "--dvl-errors", "drawn", "--out", str(tmp_path / "drawn")]) == 0
    assert "dvlerrorsdrawn" in capsys.readouterr().out
    written = SensorConfig.load(tmp_path / "drawn" / "Trajectory1" / "config_trajectory1.json")
    assert np.allclose(written.dvl.beam_bias, 0.01) and np.allclose(written.dvl.scale_factor, 0.007)


def test_written_headers_are_the_published_ones(tmp_path, akit_dir):
    from graphnav.io.export import write_akit
    write_akit(simulate_mission(5.0, seed=0), tmp_path, number=7)
    real = akit_dir / "Trajectory1"
    for kind in ("IMU", "DVL", "GT"):
        ours = (tmp_path / "Trajectory7" / f"{kind}_trajectory7.csv").read_text().splitlines()[0]
        theirs = (real / f"{kind}_trajectory1.csv").read_text().splitlines()[0]
        assert ours == theirs


def test_written_mission_loads_back(tmp_path):
    missions = pytest.importorskip("graphnav.missions")
    from graphnav.io.export import write_akit
    sim = simulate_mission(60.0, seed=2, noiseless=True)
    write_akit(sim, tmp_path)
    # imu_position_b=0: the simulated GT is already at the IMU point (the A-KIT default moves it there)
    back = missions.load_akit(tmp_path / "Trajectory1", imu_axis_signs=(1, 1, 1), dvl_time_offset_s=0.0,
                              gt_time_offset_s=0.0, rescale_stamps=False, imu_position_b=(0, 0, 0))
    np.testing.assert_allclose(back.imu.t, sim.imu.t, atol=1e-12)
    np.testing.assert_allclose(back.imu.f_b, sim.imu.f_b, atol=1e-12)
    np.testing.assert_allclose(back.imu.omega_b, sim.imu.omega_b, atol=1e-15)
    np.testing.assert_allclose(back.dvl.v_b, sim.dvl.v_b, atol=1e-12)
    np.testing.assert_allclose(back.gt.v_n, sim.gt.v_n, atol=1e-12)
    np.testing.assert_allclose(back.gt.C_b_n, sim.gt.C_b_n, atol=1e-12)
    # the loader puts its NED origin at the surface above the first GT sample (down = absolute depth);
    # geodetic round trip is sub-millimetre
    np.testing.assert_allclose(back.gt.p_n, sim.gt.p_n - sim.gt.p_n[0] * [1, 1, 0], atol=1e-3)
    np.testing.assert_allclose(back.depth.depth, sim.gt.p_n[:, 2], atol=1e-6)


def test_closed_form_euler_matches_the_shared_rotation_helper():
    from graphnav.core.rotations import euler_to_C_b_n as shared
    from graphnav.core.rotations import euler_to_C_b_n_closed_form as closed_form
    rng = np.random.default_rng(0)
    roll, pitch, yaw = rng.uniform(-3, 3, 100), rng.uniform(-1.5, 1.5, 100), rng.uniform(-3, 3, 100)
    np.testing.assert_allclose(closed_form(roll, pitch, yaw), shared(roll, pitch, yaw), atol=1e-14)


def test_dvl_pings_between_imu_samples_are_exact():
    m = simulate_mission(30.0, seed=1, noiseless=True, dvl_stamp_offset_s=0.437)
    np.testing.assert_allclose(m.dvl.t, np.arange(30) + 0.437)
    assert not np.isin(m.dvl.t, m.imu.t).any()
    geometry = DvlGeometry.from_spec(m.config.dvl)
    state = m.meta["trajectory"].state(m.dvl.t)
    np.testing.assert_allclose(m.dvl.beams, geometry.beams_from_velocity(state.v_b, state.omega_nb_b), atol=1e-12)
    # the same trajectory as without the offset: GT is unchanged
    np.testing.assert_array_equal(m.gt.p_n, simulate_mission(30.0, seed=1, noiseless=True).gt.p_n)
    from graphnav.core.errors import ConfigError
    with pytest.raises(ConfigError):
        simulate_mission(10.0, dvl_stamp_offset_s=1.0)


def test_a_written_folder_reads_as_it_was_written(tmp_path):
    """``graphnav simulate --out`` then ``--data``: the folder reads with the configuration it was written with
    (no time offset or axis estimated, the GT kept at the IMU point), its stamps as written and its own beams
    (3-beam pings, and pings with fewer beams, which the DVL file leaves without a velocity); a ping whose DVL
    velocity was edited after writing gets beams made from the edited velocity, and a ping whose velocity was
    blanked is not measured."""
    from graphnav.calibration.preparation import prepare
    from graphnav.io.export import write_akit
    from graphnav.io.loaders import read_mission
    sim = simulate_mission(120.0, seed=2, dvl_stamp_offset_s=0.37, imu_grade="tactical", dropout=True)
    counts = sim.dvl.valid.sum(axis=1)
    assert (counts == 3).sum() >= 3 and (counts < 3).sum() >= 3, "the dropout model gave too few pings to check"
    edited, blanked = np.flatnonzero(counts >= 3)[[20, 30]]
    paths = write_akit(sim, tmp_path)
    lines = paths["DVL"].read_text().splitlines()
    cols = lines[edited + 1].split(",")
    lines[edited + 1] = ",".join([cols[0], str(float(cols[1]) + 0.3), *cols[2:]])      # edited: +0.3 m/s
    lines[blanked + 1] = lines[blanked + 1].split(",")[0] + ",nan,nan,nan"
    paths["DVL"].write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)     # nothing detected or estimated, so nothing to warn about
        back = prepare(read_mission(tmp_path / "Trajectory1"))
    assert back.config.imu.name == sim.config.imu.name
    np.testing.assert_allclose(back.config.dvl.lever_arm_b, sim.config.dvl.lever_arm_b)
    assert back.config.dvl_time_offset_s == 0.0 and back.config.gt_time_offset_s == 0.0
    assert "gt_velocity_sigma_n" not in back.meta        # the simulation's truth has no error of its own
    np.testing.assert_array_equal(back.config.imu_axis_signs, [1, 1, 1])
    np.testing.assert_allclose(back.imu.t, sim.imu.t, atol=1e-12)
    np.testing.assert_allclose(back.gt.v_n, sim.gt.v_n, atol=1e-12)    # at the IMU point: not moved
    np.testing.assert_allclose(back.dvl.t, sim.dvl.t, atol=1e-12)       # every ping, with a velocity or not
    same = ~np.isin(np.arange(len(back.dvl.t)), [edited, blanked])
    np.testing.assert_array_equal(back.dvl.valid[same], sim.dvl.valid[same])
    np.testing.assert_allclose(np.where(back.dvl.valid, back.dvl.beams, 0)[same],
                               np.where(sim.dvl.valid, sim.dvl.beams, 0)[same], atol=1e-12)
    v = DvlGeometry.from_spec(back.config.dvl).velocity_from_beams(back.dvl.beams[edited])
    assert abs(v[0] - sim.dvl.v_b[edited, 0] - 0.3) < 0.2     # the edited velocity, a new draw of noise
    assert not back.dvl.valid[blanked].any()                 # the DVL file is believed over the beams file
    notes = " ".join(back.meta["streams"]["dvl"]["notes"] + back.meta["streams"]["config"]["notes"])
    assert f"beams of {(counts >= 3).sum() - 2} ping(s) read" in notes and "1 ping(s) whose DVL velocity" in notes
    assert f"and of {(counts < 3).sum()} ping(s) with fewer than three beams" in notes
    assert "configuration the folder was written with" in notes


def test_a_written_folder_keeps_its_stamps_frame_and_survives_a_damaged_beams_file(tmp_path):
    """A written folder is read with its stamps as written even on a grid the published files' rescale would
    take (a GT at 0.95 Hz), with its velocity in the body frame whatever the DVL's mounting (the file holds the
    DVL-frame velocity the configuration turns back), and a damaged beams file is warned about and left aside
    (the beams are made from the DVL file, as for a published folder)."""
    from graphnav.io.export import write_akit
    from graphnav.io.loaders import read_mission
    from scipy.spatial.transform import Rotation as R
    from graphnav.sim.simulate import default_config
    cfg = default_config()
    cfg.dvl.C_d_b = R.from_euler("z", 3.0, degrees=True).as_matrix()
    sim = simulate_mission(60.0, seed=4, config=cfg, gt_rate_hz=1.0 / 1.05)
    paths = write_akit(sim, tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = read_mission(tmp_path / "Trajectory1")
    np.testing.assert_allclose(back.gt.t, sim.gt.t, atol=1e-12)
    np.testing.assert_allclose(back.dvl.v_b, sim.dvl.v_b, atol=1e-12)
    np.testing.assert_allclose(back.dvl.beams, sim.dvl.beams, atol=1e-12)
    lines = paths["beams"].read_text().splitlines()
    lines[10] = lines[10].rsplit(",", 1)[0]                           # a truncated line
    paths["beams"].write_text("\n".join(lines) + "\n")
    with pytest.warns(RuntimeWarning, match=r"beams_trajectory1.csv.*line 11.*made from the DVL file"):
        damaged = read_mission(tmp_path / "Trajectory1")
    np.testing.assert_allclose(damaged.dvl.v_b, sim.dvl.v_b, atol=1e-12)
    assert not np.allclose(damaged.dvl.beams, sim.dvl.beams, atol=1e-6)     # made again, with new noise
