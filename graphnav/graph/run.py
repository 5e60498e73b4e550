"""``run_graph``: one call from a recorded mission to a :class:`~graphnav.solution.NavSolution` for the graph
methods -- a replay of the mission, sample by sample, through :class:`graphnav.navigator.Navigator` (the one
code path a vehicle runs too).

Methods (names as in results):

- ``Graph-TC``: measured beams only, incremental filtered output.
- ``Graph-HN``: measured beams plus the completer's regressed beams as weaker factors, filtered output.
- ``Graph-HN-batch``: as Graph-HN, then the batch smoother over the whole mission
  (:mod:`graphnav.graph.batch`) started from the incremental estimate; smoothed output.

Modes (the incremental engine): ``mode="online"`` (default) is ISAM2 over the whole mission;
``mode="fixed-lag"`` is GTSAM's IncrementalFixedLagSmoother with ``options.lag_s`` (bounded memory and
time per update, for long missions). Graph-HN-batch's first pass uses ``mode`` too (``"fixed-lag"`` is the
scalable choice). Output stamps are the keyframes: every DVL ping plus IMU-only keyframes in DVL gaps
(``info["kind"]``). The initial state is the ground truth at the first DVL ping when the mission has one,
else the Navigator aligns from the sensors.
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
from .incremental import EpochEstimate, InitialState, is_indeterminant
from .options import GraphOptions

GRAPH_METHODS = ("Graph-TC", "Graph-HN", "Graph-HN-batch")
#: run_graph's modes and the Navigator backend each one is.
MODES = {"online": "isam2", "fixed-lag": "fixed-lag"}


def graph_navigator(mission: Mission, method: str = "Graph-TC", completer=None,
                    options: GraphOptions | None = None, mode: str = "online",
                    initial: InitialState | None = None, init: str = "auto", navigator_options=None,
                    keep_keyframe_graphs: bool = False, aligner_kwargs: dict | None = None):
    """The :class:`~graphnav.navigator.Navigator` that ``run_graph`` replays ``mission`` into.

    ``init``: ``"auto"`` (the ground truth at the first ping when the mission has one, else the sensors),
    ``"gt"`` or ``"sensors"``; an explicit ``initial`` wins (its ``t`` defaults to the first ping).
    ``aligner_kwargs`` go to the :class:`~graphnav.align.Aligner` (e.g. ``initial_heading_rad``).
    """
    from graphnav.navigator import Navigator
    from graphnav.replay import first_ping_time
    if method not in GRAPH_METHODS:
        raise ConfigError(f"unknown graph method '{method}'; choose one of {GRAPH_METHODS}")
    if method.startswith("Graph-HN") and completer is None:
        raise ConfigError(f"{method} needs a beam completer (e.g. graphnav.nets.AverageCompleter)")
    if mode not in MODES:
        raise ConfigError(f"unknown graph mode '{mode}'; choose one of {tuple(MODES)}")
    initial = initial_state(mission, initial, init, first_ping_time(mission))
    return Navigator(mission.config, MODES[mode], completer=completer if method.startswith("Graph-HN") else None,
                     initial=initial, graph_options=options or GraphOptions(), options=navigator_options,
                     keep_keyframe_graphs=keep_keyframe_graphs, aligner_kwargs=aligner_kwargs)


def initial_state(mission: Mission, initial, init: str, t0: float) -> InitialState | None:
    """The initial state a replay starts from: ``initial`` (stamped t0 when it has no stamp), else the ground
    truth at t0 (``init="gt"``, or ``"auto"`` with ground truth), else None: align from the sensors."""
    if init not in ("auto", "gt", "sensors"):
        raise ConfigError(f"init must be 'auto', 'gt' or 'sensors', got '{init}'")
    if initial is not None:
        return initial if initial.t is not None else dataclasses.replace(initial, t=t0)
    if init == "sensors" or (init == "auto" and mission.gt is None):
        return None
    return InitialState.from_ground_truth(mission, t0)


def iterate_graph(mission: Mission, method: str = "Graph-TC", completer=None,
                  options: GraphOptions | None = None, mode: str = "online",
                  initial: InitialState | None = None):
    """Generator over the filtered :class:`EpochEstimate` of every keyframe, as each is computed.

    Nothing is kept between keyframes except the estimator itself (bounded memory with
    ``mode="fixed-lag"``); ``Graph-HN-batch`` streams its first (filtered) pass only.
    """
    from graphnav.replay import replay
    nav = graph_navigator(mission, method, completer, options, mode, initial)
    adders = {"imu": nav.add_imu, "dvl": nav.add_dvl, "depth": nav.add_depth}
    for kind, t, payload in replay(mission):
        yield from adders[kind](t, *payload)
    yield from nav.finish()


def run_graph(mission: Mission, method: str = "Graph-TC", completer=None, options: GraphOptions | None = None,
              callback: Callable[[EpochEstimate], None] | None = None, mode: str = "online",
              initial: InitialState | None = None, init: str = "auto",
              aligner_kwargs: dict | None = None) -> NavSolution:
    """Run a graph method over a recorded mission (a sample-by-sample replay through the Navigator).

    Args:
        mission: the mission (IMU, DVL, optional depth; ground truth only for the initial state).
        method: ``Graph-TC``, ``Graph-HN`` or ``Graph-HN-batch`` (the HN methods need ``completer``).
        completer: beam completer (``complete(past, measured)``, ``n_past``).
        options: :class:`GraphOptions` (defaults when None).
        callback: called with the filtered :class:`EpochEstimate` after each keyframe update.
        mode: ``"online"`` (ISAM2) or ``"fixed-lag"`` (lag ``options.lag_s``).
        initial: state at the first keyframe (stamp ``initial.t``, default the first DVL ping).
        init: without ``initial``: ``"auto"`` (ground truth when there is one, else align from the sensors),
            ``"gt"`` or ``"sensors"``.
        aligner_kwargs: for the sensor alignment, e.g. ``initial_heading_rad``, ``initial_lla``.

    Returns:
        NavSolution at the keyframes; ``info`` holds ``update_s`` (per-keyframe solver times), ``kind``,
        ``n_measured``/``n_regressed`` per keyframe, ``mode``, ``recovered`` (indeterminant-system
        recoveries), the Navigator's counters (``refused``, ``imu_gaps``, ``alignment`` ...) and, for the
        batch, ``batch_iterations``, ``batch_costs``, ``batch_solve_s`` -- or ``batch_failed`` (the reason)
        when the batch system was indeterminant and the filtered estimates are returned instead (with a
        warning).
    """
    from graphnav.navigator import feed_mission
    start = time.perf_counter()
    options = options or GraphOptions()
    batch = method == "Graph-HN-batch"
    # the batch computes its own marginals; its first pass only provides initial values (and the callback's
    # filtered estimates, which keep their covariance when a callback is given)
    first_pass = dataclasses.replace(options, marginals=False) if batch and callback is None else options
    nav = graph_navigator(mission, method, completer, first_pass, mode, initial, init, keep_keyframe_graphs=batch,
                          aligner_kwargs=aligner_kwargs)
    estimates = feed_mission(nav, mission, callback)
    if not estimates:
        raise ConfigError(f"{method} on '{mission.name}': no estimate was made "
                          f"({'alignment did not finish' if not nav.initialised else 'no keyframe closed'})")
    info = {**nav.info, "mode": mode, "online_s": time.perf_counter() - start}
    if batch:
        try:
            estimates, batch_info = batch_smooth(nav.backend.estimator.keyframe_graphs, estimates, options)
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
