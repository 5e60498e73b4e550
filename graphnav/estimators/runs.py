"""Replays of a recorded mission through the :class:`~graphnav.estimators.navigator.Navigator`: one call from a
:class:`~graphnav.core.mission.Mission` to a :class:`~graphnav.core.solution.NavSolution`, the same code path a
vehicle runs. The runners take objects and flags, not method names (the names live in the registry,
:mod:`graphnav.evaluation.methods`, which maps each to one of these calls):

- :func:`run_graph`: the factor graph over the measured beams (``Graph-TC``), plus a completer's regressed
  beams as weaker factors (``completer=...``: ``Graph-HN``), then optionally the batch smoother over the whole
  mission (``batch=True``: ``Graph-HN-batch``, :mod:`graphnav.estimators.graph.batch`). ``backend="isam2"`` is
  ISAM2 over the whole mission, ``backend="fixed-lag"`` GTSAM's IncrementalFixedLagSmoother (bounded memory and
  time per update). Output stamps are the keyframes: every DVL ping plus IMU-only keyframes in DVL gaps
  (``info["kind"]``).
- :func:`run_ekf`: the error-state EKF, tightly (``tight=True``: TC) or loosely (LC) coupled, with a
  completer for the hybrid variants; output at every DVL ping. The 15-state filter (default) is fed the depth
  sensor; the paper's 12-state filter (``EkfOptions(position_states=False, dvl_error_states=False)``) is not, as in the paper.

``name`` only labels the solution and the messages. The initial state is the ground truth at the start when
the mission has one, else the Navigator aligns from the sensors.
"""
from __future__ import annotations

import dataclasses
import time
import warnings
from typing import Callable

import gtsam
import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.core.mission import Mission
from graphnav.core.solution import NavSolution
from graphnav.estimators.align import AlignOptions
from graphnav.estimators.coasting import check_sigma
from graphnav.estimators.backends import BACKENDS
from graphnav.estimators.ekf import EkfOptions
from graphnav.estimators.graph.batch import batch_smooth
from graphnav.estimators.graph.first_pass import needs_filter
from graphnav.estimators.graph.incremental import is_indeterminant
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.ins import StrapdownState
from graphnav.estimators.navigator import Navigator, NavigatorOptions, feed_mission, navigate
from graphnav.estimators.replay import first_ping_time
from graphnav.estimators.types import EpochEstimate, InitialState

#: The Navigator backends :func:`run_graph` can run (the graph's; :data:`graphnav.estimators.backends.BACKENDS`).
GRAPH_BACKENDS = tuple(b for b in BACKENDS if b != "ekf")


def graph_label(completer=None, batch: bool = False) -> str:
    """The default label of a graph run: Graph-TC (measured beams only) or Graph-HN (with a completer), with
    ``-batch`` for the batch smoother."""
    return ("Graph-HN" if completer is not None else "Graph-TC") + ("-batch" if batch else "")


def graph_navigator(mission: Mission, *, completer=None, options: GraphOptions | None = None,
                    backend: str = "isam2", initial: InitialState | None = None, init: str = "auto",
                    navigator_options=None, keep_keyframe_graphs: bool = False,
                    align: AlignOptions | None = None, name: str | None = None):
    """The :class:`~graphnav.estimators.navigator.Navigator` that ``run_graph`` replays ``mission`` into.

    ``completer``: regressed beams for the pings with missing beams (None: measured beams only).

    ``init``: ``"auto"`` (the ground truth at the first ping when the mission has one, else the sensors),
    ``"gt"`` or ``"sensors"``; an explicit ``initial`` wins (its ``t`` defaults to the first ping).
    ``align``: the sensor alignment's settings (e.g. ``initial_heading_rad``), ``navigator_options.align``.
    ``backend``: a Navigator graph backend (``"dead-reckoning"``: the batch's cheap first pass, no solver).
    """
    if backend not in GRAPH_BACKENDS:
        raise ConfigError(f"unknown graph backend '{backend}'; choose one of {GRAPH_BACKENDS}")
    initial = initial_state(mission, initial, init, first_ping_time(mission))
    return Navigator(mission.config, backend, completer=completer, initial=initial,
                     graph_options=options or GraphOptions(), options=replay_options(navigator_options, mission, align),
                     keep_keyframe_graphs=keep_keyframe_graphs, name=name or graph_label(completer))


