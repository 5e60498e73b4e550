"""The mission a user works on, in one call: a recorded one read (:mod:`graphnav.io`) and prepared
(:func:`graphnav.calibration.preparation.prepare`), or the simulated default (:mod:`graphnav.sim`).

The ``graphnav`` commands do the two steps themselves (``commands.common.recorded_mission``); these are the
conveniences a script calls (``graphnav.load_mission``)."""
from __future__ import annotations

import warnings
from pathlib import Path

from graphnav.calibration.preparation import AUTO
from graphnav.calibration.preparation import prepare as prepare_mission
from graphnav.core.mission import Mission
from graphnav.core.streams import add_note


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
        _warn_depth_turn_unconfirmed(mission)
        return mission
    return prepare_mission(mission, imu_axis_signs=imu_axis_signs, gt_time_offset_s=gt_time_offset_s,
                           dvl_time_offset_s=dvl_time_offset_s)


def _warn_depth_turn_unconfirmed(mission: Mission) -> None:
    """Warn about and note a bag's depth topic the reader turned positive down (read as positive up,
    :func:`graphnav.io.bag_convert.turned_positive_up`) when the mission is not prepared: only the prepare step's
    vertical motion confirms the turn. Kept turned: as read, the range check would have dropped every sample."""
    if not mission.meta.get("prepare", {}).get("depth_turned_up"):
        return
    text = ("read as depth positive up and turned positive down, unconfirmed: the mission is not prepared, and only "
            "the prepare step checks the turn against the vehicle's vertical motion (prepare it, or declare "
            "bag_topics.depth.positive)")
    warnings.warn(f"{mission.depth.source}, field 'data': {text}", RuntimeWarning, stacklevel=3)
    add_note(mission.meta, "depth", text)


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
