"""Batch smoothing: Levenberg-Marquardt over the mission, started from the incremental (filtered) estimate.

Why chunks: ``gtsam.CustomFactor`` copies the whole ``Values`` on every call inside the C++ optimisers,
so one LM over a 4 h mission costs O(N^2) (probe: 393 s at 1 h). The smoother therefore solves chunks
of ``options.batch_chunk_s`` with ``options.batch_overlap_s`` of look-ahead whose results are discarded.
Each chunk (but the first) starts with the *filtered* joint marginal of (pose, velocity, bias) at its
first keyframe, taken from the incremental pass. In a linear-Gaussian chain that prior is exactly the
information of all earlier data (it has not seen the chunk's data, so nothing is counted twice), so a
chunk's smoothed states equal the full batch's except for the data beyond the look-ahead; with a
look-ahead of a minute that loss is negligible (``scripts/bench_graph.py`` compares chunked and full
batch on 400 s). ``batch_chunk_s=None`` (or longer than the mission) gives one full batch.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, V, X

from .incremental import EpochEstimate
from .options import GraphOptions


@dataclass
class Chunk:
    """Keyframes ``start <= k < solve_end`` are solved; ``start <= k < out_end`` are kept."""

    start: int
    out_end: int
    solve_end: int


def chunk_plan(times: np.ndarray, options: GraphOptions) -> list[Chunk]:
    """Split keyframes at stamps ``times`` (s) into chunks (see module docstring)."""
    n = len(times)
    if options.batch_chunk_s is None or times[-1] - times[0] <= options.batch_chunk_s:
        return [Chunk(0, n, n)]
    edges = np.arange(times[0], times[-1], options.batch_chunk_s)
    starts = sorted(set(int(np.searchsorted(times, e)) for e in edges) - {n})
    chunks = []
    for i, s in enumerate(starts):
        out_end = starts[i + 1] if i + 1 < len(starts) else n
        t_end = times[out_end - 1] + options.batch_overlap_s
        solve_end = max(out_end, int(np.searchsorted(times, t_end, side="right")))
        chunks.append(Chunk(s, out_end, min(solve_end, n)))
    return chunks


def marginal_prior(lin_point: gtsam.Values, cov: np.ndarray, keys: list[int]) -> gtsam.LinearContainerFactor:
    """A Gaussian prior on the joint (pose, velocity, bias) tangent space at ``lin_point``, covariance ``cov``.

    Stored as a linear factor ``|R dx|^2`` with ``R^T R = cov^-1`` (GTSAM's LinearContainerFactor maps the
    tangent-space error of the current values onto it), so it runs in C++.
    """
    info = np.linalg.inv(cov)
    R = np.linalg.cholesky(0.5 * (info + info.T)).T
    dims = [6, 3, 6]
    cols = np.cumsum([0] + dims)
    blocks = [R[:, cols[i]:cols[i + 1]] for i in range(3)]
    jf = gtsam.JacobianFactor(keys[0], blocks[0], keys[1], blocks[1], keys[2], blocks[2], np.zeros(R.shape[0]),
                              gtsam.noiseModel.Unit.Create(R.shape[0]))
    return gtsam.LinearContainerFactor(jf, lin_point)


def lm_params(options: GraphOptions) -> gtsam.LevenbergMarquardtParams:
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(options.batch_max_iterations)
    params.setLinearSolverType("MULTIFRONTAL_QR" if options.factorization == "QR" else "MULTIFRONTAL_CHOLESKY")
    params.setRelativeErrorTol(1e-6)
    return params


def batch_smooth(keyframe_graphs, estimates: list[EpochEstimate], joint: dict, chunks: list[Chunk],
                 options: GraphOptions) -> tuple[list[EpochEstimate], dict]:
    """Smooth the whole mission chunk by chunk.

    Args:
        keyframe_graphs: per keyframe (link factors: priors or IMU factor, own DVL/depth factors),
            as kept by an incremental estimator with ``keep_keyframe_graphs=True``.
        estimates: the incremental pass's estimate at every keyframe (initial values).
        joint: ``k -> (linearisation point, 15x15 covariance)`` filtered joint marginals at chunk starts > 0.
        chunks: from :func:`chunk_plan`.
        options: ``marginals`` decides whether velocity covariances are computed.

    Returns:
        (smoothed estimates per keyframe, info with per-chunk iterations and timings).
    """
    out: list[EpochEstimate] = []
    info = {"chunks": [], "lm_iterations": []}
    for chunk in chunks:
        start = time.perf_counter()
        graph = gtsam.NonlinearFactorGraph()
        values = gtsam.Values()
        s = chunk.start
        if s > 0:
            lin, cov = joint[s]
            graph.add(marginal_prior(lin, cov, [X(s), V(s), B(s)]))
        for k in range(s, chunk.solve_end):
            link, local = keyframe_graphs[k]
            if k > s or s == 0:
                graph.push_back(link)
            graph.push_back(local)
            e = estimates[k]
            values.insert(X(k), e.pose)
            values.insert(V(k), e.v_n)
            values.insert(B(k), e.bias)
        optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, lm_params(options))
        result = optimizer.optimize()
        marginals = gtsam.Marginals(graph, result) if options.marginals else None
        for k in range(s, chunk.out_end):
            e = estimates[k]
            cov = marginals.marginalCovariance(V(k)) if marginals is not None else None
            out.append(EpochEstimate(k, e.t, e.kind, result.atPose3(X(k)), result.atVector(V(k)),
                                     result.atConstantBias(B(k)), cov, e.n_measured, e.n_regressed, float("nan")))
        info["chunks"].append((chunk.start, chunk.out_end, chunk.solve_end, time.perf_counter() - start))
        info["lm_iterations"].append(optimizer.iterations())
    return out, info
