"""The estimators behind :class:`graphnav.estimators.navigator.Navigator`, one adapter each: keyframe in, estimate out.

- :class:`GraphBackend`: the factor graph (``"fixed-lag"``: GTSAM's IncrementalFixedLagSmoother, bounded
  time and memory; ``"isam2"``: ISAM2 over the whole mission) on preintegrated IMU factors, per-beam DVL
  factors, depth, heading and position-fix factors.
- :class:`EkfBackend`: the paper's error-state EKF (tightly or loosely coupled) on the same keyframes.

Both return a :class:`~graphnav.estimators.types.EpochEstimate` per keyframe (the filtered state, the biases and
the estimator's marginal covariances: the graph's as ``GraphOptions.marginals`` asks, the EKF's blocks of P). Both take the same :class:`~graphnav.estimators.types.InitialState`.
"""
from __future__ import annotations

import dataclasses
import time
import warnings

import gtsam
import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.earth import EarthModel, lla_to_ned
from graphnav.core.errors import ConfigError
from graphnav.core.rotations import so3_exp_batch
from graphnav.core.solution import position_frame
from graphnav.estimators.ekf import IE, EkfOptions, ErrorStateEkf
from graphnav.estimators.graph.builder import GraphContext, graph_keyframe, tangent_down
from graphnav.estimators.graph.first_pass import DeadReckoningGraph
from graphnav.estimators.graph.incremental import FixedLagGraph, OnlineGraph
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.ins import StrapdownState
from graphnav.estimators.types import EpochEstimate, ImuSegments, InitialState, Keyframe
from graphnav.factors.aiding import yaw_and_jacobian

#: Backend names of the Navigator. ``"dead-reckoning"``: graph keyframes and factors without a solver (IMU attitude,
#: DVL velocity), the batch smoother's cheap first pass (:mod:`graphnav.estimators.graph.first_pass`).
BACKENDS = ("fixed-lag", "isam2", "ekf", "dead-reckoning")


class _Aided:
    """Shared handling of position fixes: NED of a fix relative to the navigation origin (set by the first
    fix when the initial state gave none: the origin is then placed so that this fix equals the position
    estimated at its stamp, and the fix itself adds no information)."""

    origin_lla: tuple[float, float, float] | None = None
    n_fixes: int = 0
    #: stamp (s) of the fix that placed the origin, and the dead-reckoned north/east (m) the origin took there
    first_fix_t: float | None = None
    origin_offset_ne: np.ndarray = np.zeros(2)
    #: the first fix's distance from the estimate (m) and in sigmas, when the frame was placed before it
    first_fix_departure: tuple[float, float] | None = None
    #: beams a completer regressed entered at the last keyframe, past the screening against the estimator's own
    #: prediction (and, in the EKF, the gate): the Navigator's coasting warning then says the velocity comes from
    #: them. Offered is not entered: a 90 s total outage of a simulated mission had all 360 of its completions
    #: screened out in HNTC and Graph-HN, which navigated on the IMU alone.
    last_completed: bool = False

    def fix_ne(self, kf: Keyframe, p_n_pred: np.ndarray, cov_p_n: np.ndarray | None = None) -> np.ndarray | None:
        """North/east (m) of ``kf``'s fix in the estimate's frame (placing the frame at the first fix when nothing
        placed it before). ``p_n_pred`` (3,) m, the position predicted at the fix, and its covariance ``cov_p_n``
        (3,3) m^2 when known: the first fix in a frame placed before it is checked against them
        (:meth:`_check_first_fix`)."""
        if kf.fix is None:
            return None
        self.n_fixes += 1
        if self.origin_lla is None:
            self.origin_lla = (kf.fix.lat, kf.fix.lon, 0.0)
            self.origin_offset_ne = np.asarray(p_n_pred[:2], float).copy()
            self.first_fix_t = float(kf.t)
        ned = lla_to_ned(np.array([kf.fix.lat]), np.array([kf.fix.lon]), np.array([0.0]), self.origin_lla)[0]
        fix_ne = ned[:2] + self.origin_offset_ne
        if self.n_fixes == 1 and self.first_fix_t is None and cov_p_n is not None:
            self._check_first_fix(kf, fix_ne, p_n_pred, cov_p_n)
        return fix_ne

    def _check_first_fix(self, kf: Keyframe, fix_ne, p_n_pred, cov_p_n) -> None:
        """Warn when the first fix lies more than :data:`FIRST_FIX_MAX_SIGMAS` sigmas (the estimate's and the fix's
        together) from the estimate in a frame placed before it (an ``--initial-position`` or the GT): the start
        given, or the fix, is wrong, and the fixes are about to pull the track there without a word."""
        d = float(np.hypot(*(np.asarray(fix_ne) - np.asarray(p_n_pred)[:2])))
        var = kf.fix.sigma_m ** 2 + 0.5 * float(np.trace(np.asarray(cov_p_n, float)[:2, :2]))
        sigmas = d / np.sqrt(var)
        self.first_fix_departure = (d, float(sigmas))
        if sigmas > FIRST_FIX_MAX_SIGMAS:
            warnings.warn(f"{self.name}: the first position fix (t = {kf.t:.1f} s) is {d:.1f} m from the estimate, "
                          f"{sigmas:.0f} sigmas (the estimate's and the fix's): the start given (--initial-position) "
                          "or the fix is wrong; the fixes will pull the track to themselves", RuntimeWarning,
                          stacklevel=4)

    def position_frame(self, info: dict) -> dict:
        """Where the positions are on Earth (:func:`graphnav.core.solution.position_frame`), ``info`` the
        Navigator's (its alignment says how the start was placed)."""
        return position_frame(info, self.origin_lla, self.origin_offset_ne, self.first_fix_t)


