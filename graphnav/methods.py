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
=================  =========  ==========================================================

The average estimator uses the past ``n_past=3`` pings for ``2-missing`` and 5 for ``3-missing`` and
``none``. The network completer is ``graphnav.nets.load_completer(missing=2|3)`` (``none`` uses
``load_completer("auto")``, the networks where trained and the average estimator for other patterns, only
consulted if beams drop out); when its weights or module are missing the
average estimator stands in, with a warning, and the solution's ``info["completer"]`` says so.
"""
from __future__ import annotations

import functools
import time
import warnings

from .errors import ConfigError
from .mission import Mission
from .scenarios import SCENARIOS
from .solution import NavSolution

EKF_METHODS: tuple[str, ...] = ("LC", "TC", "Average-LC", "Average-TC", "HNLC", "HNTC")
GRAPH_METHODS: tuple[str, ...] = ("Graph-TC", "Graph-HN", "Graph-HN-batch")
#: Every method, in the order tables and plots show them.
METHODS: tuple[str, ...] = EKF_METHODS + GRAPH_METHODS

#: Past pings the average estimator uses per scenario.
AVERAGE_N_PAST: dict[str, int] = {"2-missing": 3, "3-missing": 5, "none": 5}
#: Which network (number of missing beams it was trained for) serves each scenario.
NETWORK_FOR_SCENARIO: dict[str, int | str] = {"2-missing": 2, "3-missing": 3, "none": "auto"}


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
    its options object (:class:`graphnav.ekf.EkfOptions`, :class:`graphnav.graph.GraphOptions`) or a dict
    of its fields. Graph methods only: ``callback`` receives each filtered
    :class:`graphnav.graph.EpochEstimate` as it is produced, and ``mode`` is ``"online"`` (ISAM2) or
    ``"fixed-lag"`` (lag ``options.lag_s``). ``init``: the initial state from the ground truth (``"gt"``),
    from the sensors (``"sensors"``, with ``aligner_kwargs`` such as ``initial_heading_rad``), or ``"auto"``
    (ground truth when the mission has it).
    ``runtime_s`` is the estimator's wall time; ``info["completer"]`` names the completer.
    """
    described = "given"
    if completer is None:
        completer, described = completer_for(method, scenario, mission.config.dvl.beam_noise_std)
    else:
        check_method(method)
    start = time.perf_counter()
    if method in EKF_METHODS:
        from graphnav.ekf import EkfOptions, run_ekf
        if isinstance(options, dict):
            options = EkfOptions(**options)
        sol = run_ekf(mission, method, completer=completer, options=options, init=init,
                      aligner_kwargs=aligner_kwargs)
    else:
        from graphnav.graph import GraphOptions, run_graph
        if isinstance(options, dict):
            options = GraphOptions(**options)
        sol = run_graph(mission, method, completer=completer, options=options, callback=callback, mode=mode,
                        init=init, aligner_kwargs=aligner_kwargs)
    wall = time.perf_counter() - start
    if not sol.runtime_s == sol.runtime_s:  # NaN: the estimator did not time itself
        sol.runtime_s = wall
    sol.info = {**sol.info, "completer": described, "scenario": scenario}
    return sol
