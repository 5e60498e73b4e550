"""The one place that maps a method name and a beam-outage scenario to an estimator and its completer.

Method names (used in results, reports and on the command line):

=================  =========  ==========================================================
method             estimator  completer
=================  =========  ==========================================================
LC, TC             EKF        none (fewer than 3 beams: LC coasts on the IMU)
Average-LC/-TC     EKF        :class:`graphnav.nets.AverageCompleter`
HNLC, HNTC         EKF        the network completer for the scenario
Graph-TC           graph      none (measured beams only, ISAM2 filtered output)
Graph-HN           graph      the network completer (ISAM2 filtered output)
Graph-HN-batch     graph      the network completer (batch smoothed)
Graph-MP           graph      none; model-aided motion prior (body-velocity random walk, small
                              heave) at keyframes with fewer than 3 measured beams
=================  =========  ==========================================================

The average estimator uses the past ``n_past=3`` pings for ``2-missing`` and 5 for the other scenarios.
``0-beams`` (total DVL outage) and ``markov`` (random dropouts) use ``load_completer("auto")``: the networks
for the patterns they were trained on, the average estimator for the others -- with no beam measured the
networks do not apply, so in a total outage the hybrid's completion is the average estimator's constant-beam
extrapolation unless the graph's ``motion_prior`` replaces it (:data:`GRAPH_HN_OPTIONS`).
The network completer is ``graphnav.nets.load_completer(missing=2|3)`` (``none`` uses
``load_completer("auto")``, the networks where trained and the average estimator for other patterns, only
consulted if beams drop out); when its weights or module are missing the
average estimator stands in, with a warning, and the solution's ``info["completer"]`` says so.
"""
from __future__ import annotations

import functools
import time
import warnings

from graphnav.core.errors import ConfigError
from graphnav.core.mission import Mission
from graphnav.core.scenarios import SCENARIOS
from graphnav.core.solution import NavSolution

EKF_METHODS: tuple[str, ...] = ("LC", "TC", "Average-LC", "Average-TC", "HNLC", "HNTC")
GRAPH_METHODS: tuple[str, ...] = ("Graph-TC", "Graph-HN", "Graph-HN-batch", "Graph-MP")
#: Every method, in the order tables and plots show them.
METHODS: tuple[str, ...] = EKF_METHODS + GRAPH_METHODS

#: Past pings the average estimator uses per scenario.
AVERAGE_N_PAST: dict[str, int] = {"2-missing": 3, "3-missing": 5, "none": 5, "0-beams": 5, "markov": 5}
#: Which network (number of missing beams it was trained for) serves each scenario.
NETWORK_FOR_SCENARIO: dict[str, int | str] = {"2-missing": 2, "3-missing": 3, "none": "auto", "0-beams": "auto",
                                              "markov": "auto"}
#: Graph settings of the hybrid graph methods (Graph-HN, Graph-HN-batch) on top of the GraphOptions defaults.
#: Regressed beams are screened against the graph's prediction (see graphnav.estimators.graph.regressed): their error is
#: taken as correlated with the prediction's (rho = 0.5: both come from the same past pings) and their sigma is
#: raised to what the innovation shows. Measured with scripts/regressed_candidates.py (numbers in the module
#: docstring of graphnav.estimators.graph.regressed and in the issue-13 note).
#: In total outages the screened completer (average estimator) stays, not the motion prior: the prior was
#: 1-17 % better with the tactical / MEMS IMU in 60-120 s total outages but 4-29 % worse with the recorded
#: navigation-grade IMU (Trajectory2, 6, 10; scripts/regressed_candidates.py, candidate "HN ... MP-total").
GRAPH_HN_OPTIONS: dict = {"regressed_correlation": 0.5, "regressed_adaptive": True}
#: Graph settings of Graph-MP: the motion prior at keyframes with fewer than 3 measured beams. The densities
#: are 4x the median 1-s body-velocity changes of the A-KIT ground truth and the heave sigma 0.2 m/s (5x its
#: spread): tighter values (1x, heave 0.05 m/s) made Graph-MP 1.35x Graph-TC on the real data (the vehicle
#: manoeuvres: 99th percentile of the 1-s sway change 0.47 m/s, and a heave prior treated as white pulls the
#: pitch, whose error the gravity projection turns into horizontal velocity drift).
#: EKF settings of the hybrid EKF methods (Average-LC/-TC, HNLC, HNTC): the same screening of completed beams
#: against the filter's own prediction (graphnav.estimators.ekf.ErrorStateEkf.screen_regressed). Without it a
#: 30 s outage inside a manoeuvre made the completions wrong by 2.3-3.7x their sigma (RMS 0.31-0.46 m/s) and
#: pulled the filter to 0.53-0.78 m/s window VRMSE (scripts/start_sweep.py; numbers in the issue-12 note).
EKF_HYBRID_OPTIONS: dict = dict(GRAPH_HN_OPTIONS)
GRAPH_MP_OPTIONS: dict = {"motion_prior": "partial", "motion_prior_rw": (0.2, 0.32, 0.12),
                          "motion_prior_heave_sigma": 0.2}


def check_method(method: str) -> str:
    """Return ``method`` or raise :class:`ConfigError` listing the valid names."""
    if method not in METHODS:
        raise ConfigError(f"unknown method '{method}'; choose from {', '.join(METHODS)}")
    return method


def check_scenario(scenario: str) -> str:
    if scenario not in SCENARIOS:
        raise ConfigError(f"unknown scenario '{scenario}'; choose from {', '.join(SCENARIOS)}")
    return scenario


