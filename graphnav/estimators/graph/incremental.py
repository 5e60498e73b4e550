"""Incremental graph estimators: ISAM2 over the whole mission (online) and GTSAM's fixed-lag smoother.

Both follow the same cycle per keyframe: ``add(keyframe)`` (factors + predicted initial values),
``update()`` (one solver step) and ``estimate()`` (the filtered state of the newest keyframe with the
marginal covariances ``GraphOptions.marginals`` asks for: velocity in NED; position in NED, attitude and
biases with ``"full"``). Like GTSAM's ``ImuFactorExample``::

    est = OnlineGraph(GraphContext(config, options), initial)
    for kf in keyframes:          # graph keyframes (graphnav.estimators.graph.builder.graph_keyframe)
        est.add(kf)
        est.update()
        print(est.estimate())

:class:`graphnav.estimators.navigator.Navigator` runs this cycle on keyframes it assembles from streamed samples.
"""
from __future__ import annotations

import time
import warnings
import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, D, V, X

from graphnav.core.beam_model import BeamModel
from graphnav.core.errors import ConfigError
from graphnav.estimators.graph import dvl_errors
from graphnav.estimators.graph.builder import (
    GraphContext,
    GraphKeyframe,
    KeyframeFactors,
    imu_factor,
    keyframe_factors,
)
from graphnav.estimators.graph.marginals import keyframe_marginals
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.health import LostTrack, NisMonitor
from graphnav.estimators.types import EpochEstimate, InitialState
from graphnav.factors import N_DVL_ERRORS


def is_indeterminant(exc: Exception) -> bool:
    """True for GTSAM's indeterminant-linear-system error ("Indeterminant" in the class, "Indeterminate" in
    the message)."""
    return "ndetermina" in str(exc)


def prior_factors(builder: GraphContext, initial: InitialState, k: int = 0,
                  dvl_errors_mean: np.ndarray | None = None) -> gtsam.NonlinearFactorGraph:
    """Priors on X(k), V(k), B(k): the initial state's covariances where given, else the sigmas of
    ``builder.options`` (bias: IMU spec turn-on sigmas); and on the DVL error states D(k) (mean
    ``dvl_errors_mean``, default zero) when they are enabled."""
    o, imu = builder.options, builder.config.imu
    acc, gyro = o.priors.bias_sigmas(imu)
    graph = gtsam.NonlinearFactorGraph()
    pose_noise = (gtsam.noiseModel.Gaussian.Covariance(np.asarray(initial.cov_pose, float))
                  if initial.cov_pose is not None else gtsam.noiseModel.Diagonal.Sigmas(
                      np.r_[np.full(3, o.priors.attitude_sigma_for("graph")), np.full(3, o.priors.position_sigma)]))
    vel_noise = (gtsam.noiseModel.Gaussian.Covariance(np.asarray(initial.cov_v_n, float))
                 if initial.cov_v_n is not None else gtsam.noiseModel.Isotropic.Sigma(3, o.priors.velocity_sigma))
    graph.add(gtsam.PriorFactorPose3(X(k), initial.pose, pose_noise))
    graph.add(gtsam.PriorFactorVector(V(k), initial.v_n, vel_noise))
    graph.add(gtsam.PriorFactorConstantBias(B(k), initial.bias, gtsam.noiseModel.Diagonal.Sigmas(
        np.r_[np.full(3, acc), np.full(3, gyro)])))
    if initial.cov_joint is not None:
        return _joint_initial_prior(graph, builder, initial, k, pose_noise.covariance()[3:, 3:], acc, gyro)
    if o.dvl_error_states:
        mean = np.zeros(N_DVL_ERRORS) if dvl_errors_mean is None else dvl_errors_mean
        graph.add(dvl_errors.prior_factor(k, mean, dvl_errors.prior_sigmas(builder.config, o)))
    return graph


