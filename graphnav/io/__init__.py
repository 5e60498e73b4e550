"""Reading and writing: the real data sets and vehicle formats (CSV, ROS 2 bags, PD0, JSON-lines) and the outputs."""
from graphnav.core.lazy import lazy_exports as _lazy_exports

_PUBLIC = {
    "loaders": ("read_mission", "read_akit_mission"),
    "bags": ("load_bag", "write_odometry_bag"),
    "outputs": ("write_trajectory_csv", "read_trajectory_csv", "write_tum", "write_reference_tum", "read_tum",
                "write_json", "EpochCsvWriter", "write_pose_covariance_csv", "read_pose_covariance_csv"),
    "export": ("write_akit",),
    "streamio": ("StreamReader",),
    "dvl_files": ("read_dvl",),
    "inspect": ("describe",),
    "units": ("check_units",),
}
__all__, __getattr__, __dir__ = _lazy_exports(__name__, _PUBLIC)
