"""Simulated missions with exact ground truth, and IMU error injection."""
from graphnav.core.lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "simulate": ("simulate_mission", "SurfacingProfile"),
    "imu_errors": ("corrupt_imu",),
}
__all__, __getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