def replay_options(navigator_options, mission: Mission, align: AlignOptions | None = None):
    """``navigator_options`` (default :class:`~graphnav.estimators.navigator.NavigatorOptions`) for a replayed
    ``mission`` (its loader judged the DVL's zero pings and the IMU shocks the DVL saw, and warned about its pings
    after the IMU's end), with ``align`` as its
    alignment settings when given: the one place a replay's options differ from a live stream's."""
    options = navigator_options or NavigatorOptions()
    options = dataclasses.replace(options, dvl_zeros_judged=True, imu_shocks=replayed_shocks(mission),
                                  keyframes=dataclasses.replace(options.keyframes, late_pings_said=True))
    return options if align is None else dataclasses.replace(options, align=align)


def replayed_shocks(mission: Mission) -> tuple:
    """The spans (s) of the IMU shocks ``mission``'s loader kept on the DVL's word (``NavigatorOptions.imu_shocks``)."""
    return tuple(tuple(span) for span in mission.meta.get("imu_shocks", ()))


def initial_state(mission: Mission, initial, init: str, t0: float) -> InitialState | None:
    """The initial state a replay starts from: ``initial`` (stamped t0 when it has no stamp), else the ground
    truth at t0 (s; ``init="gt"``, or ``"auto"`` with ground truth holding t0), else None: align from the sensors.
    ``"auto"`` with a reference that starts after t0 (logged over part of the mission), or one whose given time
    offset the clock search contradicts (``meta["gt_clock_doubted"]``, s the data say), aligns from the sensors with
    a warning: the reference is optional; starting from it ended the run in an error, and a reference 16 s early
    started the vehicle 16 s along its path (VRMSE 18.9 m/s against the reference as it was given)."""
    if init not in ("auto", "gt", "sensors"):
        raise ConfigError(f"init must be 'auto', 'gt' or 'sensors', got '{init}'")
    if initial is not None:
        return initial if initial.t is not None else dataclasses.replace(initial, t=t0)
    if init == "sensors" or (init == "auto" and mission.gt is None):
        return None
    why = _reference_doubted(mission, t0) if init == "auto" else None
    if why:
        warnings.warn(f"{mission.gt.source}: {why} to start from: the initial state is aligned from the sensors "
                      "(init auto); the reference scores the estimate where it overlaps it", RuntimeWarning,
                      stacklevel=3)
        return None
    return InitialState.from_ground_truth(mission, t0)


def _reference_doubted(mission: Mission, t0: float) -> str | None:
    """Why the mission's reference (present) should not start a replay whose first ping is at t0 (s), or None."""
    gt, doubted = mission.gt, mission.meta.get("gt_clock_doubted")
    if not gt.t[0] <= t0 <= gt.t[-1]:
        return f"the reference [{gt.t[0]:.3f}, {gt.t[-1]:.3f}] s does not hold the first ping at {t0:.3f} s"
    if doubted is not None:
        return f"the reference's turns put it at gt_time_offset_s {doubted:+.3f} s, not the one given"
    return None


def iterate_graph(mission: Mission, *, completer=None, options: GraphOptions | None = None,
                  backend: str = "isam2", initial: InitialState | None = None, name: str | None = None):
    """Generator over the filtered :class:`EpochEstimate` of every keyframe, as each is computed (the
    arguments as :func:`run_graph`'s).

    Nothing is kept between keyframes except the estimator itself (bounded memory with
    ``backend="fixed-lag"``); there is no batch pass.
    """
    nav = graph_navigator(mission, completer=completer, options=options, backend=backend, initial=initial,
                          name=name)
    yield from navigate(nav, mission)


