"""The data model every layer shares: mission, sensor configuration, solution, scenarios, frames and units."""
from graphnav._lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "Mission": "graphnav.core.mission",
    "ImuData": "graphnav.core.mission",
    "DvlData": "graphnav.core.mission",
    "DepthData": "graphnav.core.mission",
    "GroundTruth": "graphnav.core.mission",
    "SensorConfig": "graphnav.core.config",
    "ImuSpec": "graphnav.core.config",
    "DvlSpec": "graphnav.core.config",
    "NavSolution": "graphnav.core.solution",
    "GraphnavError": "graphnav.core.errors",
    "DataError": "graphnav.core.errors",
    "ConfigError": "graphnav.core.errors",
    "SCENARIOS": "graphnav.core.scenarios",
    "Outage": "graphnav.core.scenarios",
    "scenario_outage": "graphnav.core.scenarios",
    "DvlGeometry": "graphnav.core.dvl",
}

__all__ = list(_PUBLIC)
__getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
