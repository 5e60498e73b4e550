"""Scoring and comparing estimators: metrics, the method registry, the benchmark, fault injection, plots."""
from graphnav.core.lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "methods": ("METHODS", "Method", "run_method"),
    "metrics": ("vrmse", "vrte", "nees_velocity", "horizontal_position_error"),
    "bench": ("run_bench", "load_results"),
}
__all__, __getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
