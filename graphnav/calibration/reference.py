"""Aligning the sensor streams with a reference trajectory: time offsets, DVL residuals, gyro checks.

The tools the loaders (``time offset = "auto"``) and ``graphnav calibrate`` share. Everything runs on the
IMU clock: a stream's *offset* is the value added to its raw stamps to put them on the IMU clock.

- :class:`Reference` interpolates a 1 Hz reference (ground truth) at any IMU-clock time with the IMU's
  help: attitude is propagated with the gyro from the nearest earlier reference sample, velocity is the
  blend of the accelerometer integrated forward from the sample before and backward from the sample
  after. A constant accelerometer error cancels in that blend, and fast wave motion at the surface, which
  linear interpolation of 1 Hz samples misses by 0.1 m/s, is followed.
- :func:`estimate_gt_time_offset` matches gyro-integrated attitude increments with the reference's.
- :func:`estimate_dvl_time_offset` regresses the DVL velocity on the reference body velocity plus
  ``omega_b x l_b`` over candidate offsets.
- :func:`gyro_attitude_error` integrates the gyro from the reference attitude and reports the drift.

Frames: body FRD, nav NED; ``C_b_n`` body-to-NED; rates in rad/s, velocities in m/s, times in s.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation

from graphnav.core.earth import earth_rate_n
from graphnav.core.errors import DataError
from graphnav.core.rotations import cumulative_quat_product, skew
from graphnav.core.timeseries import cumulative_integral, interp_rows

if TYPE_CHECKING:
    from graphnav.core.mission import GroundTruth


@dataclass
class OffsetEstimate:
    """A time offset found by a 1-D search.

    Attributes:
        offset_s: value to add to the stream's raw stamps to put them on the IMU clock, s.
        sigma_s: 1-sigma from the curvature of the least-squares cost, s.
        rms: RMS residual at the optimum (rad per reference interval, or m/s per axis).
        n: number of residual terms used.
        extra: other estimated quantities (e.g. the lever arm fitted jointly), by name.
    """

    offset_s: float
    sigma_s: float
    rms: float
    n: int
    extra: dict = field(default_factory=dict)


def _search_offset(cost, lo: float, hi: float, step: float) -> tuple[float, float, float]:
    """Grid search then bounded Brent refinement of a 1-D cost; returns (x, cost, curvature)."""
    grid = np.arange(lo, hi + 0.5 * step, step)
    values = np.array([cost(x) for x in grid])
    i = int(np.nanargmin(values))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    res = minimize_scalar(cost, bounds=(a, b), method="bounded", options={"xatol": 1e-4})
    x = float(res.x)
    h = max(step / 2, 1e-3)
    curvature = (cost(x + h) - 2 * cost(x) + cost(x - h)) / h ** 2
    return x, float(res.fun), float(curvature)


def _sigma_from_curvature(sse: float, curvature: float, n: int, n_params: int) -> float:
    """1-sigma of a scalar least-squares parameter: var = 2 s^2 / J'' with s^2 = SSE / (n - p)."""
    if not np.isfinite(curvature) or curvature <= 0 or n <= n_params:
        return float("nan")
    s2 = sse / (n - n_params)
    return float(np.sqrt(2.0 * s2 / curvature))


class Reference:
    """A reference trajectory (ground truth on the IMU clock) interpolated with the IMU's help.

    Args:
        t_imu: (N,) IMU stamps, s.
        f_b: (N,3) specific force, m/s^2 (body FRD, axis signs already applied).
        omega_b: (N,3) angular rate omega_ib_b, rad/s.
        t_ref: (K,) reference stamps on the IMU clock, s.
        v_n: (K,3) reference NED velocity, m/s.
        C_b_n: (K,3,3) reference attitude.
        gravity_mps2: gravity magnitude (down), m/s^2.
        lat_rad: latitude for the Earth rate, rad; None = no Earth rotation.
        envelope: the vehicle's envelope (:class:`~graphnav.core.config.DvlSpec`, default ``DvlSpec()``): reference
            samples whose velocity is beyond its speed or spikes (:func:`graphnav.core.screening.gt_implausible`)
            are left out, with a warning, and counted in ``n_refused``: one such sample would otherwise
            dominate every least-squares fit against the reference (a 1e6 m/s GT sample pinned the DVL time
            offset at its search bound).
    """

    def __init__(self, t_imu, f_b, omega_b, t_ref, v_n, C_b_n, gravity_mps2: float,
                 lat_rad: float | None = None, envelope=None):
        self.t_imu = np.ascontiguousarray(t_imu, float)
        self.t_ref = np.asarray(t_ref, float)
        self.v_ref = np.asarray(v_n, float)
        self.C_ref = np.asarray(C_b_n, float)
        self._screen(envelope)
        self.omega_ie_n = np.zeros(3) if lat_rad is None else earth_rate_n(lat_rad)
        omega_b = np.asarray(omega_b, float)
        inside = (self.t_imu >= self.t_ref[0]) & (self.t_imu <= self.t_ref[-1])
        if inside.sum() < 2:
            raise DataError("reference and IMU do not overlap in time", "gt", field="t")
        self.omega_b = np.asfortranarray(omega_b)
        # Gyro attitude relative to the IMU start: R_i = prod Exp(omega dt); rates of the nav frame
        # (Earth rate) are removed per reference interval below.
        # Each rate is held until the next sample (as in gyro_attitude_error and _rot_at).
        dt = np.diff(self.t_imu)
        step_q = Rotation.from_rotvec(omega_b[:-1] * dt[:, None]).as_quat()
        self._R_imu = Rotation.from_quat(cumulative_quat_product(step_q))
        # Anchor each IMU sample on the reference sample at or before it (after it before the first one).
        k = np.clip(np.searchsorted(self.t_ref, self.t_imu, side="right") - 1, 0, len(self.t_ref) - 1)
        self._anchor = k
        R_at_ref = self._rot_at(self.t_ref)
        rel = R_at_ref[k].inv() * self._R_imu
        self.C_imu = Rotation.from_matrix(self.C_ref[k]) * rel
        g_n = np.array([0.0, 0.0, gravity_mps2])
        a_n = self.C_imu.apply(np.asarray(f_b, float)) + g_n
        self._V = np.asfortranarray(cumulative_integral(self.t_imu, a_n))

    def _screen(self, envelope) -> None:
        from graphnav.core.config import DvlSpec
        from graphnav.core.screening import gt_implausible
        masks = gt_implausible(self.t_ref, self.v_ref, envelope or DvlSpec())
        bad = np.any(list(masks.values()), axis=0)
        self.n_refused = {k: int(m.sum()) for k, m in masks.items() if m.any()}
        if bad.any():
            if bad.sum() > 0.5 * len(bad):
                raise DataError(f"{int(bad.sum())} of {len(bad)} reference samples implausible ({self.n_refused})",
                                "gt", int(np.flatnonzero(bad)[0]), "v_n")
            warnings.warn(f"reference: {int(bad.sum())} ground-truth sample(s) left out ({self.n_refused}), first at "
                          f"index {int(np.flatnonzero(bad)[0])}, t = {self.t_ref[bad][0]:.3f} s", RuntimeWarning,
                          stacklevel=3)
            self.t_ref, self.v_ref, self.C_ref = self.t_ref[~bad], self.v_ref[~bad], self.C_ref[~bad]

    def _rot_at(self, t: np.ndarray) -> Rotation:
        """Gyro-integrated rotation (relative to the IMU start) at arbitrary times, rotation at sample
        before ``t`` plus the partial step."""
        i = np.clip(np.searchsorted(self.t_imu, t, side="right") - 1, 0, len(self.t_imu) - 2)
        frac = (t - self.t_imu[i])[:, None]
        return self._R_imu[i] * Rotation.from_rotvec(self.omega_b[i] * frac)

    def covers(self, t: np.ndarray) -> np.ndarray:
        """True where ``t`` lies inside both the reference and the IMU time span."""
        t = np.asarray(t, float)
        return ((t >= max(self.t_ref[0], self.t_imu[0])) & (t <= min(self.t_ref[-1], self.t_imu[-1])))

    def C_b_n(self, t: np.ndarray) -> np.ndarray:
        """(M,3,3) attitude at times t (IMU clock): reference sample before t propagated with the gyro."""
        return self.rotation_b_n(t).as_matrix()

    def rotation_b_n(self, t: np.ndarray) -> Rotation:
        """The attitude of :meth:`C_b_n` as M rotations (4 numbers each, not 9: long missions at IMU rate). The
        gyro carries it from the sample before ``t`` without the Earth rate (at most 7e-5 rad/s, 4e-3 deg a
        second)."""
        t = np.asarray(t, float)
        k = np.clip(np.searchsorted(self.t_ref, t, side="right") - 1, 0, len(self.t_ref) - 1)
        rel = self._rot_at(self.t_ref[k]).inv() * self._rot_at(t)
        return Rotation.from_matrix(self.C_ref[k]) * rel

    def v_n(self, t: np.ndarray) -> np.ndarray:
        """(M,3) NED velocity at times t: blend of accelerometer integration from both neighbours."""
        t = np.asarray(t, float)
        k = np.clip(np.searchsorted(self.t_ref, t, side="right") - 1, 0, len(self.t_ref) - 2)
        t0, t1 = self.t_ref[k], self.t_ref[k + 1]
        V = interp_rows(t, self.t_imu, self._V)
        V0 = interp_rows(t0, self.t_imu, self._V)
        V1 = interp_rows(t1, self.t_imu, self._V)
        forward = self.v_ref[k] + (V - V0)
        backward = self.v_ref[k + 1] - (V1 - V)
        alpha = ((t - t0) / (t1 - t0))[:, None]
        return (1 - alpha) * forward + alpha * backward

    def v_b(self, t: np.ndarray, C_b_n: np.ndarray | None = None) -> np.ndarray:
        """(M,3) body velocity of the IMU at times t, m/s (``C_b_n``: attitude at t if already known)."""
        C = self.C_b_n(t) if C_b_n is None else C_b_n
        return np.einsum("kji,kj->ki", C, self.v_n(t))

    def omega_nb_b(self, t: np.ndarray, C_b_n: np.ndarray | None = None) -> np.ndarray:
        """(M,3) body rate relative to the nav frame (gyro minus Earth rate), rad/s."""
        t = np.asarray(t, float)
        C = self.C_b_n(t) if C_b_n is None else C_b_n
        omega = interp_rows(t, self.t_imu, self.omega_b)
        return omega - np.einsum("kji,j->ki", C, self.omega_ie_n)


def reference_gyro_increments(t_ref: np.ndarray, C_b_n_ref: np.ndarray, lat_rad: float | None) -> np.ndarray:
    """What the gyro integrates over each reference interval, (K-1,3): ``Log(C_k^T C_k+1)`` plus the Earth
    rate ``C_k^T omega_ie_n dt`` (left out when ``lat_rad`` is None)."""
    C = C_b_n_ref
    incr = Rotation.from_matrix(np.swapaxes(C[:-1], 1, 2) @ C[1:]).as_rotvec()
    if lat_rad is not None:
        incr += np.einsum("kji,j->ki", C[:-1], earth_rate_n(lat_rad)) * np.diff(t_ref)[:, None]
    return incr


def estimate_gt_time_offset(t_imu, omega_b, t_gt, C_b_n_gt, lat_rad: float | None = None,
                            search_s: tuple[float, float] = (-2.0, 2.0),
                            step_s: float = 0.02, source: str = "gt") -> OffsetEstimate:
    """Offset to add to the reference stamps so the reference attitude agrees with the gyro.

    Between reference samples k and k+1 the attitude increment ``Log(C_k^T C_k+1)`` is compared with the
    integral of ``omega_b - C_k^T omega_ie_n`` over ``[t_k + offset, t_k+1 + offset]`` (first order in the
    increment; at 1 Hz and <= 0.1 rad/s the coning term is below the gyro quantisation).

    Args:
        t_imu: (N,) IMU stamps, s. omega_b: (N,3) gyro, rad/s (axis signs applied).
        t_gt: (K,) raw reference stamps, s. C_b_n_gt: (K,3,3) reference attitude.
        lat_rad: latitude for the Earth rate, or None to ignore it.
        search_s: candidate offset interval, s. step_s: grid step before refinement, s.
        source: the reference's file or stream, for the error.
    """
    t_imu = np.ascontiguousarray(t_imu, float)
    t_gt = np.asarray(t_gt, float)
    S = np.asfortranarray(cumulative_integral(t_imu, np.asarray(omega_b, float)))
    incr_ref = reference_gyro_increments(t_gt, np.asarray(C_b_n_gt, float), lat_rad)
    # Use only intervals that stay inside the IMU span for every candidate, so the cost is comparable.
    usable = (t_gt[:-1] + search_s[0] >= t_imu[0]) & (t_gt[1:] + search_s[1] <= t_imu[-1])
    if usable.sum() < 10:
        raise DataError(f"too little overlap between the IMU [{t_imu[0]:.3f}, {t_imu[-1]:.3f}] s and the reference "
                        f"[{t_gt[0]:.3f}, {t_gt[-1]:.3f}] s to estimate a time offset ({int(usable.sum())} reference "
                        "intervals inside the IMU span for every candidate, 10 needed)", source, field="t")
    usable = _clear_of_imu_gaps(t_imu, t_gt, usable, search_s)
    a_t, b_t, ref = t_gt[:-1][usable], t_gt[1:][usable], incr_ref[usable]

    def cost(offset):
        incr = interp_rows(b_t + offset, t_imu, S) - interp_rows(a_t + offset, t_imu, S)
        return float(np.sum((incr - ref) ** 2))

    x, sse, curv = _search_offset(cost, search_s[0], search_s[1], step_s)
    n = ref.size
    return OffsetEstimate(x, _sigma_from_curvature(sse, curv, n, 1), float(np.sqrt(sse / n)), n)


#: GT intervals an IMU gap falls in are left out of the GT clock search (`clock._AngleModel.inside`) where at least
#: this many are left clear of the gaps over the refinement's reach, else kept (as the fine GT time offset keeps them,
#: :func:`estimate_gt_time_offset`, :func:`_clear_of_imu_gaps`): a 1 Hz GT beside an IMU losing 0.4 s every 2 s
#: (0.3 s every 1 s) left 1-2 of an A-KIT log's 398 intervals, and the fit, scoring none, was put 0.06-0.95 s off with a
#: NaN sigma yet applied (-198.6 s, refused); scored across the gaps as before, 25-50 ms off.
GT_MIN_CLEAR_INTERVALS = 10


def _clear_of_imu_gaps(t_imu: np.ndarray, t_ref: np.ndarray, usable: np.ndarray, search_s: tuple[float, float]
                       ) -> np.ndarray:
    """The reference intervals ``usable`` (K-1,) less those a gap in the IMU stamps ``t_imu`` (s,
    :func:`~graphnav.core.dvl_kinematics.imu_gaps`) falls in at any offset in ``search_s`` (s): across one the gyro's
    integral is interpolated, not measured. A simulated 200 s log's GT (10 Hz) 0.3 s late beside an IMU losing 0.4 s
    every 7 s (1 s every 20 s) was put 18-20 (29-36) ms off, sigma 0.7 (1.3) ms; gapless within 0.1 ms. Where that
    leaves under :data:`GT_MIN_CLEAR_INTERVALS` (an IMU losing samples every few seconds), they are kept as they are."""
    from graphnav.core.dvl_kinematics import imu_gaps
    gaps = imu_gaps(t_imu)
    if not len(gaps):
        return usable
    clear = (np.searchsorted(gaps[:, 1], t_ref[:-1] + search_s[0], side="right")
             == np.searchsorted(gaps[:, 0], t_ref[1:] + search_s[1], side="left"))
    return usable & clear if np.count_nonzero(usable & clear) >= GT_MIN_CLEAR_INTERVALS else usable


def dvl_design(reference: Reference, t_dvl: np.ndarray, v_dvl: np.ndarray,
               ok: np.ndarray | None = None):
    """Rows of the DVL-minus-reference regression at DVL times already on the IMU clock.

    Returns ``(r, omega, v_ref, keep)``: r (M,3) = DVL velocity - reference body velocity, omega (M,3)
    body rate, v_ref (M,3) reference body velocity, and the bool mask of the pings used (finite, covered).
    """
    t_dvl = np.asarray(t_dvl, float)
    keep = reference.covers(t_dvl) & np.all(np.isfinite(v_dvl), axis=1)
    if ok is not None:
        keep &= ok
    t = t_dvl[keep]
    C = reference.C_b_n(t)
    v_ref = reference.v_b(t, C)
    omega = reference.omega_nb_b(t, C)
    return v_dvl[keep] - v_ref, omega, v_ref, keep


def lever_arm_fit(r: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares lever arm l from ``r = omega x l + e``; returns (l (3,), covariance (3,3), SSE)."""
    A = skew(omega).reshape(-1, 3)               # skew(omega) @ l == cross(omega, l), stacked per ping
    b = r.reshape(-1)
    l, *_ = np.linalg.lstsq(A, b, rcond=None)
    e = b - A @ l
    sse = float(e @ e)
    dof = max(len(b) - 3, 1)
    cov = np.linalg.pinv(A.T @ A) * sse / dof
    return l, cov, sse


