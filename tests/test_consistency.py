"""Consistency tools (NEES band, reference covariance, report section, NEES plot) and noise identification."""
from __future__ import annotations

import numpy as np
import pytest

from graphnav.calibration.noise import (
    ESTIMATOR_DENSITY_FACTOR,
    allan_deviation,
    gt_white_velocity_error,
    identify,
    identify_imu_with_gt,
    white_density,
)
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.runs import run_graph
from graphnav.evaluation.bench import mission_nees, nees_section
from graphnav.evaluation.consistency import (
    chi2_band,
    n_independent,
    nees_time_series,
    nees_with_reference,
)
from graphnav.evaluation.metrics import nees_velocity
from graphnav.evaluation.plots import plot_nees
from graphnav.sim.simulate import simulate_mission


@pytest.fixture(scope="module")
def mission_and_solution():
    m = simulate_mission(120, seed=5)
    sol = run_graph(m, options=GraphOptions(dvl_error_states=True))
    return m, sol


def test_chi2_band():
    lo, hi = chi2_band(1)
    assert lo == pytest.approx(0.2158, abs=1e-3) and hi == pytest.approx(9.348, abs=1e-3)
    lo, hi = chi2_band(1000)
    assert 2.8 < lo < 3.0 < hi < 3.2
    assert n_independent(np.arange(0, 100.0)) == 10


def test_reference_covariance_lowers_nees(mission_and_solution):
    m, sol = mission_and_solution
    plain = nees_velocity(sol, m.gt, 30.0)
    np.testing.assert_allclose(nees_with_reference(sol, m.gt, np.zeros((3, 3)), 30.0), plain)
    assert np.mean(nees_with_reference(sol, m.gt, np.eye(3) * 0.01 ** 2, 30.0)) < np.mean(plain)
    t, nees = nees_time_series(sol, m.gt, 30.0)
    assert len(t) == len(nees) == len(plain) and t[0] >= 30.0


def test_nees_section_and_plot(mission_and_solution, tmp_path):
    m, sol = mission_and_solution
    m.meta["gt_velocity_sigma_n"] = [0.005, 0.005, 0.005]
    scores = mission_nees(sol, m)
    assert scores["nees_mission_gt"] < scores["nees_mission"]
    records = [{"trajectory": f"t{i}", "scenario": "none", "imu_grade": "as-recorded", "method": "Graph-TC",
                "nees_window": 3.0 + i, **scores} for i in range(2)]
    text = "\n".join(nees_section(records, ["as-recorded"], ["none"], ["Graph-TC"]))
    assert "### NEES: as-recorded, none" in text and "| Graph-TC |" in text and "%" in text
    path = plot_nees(m, [sol], [], tmp_path / "nees.png", "test")
    assert path.exists() and path.stat().st_size > 1000


def test_allan_white_density():
    rng = np.random.default_rng(0)
    density, rate = 2e-3, 100.0
    x = rng.normal(0, density * np.sqrt(rate), (60000, 3))
    adev = allan_deviation(x, rate, [1, 10, 100])
    np.testing.assert_allclose(adev[:, 0] * np.sqrt([0.01, 0.1, 1.0]), density, rtol=0.1)
    assert white_density(x, rate) == pytest.approx(density, rel=0.05)


def test_identify_beam_noise_and_exact_gt(mission_and_solution):
    """On a simulated mission the beam noise comes back within 10 % and the (exact) GT gets a small error."""
    m, _ = mission_and_solution
    est = identify(m)
    assert est.beam_noise_std == pytest.approx(m.config.dvl.beam_noise_std, rel=0.1)
    assert max(est.gt_velocity_sigma_n) < 0.01
    assert est.accel_noise_density > 0 and est.gyro_noise_density > 0


def test_the_imu_densities_hold_with_a_sparse_reference():
    """With a 1 Hz GT (A-KIT's rate) of a rolling vehicle the tactical IMU's simulated densities come back within
    15 % and the exact GT gets no white velocity error. With the attitude taken at each interval's middle, the
    accelerometer's came back 4.2x too large and the GT got 3.4 mm/s of error along the body x axis."""
    m = simulate_mission(400.0, imu_grade="tactical", seed=3, gt_rate_hz=1.0)
    accel, gyro = identify_imu_with_gt(m)
    assert accel == pytest.approx(m.config.imu.accel_noise_density, rel=0.15)
    assert gyro == pytest.approx(m.config.imu.gyro_noise_density, rel=0.15)
    assert np.max(gt_white_velocity_error(m)[0]) < 1e-3


