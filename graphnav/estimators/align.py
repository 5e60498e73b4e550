"""Initial state of a vehicle from its own sensors: in-motion, DVL-aided alignment of a strapdown INS.

The vehicle may be underway (turning, diving) from the first sample. Method (inertial-frame or
"optimisation-based" alignment, the standard for DVL-aided in-motion alignment of a FOG INS):

* b0 and n0 are the body and NED frames at the first IMU sample ``t0``, frozen in inertial space.
  The gyro tracks ``C_bt_b0`` (body at t relative to b0: the product of ``Exp(omega_b dt)``, zero-order
  hold as everywhere in graphnav); the Earth rate gives ``C_nt_n0 = Exp(omega_ie_n (t - t0))``.
  The unknown is the constant ``C = C_b0_n0``, and ``C_b_n(t) = C_nt_n0^T C C_bt_b0``.
* In n0 the velocity equation ``dv_n/dt = C_b_n f_b + g_n(p_n) - 2 omega_ie x v_n`` (n the fixed tangent frame
  at the start, :mod:`graphnav.core.earth`) becomes
  ``d(C_nt_n0 v_n)/dt = C C_bt_b0 f_b + C_nt_n0 g_n(p_n) - omega_ie x (C_nt_n0 v_n)`` with
  ``C_nt_n0 v_n = C v_b0``, ``v_b0 = C_bt_b0 v_b`` (v_b: the DVL velocity of the IMU, lever arm removed).
  Integrated from the first DVL ping t_a to each later ping t_k:

      C beta_k = alpha_k,
      beta_k  = int C_bt_b0 f_b dt - (v_b0(t_k) - v_b0(t_a))                 (body b0, from IMU + DVL)
      alpha_k = -int C_nt_n0 g_n(p_n) dt + omega_ie x C int v_b0 dt           (n0, gravity + Coriolis)

  ``C`` starts as the solution of Wahba's problem over all pings (:meth:`scipy.spatial.transform.Rotation.
  align_vectors`, SVD, with the initial velocity as a free offset: the vectors are centred); the small
  Coriolis and gravity-change terms, which need ``C``, are iterated. A Gauss-Newton refinement then fits ``C``,
  the offset, the accelerometer bias ``b_a`` (``beta_k`` loses ``int C_bt_b0 dt b_a``; prior: the spec's turn-on sigma)
  and the DVL's scale factor ``s`` (per DVL axis) and beam biases ``b`` (the measured head velocity is
  ``C_d_b (I + diag(s)) v_d + P b``, ``P`` the pseudo-inverse of the valid beams; priors: the estimators',
  :meth:`graphnav.estimators.options.PriorOptions.dvl_error_sigmas`; the scale factor's regressor is the fitted
  velocity at each ping, not the ping, whose own noise would bias it positive), with each ping weighted by its DVL noise
  (the vertical is ~4x better than the horizontal); its inverse information matrix is the attitude covariance,
  the DVL errors marginalised. Roll and pitch come from the mean direction of the vectors
  (levelling, the DVL velocity change removing the vehicle's accelerations); heading from the slow turn of
  gravity in inertial space (gyrocompassing).

Expected accuracy (1-sigma; ``L`` latitude, ``Omega`` Earth rate, ``g`` gravity, ``T`` alignment time,
``N`` DVL pings, ``sigma_v`` velocity noise per horizontal axis of one ping):

* heading, gyrocompassing: ``sqrt((b_g / (Omega cos L))^2 + (ARW / (Omega cos L sqrt(T)))^2
  + (b_a tan L / g)^2 + (sqrt(720 / N) sigma_v / (g Omega cos L T^2))^2)``. The first three terms are
  the classic (stationary) gyro-bias, angle-random-walk and accelerometer-bias limits (b_g gyro bias rad/s,
  ARW rad/sqrt(s) = gyro noise density, b_a accelerometer bias m/s^2). The last is the DVL: a heading error
  psi shows up as a tilt growing at ``psi Omega cos L``, i.e. a velocity error ``g psi Omega cos L t^2 / 2``,
  and a least-squares fit of that quadratic to N noisy pings over T has that sigma. It falls with T^-2.5:
  with the default DVL spec (0.042 m/s per beam, sigma_v = 0.087 m/s) at 1 Hz it is ~8 deg after 60 s,
  ~1.4 deg after 120 s and ~0.14 deg after 300 s. This is why a DVL-aided alignment takes minutes even with
  a perfect gyro. :func:`gyrocompass_heading_terms` gives the terms; ``Alignment.info`` reports them.
* In turns the accelerometer bias is no longer the constant tilt of the stationary formula: a body-fixed bias
  rotates with the vehicle and part of it looks like the heading signature (simulated, 50 micro-g, 120 s
  with a 90 deg turn pair: ~1 deg). So do the DVL's beam biases (a body-frame velocity error turning with the
  vehicle) and scale factor (changing with the speed). The fit estimates them and its covariance carries this
  coupling, so the reported heading sigma is the fit's (DVL noise, accelerometer bias, DVL scale factor and beam
  biases, geometry of the manoeuvres) plus the gyro-bias and random-walk terms, scaled up when the residuals
  are larger than the DVL spec says.
* roll/pitch: about ``sqrt((b_a / g)^2 + (sqrt(12 / N) sigma_v / (g T))^2 + (b_g T / 2)^2)``, plus the heading
  error times the Earth's turn since t0 (the n0 vertical is no longer the local one): from the fit.

IMU gaps of 0.2-2.5 s (:data:`GAP_JOINED_S`) are joined: each stretch after one is turned by a fitted rotation (b0,
on the left) and its velocity change offset, with priors from the rates and specific forces around the gap
(:func:`_gap_priors`); a gyrocompassed heading is then checked from starts turned 90 deg either way and, when they
fit as well elsewhere, the alignment starts again after the gaps as it did before gaps were joined, refused only when
that stretch is short too (:meth:`Aligner._solve_checked`); one that passes the check is taken over the stretch after
the last gap once that is long enough on its own, live and recorded alike (:meth:`Aligner.check_ready`). Levelling with
a given heading or a heading source joins them.

Robustness: a single bad sample must not move the alignment. The aligner refuses what the screening of
:mod:`graphnav.core.screening` refuses (an IMU value beyond the instrument's full scale; a ping beyond the
vehicle's speed or ``|v_z|``, or a spike against the median of the last pings), and the fit itself rejects
pings whose residual is an outlier (Mahalanobis distance above :data:`FIT_REJECT_CHI2` times the fit's own
median scale) and solves again without them; the output velocity is the median of the nearby pings, not their
mean. Counts in ``Alignment.info`` (``n_imu_refused``, ``n_dvl_refused``, ``n_dvl_rejected_fit``).

Gravity changes along the path: ``g_n(p_n)`` tilts by ``|p_h| / R`` away from the start (in a local-level frame
this is the transport rate) and grows with depth, its gradient times the position dead-reckoned from the pings
(:func:`_gravity_change_integral`). A constant ``g_n`` made a heading error of the order of ``v / (R Omega cos L)``
(0.3 deg at 2 m/s northward): 0.09-0.23 deg with exact sensors on the simulated survey (docs/decisions/alignment.md).

:meth:`Aligner.result` gives the state at the last sample used (a streaming navigator starts there);
:meth:`Aligner.result_at` at any stamp of the window, e.g. the first sample, for offline smoothing of a
whole record.

Frames and units: body FRD, NED, ``C_b_n`` body-to-NED, SI units, angles in rad, GTSAM's right
perturbation for the attitude covariance (``C_true = C_est @ Exp(delta)``, delta in the body frame).
"""
from __future__ import annotations

import bisect
import copy
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.spatial.transform import Rotation

from graphnav.core.config import DEG_PER_HOUR, SensorConfig
from graphnav.core.dvl import DvlGeometry
from graphnav.core.earth import EARTH_RATE, EarthModel, earth_rate_n, lla_to_ned
from graphnav.core.errors import ConfigError
from graphnav.core.imu_timing import imu_rate_hz
from graphnav.core.mission import IMU_GAP_PERIODS
from graphnav.core.screening import SpikeTest
from graphnav.core.rotations import C_b_n_to_euler, skew, so3_exp_batch
from graphnav.core.solution import LOCAL_ORIGIN
from graphnav.estimators.ins import prefix_products
from graphnav.estimators.keyframes import gyro_at
from graphnav.estimators.options import PriorOptions


#: A ping whose fit residual (Mahalanobis, 3 dof) exceeds this times the fit's median scale (median of the
#: distances / 2.366, the chi-square(3) median, at least 1) is an outlier: 25 is a chi-square(3) tail of 1.5e-5,
#: so a clean 300-ping alignment loses none (checked on the simulated missions in tests/test_screening.py).
FIT_REJECT_CHI2 = 25.0
#: Rounds of outlier rejection and re-solving in the fit.
FIT_REJECT_ROUNDS = 3
#: Prior information of an error the fit holds at zero (``estimate_accel_bias`` / ``estimate_dvl_errors`` False).
FIXED_PRIOR = 1e12
#: Gauss-Newton iterations of the fit, twice: with the DVL scale factor's column from the pings, then from the fit.
FIT_ITERATIONS = 3


#: IMU gaps up to this long, s, are held over by the alignment (:meth:`Aligner.imu_gap`); longer ones are joined
#: (:data:`GAP_JOINED_S`) or start it again.
#: Bridged, a loss of every sensor moved the gyrocompassed heading of a 150 s simulated stream 0.09 deg for 0.06 s
#: (samples refused as out of order), 0.38 deg for 0.5 s, 3.9 deg for 1 s, 23 deg for 2 s (its sigma 0.8 deg); a
#: step of the clock, which the stamps cannot tell from a loss, moves it at any length (0.03 s: 5 deg, 0.5 s: 54 deg).
#: The position pays more than the heading: a loss of 0.1 / 0.2 / 0.3 / 0.5 s at 60 s of 200 s simulated streams
#: (seeds 2-4, drift at the end 0.2-5.2 m clean) added up to 0.9 / 4.5 / 12 / 42 m, all said ok; started again
#: after a 0.6 s loss, 1.0-3.4 m.
GAP_CARRIED_S = 0.2
#: IMU gaps longer than :data:`GAP_CARRIED_S` and up to this long, s, are joined (:meth:`Aligner.imu_gap`): the
#: alignment keeps the data on both sides and fits the rotation and velocity change across each such gap with a prior
#: from the rates around it (:func:`_gap_priors`); longer gaps start it again. 2.5 s takes the 2 s losses of a logger
#: (measured 2.01-2.1 s between the samples either side) and stays below the 5 s clock steps and losses the
#: estimators' tests stream, whose bridge was off by 4 deg of roll (docs/decisions/alignment.md).
GAP_JOINED_S = 2.5
#: Turns, rad, of the second and third starts of a fit across joined IMU gaps (:meth:`Aligner._solve_checked`).
HEADING_CHECK_TURNS_RAD = (np.pi / 2, -np.pi / 2)
#: A fit from another start that ends elsewhere with a cost (chi-square) less than this much higher is as good.
HEADING_CHECK_CHI2 = 9.0
#: IMU time, s, after which an alignment refused for an undetermined heading is tried again (live); twice as long after
#: each further refusal (a fit over 300-400 s of A-KIT data with 75-98 joined gaps took 1.0-3.8 s, and two or
#: three of them make a check).
HEADING_RECHECK_S = 60.0


