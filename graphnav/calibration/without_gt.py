"""Calibration without ground truth: lever arm as a graph variable, DVL time offset by profile likelihood.

The graph is the project's batch INS/DVL graph (keyframes at DVL pings, GTSAM ``CombinedImuFactor``
between them, depth factors) with one extra variable: the DVL lever arm ``L(0)`` (Point3, body frame),
shared by every beam factor (:func:`graphnav.factors.beam_factor_lever_arm`; weak zero-mean prior).
Nothing comes from a ground truth: the first attitude is levelled from the accelerometer (yaw 0, a gauge
the DVL and IMU cannot fix), the first position is the origin.

DVL time offset: for a candidate offset the DVL stamps are shifted and the graph is re-solved; the
optimised graph error (``0.5 * chi^2`` = negative log-likelihood up to a constant) is a profile
likelihood of the offset. A parabola through the grid minimum and its neighbours gives the estimate and
``sigma^2 = 1 / curvature`` (exact for a Gaussian model). This is justified because the offset only
enters through the dynamics the IMU measures: a wrong offset pairs each ping with the wrong part of the
IMU-propagated velocity, which the IMU factors penalise.

The lever arm found here is relative to the point whose motion the accelerometer measures. On the shared
A-KIT data that point is ~1.8 m aft of the GT reference point (see
:func:`graphnav.calibration.dvl_fit.estimate_imu_position`), so this mode finds the DVL within ~0.2 m of the IMU in
x/y; the GT mode measures from the point the mission's GT stands for, which ``prepare`` moves to the same IMU point
on A-KIT folders (its report names the point: :attr:`graphnav.calibration.result.CalibrationResult.reference_point`),
and finds the DVL ~1.8 m aft of the published GT point only with the GT kept there.
Without GT, the first position is the origin, the first heading comes from gyrocompassing
(:func:`initial_heading`) and depth factors are left out (see :func:`solve_calibration_graph`).
"""
from __future__ import annotations

import dataclasses
import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, L, V, X

from graphnav.calibration.axes import check_imu_axes_without_gt
from graphnav.calibration.result import CalibrationResult, Quantity
from graphnav.core.config import SensorConfig
from graphnav.core.earth import earth_rate_n
from graphnav.core.errors import DataError
from graphnav.core.mission import Mission
from graphnav.estimators.graph.builder import GraphContext, imu_factor, mission_keyframes
from graphnav.estimators.graph.options import GraphOptions
from graphnav.factors import beam_factor_lever_arm, beam_noise, depth_factor


def level_attitude(f_b: np.ndarray, yaw: float = 0.0) -> np.ndarray:
    """Body-to-NED rotation from mean specific force (roll, pitch from gravity) and a given yaw, (3,3)."""
    f = np.mean(f_b, axis=0)
    roll = np.arctan2(-f[1], -f[2])
    pitch = np.arctan2(f[0], np.hypot(f[1], f[2]))
    return gtsam.Rot3.Ypr(yaw, pitch, roll).matrix()


@dataclasses.dataclass
class GraphFit:
    """One solve of the calibration graph."""

    offset_s: float
    error: float
    lever_arm_b: np.ndarray
    lever_arm_cov: np.ndarray | None
    n_keyframes: int
    n_beams: int
    solve_s: float


