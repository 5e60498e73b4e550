"""Sensor calibration from recorded data: IMU axes, DVL lever arm and mounting, time offsets, noise densities.

``prepare(mission)`` (module :mod:`graphnav.calibration.preparation`) is the step between reading and estimating:
the IMU axes, time offsets and clocks a read mission needs, estimated from its data.

``calibrate(mission)`` (module :mod:`graphnav.calibration.calibrate`, whose name it shares) runs them all;
``combine(results, names)`` (module :mod:`graphnav.calibration.combine`) combines several missions' calibrations with
the spread between them."""
from graphnav.core.lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "preparation": ("prepare",),
    "result": ("CalibrationResult",),
    "calibrate": ("calibrate_with_gt",),
    "combine": ("random_effects", "CombinedCalibration"),
    "without_gt": ("calibrate_with_graph",),
    "axes": ("detect_imu_axis_signs",),
    "clock": ("estimate_dvl_clock_offset", "align_stream_clocks"),
    "noise": ("identify", "NoiseEstimate"),
}
__all__, __getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
