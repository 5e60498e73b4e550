"""From streamed keyframes (:mod:`graphnav.estimators.keyframes`) to graph keyframes and their factors.

:class:`GraphContext` holds what every graph factor needs (options, configuration, DVL geometry, GTSAM's
preintegration settings); :func:`graph_keyframe` preintegrates a keyframe's IMU segments (zero-order hold,
GTSAM's convention, a split sample integrated over its part only) and keeps its
:class:`~graphnav.estimators.types.Ping` as it is, with the mask of the beams that become factors. The
estimators in this package consume :class:`GraphKeyframe` objects and make their factors with
:func:`keyframe_factors` (which needs the predicted attitude, for the Earth rate in the lever-arm term); the
ping becomes factor rows in one place, :meth:`GraphContext.beam_rows`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Iterator, NamedTuple

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, D, V, X

from graphnav.core.config import SensorConfig
from graphnav.core.dvl import DvlGeometry
from graphnav.core.earth import EarthModel, earth_rate_n
from graphnav.estimators import keyframes as kfs
from graphnav.estimators.graph.dvl_errors import beam_index
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.graph.regressed import (
    GraphPredictionError,
    OutagePriorSwitch,
    motion_prior_factors,
    screen_regressed,
)
from graphnav.estimators.rehearsal import OutageRehearsal
from graphnav.estimators.types import ImuSegments, Keyframe, Ping
from graphnav.factors import (
    beam_difference_factor,
    beam_factor,
    beam_factor_dvl_errors,
    beam_noise,
    depth_factor,
    dvl_velocity_factor,
    heading_factor,
    horizontal_position_factor,
)


class RegressedLink(NamedTuple):
    """A regressed beam that became a factor at keyframe ``k`` (stamp ``t`` s): its value ``y`` and the completer's
    sigma ``sigma`` (m/s), the body rate ``omega_b`` (rad/s) of its ping, and whether it used the DVL error states."""

    k: int
    t: float
    y: float
    sigma: float
    omega_b: np.ndarray
    use_d: bool


class BeamRows(NamedTuple):
    """The rows a ping gives the DVL factors (:meth:`GraphContext.beam_rows`).

    Attributes:
        rows_b: (m,3) beam unit vectors in the body frame (a velocity ping: the rows of ``C_d_b^T``, ``T_d`` = I).
        y: (m,) beam velocities of the DVL head, m/s (measured or regressed); a velocity ping: ``v_d`` (3,).
        sigma: (m,) noise std per beam (per DVL axis for a velocity), m/s.
        regressed: (m,) True for beams the completer supplied.
    """

    rows_b: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    regressed: np.ndarray


@dataclass
class GraphKeyframe:
    """One graph state (x_k, v_k, b_k) and what constrains it.

    Attributes:
        index: k, 0-based; keys are ``X(k)``, ``V(k)``, ``B(k)``.
        t: stamp, s.
        pim: preintegrated IMU from keyframe k-1 to k (None for k = 0).
        ping: the DVL ping at this keyframe (the keyframer's :class:`~graphnav.estimators.types.Ping`), or None
            (IMU-only keyframe, or a ping with no usable beam).
        beams_used: (4,) True for the ping's beams that become factors (:meth:`GraphContext.usable_beams`);
            None for a velocity ping or without a ping.
        depth: depth of the IMU at t (m, down), or None.
        kind: ``"init"``, ``"dvl"`` (a DVL stamp), ``"imu"`` (filler inside a DVL gap) or ``"fix"``.
        heading: (yaw rad, sigma rad) from a heading sensor, or None.
        fix_ne: (north, east) m of a position fix in the navigation frame, or None; ``fix_sigma`` m.
    """

    index: int
    t: float
    pim: gtsam.PreintegratedCombinedMeasurements | None
    ping: Ping | None
    depth: float | None
    kind: str
    heading: tuple[float, float] | None = None
    fix_ne: np.ndarray | None = None
    fix_sigma: float = 0.0
    #: the preintegration settings of ``pim`` alone (its gravity is set by :meth:`GraphContext.set_gravity`)
    params: gtsam.PreintegrationCombinedParams | None = None
    beams_used: np.ndarray | None = None

    @property
    def n_measured(self) -> int:
        """Measured rows of this keyframe's DVL factors (a velocity ping's three axes count as three)."""
        if self.ping is None:
            return 0
        if self.ping.is_velocity:
            return 3
        return int((self.beams_used & self.ping.measured).sum())

    @property
    def n_regressed(self) -> int:
        """Regressed beams of this keyframe's DVL factors."""
        if self.ping is None or self.ping.is_velocity:
            return 0
        return int((self.beams_used & ~self.ping.measured).sum())


