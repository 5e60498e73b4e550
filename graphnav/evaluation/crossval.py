"""Leave-trajectories-out choice of the defaults fitted on data.

A default that was fitted on the shared trajectories (an IMU noise density, a DVL error-state random walk) is
only worth what it scores on trajectories it was not fitted on. This module

1. runs each method over each trajectory once per candidate value of one parameter (:func:`run_grid`; the
   per-trajectory numbers are stored, one record per trajectory x scenario x method x parameter x value),
2. splits the trajectories into folds of whole trajectories (:data:`SNAPIR_FOLDS`, :func:`make_folds`;
   no trajectory is in two folds, so a held-out fold shares no data with its training folds),
3. chooses, per fold and method, the value from the training trajectories alone (:func:`select_value`) and
   scores that value on the held-out trajectories (:func:`cross_validate`), and
4. reports in-fold next to out-of-fold numbers (:func:`report`).

Parameters (:data:`PARAMETERS`):

- ``imu_noise_scale``: factor on the white-noise densities of the mission's IMU model
  (``config.imu.accel_noise_density`` and ``gyro_noise_density``; for the A-KIT folders
  :data:`graphnav.io.loaders.PHINS_RECORDED`). The EKF's ``EkfOptions.imu_noise_scale`` is the same factor
  for the filter alone.
- ``accel_bias_rw``: the accelerometer bias random walk of the mission's IMU model (``config.imu.accel_bias_rw``,
  m/s^3/sqrt(Hz); every estimator).
- ``dvl_bias_rw``, ``dvl_scale_rw``: the graph's DVL error-state random walks (``GraphOptions``; m/s/sqrt(s)
  and 1/sqrt(s)).
- ``priors.dvl_bias_sigma``: the graph's first-keyframe prior sigma of the beam bias states (m/s).
- ``integration_sigma``: the graph's preintegration integration noise (``GraphOptions``; m/sqrt(s)): a position
  random walk between keyframes, which loosens what the depth says of the vertical velocity.
- ``dvl_lever_x``, ``dvl_lever_y``: the DVL's position relative to the IMU point, body x / y (m), added to the
  loader's default lever arm (A-KIT: :data:`graphnav.io.loaders.AKIT_LEVER_ARM_B` minus
  :data:`~graphnav.io.loaders.AKIT_IMU_POSITION_B`, zero). The mission is loaded again with it, since the
  loader's DVL time-offset estimate uses the lever arm; the GT stays at the IMU point.

Selection rules (:data:`RULES`):

- ``"nees"``: the value whose mean velocity NEES over the training trajectories is closest to 3 (the value
  for 3 degrees of freedom) in log: ``|log(mean NEES / 3)|``. Over- and under-confidence by the same factor
  cost the same.
- ``"vrmse"``: the value with the lowest mean mission VRMSE over the training trajectories.
- ``"nees-guarded"`` (default of the study): among the values whose mean VRMSE is within ``vrmse_tol``
  (relative) of the best, the one of the ``"nees"`` rule: a covariance parameter must not buy its NEES
  with accuracy.

Each method is scored against the ground truth carried to its epochs by the IMU, as the benchmark's NEES
(:func:`graphnav.evaluation.consistency.mission_nees`: mean over the mission after 60 s).
"""
from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.core.folds import check_folds
from graphnav.core.mission import Mission
from graphnav.evaluation.methods import GRAPH_TC, GRAPH_TC_BATCH

#: Velocity NEES of a consistent 3-D estimate.
NEES_TARGET = 3.0
#: The selection rules of :func:`select_value`.
RULES = ("nees", "vrmse", "nees-guarded")
#: Default relative VRMSE tolerance of the ``"nees-guarded"`` rule.
VRMSE_TOL = 0.03

#: The fixed folds over the ten shared Snapir trajectories (A-KIT, June 2022): five folds of two whole
#: trajectories. Each fold holds trajectories of different character where it can, and the two unusual ones
#: are in different folds (5: many turns; 11: starts at the surface).
SNAPIR_FOLDS: tuple[tuple[str, ...], ...] = (
    ("Trajectory1", "Trajectory2"),
    ("Trajectory3", "Trajectory4"),
    ("Trajectory5", "Trajectory6"),
    ("Trajectory8", "Trajectory10"),
    ("Trajectory11", "Trajectory13"),
)