#: How far (s, either way) the fine DVL time-offset search against the GT reaches (:func:`estimate_dvl_time_offset`).
DVL_OFFSET_SEARCH_S = 3.0


def estimate_dvl_time_offset(reference: Reference, t_dvl_raw: np.ndarray, v_dvl: np.ndarray,
                             lever_arm_b: np.ndarray | None = None,
                             search_s: tuple[float, float] = (-DVL_OFFSET_SEARCH_S, DVL_OFFSET_SEARCH_S),
                             step_s: float = 0.1, source: str = "dvl") -> OffsetEstimate:
    """Offset to add to raw DVL stamps so the DVL velocity matches the reference body velocity.

    Model: ``v_dvl(t_raw) = v_b(t_raw + offset) + omega_b(t_raw + offset) x l_b``. With ``lever_arm_b``
    given the lever arm is held; with None it is fitted by least squares at every candidate offset
    (``extra["lever_arm_b"]``, ``extra["lever_arm_cov"]``).

    Args:
        reference: the reference trajectory on the IMU clock.
        t_dvl_raw: (M,) raw DVL stamps, s. v_dvl: (M,3) DVL-head body velocity, m/s (NaN rows skipped).
        source: the DVL's file, which a DataError names (too little overlap, no ping with a velocity in it).
    """
    t_raw = np.asarray(t_dvl_raw, float)
    v_dvl = np.asarray(v_dvl, float)
    # Same pings for every candidate: those whose shifted stamp stays covered over the whole search.
    ok = reference.covers(t_raw + search_s[0]) & reference.covers(t_raw + search_s[1])
    if ok.sum() < 10:
        raise DataError("too little overlap between DVL and reference to estimate a time offset", source)
    if not np.all(np.isfinite(v_dvl[ok]), axis=1).any():        # the fit would divide by zero pings
        # the window the pings were taken from (``ok``), not the whole span: a ping nearer an end than the search
        # reaches is not used, and naming the span sent users to velocities the fit never saw
        span = max(reference.t_ref[0], reference.t_imu[0]), min(reference.t_ref[-1], reference.t_imu[-1])
        margin = f"{-search_s[0]:g} s" + (f" at its start, {search_s[1]:g} s at its end" if -search_s[0] != search_s[1]
                                          else " at either end")
        used = span[0] - search_s[0], span[1] - search_s[1]
        raise DataError(f"no DVL ping with a velocity inside [{used[0]:.3f}, {used[1]:.3f}] s, the reference span "
                        f"[{span[0]:.3f}, {span[1]:.3f}] s less the {margin} that the offset search moves a ping, to "
                        f"estimate a time offset ({int(ok.sum())} ping(s) there, none with a velocity)", source)

    def fit(offset):
        r, omega, _, _ = dvl_design(reference, t_raw + offset, v_dvl, ok)
        if lever_arm_b is None:
            l, cov, sse = lever_arm_fit(r, omega)
            return sse, l, cov, r.size
        e = r - np.cross(omega, lever_arm_b)
        return float(np.sum(e ** 2)), np.asarray(lever_arm_b, float), None, r.size

    def cost(offset):
        return fit(offset)[0]

    x, sse, curv = _search_offset(cost, search_s[0], search_s[1], step_s)
    sse, l, cov, n = fit(x)
    n_params = 1 + (3 if lever_arm_b is None else 0)
    extra = {"lever_arm_b": l}
    if cov is not None:
        extra["lever_arm_cov"] = cov
    return OffsetEstimate(x, _sigma_from_curvature(sse, curv, n, n_params), float(np.sqrt(sse / n)), n,
                          extra)