def preintegration_params(config: SensorConfig, options: GraphOptions) -> gtsam.PreintegrationCombinedParams:
    """GTSAM preintegration settings: NED gravity (at the origin), Earth rate as Coriolis term (first order),
    IMU noise.

    Covariances are continuous-time (density^2), as GTSAM expects. Gravity depends on the position
    (:class:`graphnav.core.earth.EarthModel`) while GTSAM takes one vector per preintegration: every keyframe has
    its own settings, whose gravity :meth:`GraphContext.set_gravity` sets from the predicted position.
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


def preintegration_gravity(earth: EarthModel, p_n: np.ndarray, v_n: np.ndarray, length_s: float) -> np.ndarray:
    """The gravity vector (3,) m/s^2 to give GTSAM for a preintegration of ``length_s`` s that starts at ``p_n``
    (m) with velocity ``v_n`` (m/s): the Earth model's gravity at the interval's middle, plus
    ``omega_ie x (omega_ie x p_n)``.

    The second term undoes the centrifugal term GTSAM 4.3's prediction subtracts at the start position
    (measured: a static IMU 22 km from the origin gains ``-omega x (omega x p)``, 6e-5 m/s per second, whatever
    ``use2ndOrderCoriolis`` says): the Earth model's plumb-bob gravity already holds the centrifugal
    acceleration of the point. Its dependence on the estimated position (5e-9 s^-2) is far below any IMU's.
    """
    p = np.asarray(p_n, float)
    omega = earth.omega_ie_n
    return earth.gravity_n(p + 0.5 * length_s * np.asarray(v_n, float)) + _cross(omega, _cross(omega, p))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` of two 3-vectors, the products and differences of ``np.cross`` (which costs ~10 us a call)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


class GraphContext:
    """What the graph factors of one mission need: options, sensor configuration, DVL geometry, beam sigmas
    and GTSAM's preintegration settings.

    Args:
        config: sensor configuration.
        options: graph settings.
    """

    def __init__(self, config: SensorConfig, options: GraphOptions):
        self.config = config
        self.options = options
        self.geometry = DvlGeometry.from_spec(config.dvl)
        self.params = preintegration_params(config, options)
        self.earth = EarthModel.from_config(config)
        self.beam_sigma = options.beam_sigma if options.beam_sigma is not None else config.dvl.beam_noise_std
        dvl = config.dvl
        #: (3,) sigma per DVL axis of a DVL-frame velocity without its own (DvlSpec.velocity_noise_std)
        self.velocity_sigma = (dvl.velocity_noise_std if dvl.velocity_noise_std is not None
                               else self.geometry.velocity_sigma_d(self.beam_sigma))
        self.regressed_floor = (options.regressed_sigma_floor if options.regressed_sigma_floor is not None
                                else self.beam_sigma)
        #: regressed beams dropped by the gate / as redundant, given a larger sigma (see .regressed), continuing a
        #: run unscreened, and all that became factors (a completion the motion prior replaced is in none)
        self.screening = {"gated": 0, "decorrelated_out": 0, "inflated": 0, "continued": 0, "entered": 0}
        #: the choice of motion_prior="total-if-uncertain" (state across keyframes, counters)
        self.outage_switch = OutagePriorSwitch(options)
        #: with ``options.regressed_runs="screen-first"``: the regressed beams that became factors at the last keyframe
        #: with a ping, by beam number (the previous link of each beam's Gauss-Markov chain)
        self.regressed_links: dict[int, RegressedLink] = {}
        #: ``options.rehearsed_outages``: the mission's rehearsed outages (the Navigator hands them to its keyframer)
        self.rehearsal = (OutageRehearsal(self.geometry.T_b, self.geometry.lever_arm_b, options.rehearsed_outages,
                                          graph=options.rehearsal_graph, fusion=options.rehearsal_fusion,
                                          beam_sigma=self.beam_sigma)
                          if options.rehearsed_outages is not None else None)
        #: ``options.measured_both_margin``: the graph's recent prediction error against the completer's
        self.graph_error = (GraphPredictionError(options.measured_both_margin, self.beam_sigma)
                            if options.measured_both_margin is not None else None)
        #: stamp (s) of the first ping of the current run of pings with regressed beams, None outside one: the time
        #: into the run ``screening.prediction_var_table`` is indexed by
        self.regressed_run_start: float | None = None

    def claim_scale(self, kf: GraphKeyframe, regressed: bool) -> float:
        """The factor of ``screening.prediction_var_table`` at keyframe ``kf`` (1 without it), whose ping has
        ``regressed`` beams or not (which starts or ends a run)."""
        if not regressed:
            self.regressed_run_start = None
            return 1.0
        if self.regressed_run_start is None:
            self.regressed_run_start = kf.t
        return self.options.screening.table_scale(kf.n_measured, kf.t - self.regressed_run_start)

    def count_screening(self, stats: dict) -> None:
        for key, n in stats.items():
            self.screening[key] += n

    def gap_params(self, var_v: float, var_att: float, length: float) -> gtsam.PreintegrationCombinedParams:
        """Preintegration settings for a keyframe interval of ``length`` s that holds a bridged IMU gap: the
        IMU noise is inflated so that the IMU factor's velocity and rotation variances grow by ``var_v``
        ((m/s)^2) and ``var_att`` (rad^2) per axis (:func:`graphnav.core.mission.gap_variances`; GTSAM integrates
        the continuous covariance over the interval). A new object every call: a keyframe's gravity is its own."""
        params = preintegration_params(self.config, self.options)
        if not var_v and not var_att:
            return params
        imu, length = self.config.imu, max(length, 1e-9)
        params.setAccelerometerCovariance(np.eye(3) * (imu.accel_noise_density ** 2 + var_v / length))
        params.setGyroscopeCovariance(np.eye(3) * (imu.gyro_noise_density ** 2 + var_att / length))
        return params

    def preintegrate(self, imu: ImuSegments) -> tuple[gtsam.PreintegratedCombinedMeasurements,
                                                          gtsam.PreintegrationCombinedParams]:
        """The keyframe interval's IMU segments preintegrated (zero-order hold, one call per segment), with the
        settings object the preintegration holds (set its gravity with :meth:`set_gravity`)."""
        params = self.gap_params(imu.var_v, imu.var_att, float(imu.dt.sum()))
        pim = gtsam.PreintegratedCombinedMeasurements(params)
        # rows of the (n,3) arrays reach GTSAM as Eigen maps (lists would be converted to arrays first)
        for f, w, dt in zip(np.ascontiguousarray(imu.f_b, float), np.ascontiguousarray(imu.omega_b, float),
                            imu.dt.tolist()):
            pim.integrateMeasurement(f, w, dt)
        return pim, params

    def set_gravity(self, kf: "GraphKeyframe", p_n: np.ndarray, v_n: np.ndarray) -> None:
        """Give keyframe ``kf``'s IMU factor the gravity at the middle of its interval, predicted from the
        position ``p_n`` (m) and velocity ``v_n`` (m/s) at its start (before the factor is made: GTSAM shares the
        settings with the factor). Gravity changes 1.5e-6 m/s^2 per metre, so the prediction's error (metres)
        and the motion within the interval are far below IMU noise; over tens of km the vector turns by
        ``|p_h|/R`` (0.27 deg at 30 km) and a constant one would be worth 0.05 m/s^2."""
        if kf.params is None:
            return
        kf.params.n_gravity = preintegration_gravity(self.earth, p_n, v_n, kf.pim.deltaTij())

    def usable_beams(self, ping: Ping) -> np.ndarray | None:
        """(4,) True for the beams of a beam ping that become factors (measured, or regressed unless the
        motion prior replaces a ping without any measured beam); None when none is usable."""
        usable = np.isfinite(ping.beams)
        if self.options.motion_prior in ("partial", "total") and not ping.measured.any():
            # without any measured beam the completers extrapolate blind; the motion prior takes over
            usable = ping.measured
        return usable if usable.any() else None

    def beam_rows(self, ping: Ping, used: np.ndarray | None) -> BeamRows:
        """The one place a ping becomes the arrays of its DVL factors: the ``used`` beams (:meth:`usable_beams`)
        as body-frame rows, measured ones at the beam sigma, regressed ones at the completer's sigma (floored);
        a velocity ping as its DVL-frame velocity (per-axis sigma from the ping, else :attr:`velocity_sigma`)."""
        if ping.is_velocity:
            sigma = np.where(np.isfinite(ping.v_d_sigma), ping.v_d_sigma, self.velocity_sigma)
            return BeamRows(self.geometry.C_d_b.T.copy(), ping.v_d.copy(), sigma, np.zeros(3, bool))
        regressed = used & ~ping.measured
        sigma = np.where(regressed, np.maximum(ping.sigma_regressed, self.regressed_floor), self.beam_sigma)
        return BeamRows(self.geometry.T_b[used], ping.beams[used], sigma[used], regressed[used])