@dataclass(frozen=True)
class Parameter:
    """One fitted default the study can vary.

    Attributes:
        name: the parameter's name in records and tables.
        where: ``"config"`` (applied to the mission's :class:`~graphnav.core.config.SensorConfig`), ``"load"``
            (given to the A-KIT loader: the mission is loaded again),
            ``"graph"`` (a :class:`~graphnav.estimators.graph.GraphOptions` field) or ``"ekf"``
            (an :class:`~graphnav.estimators.ekf.EkfOptions` field).
        default: the current default value (what the study compares with).
        grid: candidate values.
        rule: the selection rule of :func:`select_value` for this parameter.
        unit: for tables.
    """

    name: str
    where: str
    default: float
    grid: tuple[float, ...]
    rule: str = "nees-guarded"
    unit: str = ""


def _parameters() -> dict[str, Parameter]:
    from graphnav.estimators.graph import GraphOptions
    g = GraphOptions()
    return {p.name: p for p in (
        Parameter("imu_noise_scale", "config", 1.0, (0.5, 0.7, 1.0, 1.4, 2.0, 3.0), unit="x the IMU model's densities"),
        Parameter("accel_bias_rw", "config", 1e-6, (1e-6, 1e-5, 3e-5, 1e-4),
                  unit="m/s^3/sqrt(Hz), the IMU model's accelerometer bias walk"),
        Parameter("dvl_bias_rw", "graph", g.dvl_bias_rw, (1e-4, 2e-4, 5e-4, 1e-3, 2e-3), unit="m/s/sqrt(s)"),
        Parameter("dvl_scale_rw", "graph", g.dvl_scale_rw, (2e-5, 1e-4, 5e-4), unit="1/sqrt(s)"),
        Parameter("priors.dvl_bias_sigma", "graph", 0.01, (0.005, 0.01, 0.02), unit="m/s"),
        Parameter("integration_sigma", "graph", g.integration_sigma, (3e-4, 1e-3, 3e-3, 1e-2), unit="m/sqrt(s)"),
        Parameter("dvl_lever_x", "load", 0.0, (0.0, 0.04, 0.08, 0.12, 0.16), rule="vrmse",
                  unit="m, DVL forward of the IMU point"),
        Parameter("dvl_lever_y", "load", 0.0, (-0.04, 0.0, 0.04, 0.08), rule="vrmse",
                  unit="m, DVL right of the IMU point"),
    )}


#: The parameters of the study by name (grids around the current defaults, one parameter at a time).
PARAMETERS: dict[str, Parameter] = _parameters()
#: The keys a base configuration (``GridTask.config_base``) may set before the varied parameter.
CONFIG_BASE_KEYS = ("imu_noise_scale", "accel_bias_rw", "dvl_lever_x", "dvl_lever_y")


def parameter_name(name: str) -> str:
    """``name`` as :data:`PARAMETERS` calls it: an option name of before the option groups (e.g.
    ``prior_dvl_bias_sigma``) is mapped to its new one with a DeprecationWarning
    (:func:`graphnav.estimators.options.current_name`)."""
    from graphnav.estimators.options import current_name
    return current_name(name, stacklevel=4)
#: Graph methods whose filtered and batch solutions come from one run (the batch's first pass is Graph-TC).
GRAPH_PAIR = (GRAPH_TC, GRAPH_TC_BATCH)


def _study_methods() -> tuple[str, ...]:
    from graphnav.evaluation.methods import METHODS
    return tuple(n for n, m in METHODS.items() if m.tight and m.completer == "none" and not m.defaults)


#: Methods of the study, from the registry: the tightly coupled methods on measured beams with no settings of
#: their own (TC, Graph-TC, Graph-TC-batch): what the defaults alone decide.
STUDY_METHODS: tuple[str, ...] = _study_methods()


def mean_range(values, digits: int = 2) -> str:
    """A study table's cell: ``mean (min-max)`` of ``values``."""
    x = np.asarray(values, dtype=float)
    return f"{x.mean():.{digits}f} ({x.min():.{digits}f}-{x.max():.{digits}f})"