def solve_calibration_graph(mission: Mission, offset_s: float = 0.0, lever_prior_sigma: float = 3.0,
                            options: GraphOptions | None = None, marginals: bool = False,
                            max_iterations: int = 50, yaw0: float = 0.0, yaw_sigma: float = 1e-3,
                            pings: np.ndarray | None = None) -> GraphFit:
    """Build and solve the calibration graph with the DVL stamps shifted by ``offset_s`` (s).

    ``yaw0`` (rad) is the first heading and ``yaw_sigma`` its prior (with Earth rotation modelled the
    heading is not a free gauge: a wrong one makes the Earth-rate compensation tilt the attitude).
    ``pings``: bool mask of the DVL pings to use (default: those inside the IMU span after the shift);
    compare errors of different offsets only over the same pings.
    """
    started = time.perf_counter()
    # No depth factors: keyframes move with the candidate offset, so a depth factor would sample the noisy
    # depth stream at different times for each candidate and make the profile likelihood jagged.
    options = options or GraphOptions(use_depth=False)
    dvl = dataclasses.replace(mission.dvl, t=mission.dvl.t + offset_s)
    inside = (dvl.t >= mission.t0) & (dvl.t <= mission.t1)
    if pings is not None:
        inside &= pings
    shifted = dataclasses.replace(mission, dvl=dvl.take(inside))
    cfg = mission.config
    w_ie = earth_rate_n(cfg.lat_rad) if cfg.earth_rotation else np.zeros(3)
    imu = mission.imu
    n0 = max(1, int(round(1.0 * cfg.imu_rate_hz)))
    C0 = level_attitude(imu.f_b[:n0], yaw0)

    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    acc_sigma, gyro_sigma = cfg.imu.accel_bias_sigma, cfg.imu.gyro_bias_sigma
    bias0 = gtsam.imuBias.ConstantBias()
    state = None
    n_beams = 0
    n_keyframes = 0
    # the gravity of each keyframe's predicted position (radial about the vertical, so a yaw gauge does not
    # matter: 4.5e-4 m/s^2 horizontal 300 m from the start, which a constant gravity would leave to the biases)
    gravity = GraphContext(shifted.config, options)
    for kf in mission_keyframes(shifted, options):
        k = kf.index
        n_keyframes += 1
        dvl = None if kf.ping is None else gravity.beam_rows(kf.ping, kf.beams_used)
        if k == 0:
            v_b = np.zeros(3)
            if dvl is not None and len(dvl.y) >= 3:
                v_b = np.linalg.lstsq(dvl.rows_b, dvl.y, rcond=None)[0]
            pose = gtsam.Pose3(gtsam.Rot3(C0), np.zeros(3))
            if kf.depth is not None:
                pose = gtsam.Pose3(gtsam.Rot3(C0), np.array([0.0, 0.0, kf.depth]))
            state = gtsam.NavState(pose, C0 @ v_b)
            # roll/pitch from levelling (loose), yaw and position: gauge (tight)
            graph.add(gtsam.PriorFactorPose3(X(0), pose, gtsam.noiseModel.Diagonal.Sigmas(
                np.array([0.05, 0.05, yaw_sigma, 1e-3, 1e-3, 1e-3]))))
            graph.add(gtsam.PriorFactorConstantBias(B(0), bias0, gtsam.noiseModel.Diagonal.Sigmas(
                np.r_[np.full(3, acc_sigma), np.full(3, gyro_sigma)])))
        else:
            gravity.set_gravity(kf, state.position(), state.velocity())
            graph.add(imu_factor(kf))
            state = kf.pim.predict(state, bias0)
        if dvl is not None and len(dvl.y) >= 3:
            # re-anchor the initial velocity on the DVL (the IMU alone would drift)
            v_b = np.linalg.lstsq(dvl.rows_b, dvl.y, rcond=None)[0]
            state = gtsam.NavState(state.pose(), state.attitude().matrix() @ v_b)
        values.insert(X(k), state.pose())
        values.insert(V(k), state.velocity())
        values.insert(B(k), bias0)
        if dvl is not None:
            omega = kf.ping.omega_b
            if options.earth_rate_in_lever_arm:
                omega = omega - state.attitude().matrix().T @ w_ie
            graph.add(beam_factor_lever_arm(X(k), V(k), B(k), L(0), dvl.rows_b, dvl.y,
                                            beam_noise(dvl.sigma), omega))
            n_beams += len(dvl.y)
        if kf.depth is not None and options.use_depth:
            sigma = options.depth_sigma if options.depth_sigma is not None else cfg.depth_noise_std
            graph.add(depth_factor(X(k), kf.depth, sigma, state.pose().translation()[:2]))
    if n_beams < 30:
        raise DataError("too few DVL beams inside the IMU span to calibrate", mission.name, field="dvl")
    values.insert(L(0), np.zeros(3))
    graph.add(gtsam.PriorFactorPoint3(L(0), np.zeros(3), gtsam.noiseModel.Isotropic.Sigma(3, lever_prior_sigma)))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(max_iterations)
    params.setRelativeErrorTol(1e-8)
    result = gtsam.LevenbergMarquardtOptimizer(graph, values, params).optimize()
    cov = lever_arm_covariance(graph, result) if marginals else None
    return GraphFit(offset_s, float(graph.error(result)), np.asarray(result.atPoint3(L(0))), cov,
                    n_keyframes, n_beams, time.perf_counter() - started)