def _joint_initial_prior(graph, builder: GraphContext, initial: InitialState, k: int, cov_trans: np.ndarray,
                         acc: float, gyro: float) -> gtsam.NonlinearFactorGraph:
    """``graph`` with its priors on X(k), V(k), B(k) replaced by one joint prior holding ``initial.cov_joint``'s
    cross-terms (attitude, velocity, accelerometer bias and, with ``dvl_error_states``, D(k) at
    ``initial.dvl_errors``); the position (``cov_trans``, body, m^2) and the gyro bias (``gyro``, rad/s) stay
    independent."""
    with_d = builder.options.dvl_error_states
    joint = np.asarray(initial.cov_joint, float)
    # [pose (rot, trans), v, bias (acc, gyro), D]: where the joint's [rot, v, acc, D] sit
    at = np.r_[0:3, 6:9, 9:12, 15:15 + N_DVL_ERRORS][:9 + N_DVL_ERRORS * with_d]
    cov = np.zeros((15 + N_DVL_ERRORS * with_d,) * 2)
    cov[np.ix_(at, at)] = joint[:len(at), :len(at)]
    cov[3:6, 3:6] = cov_trans
    cov[12:15, 12:15] = np.eye(3) * gyro ** 2
    info = np.linalg.inv(cov)
    R = np.linalg.cholesky(0.5 * (info + info.T)).T
    keys = [X(k), V(k), B(k)] + ([D(k)] if with_d else [])
    d = initial_dvl_errors(initial) if with_d else None
    out = gtsam.NonlinearFactorGraph()
    out.add(joint_prior_factor(keys, initial.pose, initial.v_n, initial.bias, d, R))
    return out


def initial_dvl_errors(initial: InitialState) -> np.ndarray:
    """(7,) the DVL error states' start: ``initial.dvl_errors``, else zero."""
    return np.zeros(N_DVL_ERRORS) if initial.dvl_errors is None else np.asarray(initial.dvl_errors, float)


def joint_prior_factor(keys, pose: gtsam.Pose3, v_n, bias: gtsam.imuBias.ConstantBias, d, R: np.ndarray):
    """One linear prior ``R [local(pose), v - v_n, local(bias), D - d]`` on the keys X, V, B (and D when ``d``
    (7,) is given), R^T R the joint information over those tangents (Jacobians R's blocks, as
    LinearContainerFactor's): a CustomFactor, as GTSAM's Python JacobianFactor takes at most three keys."""
    v = np.asarray(v_n, float)
    edges = np.cumsum([0, 6, 3, 6] + ([len(d)] if d is not None else []))
    blocks = [slice(a, b) for a, b in zip(edges[:-1], edges[1:])]

    def error(this, values, H):
        dx = [pose.localCoordinates(values.atPose3(keys[0])), values.atVector(keys[1]) - v,
              bias.localCoordinates(values.atConstantBias(keys[2]))]
        if d is not None:
            dx.append(values.atVector(keys[3]) - d)
        if H is not None:
            for i, sl in enumerate(blocks):
                H[i] = R[:, sl]
        return R @ np.concatenate(dx)

    return gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(R.shape[0]), gtsam.KeyVector(keys), error)


def isam2_params(options: GraphOptions, factorization: str | None = None) -> gtsam.ISAM2Params:
    """ISAM2 settings: factorisation, per-variable-type relinearisation thresholds, relinearise skip."""
    params = gtsam.ISAM2Params()
    params.setFactorization(factorization or options.factorization)
    params.relinearizeSkip = options.relinearize_skip
    thresholds = gtsam.ISAM2ThresholdMap()
    thresholds.insert(("x", np.r_[np.full(3, options.relin_rot), np.full(3, options.relin_pos)]))
    thresholds.insert(("v", np.full(3, options.relin_vel)))
    thresholds.insert(("b", np.r_[np.full(3, options.relin_bias_acc), np.full(3, options.relin_bias_gyro)]))
    thresholds.insert(("d", np.r_[np.full(3, options.relin_dvl_scale), np.full(4, options.relin_dvl_bias)]))
    params.setRelinearizeThreshold(thresholds)
    params.setOptimizationParams(gtsam.ISAM2GaussNewtonParams(options.wildfire_threshold))
    return params