# --- folds -----------------------------------------------------------------------------------------------
def make_folds(names: Sequence[str], n_folds: int) -> list[tuple[str, ...]]:
    """``n_folds`` folds of whole trajectories: the names in natural order dealt out round-robin (fixed, no
    randomness, so a study is repeatable). Raises :class:`ConfigError` for fewer names than folds or a name
    given twice."""
    from graphnav.evaluation.bench import natural_key
    names = list(names)
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(f"trajectories named twice: {twice}")
    if n_folds < 2 or len(names) < n_folds:
        raise ConfigError(f"need at least 2 folds and one trajectory per fold, got {n_folds} folds for "
                          f"{len(names)} trajectories")
    ordered = sorted(names, key=natural_key)
    return [tuple(ordered[i::n_folds]) for i in range(n_folds)]


def folds_for(names: Sequence[str], n_folds: int = 5) -> list[tuple[str, ...]]:
    """:data:`SNAPIR_FOLDS` when ``names`` are exactly the ten shared trajectories, else :func:`make_folds`."""
    if sorted(names) == sorted(n for f in SNAPIR_FOLDS for n in f):
        return [tuple(f) for f in SNAPIR_FOLDS]
    return make_folds(names, n_folds)


# --- selection -------------------------------------------------------------------------------------------
def _mean(values) -> float:
    v = [float(x) for x in values if x is not None and math.isfinite(float(x))]
    return float(np.mean(v)) if v else float("nan")


def nees_distance(nees: float) -> float:
    """``|log(nees / 3)|``: how far a mean NEES is from consistent, by the same factor either way."""
    return abs(math.log(nees / NEES_TARGET)) if nees > 0 and math.isfinite(nees) else math.inf


def score_values(table: Sequence[dict], method: str, parameter: str, trajectories: Sequence[str],
                 scenario: str = "none") -> dict[float, dict]:
    """Per value of ``parameter``: mean ``nees`` and ``vrmse`` (mission) of ``method`` over ``trajectories``
    and ``n`` (how many of them have a record). A value missing any trajectory is left out, so every value
    is judged on the same trajectories."""
    want = set(trajectories)
    per_value: dict[float, dict[str, dict]] = defaultdict(dict)
    for r in table:
        if (r["method"], r["parameter"], r["scenario"]) == (method, parameter, scenario) \
                and r["trajectory"] in want and not r.get("error"):
            per_value[float(r["value"])][r["trajectory"]] = r
    out = {}
    for value, rs in per_value.items():
        if set(rs) != want:
            continue
        out[value] = {"nees": _mean(r["nees_mission"] for r in rs.values()),
                      "vrmse": _mean(r["vrmse_mission"] for r in rs.values()),
                      "vrmse_window": _mean(r.get("vrmse_window") for r in rs.values()), "n": len(rs)}
    return out


def select_value(scores: dict[float, dict], rule: str = "nees-guarded", vrmse_tol: float = VRMSE_TOL) -> float:
    """The chosen value from :func:`score_values`' output under ``rule`` (module docstring). Ties go to the
    smaller value. Raises :class:`ConfigError` when nothing can be chosen."""
    if rule not in RULES:
        raise ConfigError(f"unknown selection rule '{rule}'; choose from {RULES}")
    usable = {v: s for v, s in scores.items() if math.isfinite(s["vrmse"])}
    if rule != "vrmse":
        usable = {v: s for v, s in usable.items() if math.isfinite(nees_distance(s["nees"]))}
    if not usable:
        raise ConfigError("no candidate value has finite scores on the training trajectories")
    if rule == "vrmse":
        return min(sorted(usable), key=lambda v: usable[v]["vrmse"])
    if rule == "nees-guarded":
        best = min(s["vrmse"] for s in usable.values())
        usable = {v: s for v, s in usable.items() if s["vrmse"] <= best * (1.0 + vrmse_tol)}
    return min(sorted(usable), key=lambda v: nees_distance(usable[v]["nees"]))


# --- cross-validation ------------------------------------------------------------------------------------
def choose_shared(table: Sequence[dict], methods: Sequence[str], parameter: str, trajectories: Sequence[str],
                  rule: str = "nees-guarded", scenario: str = "none", vrmse_tol: float = VRMSE_TOL) -> float:
    """One value for several methods that share the parameter (an IMU density, a GraphOptions field): each
    method's choice on ``trajectories`` (:func:`select_value`), then the largest. The parameters of the study
    are noise and random-walk values, so the largest is the most cautious: a method that needed less becomes
    somewhat under-confident rather than another over-confident."""
    return max(select_value(score_values(table, m, parameter, trajectories, scenario), rule, vrmse_tol)
               for m in methods)


