"""Batch smoothing over the whole mission, started from the incremental (filtered) estimate.

Why not simply LM on the incremental graph: each ``gtsam.CustomFactor`` call inside the C++ optimisers
copies the whole ``Values`` (pybind11 casts the ``const Values&`` argument by value), so one
linearisation of an N-keyframe graph costs O(N^2) (probe: LM 393 s at 1 h). The default solver here,
``"vectorized"``, is Gauss-Newton where

- the C++ factors (priors, CombinedImuFactor, depth) are linearised by GTSAM, and
- all DVL beam factors are linearised at once in numpy (same model and Jacobians as
  :func:`graphnav.factors.beam_factor`; Huber kernels by iteratively reweighted least squares, as GTSAM's
  robust noise model does) and added as ``JacobianFactor`` s,

then the linear system is solved by GTSAM's multifrontal elimination and the step retracted on the
manifold, until the cost stops decreasing (step halving if it rises). Cost per iteration is O(N).
``solver="lm"`` runs GTSAM's Levenberg-Marquardt on the CustomFactor graph itself (reference, O(N^2)).
Velocity covariances are the marginals of the final linearisation. Elimination is Cholesky (GTSAM's default)
unless ``batch_factorization="QR"``; when Cholesky reports an indeterminant system, the batch warns and solves
again with QR.
"""
from __future__ import annotations

import time
import warnings

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, V, X

from graphnav.errors import ConfigError

from .builder import BeamGroup, KeyframeFactors
from .incremental import EpochEstimate, is_indeterminant
from .options import BATCH_SOLVERS, GraphOptions


class StackedBeams:
    """All DVL beam rows of a mission as arrays, for vectorised linearisation.

    Attributes (R rows): k (R,) keyframe index; rows (R,3); y, sigma, huber (R,) (NaN = no kernel);
    omega, lever (R,3).
    """

    def __init__(self, groups: list[BeamGroup]):
        sizes = [len(g.y) for g in groups]
        self.k = np.repeat([g.k for g in groups], sizes).astype(int)
        self.rows = np.concatenate([g.rows_b for g in groups]) if groups else np.zeros((0, 3))
        self.y = np.concatenate([g.y for g in groups]) if groups else np.zeros(0)
        self.sigma = np.concatenate([g.sigma for g in groups]) if groups else np.zeros(0)
        self.huber = np.repeat([np.nan if g.huber_k is None else g.huber_k for g in groups], sizes)
        self.omega = np.repeat([g.omega_b for g in groups], sizes, axis=0).reshape(-1, 3)
        self.lever = np.repeat([g.lever_arm_b for g in groups], sizes, axis=0).reshape(-1, 3)
        order = np.argsort(self.k, kind="stable")
        for name in ("k", "rows", "y", "sigma", "huber", "omega", "lever"):
            setattr(self, name, getattr(self, name)[order])
        # one JacobianFactor per keyframe: row ranges
        self.keyframes, self.starts = np.unique(self.k, return_index=True)
        self.ends = np.append(self.starts[1:], len(self.k))

    def linearize(self, C_b_n: np.ndarray, v_n: np.ndarray, gyro_bias: np.ndarray):
        """Residuals e (R,) and Jacobians (R,3) d/drot, d/dv, d/dgyro-bias at per-keyframe states (K,...)."""
        R = C_b_n[self.k]
        v_body = np.einsum("rji,rj->ri", R, v_n[self.k])
        rate = self.omega - gyro_bias[self.k]
        e = np.einsum("ri,ri->r", self.rows, v_body + np.cross(rate, self.lever)) - self.y
        # b^T [u]x w = w . (b x u)
        J_rot = np.cross(self.rows, v_body)
        J_v = np.einsum("rij,rj->ri", R, self.rows)
        J_bg = np.cross(self.rows, self.lever)
        return e, J_rot, J_v, J_bg

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

    def jacobian_factors(self, e, J_rot, J_v, J_bg) -> gtsam.GaussianFactorGraph:
        """Whitened, reweighted linear factors ``|A dx + e|`` per keyframe."""
        scale = np.sqrt(self.weights(e)) / self.sigma
        A_rot, A_v, A_bg, b = J_rot * scale[:, None], J_v * scale[:, None], J_bg * scale[:, None], -e * scale
        zeros = np.zeros((len(e), 3))
        A_pose = np.hstack([A_rot, zeros])
        A_bias = np.hstack([zeros, A_bg])
        graph = gtsam.GaussianFactorGraph()
        for k, a, z in zip(self.keyframes.tolist(), self.starts.tolist(), self.ends.tolist()):
            graph.push_back(gtsam.JacobianFactor(X(k), A_pose[a:z], V(k), A_v[a:z], B(k), A_bias[a:z], b[a:z],
                                                 gtsam.noiseModel.Unit.Create(z - a)))
        return graph


