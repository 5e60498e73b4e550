"""The Earth model (gravity, tangent frame, stamps) against an independent INS: nmayorov's pyins (python-ins).

pyins navigates in latitude/longitude/altitude with transport rate and WGS84 gravity at every point; graphnav in a
fixed tangent frame with the gravity of :class:`graphnav.core.earth.EarthModel`. A pyins-generated AUV run
(``tests/pyins_scenario.py``) must come out of graphnav's strapdown and estimators as it went in.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from graphnav.core.config import DEG, SensorConfig
from graphnav.core.earth import EarthModel, gravity_magnitude, lla_to_ned, ned_to_lla, radii_of_curvature
from graphnav.core.errors import DataError
from graphnav.core.imu_stamps import increments_to_samples, rates_to_samples
from graphnav.core.mission import ImuData
from graphnav.estimators.ins import Strapdown, StrapdownState

pyins = pytest.importorskip("pyins", reason="python-ins (the independent INS) is in the 'test' extra")
from pyins_scenario import make_mission, make_run  # noqa: E402  (needs pyins)

LAT = 33.0 * DEG


@pytest.fixture(scope="module")
def run():
    return make_run()


def _free_inertial(run, imu: ImuData, n: int, earth: EarthModel | None = None, start: int = 0):
    """Pure strapdown from the truth at ``run.t[start]``, sample j driving ``[t_{start+j}, t_{start+j+1})``, over
    n samples; (|dv| m/s, horizontal m, down m) against the truth at the end."""
    sd = Strapdown(earth or run.earth)
    s0 = StrapdownState(run.t[start], run.C_b_n[start], run.v_n[start], run.p_n[start])
    end, _ = sd.propagate(s0, imu.f_b[:n], imu.omega_b[:n], np.diff(run.t[start:start + n + 1]))
    k = start + n
    dp = end.p_n - run.p_n[k]
    return float(np.linalg.norm(end.v_n - run.v_n[k])), float(np.linalg.norm(dp[:2])), float(dp[2])


# --- the model itself ------------------------------------------------------------------------------------

def test_gravity_is_the_configured_value_at_the_origin_and_tilts_with_displacement():
    earth = EarthModel(LAT, 9.8)
    np.testing.assert_allclose(earth.gravity_n(np.zeros(3)), [0, 0, 9.8], atol=1e-12)
    r_m, r_n = radii_of_curvature(LAT)
    G = earth.gravity_gradient_n()
    g = gravity_magnitude(LAT)
    # horizontal: the local vertical tilts towards the origin by d/R (the Schuler coupling)
    assert G[0, 0] == pytest.approx(-g / r_m, rel=2e-3) and G[1, 1] == pytest.approx(-g / r_n, rel=2e-3)
    # vertical: the free-air gradient, +3.086e-6 s^-2 per metre of depth
    assert G[2, 2] == pytest.approx(3.086e-6, rel=2e-3)
    # 10 km north-east, 30 m deep: the vector's direction is the local vertical there, its size normal gravity
    p = np.array([7000.0, 7000.0, 30.0])
    local = earth.local_rotation(p) @ earth.gravity_n(p)
    lat, _, alt = earth.to_lla(p)
    assert np.hypot(local[0], local[1]) < 1e-9
    assert local[2] == pytest.approx(9.8 + gravity_magnitude(lat, -alt) - gravity_magnitude(LAT), abs=1e-9)


def test_gravity_matches_pyins_normal_gravity():
    """pyins' own WGS84 gravity (Somigliana with a linear height term) at points of a 20 km square."""
    earth = EarthModel(LAT, gravity_magnitude(LAT))
    p = np.array([[0, 0, 0], [10000, 0, 20], [-5000, 8000, 100], [3000, -10000, 5]], float)
    lla = earth.to_lla(p)
    theirs = pyins.earth.gravity(np.degrees(lla[:, 0]), lla[:, 2])
    ours = np.linalg.norm(earth.gravity_n(p), axis=1)
    # the height terms differ (WGS84 second order vs pyins' 2 g h / a): 1.5e-8 s^-2 per metre
    np.testing.assert_allclose(ours, theirs, atol=2e-6)


