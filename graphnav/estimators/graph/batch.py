"""Batch smoothing over the whole mission, started from the incremental (filtered) estimate.

Why not simply LM on the incremental graph: each ``gtsam.CustomFactor`` call inside the C++ optimisers
copies the whole ``Values`` (pybind11 casts the ``const Values&`` argument by value), so one
linearisation of an N-keyframe graph costs O(N^2) (probe: LM 393 s at 1 h). The default solver here,
``"vectorized"``, is Gauss-Newton where

- the C++ factors (priors, CombinedImuFactor, depth) and the whitened differences of a run of regressed beams
  (``GraphOptions.regressed_error_tau_s``; Python factors, so each costs a copy of the ``Values`` as above and
  a long regressed run makes a batch slower) are linearised by GTSAM, and
- all other DVL beam factors are linearised at once in numpy (the one beam model of
  :mod:`graphnav.core.beam_model`, as in :func:`graphnav.factors.dvl_factor`; Huber kernels by iteratively reweighted least squares, as GTSAM's
  robust noise model does) and added as ``JacobianFactor`` s,

then the linear system is solved by GTSAM's multifrontal elimination and the step retracted on the
manifold, until the cost stops decreasing (step halving if it rises). Cost per iteration is O(N).
``solver="lm"`` runs GTSAM's Levenberg-Marquardt on the CustomFactor graph itself (reference, O(N^2)).
The covariances (``GraphOptions.marginals``: velocity, or with ``"full"`` also position, attitude and biases)
are the marginals of the final linearisation. Elimination is Cholesky (GTSAM's default)
unless ``batch_factorization="QR"``; when Cholesky reports an indeterminant system, the batch warns and solves
again with QR.
"""
from __future__ import annotations

import time
import warnings

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, D, V, X

from graphnav.core.beam_model import N_DVL_ERRORS, BeamModel
from graphnav.core.errors import ConfigError
from graphnav.estimators.graph.builder import BeamGroup, KeyframeFactors
from graphnav.estimators.graph.incremental import is_indeterminant
from graphnav.estimators.graph.marginals import keyframe_marginals
from graphnav.estimators.graph.options import BATCH_SOLVERS, GraphOptions
from graphnav.estimators.types import EpochEstimate