def test_calibrate_writes_the_densities_the_estimators_need(mission_and_solution):
    """The calibrated configuration gets the identified densities times the factor of how they were identified
    (against the GT here); the identified ones stay in the result."""
    from graphnav.calibration.calibrate import calibrate
    m, _ = mission_and_solution
    result = calibrate(m, identify_noise=True)
    n = result.noise
    assert n.density_source == "gt"
    f_acc, f_gyro = ESTIMATOR_DENSITY_FACTOR["gt"]
    assert result.config.imu.accel_noise_density == pytest.approx(f_acc * n.accel_noise_density)
    assert result.config.imu.gyro_noise_density == pytest.approx(f_gyro * n.gyro_noise_density)
    assert f"IMU densities written     : accel {f_acc * n.accel_noise_density:.2e}" in result.report()


def test_without_a_reference_the_allan_densities_get_their_own_factor():
    import dataclasses

    from graphnav.calibration.noise import identify_imu
    m = simulate_mission(60.0, imu_grade="tactical", seed=2)
    est = identify_imu(dataclasses.replace(m, gt=None))
    assert est.density_source == "allan" and est.accel_noise_density == est.allan_accel_density
    f_acc, f_gyro = ESTIMATOR_DENSITY_FACTOR["allan"]
    assert est.estimator_densities() == pytest.approx((f_acc * est.allan_accel_density,
                                                       f_gyro * est.allan_gyro_density))


def test_imu_carried_reference_between_sparse_samples(mission_and_solution):
    """A 1 Hz GT carried to off-sample stamps by the IMU matches the full-rate GT there far better than its
    linear interpolation does, and is exact at its own samples; the bench's NEES is scored against it."""
    import dataclasses

    from graphnav.evaluation.consistency import imu_carried_reference, scoring_reference
    m, sol = mission_and_solution
    gt = m.gt
    step = int(round(1.0 / np.median(np.diff(gt.t))))
    sparse = dataclasses.replace(m, gt=gt.take(np.arange(0, len(gt.t), step)))
    t = sparse.gt.t[5:-5] + 0.37
    v_true = gt.at(t)[1]
    ref = imu_carried_reference(t, sparse)
    np.testing.assert_array_equal(ref.t, t)
    err_carried = np.sqrt(np.mean(np.sum((ref.v_n - v_true) ** 2, axis=1)))
    err_linear = np.sqrt(np.mean(np.sum((sparse.gt.at(t)[1] - v_true) ** 2, axis=1)))
    assert err_carried < 0.005 and err_carried < 0.5 * err_linear
    on_samples = imu_carried_reference(sparse.gt.t[3:9], sparse)
    np.testing.assert_allclose(on_samples.v_n, sparse.gt.v_n[3:9], atol=1e-9)
    own = scoring_reference(sol, sparse)
    inside = (sol.t >= sparse.gt.t[0]) & (sol.t <= sparse.gt.t[-1])
    np.testing.assert_array_equal(own.t, sol.t[inside])


# --- position and heading NEES ------------------------------------------------------------------------------
def test_chi2_band_per_dof():
    """The band of one epoch is the chi-square quantiles of its dof; of many it narrows around the dof."""
    assert chi2_band(1, 2) == pytest.approx((0.05064, 7.3778), abs=1e-4)
    assert chi2_band(1, 1) == pytest.approx((0.000982, 5.0239), abs=1e-4)
    lo, hi = chi2_band(50, 2)                     # chi2(100) / 50
    assert lo == pytest.approx(74.222 / 50, abs=1e-3) and hi == pytest.approx(129.561 / 50, abs=1e-3)


def _ar1(rng, n, tau_samples, dims):
    """Unit-variance AR(1) noise (n, dims) with e-folding time ``tau_samples``."""
    phi = np.exp(-1.0 / tau_samples)
    x = np.zeros((n, dims))
    x[0] = rng.normal(size=dims)
    w = rng.normal(scale=np.sqrt(1 - phi ** 2), size=(n, dims))
    for k in range(1, n):
        x[k] = phi * x[k - 1] + w[k]
    return x


def test_decorrelation_time_of_white_and_correlated_errors():
    from graphnav.evaluation.consistency import decorrelation_time
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 4000.0, 0.5)
    assert decorrelation_time(t, rng.normal(size=(len(t), 2))) == 10.0          # white: the 10 s floor
    assert decorrelation_time(t, _ar1(rng, len(t), 80, 2)) == pytest.approx(40.0, rel=0.25)  # 80 samples of 0.5 s
    ramp = np.c_[t, -t]                                                          # never decorrelates in the span
    assert decorrelation_time(t[:200], ramp[:200]) > 0.4 * 100.0                # a trend: a large part of the span
    assert decorrelation_time(t[:2], ramp[:2]) == 10.0