def run_graph(mission: Mission, *, completer=None, batch: bool = False, options: GraphOptions | None = None,
              callback: Callable[[EpochEstimate], None] | None = None, backend: str = "isam2",
              initial: InitialState | None = None, init: str = "auto",
              align: AlignOptions | None = None, name: str | None = None,
              navigator_options: NavigatorOptions | None = None) -> NavSolution:
    """Run the factor graph over a recorded mission (a sample-by-sample replay through the Navigator).

    Args:
        mission: the mission (IMU, DVL, optional depth; ground truth only for the initial state).
        completer: beam completer (``complete(past, measured)``, ``n_past``) whose regressed beams enter as
            weaker factors at pings with missing beams (Graph-HN); None: measured beams only (Graph-TC).
        batch: after the filtered pass, the batch smoother over the whole mission (Graph-HN-batch).
        options: :class:`GraphOptions` (defaults when None).
        callback: called with the filtered :class:`EpochEstimate` after each keyframe update.
        backend: ``"isam2"`` or ``"fixed-lag"`` (lag ``options.lag_s``), as the Navigator's backends.
        initial: state at the first keyframe (stamp ``initial.t``, default the first DVL ping).
        init: without ``initial``: ``"auto"`` (ground truth when there is one, else align from the sensors),
            ``"gt"`` or ``"sensors"``.
        align: settings of the sensor alignment (:class:`~graphnav.estimators.align.AlignOptions`, e.g.
            ``initial_heading_rad``, ``initial_lla``).
        name: the solution's label, also used in messages (default :func:`graph_label`).
        navigator_options: the Navigator's streaming and alignment settings (e.g. ``align_catch_up``).

    Returns:
        NavSolution at the keyframes, with the covariances ``options.marginals`` asks for (default ``"full"``:
        velocity, position, attitude and biases; the batch's are the smoothed marginals); ``info`` holds ``update_s`` (per-keyframe solver times), ``kind``,
        ``n_measured``/``n_regressed`` per keyframe, ``mode`` (the backend), ``recovered`` (indeterminant-system
        recoveries), the Navigator's counters (``refused``, ``imu_gaps``, ``alignment`` ...) and, for the
        batch, ``batch_iterations``, ``batch_costs``, ``batch_solve_s`` -- or ``batch_failed`` (the reason)
        when the batch system was indeterminant and the filtered estimates are returned instead (with a
        warning).
    """
    start = time.perf_counter()
    options = options or GraphOptions()
    name = name or graph_label(completer, batch)
    # the batch computes its own marginals; its first pass only provides initial values (and the callback's
    # filtered estimates, which keep their covariance when a callback is given)
    first_pass = dataclasses.replace(options, marginals="none") if batch and callback is None else options
    if batch:
        # the batch leaves out the completions of the outages the measured beams end (GraphOptions.
        # retire_completions) itself; its first pass keeps them all, as the online estimate made during each outage
        # did (a failed batch returns those filtered estimates)
        first_pass = dataclasses.replace(first_pass, retire_completions=False)
    dead_reckoning = (batch and callback is None and options.batch_first_pass == "dead-reckoning"
                      and not needs_filter(options, completer))
    nav = graph_navigator(mission, completer=completer, options=first_pass,
                          backend="dead-reckoning" if dead_reckoning else backend, initial=initial,
                          init=init, keep_keyframe_graphs=batch, align=align, name=name,
                          navigator_options=navigator_options)
    estimates = feed_mission(nav, mission, callback)
    if not estimates:
        raise ConfigError(f"{name} on '{mission.name}': no estimate was made "
                          f"({'alignment did not finish' if not nav.initialised else 'no keyframe closed'})")
    info = {**nav.info, "mode": backend, "online_s": time.perf_counter() - start}
    if batch:
        info["batch_first_pass"] = "dead-reckoning" if dead_reckoning else backend
    if batch:
        try:
            estimates, batch_info = batch_smooth(nav.keyframe_graphs(), estimates, options)
            info["completions_retired"] = batch_info.pop("completions_retired")
            info.update({"batch_" + k: v for k, v in batch_info.items()})
            info.update(_smoothed_sigma_health(name, estimates, options))
        except RuntimeError as exc:
            if not is_indeterminant(exc):
                raise
            # Seen with a tiny integration_sigma (1e-4) or a huge rotation variance in one IMU factor: the
            # whole-mission system is too poorly conditioned. The filtered pass is a valid answer; keep it.
            reason = " ".join(str(exc).split())[:160]
            first = "dead-reckoned (first pass)" if dead_reckoning else "filtered (incremental)"
            warnings.warn(f"graph batch: {reason} -- returning the {first} estimates instead of "
                          "smoothed ones (without covariances)", RuntimeWarning, stacklevel=2)
            info["batch_failed"] = reason
        info["batch_s"] = time.perf_counter() - start - info["online_s"]
    sol = solution_from_estimates(name, estimates)
    sol.runtime_s = time.perf_counter() - start
    sol.info.update(info)
    if batch and sol.cov_v_n is not None:
        # the Navigator's live coasting check (info["pure_inertial_spans"]) saw the filtered pass; a span's
        # sigma is the smoothed one at its end
        for span in sol.info.get("pure_inertial_spans", []):
            k = int(np.clip(np.searchsorted(sol.t, span[1]), 0, len(sol.t) - 1))
            span[2] = float(np.sqrt(np.trace(sol.cov_v_n[k])))
    return sol