def tangent_down(earth: EarthModel, depth_m: float, p_n_pred: np.ndarray | None) -> float:
    """The navigation frame's ``down`` (m) of a depth reading: a pressure sensor measures depth below the sea
    surface, which curves away below the fixed tangent plane by ``|p_h|^2 / 2R`` (2 cm at 500 m, 7.8 m at
    10 km); the drop is taken at the predicted position (its error, metres, changes it by micrometres)."""
    if p_n_pred is None:
        return float(depth_m)
    p = np.asarray(p_n_pred, float)
    return float(depth_m - (earth.depth_of(p) - p[2]))


def graph_keyframe(kf: Keyframe, ctx: GraphContext) -> GraphKeyframe:
    """A streamed keyframe as the graph estimators use it (a position fix's NED ``fix_ne`` is set by the caller,
    who knows the navigation origin)."""
    pim, params = ctx.preintegrate(kf.imu) if kf.imu is not None else (None, None)
    ping, used = kf.ping, None
    if ping is not None and not ping.is_velocity:
        used = ctx.usable_beams(ping)
        if used is None:
            ping = None
    depth = kf.depth if ctx.options.use_depth else None
    return GraphKeyframe(kf.index, kf.t, pim, ping, depth, kf.kind, kf.heading, None,
                         kf.fix.sigma_m if kf.fix is not None else 0.0, params, used)