class StackedBeams:
    """All DVL beam rows of a mission as arrays, for vectorised linearisation.

    Attributes (R rows): k (R,) keyframe index; rows (R,3); y, sigma, huber (R,) (NaN = no kernel);
    omega, lever (R,3); with DVL error states (``has_dvl_errors``): beam (R,) beam number 0..3 and C_d_b
    (3,3), and the columns d/ds (3) and d/db (4) of each row on ``D(k)``.
    """

    def __init__(self, groups: list[BeamGroup]):
        sizes = [len(g.y) for g in groups]
        with_d = [g for g in groups if g.beam_index is not None]
        self.has_dvl_errors = bool(with_d)
        self.C_d_b = with_d[0].C_d_b if with_d else np.eye(3)
        # rows without the DVL error states (e.g. regressed beams with dvl_errors_on_regressed=False) get s = b = 0
        self.uses_d = np.repeat([g.beam_index is not None for g in groups], sizes).astype(bool)
        self.beam = (np.concatenate([np.zeros(len(g.y), int) if g.beam_index is None else g.beam_index
                                     for g in groups]).astype(int) if groups else np.zeros(0, int))
        self.k = np.repeat([g.k for g in groups], sizes).astype(int)
        self.rows = np.concatenate([g.rows_b for g in groups]) if groups else np.zeros((0, 3))
        self.y = np.concatenate([g.y for g in groups]) if groups else np.zeros(0)
        self.sigma = np.concatenate([g.sigma for g in groups]) if groups else np.zeros(0)
        self.huber = np.repeat([np.nan if g.huber_k is None else g.huber_k for g in groups], sizes)
        self.omega = np.repeat([g.omega_b for g in groups], sizes, axis=0).reshape(-1, 3)
        self.lever = np.repeat([g.lever_arm_b for g in groups], sizes, axis=0).reshape(-1, 3)
        order = np.argsort(self.k, kind="stable")
        for name in ("k", "rows", "y", "sigma", "huber", "omega", "lever", "beam", "uses_d"):
            setattr(self, name, getattr(self, name)[order])
        self.model = BeamModel(self.rows, self.beam, self.C_d_b) if self.has_dvl_errors else BeamModel(self.rows)
        # one JacobianFactor per keyframe: row ranges
        self.keyframes, self.starts = np.unique(self.k, return_index=True)
        self.ends = np.append(self.starts[1:], len(self.k))

    def linearize(self, C_b_n: np.ndarray, v_n: np.ndarray, gyro_bias: np.ndarray,
                  dvl_errors: np.ndarray | None = None):
        """Residuals e (R,) and Jacobians (R,3) d/drot, d/dv, d/dgyro-bias at per-keyframe states (K,...),
        and (R,7) d/dD (None without DVL error states; ``dvl_errors`` (K,7) = [scale (3), beam bias (4)]).
        The model is :class:`graphnav.core.beam_model.BeamModel` with one state per row."""
        k = self.k
        # rows without the DVL error states see s = b = 0 and no D(k) columns
        d = None if not self.has_dvl_errors else dvl_errors[k] * self.uses_d[:, None]
        p = self.model.predict(C_b_n[k], v_n[k], self.omega, gyro_bias[k], self.lever, d)
        J_d = None if d is None else p.d_dvl_errors() * self.uses_d[:, None]
        return p.h - self.y, p.d_rot(), p.d_v(), p.d_gyro_bias(), J_d

    def weights(self, e: np.ndarray) -> np.ndarray:
        """Huber IRLS weights (1 where no kernel or inside the threshold)."""
        s = np.abs(e / self.sigma)
        w = np.ones_like(s)
        robust = np.isfinite(self.huber) & (s > self.huber)
        w[robust] = self.huber[robust] / s[robust]
        return w

    def cost(self, e: np.ndarray) -> float:
        """GTSAM-compatible cost: 0.5 s^2 (Gaussian) or the Huber loss, s = e / sigma."""
        s = np.abs(e / self.sigma)
        k = self.huber
        robust = np.isfinite(k) & (s > k)
        loss = 0.5 * s ** 2
        loss[robust] = k[robust] * s[robust] - 0.5 * k[robust] ** 2
        return float(loss.sum())

    def jacobian_factors(self, e, J_rot, J_v, J_bg, J_d=None) -> gtsam.GaussianFactorGraph:
        """Whitened, reweighted linear factors ``|A dx + e|`` per keyframe (with ``D(k)`` columns if J_d)."""
        scale = np.sqrt(self.weights(e)) / self.sigma
        A_rot, A_v, A_bg, b = J_rot * scale[:, None], J_v * scale[:, None], J_bg * scale[:, None], -e * scale
        zeros = np.zeros((len(e), 3))
        A_pose = np.hstack([A_rot, zeros])
        A_bias = np.hstack([zeros, A_bg])
        graph = gtsam.GaussianFactorGraph()
        A_d = None if J_d is None else J_d * scale[:, None]
        for k, a, z in zip(self.keyframes.tolist(), self.starts.tolist(), self.ends.tolist()):
            if A_d is None:
                graph.push_back(gtsam.JacobianFactor(X(k), A_pose[a:z], V(k), A_v[a:z], B(k), A_bias[a:z],
                                                     b[a:z], gtsam.noiseModel.Unit.Create(z - a)))
            else:
                graph.push_back(_jacobian_factor4([X(k), V(k), B(k), D(k)],
                                                  [A_pose[a:z], A_v[a:z], A_bias[a:z], A_d[a:z]], b[a:z]))
        return graph


def _jacobian_factor4(keys: list[int], blocks: list[np.ndarray], b: np.ndarray) -> gtsam.JacobianFactor:
    """``JacobianFactor`` ``|sum_j A_j dx_j - b|`` on four keys (X, V, B, D).

    gtsam's Python wrapper constructs JacobianFactors on at most three keys, so the precomputed (already
    whitened) blocks are handed through a ``CustomFactor`` that returns them, linearised on a Values holding
    only its own four variables (about 11 us; no copy of the mission's Values).
    """
    residual = -np.asarray(b)

    def error(_factor, _values, H):
        if H is not None:
            for j, block in enumerate(blocks):
                H[j] = block
        return residual

    small = gtsam.Values()
    small.insert(keys[0], gtsam.Pose3())
    small.insert(keys[1], np.zeros(3))
    small.insert(keys[2], gtsam.imuBias.ConstantBias())
    small.insert(keys[3], np.zeros(N_DVL_ERRORS))
    return gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(len(b)), keys, error).linearize(small)