def test_the_velocity_band_counts_the_errors_decorrelation():
    """Velocity errors drawn from the stated covariance but correlated over 40 s (as a smoother's are, through
    its DVL error states): the band counts one independent epoch per 40 s, not per 10 s, and holds the NEES of
    most draws (one per 10 s held 4 of 16 simulated missions' batch NEES); a covariance 4x too small is above
    it."""
    from graphnav.core.mission import GroundTruth
    from graphnav.core.rotations import euler_to_C_b_n
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.consistency import reference_nees
    n, inside, inside_10s, taus = 1000, 0, 0, []
    t = np.arange(n, dtype=float)
    zero = np.zeros(n)
    gt = GroundTruth(t, np.c_[1.5 * t, zero, zero], np.tile([1.5, 0, 0], (n, 1)), euler_to_C_b_n(zero, zero, zero))
    P = np.tile(np.diag([0.03, 0.02, 0.005]) ** 2, (n, 1, 1))
    for seed in range(40):
        e = _ar1(np.random.default_rng(seed), n, 40, 3) * np.array([0.03, 0.02, 0.005])
        sol = NavSolution("s", t, gt.p_n, gt.v_n + e, gt.C_b_n, cov_v_n=P)
        s = reference_nees(sol, gt, t0=60.0)
        taus.append(s["nees_decorrelation_s"])
        lo, hi = chi2_band(s["nees_n_independent"])
        inside += lo <= s["nees_mission"] <= hi
        lo, hi = chi2_band(n_independent(t[t >= 60.0]))
        inside_10s += lo <= s["nees_mission"] <= hi
    assert np.median(taus) == pytest.approx(40.0, rel=0.25)
    assert inside >= 34 and inside_10s <= 25          # 37 and 21 of 40
    tight = reference_nees(NavSolution("s", t, gt.p_n, gt.v_n + e, gt.C_b_n, cov_v_n=P / 4), gt, t0=60.0)
    assert tight["nees_mission"] > chi2_band(tight["nees_n_independent"])[1]
    lost = gt.v_n + e
    lost[500:] = np.nan                                     # an estimate lost half-way: no number from the rest
    gone = reference_nees(NavSolution("s", t, gt.p_n, lost, gt.C_b_n, cov_v_n=P), gt, t0=60.0)
    assert np.isnan(gone["nees_mission"]) and gone["nees_n_independent"] >= 1


def test_the_velocity_nees_split_along_the_body_axes():
    """A vehicle heading 60 deg: errors drawn from a body-frame covariance (0.03, 0.02, 0.005 m/s) stated in NED
    give about 1 per body axis; the vertical sigma stated 2x too wide gives 0.25 down and leaves the others, while
    the NEES falls to about 2.25 without saying which axis."""
    from graphnav.core.mission import GroundTruth
    from graphnav.core.rotations import euler_to_C_b_n
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.consistency import BODY_AXES, body_axis_nees, reference_nees
    n = 4000
    t = np.arange(n, dtype=float)
    zero = np.zeros(n)
    C_b_n = euler_to_C_b_n(zero, zero, np.full(n, np.deg2rad(60.0)))
    gt = GroundTruth(t, np.zeros((n, 3)), np.tile([0.75, 1.3, 0.0], (n, 1)), C_b_n)
    sigma_b = np.array([0.03, 0.02, 0.005])
    e_n = np.einsum("kij,kj->ki", C_b_n, np.random.default_rng(3).normal(size=(n, 3)) * sigma_b)
    cov_n = np.einsum("kij,jl,kml->kim", C_b_n, np.diag(sigma_b ** 2), C_b_n)
    assert body_axis_nees(e_n, cov_n, C_b_n) == pytest.approx([1.0, 1.0, 1.0], abs=0.06)
    wide = np.einsum("kij,jl,kml->kim", C_b_n, np.diag((sigma_b * [1, 1, 2]) ** 2), C_b_n)
    s = reference_nees(NavSolution("s", t, gt.p_n, gt.v_n + e_n, C_b_n, cov_v_n=wide), gt, t0=0.0)
    assert s["nees_axes_b"] == pytest.approx([1.0, 1.0, 0.25], abs=0.06) and len(BODY_AXES) == 3
    assert s["nees_mission"] == pytest.approx(2.25, abs=0.1)
    e_nan = e_n.copy()
    e_nan[10] = np.nan                                        # a lost epoch: its axes' means are not finite
    assert all(np.isnan(body_axis_nees(e_nan, cov_n, C_b_n)))