def _states(values: gtsam.Values, n: int):
    C = np.empty((n, 3, 3))
    v = np.empty((n, 3))
    bg = np.empty((n, 3))
    for k in range(n):
        C[k] = values.atPose3(X(k)).rotation().matrix()
        v[k] = values.atVector(V(k))
        bg[k] = values.atConstantBias(B(k)).gyroscope()
    return C, v, bg


def batch_smooth(keyframe_graphs: list[tuple[gtsam.NonlinearFactorGraph, KeyframeFactors]],
                 estimates: list[EpochEstimate], options: GraphOptions) -> tuple[list[EpochEstimate], dict]:
    """Smooth the whole mission.

    Args:
        keyframe_graphs: per keyframe (link factors: priors or IMU factor, :class:`KeyframeFactors`), as kept
            by an incremental estimator with ``keep_keyframe_graphs=True``.
        estimates: the incremental pass's estimate at every keyframe (initial values).
        options: ``batch_solver``, ``batch_max_iterations``, ``marginals``.

    Returns:
        (smoothed estimates per keyframe, info: iterations, cost history, timings).
    """
    if options.batch_solver not in BATCH_SOLVERS:
        raise ConfigError(f"batch_solver must be one of {BATCH_SOLVERS}, got '{options.batch_solver}'")
    start = time.perf_counter()
    n = len(estimates)
    cpp = gtsam.NonlinearFactorGraph()
    groups: list[BeamGroup] = []
    values = gtsam.Values()
    for (link, local), e in zip(keyframe_graphs, estimates):
        cpp.push_back(link)
        cpp.push_back(local.other)
        groups.extend(local.groups)
        values.insert(X(e.index), e.pose)
        values.insert(V(e.index), e.v_n)
        values.insert(B(e.index), e.bias)
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
    out = [EpochEstimate(e.index, e.t, e.kind, result.atPose3(X(e.index)), result.atVector(V(e.index)),
                         result.atConstantBias(B(e.index)), covs[e.index], e.n_measured, e.n_regressed,
                         float("nan")) for e in estimates]
    return out, info


def _solve(cpp, groups, values, n, options, qr: bool):
    """(result, info, velocity covariance per keyframe or Nones) with the configured solver; ``qr`` selects
    QR elimination (else GTSAM's default, Cholesky) for the steps and the marginals."""
    if options.batch_solver == "lm":
        result, info, linear = _solve_lm(cpp, groups, values, options, qr)
    else:
        result, info, linear = _solve_vectorized(cpp, StackedBeams(groups), values, n, options, qr)
    covs = [None] * n
    if options.marginals:
        t0 = time.perf_counter()
        if qr:      # Marginals and marginalCovariance eliminate with Cholesky: take R of the QR marginal
            tree = linear.eliminateMultifrontal(None, gtsam.EliminateQR)
            covs = [_covariance(tree.marginalFactor(V(k), gtsam.EliminateQR)) for k in range(n)]
        else:
            marginals = gtsam.Marginals(linear, result)
            covs = [marginals.marginalCovariance(V(k)) for k in range(n)]
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
        C, v, bg = _states(vals, n)
        e, J_rot, J_v, J_bg = beams.linearize(C, v, bg)
        linear = cpp.linearize(vals)
        linear.push_back(beams.jacobian_factors(e, J_rot, J_v, J_bg))
        return linear

    def cost(vals):
        C, v, bg = _states(vals, n)
        return cpp.error(vals) + beams.cost(beams.linearize(C, v, bg)[0])

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
    for group in groups:
        graph.add(group.factor())
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(options.batch_max_iterations)
    params.setLinearSolverType("MULTIFRONTAL_QR" if qr else "MULTIFRONTAL_CHOLESKY")
    params.setRelativeErrorTol(1e-6)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, params)
    result = optimizer.optimize()
    return result, {"iterations": optimizer.iterations(), "costs": [graph.error(values), graph.error(result)]}, \
        graph.linearize(result)