class AlignmentError(ConfigError):
    """The aligner cannot produce an initial state; the message says what is missing."""


@dataclass
class AlignOptions:
    """Settings of :class:`Aligner` (SI units).

    Attributes:
        duration_s: alignment time when the heading comes from gyrocompassing, s. Measured on the ten shared
            A-KIT trajectories (Phins FOG, 1 Hz DVL, vehicle underway; ``experiments/alignment_report.py``), heading
            RMS error: 36 deg (30 s), 9.7 deg (60 s), 2.0 deg (120 s), 1.2 deg (180 s), 0.52 deg (240 s),
            0.28 deg (300 s); roll/pitch <= 0.02 deg from 60 s. Default 300 s, the in-motion alignment time
            FOG INS makers quote: the graph refines a heading error only slowly afterwards (Trajectory10,
            120 s: -4.9 deg at the start, still -2.2 deg 400 s later), and
            :class:`graphnav.estimators.navigator.Navigator` carries the alignment back to the first sample and catches up,
            so the longer wait costs latency, not estimates (``experiments/no_gt_runs.py``: mission VRMSE without
            GT 0.080 m/s with 120 s, against 0.056 from the GT; docs/decisions/alignment.md).
        min_duration_s: when the data end before ``duration_s`` (a short record), the shortest gyrocompassing
            window ``result_at(t, end_of_data=True)`` still accepts, s (2.0 deg RMS heading at 120 s).
        levelling_duration_s: alignment time when the heading comes from a heading source or is given, s
            (levelling alone needs far less data).
        min_dvl_pings: pings with >= 3 valid beams needed in the window (velocity changes for levelling).
        max_heading_sigma_rad: gyrocompassing is refused when the gyro bias alone limits the heading to a
            worse 1-sigma than this, rad (default 2 deg: a navigation-grade FOG at 0.01 deg/h gives 0.05 deg,
            a 1 deg/h tactical gyro 4.5 deg, a 10 deg/h MEMS 45 deg).
        given_heading_sigma_rad: 1-sigma of ``initial_heading_rad`` when no ``heading_sigma_rad`` is given.
        local_origin_sigma_m: horizontal 1-sigma of where on Earth a local origin is (no fix, no
            ``initial_lla``: the NED origin is then the vehicle's position at the first IMU sample), m. It goes to
            the solution's position frame (``info["alignment"]["origin_sigma_m"]``), not into its covariance: a
            covariance holding it could not show the drift since the start beside it (see
            ``docs/decisions/position-consistency.md``).
        start_position_sigma_m: horizontal 1-sigma of a local origin's start in its own frame (the start itself), m.
        initial_position_sigma_m: horizontal 1-sigma of a given ``initial_lla`` / ``initial_position_n``, m (a GNSS
            fix at launch: a few m; held to 1 m, a start 55 m off claimed 1.85 m against 22.7 m of error after
            the first fixes).
        unaligned_heading_sigma_rad, unaligned_tilt_sigma_rad, unaligned_velocity_sigma_mps: what is known of the
            heading, roll/pitch (rad) and velocity (m/s) before any data, the prior of the estimator that
            :class:`graphnav.estimators.navigator.Navigator` runs through the alignment's own data again
            (``align_catch_up``): the alignment's covariance there would count those data twice (measured:
            docs/decisions/alignment.md). Wide: a vehicle launched at any heading, roughly level, slow. The EKF
            narrows the heading one to ``EkfOptions.catch_up_heading_sigma_factor`` times the aligned sigma.
        unknown_depth_sigma_m: 1-sigma of the depth without a depth sensor (the start is taken at depth 0,
            the vertical is dead-reckoned), m.
        max_window_s: the aligner keeps at most this much data (the newest), s; bounds memory when
            ``result`` is called late or never.
        coriolis_iterations: Wahba solutions (the Coriolis term of alpha uses the previous one).
        estimate_accel_bias: estimate the accelerometer bias in the fit (observable when the vehicle turns;
            the spec's turn-on sigma is its prior); False holds it at zero.
        estimate_dvl_errors: estimate the DVL scale factor (per DVL axis) and beam biases in the fit, with the
            estimators' priors (``dvl_scale_sigma``, ``dvl_bias_sigma``); False holds them at zero and the
            heading and tilt sigmas leave them out (over-confident when the DVL has them: docs/decisions/alignment.md).
        dvl_scale_sigma, dvl_bias_sigma: prior sigmas of the DVL scale factor (unitless) and of each beam bias
            (m/s); None = the estimators' (:meth:`graphnav.estimators.options.PriorOptions.dvl_error_sigmas`).
        velocity_window_s: the velocity at the output stamp is the mean of the pings within half this window of
            it, each carried there with the aligned IMU, s (one ping has ~0.09 m/s noise per horizontal axis).
        initial_position_n, initial_lla, initial_heading_rad, heading_sigma_rad: what is known at the start
            (None = unknown), below.
        initial_position_n: (3,) NED position at the first IMU sample relative to the local origin, m (the
            local origin is then the user's; default (0, 0, depth)).
        initial_lla: (lat rad, lon rad, alt m) of the vehicle at the first IMU sample: the NED origin when no
            fix arrives (a fix still sets the origin when it does).
        initial_heading_rad: yaw at the first IMU sample, rad (e.g. from the launch); heading source "given".
        heading_sigma_rad: its 1-sigma, rad; None = ``given_heading_sigma_rad``.
    """

    duration_s: float = 300.0
    min_duration_s: float = 120.0
    levelling_duration_s: float = 20.0
    min_dvl_pings: int = 5
    max_heading_sigma_rad: float = np.deg2rad(2.0)
    given_heading_sigma_rad: float = np.deg2rad(5.0)
    local_origin_sigma_m: float = 100.0
    start_position_sigma_m: float = 1.0
    initial_position_sigma_m: float = 5.0
    unaligned_heading_sigma_rad: float = np.deg2rad(30.0)
    unaligned_tilt_sigma_rad: float = np.deg2rad(2.0)
    unaligned_velocity_sigma_mps: float = 0.5
    unknown_depth_sigma_m: float = 100.0
    max_window_s: float = 600.0
    coriolis_iterations: int = 2
    estimate_accel_bias: bool = True
    estimate_dvl_errors: bool = True
    dvl_scale_sigma: float | None = None
    dvl_bias_sigma: float | None = None
    velocity_window_s: float = 10.0
    initial_position_n: tuple[float, float, float] | np.ndarray | None = None
    initial_lla: tuple[float, float, float] | None = None
    initial_heading_rad: float | None = None
    heading_sigma_rad: float | None = None

    def __post_init__(self):
        if self.initial_heading_rad is not None and not np.isfinite(self.initial_heading_rad):
            raise ConfigError(f"AlignOptions.initial_heading_rad must be finite, got {self.initial_heading_rad}")
        for name in ("duration_s", "min_duration_s", "levelling_duration_s", "max_heading_sigma_rad",
                     "given_heading_sigma_rad", "local_origin_sigma_m", "start_position_sigma_m",
                     "initial_position_sigma_m", "unknown_depth_sigma_m", "max_window_s", "velocity_window_s",
                     "unaligned_heading_sigma_rad", "unaligned_tilt_sigma_rad", "unaligned_velocity_sigma_mps"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"AlignOptions.{name} must be > 0, got {getattr(self, name)}")
        if self.max_window_s < max(self.duration_s, self.levelling_duration_s):
            raise ConfigError("AlignOptions.max_window_s must be >= duration_s and levelling_duration_s")
        if self.min_dvl_pings < 2 or self.coriolis_iterations < 1:
            raise ConfigError("AlignOptions.min_dvl_pings must be >= 2 and coriolis_iterations >= 1")


@dataclass
class Alignment:
    """Initial navigation state of the IMU from the aligner.

    Attributes:
        t: stamp of the state, s (IMU clock): the last sample the aligner used (``result``), or the stamp asked
            for (``result_at``).
        C_b_n: (3,3) body-to-NED at t.
        v_n: (3,) NED velocity at t, m/s.
        p_n: (3,) NED position at t relative to ``origin_lla`` (or to the local origin: the vehicle's position
            at the first IMU sample when there was no fix), m; ``p_n[2]`` is the depth when a depth sensor
            was seen.
        origin_lla: (lat rad, lon rad, alt m) of the NED origin (the first fix, at the sea surface) or None.
        cov_rot: (3,3) rad^2, attitude error covariance in GTSAM's Rot3 tangent (right perturbation, body).
        cov_v_n: (3,3) (m/s)^2; cov_p_n: (3,3) m^2.
        bias_acc, bias_gyro: (3,) initial bias estimates, m/s^2 and rad/s (zeros: not estimated).
        heading_source: ``"gyrocompass"``, ``"heading"`` (add_heading) or ``"given"`` (initial_heading_rad).
        info: duration, sample counts, expected accuracies and their terms, residuals, sources.
        dvl_errors: (7,) the DVL's fitted scale factor per DVL axis (unitless) and beam biases (m/s); zeros when
            held at zero (``estimate_dvl_errors=False``).
        cov_joint: (16,16) covariance of the errors of [attitude (as ``cov_rot``), ``v_n``, ``bias_acc``,
            ``dvl_errors``] with their cross-terms (``cov_rot`` and ``cov_v_n`` are its blocks), or None.
    """

    t: float
    C_b_n: np.ndarray
    v_n: np.ndarray
    p_n: np.ndarray
    origin_lla: tuple | None
    cov_rot: np.ndarray
    cov_v_n: np.ndarray
    cov_p_n: np.ndarray
    bias_acc: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bias_gyro: np.ndarray = field(default_factory=lambda: np.zeros(3))
    heading_source: str = "gyrocompass"
    info: dict = field(default_factory=dict)
    dvl_errors: np.ndarray = field(default_factory=lambda: np.zeros(7))
    cov_joint: np.ndarray | None = None

    @property
    def euler(self) -> np.ndarray:
        """Roll, pitch, yaw at t, rad."""
        return C_b_n_to_euler(self.C_b_n)

    @property
    def rot_sigma_rad(self) -> np.ndarray:
        """1-sigma of the attitude error about the body axes, rad (sqrt of the diagonal of cov_rot)."""
        return np.sqrt(np.diag(self.cov_rot))


def gyrocompass_heading_terms(config: SensorConfig, duration_s: float, n_pings: int, sigma_v: float,
                              lat_rad: float | None = None) -> dict:
    """The terms (rad, 1-sigma) of the expected gyrocompassing heading error (module docstring).

    Args:
        config: sensor configuration (IMU spec, gravity, latitude).
        duration_s: alignment time T, s; n_pings: DVL pings N; sigma_v: DVL velocity noise per axis, m/s.
        lat_rad: latitude, rad (default ``config.lat_rad``).
    """
    lat = config.lat_rad if lat_rad is None else lat_rad
    horizontal_rate = EARTH_RATE * np.cos(lat) if config.earth_rotation else 0.0
    imu, g, T = config.imu, config.gravity_mps2, max(duration_s, 1e-9)
    if horizontal_rate <= 0.0:
        inf = float("inf")
        return {"gyro_bias": inf, "gyro_arw": inf, "accel_bias": imu.accel_bias_sigma * np.tan(lat) / g, "dvl": inf}
    return {
        "gyro_bias": imu.gyro_bias_sigma / horizontal_rate,
        "gyro_arw": imu.gyro_noise_density / (horizontal_rate * np.sqrt(T)),
        "accel_bias": imu.accel_bias_sigma * abs(np.tan(lat)) / g,
        "dvl": np.sqrt(720.0 / max(n_pings, 1)) * sigma_v / (g * horizontal_rate * T ** 2),
    }