#: The first fix's departure from the estimate, in sigmas, beyond which it is warned about (:class:`_Aided`).
FIRST_FIX_MAX_SIGMAS = 5.0


class GraphBackend(_Aided):
    """Factor-graph backend.

    Args:
        config: sensor configuration.
        options: graph settings.
        mode: ``"fixed-lag"`` (lag ``options.lag_s``), ``"isam2"`` or ``"dead-reckoning"`` (no solver: the batch's
            first pass, :class:`~graphnav.estimators.graph.first_pass.DeadReckoningGraph`).
        initial: state at the first keyframe.
    """

    def __init__(self, config: SensorConfig, options: GraphOptions | None, mode: str, initial: InitialState,
                 name: str = "graph", keep_keyframe_graphs: bool = False):
        self.ctx = GraphContext(config, options or GraphOptions())
        if mode == "isam2":
            self.estimator = OnlineGraph(self.ctx, initial, keep_keyframe_graphs)
        elif mode == "fixed-lag":
            self.estimator = FixedLagGraph(self.ctx, initial, keep_keyframe_graphs)
        elif mode == "dead-reckoning":
            self.estimator = DeadReckoningGraph(self.ctx, initial, keep_keyframe_graphs)
        else:
            raise ConfigError(f"unknown graph backend '{mode}'; choose 'fixed-lag', 'isam2' or 'dead-reckoning'")
        self.estimator.health.estimator = name
        self.name = name
        self.last_aided = False
        self.mode = mode
        self.origin_lla = initial.origin_lla
        self._initial = initial

    def process(self, kf: Keyframe) -> EpochEstimate:
        gkf = graph_keyframe(kf, self.ctx)
        if kf.fix is not None:
            last = self.estimator.latest
            if last is None:
                p_pred = self._initial.pose.translation()
            else:
                self.ctx.set_gravity(gkf, last.pose.translation(), last.v_n)
                p_pred = gkf.pim.predict(gtsam.NavState(last.pose, last.v_n), last.bias).position()
            gkf.fix_ne = self.fix_ne(kf, p_pred, None if last is None else last.cov_p_n)
        self.estimator.add(gkf)
        est = self.estimator.update()
        #: a DVL factor with a measured beam (or velocity) entered at this keyframe (the Navigator's coasting
        #: check); beams regressed at a ping without any measured one are no DVL aiding
        self.last_aided = est.n_measured > 0
        self.last_completed = self.estimator.completions_entered
        return est

    @property
    def monitor(self):
        """The estimator's :class:`~graphnav.estimators.health.NisMonitor`."""
        return self.estimator.health

    @monitor.setter
    def monitor(self, value):
        self.estimator.health = value

    def screening_counts(self) -> dict:
        """What the graph did with regressed beams so far: ``regressed_screening`` (gated, decorrelated out,
        inflated, continued: entered unscreened as the continuation of a run with ``regressed_runs="screen-first"``,
        and entered) and, with ``motion_prior="total-if-uncertain"``, ``motion_prior_switch`` (the outage prior's
        decisions); also in :attr:`info`."""
        out = {"regressed_screening": dict(self.ctx.screening)}
        if self.ctx.rehearsal is not None:
            out["outage_rehearsal"] = dict(self.ctx.rehearsal.counts)
        if self.ctx.graph_error is not None:
            out["measured_both"] = dict(self.ctx.graph_error.counts)
        if self.ctx.options.motion_prior == "total-if-uncertain":
            out["motion_prior_switch"] = dict(self.ctx.outage_switch.counts)
        return out

    def dvl_errors(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """The DVL error states ``D(index)`` of a keyframe still in the smoother: estimate (7,) [scale per DVL
        axis, bias per beam m/s] and marginal covariance (7,7). ConfigError without ``dvl_error_states``."""
        if not self.ctx.options.dvl_error_states:
            raise ConfigError(f"{self.name}: no DVL error states (GraphOptions.dvl_error_states is off)")
        return self.estimator.dvl_error_state(index)

    def keyframe_graphs(self) -> list:
        """Every keyframe's factors so far, one (link factors, :class:`~.graph.builder.KeyframeFactors`) per
        keyframe, for :func:`graphnav.estimators.graph.batch.batch_smooth`. ConfigError when the backend was
        made without ``keep_keyframe_graphs`` (it then keeps none)."""
        if not self.estimator.keep_keyframe_graphs:
            raise ConfigError(f"{self.name}: the keyframe factors were not kept (make the backend with "
                              "keep_keyframe_graphs=True for a batch smoother)")
        return self.estimator.keyframe_graphs

    @property
    def info(self) -> dict:
        e = self.estimator
        return {"mode": self.mode, "update_s": list(e.update_times), "recovered": e.n_recovered,
                "reanchored": e.n_reanchored, "completions_retired": e.n_completions_retired,
                "health": e.health.summary(), **self.screening_counts()}


def split_specific_force(imu: ImuSegments) -> np.ndarray:
    """Specific force of each segment in the body axes at the segment's start, m/s^2: a segment that starts
    ``lag`` s into its sample sees the body already rotated by ``D = Exp(omega lag)``, so the sample is
    expressed as ``D^T f`` (then a split propagation equals the unsplit one; see
    :func:`graphnav.estimators.ins.segment_specific_force`)."""
    f = imu.f_b.copy()
    split = np.flatnonzero(imu.lag > 0)
    if split.size:
        D = so3_exp_batch(imu.omega_b[split] * imu.lag[split, None])
        f[split] = np.einsum("nji,nj->ni", D, f[split])
    return f


class EkfBackend(_Aided):
    """Error-state EKF backend (the paper's filter; see :mod:`graphnav.estimators.ekf`).

    Per keyframe: predict over its IMU segments (covariance inflated over bridged IMU gaps), then update with
    the ping as it is (:meth:`~graphnav.estimators.ekf.ErrorStateEkf.update_ping`: ``tight``, one row per beam,
    else least squares from >= 3 beams; regressed beams add their completer sigma^2; a DVL-frame velocity ping
    the same for TC and LC) at the gyro rate interpolated at the ping, and with a heading measurement. The 15-state
    filter (``EkfOptions.position_states``, the default) also updates with the keyframe's depth (the graph's
    measurement: the pressure depth turned into the navigation frame's down by
    :func:`~graphnav.estimators.graph.builder.tangent_down`, sigma ``EkfOptions.depth_sigma`` or
    ``config.depth_noise_std``) and with a position fix at the fix's sigma. The paper's 12-state filter
    integrates position from velocity without a position error state, ignores depth, and a position fix resets
    the horizontal position. Fixes are counted in ``info["n_fixes"]``, depth and fix updates in
    ``info["aiding"]``.

    Args:
        config: sensor configuration.
        options: EKF tuning.
        tight: tightly (TC) or loosely (LC) coupled beam updates.
        initial: state at the first keyframe; its covariances, when given, replace the options' initial sigmas.
    """

    def __init__(self, config: SensorConfig, options: EkfOptions | None, tight: bool, initial: InitialState,
                 name: str = "EKF"):
        options = options or EkfOptions()
        C = initial.pose.rotation().matrix()
        priors = options.priors
        if initial.cov_pose is not None:       # body-frame rotation tangent -> NED misalignment (diagonal)
            cov_eps = C @ np.asarray(initial.cov_pose)[:3, :3] @ C.T
            priors = dataclasses.replace(priors, attitude_sigma=np.sqrt(np.diag(cov_eps)))
        if initial.cov_v_n is not None:
            priors = dataclasses.replace(priors, velocity_sigma=float(np.sqrt(np.max(np.diag(initial.cov_v_n)))))
        if initial.cov_pose is not None and options.position_states:   # body-frame translation -> NED
            cov_p = C @ np.asarray(initial.cov_pose)[3:, 3:] @ C.T
            priors = dataclasses.replace(priors, position_sigma=np.sqrt(np.diag(cov_p)))
        if priors is not options.priors:
            options = dataclasses.replace(options, priors=priors)
        state = StrapdownState(float(initial.t), C, np.asarray(initial.v_n, float).copy(),
                               np.asarray(initial.pose.translation(), float).copy())
        self.ekf = ErrorStateEkf(config, state, options, initial.bias.accelerometer(), initial.bias.gyroscope(),
                                 name=name)
        if initial.cov_joint is not None:
            self.ekf.set_joint_prior(initial.cov_joint, initial.dvl_errors)
        self.tight = tight
        self.name = name
        self.last_aided = False
        self.origin_lla = initial.origin_lla
        self.n_regressed_pings = 0
        self.n_imu_segments = 0
        self.n_imu_gaps = 0
        self.n_fix_origin = 0
        self.update_times: list[float] = []
        self._earth = EarthModel.from_config(config)

    def process(self, kf: Keyframe) -> EpochEstimate:
        start = time.perf_counter()
        ekf = self.ekf
        if kf.imu is not None and len(kf.imu.dt):
            ekf.predict(split_specific_force(kf.imu), kf.imu.omega_b, kf.imu.dt)
            self.n_imu_segments += len(kf.imu.dt)
            if kf.imu.var_v or kf.imu.var_att:
                ekf.inflate(kf.imu.var_v, kf.imu.var_att)
                self.n_imu_gaps += 1
        ping = kf.ping
        #: a DVL update with a measured beam (or velocity) entered at this keyframe (not gated; LC: >= 3 beams),
        #: for the Navigator's coasting check; beams regressed at a ping without any measured one are no DVL aiding
        self.last_aided = self.last_completed = False
        if ping is not None:
            self.n_regressed_pings += ping.has_regressed
            screened_in = ekf.regressed_screening["entered"]
            entered = ekf.update_ping(ping, self.tight)
            self.last_aided = entered and (ping.is_velocity or ping.n_measured > 0)
            self.last_completed = entered and ekf.regressed_screening["entered"] > screened_in
        if kf.heading is not None:
            self._update_heading(*kf.heading)
        if ekf.position_states:
            self._update_position(kf)
        elif kf.fix is not None:                   # the paper's filter: the fix replaces the position
            ekf.state.p_n[:2] = self.fix_ne(kf, ekf.state.p_n)
        s = ekf.state
        elapsed = time.perf_counter() - start
        self.update_times.append(elapsed)
        covs = ekf.nav_covariances()
        return EpochEstimate(kf.index, kf.t, kf.kind, gtsam.Pose3(gtsam.Rot3(s.C_b_n), s.p_n), s.v_n.copy(),
                             gtsam.imuBias.ConstantBias(ekf.bias_acc, ekf.bias_gyro), covs["cov_v_n"],
                             0 if ping is None else (3 if ping.is_velocity else ping.n_measured),
                             0 if ping is None else ping.n_regressed,
                             elapsed, cov_p_n=covs["cov_p_n"], cov_rot_b=covs["cov_rot_b"],
                             cov_bias=covs["cov_bias"])

    def _update_position(self, kf: Keyframe) -> None:
        """Depth and position-fix updates of the 15-state filter. A fix that places the navigation origin (no
        origin from the initial state) equals the estimate by construction and carries no information: no
        update (counted in ``info["n_fix_origin"]``)."""
        ekf = self.ekf
        if kf.depth is not None and ekf.options.use_depth:
            ekf.update_depth(tangent_down(self._earth, kf.depth, ekf.state.p_n))
        if kf.fix is not None:
            places_origin = self.origin_lla is None
            p_ne = self.fix_ne(kf, ekf.state.p_n, ekf.nav_covariances()["cov_p_n"])
            if places_origin:
                self.n_fix_origin += 1
            else:
                ekf.update_position_ne(p_ne, kf.fix.sigma_m)

    def _update_heading(self, yaw: float, sigma: float) -> None:
        """Yaw update: ``dz = yaw(C_hat) - yaw_meas``; with ``C = Exp(-eps) C_hat`` the row on the NED
        misalignment is ``d yaw / d eps = C_hat J`` (J the right-perturbation yaw Jacobian)."""
        ekf = self.ekf
        C = ekf.state.C_b_n
        yaw_hat, J = yaw_and_jacobian(C)
        H = np.zeros((1, ekf.n_states))
        # C_true = Exp(-eps) C_hat = C_hat Exp(-C_hat^T eps): right perturbation d = -C_hat^T eps, and
        # dz = h(x_hat) - y = -(J . d) = J C_hat^T eps
        H[0, IE] = J @ C.T
        dz = np.array([np.remainder(yaw_hat - yaw + np.pi, 2 * np.pi) - np.pi])
        ekf._update(dz, H, np.array([[sigma ** 2]]))

    @property
    def monitor(self):
        """The estimator's :class:`~graphnav.estimators.health.NisMonitor`."""
        return self.ekf.health

    @monitor.setter
    def monitor(self, value):
        self.ekf.health = value

    @property
    def info(self) -> dict:
        e = self.ekf
        return {"n_updates": e.n_updates, "n_gated": e.n_gated, "n_regressed_pings": self.n_regressed_pings,
                "n_velocity_updates": e.n_velocity_updates, "states": e.n_states,
                "n_fix_origin": self.n_fix_origin, "aiding": {k: dict(v) for k, v in e.aiding.items()},
                "dvl_scale": e.dvl_scale.copy(), "beam_bias": e.beam_bias.copy(),
                "n_imu_segments": self.n_imu_segments, "update_s": list(self.update_times),
                "regressed_screening": dict(e.regressed_screening), "health": e.health.summary()}


def make_backend(name: str, config: SensorConfig, initial: InitialState, *, graph_options: GraphOptions | None = None,
                 ekf_options: EkfOptions | None = None, tight: bool = True, keep_keyframe_graphs: bool = False,
                 label: str | None = None):
    """The backend called ``name`` (one of :data:`BACKENDS`) started at ``initial`` (``keep_keyframe_graphs``:
    a graph backend keeps every keyframe's factors for a batch smoother; ``label`` names the estimator in its
    health warnings)."""
    if name == "ekf":
        return EkfBackend(config, ekf_options, tight, initial, name=label or f"EKF {'TC' if tight else 'LC'}")
    if name in ("fixed-lag", "isam2", "dead-reckoning"):
        return GraphBackend(config, graph_options, name, initial, name=label or f"graph {name}",
                            keep_keyframe_graphs=keep_keyframe_graphs)
    raise ConfigError(f"unknown backend '{name}'; choose one of {', '.join(BACKENDS)}")