def dvl_residual_rms(reference: Reference, t_dvl: np.ndarray, v_dvl: np.ndarray,
                     lever_arm_b: np.ndarray) -> tuple[float, np.ndarray]:
    """RMS (over pings and axes) and per-axis RMS of DVL minus (reference v_b + omega x l), m/s.

    ``t_dvl`` must already be on the IMU clock.
    """
    r, omega, _, _ = dvl_design(reference, t_dvl, v_dvl)
    e = r - np.cross(omega, np.asarray(lever_arm_b, float))
    return float(np.sqrt(np.mean(e ** 2))), np.sqrt(np.mean(e ** 2, axis=0))


def gyro_attitude_error(t_imu, omega_b, t_ref, C_b_n_ref, start_s: float, duration_s: float,
                        lat_rad: float | None = None) -> np.ndarray:
    """Attitude error (rad) of gyro integration started from the reference attitude.

    Starts from the reference attitude at the first reference sample at or after ``start_s`` and
    integrates ``C' = C [omega_b]x - [omega_ie_n]x C`` (each IMU rate held until the next sample; the
    Earth rate is applied on the nav side in closed form) until ``duration_s`` later. Returns (K,3)
    body-frame errors ``Log(C_ref^T C_gyro)`` at the K reference samples of the window (first row zero).
    """
    t_imu = np.ascontiguousarray(t_imu, float)
    t_ref = np.asarray(t_ref, float)
    omega_b = np.asarray(omega_b, float)
    sel = np.flatnonzero((t_ref >= max(start_s, t_imu[0])) &
                         (t_ref <= min(start_s + duration_s + 1e-9, t_imu[-1])))
    if len(sel) < 2:
        raise DataError("no reference samples inside the requested window", "gt", field="t")
    t_start, t_end = t_ref[sel[0]], t_ref[sel[-1]]
    inner = t_imu[(t_imu > t_start) & (t_imu < t_end)]
    grid = np.unique(np.concatenate([inner, t_ref[sel]]))
    src = np.clip(np.searchsorted(t_imu, grid[:-1], side="right") - 1, 0, len(t_imu) - 1)
    steps = Rotation.from_rotvec(omega_b[src] * np.diff(grid)[:, None]).as_quat()
    quats = cumulative_quat_product(steps)
    at_ref = np.searchsorted(grid, t_ref[sel])
    R_body = Rotation.from_quat(quats[at_ref])
    w_ie = np.zeros(3) if lat_rad is None else earth_rate_n(lat_rad)
    C_nav = Rotation.from_rotvec(-np.outer(t_ref[sel] - t_start, w_ie))
    C_est = C_nav * Rotation.from_matrix(C_b_n_ref[sel[0]]) * R_body
    return (Rotation.from_matrix(C_b_n_ref[sel]).inv() * C_est).as_rotvec()


