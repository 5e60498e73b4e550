"""Simulated missions with exact ground truth, and IMU error injection."""
from graphnav._lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "simulate_mission": "graphnav.sim.simulate",
    "corrupt_imu": "graphnav.sim.imu_errors",
}

__all__ = list(_PUBLIC)
__getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