def cross_validate(table: Sequence[dict], folds: Sequence[Sequence[str]], method: str, parameter: str,
                   rule: str = "nees-guarded", scenario: str = "none", vrmse_tol: float = VRMSE_TOL,
                   score_scenarios: Sequence[str] = (), shared_with: Sequence[str] = ()) -> dict:
    """Leave-one-fold-out for one method and parameter.

    For each fold the value is chosen on the other folds' trajectories (``scenario``) and scored on the fold's
    own. Returns ``folds`` (per fold: held-out names, chosen value, in-fold mean NEES/VRMSE on its training
    trajectories, out-of-fold mean NEES/VRMSE on the held-out ones), ``per_trajectory`` (each trajectory's
    held-out NEES and VRMSE at the value chosen without it), ``in_fold`` / ``out_of_fold`` (means: in-fold over
    folds, out-of-fold over all trajectories each scored once held out), ``all_data_value`` (the value chosen
    on every trajectory: the default the study recommends) with its in-sample means, and ``default`` (the
    current default's means over every trajectory). ``score_scenarios``: further scenarios scored at the
    chosen values (e.g. ``"3-missing"``), in ``out_of_fold_by_scenario``. ``shared_with``: other methods that
    share the parameter; the value is then :func:`choose_shared` over ``method`` and them.
    """
    choosers = [method, *[m for m in shared_with if m != method]]
    check_folds(folds)
    spec = PARAMETERS.get(parameter)
    names = [n for f in folds for n in f]
    result = {"method": method, "parameter": parameter, "rule": rule, "scenario": scenario, "folds": [],
              "chosen_by": choosers,
              "per_trajectory": {}}
    held_scores: dict[str, list[dict]] = defaultdict(list)
    for fold in folds:
        train = [n for n in names if n not in fold]
        chosen = choose_shared(table, choosers, parameter, train, rule, scenario, vrmse_tol)
        inside = score_values(table, method, parameter, train, scenario)[chosen]
        held = {}
        for n in fold:
            one = score_values(table, method, parameter, [n], scenario).get(chosen)
            if one is None:
                raise ConfigError(f"no record of {method} on {n} with {parameter} = {chosen:g} ({scenario})")
            held[n] = one
            result["per_trajectory"][n] = {"value": chosen, "nees": one["nees"], "vrmse": one["vrmse"]}
            for sc in score_scenarios:
                other = score_values(table, method, parameter, [n], sc).get(chosen)
                if other is not None:
                    held_scores[sc].append(other)
        result["folds"].append({
            "held_out": list(fold), "value": chosen,
            "in_fold_nees": inside["nees"], "in_fold_vrmse": inside["vrmse"],
            "out_of_fold_nees": _mean(h["nees"] for h in held.values()),
            "out_of_fold_vrmse": _mean(h["vrmse"] for h in held.values())})
    per = result["per_trajectory"].values()
    result["in_fold"] = {"nees": _mean(f["in_fold_nees"] for f in result["folds"]),
                         "vrmse": _mean(f["in_fold_vrmse"] for f in result["folds"])}
    result["out_of_fold"] = {"nees": _mean(p["nees"] for p in per), "vrmse": _mean(p["vrmse"] for p in per),
                             "nees_max": max(p["nees"] for p in per)}
    result["out_of_fold_by_scenario"] = {
        sc: {"nees": _mean(s["nees"] for s in v), "vrmse": _mean(s["vrmse"] for s in v),
             "vrmse_window": _mean(s["vrmse_window"] for s in v)} for sc, v in held_scores.items()}
    all_scores = score_values(table, method, parameter, names, scenario)
    result["all_data_value"] = choose_shared(table, choosers, parameter, names, rule, scenario, vrmse_tol)
    result["all_data"] = all_scores[result["all_data_value"]]
    if spec is not None and spec.default in all_scores:
        result["default"] = {"value": spec.default, **all_scores[spec.default]}
    return result


