"""DVL lever arm, mounting yaw, scale factor and time offset regressed on the ground truth, and where the
accelerometer sits relative to the GT reference point."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from graphnav.calibration.reference import (
    Reference,
    _search_offset,
    _sigma_from_curvature,
    cumulative_integral,
    interp_rows,
)
from graphnav.core.dvl import beam_velocity_b
from graphnav.core.errors import DataError
from graphnav.core.mission import Mission
from graphnav.core.rotations import skew


# ------------------------------------------------------------------------------------------------
# Where the accelerometer sits relative to the reference (GT) point
# ------------------------------------------------------------------------------------------------
#: Half-width (s) of the gyro averages at an interval's ends whose difference is the interval's mean angular
#: acceleration: long enough to average the gyro's white noise down, short against the vehicle's roll period.
RATE_END_HALF_WIDTH_S = 0.05
#: GT intervals longer than this times the median are holes: left out of the accelerometer regression.
REGULAR_INTERVAL_FACTOR = 1.5

#: IMU samples rotated at a time (about 40 MB of temporaries each).
IMU_CHUNK = 100_000


@dataclass
class AccelerometerMismatch:
    """The accelerometer against the GT over each GT interval ``[a, b]`` (s, IMU clock), body frame.

    ``d`` (K,3) m/s^2: the mean measured specific force minus the one the GT predicts; ``design`` (K,3,6): the
    interval means of ``omega_dot x r + omega x (omega x r)`` as a matrix on r (first three columns) and a
    constant bias (last three), so ``d ~ design @ [r, bias]`` up to noise."""

    a: np.ndarray
    b: np.ndarray
    d: np.ndarray
    design: np.ndarray

    @property
    def regular(self) -> np.ndarray:
        """(K,) the intervals no longer than :data:`REGULAR_INTERVAL_FACTOR` times the median: across a hole in the
        GT its constant acceleration says little."""
        dt = self.b - self.a
        return dt <= REGULAR_INTERVAL_FACTOR * float(np.median(dt))

    def fit(self) -> tuple[np.ndarray, np.ndarray]:
        """(x (6,) = [r m, bias m/s^2], residual (K,3) m/s^2): the least-squares fit of ``d`` on ``design`` over the
        :attr:`regular` intervals; the residual of every interval."""
        regular = self.regular
        x, *_ = np.linalg.lstsq(self.design[regular].reshape(-1, 6), self.d[regular].reshape(-1), rcond=None)
        return x, self.d - self.design @ x


def accelerometer_mismatch(mission: Mission) -> AccelerometerMismatch:
    """The accelerometer's interval means against the GT's (:class:`AccelerometerMismatch`).

    The GT predicts ``C^T (dv_n/dt - g_n)`` at its reference point. ``C^T`` is averaged over the interval along
    the attitude the gyro carries from the GT sample, as the accelerometer averages its own specific force; the
    GT's acceleration is constant over the interval, so the prediction's mean is that mean rotation applied to it
    (whatever IMU sample straddles the interval's ends). ``omega_dot`` is the difference of the mean rates at the
    interval's ends (:data:`RATE_END_HALF_WIDTH_S`). Every term is an interval mean, so a sparse GT adds no
    bias: with the attitude taken at the interval's middle, a 1 Hz GT of a rolling vehicle put r ~0.9 m above
    the truth on simulated missions (``g/12`` times the roll acceleration) and doubled the accelerometer density
    identified on the shared trajectories. The GT stamps must already be on the IMU clock.
    """
    from graphnav.calibration.reference import mission_reference
    imu, gt = mission.imu, mission.gt
    t = np.ascontiguousarray(imu.t)
    h = RATE_END_HALF_WIDTH_S
    ok = (gt.t[:-1] - h >= t[0]) & (gt.t[1:] + h <= t[-1])
    a, b = gt.t[:-1][ok], gt.t[1:][ok]
    if a.size < 2:
        raise DataError(f"the GT has {a.size} sample interval(s) inside the IMU's span (with "
                        f"{RATE_END_HALF_WIDTH_S:g} s to spare at each end): the accelerometer cannot be compared with "
                        "it", mission.name, field="gt.t")
    dt = (b - a)[:, None]

    def mean(cumulative, lo, hi):
        return (interp_rows(hi, t, cumulative) - interp_rows(lo, t, cumulative)) / (hi - lo)[:, None]

    f_meas = mean(np.asfortranarray(cumulative_integral(t, imu.f_b)), a, b)
    W = np.asfortranarray(cumulative_integral(t, imu.omega_b))
    w_dot = (mean(W, b - h, b + h) - mean(W, a - h, a + h)) / dt
    # omega x (omega x r) = (omega omega^T - |omega|^2 I) r: its six distinct terms averaged (not N 3x3 matrices)
    w = imu.omega_b
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    ww = mean(np.asfortranarray(cumulative_integral(t, np.stack([w[:, i] * w[:, j] for i, j in pairs], 1))), a, b)
    w_w = np.empty((len(a), 3, 3))
    for c, (i, j) in enumerate(pairs):
        w_w[:, i, j] = w_w[:, j, i] = ww[:, c]
    w_w -= np.trace(w_w, axis1=1, axis2=2)[:, None, None] * np.eye(3)
    g_n = np.array([0.0, 0.0, mission.config.gravity_mps2])
    a_n = (np.diff(gt.v_n, axis=0) / np.diff(gt.t)[:, None])[ok]
    # The GT's acceleration is constant over an interval: its prediction's mean is the interval mean of C^T applied
    # to it. Integrating the predicted specific force sample by sample instead put the step between two intervals'
    # accelerations inside the IMU sample held across their boundary, on whichever side its stamp fell: a GT
    # shifted by 5e-7 s moved r by up to 20 mm on simulated missions (tests/test_calibration.py).
    C_mean = mean(_cumulative_body_from_nav(t, mission_reference(mission), a[0], b[-1]), a, b).reshape(-1, 3, 3)
    d = f_meas - np.einsum("kij,kj->ki", C_mean, a_n - g_n)
    design = np.concatenate([skew(w_dot) + w_w, np.broadcast_to(np.eye(3), (len(a), 3, 3))], axis=2)
    return AccelerometerMismatch(a, b, d, design)


def _cumulative_body_from_nav(t: np.ndarray, reference, start: float, end: float) -> np.ndarray:
    """(N,9), Fortran order: the running integral (:func:`cumulative_integral`, zero-order hold) of the
    navigation-to-body rotation ``C^T`` (row-major elements) along ``reference``'s attitude, over the samples from the
    one held over ``start`` to ``end`` (s); ``C^T`` is left at zero outside them, where no interval mean between
    ``start`` and ``end`` reads."""
    first = max(int(np.searchsorted(t, start, side="right")) - 1, 0)
    last = min(int(np.searchsorted(t, end, side="left")) + 1, len(t))
    C_t = np.zeros((len(t), 9))
    rows = np.arange(first, last)
    for chunk in np.array_split(rows, max(1, len(rows) // IMU_CHUNK)):     # bounded memory on long missions
        C_t[chunk] = reference.rotation_b_n(t[chunk]).inv().as_matrix().reshape(-1, 9)
    return np.asfortranarray(cumulative_integral(t, C_t))


def estimate_imu_position(mission: Mission) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Position r (body, m) of the accelerometer's measurement point relative to the GT reference point.

    A rigid body's specific force at r differs from the one at the reference point by
    ``omega_dot x r + omega x (omega x r)``: the accelerometer's interval means minus the GT's
    (:func:`accelerometer_mismatch`) are regressed on those terms' interval means, with a constant bias.
    Returns (r, covariance of r, residual RMS before, after), m/s^2. The GT stamps must already be on the IMU
    clock. r matters because the estimators integrate the IMU: the DVL lever arm they need is the DVL's
    position relative to the accelerometer point, ``l_dvl - r``.
    """
    m = accelerometer_mismatch(mission)
    x, e = m.fit()
    regular = m.regular
    A, e = m.design[regular].reshape(-1, 6), e[regular]
    cov = np.linalg.pinv(A.T @ A) * float(np.sum(e ** 2)) / max(e.size - 6, 1) * correlation_inflation(e)
    return x[:3], cov[:3, :3], float(np.sqrt(np.mean(m.d[regular] ** 2))), float(np.sqrt(np.mean(e ** 2)))


# ------------------------------------------------------------------------------------------------
# DVL regression against the GT
# ------------------------------------------------------------------------------------------------
PARAM_NAMES = ("l_x", "l_y", "l_z", "scale", "yaw", "b_z")
N_PARAMS = len(PARAM_NAMES)


def dvl_velocity(mission: Mission) -> tuple[np.ndarray, np.ndarray]:
    """The DVL-head body velocity of each ping as the estimators see it, and the mask of usable pings.

    The instrument's own velocity (``dvl.v_b``) when present, else least squares from >= 3 valid beams
    with the configured geometry (:func:`graphnav.core.dvl.beam_velocity_b`).
    """
    v = beam_velocity_b(mission.dvl, mission.config.dvl)
    return v, np.all(np.isfinite(v), axis=1)


def _design(reference: Reference, t: np.ndarray):
    C = reference.C_b_n(t)
    v_ref = reference.v_b(t, C)
    omega = reference.omega_nb_b(t, C)
    # linearised about l = s = psi = b = 0 (the small terms' products, e.g. s * omega x l, are left to the
    # exact refinement)
    A = np.zeros((len(t), 3, N_PARAMS))
    A[:, :, 0:3] = skew(omega)                   # omega x l
    A[:, :, 3] = v_ref                           # s v
    A[:, :, 4] = np.stack([v_ref[:, 1], -v_ref[:, 0], np.zeros(len(t))], axis=1)  # Rz(psi)^T v ~ v + psi [v_y, -v_x, 0]
    A[:, 2, 5] = 1.0                             # vertical bias (equal beam biases show up on z only)
    return A, v_ref, omega


def _exact_residual(theta, v_dvl, v_ref, omega):
    l, s, psi, b = theta[0:3], theta[3], theta[4], np.array([0.0, 0.0, theta[5]])
    head = v_ref + np.cross(omega, l)
    Rz_T = Rotation.from_euler("z", -psi).as_matrix()
    return (v_dvl - ((1 + s) * head @ Rz_T.T + b)).reshape(-1)


@dataclass
class DvlFit:
    """DVL regression result at one offset: parameters, covariance, residual RMS, pings used."""

    offset_s: float
    theta: np.ndarray
    cov: np.ndarray
    rms: float
    n_pings: int
    sse: float


def correlation_inflation(e: np.ndarray, max_lag: int = 20) -> float:
    """Variance inflation ``1 + 2 sum_k rho_k`` of a mean over residuals correlated in time (k up to the
    first non-positive autocorrelation, at most ``max_lag``), averaged over the columns of e (N,k).

    Least-squares covariances assume white residuals; the real DVL-minus-GT residuals are correlated over
    a few pings (GT smoothing, waves), which this factor accounts for (approximately: it treats every
    regressor as slowly varying).
    """
    e = e - e.mean(axis=0)
    var = np.sum(e * e, axis=0)
    if np.any(var <= 0):
        return 1.0
    total = 1.0
    for k in range(1, min(max_lag, len(e) - 1) + 1):
        rho = float(np.mean(np.sum(e[k:] * e[:-k], axis=0) / var))
        if rho <= 0:
            break
        total += 2 * rho
    return total


def fit_dvl(reference: Reference, t_raw: np.ndarray, v_dvl: np.ndarray, offset_s: float,
            use: np.ndarray, exact: bool = False) -> DvlFit:
    """Least-squares fit of (l, s, psi, b) at one DVL offset (linearised; ``exact`` refines the
    nonlinear model with scipy's least_squares)."""
    t = t_raw[use] + offset_s
    A, v_ref, omega = _design(reference, t)
    r = (v_dvl[use] - v_ref).reshape(-1)
    A2 = A.reshape(-1, N_PARAMS)
    theta, *_ = np.linalg.lstsq(A2, r, rcond=None)
    if exact:
        sol = least_squares(_exact_residual, theta, args=(v_dvl[use], v_ref, omega), method="lm")
        theta = sol.x
        e = sol.fun
        J = sol.jac
    else:
        e = r - A2 @ theta
        J = A2
    sse = float(e @ e)
    dof = max(len(e) - N_PARAMS, 1)
    cov = np.linalg.pinv(J.T @ J) * sse / dof * correlation_inflation(e.reshape(-1, 3))
    return DvlFit(offset_s, theta, cov, float(np.sqrt(sse / len(e))), int(use.sum()), sse)


#: Fewest DVL pings the fit of :func:`calibrate_dvl_with_gt` takes: six parameters and an offset from three axes each.
MIN_FIT_PINGS = 20


def calibrate_dvl_with_gt(reference: Reference, t_raw: np.ndarray, v_dvl: np.ndarray, use: np.ndarray,
                          search_s: tuple[float, float] = (-3.0, 3.0), step_s: float = 0.1, source: str = "dvl"
                          ) -> tuple[DvlFit, float]:
    """Profile the DVL fit over candidate offsets; returns (exact fit at the best offset, offset sigma). Fewer than
    :data:`MIN_FIT_PINGS` usable pings (``use``) inside the reference's span at every offset searched is a DataError
    naming the DVL's file ``source``, the pings and the span."""
    usable = int(use.sum())
    use = use & reference.covers(t_raw + search_s[0]) & reference.covers(t_raw + search_s[1])
    if use.sum() < MIN_FIT_PINGS:
        lo = max(reference.t_ref[0], reference.t_imu[0])
        hi = min(reference.t_ref[-1], reference.t_imu[-1])
        raise DataError(f"{int(use.sum())} of the {usable} usable DVL pings overlap the ground truth and the IMU "
                        f"([{lo:.3f}, {hi:.3f}] s) at every time offset searched ({search_s[0]:+g} to "
                        f"{search_s[1]:+g} s): the DVL fit needs {MIN_FIT_PINGS}", source, field="t")

    def cost(offset):
        return fit_dvl(reference, t_raw, v_dvl, offset, use).sse

    x, sse, curv = _search_offset(cost, search_s[0], search_s[1], step_s)
    fit = fit_dvl(reference, t_raw, v_dvl, x, use, exact=True)
    inflation = correlation_inflation(_exact_residual(fit.theta, v_dvl[use], *_design(reference, t_raw[use] + x)[1:]
                                                      ).reshape(-1, 3))
    sigma = _sigma_from_curvature(sse, curv, 3 * int(use.sum()), N_PARAMS + 1) * np.sqrt(inflation)
    return fit, sigma