def _smoothed_sigma_health(name: str, estimates: list[EpochEstimate], options: GraphOptions) -> dict:
    """The claimed-sigma check (:class:`~graphnav.estimators.coasting.SigmaMonitor`) over the batch's smoothed
    velocity covariances: the first pass had none to judge (or the filtered ones, larger than the smoothed). An
    estimate the filtered pass found ok and whose smoothed sigma is above its bound is degraded. Returns the
    monitor's summary for ``info``."""
    if not estimates or any(e.cov_v_n is None for e in estimates):
        return {}
    monitor, states = check_sigma(name, np.array([e.t for e in estimates]), np.array([e.v_n for e in estimates]),
                                  np.array([e.cov_v_n for e in estimates]), options.health)
    for e, (degraded, reason) in zip(estimates, states):
        if degraded and (e.health or "ok") == "ok":
            e.health, e.health_why = "degraded", reason
    return monitor.summary()


def solution_from_estimates(method: str, estimates: list[EpochEstimate]) -> NavSolution:
    """Pack per-keyframe estimates into a :class:`NavSolution` (a covariance only when every estimate has it)."""
    def stacked(name):
        values = [getattr(e, name) for e in estimates]
        return np.array(values) if values and all(v is not None for v in values) else None

    K = len(estimates)
    return NavSolution(
        method=method,
        t=np.array([e.t for e in estimates]),
        p_n=np.array([e.p_n for e in estimates]).reshape(K, 3),
        v_n=np.array([e.v_n for e in estimates]).reshape(K, 3),
        C_b_n=np.array([e.C_b_n for e in estimates]).reshape(K, 3, 3),
        cov_v_n=stacked("cov_v_n"),
        bias_acc=np.array([e.bias.accelerometer() for e in estimates]).reshape(K, 3),
        bias_gyro=np.array([e.bias.gyroscope() for e in estimates]).reshape(K, 3),
        cov_p_n=stacked("cov_p_n"), cov_rot_b=stacked("cov_rot_b"), cov_bias=stacked("cov_bias"),
        info={"kind": [e.kind for e in estimates], "n_measured": np.array([e.n_measured for e in estimates]),
              "n_regressed": np.array([e.n_regressed for e in estimates]),
              "health_state": [e.health or "ok" for e in estimates]},
    )


def _initial_state(mission: Mission, t0: float) -> StrapdownState:
    """The ground truth at t0 as a strapdown state (what tests and demos perturb before passing it as
    ``run_ekf(initial=...)``)."""
    p, v, C = mission.gt.at(t0, mission.imu)
    return StrapdownState(t0, C, v, p)


