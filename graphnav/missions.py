"""The mission a user works on, in one call: a recorded one read (:mod:`graphnav.io`) and prepared
(:func:`graphnav.calibration.preparation.prepare`), or the simulated default (:mod:`graphnav.sim`).

The ``graphnav`` commands do the two steps themselves (``commands.common.recorded_mission``); these are the
conveniences a script calls (``graphnav.load_mission``)."""
from __future__ import annotations

from pathlib import Path

from graphnav.calibration.preparation import AUTO
from graphnav.calibration.preparation import prepare as prepare_mission
from graphnav.core.mission import Mission
from graphnav.io.bags import warn_depth_turn_unconfirmed


def load_mission(data: str | Path | None = None, config_path: str | Path | None = None,
                 topics: dict[str, str] | None = None, *, prepare: bool = True, imu_axis_signs=AUTO,
                 gt_time_offset_s: float | str = AUTO, dvl_time_offset_s: float | str = AUTO, **kwargs) -> Mission:
    """The mission of ``data``: :func:`graphnav.io.loaders.read_mission` then, with ``prepare`` (default),
    :func:`graphnav.calibration.preparation.prepare` with the axis signs and time offsets given here (``"auto"``: the
    configuration's, else estimated); ``data`` None is the simulated default (:func:`simulated_mission`).

    ``kwargs``: passed to :func:`graphnav.sim.simulate.simulate_mission` when ``data`` is None, or to
    :func:`graphnav.io.loaders.read_akit_mission` (e.g. ``beam_seed``)."""
    if data is None:
        return simulated_mission(config_path, **kwargs)
    from graphnav.io.loaders import read_mission
    mission = read_mission(data, config_path, topics, **kwargs)
    if not prepare:
        warn_depth_turn_unconfirmed(mission)
        return mission
    return prepare_mission(mission, imu_axis_signs=imu_axis_signs, gt_time_offset_s=gt_time_offset_s,
                           dvl_time_offset_s=dvl_time_offset_s)


def load_akit(folder: str | Path, *, imu_axis_signs=AUTO, dvl_time_offset_s: float | str = AUTO,
              gt_time_offset_s: float | str = AUTO, **kwargs) -> Mission:
    """One A-KIT trajectory folder read (:func:`graphnav.io.loaders.read_akit_mission`, ``kwargs``: lever arm,
    beam seed, config, name, stamps, IMU position) and prepared with the axis signs and offsets given here."""
    from graphnav.io.loaders import read_akit_mission
    return prepare_mission(read_akit_mission(folder, **kwargs), imu_axis_signs=imu_axis_signs,
                           gt_time_offset_s=gt_time_offset_s, dvl_time_offset_s=dvl_time_offset_s)


def simulated_mission(config_path: str | Path | None = None, **sim_kwargs) -> Mission:
    """The simulated default mission (:func:`graphnav.sim.simulate.simulate_mission`, ``sim_kwargs``: e.g.
    ``duration_s``, ``seed``), with the keys a configuration file sets laid over the simulator's defaults."""
    from graphnav.core.config import read_config
    from graphnav.io.loaders import warn_replaced
    from graphnav.sim.simulate import default_config, simulate_mission
    overrides = read_config(config_path) if config_path else None
    if overrides:
        sim_kwargs.setdefault("config", overrides.over(default_config()))
    mission = simulate_mission(**sim_kwargs)
    if overrides:
        warn_replaced(overrides, mission)
    return mission