def _states(values: gtsam.Values, n: int, with_d: bool = False):
    C = np.empty((n, 3, 3))
    v = np.empty((n, 3))
    bg = np.empty((n, 3))
    d = np.zeros((n, N_DVL_ERRORS)) if with_d else None
    for k in range(n):
        C[k] = values.atPose3(X(k)).rotation().matrix()
        v[k] = values.atVector(V(k))
        bg[k] = values.atConstantBias(B(k)).gyroscope()
        if with_d:
            d[k] = values.atVector(D(k))
    return C, v, bg, d


def batch_smooth(keyframe_graphs: list[tuple[gtsam.NonlinearFactorGraph, KeyframeFactors]],
                 estimates: list[EpochEstimate], options: GraphOptions) -> tuple[list[EpochEstimate], dict]:
    """Smooth the whole mission.

    Args:
        keyframe_graphs: per keyframe (link factors: priors or IMU factor, :class:`KeyframeFactors`), as kept
            by an incremental estimator with ``keep_keyframe_graphs=True``.
        estimates: the incremental pass's estimate at every keyframe (initial values).
        options: ``batch_solver``, ``batch_max_iterations``, ``marginals`` (the level of the smoothed
            estimates' covariances).

    Returns:
        (smoothed estimates per keyframe, info: iterations, cost history, timings, ``completions_retired``: the
        regressed beams left out with ``options.retire_completions``).
    """
    if options.batch_solver not in BATCH_SOLVERS:
        raise ConfigError(f"batch_solver must be one of {BATCH_SOLVERS}, got '{options.batch_solver}'")
    start = time.perf_counter()
    n = len(estimates)
    cpp = gtsam.NonlinearFactorGraph()
    groups: list[BeamGroup] = []
    values = gtsam.Values()
    # GraphOptions.retire_completions: an outage that a ping's measured beams end (3 or more rows) is bridged by
    # the IMU and the measured beams on both sides, as without a completer; the completions after the last such
    # ping (an outage the mission ends in) stay
    last_measured = max((e.index for e in estimates if e.n_measured >= 3), default=-1) \
        if options.retire_completions else -1
    retired = 0
    if len(keyframe_graphs) != len(estimates):
        raise ConfigError(f"batch: {len(keyframe_graphs)} keyframe graphs for {len(estimates)} estimates")
    for (link, local), e in zip(keyframe_graphs, estimates):
        if e.index < last_measured:
            local, beams = local.without_completions()
            retired += beams
        cpp.push_back(link)
        cpp.push_back(local.run_links)
        cpp.push_back(local.other)
        groups.extend(local.groups)
        values.insert(X(e.index), e.pose)
        values.insert(V(e.index), e.v_n)
        values.insert(B(e.index), e.bias)
    # DVL error states (GraphOptions.dvl_error_states) start at zero: the model is linear in them
    for key in cpp.keyVector():
        if gtsam.Symbol(key).chr() == ord("d") and not values.exists(key):
            values.insert(key, np.zeros(N_DVL_ERRORS))
    qr = options.batch_factorization == "QR"
    try:
        result, info, covs = _solve(cpp, groups, values, n, options, qr)
    except RuntimeError as exc:
        if qr or not is_indeterminant(exc):
            raise
        # Cholesky (GTSAM's default elimination) gives up on poorly conditioned systems that QR solves, e.g.
        # integration_sigma=1e-4, or one IMU factor holding a large rotation variance (tests/test_faults.py)
        warnings.warn(f"graph batch: {' '.join(str(exc).split())[:120]} -- solving again with QR elimination",
                      RuntimeWarning, stacklevel=2)
        result, info, covs = _solve(cpp, groups, values, n, options, True)
        info["qr_retry"] = True
    info["solve_s"] = time.perf_counter() - start
    info["completions_retired"] = retired
    with_d = result.exists(D(0))
    out = [EpochEstimate(e.index, e.t, e.kind, result.atPose3(X(e.index)), result.atVector(V(e.index)),
                         result.atConstantBias(B(e.index)), covs[e.index].get("cov_v_n"), e.n_measured,
                         e.n_regressed, float("nan"), result.atVector(D(e.index)) if with_d else None, e.health,
                         e.health_why, cov_p_n=covs[e.index].get("cov_p_n"),
                         cov_rot_b=covs[e.index].get("cov_rot_b"), cov_bias=covs[e.index].get("cov_bias"))
           for e in estimates]      # the health of the filtered pass at each keyframe
    if with_d:
        info["dvl_errors"] = np.array([o.dvl_errors for o in out])
    return out, info


