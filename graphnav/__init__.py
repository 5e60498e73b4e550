"""graphnav: factor-graph INS/DVL navigation for AUVs.

The public API (the names of ``__all__``, each imported on first use so that ``import graphnav`` stays light):

- :class:`Navigator`, :class:`NavigatorOptions`: the streaming backend a vehicle runs
  (:mod:`graphnav.estimators.navigator`); :class:`GraphOptions`, :class:`EkfOptions` configure its estimators.
- :class:`Mission`, :class:`SensorConfig`, :class:`NavSolution`: the data model (:mod:`graphnav.core`);
  :func:`load_mission` reads a recorded one (A-KIT folder, ROS 1/2 bag, PD0, CSV log) and prepares it
  (:func:`prepare`: IMU axes, time offsets and clocks estimated from the data), :func:`simulate_mission`
  makes one; :func:`read_dvl` reads a DVL log on its own (PD0/VmDAS in every RDI frame, a CSV of DVL
  velocities) into a :class:`~graphnav.core.dvl_log.DvlLog`.
- :func:`run_method` runs a method of :data:`METHODS` (the registry: LC, TC, ..., Graph-HN-batch) on a mission.
- :class:`DataError`, :class:`ConfigError`: what bad input and bad settings raise.

Each subpackage (``core``, ``io``, ``sim``, ``estimators``, ``calibration``, ``evaluation``) lists its own API
in its ``__all__``.
"""
from graphnav.core.lazy import lazy_exports as _lazy_exports

__version__ = "0.1.0"

_PUBLIC = {
    "estimators.navigator": ("Navigator", "NavigatorOptions"),
    "core.mission": ("Mission",),
    "core.config": ("SensorConfig",),
    "core.solution": ("NavSolution",),
    "missions": ("load_mission",),
    "calibration.preparation": ("prepare",),
    "io.dvl_files": ("read_dvl",),
    "sim.simulate": ("simulate_mission",),
    "estimators.graph.options": ("GraphOptions",),
    "estimators.ekf": ("EkfOptions",),
    "evaluation.methods": ("run_method", "METHODS"),
    "core.errors": ("DataError", "ConfigError"),
}
_names, __getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
__all__ = [name for names in _PUBLIC.values() for name in names]