class _IncrementalGraph:
    """Shared add/update/estimate logic; subclasses provide the solver calls.

    ``reanchors`` (class attribute): the solver is restarted from the last estimate every
    ``options.reanchor_interval_s`` (:meth:`_restart_from_last`), to keep its cost bounded.

    Health (:attr:`health`, a :class:`graphnav.estimators.health.NisMonitor`): each keyframe with measured beams is
    checked *before* its update, as a filter's innovation test: the innovation ``y - h(x_pred)`` of its
    measured (not regressed) beams at the IMU-predicted state of keyframe k, against
    ``S = H P_v H^T + R`` with ``H = B C_pred^T`` (beam rows B), ``P_v`` the predicted velocity covariance
    in NED (the marginal of V(k-1) plus the preintegrated velocity covariance rotated to NED) and R the
    beam noise. Why the innovation rather than the whitened residuals after the update: after the update
    the graph has already pulled the state onto the measurements (the residuals are small and their
    distribution depends on the update's gain), so a graph that has lost track would still look healthy;
    the innovation shows the disagreement between what the IMU chain predicts and what the DVL sees, which
    is what divergence is. The attitude and bias uncertainty are left out of S (at AUV speeds a 0.1 deg
    misalignment moves a beam by ~3 mm/s against a 40 mm/s beam sigma), and without marginals
    (``options.marginals="none"``, e.g. the batch's first pass) P_v(k-1) is taken as zero: S is then a lower
    bound and the NIS an upper bound (conservative for the divergence test).
    """

    def __init__(self, builder: GraphContext, initial: InitialState, keep_keyframe_graphs: bool = False):
        self.builder = builder
        self.options = builder.options
        self.initial = initial
        self._pending_factors = gtsam.NonlinearFactorGraph()
        self._pending_values = gtsam.Values()
        self._pending_kf: GraphKeyframe | None = None
        self._pending_local: KeyframeFactors | None = None      # the queued keyframe's DVL groups and factors
        self._last: EpochEstimate | None = None
        # per keyframe (link to the past: priors or IMU factor, own DVL/depth factors); the batch reuses them
        self.keyframe_graphs: list[tuple[gtsam.NonlinearFactorGraph, KeyframeFactors]] = []
        self.keep_keyframe_graphs = keep_keyframe_graphs
        self.update_times: list[float] = []
        self.n_recovered = 0
        self.n_reanchored = 0
        self._recovering_at: int | None = None     # keyframe of the last solver restart (a second one raises)
        self._t_anchor: float | None = None        # first keyframe of the current solver
        self.factorization = self.options.factorization
        self.health = NisMonitor("graph", self.options.health)
        #: (keyframe index, value) of the newest DVL error-state estimate (``options.dvl_error_states``)
        self.dvl_errors: tuple[int, np.ndarray] | None = None
        # ``options.retire_completions``: (keyframe time s, solver's index) of the regressed beams' factors since the last
        # return of the beams, and the positions of the queued keyframe's among its factors
        self._completions: list[tuple[float, int]] = []
        self._pending_completions: list[int] = []
        #: factors made from regressed beams entered with the keyframe added last (past the screening)
        self.completions_entered = False
        # the fixed-lag smoother's (index, time s) of the keyframes since the first of them that took a regressed
        # beam's factor, while their factors wait to be taken out: it holds them (:meth:`FixedLagGraph._track_hold`)
        self._held: list[tuple[int, float]] = []
        #: regressed beams taken out of the graph when the beams returned (``options.retire_completions``)
        self.n_completions_retired = 0

    # --- the cycle --------------------------------------------------------------------------------
    def add(self, kf: GraphKeyframe) -> None:
        """Queue the factors of keyframe ``kf`` and its predicted initial values (from the last estimate)."""
        k = kf.index
        if k == 0:
            pose, v_n, bias = self.initial.pose, np.asarray(self.initial.v_n, float), self.initial.bias
            link = prior_factors(self.builder, self.initial)
        else:
            if self._last is None or self._last.index != k - 1:
                raise ConfigError(f"keyframe {k} added before keyframe {k - 1} was updated")
            last = self._last
            self.builder.set_gravity(kf, last.pose.translation(), last.v_n)
            nav = kf.pim.predict(gtsam.NavState(last.pose, last.v_n), last.bias)
            pose, v_n, bias = nav.pose(), nav.velocity(), last.bias
            link = gtsam.NonlinearFactorGraph()
            link.add(imu_factor(kf))
        if self.options.dvl_error_states:
            if k == 0:
                d = initial_dvl_errors(self.initial)
            else:
                d = self._value(D(k - 1), "Vector")
                self.dvl_errors = (k - 1, d)
                last.dvl_errors = d
                link.add(dvl_errors.random_walk_factor(k, kf.t - self._last.t, self.options))
        local = keyframe_factors(kf, self.builder, pose.rotation().matrix(), pose.translation(),
                                 self._prediction(kf, v_n, bias))
        self._check_innovation(kf, local, pose, v_n, bias)
        if self.keep_keyframe_graphs:
            self.keyframe_graphs.append((link, local))
        self._pending_completions = [link.size() + i for i in local.completion_positions()]
        self.completions_entered = bool(self._pending_completions)
        self._pending_factors.push_back(link)
        self._pending_factors.push_back(local.graph())
        self._pending_values.insert(X(k), pose)
        self._pending_values.insert(V(k), v_n)
        self._pending_values.insert(B(k), bias)
        if self.options.dvl_error_states:
            self._pending_values.insert(D(k), d)
        self._pending_kf = kf
        self._pending_local = local

    def _prediction(self, kf: GraphKeyframe, v_n_pred, bias):
        """The graph's predicted velocity and covariance at kf, when its regressed beams are to be screened or
        ``motion_prior="total-if-uncertain"`` must choose at a keyframe without measured beams."""
        o = self.options
        needed = (o.screening.active and kf.n_regressed
                  or o.motion_prior == "total-if-uncertain" and not kf.n_measured)
        if not needed or kf.index == 0:
            return None
        return self.predicted_state(kf, v_n_pred, bias)

    def predicted_state(self, kf: GraphKeyframe, v_n_pred, bias):
        """The :class:`.regressed.VelocityPrediction` at kf (index >= 1) from the last estimate: its marginal velocity
        covariance plus the preintegrated velocity noise, the predicted velocity ``v_n_pred`` (NED, m/s) and the gyro
        bias of ``bias``."""
        from graphnav.estimators.graph.regressed import predict_state
        last = self._last
        cov = last.cov_v_n if last.cov_v_n is not None else self._marginal(V(last.index))
        return predict_state(cov, last.C_b_n, kf.pim, v_n_pred, bias.gyroscope())

    def update(self) -> EpochEstimate:
        """One solver step with the queued keyframe; returns (and stores) its estimate."""
        kf = self._pending_kf
        if kf is None:
            raise ConfigError("update() called without a new keyframe")
        start = time.perf_counter()
        try:
            if self._reanchor_due(kf):
                self.n_reanchored += 1
                new = self._restart_from_last(kf)
            else:
                retired, beams = self._retired(kf)
                new = self._solve(self._pending_factors, self._pending_values, kf, remove=retired)
                # counted once the solver has taken them out (a failed update restarts with them in its prior)
                self.n_completions_retired += beams
        except RuntimeError as exc:
            if not is_indeterminant(exc):
                raise
            new = self._recover(kf, exc)
        if new is not None and self.options.retire_completions:
            self._completions += [(kf.t, new[i]) for i in self._pending_completions]
            self._track_hold(kf)
        k = kf.index
        pose, v_n, bias = self._value(X(k), "Pose3"), self._value(V(k), "Vector"), self._value(B(k), "ConstantBias")
        covs = keyframe_marginals(self.options.marginals, k, pose, self._marginal)
        elapsed = time.perf_counter() - start
        self.update_times.append(elapsed)
        self._last = EpochEstimate(k, kf.t, kf.kind, pose, v_n, bias, covs.get("cov_v_n"),
                                   kf.n_measured, kf.n_regressed, elapsed,
                                   cov_p_n=covs.get("cov_p_n"), cov_rot_b=covs.get("cov_rot_b"),
                                   cov_bias=covs.get("cov_bias"))
        if self.builder.rehearsal is not None:
            self.builder.rehearsal.graph_keyframe(kf, self._last)
        self._pending_factors = gtsam.NonlinearFactorGraph()
        self._pending_values = gtsam.Values()
        self._pending_kf = None
        return self._last

    def _retired(self, kf: GraphKeyframe) -> tuple[list[int], int]:
        """(the solver's indices of the regressed beams' factors to take out at keyframe ``kf``, their beams): with
        ``options.retire_completions``, all those still in the solver once a ping's measured beams alone give the
        velocity (3 or more rows); else none."""
        if not (self.options.retire_completions and self._completions and kf.n_measured >= 3):
            return [], 0
        graph = self._graph()
        # the fixed-lag smoother has already marginalised those it held no longer (options.retire_hold_s)
        retired = [i for _, i in self._completions if graph.exists(i)]
        self._completions, self._held = [], []
        return retired, sum(graph.at(i).dim() for i in retired)     # a row per regressed beam

    def _check_innovation(self, kf: GraphKeyframe, local, pose, v_n, bias) -> None:
        """NIS of keyframe kf's measured beams at the predicted state (see the class docstring)."""
        groups = [g for g in local.groups if not g.regressed]
        if not groups:
            return
        C = pose.rotation().matrix()
        if kf.index == 0:
            P_v = (np.asarray(self.initial.cov_v_n, float) if self.initial.cov_v_n is not None
                   else np.eye(3) * self.options.priors.velocity_sigma ** 2)
        else:
            last = self._last
            C_prev = last.pose.rotation().matrix()
            P_v = C_prev @ kf.pim.preintMeasCov()[6:9, 6:9] @ C_prev.T   # GTSAM order [rot, pos, vel, ...]
            if last.cov_v_n is not None:
                P_v = P_v + last.cov_v_n
        predicted = [BeamModel(g.rows_b).predict(C, v_n, g.omega_b, bias.gyroscope(), g.lever_arm_b) for g in groups]
        dz = np.concatenate([g.y - p.h for g, p in zip(groups, predicted)])
        H = np.vstack([p.d_v() for p in predicted])
        S = H @ P_v @ H.T + np.diag(np.concatenate([g.sigma for g in groups]) ** 2)
        if not (np.all(np.isfinite(dz)) and np.all(np.isfinite(S))):
            raise LostTrack(kf.t, f"the DVL innovation at the predicted state is not finite (predicted velocity "
                            f"{np.linalg.norm(v_n):.3g} m/s)")
        try:
            nis = float(dz @ np.linalg.solve(S, dz))
        except np.linalg.LinAlgError as exc:
            raise LostTrack(kf.t, f"the DVL innovation covariance cannot be inverted ({exc}; predicted velocity "
                            f"{np.linalg.norm(v_n):.3g} m/s)") from exc
        self.health.record(kf.t, nis, len(dz))

    def estimate(self) -> EpochEstimate:
        """The estimate of the newest updated keyframe."""
        if self._last is None:
            raise ConfigError("no keyframe has been updated yet")
        return self._last

    @property
    def latest(self) -> EpochEstimate | None:
        """The estimate of the newest updated keyframe, None before the first update."""
        return self._last

    def dvl_error_state(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """The DVL error states ``D(index)`` of a keyframe still in the solver: estimate (7,) [scale per DVL axis,
        bias per beam m/s] and marginal covariance (7,7)."""
        return (np.asarray(self._value(D(index), "Vector"), float), np.asarray(self._marginal(D(index)), float))

    def _recover(self, kf: GraphKeyframe, exc: Exception) -> list[int] | None:
        """Indeterminant linear system: restart the solver (with QR factorisation) from the last good state
        (:meth:`_restart_from_last`, whose return this is). A second failure at the same keyframe raises."""
        self.n_recovered += 1
        warnings.warn(f"graph: indeterminant linear system at keyframe {kf.index} (t={kf.t:.2f} s): "
                      f"{str(exc).strip().splitlines()[0]} -- restarting the solver with QR factorisation from "
                      "the last estimate",
                      RuntimeWarning, stacklevel=3)
        if self._last is None or self._recovering_at == kf.index:
            raise exc
        self._recovering_at = kf.index
        self.factorization = "QR"
        return self._restart_from_last(kf)

    def _restart_from_last(self, kf: GraphKeyframe) -> list[int] | None:
        """A new solver that starts with priors on keyframe k-1 at its estimate, with its marginal covariances
        (block-diagonal: pose, velocity, bias, DVL errors; the prior sigmas of the options if the old solver
        cannot give them), then takes keyframe k's factors. The filtered output continues; what is lost is
        the cross-correlation between those blocks at the restart, and the factors of regressed beams before it
        can no longer be taken out (``options.retire_completions``). Returns the new solver's indices of keyframe
        k's factors (None without a solver)."""
        last = self._last
        j = last.index
        with_d = self.options.dvl_error_states
        # the DVL error states of keyframe j were read when keyframe k = j + 1 was added
        d_j = self.dvl_errors[1] if with_d and self.dvl_errors is not None and self.dvl_errors[0] == j else None
        try:
            covs = [self._marginal(X(j)), self._marginal(V(j)), self._marginal(B(j))]
            if with_d:
                covs.append(self._marginal(D(j)))
        except (RuntimeError, IndexError):      # a failed solver may have dropped its Bayes tree
            covs = None
        if with_d and d_j is None:
            d_j = np.zeros(N_DVL_ERRORS)
        joint = None if self.factorization != self.options.factorization else self._joint_prior(last, d_j)
        self._restart()
        self._t_anchor = last.t
        restart_state = InitialState(last.pose, last.v_n, last.bias)
        graph = prior_factors(self.builder, restart_state, j, d_j)
        if joint is not None:
            graph = joint
        elif covs is not None:
            graph = gtsam.NonlinearFactorGraph()
            graph.add(gtsam.PriorFactorPose3(X(j), last.pose, gtsam.noiseModel.Gaussian.Covariance(covs[0])))
            graph.add(gtsam.PriorFactorVector(V(j), last.v_n, gtsam.noiseModel.Gaussian.Covariance(covs[1])))
            graph.add(gtsam.PriorFactorConstantBias(B(j), last.bias, gtsam.noiseModel.Gaussian.Covariance(covs[2])))
            if with_d:
                graph.add(dvl_errors.prior_factor(j, d_j, covs[3]))
        graph.push_back(self._pending_factors)
        values = gtsam.Values(self._pending_values)
        values.insert(X(j), last.pose)
        values.insert(V(j), last.v_n)
        values.insert(B(j), last.bias)
        if with_d:
            values.insert(D(j), d_j)
        self._completions, self._held = [], []
        new = self._solve(graph, values, kf, first_key=j)
        return None if new is None else new[graph.size() - self._pending_factors.size():]

    def _joint_prior(self, last: EpochEstimate, d_j: np.ndarray | None = None) -> gtsam.NonlinearFactorGraph | None:
        """The joint marginal of (pose, velocity, bias and, with ``dvl_error_states``, the DVL error states
        ``d_j``) at the last keyframe as one linear prior (GTSAM's Marginals over the solver's current graph;
        R^T R = the joint information, at the estimate as linearisation point), or None when the solver cannot
        give it. Four keys are more than GTSAM's Python JacobianFactor takes, so with the DVL error states
        the prior is a CustomFactor ``R [local(pose), v, local(bias), d]`` (Jacobians R's blocks, as
        LinearContainerFactor's)."""
        j = last.index
        with_d = self.options.dvl_error_states and d_j is not None
        keys = [X(j), V(j), B(j)] + ([D(j)] if with_d else [])
        try:
            marginals = gtsam.Marginals(self._graph(), self._estimates())
            joint = marginals.jointMarginalCovariance(gtsam.KeyVector(keys))
            cov = np.block([[joint.at(a, b) for b in keys] for a in keys])
            info = np.linalg.inv(cov)
            R = np.linalg.cholesky(0.5 * (info + info.T)).T
        except (RuntimeError, np.linalg.LinAlgError, AttributeError):
            return None
        if with_d:
            graph = gtsam.NonlinearFactorGraph()
            graph.add(joint_prior_factor(keys, last.pose, last.v_n, last.bias, np.asarray(d_j, float), R))
            return graph
        factor = gtsam.JacobianFactor(X(j), R[:, :6], V(j), R[:, 6:9], B(j), R[:, 9:15], np.zeros(15),
                                      gtsam.noiseModel.Unit.Create(15))
        point = gtsam.Values()
        point.insert(X(j), last.pose)
        point.insert(V(j), last.v_n)
        point.insert(B(j), last.bias)
        graph = gtsam.NonlinearFactorGraph()
        graph.add(gtsam.LinearContainerFactor(factor, point))
        return graph

    def _track_hold(self, kf: GraphKeyframe) -> None:
        """After keyframe ``kf``'s update: what the solver must hold for the completions still to be taken out, and
        those it can no longer hold. Nothing here (ISAM2 keeps the whole mission); the fixed-lag smoother's
        (:class:`FixedLagGraph`), bounded by its hold and lag in a long outage."""

    def _state_keys(self, j: int) -> tuple[int, ...]:
        """The variables of keyframe ``j``."""
        return (X(j), V(j), B(j)) + ((D(j),) if self.options.dvl_error_states else ())

    def _reanchor_due(self, kf: GraphKeyframe) -> bool:
        interval = self.options.reanchor_interval_s
        if self._t_anchor is None:
            self._t_anchor = kf.t
        return (self.reanchors and interval is not None and self._last is not None
                and kf.t - self._t_anchor >= interval)

    # --- solver hooks -----------------------------------------------------------------------------
    def _solve(self, factors, values, kf, first_key=None, remove=()) -> list[int] | None:
        """One solver update with ``factors`` and the new ``values``, taking out the factors ``remove`` (the
        solver's indices); returns the solver's indices of ``factors`` (None without a solver)."""
        raise NotImplementedError

    def _graph(self) -> gtsam.NonlinearFactorGraph:
        raise NotImplementedError

    def _estimates(self) -> gtsam.Values:
        raise NotImplementedError

    def _restart(self):
        raise NotImplementedError

    def _value(self, key, kind):
        raise NotImplementedError

    def _marginal(self, key):
        raise NotImplementedError


class OnlineGraph(_IncrementalGraph):
    reanchors = False      # ISAM2 over the whole mission keeps the whole mission
    """ISAM2 over the whole mission, one update per keyframe (settings: :func:`isam2_params`).

    The estimate at each keyframe is the filtered state (all data up to that keyframe); the graph keeps
    every keyframe, so its cost grows with the mission (use :class:`FixedLagGraph` for long missions).
    """

    def __init__(self, builder: GraphContext, initial: InitialState, keep_keyframe_graphs: bool = False):
        super().__init__(builder, initial, keep_keyframe_graphs)
        self._times: list[float] = []
        self._restart()

    def _restart(self):
        self.isam = gtsam.ISAM2(isam2_params(self.options, self.factorization))
        # keyframes older than options.relin_window_s stay at their linearisation point: relinearising an
        # old state re-eliminates the whole chain from it to the newest state (cost grows with the mission)
        self._frozen = gtsam.KeyList()
        self._n_frozen = max(0, len(self._times) - 2)   # after a restart the oldest key is k-1

    def _solve(self, factors, values, kf, first_key=None, remove=()):
        if first_key is None:
            self._times.append(kf.t)
        window = self.options.relin_window_s
        if window is None:
            return list(self.isam.update(factors, values, list(remove)).getNewFactorsIndices())
        while self._n_frozen < len(self._times) - 1 and kf.t - self._times[self._n_frozen] > window:
            j = self._n_frozen
            for key in self._state_keys(j):
                self._frozen.push_back(key)
            self._n_frozen += 1
        return list(self.isam.update(factors, values, list(remove), None, self._frozen).getNewFactorsIndices())

    def _value(self, key, kind):
        return getattr(self.isam, f"calculateEstimate{kind}")(key)

    def _marginal(self, key):
        return self.isam.marginalCovariance(key)

    def _graph(self):
        return self.isam.getFactorsUnsafe()

    def _estimates(self):
        return self.isam.calculateEstimate()


class FixedLagGraph(_IncrementalGraph):
    """GTSAM's IncrementalFixedLagSmoother: keyframes older than ``options.lag_s`` are marginalised out,
    so the working graph, the time per update and the memory stay bounded on long missions.
    The estimate at each keyframe is the filtered state."""

    # GTSAM's IncrementalFixedLagSmoother slows down over hours (borglab/gtsam#1935: its occasional full
    # re-eliminations take longer and longer): measured update p99 5 ms in hour 1 and 18 ms in hour 21.
    # Restarting it from the last estimate's marginals keeps it flat (options.reanchor_interval_s).
    reanchors = True

    def __init__(self, builder: GraphContext, initial: InitialState, keep_keyframe_graphs: bool = False):
        super().__init__(builder, initial, keep_keyframe_graphs)
        self._restart()

    def _restart(self):
        self.smoother = gtsam.IncrementalFixedLagSmoother(self.options.lag_s,
                                                          isam2_params(self.options, self.factorization))

    def _track_hold(self, kf: GraphKeyframe) -> None:
        if self._held or self._pending_completions:
            self._held.append((kf.index, kf.t))
        # a keyframe stops being stamped anew retire_hold_s after it entered, and is marginalised lag_s later
        t, hold = kf.t, self.options.retire_hold_s
        self._held = [(j, t_j) for j, t_j in self._held if t - t_j <= hold]
        self._completions = [(t_c, i) for t_c, i in self._completions if t - t_c <= hold + self.options.lag_s]

    def _solve(self, factors, values, kf, first_key=None, remove=()):
        t_last = self._last.t if first_key is not None else kf.t
        stamps = {key: (t_last if gtsam.Symbol(key).index() == first_key else kf.t) for key in values.keys()}
        # the keyframes of completions still to be taken out (options.retire_completions) are stamped anew, so that
        # the smoother keeps them beyond its lag, for at most options.retire_hold_s
        if first_key is None:
            for j, _ in self._held:
                stamps.update({key: kf.t for key in self._state_keys(j)})
        self.smoother.update(factors, values, stamps, list(remove))
        return list(self.smoother.getISAM2Result().getNewFactorsIndices())

    def _value(self, key, kind):
        return getattr(self.smoother, f"calculateEstimate{kind}")(key)

    def _marginal(self, key):
        return self.smoother.marginalCovariance(key)

    def _graph(self):
        return self.smoother.getFactors()

    def _estimates(self):
        return self.smoother.calculateEstimate()

