"""Bench cases: what runs (:class:`TrajectorySource`, :class:`BenchCase`, :func:`make_cases`) and the mission each case
runs on (:func:`load_source`, :func:`prepared_mission`: the mission at an IMU grade, :func:`degrade_imu`), with its
outage windows (:func:`case_windows`). See :mod:`graphnav.evaluation.bench` for the whole benchmark."""
from __future__ import annotations

import dataclasses
import functools
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from graphnav.core.config import imu_grade as imu_grade_spec
from graphnav.core.errors import ConfigError
from graphnav.core.mission import Mission
from graphnav.core.scenarios import window_starts
from graphnav.evaluation.methods import BENCH_METHODS, check_method, check_scenario


SCENARIO_NAMES: tuple[str, ...] = ("2-missing", "3-missing", "0-beams", "markov", "none")


IMU_GRADE_CHOICES: tuple[str, ...] = ("as-recorded", "tactical", "mems")


@dataclass(frozen=True)
class TrajectorySource:
    """Where a trajectory comes from: a folder in the A-KIT layout, or the simulator (``folder=None``)."""

    name: str
    folder: str | None = None
    seed: int = 0
    duration_s: float = 400.0
    config_path: str | None = None


@dataclass(frozen=True)
class BenchCase:
    """One run: a method on a trajectory with a scenario's windows, at an IMU grade."""

    trajectory: TrajectorySource
    scenario: str
    imu_grade: str
    method: str
    window_s: float = 30.0
    max_windows: int | None = None
    save_dir: str | None = None  # keep the (down-sampled) solution here for the plots

    @property
    def key(self) -> tuple:
        return (self.trajectory.name, self.scenario, self.imu_grade, self.method, float(self.window_s))


def find_trajectories(data: str | None = None, sim_seeds: int = 1, sim_duration_s: float = 400.0,
                      config_path: str | None = None) -> list[TrajectorySource]:
    """The simulated default (``data=None``; one trajectory per seed), one mission (an A-KIT trajectory
    folder or a ROS 2 bag), or every mission under the folder ``data``: its A-KIT ``TrajectoryN`` folders,
    else its ROS 2 bags (bag folders or bare ``.mcap``/``.db3`` files)."""
    if data is None:
        return [TrajectorySource(f"sim-seed{s}", None, s, sim_duration_s, config_path) for s in range(sim_seeds)]
    from graphnav.io.bags import is_bag
    from graphnav.io.loaders import list_akit
    root = Path(data)
    if is_bag(root):
        return [TrajectorySource(root.stem if root.is_file() else root.name, str(root), 0, 0.0, config_path)]
    if not root.is_dir():
        raise ConfigError(f"--data {data}: not a folder")
    if any(root.glob("IMU_*.csv")):
        return [TrajectorySource(root.name, str(root), 0, 0.0, config_path)]
    found = [Path(f) for f in list_akit(root)] or sorted(p for p in root.iterdir() if is_bag(p))
    if not found:
        raise ConfigError(f"--data {data}: no trajectory folders (IMU_*.csv, DVL_*.csv, GT_*.csv) or ROS 2 "
                          "bags found")
    sources = [TrajectorySource(p.stem if p.is_file() else p.name, str(p), 0, 0.0, config_path) for p in found]
    names = [s.name for s in sources]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(f"--data {data}: several missions named {twice} (e.g. a bag folder and a bag file); "
                          "rename one")
    return sources


def mission_collection(data: str | None, config_path: str | None = None) -> list[TrajectorySource] | None:
    """The missions under ``data`` when it is a folder of missions (as :func:`find_trajectories` finds
    them), or None when ``data`` is one mission (a file, a bag, an A-KIT folder, a column-map CSV folder)
    or nothing (the simulated default); the loader then reads it or says why it cannot."""
    if data is None or not Path(data).is_dir():
        return None
    try:
        sources = find_trajectories(data, config_path=config_path)
    except ConfigError:
        return None
    if len(sources) == 1 and Path(sources[0].folder) == Path(data):
        return None
    return sources


def load_source(source: TrajectorySource) -> Mission:
    """The mission of a trajectory source, as recorded (or simulated at navigation grade)."""
    if source.folder is None:
        from graphnav.missions import simulated_mission
        return simulated_mission(source.config_path, duration_s=source.duration_s, seed=source.seed)
    from graphnav.calibration.preparation import prepare
    from graphnav.io.loaders import read_mission
    return prepare(read_mission(source.folder, source.config_path))


def degrade_imu(mission: Mission, grade: str, seed: int) -> Mission:
    """A copy of ``mission`` with ``grade``'s IMU errors added and the estimators' IMU model set to it."""
    from graphnav.sim.imu_errors import corrupt_imu
    spec = imu_grade_spec(grade)
    imu, _truth = corrupt_imu(mission.imu, spec, seed=seed)
    config = dataclasses.replace(mission.config, imu=spec)
    return dataclasses.replace(mission, imu=imu, config=config,
                               meta={**mission.meta, "imu_degraded_to": grade, "imu_degrade_seed": seed})


@functools.lru_cache(maxsize=4)
def prepared_mission(source: TrajectorySource, grade: str) -> Mission:
    """Mission for a trajectory at an IMU grade; cached per process (cases of one trajectory share it)."""
    mission = load_source(source)
    if mission.gt is None:
        raise ConfigError(f"trajectory {source.name} has no ground truth; the benchmark needs it")
    if grade == "as-recorded":
        return mission
    # The seed depends on the trajectory only, so every method and scenario sees the same IMU.
    return degrade_imu(mission, grade, seed=zlib.crc32(source.name.encode()) % 2**31)


def case_windows(mission: Mission, window_s: float, max_windows: int | None = None) -> list[float]:
    return window_starts(mission.t0, mission.t1, window_s=window_s, settle_s=60.0, gap_s=60.0,
                         max_windows=max_windows)


def make_cases(trajectories: list[TrajectorySource], scenarios=SCENARIO_NAMES, grades=IMU_GRADE_CHOICES,
               methods=BENCH_METHODS, window_s: float | list[float] = 30.0, max_windows: int | None = None,
               save_dir: str | None = None, save_first: int = 1) -> list[BenchCase]:
    """All cases, grouped by trajectory then grade (so a worker's mission cache is reused); solutions of the
    first ``save_first`` trajectories are kept in ``save_dir`` for the plots (first window length only).
    ``window_s`` may be a list of window lengths (s): every case is run once per length."""
    windows = [float(w) for w in np.atleast_1d(window_s)]
    if any(w <= 0 for w in windows):
        raise ConfigError(f"window lengths must be > 0 s, got {windows}")
    for s in scenarios:
        check_scenario(s)
    for m in methods:
        check_method(m)
    for g in grades:
        if g != "as-recorded":
            try:
                imu_grade_spec(g)
            except ConfigError as exc:
                raise ConfigError(f"{exc} (or 'as-recorded')") from None
    return [BenchCase(traj, sc, g, m, w, max_windows, save_dir if i < save_first and w == windows[0] else None)
            for i, traj in enumerate(trajectories) for g in grades for w in windows for sc in scenarios
            for m in methods]