def test_tangent_frame_round_trips_and_curvature_drop():
    origin = (LAT, 35 * DEG, -3.0)
    p = np.array([[100.0, 200.0, 3.0], [-5000.0, 40.0, -2.0], [10000.0, 10000.0, 50.0]])
    lla = ned_to_lla(p, origin)
    np.testing.assert_allclose(lla_to_ned(lla[:, 0], lla[:, 1], lla[:, 2], origin), p, atol=1e-6)
    earth = EarthModel(LAT, 9.79, -3.0)
    r_m, r_n = radii_of_curvature(LAT)
    drop = earth.depth_of(np.array([10000.0, 0.0, 0.0]))
    assert drop == pytest.approx(-1e8 / (2 * r_m), rel=1e-3)            # 7.8 m above the ellipsoid at 10 km


# --- stamps -----------------------------------------------------------------------------------------------

def test_increment_conversion_stamps_at_the_interval_start(run):
    v, h, d = _free_inertial(run, run.imu, 6000)
    assert v < 2e-5 and h < 1e-3
    # the same increments stamped at their interval's end: a real, large error (measured 1.2 m/s, 240 m in
    # 400 s; over these 60 s 0.18 m/s, 5.5 m)
    # each increment held over the interval after the one it covers
    v_late, h_late, _ = _free_inertial(run, run.imu, 6000, start=1)
    assert v_late > 100 * v and h_late > 0.1


def test_rate_conversion_of_instant_samples(run):
    """ROS-style instant rates from pyins (``sensor_type='rate'``) integrate as well as the exact increments to
    the order of the linear model (measured over 60 s: 4e-6 m/s)."""
    _, rates = pyins.sim.generate_imu(run.t[:6002], run.trajectory.iloc[0][["lat", "lon", "alt"]].to_numpy(),
                                      run.trajectory[["roll", "pitch", "heading"]].to_numpy()[:6002],
                                      run.trajectory[["VN", "VE", "VD"]].to_numpy()[:6002], sensor_type="rate")
    imu = rates_to_samples(run.t[:6002], rates[["gyro_x", "gyro_y", "gyro_z"]].to_numpy(),
                           rates[["accel_x", "accel_y", "accel_z"]].to_numpy())
    v, h, _ = _free_inertial(run, imu, 6000)
    assert v < 1e-4 and h < 5e-3
    # the instant values taken as graphnav samples are first-order wrong in the turns
    raw = ImuData(run.t[:6002], rates[["accel_x", "accel_y", "accel_z"]].to_numpy(),
                  rates[["gyro_x", "gyro_y", "gyro_z"]].to_numpy())
    v_raw, _, _ = _free_inertial(run, raw, 6000)
    assert v_raw > 10 * v


def test_conversions_refuse_bad_input():
    t = np.array([0.0, 0.01, 0.01, 0.03])
    with pytest.raises(DataError, match="index 2"):
        increments_to_samples(t, np.zeros((4, 3)), np.zeros((4, 3)), source="log.bin")
    with pytest.raises(DataError, match="two"):
        rates_to_samples(np.array([0.0]), np.zeros((1, 3)), np.zeros((1, 3)))


# --- strapdown against pyins ------------------------------------------------------------------------------

def test_noise_free_strapdown_holds_the_pyins_trajectory(run):
    # measured: 60 s 3.0e-6 m/s, 0.0000 m; 400 s 1.4e-4 m/s, 0.0015 m horizontal, 0.029 m down (the height
    # term of pyins' gravity, 2 g h / a, against WGS84's 3.086e-6 s^-2)
    v60, h60, _ = _free_inertial(run, run.imu, 6000)
    v, h, d = _free_inertial(run, run.imu, len(run.imu.t))
    assert v60 < 2e-5 and h60 < 1e-3
    assert v < 1e-3 and h < 0.01 and abs(d) < 0.1
    # the flat model (constant gravity) on the same data: 0.11 m/s, 15 m
    flat = dataclasses.replace(run.earth, gravity_variation=False)
    v_flat, h_flat, _ = _free_inertial(run, run.imu, len(run.imu.t), flat)
    assert v_flat > 0.05 and h_flat > 5.0


