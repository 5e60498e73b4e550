"""The types the estimators exchange with the Navigator, the backends, the runs and the commands.

:class:`InitialState` is where a run starts (the first keyframe's pose, velocity, bias and prior
covariances); :class:`Keyframe` (with its :class:`ImuSegments`, :class:`Ping` and :class:`PositionFix`) is what
the keyframer (:mod:`graphnav.estimators.keyframes`) hands a backend; :class:`EpochEstimate` is what each keyframe
update returns, from the factor graph and from the EKF alike. Both are in GTSAM's conventions: ``Pose3`` with attitude ``C_b_n`` (body FRD to NED) and NED
position, covariances in the right perturbation (body axes).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import gtsam
import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.core.mission import Mission


@dataclass
class InitialState:
    """State at the first keyframe: pose (attitude C_b_n and NED position, m), NED velocity (m/s), IMU bias.

    Attributes:
        t: its stamp, s (IMU clock); None = the first keyframe's (the first DVL ping) in the replay helpers.
        cov_pose: optional (6,6) prior covariance in GTSAM's Pose3 tangent ``[rot (rad), trans (m)]`` (right
            perturbation, body frame); None = the option sigmas (``GraphOptions.prior_*``).
        cov_v_n: optional (3,3) prior velocity covariance, (m/s)^2; None = the option sigma.
        origin_lla: (lat rad, lon rad, alt m) of the NED origin, when known (position fixes need it).
        dvl_errors: optional (7,) initial DVL error states: scale factor per DVL axis (unitless) and beam biases
            (m/s), e.g. fitted by the alignment; None = zero with the estimator's prior.
        cov_joint: optional (16,16) joint covariance of the errors of [attitude (as ``cov_pose``'s rotation),
            ``v_n``, accelerometer bias, ``dvl_errors``] (an alignment's: its heading was fitted jointly with the
            DVL's errors); its blocks replace ``cov_pose``'s rotation, ``cov_v_n`` and the options' accelerometer
            bias and DVL error priors in the estimators. None = those blocks independent.
    """

    pose: gtsam.Pose3
    v_n: np.ndarray
    bias: gtsam.imuBias.ConstantBias = field(default_factory=gtsam.imuBias.ConstantBias)
    t: float | None = None
    cov_pose: np.ndarray | None = None
    cov_v_n: np.ndarray | None = None
    origin_lla: tuple[float, float, float] | None = None
    dvl_errors: np.ndarray | None = None
    cov_joint: np.ndarray | None = None

    @classmethod
    def from_ground_truth(cls, mission: Mission, t: float) -> "InitialState":
        """Ground truth at t (:meth:`graphnav.core.mission.GroundTruth.at`, attitude carried by the gyro between
        the samples), zero bias."""
        gt = mission.gt
        if gt is None:
            raise ConfigError(f"mission '{mission.name}' has no ground truth to initialise the graph from; "
                              "pass an InitialState")
        p, v, C = gt.at(t, mission.imu)
        return cls(gtsam.Pose3(gtsam.Rot3(C), p), v, t=float(t), origin_lla=gt.origin_lla)


@dataclass
class EpochEstimate:
    """Filtered (or smoothed) state at one keyframe.

    Attributes:
        index: keyframe index k; t: stamp, s; kind: ``"dvl"`` or ``"imu"``.
        pose: Pose3 (attitude C_b_n, NED position m); v_n: (3,) m/s; bias: ConstantBias (acc m/s^2, gyro rad/s).
        cov_v_n: (3,3) marginal velocity covariance in NED, (m/s)^2, or None.
        cov_p_n, cov_rot_b, cov_bias: (3,3) position (NED, m^2), (3,3) attitude (right perturbation, body
            axes, rad^2) and (6,6) bias ([acc, gyro]) marginal covariances, or None (the fields of
            :class:`graphnav.core.solution.NavSolution`).
        n_measured, n_regressed: beams used at this keyframe.
        update_s: solver time of this keyframe, s.
        dvl_errors: (7,) DVL error states [scale (3), beam bias (4) m/s] at this keyframe, filled in when the
            next keyframe is added (``GraphOptions.dvl_error_states``), else None.
        health: how far to trust this estimate, ``"ok"``, ``"degraded"`` or ``"diverged"``, and ``health_why``
            the reason (:func:`graphnav.estimators.health.epoch_health`; set by the Navigator), else None.
    """

    index: int
    t: float
    kind: str
    pose: gtsam.Pose3
    v_n: np.ndarray
    bias: gtsam.imuBias.ConstantBias
    cov_v_n: np.ndarray | None
    n_measured: int
    n_regressed: int
    update_s: float
    dvl_errors: np.ndarray | None = None
    health: str | None = None
    health_why: str = ""
    cov_p_n: np.ndarray | None = None
    cov_rot_b: np.ndarray | None = None
    cov_bias: np.ndarray | None = None

    @property
    def C_b_n(self) -> np.ndarray:
        return self.pose.rotation().matrix()

    @property
    def p_n(self) -> np.ndarray:
        return self.pose.translation()


@dataclass
class ImuSegments:
    """Zero-order-hold IMU segments from the previous keyframe to this one.

    Attributes:
        f_b: (n,3) specific force of each segment's sample, m/s^2 (body axes at the sample's stamp).
        omega_b: (n,3) angular rate, rad/s.
        dt: (n,) segment lengths, s (they add up to the keyframe interval).
        lag: (n,) time from the sample's stamp to the segment's start, s (> 0 for a split sample).
        var_v, var_att: extra velocity ((m/s)^2) and attitude (rad^2) variance per axis over bridged IMU gaps.
    """

    f_b: np.ndarray
    omega_b: np.ndarray
    dt: np.ndarray
    lag: np.ndarray
    var_v: float = 0.0
    var_att: float = 0.0


@dataclass(frozen=True)
class Ping:
    """One DVL ping, the one object that carries it from :meth:`graphnav.estimators.navigator.Navigator.add_dvl`
    (or ``add_dvl_velocity``) to the graph's DVL factors and the EKF's update.

    Made once where the ping enters (:meth:`from_beams`, :meth:`from_velocity`); the keyframer
    (:mod:`graphnav.estimators.keyframes`) hands the estimators an enriched copy (``dataclasses.replace``) that
    adds the gyro rate at the ping and, with a completer, the regressed beams and their sigmas. Frozen: no
    one changes a ping after it was made.

    Attributes:
        t: stamp (IMU clock), s.
        beams: (4,) along-beam velocities of the DVL head, m/s (beam directions of ``DvlGeometry.T_d``):
            measured, or regressed (the completer's value for an unmeasured beam, set by the keyframer); NaN
            where neither.
        measured: (4,) True for beams measured at this ping (the instrument's valid mask, finite values only).
        sigma_regressed: (4,) completer one-sigma of regressed beams, m/s (0 elsewhere).
        has_regressed: True when the completer supplied regressed beams for this ping.
        omega_b: (3,) raw gyro rate at the ping, body frame, rad/s
            (:func:`graphnav.estimators.keyframes.gyro_at`); None until the keyframer sets it.
        v_d: (3,) velocity of the DVL head in the DVL frame measured by the instrument, m/s, on a velocity
            ping (its beams are then all NaN and unmeasured); None on a beam ping.
        v_d_sigma: (3,) one-sigma of ``v_d`` per DVL axis, m/s; NaN where the ping gave none (the estimator's
            configured ``DvlSpec.velocity_noise_std`` applies).
        rehearsed: (4,) True for regressed beams that rehearsed outages kept (:mod:`graphnav.estimators.rehearsal`):
            they enter at ``sigma_regressed`` without the screening; None without rehearsals.
    """

    t: float
    beams: np.ndarray
    measured: np.ndarray
    sigma_regressed: np.ndarray
    has_regressed: bool
    omega_b: np.ndarray | None = None
    v_d: np.ndarray | None = None
    v_d_sigma: np.ndarray | None = None
    rehearsed: np.ndarray | None = None

    @classmethod
    def from_beams(cls, t: float, beams, valid) -> "Ping":
        """A beam ping as the instrument gave it: along-beam velocities ``beams`` (4,) m/s and their validity
        ``valid`` (4,) bool; a beam is measured where valid and finite (the others become NaN)."""
        b = np.asarray(beams, float).reshape(4)
        measured = np.asarray(valid, bool).reshape(4) & np.isfinite(b)
        return cls(float(t), np.where(measured, b, np.nan), measured, np.zeros(4), False)

    @classmethod
    def from_velocity(cls, t: float, v_d, sigma) -> "Ping":
        """A velocity ping: ``v_d`` (3,) m/s of the DVL head in the DVL frame and its one-sigma per DVL axis
        ``sigma`` (3,) m/s (NaN = the configured one); no beams."""
        return cls(float(t), np.full(4, np.nan), np.zeros(4, bool), np.zeros(4), False,
                   v_d=np.array(v_d, float).reshape(3), v_d_sigma=np.array(sigma, float).reshape(3))

    @property
    def is_velocity(self) -> bool:
        """True for a ping that carries a DVL-frame velocity instead of beams."""
        return self.v_d is not None

    @property
    def regressed(self) -> np.ndarray:
        """(4,) True for beams the completer supplied (finite and not measured)."""
        return np.isfinite(self.beams) & ~self.measured

    @property
    def n_measured(self) -> int:
        return int(self.measured.sum())

    @property
    def n_regressed(self) -> int:
        return int(self.regressed.sum())


@dataclass
class PositionFix:
    """A horizontal position fix: geodetic latitude/longitude (rad), 1-sigma per horizontal axis (m)."""

    t: float
    lat: float
    lon: float
    sigma_m: float


@dataclass
class Keyframe:
    """One estimator epoch and everything that constrains it.

    Attributes:
        index: k, 0-based.
        t: stamp, s.
        kind: ``"init"`` (the initial epoch without a ping), ``"dvl"``, ``"imu"`` (filler in a DVL gap) or
            ``"fix"``.
        imu: IMU segments from keyframe k-1 (None for k = 0).
        ping: the DVL ping at this stamp, or None.
        depth: depth of the IMU at t (m, down), or None.
        heading: (yaw rad, sigma rad) at t, or None.
        fix: a position fix at t, or None.
    """

    index: int
    t: float
    kind: str
    imu: ImuSegments | None = None
    ping: Ping | None = None
    depth: float | None = None
    heading: tuple[float, float] | None = None
    fix: PositionFix | None = None
