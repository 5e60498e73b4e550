"""The estimators: strapdown INS, the error-state EKF, the factor graph, and the streaming Navigator over them."""
from graphnav._lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "Navigator": "graphnav.estimators.navigator",
    "NavigatorOptions": "graphnav.estimators.navigator",
    "EkfOptions": "graphnav.estimators.ekf",
    "GraphOptions": "graphnav.estimators.graph",
    "InitialState": "graphnav.estimators.graph",
    "EpochEstimate": "graphnav.estimators.graph",
    "AlignOptions": "graphnav.estimators.align",
    "HealthOptions": "graphnav.estimators.health",
    "run_ekf": "graphnav.estimators.runs",
    "run_graph": "graphnav.estimators.runs",
    "iterate_graph": "graphnav.estimators.runs",
}

__all__ = list(_PUBLIC)
__getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