def _rss(terms: dict) -> float:
    return float(np.sqrt(sum(v ** 2 for v in terms.values())))


class Aligner:
    """Initial state of a moving vehicle from its IMU, DVL, depth sensor and optional fixes and headings.

    Feed measurements in time order (``add_*``); when :meth:`check_ready` says so, :meth:`result` gives the
    :class:`Alignment` at the last sample used. See the module docstring for the method and its accuracy.

    Args:
        config: sensor configuration: IMU spec (decides whether gyrocompassing is possible), DVL geometry and
            lever arm, gravity, latitude (a fix's latitude replaces it), Earth rotation.
        options: :class:`AlignOptions`, with what is known at the start (initial heading, position).
    """

    def __init__(self, config: SensorConfig, options: AlignOptions | None = None):
        self.config = config
        self.options = o = options or AlignOptions()
        self.geometry = DvlGeometry.from_spec(config.dvl)
        self.initial_position_n = None if o.initial_position_n is None else \
            np.asarray(o.initial_position_n, float).reshape(3)
        self.initial_lla = None if o.initial_lla is None else tuple(float(x) for x in o.initial_lla)
        self.initial_heading_rad = o.initial_heading_rad
        self.heading_sigma_rad = o.given_heading_sigma_rad if o.heading_sigma_rad is None \
            else float(o.heading_sigma_rad)
        self._imu: list[tuple[float, np.ndarray, np.ndarray]] = []
        # (t, velocity of the DVL head in body m/s, (3,4) its error per beam bias: the valid beams' pseudo-inverse)
        self._dvl: list[tuple[float, np.ndarray, np.ndarray]] = []
        self._depth: list[tuple[float, float]] = []
        self._fixes: list[tuple[float, float, float, float]] = []
        self._headings: list[tuple[float, float, float]] = []
        self.n_dvl_ignored = 0       # pings with < 3 valid beams or before the first IMU sample
        self.n_imu_refused = 0       # IMU samples beyond the instrument's full scale
        self.n_dvl_refused = 0       # pings outside the vehicle's envelope or spiking
        spec = config.dvl
        self._dvl_spike = SpikeTest(spec.max_accel_mps2, spec.jump_tolerance_mps)
        # IMU gaps (t0, t1) s met so far, and the longest stretch of data before the last of them (imu, dvl, depth)
        self.imu_gaps: list[tuple[float, float]] = []
        # IMU gaps (t0, t1) s the alignment joins over (:data:`GAP_JOINED_S`): fitted, not started again after; only
        # those inside the data held are kept (a live run with periodic gaps would grow the list for its whole length)
        self.joined_gaps: list[tuple[float, float]] = []
        self._n_gaps_told = 0        # IMU gaps longer than GAP_CARRIED_S told so far (imu_gap)
        # the data held (_data_key) when the joined gaps last left the heading determined: not checked again for them
        self._checked: tuple | None = None
        # (this aligner as it was when ready across joined gaps, _n_gaps_told then) while the data after the last of
        # them gather (check_ready)
        self._joined_wait: tuple[Aligner, int] | None = None
        # (IMU stamp to fit again at, s, why) when joined gaps last left the heading undetermined (_solve_checked),
        # and how many times in a row they did
        self._undetermined: tuple[float, str] | None = None
        self._n_undetermined = 0
        # why the alignment started again after joined IMU gaps (_fall_back), for Alignment.info
        self._not_joined: str | None = None
        self._before_gap: tuple[list, list, list] | None = None

    # --- input ------------------------------------------------------------------------------------
    def add_imu(self, t: float, f_b, omega_b) -> None:
        """IMU sample: specific force f_b (3,) m/s^2 and angular rate omega_b (3,) rad/s, body; held over
        [t, next t) (increment convention). A sample beyond the IMU's full scale (or not finite) is refused:
        one such sample would shift every later velocity increment."""
        f = np.asarray(f_b, float).reshape(3)
        w = np.asarray(omega_b, float).reshape(3)
        imu = self.config.imu
        if not (np.all(np.abs(f) <= imu.accel_range_mps2) and np.all(np.abs(w) <= imu.gyro_range_rads)):
            self.n_imu_refused += 1
            return
        self._imu.append((float(t), f, w))
        self._trim()

    def add_ping(self, ping) -> None:
        """A DVL ping as the Navigator made it (:class:`~graphnav.estimators.types.Ping`): its DVL-frame velocity
        (:meth:`add_dvl_velocity`) or its measured beams (:meth:`add_dvl`)."""
        if ping.is_velocity:
            self.add_dvl_velocity(ping.t, ping.v_d, ping.v_d_sigma)
        else:
            self.add_dvl(ping.t, ping.beams, ping.measured)

    def add_dvl(self, t: float, beams, valid) -> None:
        """DVL ping: along-beam velocities (4,) m/s and the valid mask (4,) bool (>= 3 valid beams used)."""
        beams = np.asarray(beams, float).reshape(4)
        valid = np.asarray(valid, bool).reshape(4) & np.isfinite(beams)
        if valid.sum() < 3 or not self._imu:
            self.n_dvl_ignored += 1
            return
        v = self.geometry.velocity_from_beams(beams, valid)
        spec = self.config.dvl
        if (np.linalg.norm(v) > spec.max_speed_mps or abs(v[2]) > spec.max_vertical_mps
                or self._dvl_spike.is_spike(float(t), v)):
            self.n_dvl_refused += 1
            return
        self._dvl.append((float(t), v, self._bias_map(valid)))

    def add_dvl_velocity(self, t: float, v_d, sigma=None) -> None:
        """A DVL-frame velocity of the DVL head (3,) m/s measured by the instrument (used as a >= 3-beam ping;
        ``sigma`` is not used: the alignment weighs every ping alike)."""
        if not self._imu:
            self.n_dvl_ignored += 1
            return
        self._dvl.append((float(t), self.geometry.C_d_b @ np.asarray(v_d, float).reshape(3),
                          self._bias_map(np.ones(4, bool))))

    def _bias_map(self, valid: np.ndarray) -> np.ndarray:
        """(3,4) body velocity error, m/s, per beam bias (m/s) of a least-squares solution from the ``valid`` beams."""
        out = np.zeros((3, 4))
        out[:, valid] = np.linalg.pinv(self.geometry.T_b[valid])
        return out

    def add_depth(self, t: float, depth_m: float) -> None:
        """Depth of the IMU below the sea surface, m (positive down)."""
        self._depth.append((float(t), float(depth_m)))

    def add_position_fix(self, t: float, lat: float, lon: float, sigma_m: float) -> None:
        """Horizontal position fix of the IMU (GNSS at the surface, USBL): lat, lon in rad, 1-sigma m."""
        self._fixes.append((float(t), float(lat), float(lon), float(sigma_m)))

    def add_heading(self, t: float, yaw: float, sigma: float) -> None:
        """Heading (yaw of C_b_n, rad, e.g. AHRS or magnetometer corrected for declination) with 1-sigma rad."""
        self._headings.append((float(t), float(yaw), float(sigma)))

    def imu_gap(self, t0: float, t1: float) -> None:
        """The IMU stream has a gap from ``t0`` to ``t1`` (s; a loss of samples, or the clock stepped).

        A gap of at most :data:`GAP_CARRIED_S` is held over as any other step. One of at most :data:`GAP_JOINED_S`
        is joined: the alignment keeps the data either side, bridges the gap by interpolation and fits the bridge's
        error (its turn, with a prior from the rates around the gap that also covers a clock step, and its velocity
        change; :func:`_gap_priors`); a gyrocompassed heading that such gaps leave undetermined falls back to
        starting again after them, refused only when that is short too (:meth:`_solve_checked`). Over a longer gap
        the gyros cannot carry the attitude (a bridge of 5 s at 0.014 rad/s, straight through a roll the vehicle
        was not making, tilted the rest 4 deg: 0.7 m/s^2 of gravity into the levelling), so the alignment starts
        again after it. The data before it are kept while they are the
        longest stretch without such a gap: when the data end (:meth:`missing`, ``end_of_data``) the alignment is
        over the longest stretch (:attr:`t_first`)."""
        if t1 - t0 <= GAP_CARRIED_S:
            return
        self._n_gaps_told += 1
        if t1 - t0 <= GAP_JOINED_S:
            self.joined_gaps.append((float(t0), float(t1)))
            return
        self._start_again(float(t0), float(t1))

    def _start_again(self, t0: float, t1: float) -> None:
        """Start the alignment again after the IMU gap from ``t0`` to ``t1`` (s): the samples from ``t1`` on (none
        live, where the gap is told before its next sample) stay, those before it are kept while they are the
        longest stretch (:meth:`_take_longest_stretch`)."""
        self.imu_gaps.append((t0, t1))
        if not self._imu:
            return
        k = bisect.bisect_left([s[0] for s in self._imu], t1)
        held = (self._imu[:k], [d for d in self._dvl if d[0] <= t0], [d for d in self._depth if d[0] <= t0])
        if self._before_gap is None or _span(held[0]) > _span(self._before_gap[0]):
            self._before_gap = held
        self._imu, self._dvl, self._depth = self._imu[k:], [d for d in self._dvl if d[0] > t0], \
            [d for d in self._depth if d[0] > t0]
        self._forget_joined_gaps(self._imu[0][0] if self._imu else t1)

    def _forget_joined_gaps(self, t_first: float) -> None:
        """Drop the joined IMU gaps that start before ``t_first`` (s), the first IMU sample held: no fit or check
        uses them."""
        self.joined_gaps = [g for g in self.joined_gaps if g[0] >= t_first]

    def _take_longest_stretch(self) -> None:
        """At the end of the data: align over the stretch before a gap when it is longer than the one after."""
        if self._before_gap is not None and _span(self._before_gap[0]) > _span(self._imu):
            self._imu, self._dvl, self._depth = self._before_gap
            self._before_gap = None

    @property
    def t_first(self) -> float | None:
        """Stamp of the first IMU sample the alignment uses, s (after the last IMU gap, or before one at the end of
        the data, :meth:`imu_gap`); None before any."""
        return self._imu[0][0] if self._imu else None

    def _gap_note(self) -> str:
        """Why the IMU time held is short when gaps split it: names them (empty when none)."""
        if not self.imu_gaps:
            return ""
        where = ", ".join(f"{t1 - t0:.3g} s after t = {t0:.3f} s" for t0, t1 in self.imu_gaps[:3])
        return (f" (the IMU gap{'s' * (len(self.imu_gaps) > 1)} {where} split{'s' * (len(self.imu_gaps) == 1)} "
                "the data: the attitude is not carried over a gap, and the longest stretch without one counts)")

    def _joined_steps(self, t_imu: np.ndarray) -> np.ndarray:
        """Indices i of the steps from sample i to i + 1 (stamps ``t_imu``, s) that are joined IMU gaps."""
        if not self.joined_gaps:
            return np.zeros(0, int)
        i = np.searchsorted(t_imu, [g[0] for g in self.joined_gaps], side="right") - 1
        i = np.unique(i[(i >= 0) & (i < len(t_imu) - 1)])
        return i[np.diff(t_imu)[i] > GAP_CARRIED_S]

    def _trim(self) -> None:
        t_last = self._imu[-1][0]
        if t_last - self._imu[0][0] > self.options.max_window_s + 1.0:
            start = t_last - self.options.max_window_s
            del self._imu[:bisect.bisect_left([s[0] for s in self._imu], start)]
            del self._dvl[:bisect.bisect_left([s[0] for s in self._dvl], start)]
            del self._depth[:bisect.bisect_left([s[0] for s in self._depth], start)]
            self._forget_joined_gaps(self._imu[0][0])

    # --- readiness --------------------------------------------------------------------------------
    @property
    def lat_rad(self) -> float:
        """Latitude used for the Earth rate, rad: the first fix's, else the initial LLA's, else the config's."""
        if self._fixes:
            return self._fixes[0][1]
        if self.initial_lla is not None:
            return self.initial_lla[0]
        return float(self.config.lat_rad)

    def _has_heading_source(self) -> bool:
        return bool(self._headings) or self.initial_heading_rad is not None

    def _gyrocompass_bias_limit(self) -> float:
        """Heading 1-sigma (rad) that the gyro bias alone allows; inf without Earth rotation."""
        return gyrocompass_heading_terms(self.config, 1.0, 1, 0.0, self.lat_rad)["gyro_bias"]

    def missing(self, end_of_data: bool = False) -> list[str]:
        """What is still missing before :meth:`result` can work (empty when :attr:`ready`); ``end_of_data``:
        no more data will come, so a gyrocompassing window of ``min_duration_s`` is enough."""
        o, out = self.options, []
        if end_of_data:
            self._take_longest_stretch()
        need = self._needed_s(end_of_data)
        span = self._span_s()
        if not self._imu:
            out.append("no IMU samples (add_imu)")
        elif span < need:
            out.append(f"IMU data cover {span:.1f} s of the {need:g} s needed" + self._gap_note())
        if self._recheck_pending(end_of_data) and not self._after_last_joined_ready():
            out.append(self._undetermined[1])
        if len(self._dvl) < o.min_dvl_pings:
            out.append(f"{len(self._dvl)} DVL pings with >= 3 valid beams (bottom lock), {o.min_dvl_pings} needed "
                       "(add_dvl): a moving vehicle is levelled with the DVL velocity change")
        if not self._has_heading_source():
            limit = self._gyrocompass_bias_limit()
            if limit > o.max_heading_sigma_rad:
                why = ("Earth rotation is off in the configuration (earth_rotation=False)"
                       if not self.config.earth_rotation else
                       f"a gyro with bias {self.config.imu.gyro_bias_sigma / DEG_PER_HOUR:g} deg/h "
                       f"(IMU '{self.config.imu.name}') at latitude {np.degrees(self.lat_rad):.1f} deg would "
                       f"give a heading error of {np.degrees(limit):.1f} deg (limit "
                       f"{np.degrees(o.max_heading_sigma_rad):g} deg, AlignOptions.max_heading_sigma_rad)")
                out.append(f"heading cannot be determined by gyrocompassing: {why}; supply a heading source "
                           "(add_heading from an AHRS/magnetometer, or AlignOptions.initial_heading_rad)")
        return out

    def _needed_s(self, end_of_data: bool = False) -> float:
        """IMU time the alignment needs, s: levelling with a heading source, else gyrocompassing."""
        o = self.options
        if self._has_heading_source():
            return o.levelling_duration_s
        return min(o.min_duration_s, o.duration_s) if end_of_data else o.duration_s

    def _span_s(self) -> float:
        return _span(self._imu)

    def progress(self, end_of_data: bool = False) -> dict:
        """Where the alignment stands (a live status line): ``aligned_s`` IMU time gathered of ``needed_s``
        (s; ``end_of_data``: what an alignment at the end of the data needs, :meth:`missing`), ``dvl_pings`` with
        bottom lock of ``dvl_pings_needed``, ``heading`` (``"heading record"``, ``"given"`` or
        ``"gyrocompassing"``), ``waiting_for``: ``"imu time"``, ``"dvl bottom lock"``, ``"heading source"``
        (gyrocompassing impossible with this gyro or configuration), ``"imu time after a joined imu gap"`` (ready
        across joined IMU gaps, the alignment held while the data after them gather, :meth:`check_ready`;
        ``aligned_s`` is then the IMU time after the last of them), and
        ``imu_gaps``: why the IMU time gathered restarted (empty, or the IMU gaps in words, :meth:`imu_gap`)."""
        waiting = []
        span, need = self._span_s(), self._needed_s(end_of_data)
        if span < need:
            waiting.append("imu time")
        if len(self._dvl) < self.options.min_dvl_pings:
            waiting.append("dvl bottom lock")
        heading = ("heading record" if self._headings else "given" if self.initial_heading_rad is not None
                   else "gyrocompassing")
        if heading == "gyrocompassing" and self._gyrocompass_bias_limit() > self.options.max_heading_sigma_rad:
            waiting.append("heading source")
        if self._joined_wait is not None:       # else "waiting for" nothing, for up to duration_s
            waiting.append("imu time after a joined imu gap")
            if self.joined_gaps:                # the time gathered is what counts: after the last gap
                span = self._imu[-1][0] - self.joined_gaps[-1][1]
        return {"aligned_s": float(span), "needed_s": float(need), "dvl_pings": len(self._dvl),
                "dvl_pings_needed": int(self.options.min_dvl_pings), "dvl_pings_ignored": int(self.n_dvl_ignored),
                "heading": heading, "waiting_for": waiting, "imu_gaps": self._gap_note().strip(" ()")}

    @property
    def ready(self) -> bool:
        """True when :meth:`result` can produce an :class:`Alignment` now, without a fit: the data are enough and,
        across joined IMU gaps with a gyrocompassed heading, :meth:`check_ready` found the heading determined for
        the data held (and is not waiting for the data after the last of them)."""
        if self.missing() or self._joined_wait is not None:
            return False
        return not self._needs_heading_check() or self._checked == self._data_key()

    def check_ready(self, wait_after_joined_gaps: bool = True) -> bool:
        """Decide whether the alignment can start, and over which data (it changes them; :attr:`ready` does not):
        True when :meth:`result` can produce an :class:`Alignment`.

        Across joined IMU gaps a gyrocompassed heading is checked (:meth:`_solve_checked`; one the gaps leave
        undetermined starts again after them). One they leave determined is not taken yet: the aligner goes on
        gathering until the data after the last of those gaps are enough on their own, and aligns over them as
        before gaps were joined. Simulated (``simulate_mission(250, "navigation", seed)`` from 120 s, 90 s, IMU
        samples lost 20 s in), the joined heading was 5-10 deg off where the stretch after the gap gave 0.2-2.8 deg
        (docs/decisions/alignment.md). A further IMU gap longer than :data:`GAP_CARRIED_S` before then, or the end
        of the data (:meth:`stop_waiting`), keeps the alignment across the gaps as it was when first ready. A caller
        that cannot go back over the data gathered meanwhile (a Navigator without ``align_catch_up``) passes
        ``wait_after_joined_gaps=False`` and takes the alignment across the gaps at once."""
        if self._joined_wait is not None:
            if self._n_gaps_told != self._joined_wait[1]:
                self.stop_waiting()
                return True
            if not self.joined_gaps:
                # the window held (max_window_s) moved past the gaps before the data after them were enough: it
                # holds only data after them, and aligns over them once they are enough (else it waited for ever)
                if self.missing():
                    return False
                held = self._joined_wait[0]
                n, note = len(held._joined_steps(np.array([s[0] for s in held._imu]))), held._joined_note()
            else:
                if not self._after_last_joined_ready():
                    return False
                n, note = len(self._joined_steps(np.array([s[0] for s in self._imu]))), self._joined_note()
                if self._fall_back():
                    self.stop_waiting()
                    return True
            self._joined_wait = None
            self._not_joined = (f"the IMU gap{'s' * (n > 1)} ({note}) not joined: the data after "
                                f"{'them' if n > 1 else 'it'} are enough to gyrocompass over, as before gaps were "
                                "joined (a heading across joined gaps is no better)")
            return True
        if self.missing():
            return False
        if not self._needs_heading_check():
            return True
        try:
            self._solve_checked(None)
        except AlignmentError:
            return False
        if not self._needs_heading_check() or not wait_after_joined_gaps:      # started again after the gaps
            return True
        self._joined_wait = (copy.deepcopy(self), self._n_gaps_told)
        return self.check_ready()

    @property
    def waiting_after_joined_gaps(self) -> bool:
        """True while :meth:`check_ready` holds an alignment across joined IMU gaps and waits for the data after
        the last of them."""
        return self._joined_wait is not None

    def stop_waiting(self) -> None:
        """Take the alignment across the joined IMU gaps as it was when :meth:`check_ready` first found it ready
        (the data after the last gap will not be enough: the data ended, or the state is wanted before the gap);
        nothing when not waiting."""
        if self._joined_wait is not None:
            self.__dict__.update(self._joined_wait[0].__dict__)

    def _data_key(self) -> tuple:
        """What identifies the data held: IMU stamps first and last, and the counts of samples, pings and gaps."""
        return (self._imu[0][0], self._imu[-1][0], len(self._imu), len(self._dvl), len(self.joined_gaps)) \
            if self._imu else ()

    def _needs_heading_check(self) -> bool:
        return (bool(self.joined_gaps) and not self._has_heading_source() and len(self._imu) > 1
                and self._joined_steps(np.array([s[0] for s in self._imu])).size > 0)

    def _solve_checked(self, t_out: float | None, end_of_data: bool = False) -> Alignment:
        """:meth:`_solve` across joined IMU gaps, checked: when they leave the gyrocompassed heading undetermined
        (:meth:`_heading_undetermined`), the alignment starts again after them as it did before gaps were joined
        (:meth:`_fall_back`: over the stretch after the last, or the longest at the end of the data), and is refused
        only when that stretch is too short as well. A heading found undetermined is not fitted again before
        :meth:`_recheck_pending` says so."""
        if not self._needs_heading_check():
            al = self._solve(t_out, end_of_data)
            if self._not_joined is not None:
                al.info["imu_gaps_not_joined"] = self._not_joined
            return al
        if self._recheck_pending(end_of_data):
            why = self._undetermined[1]
        else:
            al = self._solve(t_out, end_of_data)
            if self._checked == self._data_key():
                return al
            why = self._heading_undetermined(al, t_out, end_of_data)
            if why is None:
                self._undetermined, self._n_undetermined, self._checked = None, 0, self._data_key()
                return al
            # each fit across hundreds of gaps costs seconds: wait twice as long after each refusal
            wait_s = HEADING_RECHECK_S * 2.0 ** min(self._n_undetermined, 20)
            self._undetermined, self._n_undetermined = (self._imu[-1][0] + wait_s, why), self._n_undetermined + 1
        short = self._fall_back(end_of_data)
        if short:
            raise AlignmentError(f"cannot align from the sensors: {why}; started again after the gaps, {short}")
        self._not_joined = why
        return self._solve_checked(t_out, end_of_data)

    def _heading_undetermined(self, al: Alignment, t_out: float | None, end_of_data: bool) -> str | None:
        """Why the joined IMU gaps leave the heading of ``al`` undetermined, or None: a fit started turned by each of
        :data:`HEADING_CHECK_TURNS_RAD` that ends more than 3 sigmas from it with a cost less than
        :data:`HEADING_CHECK_CHI2` higher is an equally good heading (docs/decisions/alignment.md)."""
        for turn in HEADING_CHECK_TURNS_RAD:
            other = self._solve(t_out, end_of_data, yaw_start=turn)
            apart = abs(float(np.angle(np.exp(1j * (other.euler[2] - al.euler[2])))))
            worse = other.info["fit_cost"] - al.info["fit_cost"]
            if apart > 3.0 * al.info["heading_sigma_rad"] and worse < HEADING_CHECK_CHI2:
                n = len(self._joined_steps(np.array([s[0] for s in self._imu])))
                gaps = f"the {n} IMU gaps joined" if n > 1 else "the IMU gap joined"
                return (f"{gaps} in the alignment ({self._joined_note()}) leave{'s' * (n == 1)} its gyrocompassed "
                        f"heading undetermined: a fit started {np.degrees(turn):+.0f} deg away ends at "
                        f"{np.degrees(other.euler[2]):.1f} deg against {np.degrees(al.euler[2]):.1f} deg (claimed "
                        f"sigma {np.degrees(al.info['heading_sigma_rad']):.2g} deg) with a cost {worse:+.2f} from "
                        "it; supply a heading source (add_heading, or AlignOptions.initial_heading_rad: "
                        "--initial-heading)")
        return None

    def _recheck_pending(self, end_of_data: bool = False) -> bool:
        """True while a heading the joined IMU gaps left undetermined waits (live) before it is fitted again:
        :data:`HEADING_RECHECK_S` of IMU time after the first refusal, twice as long after each further one."""
        return (not end_of_data and self._undetermined is not None and not self._has_heading_source()
                and bool(self._imu) and self._imu[-1][0] < self._undetermined[0])

    def _after_last_joined_ready(self) -> bool:
        """True when the data after the last joined IMU gap held are enough to align over on their own (as
        :meth:`_fall_back` will, not at the end of the data)."""
        if not self.joined_gaps or not self._imu or self.joined_gaps[-1][1] < self._imu[0][0]:
            return False
        t0, t1 = self.joined_gaps[-1]
        pings = len(self._dvl) - bisect.bisect_right([d[0] for d in self._dvl], t0)
        return self._imu[-1][0] - t1 >= self._needed_s() and pings >= self.options.min_dvl_pings

    def _fall_back(self, end_of_data: bool = False) -> str:
        """Start the alignment again after every joined IMU gap of the data held (:meth:`_start_again`), the rule
        before gaps were joined: it aligns over the stretch after the last (at the end of the data: the longest).
        Returns what that stretch lacks ("" when it is enough; when it lacks any, the data held stay as they were)."""
        t = np.array([s[0] for s in self._imu])
        held = (self._imu, self._dvl, self._depth, list(self.imu_gaps), self._before_gap, self._undetermined,
                self.joined_gaps)
        for i in self._joined_steps(t):
            self._start_again(float(t[i]), float(t[i + 1]))
        self._undetermined = None
        missing = self.missing(end_of_data)
        if missing:
            (self._imu, self._dvl, self._depth, self.imu_gaps, self._before_gap, self._undetermined,
             self.joined_gaps) = held
            return "; ".join(missing)
        self._n_undetermined = 0        # a later joined gap's first refusal waits HEADING_RECHECK_S again
        return ""

    def settle(self, end_of_data: bool = False) -> None:
        """Decide which data the alignment is over, so that :attr:`t_first` says where it starts: across the joined
        IMU gaps, or after them when they leave the heading undetermined (:meth:`_solve_checked`; :meth:`check_ready`
        decides it live, this at the end of the data).

        Raises:
            AlignmentError: as :meth:`result`."""
        if self._needs_heading_check():
            self._solve_checked(None, end_of_data)

    def _joined_note(self) -> str:
        """The first joined IMU gaps of the data held, in words."""
        t = np.array([s[0] for s in self._imu])
        steps = self._joined_steps(t)
        return ", ".join(f"{t[i + 1] - t[i]:.3g} s after t = {t[i]:.3f} s" for i in steps[:3]) + \
            (" ..." if len(steps) > 3 else "")

    # --- solution ---------------------------------------------------------------------------------
    def result(self) -> Alignment:
        """The aligned initial state at the last sample used.

        Raises:
            AlignmentError: naming what is missing (IMU time, DVL bottom lock, a heading source).
        """
        return self._solve_checked(None)

    def result_at(self, t: float, end_of_data: bool = False) -> Alignment:
        """The aligned state at any stamp t (s) inside the data the aligner holds, e.g. the first IMU sample, so
        that an offline smoother can navigate the whole record (the attitude is known over the whole window:
        ``C_b_n(t) = C_nt_n0^T C_b0_n0 C_bt_b0``; the velocity comes from the pings around t).

        ``end_of_data``: the data have ended, align over what there is if it covers ``min_duration_s``.

        Raises:
            AlignmentError: as :meth:`result`, or t outside the data held.
        """
        return self._solve_checked(float(t), end_of_data)

    def _solve(self, t_out: float | None, end_of_data: bool = False, exclude: frozenset = frozenset(),
               rounds: int = FIT_REJECT_ROUNDS, yaw_start: float = 0.0) -> Alignment:
        missing = self.missing(end_of_data)
        if missing:
            raise AlignmentError("cannot align from the sensors: " + "; ".join(missing))
        cfg, o = self.config, self.options
        lat = self.lat_rad
        omega_ie = earth_rate_n(lat) if cfg.earth_rotation else np.zeros(3)
        g_n = np.array([0.0, 0.0, cfg.gravity_mps2])
        t_imu = np.array([s[0] for s in self._imu])
        f_b = np.array([s[1] for s in self._imu])
        w_b = np.array([s[2] for s in self._imu])
        t0 = t_imu[0]
        dvl = [d for d in self._dvl if d[0] >= t0 and d[0] not in exclude]
        t_dvl = np.array([d[0] for d in dvl])
        v_head_b = np.array([d[1] for d in dvl])
        # the DVL's errors: v_head_b = C_d_b (I + diag(s)) v_d + P b (scale s per DVL axis, beam biases b), so
        # D (N,3,7) maps [s, b] to the measured velocity's error; the scale factor's column is the head velocity
        C_d_b, P_b = self.geometry.C_d_b, np.array([d[2] for d in dvl])

        def error_map(v_head):
            return np.concatenate([C_d_b[None] * (v_head @ C_d_b)[:, None, :], P_b], axis=2)

        D = error_map(v_head_b)
        t_end = max(t_imu[-1], t_dvl[-1])
        if t_out is None:
            t_out = t_end
        elif not t0 <= t_out <= t_end:
            raise AlignmentError(f"result_at({t_out:.3f}): outside the aligner's data [{t0:.3f}, {t_end:.3f}] s")

        # body attitude C_bt_b0, int C_bt_b0 f dt and int C_bt_b0 dt at every IMU stamp (zero-order hold); a joined
        # gap (imu_gap) is bridged by interpolation, as the estimators bridge it, and its error is fitted below
        gaps = self._joined_steps(t_imu)
        f_step, w_step = f_b.copy(), w_b.copy()
        f_step[gaps], w_step[gaps] = 0.5 * (f_b[gaps] + f_b[gaps + 1]), 0.5 * (w_b[gaps] + w_b[gaps + 1])
        dt = np.diff(t_imu)
        B0 = np.concatenate([np.eye(3)[None], prefix_products(so3_exp_batch(w_step[:-1] * dt[:, None]))])
        dF0 = np.einsum("nij,nj->ni", B0[:-1], f_step[:-1]) * dt[:, None]
        dM0 = B0[:-1] * dt[:, None, None]
        n_gaps = len(gaps)
        stretch_of = np.searchsorted(gaps, np.arange(len(t_imu)))      # the stretch of each sample (0: before any gap)
        gap_prior_info, gap_velocity_sigma = _gap_priors(t_imu, f_b, w_b, gaps, B0, cfg.imu)

        def sample_index(t):
            return np.clip(np.searchsorted(t_imu, np.atleast_1d(t), side="right") - 1, 0, len(t_imu) - 1)

        def rechain(Q):
            """The chain with each stretch s turned by ``Q[s]`` (n_gaps + 1,3,3; b0, on the left; ``Q[0]`` = I): the
            fitted error of the bridges before it. A gap's own step belongs to the stretch before it."""
            nonlocal B, F, M
            if not n_gaps:
                B = B0
                F = np.concatenate([np.zeros((1, 3)), np.cumsum(dF0, 0)])
                M = np.concatenate([np.zeros((1, 3, 3)), np.cumsum(dM0, 0)])
                return
            Q = Q[stretch_of]
            B = Q @ B0
            F = np.concatenate([np.zeros((1, 3)), np.cumsum(np.einsum("nij,nj->ni", Q[:-1], dF0), 0)])
            M = np.concatenate([np.zeros((1, 3, 3)), np.cumsum(Q[:-1] @ dM0, 0)])

        def body_at(t):
            """(C_bt_b0, int C f dt, int C dt) at stamps t: the last sample held (zero-order hold)."""
            t = np.atleast_1d(t)
            k = sample_index(t)
            lag = (t - t_imu[k])[:, None]
            return (B[k] @ so3_exp_batch(w_step[k] * lag), F[k] + np.einsum("nij,nj->ni", B[k], f_step[k]) * lag,
                    M[k] + B[k] * lag[:, :, None])

        # IMU velocity in the body frame: the DVL head's minus the lever-arm term omega x l, with the rate at the ping
        # by the estimators' rule (the sample held there is its interval's mean, half a sample late: 0.001 deg)
        w_dvl = np.array([gyro_at(t, self._imu) for t in t_dvl])
        v_b = v_head_b - np.cross(w_dvl, self.geometry.lever_arm_b)
        stretch_dvl = stretch_of[sample_index(t_dvl)]

        def pings_on_chain():
            """The pings' attitude, integrals and b0 velocity on the current chain, and what the fit takes of them."""
            nonlocal B_dvl, F_dvl, M_dvl, v_b0, r_b0, beta, M_k
            B_dvl, F_dvl, M_dvl = body_at(t_dvl)
            v_b0 = np.einsum("nij,nj->ni", B_dvl, v_b)
            r_b0 = cumulative_trapezoid(v_b0, t_dvl, axis=0, initial=0.0)[1:]
            beta = ((F_dvl - F_dvl[0]) - (v_b0 - v_b0[0]))[1:]
            M_k = (M_dvl - M_dvl[0])[1:]

        B = F = M = B_dvl = F_dvl = M_dvl = v_b0 = r_b0 = beta = M_k = None
        Q, jumps = np.repeat(np.eye(3)[None], n_gaps + 1, 0), np.zeros((n_gaps, 3))
        rechain(Q)
        pings_on_chain()

        def nav_rotation(t):          # C_n0_nt = Exp(-omega_ie (t - t0))
            return Rotation.from_rotvec(-np.outer(np.atleast_1d(t) - t0, omega_ie)).as_matrix()

        gamma = EarthModel(lat, cfg.gravity_mps2, 0.0, cfg.earth_rotation, cfg.gravity_variation).gravity_gradient_n()

        def gravity_integral(C, t):
            """int_t0^t C_nt_n0 g_n(p) dt (N,3), m/s, at stamps t (s): gravity turning with the Earth and changing
            along the path dead-reckoned with the attitude C (a constant g was 0.1-0.2 deg of heading)."""
            t = np.atleast_1d(t)
            return _rotating_integral(omega_ie, g_n, t - t0) + _gravity_change_integral(
                gamma, nav_rotation, t0, t_dvl, v_b0 @ C.T, t)
        tau = t_dvl[1:] - t_dvl[0]
        C = np.eye(3)

        def alpha_of(C):
            """(N-1,3) alpha_k (module docstring) of the pings after the first, m/s."""
            G = gravity_integral(C, t_dvl)
            return -(G[1:] - G[0]) + np.cross(omega_ie, r_b0 @ C.T)

        for _ in range(o.coriolis_iterations):
            alpha = alpha_of(C)
            # the initial velocity C v_b0(t_a) is a free offset u (Kabsch with centring): otherwise the noise
            # of the first ping is common to every vector and tilts the whole fit
            rot, _ = Rotation.align_vectors(alpha - alpha.mean(0), beta - beta.mean(0))
            C = rot.as_matrix()
        if yaw_start:     # a start turned about the vertical (_heading_undetermined)
            C = Rotation.from_rotvec([0.0, 0.0, yaw_start]).as_matrix() @ C
        # Gauss-Newton refinement with the accelerometer bias and the DVL's scale factor and beam biases (seen in
        # turns and speed changes; their priors otherwise, and their uncertainty reaches the heading and tilt),
        # weighted by the DVL noise of each ping (anisotropic: the vertical is better), giving the covariance
        sigma_acc = cfg.imu.accel_noise_density
        cov_dvl_b = self._dvl_velocity_covariance()
        x = np.zeros(10)
        x_sigma, x_prior = self._error_prior()
        # a joined gap j lies between the first ping and ping n when stretch_a < j <= stretch_n
        crossed = (np.arange(1, n_gaps + 1)[None, :] > stretch_dvl[0]) & \
            (np.arange(1, n_gaps + 1)[None, :] <= stretch_dvl[1:, None])

        def residuals(C, x, D):
            """Weights W, model y, offset u and residuals of the pings after the first, D's K and B_dvl @ D."""
            BD = B_dvl @ D
            # beta without the errors x = [b_acc, s, b]: beta - K x (the first ping's DVL error goes into u)
            K = np.concatenate([M_k, -(BD - BD[0])[1:]], axis=2)
            alpha = alpha_of(C)
            C_B = C @ B_dvl[1:]
            R = C_B @ cov_dvl_b @ np.swapaxes(C_B, 1, 2) + (sigma_acc ** 2 * tau)[:, None, None] * np.eye(3)
            W = np.linalg.inv(R)
            y = (beta - np.einsum("nij,j->ni", K, x)) @ C.T
            y_all = y + crossed @ jumps if n_gaps else y        # the velocity changes fitted across the gaps
            u = np.linalg.solve(W.sum(0), np.einsum("nij,nj->i", W, alpha - y_all))
            return W, y, u, alpha - u - y_all, K, BD

        def gap_columns(C, x, BD):
            """d res / d [stretch rotations 1.., jumps] (N-1,3,6 n_gaps): stretch s's rotation (b0, left) turns the
            part of the pings' velocity change made in it."""
            J = np.zeros((len(t_dvl) - 1, 3, 6 * n_gaps))
            z_dvl = F_dvl - M_dvl @ x[:3]                         # int C_bt_b0 (f - b_a) dt at the pings
            v_dvl = v_b0 - np.einsum("nij,j->ni", BD, x[3:])    # the pings less the DVL errors
            starts = gaps + 1                                    # the first sample of each stretch after the first
            for s in range(1, n_gaps + 1):
                z_in = F[starts[s - 1]] - M[starts[s - 1]] @ x[:3]
                z_out = F[starts[s]] - M[starts[s]] @ x[:3] if s < n_gaps else None
                upper = np.where((stretch_dvl[1:] == s)[:, None], z_dvl[1:] - v_dvl[1:],
                                 z_out if z_out is not None else 0.0)
                lower = z_dvl[0] - v_dvl[0] if stretch_dvl[0] == s else z_in
                inside = (stretch_dvl[1:] >= s) & (stretch_dvl[0] <= s)
                part = (upper - lower) @ C.T
                J[inside, :, 3 * (s - 1):3 * s] = skew(part[inside]) @ C
                J[crossed[:, s - 1], :, 3 * (n_gaps + s - 1):3 * (n_gaps + s)] = -np.eye(3)
            return J

        for i in range(2 * FIT_ITERATIONS):
            W, y, u, res, K, BD = residuals(C, x, D)
            if i == FIT_ITERATIONS:
                # the scale factor's column from the fitted velocity (the IMU's between the pings), not the pings:
                # a ping's own noise in its column made the fit shrink every ping (scale factor biased positive)
                v_fit_b0 = v_b0 - np.einsum("nij,j->ni", BD, x[3:]) - np.concatenate([-u[None], res]) @ C
                D = error_map(np.einsum("nji,nj->ni", B_dvl, v_fit_b0) + (v_head_b - v_b))
                W, y, u, res, K, BD = residuals(C, x, D)
            n = len(res)
            J = np.zeros((n, 3, 16))
            J[:, :, 0:3] = skew(y)                              # d res / d phi (left perturbation, n0)
            J[:, :, 3:6] = -np.eye(3)                           # d res / d u
            J[:, :, 6:16] = C @ K                               # d res / d x
            if n_gaps:
                J = np.concatenate([J, gap_columns(C, x, BD)], axis=2)
            if n_gaps:        # hundreds of columns: as matrix products
                WJ = (W @ J).reshape(-1, J.shape[2])
                H, g_vec = J.reshape(-1, J.shape[2]).T @ WJ, WJ.T @ res.reshape(-1)
            else:
                H = np.einsum("nki,nkl,nlj->ij", J, W, J)
                g_vec = np.einsum("nki,nkl,nl->i", J, W, res)
            H[6:16, 6:16] += np.diag(x_prior)
            g_vec[6:16] += x_prior * x
            if n_gaps:
                _add_gap_priors(H, g_vec, Q, jumps, gap_prior_info, gap_velocity_sigma)
            dx = -np.linalg.solve(H, g_vec)
            C = Rotation.from_rotvec(dx[0:3]).as_matrix() @ C
            x = x + np.where(x_prior < FIXED_PRIOR, dx[6:16], 0.0)
            if n_gaps:
                Q = np.concatenate([Q[:1], so3_exp_batch(dx[16:16 + 3 * n_gaps].reshape(-1, 3)) @ Q[1:]])
                jumps = jumps + dx[16 + 3 * n_gaps:].reshape(-1, 3)
                rechain(Q)
                pings_on_chain()
        if n_gaps:
            BD = B_dvl @ D
        b_acc = x[:3]
        v_b0 = v_b0 - np.einsum("nij,j->ni", BD, x[3:])        # the pings without the fitted DVL errors
        # a ping whose residual is an outlier against the fit's own scale: solve again without it
        d2 = np.einsum("ni,nij,nj->n", res, W, res)
        scale = max(float(np.median(d2)) / 2.366, 1.0)
        outliers = np.flatnonzero(d2 > FIT_REJECT_CHI2 * scale)
        if outliers.size and rounds > 0 and n - outliers.size >= o.min_dvl_pings:
            return self._solve(t_out, end_of_data, exclude | frozenset(t_dvl[1:][outliers].tolist()), rounds - 1,
                               yaw_start)
        chi2_dof = float(np.einsum("ni,nij,nj->", res, W, res) / max(3 * n - 9, 1))
        fit_cost = float(np.einsum("ni,nij,nj->", res, W, res) + x_prior[x_prior < FIXED_PRIOR] @ (
            x[x_prior < FIXED_PRIOR] ** 2) + (_gap_prior_cost(Q, jumps, gap_prior_info, gap_velocity_sigma)
                                              if n_gaps else 0.0))
        P = np.linalg.inv(H) * max(1.0, chi2_dof)              # what the data say, if worse than the spec
        stretch_out = int(stretch_of[sample_index(t_out)][0])
        if n_gaps:    # the attitude at t_out carries the rotations fitted across the gaps before it
            L = np.zeros((16, len(P)))
            L[:, :16] = np.eye(16)
            if stretch_out:
                L[0:3, 13 + 3 * stretch_out:16 + 3 * stretch_out] = C
            P = L @ P @ L.T
        cov_phi = P[0:3, 0:3]
        resid_rms = float(np.sqrt(np.mean(res ** 2)))

        # --- heading: gyrocompass or a heading source, whichever is better
        T = float(t_dvl[-1] - t_dvl[0])
        sigma_v_spec = self._dvl_velocity_sigma()
        sigma_v = max(sigma_v_spec, resid_rms)
        terms = gyrocompass_heading_terms(cfg, T, len(t_dvl), sigma_v, lat)
        spec_terms = {k: v for k, v in terms.items() if k != "dvl"}
        # the fit's covariance holds the DVL noise and the accelerometer bias (and what turns do to them);
        # the gyro bias and random walk act through C_bt_b0, which the fit takes as exact: added here
        gyro_var = terms["gyro_bias"] ** 2 + terms["gyro_arw"] ** 2
        tilt_gyro_var = (cfg.imu.gyro_bias_sigma * T / 2) ** 2 + cfg.imu.gyro_noise_density ** 2 * T / 3
        cov_phi = cov_phi + np.diag([tilt_gyro_var, tilt_gyro_var, gyro_var if np.isfinite(gyro_var) else 0.0])
        gc_sigma = gyrocompass_sigma = float(np.sqrt(cov_phi[2, 2]))
        heading_source, heading_sigma = "gyrocompass", gc_sigma
        if self._gyrocompass_bias_limit() > o.max_heading_sigma_rad:
            gc_sigma = float("inf")
        if self._has_heading_source():
            C_h, h_sigma, h_src = self._apply_heading(C, t_imu, t_out, nav_rotation, body_at)
            if h_sigma < gc_sigma:
                C, heading_sigma, heading_source = C_h, h_sigma, h_src
                cov_phi = cov_phi.copy()
                cov_phi[2, :] = cov_phi[:, 2] = 0.0
                cov_phi[2, 2] = h_sigma ** 2

        # --- state at t_out
        B_out, F_out, M_out = body_at(t_out)
        E_out = nav_rotation(t_out)[0]
        C_b_n = _orthonormalise(E_out @ C @ B_out[0])
        G_out, G = gravity_integral(C, t_out)[0], gravity_integral(C, t_dvl)
        # velocity at t_out: the pings around it, each carried to t_out with the IMU, averaged (one ping is noisy)
        near = np.abs(t_dvl - t_out) <= o.velocity_window_s / 2
        near = near if near.any() else np.abs(t_dvl - t_out) == np.min(np.abs(t_dvl - t_out))
        if n_gaps and (near & (stretch_dvl == stretch_out)).any():
            near &= stretch_dvl == stretch_out            # carried to t_out without a gap's fitted turn between
        dF = (F_out[0] - F_dvl[near]) - np.einsum("nij,j->ni", M_out[0] - M_dvl[near], b_acc)
        v_n = E_out @ np.median((v_b0[near] + dF) @ C.T + (G_out - G[near]), axis=0)   # one bad ping cannot move it
        v_n_dvl = np.einsum("nij,nj->ni", nav_rotation(t_dvl), v_b0 @ C.T)

        # attitude covariance: left perturbation in n0 -> right perturbation in the body at t_out
        A = C_b_n.T @ E_out
        tilt_sigma = float(np.sqrt(max(cov_phi[0, 0], cov_phi[1, 1])))
        # the fit's covariance with the attitude's as above; an error held at zero keeps its prior, uncorrelated
        P_fit = P.copy()
        if heading_source != "gyrocompass":
            P_fit[2, :] = P_fit[:, 2] = 0.0
        P_fit[0:3, 0:3] = cov_phi
        held = 6 + np.flatnonzero(x_prior >= FIXED_PRIOR)
        P_fit[held, :] = P_fit[:, held] = 0.0
        P_fit[held, held] = x_sigma[held - 6] ** 2
        cov_joint = self._joint_covariance(P_fit, C_b_n, A, v_b[near][-1], D[near][-1],
                                           float(np.max(np.abs(t_out - t_dvl[near]))), int(near.sum()))
        cov_rot, cov_v_n = cov_joint[0:3, 0:3], cov_joint[3:6, 3:6]
        p_n, cov_p_n, origin_lla, pos_info = self._position(t_imu[0], t_dvl, v_n_dvl, t_out, cov_v_n,
                                                            heading_sigma)
        info = {
            "t_start": float(t0), "t_end": float(t_end), "duration_s": float(t_end - t0), "dvl_span_s": T,
            "n_imu": len(t_imu), "n_dvl": len(t_dvl), "n_dvl_ignored": self.n_dvl_ignored,
            "n_imu_refused": self.n_imu_refused, "n_dvl_refused": self.n_dvl_refused,
            "n_dvl_rejected_fit": len(exclude),
            "lat_rad": lat, "heading_sigma_rad": float(heading_sigma), "tilt_sigma_rad": tilt_sigma,
            "gyrocompass_sigma_rad": gyrocompass_sigma, "gyrocompass_sigma_formula_rad": _rss(terms),
            "fit_chi2_per_dof": chi2_dof, "fit_cost": fit_cost,
            "accel_bias_sigma_mps2": np.sqrt(np.diag(P[6:9, 6:9])).tolist(), "gyrocompass_terms_rad": {k: float(v) for k, v in terms.items()},
            "dvl_scale_factor": x[3:6].tolist(), "dvl_beam_bias_mps": x[6:].tolist(),
            "dvl_error_sigma": np.sqrt(np.diag(P[9:, 9:])).tolist(),
            "heading_sigma_spec_rad": _rss(spec_terms), "sigma_v_spec_mps": sigma_v_spec,
            "wahba_residual_rms_mps": resid_rms, "imu_gaps_joined": n_gaps, **pos_info,
        }
        return Alignment(float(t_out), C_b_n, v_n, p_n, origin_lla, cov_rot, cov_v_n, cov_p_n,
                         b_acc.copy(), np.zeros(3), heading_source, info, x[3:].copy(), cov_joint)

    # --- pieces -----------------------------------------------------------------------------------
    def _dvl_velocity_covariance(self) -> np.ndarray:
        """Body-frame covariance of one 4-beam least-squares velocity from the beam noise, (m/s)^2."""
        T_b = self.geometry.T_b
        return self.config.dvl.beam_noise_std ** 2 * np.linalg.inv(T_b.T @ T_b)

    def _dvl_velocity_sigma(self) -> float:
        """Horizontal velocity 1-sigma of one ping from the beam noise and geometry (4 beams), m/s."""
        cov = self._dvl_velocity_covariance()
        return float(np.sqrt(max(cov[0, 0], cov[1, 1])))

    def _apply_heading(self, C, t_imu, t_out, nav_rotation, body_at):
        """Replace the heading of ``C`` (= C_b0_n0) with the heading measurements (or the given initial heading).

        Returns (C, heading 1-sigma at t_out, source). AHRS/magnetometer errors are mostly slow (deviation),
        so several headings are averaged (weights 1/sigma^2) but their sigma is not divided by sqrt(n).
        """
        if self._headings:
            meas = [(t, y, s) for t, y, s in self._headings if t >= t_imu[0] - 1.0] or self._headings[-1:]
            source = "heading"
        else:
            meas = [(t_imu[0], float(self.initial_heading_rad), self.heading_sigma_rad)]
            source = "given"
        t_h = np.clip(np.array([m[0] for m in meas]), t_imu[0], None)
        yaw = np.array([m[1] for m in meas])
        sig = np.array([m[2] for m in meas])
        B_h = body_at(t_h)[0]
        E_h = nav_rotation(t_h)
        for _ in range(2):           # Earth-rate rotation and Rz do not commute exactly: iterate
            model = C_b_n_to_euler(E_h @ C @ B_h)[:, 2]
            w = 1.0 / sig ** 2
            d = np.angle(np.sum(w * np.exp(1j * (yaw - model))))
            C = Rotation.from_rotvec([0.0, 0.0, d]).as_matrix() @ C
        imu = self.config.imu
        elapsed = abs(t_out - float(t_h[np.argmin(np.abs(t_h - t_out))]))
        drift = np.hypot(imu.gyro_bias_sigma * elapsed, imu.gyro_noise_density * np.sqrt(max(elapsed, 0.0)))
        return C, float(np.hypot(np.average(sig, weights=1 / sig ** 2), drift)), source

    def _error_prior(self) -> tuple[np.ndarray, np.ndarray]:
        """Prior sigmas (10,) of the fit's accelerometer bias (3, m/s^2), DVL scale factor (3, unitless) and beam
        biases (4, m/s), and their information (10,): :data:`FIXED_PRIOR` where held at zero."""
        o = self.options
        scale, bias = PriorOptions(dvl_scale_sigma=o.dvl_scale_sigma,
                                   dvl_bias_sigma=o.dvl_bias_sigma).dvl_error_sigmas(self.config.dvl)
        sigma = np.array([self.config.imu.accel_bias_sigma] * 3 + [scale] * 3 + [bias] * 4)
        free = np.repeat([o.estimate_accel_bias, o.estimate_dvl_errors], [3, 7])
        return sigma, np.where(free, sigma ** -2.0, FIXED_PRIOR)

    def _joint_covariance(self, P_fit, C_b_n, A, v_b, D_out, dt_since_ping, n_pings) -> np.ndarray:
        """(16,16) covariance of the errors (truth - estimate) of [attitude (GTSAM right perturbation, body, rad),
        NED velocity (m/s), accelerometer bias (m/s^2), DVL scale factor per DVL axis (3) and beam biases (4, m/s)]
        at the output stamp, with their cross-terms (the heading was fitted jointly with the DVL's errors).

        ``P_fit``: covariance of the fit's [attitude (left perturbation in n0), offset, accelerometer bias, DVL
        errors]; ``A`` maps the n0 attitude error to the body's at the stamp; ``v_b`` (3,) m/s the body velocity
        and ``D_out`` (3,7) its error per DVL error at the last ping averaged. The velocity's own error: beam noise
        averaged over ``n_pings``, IMU propagation over ``dt_since_ping`` (s, from the oldest ping averaged)."""
        G = np.zeros((16, 16))
        G[0:3, 0:3] = A
        G[3:6, 0:3] = -C_b_n @ skew(v_b) @ A             # d v_n / d attitude (right perturbation)
        G[3:6, 9:] = -C_b_n @ D_out                        # the pings less the fitted DVL errors
        G[6:, 6:] = np.eye(10)
        cov = G @ P_fit @ G.T
        spec, pinv, imu = self.config.dvl, np.linalg.pinv(self.geometry.T_b), self.config.imu
        prop = (imu.accel_noise_density ** 2 * dt_since_ping + (imu.accel_bias_sigma * dt_since_ping) ** 2)
        cov[3:6, 3:6] += C_b_n @ (spec.beam_noise_std ** 2 / n_pings * pinv @ pinv.T) @ C_b_n.T + prop * np.eye(3)
        return 0.5 * (cov + cov.T)

    def _position(self, t_start, t_dvl, v_n_dvl, t_out, cov_v_n, heading_sigma):
        """Position at t_out: dead reckoning with the aligned DVL velocities from the latest fix (NED origin at
        the first fix) or from the local origin at t_start; depth from the depth sensor."""
        o = self.options
        sigma_v = float(np.sqrt(np.trace(cov_v_n[:2, :2]) / 2))
        # running integral of the ping velocities (trapezoid), held flat before the first and after the last
        steps = 0.5 * (v_n_dvl[1:] + v_n_dvl[:-1]) * np.diff(t_dvl)[:, None]
        travel = np.concatenate([[0.0], np.cumsum(np.linalg.norm(steps[:, :2], axis=1))])
        run = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, 0)])

        def integral(t):
            """(int v_n dt, distance travelled) from the first ping to t, m."""
            t = float(t)
            at = np.array([np.interp(t, t_dvl, run[:, i]) for i in range(3)])
            travelled = float(np.interp(t, t_dvl, travel))
            edge = 0 if t < t_dvl[0] else -1                     # outside the pings: the nearest ping's velocity
            extra = v_n_dvl[edge] * (t - t_dvl[edge]) if (t < t_dvl[0] or t > t_dvl[-1]) else np.zeros(3)
            return at + extra, travelled + float(np.linalg.norm(extra[:2])) * (1 if edge else -1)

        def displacement(t_from):
            """Dead-reckoned displacement from t_from to t_out (m), distance travelled (m), |time| (s)."""
            (a, da), (b, db) = integral(t_from), integral(t_out)
            return b - a, abs(db - da), abs(t_out - t_from)

        info = {}
        if self._fixes:
            _, lat0, lon0, _ = self._fixes[0]
            origin = (lat0, lon0, 0.0)
            t_f, lat, lon, s_f = min(self._fixes, key=lambda f: abs(f[0] - t_out))   # the fix nearest t_out
            start = lla_to_ned(lat, lon, 0.0, origin)
            d, dist, elapsed = displacement(max(t_f, t_start))
            horizontal_var = s_f ** 2
            info["position_source"] = "fix"
        else:
            origin = self.initial_lla
            start = np.zeros(3) if self.initial_position_n is None else self.initial_position_n.copy()
            d, dist, elapsed = displacement(t_start)
            # the frame starts here: an unknown place on Earth is the frame's (origin_sigma_m), not the position's
            given = self.initial_lla is not None or self.initial_position_n is not None
            horizontal_var = (o.initial_position_sigma_m if given else o.start_position_sigma_m) ** 2
            info["position_source"] = "initial_lla" if self.initial_lla is not None else LOCAL_ORIGIN
            if self.initial_lla is None:
                info["origin_sigma_m"] = o.local_origin_sigma_m
        # dead-reckoning error: velocity sigma over the time, heading sigma over the distance
        dr_var = (sigma_v * elapsed) ** 2 + (heading_sigma * dist) ** 2
        p_n = np.asarray(start, float) + d
        cov = np.diag([horizontal_var + dr_var, horizontal_var + dr_var, 0.0])
        depth = [(t, z) for t, z in self._depth if t >= t_start - 1.0]
        if depth:
            t_d = np.array([x[0] for x in depth])
            k = int(np.argmin(np.abs(t_d - t_out)))
            p_n[2] = depth[k][1] + (integral(t_out)[0][2] - integral(t_d[k])[0][2])
            cov[2, 2] = self.config.depth_noise_std ** 2 + cov_v_n[2, 2] * (t_out - t_d[k]) ** 2
            info["depth_source"] = "depth sensor"
        else:
            p_n[2] = (0.0 if self.initial_position_n is None else self.initial_position_n[2]) + \
                displacement(t_start)[0][2]
            cov[2, 2] = o.unknown_depth_sigma_m ** 2
            info["depth_source"] = "none (dead reckoning from depth 0 or initial_position_n)"
        info["dead_reckoning_distance_m"] = dist
        return p_n, cov, origin, info


