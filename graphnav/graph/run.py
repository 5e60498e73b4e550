"""``run_graph``: one call from a mission to a :class:`~graphnav.solution.NavSolution` for the graph methods.

Methods (names as in results):

- ``Graph-TC``: measured beams only, incremental filtered output.
- ``Graph-HN``: measured beams plus the completer's regressed beams as weaker factors, filtered output.
- ``Graph-HN-batch``: as Graph-HN, then the batch smoother over the whole mission
  (:mod:`graphnav.graph.batch`) started from the incremental estimate; smoothed output.

Modes (the incremental engine): ``mode="online"`` (default) is ISAM2 over the whole mission;
``mode="fixed-lag"`` is GTSAM's IncrementalFixedLagSmoother with ``options.lag_s`` (bounded memory and
time per update, for long missions). Graph-HN-batch's first pass uses ``mode`` too (``"fixed-lag"`` is the
scalable choice). Output stamps are the keyframes: every DVL ping plus IMU-only keyframes in DVL gaps
(``info["kind"]``).
"""
from __future__ import annotations

import dataclasses
import time
import warnings
from typing import Callable

import numpy as np

from graphnav.errors import ConfigError
from graphnav.mission import Mission
from graphnav.solution import NavSolution

from .batch import batch_smooth
from .builder import KeyframeBuilder
from .incremental import EpochEstimate, FixedLagGraph, InitialState, OnlineGraph, is_indeterminant
from .options import GraphOptions

GRAPH_METHODS = ("Graph-TC", "Graph-HN", "Graph-HN-batch")
MODES = ("online", "fixed-lag")


def make_estimator(mode: str, builder: KeyframeBuilder, initial: InitialState):
    """An :class:`OnlineGraph` (``"online"``) or :class:`FixedLagGraph` (``"fixed-lag"``)."""
    if mode == "online":
        return OnlineGraph(builder, initial)
    if mode == "fixed-lag":
        return FixedLagGraph(builder, initial)
    raise ConfigError(f"unknown graph mode '{mode}'; choose one of {MODES}")


def iterate_graph(mission: Mission, method: str = "Graph-TC", completer=None,
                  options: GraphOptions | None = None, mode: str = "online",
                  initial: InitialState | None = None):
    """Generator over the filtered :class:`EpochEstimate` of every keyframe, as each is computed.

    Nothing is kept between keyframes except the estimator itself (bounded memory with
    ``mode="fixed-lag"``); ``Graph-HN-batch`` streams its first (filtered) pass only.
    """
    estimator, builder = _setup(mission, method, completer, options, mode, initial)
    for kf in builder:
        estimator.add(kf)
        yield estimator.update()


def _setup(mission, method, completer, options, mode, initial):
    if method not in GRAPH_METHODS:
        raise ConfigError(f"unknown graph method '{method}'; choose one of {GRAPH_METHODS}")
    if method.startswith("Graph-HN") and completer is None:
        raise ConfigError(f"{method} needs a beam completer (e.g. graphnav.nets.AverageCompleter)")
    options = options or GraphOptions()
    builder = KeyframeBuilder(mission, options, completer if method.startswith("Graph-HN") else None)
    if initial is None:
        initial = InitialState.from_ground_truth(mission, builder.times[0])
    return make_estimator(mode, builder, initial), builder


def run_graph(mission: Mission, method: str = "Graph-TC", completer=None, options: GraphOptions | None = None,
              callback: Callable[[EpochEstimate], None] | None = None, mode: str = "online",
              initial: InitialState | None = None) -> NavSolution:
    """Run a graph method over a mission.

    Args:
        mission: the mission (IMU, DVL, optional depth; ground truth for the initial state unless ``initial``).
        method: ``Graph-TC``, ``Graph-HN`` or ``Graph-HN-batch`` (the HN methods need ``completer``).
        completer: beam completer (``complete(past, measured)``, ``n_past``).
        options: :class:`GraphOptions` (defaults when None).
        callback: called with the filtered :class:`EpochEstimate` after each keyframe update.
        mode: ``"online"`` (ISAM2) or ``"fixed-lag"`` (lag ``options.lag_s``).
        initial: state at the first keyframe; default: ground truth there (zero bias).

    Returns:
        NavSolution at the keyframes; ``info`` holds ``update_s`` (per-keyframe solver times), ``kind``,
        ``n_measured``/``n_regressed`` per keyframe, ``mode``, ``recovered`` (indeterminant-system
        recoveries) and, for the batch, ``batch_iterations``, ``batch_costs``, ``batch_solve_s`` -- or
        ``batch_failed`` (the reason) when the batch system was indeterminant and the filtered estimates
        are returned instead (with a warning).
    """
    start = time.perf_counter()
    options = options or GraphOptions()
    batch = method == "Graph-HN-batch"
    # the batch computes its own marginals; its first pass only provides initial values (and the callback's
    # filtered estimates, which keep their covariance when a callback is given)
    first_pass = dataclasses.replace(options, marginals=False) if batch and callback is None else options
    estimator, builder = _setup(mission, method, completer, first_pass, mode, initial)
    estimator.keep_keyframe_graphs = batch
    estimates = []
    for kf in builder:
        estimator.add(kf)
        est = estimator.update()
        estimates.append(est)
        if callback is not None:
            callback(est)
    info = {"mode": mode, "update_s": list(estimator.update_times), "recovered": estimator.n_recovered,
            "online_s": time.perf_counter() - start, "regressed_screening": dict(builder.screening)}
    if batch:
        try:
            estimates, batch_info = batch_smooth(estimator.keyframe_graphs, estimates, options)
            info.update({"batch_" + k: v for k, v in batch_info.items()})
        except RuntimeError as exc:
            if not is_indeterminant(exc):
                raise
            # Seen with a tiny integration_sigma (1e-4) or a huge rotation variance in one IMU factor: the
            # whole-mission system is too poorly conditioned. The filtered pass is a valid answer; keep it.
            reason = " ".join(str(exc).split())[:160]
            warnings.warn(f"graph batch: {reason} -- returning the filtered (incremental) estimates instead of "
                          "smoothed ones (no velocity covariance)", RuntimeWarning, stacklevel=2)
            info["batch_failed"] = reason
        info["batch_s"] = time.perf_counter() - start - info["online_s"]
    sol = solution_from_estimates(method, estimates)
    sol.runtime_s = time.perf_counter() - start
    sol.info.update(info)
    return sol


def solution_from_estimates(method: str, estimates: list[EpochEstimate]) -> NavSolution:
    """Pack per-keyframe estimates into a :class:`NavSolution`."""
    has_cov = all(e.cov_v_n is not None for e in estimates)
    return NavSolution(
        method=method,
        t=np.array([e.t for e in estimates]),
        p_n=np.array([e.p_n for e in estimates]),
        v_n=np.array([e.v_n for e in estimates]),
        C_b_n=np.array([e.C_b_n for e in estimates]),
        cov_v_n=np.array([e.cov_v_n for e in estimates]) if has_cov else None,
        bias_acc=np.array([e.bias.accelerometer() for e in estimates]),
        bias_gyro=np.array([e.bias.gyroscope() for e in estimates]),
        info={"kind": [e.kind for e in estimates], "n_measured": np.array([e.n_measured for e in estimates]),
              "n_regressed": np.array([e.n_regressed for e in estimates])},
    )