def baseline_of(method: str) -> str:
    """The classical baseline a method is compared with: LC for the loosely coupled family, TC otherwise."""
    return "LC" if method.endswith("LC") else "TC"


def average_of(method: str) -> str:
    """The average-estimator method a method is compared with (Average-LC or Average-TC)."""
    return "Average-LC" if method.endswith("LC") else "Average-TC"


def uses_network(method: str) -> bool:
    return method.startswith("HN") or method.startswith("Graph-HN")


def average_completer(scenario: str, noise_std: float = 0.042):
    """The paper's average estimator with the scenario's ``n_past``."""
    from graphnav.nets import AverageCompleter
    return AverageCompleter(n_past=AVERAGE_N_PAST[check_scenario(scenario)], noise_std=noise_std)


@functools.lru_cache(maxsize=None)
def _network(missing):
    """Load a network once per process (loading torch weights costs far more than a completion)."""
    from graphnav import nets
    return nets.load_completer(missing=missing)


def network_completer(scenario: str, noise_std: float = 0.042):
    """(completer, description): the scenario's network, or the average estimator when it cannot be loaded."""
    missing = NETWORK_FOR_SCENARIO[check_scenario(scenario)]
    try:
        return _network(missing), f"network(missing={missing})"
    except (ImportError, AttributeError, OSError, ValueError, RuntimeError, KeyError) as exc:
        warnings.warn(f"network completer for {missing} missing beams unavailable ({exc}); "
                      f"using the average estimator instead", RuntimeWarning, stacklevel=2)
        return average_completer(scenario, noise_std), f"average(n_past={AVERAGE_N_PAST[scenario]}) fallback"


def completer_for(method: str, scenario: str, noise_std: float = 0.042):
    """(completer or None, description) for a method in a scenario (see the module table)."""
    check_method(method)
    check_scenario(scenario)
    if method.startswith("Average-"):
        return average_completer(scenario, noise_std), f"average(n_past={AVERAGE_N_PAST[scenario]})"
    if uses_network(method):
        return network_completer(scenario, noise_std)
    return None, "none"


def run_method(mission: Mission, method: str, scenario: str = "none", *, completer=None,
               options=None, callback=None, mode: str = "online", init: str = "auto",
               aligner_kwargs: dict | None = None) -> NavSolution:
    """Run one method on a mission and return its :class:`NavSolution`.

    The scenario only chooses the completer (the outage itself is already in ``mission``'s valid mask,
    see :meth:`Mission.with_outage`). ``completer`` overrides the choice. ``options`` go to the estimator:
    its options object (:class:`graphnav.estimators.ekf.EkfOptions`, :class:`graphnav.estimators.graph.GraphOptions`) or a dict
    of its fields. Graph methods only: ``callback`` receives each filtered
    :class:`graphnav.estimators.graph.EpochEstimate` as it is produced, and ``mode`` is ``"online"`` (ISAM2) or
    ``"fixed-lag"`` (lag ``options.lag_s``). ``init``: the initial state from the ground truth (``"gt"``),
    from the sensors (``"sensors"``, with ``aligner_kwargs`` such as ``initial_heading_rad``), or ``"auto"``
    (ground truth when the mission has it).
    ``runtime_s`` is the estimator's wall time; ``info["completer"]`` names the completer and, for a network
    completer, ``info["completer_fallbacks"]`` counts the pings it left to the average estimator
    (``{"envelope": inputs outside its training envelope, "pattern": a pattern it was not trained for}``).
    """
    described = "given"
    if completer is None:
        completer, described = completer_for(method, scenario, mission.config.dvl.beam_noise_std)
    else:
        check_method(method)
    fallbacks_before = dict(getattr(completer, "fallbacks", {}))
    start = time.perf_counter()
    if method in EKF_METHODS:
        from graphnav.estimators.ekf import EkfOptions
        from graphnav.estimators.runs import run_ekf
        if options is None or isinstance(options, dict):
            defaults = EKF_HYBRID_OPTIONS if method not in ("LC", "TC") else {}
            options = EkfOptions(**{**defaults, **(options or {})})
        sol = run_ekf(mission, method, completer=completer, options=options, init=init,
                      aligner_kwargs=aligner_kwargs)
    else:
        from graphnav.estimators.graph import GraphOptions
        from graphnav.estimators.runs import run_graph
        defaults = GRAPH_MP_OPTIONS if method == "Graph-MP" else (GRAPH_HN_OPTIONS if uses_network(method) else {})
        if options is None or isinstance(options, dict):
            options = GraphOptions(**{**defaults, **(options or {})})
        # Graph-MP is Graph-TC (measured beams only) with the motion prior switched on
        sol = run_graph(mission, "Graph-TC" if method == "Graph-MP" else method, completer=completer,
                        options=options, callback=callback, mode=mode, init=init, aligner_kwargs=aligner_kwargs)
        sol.method = method
    wall = time.perf_counter() - start
    if not sol.runtime_s == sol.runtime_s:  # NaN: the estimator did not time itself
        sol.runtime_s = wall
    sol.info = {**sol.info, "completer": described, "scenario": scenario}
    if fallbacks_before:
        counts = {k: completer.fallbacks[k] - n for k, n in fallbacks_before.items()}
        sol.info["completer_fallbacks"] = counts
        if any(counts.values()):
            warnings.warn(f"{method}: the average estimator filled {counts['envelope']} ping(s) whose inputs left "
                          f"the network's training envelope and {counts['pattern']} with a missing-beam pattern "
                          f"the network was not trained for", RuntimeWarning, stacklevel=2)
    return sol