def lever_arm_covariance(graph: gtsam.NonlinearFactorGraph, values: gtsam.Values) -> np.ndarray:
    """Marginal covariance (3,3) of ``L(0)`` at ``values``.

    ``gtsam.Marginals`` (Cholesky) reports an indeterminate system here: the bias random walk of a FOG
    (1e-9 rad/s^2/sqrt(Hz)) makes the information matrix span ~20 orders of magnitude. A sparse LU solve of
    the normal equations for the lever-arm columns copes with that.
    """
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    lin = graph.linearize(values)
    ijs = lin.sparseJacobian_()
    rows, cols, vals = ijs[0].astype(int) - 1, ijs[1].astype(int) - 1, ijs[2]
    # sparseJacobian_ orders variables by key and appends the right-hand side as the last column
    dims = {"b": 6, "l": 3, "v": 3, "x": 6}
    offset, start = 0, None
    for key in sorted(graph.keys()):
        if key == L(0):
            start = offset
        offset += dims[chr(gtsam.Symbol(key).chr())]
    keep = cols < offset
    J = sp.csc_matrix((vals[keep], (rows[keep], cols[keep])), shape=(int(rows.max()) + 1, offset))
    H = (J.T @ J).tocsc()
    rhs = np.zeros((offset, 3))
    rhs[start:start + 3] = np.eye(3)
    sol = splu(H).solve(rhs)
    cov = sol[start:start + 3]
    return 0.5 * (cov + cov.T)


def initial_heading(mission: Mission, window_s: float = 100.0, n_candidates: int = 8, **kwargs
                    ) -> tuple[float, dict]:
    """First heading (rad) by gyrocompassing in the graph: the first ``window_s`` s are solved with the
    heading held at each of ``n_candidates`` values; the graph error, minimised over them, is refined by a
    parabola through the best candidate and its neighbours (periodic in heading).

    With Earth rotation modelled a wrong heading misplaces the Earth rate, which tilts the attitude at up
    to 7e-5 rad/s: a navigation-grade gyro sees that within a minute, a noisier one less (and then the
    heading matters less to the other estimates).
    """
    cfg = mission.config
    if not cfg.earth_rotation:
        return 0.0, {}
    part = mission.slice(mission.t0, mission.t0 + window_s)
    step = 2 * np.pi / n_candidates
    yaws = np.arange(n_candidates) * step
    errors = np.array([solve_calibration_graph(part, yaw0=y, yaw_sigma=1e-3, **kwargs).error for y in yaws])
    i = int(np.argmin(errors))
    e_m, e_0, e_p = errors[i - 1], errors[i], errors[(i + 1) % n_candidates]
    denom = e_m - 2 * e_0 + e_p
    shift = 0.5 * (e_m - e_p) / denom if denom > 0 else 0.0
    yaw = float(np.mod(yaws[i] + np.clip(shift, -1, 1) * step + np.pi, 2 * np.pi) - np.pi)
    return yaw, {f"{np.degrees(y):.0f}": float(e) for y, e in zip(yaws, errors)}