def _span(imu: list) -> float:
    """Time covered by IMU samples ``[(t, f_b, omega_b), ...]`` in time order, s."""
    return imu[-1][0] - imu[0][0] if imu else 0.0


def _rotating_integral(omega: np.ndarray, x: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """``int_0^tau Exp(omega s) x ds`` (N,3) in closed form for a constant rate vector omega (rad/s)."""
    tau = np.asarray(tau, float)
    w = float(np.linalg.norm(omega))
    if w == 0.0:
        return np.outer(tau, x)
    axis = omega / w
    par = axis * (axis @ x)
    perp = x - par
    cross = np.cross(axis, x)
    return (np.outer(tau, par) + np.outer(np.sin(w * tau) / w, perp)
            + np.outer((1.0 - np.cos(w * tau)) / w, cross))


def _gravity_change_integral(gamma: np.ndarray, nav_rotation, t0: float, t_ping: np.ndarray, u_ping: np.ndarray,
                             t: np.ndarray) -> np.ndarray:
    """``int_t0^t C_nt_n0 (g_n(p) - g_n(p(t0))) ds`` (N,3), m/s, at stamps t (s): what gravity's change along the
    path adds to the aligner's gravity integral.

    The plumb-bob gravity of the fixed tangent frame tilts by ``|p_h| / R`` away from the start (the transport rate
    of a local-level frame) and grows with depth: ``gamma`` (3,3) s^-2 its gradient (linear: 3.6e-7 m/s^2 off at
    1 km, against a change of 1.5e-3). The position is dead-reckoned from the pings' velocities ``u_ping`` (N_p,3)
    m/s in n0 at ``t_ping`` (held at the nearest ping's outside them); ``nav_rotation(t)`` gives C_n0_nt.
    Trapezoid rule on the pings' stamps."""
    s = np.union1d(np.concatenate([[t0], t_ping]), t)
    E = nav_rotation(s)
    u = np.stack([np.interp(s, t_ping, u_ping[:, i]) for i in range(3)], axis=-1)
    p_n = cumulative_trapezoid(np.einsum("nij,nj->ni", E, u), s, axis=0, initial=0.0)
    change_n0 = np.einsum("nji,nj->ni", E, p_n @ gamma.T)
    return cumulative_trapezoid(change_n0, s, axis=0, initial=0.0)[np.searchsorted(s, t)]


#: Time either side of a joined IMU gap whose rates and specific forces set the gap's prior (:func:`_gap_priors`), s.
GAP_PRIOR_SPAN_S = 1.0


def _gap_priors(t_imu: np.ndarray, f_b: np.ndarray, w_b: np.ndarray, gaps: np.ndarray, B0: np.ndarray,
                imu) -> tuple[np.ndarray, np.ndarray]:
    """Priors of the error of the interpolated bridge over each joined IMU gap (steps ``gaps`` of stamps ``t_imu``, s):
    the information (n,3,3) of its rotation (b0 frame, rad^-2) and the 1-sigma (n,) of its velocity change, m/s.

    Per body axis the rotation's sigma over a gap of ``dT`` is the root sum of squares of: the spread (standard
    deviation) of the rate over :data:`GAP_PRIOR_SPAN_S` either side times ``dT`` (a loss: the turn the vehicle's
    own motion can make unseen), the mean rate either side times ``dT`` (a step of the clock: nothing turned, the
    bridge turned by that), half the change of rate across times ``dT`` and the gyro's random walk. Measured on
    the A-KIT Trajectory1/3 IMU (300 bridged losses each of 0.4 / 1 / 2 s), the spread term alone gave a NEES per
    axis of 0.1-1.2 (docs/decisions/alignment.md). The velocity's sigma: the spread of the specific force times
    ``dT``, half its change across, and the accelerometer's random walk."""
    info, sigma_v = np.zeros((len(gaps), 3, 3)), np.zeros(len(gaps))
    for j, g in enumerate(gaps):
        dT = t_imu[g + 1] - t_imu[g]
        around = ((t_imu >= t_imu[g] - GAP_PRIOR_SPAN_S) & (t_imu <= t_imu[g]) |
                  (t_imu >= t_imu[g + 1]) & (t_imu <= t_imu[g + 1] + GAP_PRIOR_SPAN_S))
        var = ((np.std(w_b[around], 0) * dT) ** 2 + (0.5 * (w_b[g] + w_b[g + 1]) * dT) ** 2
               + (0.5 * (w_b[g + 1] - w_b[g]) * dT) ** 2 + imu.gyro_noise_density ** 2 * dT)
        info[j] = B0[g] @ np.diag(1.0 / np.maximum(var, 1e-18)) @ B0[g].T
        sigma_v[j] = np.sqrt((np.max(np.std(f_b[around], 0)) * dT) ** 2
                             + (0.5 * np.linalg.norm(f_b[g + 1] - f_b[g]) * dT) ** 2
                             + imu.accel_noise_density ** 2 * dT + 1e-12)
    return info, sigma_v


def _gap_prior_cost(Q: np.ndarray, jumps: np.ndarray, info: np.ndarray, sigma_v: np.ndarray) -> float:
    """The joined gaps' prior terms of the fit's cost (:func:`_add_gap_priors`), chi-square."""
    r = Rotation.from_matrix(Q[1:] @ np.swapaxes(Q[:-1], 1, 2)).as_rotvec()
    return float(np.einsum("ni,nij,nj->", r, info, r) + np.sum(jumps ** 2 / sigma_v[:, None] ** 2))


def _add_gap_priors(H: np.ndarray, g_vec: np.ndarray, Q: np.ndarray, jumps: np.ndarray, info: np.ndarray,
                    sigma_v: np.ndarray) -> None:
    """Add the joined gaps' priors (:func:`_gap_priors`) to the normal equations ``H``, ``g_vec``: on the bridge's
    fitted error ``Log(Q_s Q_{s-1}^T)`` (``Q`` (n+1,3,3) the stretches' rotations, b0, left; their perturbations
    follow the fit's 16 states) and on the velocity changes ``jumps`` (n,3) m/s that follow them."""
    n = len(jumps)
    for j in range(n):
        s, v = 16 + 3 * j, 16 + 3 * (n + j)
        across = Q[j + 1] @ Q[j].T
        r = Rotation.from_matrix(across).as_rotvec()
        Jr = np.zeros((3, len(g_vec)))
        Jr[:, s:s + 3] = np.eye(3)
        if j:
            Jr[:, s - 3:s] = -across
        H += Jr.T @ info[j] @ Jr
        g_vec += Jr.T @ info[j] @ r
        H[v:v + 3, v:v + 3] += np.eye(3) / sigma_v[j] ** 2
        g_vec[v:v + 3] += jumps[j] / sigma_v[j] ** 2


def _orthonormalise(C: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(C)
    return u @ vt


def align_mission(mission, options: AlignOptions | None = None, *, use_depth: bool = True,
                  t_end: float | None = None, t_result: float | None = None) -> Alignment:
    """Feed a recorded :class:`~graphnav.core.mission.Mission` to an :class:`Aligner` in time order (IMU, DVL and,
    with ``use_depth``, the depth stream, and the mission's heading aiding; never the ground truth) until it is ready (or until ``t_end``, s).

    The state is given at the last sample used, or at ``t_result`` (s, inside the data used; e.g.
    ``mission.t0`` to smooth a whole record offline, see :meth:`Aligner.result_at`); what is known at the
    start (initial heading, position) is in ``options``. Raises :class:`AlignmentError` when the mission ends (or
    ``t_end`` comes) before the aligner is ready. The aligner is told of every IMU gap the estimators bridge
    (:data:`~graphnav.core.mission.IMU_GAP_PERIODS` periods of the rate its stamps show,
    :func:`~graphnav.core.imu_timing.imu_rate_hz`), as the Navigator tells it live (:meth:`Aligner.imu_gap`: its
    keyframer judges gaps by the period the stream shows, not the configured one). A gyrocompassed heading ready
    across joined IMU gaps (:data:`GAP_JOINED_S`) is taken over the mission's data after the last of them instead
    when they are enough on their own, as before gaps were joined (:meth:`Aligner.check_ready`, as the Navigator
    does), unless ``t_result`` is before that gap.
    """
    aligner = Aligner(mission.config, options)
    rate_hz = imu_rate_hz(mission.imu.t, mission.config.imu_rate_hz)
    # a configured rate the data do not have would tell gaps that are none, or miss some (the live keyframer's)
    gap_limit_s = IMU_GAP_PERIODS / (rate_hz if np.isfinite(rate_hz) else mission.config.imu_rate_hz)
    gap_before = set((np.flatnonzero(np.diff(mission.imu.t) > gap_limit_s) + 1).tolist())    # IMU indices after one
    events = [(t, 0, i) for i, t in enumerate(mission.imu.t)]
    events += [(t, 1, i) for i, t in enumerate(mission.dvl.t)]
    if use_depth and mission.depth is not None:
        events += [(t, 2, i) for i, t in enumerate(mission.depth.t)]
    if mission.heading is not None:
        events += [(t, 3, i) for i, t in enumerate(mission.heading.t)]
    events.sort()
    imu, dvl, depth = mission.imu, mission.dvl, mission.depth

    def feed(a: Aligner, t: float, kind: int, i: int) -> bool:
        """Give ``a`` event (t, kind, i); True when it was an IMU sample."""
        if kind == 0:
            if i in gap_before:
                a.imu_gap(imu.t[i - 1], t)
            a.add_imu(t, imu.f_b[i], imu.omega_b[i])
        elif kind == 1:
            a.add_dvl(t, dvl.beams[i], dvl.valid[i])
        elif kind == 2:
            a.add_depth(t, depth.depth[i])
        else:
            a.add_heading(t, mission.heading.yaw[i], mission.heading.sigma[i])
        return kind == 0

    for t, kind, i in events:
        if t_end is not None and t > t_end:
            break
        if feed(aligner, t, kind, i) and t_end is None and aligner.check_ready():
            break
        if (aligner.waiting_after_joined_gaps and t_result is not None and aligner.joined_gaps
                and t_result < aligner.joined_gaps[-1][1]):     # (the window held may have moved past the gaps)
            aligner.stop_waiting()      # the state is wanted before the gap: the data after it cannot give it
            break
    aligner.stop_waiting()              # the mission ended before the data after the gap were enough
    return aligner.result() if t_result is None else aligner.result_at(t_result)
