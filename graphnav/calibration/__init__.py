"""Sensor calibration from recorded data: IMU axes, DVL lever arm and mounting, time offsets, noise densities.

``calibrate(mission)`` (module :mod:`graphnav.calibration.calibrate`, whose name it shares) runs them all."""
from graphnav._lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "CalibrationResult": "graphnav.calibration.result",
    "calibrate_with_gt": "graphnav.calibration.calibrate",
    "calibrate_with_graph": "graphnav.calibration.without_gt",
    "detect_imu_axis_signs": "graphnav.calibration.axes",
    "identify": "graphnav.calibration.noise",
    "NoiseEstimate": "graphnav.calibration.noise",
}

__all__ = list(_PUBLIC)
__getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