def profile_offset(mission: Mission, search_s=(-1.5, 1.5), step_s: float = 0.5, **kwargs):
    """DVL offset from the graph's profile likelihood: grid, then a parabola through the minimum.

    Returns (offset_s, sigma_s, fits) with ``fits`` every :class:`GraphFit` evaluated.
    """
    fits = {}
    # the same pings for every candidate: those inside the IMU span for the whole search interval
    t = mission.dvl.t
    pings = (t + search_s[0] >= mission.t0) & (t + search_s[1] <= mission.t1)
    kwargs = {**kwargs, "pings": pings}

    def fit(o):
        o = round(float(o), 6)
        if o not in fits:
            fits[o] = solve_calibration_graph(mission, o, **kwargs)
        return fits[o]

    grid = np.arange(search_s[0], search_s[1] + 1e-9, step_s)
    errors = np.array([fit(o).error for o in grid])
    i = int(np.argmin(errors))
    # refine once at half the step around the minimum, then fit a parabola through the 3 best points
    for o in (grid[i] - step_s / 2, grid[i] + step_s / 2):
        fit(o)
    xs = np.array(sorted(fits))
    ys = np.array([fits[x].error for x in xs])
    j = int(np.clip(np.argmin(ys), 1, len(xs) - 2))
    a, b, _ = np.polyfit(xs[j - 1:j + 2], ys[j - 1:j + 2], 2)
    if a <= 0:
        return float(xs[np.argmin(ys)]), float("nan"), fits
    x = float(np.clip(-b / (2 * a), xs[j - 1], xs[j + 1]))
    return x, float(np.sqrt(1.0 / (2 * a))), fits


def calibrate_with_graph(mission: Mission, search_s=(-1.5, 1.5), step_s: float = 0.5,
                         estimate_offset: bool = True, **kwargs) -> CalibrationResult:
    """Lever arm (graph variable) and DVL time offset (profile likelihood) without ground truth.

    The GT, when present, is not used. DVL yaw and scale are not estimated in this mode (they need a
    velocity reference).
    """
    check = check_imu_axes_without_gt(mission)
    work = mission
    if not check.ok:
        from graphnav.calibration.axes import apply_axis_map
        work = apply_axis_map(mission, check.gyro_map, check.accel_map)
    if "yaw0" not in kwargs:
        kwargs["yaw0"], heading_errors = initial_heading(work)
        kwargs.setdefault("yaw_sigma", 0.05)
    fits = {}
    if estimate_offset:
        offset, offset_sigma, fits = profile_offset(work, search_s, step_s, **kwargs)
    else:
        offset, offset_sigma = 0.0, float("nan")
    final = solve_calibration_graph(work, offset, marginals=True, **kwargs)
    cfg0 = mission.config
    cfg = SensorConfig.from_dict(cfg0.to_dict())
    cfg.dvl.lever_arm_b = final.lever_arm_b.copy()
    cfg.dvl_time_offset_s = cfg0.dvl_time_offset_s + offset
    cfg.imu_axis_signs = cfg0.imu_axis_signs * check.sign_correction
    sigma_l = np.sqrt(np.diag(final.lever_arm_cov))
    rms = float(np.sqrt(2 * final.error / max(final.n_beams, 1)))
    return CalibrationResult(
        "graph", Quantity(final.lever_arm_b, sigma_l, "m"), Quantity(cfg.dvl_time_offset_s, offset_sigma, "s"),
        None, None, None, None, rms, check, cfg,
        info={"dvl_offset_correction_s": offset, "keyframes": final.n_keyframes, "beams": final.n_beams,
              "graph_solves": len(fits) + 1, "final_solve_s": final.solve_s, "yaw0_rad": kwargs["yaw0"],
              "profile": {f"{o:+.3f}": f.error for o, f in sorted(fits.items())}})