def test_noisy_strapdown_agrees_with_pyins_integrator(run):
    """The same noisy increments through pyins' own strapdown and graphnav's: the two solutions agree far below
    the errors the noise causes (measured over 100 s: 2.9e-5 m/s and 7e-5 m between them, 0.081 m/s and 0.99 m
    from the truth)."""
    from pyins.strapdown import Integrator, compute_increments_from_imu
    n = 10001
    rng = np.random.default_rng(7)
    inc = run.increments.iloc[:n].copy()
    dt = 0.01
    gyro = ["gyro_x", "gyro_y", "gyro_z"]
    accel = ["accel_x", "accel_y", "accel_z"]
    inc[gyro] += (2e-6 + rng.normal(0, 1e-4, (n, 3))) * dt           # rad: bias 2e-6 rad/s, white noise
    inc[accel] += (5e-4 + rng.normal(0, 1e-2, (n, 3))) * dt           # m/s: bias 5e-4 m/s^2, white noise
    theirs = Integrator(run.trajectory.iloc[0]).integrate(compute_increments_from_imu(inc, "increment"))
    imu = increments_to_samples(run.t[:n], inc[gyro].to_numpy(), inc[accel].to_numpy())
    sd = Strapdown(run.earth)
    end, _ = sd.propagate(StrapdownState(0.0, run.C_b_n[0], run.v_n[0], run.p_n[0]), imu.f_b, imu.omega_b,
                          np.diff(run.t[:n]))
    last = theirs.iloc[-1]
    lla = np.radians([last["lat"], last["lon"] - 35.0])
    p_theirs = run.earth.from_lla(np.array([lla[0], lla[1], last["alt"]]))
    v_theirs = run.earth.local_rotation(p_theirs).T @ last[["VN", "VE", "VD"]].to_numpy(float)
    from_truth = np.linalg.norm(end.v_n - run.v_n[n - 1])
    assert from_truth > 0.02                                        # the noise matters ...
    assert np.linalg.norm(end.v_n - v_theirs) < 1e-3                # ... and both integrate it the same way
    assert np.linalg.norm(end.p_n[:2] - p_theirs[:2]) < 0.02


# --- estimators against pyins -----------------------------------------------------------------------------

def _score(run, sol):
    k = np.searchsorted(run.t, sol.t - 1e-9)
    vrmse = float(np.sqrt(np.mean(np.sum((sol.v_n - run.v_n[k]) ** 2, axis=1))))
    return vrmse, float(np.linalg.norm(sol.p_n[-1, :2] - run.p_n[k[-1], :2]))


@pytest.mark.parametrize("method", ["TC", "Graph-TC"])
def test_dvl_aided_estimators_hold_the_pyins_trajectory(run, method):
    """Noise-free IMU and beams, started from the truth: measured TC 1.2e-5 m/s, 0.001 m at the end; Graph-TC
    1.4e-5 m/s, 0.006 m (before the Earth model: 7.8e-3 m/s, 1.8 m and 8.5e-3 m/s, 1.4 m)."""
    from graphnav.estimators.graph import InitialState
    from graphnav.estimators.runs import run_ekf, run_graph
    m = make_mission(run)
    init = InitialState.from_ground_truth(m, 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)     # NIS bands: the beams are noise-free
        sol = run_ekf(m, tight=True, initial=init) if method == "TC" else run_graph(m, initial=init)
    vrmse, end = _score(run, sol)
    assert vrmse < 2e-4 and end < 0.05