# --- running the grid ------------------------------------------------------------------------------------
def with_imu_noise_scale(mission: Mission, scale: float) -> Mission:
    """A copy of ``mission`` whose IMU model has its white-noise densities multiplied by ``scale``."""
    if not scale > 0:
        raise ConfigError(f"imu_noise_scale must be > 0, got {scale}")
    imu = dataclasses.replace(mission.config.imu,
                              accel_noise_density=mission.config.imu.accel_noise_density * scale,
                              gyro_noise_density=mission.config.imu.gyro_noise_density * scale)
    return dataclasses.replace(mission, config=dataclasses.replace(mission.config, imu=imu))


def with_accel_bias_rw(mission: Mission, walk: float) -> Mission:
    """A copy of ``mission`` whose IMU model has the accelerometer bias random walk ``walk`` (m/s^3/sqrt(Hz))."""
    if not walk > 0:
        raise ConfigError(f"accel_bias_rw must be > 0, got {walk}")
    imu = dataclasses.replace(mission.config.imu, accel_bias_rw=walk)
    return dataclasses.replace(mission, config=dataclasses.replace(mission.config, imu=imu))


def load_with_lever(source, dx: float, dy: float) -> Mission:
    """The A-KIT mission of ``source`` (a trajectory folder) loaded with the DVL ``dx``, ``dy`` m (body x, y)
    away from the loader's default lever arm (the GT stays at the IMU point)."""
    from graphnav.io.loaders import akit_default_config
    from graphnav.missions import load_akit
    if source.folder is None:
        raise ConfigError(f"{source.name}: the lever-arm parameters need an A-KIT folder")
    lever = akit_default_config().dvl.lever_arm_b + np.array([dx, dy, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return load_akit(source.folder, lever_arm_b=lever)


def _method_options(parameter: Parameter, value: float, family: str, base: dict | None) -> dict | None:
    options = dict(base or {})
    if parameter.where == family:
        options[parameter.name] = value
    return options or None


def run_methods(mission: Mission, methods: Sequence[str], scenario: str, options: dict | None = None,
                ekf_options: dict | None = None) -> dict:
    """{method: NavSolution} of ``methods`` on ``mission`` (outage already applied). Graph-TC and
    Graph-TC-batch come from one run when both are asked for: the batch's first pass is Graph-TC, with its
    marginals, handed out by the callback."""
    from graphnav.estimators.runs import solution_from_estimates
    from graphnav.evaluation.methods import get_method, run_method
    out = {}
    todo = list(methods)
    if all(m in todo for m in GRAPH_PAIR):
        filtered = []
        out[GRAPH_TC_BATCH] = run_method(mission, GRAPH_TC_BATCH, scenario, options=options,
                                           callback=filtered.append)
        sol = solution_from_estimates(GRAPH_TC, filtered)
        sol.runtime_s = float("nan")
        out[GRAPH_TC] = sol
        todo = [m for m in todo if m not in GRAPH_PAIR]
    for m in todo:
        family = get_method(m).family
        out[m] = run_method(mission, m, scenario, options=options if family == "graph" else ekf_options)
    return out


@dataclass(frozen=True)
class GridTask:
    """One trajectory x scenario x parameter x value: every method is run on it."""

    source: object          # graphnav.evaluation.bench.TrajectorySource
    scenario: str
    parameter: str
    value: float
    methods: tuple[str, ...]
    graph_base: tuple = ()   # (name, value) pairs on top of the graph defaults (e.g. a value chosen before)
    ekf_base: tuple = ()
    config_base: tuple = ()  # (("imu_noise_scale", s),) applied before the varied parameter

    @property
    def key(self) -> tuple:
        return (self.source.name, self.scenario, self.parameter, float(self.value))


def run_grid_task(task: GridTask) -> list[dict]:
    """Records of one :class:`GridTask` (one per method): ``nees_mission``, ``vrmse_mission``,
    ``vrmse_window`` and ``nees_window`` (means over the bench's windows), ``nees_mission_gt``, runtime.
    A failing run gives a record with ``error`` (reported, not averaged)."""
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench import case_windows, prepared_mission, score_case
    spec = PARAMETERS[task.parameter]
    base = {"trajectory": task.source.name, "scenario": task.scenario, "parameter": task.parameter,
            "value": float(task.value), "graph_base": dict(task.graph_base), "ekf_base": dict(task.ekf_base),
            "config_base": dict(task.config_base)}
    try:
        lever = {k: v for k, v in task.config_base if k.startswith("dvl_lever_")}
        if spec.where == "load":
            lever[spec.name] = task.value
        mission = (load_with_lever(task.source, lever.get("dvl_lever_x", 0.0), lever.get("dvl_lever_y", 0.0))
                   if any(lever.values()) else prepared_mission(task.source, "as-recorded"))
        # a base factor (e.g. back to the densities before a change) composes with the varied one
        scale = dict(task.config_base).get("imu_noise_scale", 1.0) * (
            task.value if spec.name == "imu_noise_scale" else 1.0)
        if scale != 1.0:
            mission = with_imu_noise_scale(mission, scale)
        walk = task.value if spec.name == "accel_bias_rw" else dict(task.config_base).get("accel_bias_rw")
        if walk is not None:
            mission = with_accel_bias_rw(mission, walk)
        starts = case_windows(mission, 30.0)
        run_mission = mission.with_outage(*[scenario_outage(task.scenario, s, 30.0) for s in starts])
        graph_opts = _method_options(spec, task.value, "graph", dict(task.graph_base))
        ekf_opts = _method_options(spec, task.value, "ekf", dict(task.ekf_base))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            start = time.perf_counter()
            sols = run_methods(run_mission, task.methods, task.scenario, graph_opts, ekf_opts)
            wall = time.perf_counter() - start
    except Exception as exc:  # noqa: BLE001 - one failed run must not end a study; it is reported
        return [{**base, "method": m, "error": f"{type(exc).__name__}: {exc}"} for m in task.methods]
    out = []
    for m, sol in sols.items():
        scores = score_case(sol, mission, starts, 30.0)
        out.append({**base, "method": m,
                    "nees_mission": scores[0]["nees_mission"], "nees_mission_gt": scores[0]["nees_mission_gt"],
                    "vrmse_mission": scores[0]["vrmse_mission"],
                    "vrmse_window": _mean(s["vrmse_window"] for s in scores),
                    "nees_window": _mean(s["nees_window"] for s in scores),
                    "runtime_s": wall})
    return out


def grid_tasks(sources: Sequence, parameters: Sequence[str], scenarios: Sequence[str],
               methods: Sequence[str] = STUDY_METHODS, graph_base: dict | None = None,
               config_base: dict | None = None) -> list[GridTask]:
    """Every trajectory x scenario x parameter x grid value. Methods the parameter cannot change (an EKF
    method for a graph option) are run at one value only (the default), since their numbers do not depend
    on it; :func:`expand_constant` copies them to the other values."""
    from graphnav.evaluation.methods import get_method
    tasks = []
    for p in parameters:
        if p not in PARAMETERS:
            raise ConfigError(f"unknown parameter '{p}'; choose from {', '.join(PARAMETERS)}")
        spec = PARAMETERS[p]
        for src in sources:
            for sc in scenarios:
                for v in spec.grid:
                    ms = tuple(m for m in methods
                               if spec.where in ("config", "load", get_method(m).family) or v == spec.default)
                    if ms:
                        tasks.append(GridTask(src, sc, p, float(v), ms, tuple(sorted((graph_base or {}).items())),
                                              (), tuple(sorted((config_base or {}).items()))))
    return tasks


def expand_constant(table: list[dict]) -> list[dict]:
    """Copy the records of methods a parameter does not act on (run at the default only) to every grid value."""
    from graphnav.evaluation.methods import get_method
    out = list(table)
    have = {(r["trajectory"], r["scenario"], r["parameter"], float(r["value"]), r["method"]) for r in table}
    for r in table:
        spec = PARAMETERS.get(r["parameter"])
        if (spec is None or spec.where in ("config", "load", get_method(r["method"]).family)
                or r["value"] != spec.default):
            continue
        for v in spec.grid:
            k = (r["trajectory"], r["scenario"], r["parameter"], float(v), r["method"])
            if k not in have:
                out.append({**r, "value": float(v), "copied_from_default": True})
                have.add(k)
    return out


def run_grid(tasks: Sequence[GridTask], out_path: str | Path, jobs: int = 1,
             progress: Callable[[str], None] | None = None) -> list[dict]:
    """Run ``tasks`` (``jobs`` processes), appending to the JSON list at ``out_path`` after each one; tasks
    whose records are already there (without error) are skipped, so an interrupted study resumes."""
    from graphnav.evaluation.bench import load_results
    from graphnav.evaluation.tasks import run_tasks
    from graphnav.io.outputs import write_json
    out_path = Path(out_path)
    records = [r for r in load_results(out_path) if not r.get("error")]

    def task_key(r):
        return (r["trajectory"], r["scenario"], r["parameter"], float(r["value"]),
                tuple(sorted(r.get("graph_base", {}).items())), tuple(sorted(r.get("config_base", {}).items())))

    done = {task_key(r) for r in records}
    todo = [t for t in tasks if (*t.key, t.graph_base, t.config_base) not in done]

    def finished(new: list[dict]) -> None:
        records.extend(new)
        write_json(out_path, records)
        if progress:
            r = new[0]
            progress(f"{r['trajectory']} {r['scenario']} {r['parameter']}={r['value']:g}: "
                     + ", ".join(f"{x['method']} NEES {x.get('nees_mission') or float('nan'):.2f}" for x in new)
                     + (f" ERROR {r['error']}" if r.get("error") else ""))

    run_tasks(run_grid_task, todo, finished, jobs)
    return records


# --- report ----------------------------------------------------------------------------------------------
def _f(x, digits: int = 2) -> str:
    return "-" if x is None or not math.isfinite(float(x)) else f"{float(x):.{digits}f}"


def _g(x) -> str:
    return f"{x:g}"


def sharing_methods(parameter: str, methods: Sequence[str]) -> list[str]:
    """The methods of ``methods`` one default of ``parameter`` acts on (all for a config or loader value, the
    graph's or the EKF's for an options field)."""
    from graphnav.evaluation.methods import get_method
    where = PARAMETERS[parameter].where
    return [m for m in methods if where in ("config", "load") or get_method(m).family == where]


def report(results: Sequence[dict]) -> str:
    """Markdown: per parameter and method the current default, the per-fold choices, in-fold and
    out-of-fold mean NEES and VRMSE, and the value chosen on all trajectories."""
    lines = ["| parameter | method | chosen by | default: NEES / VRMSE | per-fold choice | in-fold NEES / VRMSE | "
             "out-of-fold NEES (max) / VRMSE | 3-missing out-of-fold NEES / window VRMSE | chosen on all |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        d = r.get("default") or {}
        miss = r["out_of_fold_by_scenario"].get("3-missing", {})
        lines.append(
            f"| {r['parameter']} | {r['method']} | {', '.join(r.get('chosen_by', [r['method']]))} | "
            f"{_g(d['value']) + ': ' + _f(d['nees']) + ' / ' + _f(d['vrmse'], 4) if d else '-'} | "
            f"{', '.join(_g(f['value']) for f in r['folds'])} | "
            f"{_f(r['in_fold']['nees'])} / {_f(r['in_fold']['vrmse'], 4)} | "
            f"{_f(r['out_of_fold']['nees'])} ({_f(r['out_of_fold']['nees_max'])}) / "
            f"{_f(r['out_of_fold']['vrmse'], 4)} | "
            f"{_f(miss.get('nees'))} / {_f(miss.get('vrmse_window'), 4)} | {_g(r['all_data_value'])} |")
    return "\n".join(lines) + "\n"


def per_trajectory_table(table: Sequence[dict], parameter: str, methods: Sequence[str],
                         scenario: str = "none") -> str:
    """Markdown: mission NEES per trajectory (rows) and value (columns) for each method."""
    from graphnav.evaluation.bench import natural_key
    spec = PARAMETERS[parameter]
    trajs = sorted({r["trajectory"] for r in table if r["parameter"] == parameter}, key=natural_key)
    lines = []
    for m in methods:
        lines += [f"{m}, {parameter} ({spec.unit}), mission NEES / VRMSE per trajectory, {scenario}:", "",
                  "| trajectory | " + " | ".join(_g(v) for v in spec.grid) + " |",
                  "| --- |" + " --- |" * len(spec.grid)]
        for t in trajs:
            cells = []
            for v in spec.grid:
                s = score_values(table, m, parameter, [t], scenario).get(float(v))
                cells.append("-" if s is None else f"{_f(s['nees'], 1)} / {_f(s['vrmse'], 3)}")
            lines.append(f"| {t} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)