def test_epochs_without_a_sigma_are_left_out_and_a_lost_estimate_gives_no_number():
    """A file's empty sigma rows (finite estimate, no covariance) are left out of the velocity, position and
    heading NEES and counted; an epoch whose estimate is not finite (the estimator lost track) leaves that NEES NaN
    and is counted: never a number from part of the run."""
    from graphnav.core.mission import GroundTruth
    from graphnav.core.rotations import euler_to_C_b_n
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.consistency import reference_nees
    n = 600
    t = np.arange(n, dtype=float)
    zero = np.zeros(n)
    gt = GroundTruth(t, np.c_[1.5 * t, zero, zero], np.tile([1.5, 0, 0], (n, 1)), euler_to_C_b_n(zero, zero, zero))
    rng = np.random.default_rng(7)
    P = np.tile(np.diag([0.03, 0.02, 0.005]) ** 2, (n, 1, 1))
    P_p = np.tile(np.eye(3) * 4.0, (n, 1, 1))
    P_r = np.tile(np.eye(3) * 1e-4, (n, 1, 1))

    def solution(v_n, p_n, cov_v, cov_p):
        return NavSolution("s", t, p_n, v_n, gt.C_b_n, cov_v_n=cov_v, cov_p_n=cov_p, cov_rot_b=P_r)
    v = gt.v_n + rng.normal(size=(n, 3)) * [0.03, 0.02, 0.005]
    p = gt.p_n + rng.normal(size=(n, 3)) * 2.0
    whole = reference_nees(solution(v, p, P, P_p), gt, t0=60.0)
    holes_v, holes_p = P.copy(), P_p.copy()
    holes_v[100:110], holes_p[300:320] = np.nan, np.nan
    holed = reference_nees(solution(v, p, holes_v, holes_p), gt, t0=60.0)
    assert (holed["nees_epochs_without_sigma"], holed["nees_pos_epochs_without_sigma"]) == (10, 20)
    assert holed["nees_epochs_lost"] == holed["nees_pos_epochs_lost"] == 0
    keep = np.ones(n - 60, bool)
    keep[40:50] = False
    from graphnav.evaluation.metrics import nees_velocity
    assert holed["nees_mission"] == pytest.approx(np.mean(nees_velocity(solution(v, p, P, P_p), gt, 60.0)[keep]))
    assert holed["nees_pos_mission"] == pytest.approx(whole["nees_pos_mission"], rel=0.1)
    assert all(np.isfinite(holed["nees_axes_b"])) and np.isfinite(holed["nees_mission_interp"])
    lost_v, lost_p = v.copy(), p.copy()
    lost_v[200], lost_p[400] = np.nan, np.nan
    lost = reference_nees(solution(lost_v, lost_p, P, P_p), gt, t0=60.0)
    assert np.isnan(lost["nees_mission"]) and lost["nees_epochs_lost"] == 1
    assert np.isnan(lost["nees_pos_mission"]) and lost["nees_pos_epochs_lost"] == 1
    assert np.isfinite(lost["nees_heading_mission"]) and lost["nees_heading_epochs_lost"] == 0
    from graphnav.evaluation import consistency
    no_attitude = solution(v, p, P, P_p)
    no_attitude.C_b_n = no_attitude.C_b_n.copy()
    no_attitude.C_b_n[300] = np.nan                                  # a lost attitude is a lost estimate as well
    lost_attitude = reference_nees(no_attitude, gt, t0=60.0)
    assert np.isnan(lost_attitude["nees_mission"]) and lost_attitude["nees_epochs_lost"] == 1
    assert lost_attitude["nees_heading_epochs_lost"] == 1 and all(np.isnan(lost_attitude["nees_axes_b"]))
    assert np.isnan(lost_attitude["nees_mission_interp"])
    window = consistency.window_nees(no_attitude, gt, 290.0, 310.0)
    assert np.isnan(window["nees_window"]) and np.isnan(window["nees_heading_window"])
    assert np.isfinite(window["nees_pos_window"])
    from graphnav.evaluation.consistency import window_nees
    window = window_nees(solution(v, p, holes_v, holes_p), gt, 90.0, 130.0)        # 10 epochs without a sigma
    assert window["nees_window"] == pytest.approx(np.mean(nees_velocity(solution(v, p, P, P_p), gt, 90.0,
                                                                        130.0)[np.r_[0:10, 20:41]]))
    window = window_nees(solution(lost_v, lost_p, P, P_p), gt, 180.0, 220.0)      # the velocity lost at 200 s
    assert np.isnan(window["nees_window"]) and np.isfinite(window["nees_pos_window"])
    all_lost = lost_p.copy()
    all_lost[60:] = np.nan                                                     # a position lost for good
    gone = reference_nees(solution(v, all_lost, P, P_p), gt, t0=60.0)
    assert np.isnan(gone["nees_pos_mission"]) and gone["nees_pos_n_independent"] == 1