def ekf_label(tight: bool = True, completer=None) -> str:
    """The default label of an EKF run: TC or LC, ``Hybrid-`` in front with a completer."""
    return ("Hybrid-" if completer is not None else "") + ("TC" if tight else "LC")


def run_ekf(mission: Mission, *, tight: bool = True, completer=None, options: EkfOptions | None = None,
            initial=None, init: str = "auto", align: AlignOptions | None = None,
            name: str | None = None, navigator_options: NavigatorOptions | None = None) -> NavSolution:
    """Run the error-state EKF over a recorded mission and return the solution at every DVL ping (post update): a
    sample-by-sample replay through :class:`graphnav.estimators.navigator.Navigator` (backend ``"ekf"``). The
    mission's depth is replayed for the 15-state filter (``options.position_states`` and ``use_depth``), not
    for the paper's 12-state filter.

    Args:
        mission: the mission (IMU, DVL beams and valid mask, config; ground truth only for the initial state).
        tight: every measured beam is a measurement (TC); False: a velocity fix from 3+ beams (LC).
        completer: regresses the missing beams (the hybrids: Average-*, HN*), e.g. ``AverageCompleter(n_past)`` or
            the network's, through :class:`~graphnav.estimators.history.BeamHistory`; the regressed beams enter
            with their variance inflated by the completer's sigma^2. None: measured beams only.
        options: :class:`EkfOptions` (default: the 15-state filter).
        initial: initial state (:class:`~graphnav.estimators.ins.StrapdownState` or :class:`~graphnav.estimators.types.InitialState`
            with its stamp); default the ground truth at ``max(imu.t[0], gt.t[0])``, as in the paper (the
            comparison is about the outage, not the alignment; the initial covariance of :class:`EkfOptions`
            covers the ground truth's own error).
        init: without ``initial``: ``"auto"`` (ground truth when there is one, else align from the sensors),
            ``"gt"`` or ``"sensors"``.
        align: settings of the sensor alignment (:class:`~graphnav.estimators.align.AlignOptions`, e.g.
            ``initial_heading_rad``, ``initial_lla``).
        name: the solution's label, also used in messages (default :func:`ekf_label`).
        navigator_options: the Navigator's streaming and alignment settings (e.g. ``align_catch_up``).

    Returns:
        :class:`NavSolution` with ``cov_v_n``, ``cov_rot_b``, ``cov_bias`` (and ``cov_p_n`` from the 15-state
        filter), biases, ``runtime_s`` (wall time) and ``info`` counters.
    """
    wall = time.perf_counter()
    options = options or EkfOptions()
    depth = options.position_states and options.use_depth and mission.depth is not None
    name = name or ekf_label(tight, completer)
    if isinstance(initial, StrapdownState):
        initial = InitialState(gtsam.Pose3(gtsam.Rot3(initial.C_b_n), initial.p_n), initial.v_n, t=initial.t)
    t0 = float(mission.imu.t[0])
    if initial is None and init != "sensors" and mission.gt is not None:
        t0 = max(t0, float(mission.gt.t[0]))     # the paper's start: the first instant with IMU and GT
    initial = initial_state(mission, initial, init, t0)
    nav = Navigator(mission.config, "ekf", completer=completer, initial=initial, ekf_options=options, tight=tight,
                    options=replay_options(navigator_options, mission, align), name=f"EKF {name}")
    estimates = [e for e in feed_mission(nav, mission, depth=depth) if e.kind == "dvl"]
    info = nav.info
    info["t0"] = float(initial.t) if initial is not None else (nav.alignment.t if nav.alignment else float("nan"))
    sol = solution_from_estimates(name, estimates)
    sol.runtime_s = time.perf_counter() - wall
    sol.info.update(info)
    return sol  # info holds the Navigator's live pure-inertial check (pure_inertial_spans)