def mission_keyframes(mission, options: GraphOptions, completer=None,
                      keyframe_options: kfs.KeyframeOptions | None = None) -> Iterator[GraphKeyframe]:
    """Graph keyframes of a recorded mission, from its first DVL ping inside the IMU span (a replay of its
    samples in time order through :class:`graphnav.estimators.keyframes.Keyframer`; used by offline tools such as the
    lever-arm calibration)."""
    from graphnav.estimators.replay import first_ping_time, replay
    ctx = GraphContext(mission.config, options)
    # Mission.validate warned about the pings after the IMU's end
    said = dataclasses.replace(keyframe_options or kfs.KeyframeOptions(), late_pings_said=True)
    keyframer = kfs.Keyframer(mission.config, said, completer)
    started = False
    t0 = first_ping_time(mission)
    for kind, t, payload in replay(mission):
        if not started and t >= t0:
            started = True
            yield from (graph_keyframe(k, ctx) for k in keyframer.start(t0))
        yield from (graph_keyframe(k, ctx) for k in getattr(keyframer, "add_" + kind)(t, *payload))
    yield from (graph_keyframe(k, ctx) for k in keyframer.finish())


def imu_factor(kf: GraphKeyframe) -> gtsam.CombinedImuFactor:
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
        regressed: whether these are regressed beams.
        beam_index: (m,) beam number 0..3 of each row when the DVL error states ``D(k)`` (scale, beam bias)
            act on these beams (``GraphOptions.dvl_error_states``), else None.
        C_d_b: (3,3) DVL-to-body rotation, with ``beam_index``.
        velocity: the rows are a DVL-frame velocity (rows ``C_d_b^T``, beam index -1 with the DVL error
            states): one :func:`graphnav.factors.dvl_velocity_factor`.
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
    velocity: bool = False

    def factor(self) -> gtsam.CustomFactor:
        """One factor over the group's rows; a Huber kernel acts on each beam by itself (per-row reweighting,
        :func:`graphnav.factors.beam_noise`), on a velocity's residual as a whole."""
        if self.velocity:
            C_d_b = self.rows_b.T
            d_key = D(self.k) if self.beam_index is not None else None
            return dvl_velocity_factor(X(self.k), V(self.k), B(self.k), C_d_b, self.y,
                                       beam_noise(self.sigma, self.huber_k), self.omega_b, self.lever_arm_b,
                                       d_key=d_key)
        noise = beam_noise(self.sigma, self.huber_k, per_row=True)
        if self.beam_index is not None:
            return beam_factor_dvl_errors(X(self.k), V(self.k), B(self.k), D(self.k), self.rows_b,
                                          self.beam_index, self.C_d_b, self.y, noise, self.omega_b, self.lever_arm_b)
        return beam_factor(X(self.k), V(self.k), B(self.k), self.rows_b, self.y, noise, self.omega_b,
                           self.lever_arm_b)

    def beam_factors(self) -> list[gtsam.CustomFactor]:
        """One factor per beam (a velocity: its one factor): the same linearisation as :meth:`factor`, and a
        nonlinear error that is the sum of the beams' robust losses (what Levenberg-Marquardt's step test needs)."""
        if self.velocity or self.huber_k is None or len(self.y) == 1:
            return [self.factor()]
        return [dataclasses.replace(self, rows_b=self.rows_b[[i]], y=self.y[[i]], sigma=self.sigma[[i]],
                                    beam_index=None if self.beam_index is None else self.beam_index[[i]]).factor()
                for i in range(len(self.y))]