# ------------------------------------------------------------------------------------------------
# Mission-level checks (used by tests/test_realdata.py, experiments/check_realdata.py and calibrate)
# ------------------------------------------------------------------------------------------------
#: Pings shallower than this (m, from the depth stream) are left out of the DVL-vs-reference RMS: at
#: the surface (trajectory 11 ends there) waves and bubbles make the DVL disagree by 0.1 m/s.
SURFACE_DEPTH_M = 2.0


def mission_reference(mission) -> Reference:
    """The IMU-aided :class:`Reference` built from a mission's ground truth (must have GT)."""
    cfg = mission.config
    if mission.gt is None:
        raise DataError("the mission has no ground truth", mission.name, field="gt")
    return Reference(mission.imu.t, mission.imu.f_b, mission.imu.omega_b, mission.gt.t, mission.gt.v_n,
                     mission.gt.C_b_n, cfg.gravity_mps2, cfg.lat_rad if cfg.earth_rotation else None, cfg.dvl)


def submerged_pings(mission, min_depth_m: float = SURFACE_DEPTH_M) -> np.ndarray:
    """(M,) bool: DVL pings taken deeper than ``min_depth_m`` (all True without a depth stream)."""
    if mission.depth is None:
        return np.ones(len(mission.dvl.t), bool)
    depth = np.interp(mission.dvl.t, mission.depth.t, mission.depth.depth)
    return depth > min_depth_m


