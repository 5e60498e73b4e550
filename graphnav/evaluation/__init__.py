"""Scoring and comparing estimators: metrics, the method registry, the benchmark, fault injection, plots."""
from graphnav._lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "METHODS": "graphnav.evaluation.methods",
    "Method": "graphnav.evaluation.methods",
    "run_method": "graphnav.evaluation.methods",
    "vrmse": "graphnav.evaluation.metrics",
    "vrte": "graphnav.evaluation.metrics",
    "nees_velocity": "graphnav.evaluation.metrics",
    "horizontal_position_error": "graphnav.evaluation.metrics",
    "run_bench": "graphnav.evaluation.bench",
    "load_results": "graphnav.evaluation.bench",
}

__all__ = list(_PUBLIC)
__getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