@dataclass
class KeyframeFactors:
    """What keyframe k adds besides its IMU link: DVL beam groups, the difference factors that carry a run of
    regressed beams with correlated errors (``run_links``) and the other factors (depth, fixes, motion prior)."""

    groups: list[BeamGroup]
    other: gtsam.NonlinearFactorGraph
    run_links: gtsam.NonlinearFactorGraph = field(default_factory=gtsam.NonlinearFactorGraph)

    def graph(self) -> gtsam.NonlinearFactorGraph:
        """The keyframe's factors: the groups' (in order), then ``run_links``, then ``other``."""
        graph = gtsam.NonlinearFactorGraph()
        for group in self.groups:
            graph.add(group.factor())
        graph.push_back(self.run_links)
        graph.push_back(self.other)
        return graph

    def completion_positions(self) -> list[int]:
        """Positions in :meth:`graph` of the factors made from regressed beams (their groups and run links)."""
        n = len(self.groups)
        return [i for i, g in enumerate(self.groups) if g.regressed] + list(range(n, n + self.run_links.size()))

    def without_completions(self) -> tuple["KeyframeFactors", int]:
        """(these factors without those made from regressed beams, the regressed beams left out: a row each, as
        :meth:`completion_positions` counts them in the incremental smoothers)."""
        beams = sum(len(g.y) for g in self.groups if g.regressed) + sum(
            self.run_links.at(i).dim() for i in range(self.run_links.size()))
        return KeyframeFactors([g for g in self.groups if not g.regressed], self.other), beams


def continue_regressed_runs(kf: GraphKeyframe, builder: GraphContext, m: BeamRows, sel: np.ndarray,
                            omega_b: np.ndarray, use_d: bool):
    """``options.regressed_runs="screen-first"``: the regressed rows ``sel`` of keyframe ``kf`` (rows of ``m``) whose
    beam was a regressed factor at keyframe k-1 too continue their run without the screening, as plain rows at the
    completer's sigma or, with ``options.regressed_error_tau_s``, as one whitened difference factor
    (:func:`graphnav.factors.beam_difference_factor`; see :class:`~.options.GraphOptions`). With a Huber kernel
    on regressed beams each beam's difference is a factor of its own, so that the factor's nonlinear error (which
    the batch smoother's step test and Levenberg-Marquardt use) is the sum of per-beam losses its linearisation
    reweights by.

    Returns (the rows left for the screening, the plain continued rows, the difference factors, the chain links of
    the continued beams at kf)."""
    options, k = builder.options, kf.index
    beams = beam_index(m.rows_b[sel], builder.geometry.T_b)
    prev = [builder.regressed_links.get(int(j)) for j in beams]
    chained = np.array([p is not None and p.k == k - 1 and p.use_d == use_d for p in prev], dtype=bool)
    rows = sel[chained]
    builder.screening["continued"] += len(rows)
    builder.screening["entered"] += len(rows)
    links = regressed_links(kf, m, rows, beams[chained], omega_b, use_d)
    tau = options.error_tau_for(int(np.count_nonzero(~m.regressed)))     # by the ping's measured beams
    if not chained.any() or tau is None:
        return sel[~chained], rows, [], links
    prev = [p for p, c in zip(prev, chained) if c]
    phi = np.exp(-max(kf.t - prev[0].t, 0.0) / tau)
    s_k, s_prev = m.sigma[rows], np.array([p.sigma for p in prev])
    sigma_w = np.sqrt(np.maximum(s_k ** 2 - phi ** 2 * s_prev ** 2, (1.0 - phi ** 2) * s_k ** 2))
    keys = [(X(j), V(j), B(j)) + ((D(j),) if use_d else ()) for j in (k - 1, k)]
    y_prev, huber = np.array([p.y for p in prev]), options.huber_regressed_k
    factors = []
    for part in ([[i] for i in range(len(rows))] if huber is not None else [np.arange(len(rows))]):
        extra = {"beam_index": beams[chained][part], "C_d_b": builder.geometry.C_d_b} if use_d else {}
        factors.append(beam_difference_factor(keys[0], keys[1], m.rows_b[rows[part]], y_prev[part], m.y[rows[part]],
                                              phi, beam_noise(sigma_w[part], huber, per_row=True), prev[0].omega_b,
                                              omega_b, builder.geometry.lever_arm_b, **extra))
    return sel[~chained], rows[:0], factors, links