def dvl_consistency(mission, reference: Reference | None = None, lever_arm_b=None,
                    min_depth_m: float = SURFACE_DEPTH_M) -> dict:
    """DVL body velocity vs reference ``v_b + omega x l`` (stamps as loaded), m/s.

    Returns ``{"rms": per-axis-pooled RMS over submerged pings, "rms_axes": (3,), "rms_all": RMS over
    every ping, "n": pings used, "n_surface": pings left out}``.
    """
    ref = reference or mission_reference(mission)
    l = mission.config.dvl.lever_arm_b if lever_arm_b is None else np.asarray(lever_arm_b, float)
    if mission.dvl.v_b is None:
        raise DataError("the mission's DVL has no body velocity", mission.name, field="dvl.v_b")
    deep = submerged_pings(mission, min_depth_m)
    rms_all, _ = dvl_residual_rms(ref, mission.dvl.t, mission.dvl.v_b, l)
    v = np.where(deep[:, None], mission.dvl.v_b, np.nan)
    rms, axes = dvl_residual_rms(ref, mission.dvl.t, v, l)
    return {"rms": rms, "rms_axes": axes, "rms_all": rms_all, "n": int(deep.sum()),
            "n_surface": int((~deep).sum())}


def gyro_check(mission, duration_s: float = 60.0, starts_s=None) -> np.ndarray:
    """Largest gyro-vs-reference attitude error (rad) within ``duration_s`` from each start time.

    ``starts_s`` default: every 100 s that leaves a full window.
    """
    gt = mission.gt
    if starts_s is None:
        starts_s = np.arange(max(gt.t[0], mission.t0), min(gt.t[-1], mission.t1) - duration_s, 100.0)
    lat = mission.config.lat_rad if mission.config.earth_rotation else None
    return np.array([np.linalg.norm(gyro_attitude_error(mission.imu.t, mission.imu.omega_b, gt.t, gt.C_b_n,
                                                        s, duration_s, lat), axis=1).max()
                     for s in starts_s])