def test_noisy_dvl_aided_ekf_is_consistent(run):
    """Noisy beams (0.01 m/s): the velocity error is the filter's own, as its covariance says (measured: VRMSE
    6.6e-3 m/s, mean velocity NEES 1.3; with the flat model on the same data 6.9e-3 m/s, NEES 1.7)."""
    from graphnav.estimators.graph import InitialState
    from graphnav.estimators.runs import run_ekf
    m = make_mission(run, beam_noise_std=0.01, seed=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sol = run_ekf(m, tight=True, initial=InitialState.from_ground_truth(m, 0.5))
    vrmse, _ = _score(run, sol)
    k = np.searchsorted(run.t, sol.t - 1e-9)
    e = sol.v_n - run.v_n[k]
    nees = float(np.mean(np.einsum("ni,ni->n", e, np.linalg.solve(sol.cov_v_n, e[:, :, None])[:, :, 0])))
    assert vrmse < 1e-2 and 0.5 < nees < 3.0


# --- far from the origin ------------------------------------------------------------------------------------

def _aided_far_and_near(method: str, flat: bool = False):
    """VRMSE (m/s) of a noise-free 150 s simulated survey aided by beams and depth, started at the origin and
    22 km from it (gravity tilted 0.2 deg, the tangent plane 39 m above the sea)."""
    from graphnav.estimators.graph import InitialState
    from graphnav.estimators.runs import run_ekf, run_graph
    from graphnav.sim.simulate import simulate_mission
    out = []
    for start in ((0.0, 0.0), (20000.0, 10000.0)):
        m = simulate_mission(150.0, noiseless=True, seed=4, start_ne_m=start)
        init = InitialState.from_ground_truth(m, float(m.dvl.t[0]))
        if flat:        # the estimator's gravity constant at the start's magnitude, as before the Earth model
            m.config.gravity_mps2 = float(np.linalg.norm(EarthModel.from_config(m.config).gravity_n(m.gt.p_n[0])))
            m.config.gravity_variation = False
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            sol = run_ekf(m, tight=True, initial=init) if method == "TC" else run_graph(m, initial=init)
        k = np.searchsorted(m.gt.t, sol.t - 1e-9)
        on = (k < len(m.gt.t)) & (np.abs(m.gt.t[np.minimum(k, len(m.gt.t) - 1)] - sol.t) < 1e-6)
        out.append(float(np.sqrt(np.mean(np.sum((sol.v_n[on] - m.gt.v_n[k[on]]) ** 2, axis=1)))))
    return out


@pytest.mark.parametrize("method", ["TC", "Graph-TC"])
def test_aided_error_does_not_grow_with_distance_from_the_origin(method):
    """Measured (VRMSE at the origin / 22 km): TC 1.04e-4 / 1.04e-4 m/s, Graph-TC 1.13e-5 / 1.13e-5 m/s (with
    depth: the reading is turned into the tangent plane's down). With a constant gravity (the flat model) the
    same runs give TC 3.2e-3 / 1.3e-2 and Graph-TC 3.0e-3 / 2.7e-2 m/s: 22 km out the filters must absorb a
    0.034 m/s^2 horizontal error as tilt and bias."""
    near, far = _aided_far_and_near(method)
    assert far < 2e-4 and far < 1.5 * near + 1e-5
    _, far_flat = _aided_far_and_near(method, flat=True)
    assert far_flat > 3 * far


@pytest.mark.slow
def test_two_hour_mission_far_from_the_origin_keeps_its_accuracy():
    """A 2 h noise-free survey started 20 km from the origin (30 km at most from it), TC with 1 Hz beams: the
    velocity error of the last 10 minutes is that of the first 10 (no growth with time or distance)."""
    from graphnav.estimators.graph import InitialState
    from graphnav.estimators.runs import run_ekf
    from graphnav.sim.simulate import simulate_mission
    m = simulate_mission(7200.0, noiseless=True, seed=1, start_ne_m=(20000.0, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sol = run_ekf(m, tight=True, initial=InitialState.from_ground_truth(m, float(m.dvl.t[0])))
    k = np.searchsorted(m.gt.t, sol.t - 1e-9)
    on = (k < len(m.gt.t)) & (np.abs(m.gt.t[np.minimum(k, len(m.gt.t) - 1)] - sol.t) < 1e-6)
    err = np.linalg.norm(sol.v_n[on] - m.gt.v_n[k[on]], axis=1)
    t = sol.t[on]
    first, last = np.sqrt(np.mean(err[t < 600] ** 2)), np.sqrt(np.mean(err[t > t[-1] - 600] ** 2))
    assert first < 3e-4 and last < 1.5 * first