def rehearsed_rows(kf: GraphKeyframe, m: BeamRows) -> np.ndarray:
    """(len(m.y),) bool: the rows of ``m`` (keyframe ``kf``'s ping) whose completion the rehearsed outages kept."""
    rehearsed = kf.ping.rehearsed
    if rehearsed is None or kf.ping.is_velocity:
        return np.zeros(len(m.y), dtype=bool)
    return rehearsed[kf.beams_used] & m.regressed


def regressed_links(kf: GraphKeyframe, m: BeamRows, rows: np.ndarray, beams: np.ndarray, omega_b: np.ndarray,
                    use_d: bool) -> dict[int, RegressedLink]:
    """The chain links (by beam number ``beams``) of the regressed rows ``rows`` of ``m`` that became factors at
    keyframe ``kf``."""
    return {int(j): RegressedLink(kf.index, kf.t, float(m.y[i]), float(m.sigma[i]), omega_b, use_d)
            for i, j in zip(rows, beams)}


def dropped_completions(builder: GraphContext, m: BeamRows, C_b_n_pred: np.ndarray, omega_b: np.ndarray,
                        prediction) -> np.ndarray:
    """(len(m.y),) bool: the regressed rows of a ping that ``GraphOptions.measured_both_margin`` drops, the graph's
    prediction error being smaller than the completer's (:class:`.regressed.GraphPredictionError`; none without it)."""
    dropped = np.zeros(len(m.y), dtype=bool)
    judge = builder.graph_error
    if judge is None:
        return dropped
    if not m.regressed.any():
        judge.end_run()
        return dropped
    dropped[m.regressed] = ~judge.keep(m.rows_b, m.y, m.sigma, m.regressed, C_b_n_pred, omega_b,
                                       builder.geometry.lever_arm_b, prediction)
    return dropped