def _solve(cpp, groups, values, n, options, qr: bool):
    """(result, info, per keyframe the covariances ``options.marginals`` asks for, a dict as
    :func:`~graphnav.estimators.graph.marginals.keyframe_marginals`'s) with the configured solver; ``qr`` selects
    QR elimination (else GTSAM's default, Cholesky) for the steps and the marginals."""
    if options.batch_solver == "lm":
        result, info, linear = _solve_lm(cpp, groups, values, options, qr)
    else:
        result, info, linear = _solve_vectorized(cpp, StackedBeams(groups), values, n, options, qr)
    covs = [{} for _ in range(n)]
    if options.marginals != "none":
        t0 = time.perf_counter()
        if qr:      # Marginals and marginalCovariance eliminate with Cholesky: take R of the QR marginal
            tree = linear.eliminateMultifrontal(None, gtsam.EliminateQR)

            def marginal(key):
                return _covariance(tree.marginalFactor(key, gtsam.EliminateQR))
        else:
            marginal = gtsam.Marginals(linear, result).marginalCovariance
        covs = [keyframe_marginals(options.marginals, k, result.atPose3(X(k)), marginal) for k in range(n)]
        info["marginals_s"] = time.perf_counter() - t0
    return result, info, covs


def _covariance(conditional: gtsam.GaussianConditional) -> np.ndarray:
    """Covariance (R^T Sigma^-2 R)^-1 of a marginal Gaussian conditional ``|| Sigma^-1 (R x - d) ||``."""
    R = conditional.R()
    model = conditional.get_model()
    if model is not None:
        R = R / np.asarray(model.sigmas())[:, None]
    R_inv = np.linalg.inv(R)
    return R_inv @ R_inv.T


def _solve_vectorized(cpp, beams: StackedBeams, values, n, options, qr: bool = False):
    def linearize(vals):
        linear = cpp.linearize(vals)
        linear.push_back(beams.jacobian_factors(*beams.linearize(*_states(vals, n, beams.has_dvl_errors))))
        return linear

    def cost(vals):
        return cpp.error(vals) + beams.cost(beams.linearize(*_states(vals, n, beams.has_dvl_errors))[0])

    costs = [cost(values)]
    iterations = 0
    for iterations in range(1, options.batch_max_iterations + 1):
        linear = linearize(values)
        delta = linear.optimize(gtsam.EliminateQR) if qr else linear.optimize()
        step = 1.0
        while True:
            candidate = values.retract(delta if step == 1.0 else delta.scale(step))
            new_cost = cost(candidate)
            if new_cost <= costs[-1] or step < 1e-3:
                break
            step *= 0.5
        if new_cost > costs[-1]:
            break                                   # no descent along the Gauss-Newton direction: converged
        values = candidate
        costs.append(new_cost)
        if costs[-2] - new_cost <= 1e-6 * costs[-2]:
            break
    return values, {"iterations": iterations, "costs": costs}, linearize(values)


def _solve_lm(cpp, groups, values, options, qr: bool = False):
    graph = gtsam.NonlinearFactorGraph()
    graph.push_back(cpp)
    for group in groups:       # one factor per robust beam: LM accepts a step by the nonlinear error
        for factor in group.beam_factors():
            graph.add(factor)
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(options.batch_max_iterations)
    params.setLinearSolverType("MULTIFRONTAL_QR" if qr else "MULTIFRONTAL_CHOLESKY")
    params.setRelativeErrorTol(1e-6)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, params)
    result = optimizer.optimize()
    return result, {"iterations": optimizer.iterations(), "costs": [graph.error(values), graph.error(result)]}, \
        graph.linearize(result)