def test_pose_nees_of_consistent_and_overconfident_errors():
    """Errors drawn from the stated covariances (correlated in time): position NEES about 2, heading about 1,
    each inside its band; a covariance 4x too small puts them 4x higher and outside. Without the covariances:
    None, never a number."""
    from graphnav.core.mission import GroundTruth
    from graphnav.core.rotations import euler_to_C_b_n, so3_exp_batch
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.consistency import HEADING_DOF, POSITION_DOF, pose_nees
    rng = np.random.default_rng(7)
    n = 6000
    t = np.arange(n, dtype=float)
    zero = np.zeros(n)
    gt = GroundTruth(t, np.c_[1.5 * t, zero, zero], np.tile([1.5, 0, 0], (n, 1)),
                     euler_to_C_b_n(zero, zero, np.full(n, 3.1)))
    sigma_p = np.linspace(1.0, 10.0, n)                                         # growing, as dead reckoning
    P = np.einsum("k,ij->kij", sigma_p ** 2, np.diag([1.0, 0.5, 0.01]))
    z = _ar1(rng, n, 20, 3)                                                      # decorrelates in 20 s
    p_est = gt.p_n + np.c_[sigma_p * z[:, 0], sigma_p * np.sqrt(0.5) * z[:, 1], zero]
    R = np.tile(np.diag([1e-6, 1e-6, np.deg2rad(0.5) ** 2]), (n, 1, 1))
    C_est = gt.C_b_n @ so3_exp_batch(np.c_[zero, zero, np.deg2rad(0.5) * z[:, 2]])   # crosses +-180 deg
    sol = NavSolution("s", t, p_est, gt.v_n, C_est, cov_p_n=P, cov_rot_b=R)
    s = pose_nees(sol, gt, 60.0)
    assert s["nees_pos_mission"] == pytest.approx(2.0, rel=0.15)
    assert s["nees_heading_mission"] == pytest.approx(1.0, rel=0.15)
    assert s["nees_pos_decorrelation_s"] == pytest.approx(20.0, rel=0.3)
    for key, dof in (("nees_pos", POSITION_DOF), ("nees_heading", HEADING_DOF)):
        lo, hi = chi2_band(s[f"{key}_n_independent"], dof)
        assert lo <= s[f"{key}_mission"] <= hi
    tight = NavSolution("s", t, p_est, gt.v_n, C_est, cov_p_n=P / 4, cov_rot_b=R / 4)
    s4 = pose_nees(tight, gt, 60.0)
    assert s4["nees_pos_mission"] == pytest.approx(4 * s["nees_pos_mission"], rel=1e-9)
    assert s4["nees_pos_mission"] > chi2_band(s4["nees_pos_n_independent"], POSITION_DOF)[1]
    assert s4["nees_heading_mission"] > chi2_band(s4["nees_heading_n_independent"], HEADING_DOF)[1]
    none = pose_nees(NavSolution("s", t, p_est, gt.v_n, C_est), gt, 60.0)
    assert set(none) == set(s) and all(v is None for v in none.values())


def test_the_ekf_reports_heading_nees_and_no_position_nees():
    """The paper's 12-state EKF carries an attitude covariance and no position covariance: the mission scores
    have a heading NEES and None for the position NEES."""
    from graphnav.estimators.ekf import EkfOptions
    from graphnav.estimators.runs import run_ekf
    m = simulate_mission(90, seed=4)
    sol = run_ekf(m, options=EkfOptions(position_states=False, dvl_error_states=False))
    assert sol.cov_rot_b is not None and sol.cov_p_n is None
    scores = mission_nees(sol, m)
    assert scores["nees_pos_mission"] is None and scores["nees_pos_n_independent"] is None
    assert 0 < scores["nees_heading_mission"] < 100 and scores["nees_heading_n_independent"] >= 1