def keyframe_factors(kf: GraphKeyframe, builder: GraphContext, C_b_n_pred: np.ndarray,
                     p_n_pred: np.ndarray | None = None, prediction=None) -> KeyframeFactors:
    """The DVL and depth factors of keyframe ``kf`` (the IMU factor is :func:`imu_factor`).

    Measured beams form one group (one factor per ping) unless ``beam_factor_mode="beam"``; regressed beams
    likewise. A Huber kernel acts on each beam of a group by itself (:meth:`BeamGroup.factor`); a DVL-frame
    velocity is one measurement, its kernel acts on the whole residual.

    Args:
        kf: the keyframe.
        builder: the mission's :class:`GraphContext` (geometry, options, configuration).
        C_b_n_pred: predicted attitude at kf (for the Earth rate removed from the lever-arm rate).
        p_n_pred: predicted position (centre of the depth factor's weak horizontal part).
        prediction: the graph's :class:`.regressed.VelocityPrediction` at kf, for screening regressed beams and
            for the choice of ``motion_prior="total-if-uncertain"``.
    """
    options, config = builder.options, builder.config
    groups: list[BeamGroup] = []
    other, run_links = gtsam.NonlinearFactorGraph(), gtsam.NonlinearFactorGraph()
    k = kf.index
    n_measured = kf.n_measured
    if options.motion_prior == "total-if-uncertain":
        use_prior = builder.outage_switch.decide(n_measured, prediction, C_b_n_pred)
    else:
        use_prior = k > 0 and (options.motion_prior == "partial" and n_measured < 3
                               or options.motion_prior == "total" and n_measured == 0)
    if kf.ping is not None:
        velocity = kf.ping.is_velocity
        m = builder.beam_rows(kf.ping, kf.beams_used)
        omega = kf.ping.omega_b.copy()
        if options.earth_rate_in_lever_arm and config.earth_rotation:
            omega = omega - C_b_n_pred.T @ earth_rate_n(config.lat_rad)
        lever = builder.geometry.lever_arm_b
        # the DVL error states act on measured beams, and on regressed ones if dvl_errors_on_regressed; a
        # velocity's rows take the scale only (beam index -1)
        index = None
        if options.dvl_error_states:
            index = np.full(len(m.y), -1) if velocity else beam_index(m.rows_b, builder.geometry.T_b)
        C_d_b = builder.geometry.C_d_b if options.dvl_error_states else None
        links: dict[int, RegressedLink] = {}
        screen_first = options.runs_for(n_measured) == "screen-first"
        dropped = dropped_completions(builder, m, C_b_n_pred, omega, prediction)
        claim_scale = builder.claim_scale(kf, bool(m.regressed.any()))
        for regressed, huber in ((False, options.huber_measured_k), (True, options.huber_regressed_k)):
            sel = np.flatnonzero((m.regressed == regressed) & ~dropped)
            sigma = m.sigma
            use_d = index is not None and (options.dvl_errors_on_regressed or not regressed)
            continued = vouched = sel[:0]
            if regressed and sel.size and screen_first:
                sel, continued, differences, links = continue_regressed_runs(kf, builder, m, sel, omega, use_d)
                for factor in differences:
                    run_links.add(factor)
            if regressed and sel.size:
                # completions the rehearsed outages kept enter without the screening
                rehearsed = rehearsed_rows(kf, m)[sel]
                vouched, sel = sel[rehearsed], sel[~rehearsed]
                builder.count_screening({"entered": len(vouched)})
            if regressed and sel.size:
                keep, sigma_sel, stats = screen_regressed(m.rows_b[sel], m.y[sel], m.sigma[sel], C_b_n_pred,
                                                          omega, builder.geometry.lever_arm_b, prediction,
                                                          options, claim_scale)
                builder.count_screening({**stats, "entered": int(keep.sum())})
                sigma = m.sigma.copy()
                sigma[sel] = sigma_sel
                sel = sel[keep]
            if regressed:
                sel = np.sort(np.r_[sel, vouched]).astype(int)
            if regressed and screen_first:
                links.update(regressed_links(kf, m, sel, beam_index(m.rows_b[sel], builder.geometry.T_b), omega,
                                             use_d))
                sel = np.sort(np.r_[sel, continued])      # continued rows keep the completer's sigma
            if sel.size == 0:
                continue
            # a velocity is one measurement: one factor (a robust kernel on its whole residual)
            split = not velocity and options.beam_factor_mode == "beam"
            for part in ([[i] for i in sel] if split else [sel]):
                groups.append(BeamGroup(k, m.rows_b[part], m.y[part], sigma[part], huber, omega, lever,
                                        regressed, index[part] if use_d else None, C_d_b if use_d else None,
                                        velocity))
        builder.regressed_links = links
    if use_prior and k > 0:
        other.push_back(motion_prior_factors(k, kf.pim.deltaTij(), options))
    if kf.depth is not None:
        sigma = options.depth_sigma if options.depth_sigma is not None else config.depth_noise_std
        ne = None if p_n_pred is None else p_n_pred[:2]
        other.add(depth_factor(X(k), tangent_down(builder.earth, kf.depth, p_n_pred), sigma, ne))
    if kf.fix_ne is not None:
        down = None if p_n_pred is None else p_n_pred[2]
        other.add(horizontal_position_factor(X(k), kf.fix_ne, kf.fix_sigma, down))
    if kf.heading is not None:
        other.add(heading_factor(X(k), *kf.heading))
    return KeyframeFactors(groups, other, run_links)
