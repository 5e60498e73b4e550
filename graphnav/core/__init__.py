"""The data model every layer shares: mission, sensor configuration, solution, scenarios, frames and units."""
from graphnav.core.lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "mission": ("Mission", "ImuData", "DvlData", "DepthData", "HeadingData", "PositionFixData", "GroundTruth"),
    "config": ("SensorConfig", "ImuSpec", "DvlSpec"),
    "solution": ("NavSolution",),
    "errors": ("GraphnavError", "DataError", "ConfigError"),
    "scenarios": ("SCENARIOS", "Outage", "scenario_outage"),
    "dvl": ("DvlGeometry",),
    "earth": ("EarthModel",),
    "imu_stamps": ("increments_to_samples", "rates_to_samples"),
}
__all__, __getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
