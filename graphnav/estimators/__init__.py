"""The estimators: strapdown INS, the error-state EKF, the factor graph, and the streaming Navigator over them."""
from graphnav.core.lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "navigator": ("Navigator", "NavigatorOptions"),
    "ekf": ("EkfOptions",),
    "graph": ("GraphOptions",),
    "types": ("InitialState", "EpochEstimate"),
    "align": ("AlignOptions",),
    "options": ("PriorOptions", "RegressedScreeningOptions"),
    "health": ("HealthOptions",),
    "runs": ("run_ekf", "run_graph", "iterate_graph"),
    "dead_reckoning": ("dvl_dead_reckoning",),
}
__all__, __getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