def ground_truth_at(mission, r_b) -> GroundTruth:
    """The mission's ground truth moved to the point ``r_b`` (body frame, m, relative to the GT point).

    See :func:`move_ground_truth`. On the raw A-KIT reference (``load_akit(..., imu_position_b=(0, 0, 0))``)
    the accelerometer's point is ~[-1.77, -0.01, -0.12] m from the GT point (``graphnav calibrate`` both modes),
    whose velocity differs from the GT point's by 0.1-0.2 m/s RMS on the turning trajectories.
    """
    return move_ground_truth(mission.gt, mission.imu.t, mission.imu.omega_b, r_b,
                             mission.config.lat_rad if mission.config.earth_rotation else None)


def move_ground_truth(gt, t_imu, omega_b, r_b, lat_rad: float | None) -> GroundTruth:
    """Ground truth moved to the point ``r_b`` (body frame, m, relative to the GT point).

    ``p_n + C_b_n r_b`` and ``v_n + C_b_n (omega_nb_b x r_b)``, with omega_nb_b the gyro interpolated at the
    GT stamps minus the Earth rate (``lat_rad`` None: no Earth rate); attitude unchanged.
    """
    from graphnav.core.mission import GroundTruth
    r_b = np.asarray(r_b, float).reshape(3)
    omega = interp_rows(gt.t, np.ascontiguousarray(t_imu), np.asarray(omega_b, float))
    if lat_rad is not None:
        omega = omega - np.einsum("kji,j->ki", gt.C_b_n, earth_rate_n(lat_rad))
    p_n = gt.p_n + gt.C_b_n @ r_b
    v_n = gt.v_n + np.einsum("kij,kj->ki", gt.C_b_n, np.cross(omega, r_b))
    return GroundTruth(gt.t.copy(), p_n, v_n, gt.C_b_n.copy(), gt.origin_lla, gt.source)
