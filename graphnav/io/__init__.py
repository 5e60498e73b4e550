"""Reading and writing: the real data sets and vehicle formats (CSV, ROS 2 bags, PD0, JSON-lines) and the outputs."""
from graphnav._lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "load_mission": "graphnav.io.loaders",
    "load_akit": "graphnav.io.loaders",
    "load_bag": "graphnav.io.bags",
    "write_odometry_bag": "graphnav.io.bags",
    "write_trajectory_csv": "graphnav.io.outputs",
    "read_trajectory_csv": "graphnav.io.outputs",
    "write_tum": "graphnav.io.outputs",
    "read_tum": "graphnav.io.outputs",
    "write_json": "graphnav.io.outputs",
    "EpochCsvWriter": "graphnav.io.outputs",
    "write_akit": "graphnav.io.export",
    "StreamReader": "graphnav.io.streamio",
}

__all__ = list(_PUBLIC)
__getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
