"""Turn a mission into a stream of keyframes: IMU preintegration between them plus their DVL/depth data.

Keyframes sit at DVL stamps; when the DVL is silent for longer than ``options.max_keyframe_gap_s``,
IMU-only keyframes every ``options.imu_keyframe_interval_s`` fill the gap. IMU sample j holds over
``[t_j, t_{j+1})`` (zero-order hold, GTSAM's convention), so a keyframe between two IMU samples splits
that interval: sample j is integrated up to the keyframe and the rest of it goes to the next keyframe.

The estimators in this package consume :class:`Keyframe` objects and make their factors with
:func:`keyframe_factors` (which needs the predicted attitude, for the Earth rate in the lever-arm term).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, D, V, X

from graphnav.config import SensorConfig
from graphnav.dvl import DvlGeometry
from graphnav.earth import earth_rate_n
from graphnav.factors import beam_factor, beam_factor_dvl_errors, beam_noise, depth_factor
from graphnav.history import BeamHistory
from graphnav.mission import Mission, gap_variances

from .dvl_errors import beam_index
from .options import GraphOptions


@dataclass
class DvlMeasurement:
    """The beams of one DVL ping that go into the graph.

    Attributes:
        t: DVL stamp (IMU clock), s.
        rows_b: (m,3) beam unit vectors in the body frame.
        y: (m,) beam velocities of the DVL head, m/s (measured or regressed).
        sigma: (m,) noise std per beam, m/s.
        regressed: (m,) True for beams filled in by the completer.
        omega_b: (3,) gyro sample nearest the ping (raw, rad/s).
    """

    t: float
    rows_b: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    regressed: np.ndarray
    omega_b: np.ndarray

    @property
    def n_measured(self) -> int:
        return int((~self.regressed).sum())

    @property
    def n_regressed(self) -> int:
        return int(self.regressed.sum())


@dataclass
class Keyframe:
    """One graph state (x_k, v_k, b_k) and what constrains it.

    Attributes:
        index: k, 0-based; keys are ``X(k)``, ``V(k)``, ``B(k)``.
        t: stamp, s.
        pim: preintegrated IMU from keyframe k-1 to k (None for k = 0).
        dvl: the DVL ping at this keyframe, or None (IMU-only keyframe, or a ping with no usable beam).
        depth: depth of the IMU at t (m, down), or None.
        kind: ``"dvl"`` (a DVL stamp) or ``"imu"`` (filler inside a DVL gap).
    """

    index: int
    t: float
    pim: gtsam.PreintegratedCombinedMeasurements | None
    dvl: DvlMeasurement | None
    depth: float | None
    kind: str


def preintegration_params(config: SensorConfig, options: GraphOptions) -> gtsam.PreintegrationCombinedParams:
    """GTSAM preintegration settings: NED gravity, Earth rate as Coriolis term (first order), IMU noise.

    Covariances are continuous-time (density^2), as GTSAM expects.
    """
    params = gtsam.PreintegrationCombinedParams.MakeSharedD(config.gravity_mps2)
    imu = config.imu
    params.setAccelerometerCovariance(np.eye(3) * imu.accel_noise_density ** 2)
    params.setGyroscopeCovariance(np.eye(3) * imu.gyro_noise_density ** 2)
    params.setIntegrationCovariance(np.eye(3) * options.integration_sigma ** 2)
    params.setBiasAccCovariance(np.eye(3) * imu.accel_bias_rw ** 2)
    params.setBiasOmegaCovariance(np.eye(3) * imu.gyro_bias_rw ** 2)
    if config.earth_rotation:
        params.setOmegaCoriolis(earth_rate_n(config.lat_rad))
    # use2ndOrderCoriolis stays False (the default): the project's IMU model keeps first-order terms only
    return params


def keyframe_times(imu_t: np.ndarray, dvl_t: np.ndarray, options: GraphOptions) -> tuple[np.ndarray, np.ndarray]:
    """Keyframe stamps (K,) and, per keyframe, the DVL ping index or -1 for IMU-only keyframes.

    Every DVL stamp inside the IMU span is a keyframe; gaps longer than ``max_keyframe_gap_s`` (also before
    the end of the IMU data) get IMU-only keyframes every ``imu_keyframe_interval_s``, none closer than half
    an interval to the next keyframe.
    """
    inside = np.flatnonzero((dvl_t >= imu_t[0]) & (dvl_t <= imu_t[-1]))
    anchors = [(float(dvl_t[j]), int(j)) for j in inside] or [(float(imu_t[0]), -1)]
    following = [t for t, _ in anchors[1:]] + [float(imu_t[-1])]
    step = options.imu_keyframe_interval_s
    times, ping = [], []
    for (t, j), t_next in zip(anchors, following):
        times.append(t)
        ping.append(j)
        if t_next - t > options.max_keyframe_gap_s:
            n_fill = int(np.floor((t_next - t) / step - 0.5))
            times.extend(t + step * np.arange(1, n_fill + 1))
            ping.extend([-1] * n_fill)
    return np.array(times), np.array(ping, dtype=int)


class KeyframeBuilder:
    """Preintegrates the IMU and collects the DVL (and depth) data of each keyframe of one mission.

    Args:
        mission: the mission (stamps on the IMU clock).
        options: graph settings.
        completer: beam completer for the hybrid methods (Graph-HN*), or None for measured beams only.
    """

    def __init__(self, mission: Mission, options: GraphOptions, completer=None):
        self.mission = mission
        self.options = options
        self.config = mission.config
        self.geometry = DvlGeometry.from_spec(mission.config.dvl)
        self.params = preintegration_params(self.config, options)
        self.completer = completer
        self.history = BeamHistory(completer.n_past) if completer is not None else None
        self.beam_sigma = options.beam_sigma if options.beam_sigma is not None else self.config.dvl.beam_noise_std
        self.regressed_floor = (options.regressed_sigma_floor if options.regressed_sigma_floor is not None
                                else self.beam_sigma)
        # all-zero rows dropped and gaps bridged (with warnings); keyframes over a gap get inflated IMU noise
        self.imu, self.imu_gaps = mission.imu.bridge_gaps(self.config.imu_rate_hz)
        self.times, self.ping = keyframe_times(self.imu.t, mission.dvl.t, options)

    def __len__(self) -> int:
        return len(self.times)

    def dvl_measurement(self, j: int) -> DvlMeasurement | None:
        """The beams of ping j as graph measurements (completed when a completer is set)."""
        dvl = self.mission.dvl
        beams, valid = dvl.beams[j], dvl.valid[j] & np.isfinite(dvl.beams[j])
        sigma = np.where(valid, self.beam_sigma, np.nan)
        regressed = np.zeros(4, dtype=bool)
        if self.history is not None:
            completed = self.history.complete(self.completer, np.where(valid, beams, 0.0), valid)
            if completed is not None:
                full, filled_sigma = completed
                regressed = ~valid
                beams = np.where(valid, beams, full)
                sigma = np.where(valid, self.beam_sigma, np.maximum(filled_sigma, self.regressed_floor))
                valid = np.ones(4, dtype=bool)
        if not valid.any():
            return None
        imu = self.imu
        nearest = int(np.clip(np.searchsorted(imu.t, dvl.t[j]), 1, len(imu.t) - 1))
        if abs(imu.t[nearest - 1] - dvl.t[j]) <= abs(imu.t[nearest] - dvl.t[j]):
            nearest -= 1
        return DvlMeasurement(float(dvl.t[j]), self.geometry.T_b[valid], beams[valid], sigma[valid],
                              regressed[valid], imu.omega_b[nearest].copy())

    def depth_at(self, t: float) -> float | None:
        depth = self.mission.depth
        if depth is None or not self.options.use_depth or len(depth.t) == 0:
            return None
        if t < depth.t[0] - 0.5 or t > depth.t[-1] + 0.5:
            return None
        return float(np.interp(t, depth.t, depth.depth))

    def gap_params(self, t0: float, t1: float) -> gtsam.PreintegrationCombinedParams:
        """Preintegration settings for the keyframe interval [t0, t1]: inflated IMU noise when it holds a
        bridged IMU gap, so that the IMU factor's velocity and rotation variances grow by
        :func:`graphnav.mission.gap_variances` (GTSAM integrates the continuous covariance over t1 - t0)."""
        var_v, var_att = gap_variances(self.imu_gaps, t0, t1)
        if not var_v and not var_att:
            return self.params
        imu, length = self.config.imu, max(t1 - t0, 1e-9)
        params = preintegration_params(self.config, self.options)
        params.setAccelerometerCovariance(np.eye(3) * (imu.accel_noise_density ** 2 + var_v / length))
        params.setGyroscopeCovariance(np.eye(3) * (imu.gyro_noise_density ** 2 + var_att / length))
        return params

    def __iter__(self) -> Iterator[Keyframe]:
        imu = self.imu
        t_imu = imu.t
        n = len(t_imu)
        # IMU sample j covers [t_j, t_{j+1}); the last sample covers one nominal period
        last_dt = t_imu[-1] - t_imu[-2] if n > 1 else 1.0 / self.config.imu_rate_hz
        t_next = np.append(t_imu[1:], t_imu[-1] + last_dt)
        # first sample whose interval ends after each keyframe (the one a keyframe splits, if any)
        split = np.searchsorted(t_next, self.times, side="right").tolist()
        for k, (t, ping) in enumerate(zip(self.times, self.ping)):
            pim = None
            if k > 0:
                t_prev = self.times[k - 1]
                params = self.gap_params(t_prev, t) if self.imu_gaps else self.params
                pim = gtsam.PreintegratedCombinedMeasurements(params)
                j0, j1 = split[k - 1], split[k]
                # python lists of this keyframe's samples only (bounded memory on long missions)
                hi = min(j1 + 1, n)
                f, w = imu.f_b[j0:hi].tolist(), imu.omega_b[j0:hi].tolist()
                dt = (t_next[j0:hi] - t_imu[j0:hi]).tolist()
                if j0 == j1:                                   # both keyframes inside one IMU interval
                    pim.integrateMeasurement(f[0], w[0], t - t_prev)
                else:
                    if j0 < n:                                 # rest of the interval split at t_prev
                        pim.integrateMeasurement(f[0], w[0], t_next[j0] - max(t_prev, t_imu[j0]))
                    for i in range(1, min(j1, n) - j0):
                        pim.integrateMeasurement(f[i], w[i], dt[i])
                    if j1 < n and t > t_imu[j1]:               # start of the interval split at t
                        pim.integrateMeasurement(f[j1 - j0], w[j1 - j0], t - t_imu[j1])
            dvl = self.dvl_measurement(ping) if ping >= 0 else None
            yield Keyframe(k, float(t), pim, dvl, self.depth_at(t), "dvl" if ping >= 0 else "imu")


def imu_factor(kf: Keyframe) -> gtsam.CombinedImuFactor:
    """The preintegrated IMU factor between keyframes k-1 and k (k >= 1)."""
    k = kf.index
    return gtsam.CombinedImuFactor(X(k - 1), V(k - 1), X(k), V(k), B(k - 1), B(k), kf.pim)


@dataclass
class BeamGroup:
    """Beams of keyframe k that share one DVL factor (same kernel), with everything the factor needs.

    Attributes:
        k: keyframe index (keys ``X(k)``, ``V(k)``, ``B(k)``).
        rows_b: (m,3) beam unit vectors, body frame.
        y: (m,) beam velocities, m/s.
        sigma: (m,) noise std, m/s.
        huber_k: Huber threshold in sigmas, or None (Gaussian).
        omega_b: (3,) body rate for the lever-arm term (Earth rate removed when configured), rad/s.
        lever_arm_b: (3,) m.
        regressed: whether these are regressed (completed) beams.
        beam_index: (m,) beam number 0..3 of each row when the DVL error states ``D(k)`` (scale, beam bias)
            act on these beams (``GraphOptions.dvl_error_states``), else None.
        C_d_b: (3,3) DVL-to-body rotation, with ``beam_index``.
    """

    k: int
    rows_b: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    huber_k: float | None
    omega_b: np.ndarray
    lever_arm_b: np.ndarray
    regressed: bool
    beam_index: np.ndarray | None = None
    C_d_b: np.ndarray | None = None

    def factor(self) -> gtsam.CustomFactor:
        if self.beam_index is not None:
            return beam_factor_dvl_errors(X(self.k), V(self.k), B(self.k), D(self.k), self.rows_b,
                                          self.beam_index, self.C_d_b, self.y,
                                          beam_noise(self.sigma, self.huber_k), self.omega_b, self.lever_arm_b)
        return beam_factor(X(self.k), V(self.k), B(self.k), self.rows_b, self.y,
                           beam_noise(self.sigma, self.huber_k), self.omega_b, self.lever_arm_b)


@dataclass
class KeyframeFactors:
    """What keyframe k adds besides its IMU link: DVL beam groups and C++ factors (depth)."""

    groups: list[BeamGroup]
    other: gtsam.NonlinearFactorGraph

    def graph(self) -> gtsam.NonlinearFactorGraph:
        graph = gtsam.NonlinearFactorGraph()
        for group in self.groups:
            graph.add(group.factor())
        graph.push_back(self.other)
        return graph


def keyframe_factors(kf: Keyframe, builder: KeyframeBuilder, C_b_n_pred: np.ndarray,
                     p_n_pred: np.ndarray | None = None) -> KeyframeFactors:
    """The DVL and depth factors of keyframe ``kf`` (the IMU factor is :func:`imu_factor`).

    Measured beams form one group (one factor per epoch) unless ``beam_factor_mode="beam"`` or a Huber
    kernel is set for them; regressed beams likewise. A robust kernel acts on a factor's whole residual,
    so robust beams get one factor each.

    Args:
        kf: the keyframe.
        builder: its builder (geometry, options, configuration).
        C_b_n_pred: predicted attitude at kf (for the Earth rate removed from the lever-arm rate).
        p_n_pred: predicted position (centre of the depth factor's weak horizontal part).
    """
    options, config = builder.options, builder.config
    groups: list[BeamGroup] = []
    other = gtsam.NonlinearFactorGraph()
    k = kf.index
    if kf.dvl is not None:
        m = kf.dvl
        omega = m.omega_b
        if options.earth_rate_in_lever_arm and config.earth_rotation:
            omega = omega - C_b_n_pred.T @ earth_rate_n(config.lat_rad)
        lever = builder.geometry.lever_arm_b
        # the DVL error states act on measured beams, and on regressed ones if dvl_errors_on_regressed
        index = beam_index(m.rows_b, builder.geometry.T_b) if options.dvl_error_states else None
        C_d_b = builder.geometry.C_d_b if options.dvl_error_states else None
        for regressed, huber in ((False, options.huber_measured_k), (True, options.huber_regressed_k)):
            sel = np.flatnonzero(m.regressed == regressed)
            if sel.size == 0:
                continue
            split = options.beam_factor_mode == "beam" or huber is not None
            use_d = index is not None and (options.dvl_errors_on_regressed or not regressed)
            for part in ([[i] for i in sel] if split else [sel]):
                groups.append(BeamGroup(k, m.rows_b[part], m.y[part], m.sigma[part], huber, omega, lever,
                                        regressed, index[part] if use_d else None, C_d_b if use_d else None))
    if kf.depth is not None:
        sigma = options.depth_sigma if options.depth_sigma is not None else config.depth_noise_std
        ne = None if p_n_pred is None else p_n_pred[:2]
        other.add(depth_factor(X(k), kf.depth, sigma, ne))
    return KeyframeFactors(groups, other)
