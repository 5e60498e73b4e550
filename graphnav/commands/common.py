"""Helpers shared by the ``graphnav`` subcommands: the mission and initial-state options (``smooth``,
``online``), the mission they describe, the accuracy summary, plots and the printed summary, and the help
formatter of every command. Every command module imports these from here, none from another command.
"""
from __future__ import annotations

import argparse
import functools
from pathlib import Path

from graphnav.core.scenarios import SCENARIOS, scenario_outage, window_starts
from graphnav.estimators.health import EXIT_DIVERGED, run_health
from graphnav.evaluation.methods import METHODS, check_scenario


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Show defaults in --help, except the uninformative None/False/[] of optional paths, flags and lists."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.default == []:
            return action.help
        return super()._get_help_string(action)


def methods_help(names=None) -> str:
    """One line per method of the registry for ``--help``: its name and description."""
    return "; ".join(f"{n} - {METHODS[n].description}" for n in (names or METHODS))


def add_mission_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("mission")
    g.add_argument("--data", metavar="PATH",
                   help="trajectory folder in the published A-KIT layout (IMU_*.csv, DVL_*.csv, GT_*.csv), a ROS 2 "
                        "bag (.mcap, .db3 or bag folder), a PD0 file (.pd0/.000) or a CSV log with the column "
                        "map of --config; `smooth` also takes a folder of missions (TrajectoryN folders or "
                        "bags, as `bench --data` finds them); default: the simulated 400 s mission")
    g.add_argument("--topic", action="append", metavar="STREAM=TOPIC",
                   help="bags: read STREAM (imu, dvl, depth, gt) from TOPIC instead of the topic chosen by "
                        "message type (repeatable)")
    g.add_argument("--config", metavar="JSON", help="sensor configuration (e.g. from `graphnav calibrate`)")
    g.add_argument("--seed", type=int, default=0, help="simulator seed when --data is not given")
    g.add_argument("--duration", type=float, default=400.0, metavar="S",
                   help="simulated mission length in s when --data is not given")
    g.add_argument("--imu-grade", default="as-recorded", metavar="GRADE",
                   help="'as-recorded' or an IMU grade (tactical, mems) whose errors are added to "
                        "the recorded IMU, seeded, as in `graphnav bench`")
    g.add_argument("--scenario", default="none", choices=sorted(SCENARIOS),
                   help="inject a beam outage: 2-missing (beams 1, 3), 3-missing (only beam 2 left) or none "
                        "(data as recorded)")
    g.add_argument("--window-start", type=float, action="append", metavar="S",
                   help="start of an outage window in s (repeatable); default: windows spread over the "
                        "mission as in the benchmark (60 s in, then every window + 60 s)")
    g.add_argument("--window-s", type=float, default=30.0, metavar="S", help="outage window length")


def add_init_arguments(parser: argparse.ArgumentParser) -> None:
    """Where the estimator starts: the ground truth or an alignment from the sensors (shared with online)."""
    g = parser.add_argument_group("initial state")
    g.add_argument("--init", default="auto", choices=("auto", "gt", "sensors"),
                   help="the ground truth at the first ping (gt), an alignment from the sensors (sensors: "
                        "levelling, gyrocompassing or a heading record, DVL velocity), or gt when the data "
                        "has ground truth (auto)")
    g.add_argument("--initial-position", type=float, nargs=2, metavar=("LAT", "LON"),
                   help="with sensor alignment: the starting position, degrees (else a local origin)")
    g.add_argument("--initial-heading", type=float, metavar="DEG",
                   help="with sensor alignment: the starting heading, degrees (else gyrocompassing or the "
                        "first heading record)")
    g.add_argument("--heading-sigma", type=float, default=2.0, metavar="DEG",
                   help="1-sigma of --initial-heading, degrees")


def aligner_kwargs(args) -> dict:
    """The Aligner's keyword arguments from --initial-position / --initial-heading."""
    import math
    kw = {}
    if args.initial_position is not None:
        kw["initial_lla"] = (math.radians(args.initial_position[0]), math.radians(args.initial_position[1]), 0.0)
    if args.initial_heading is not None:
        kw["initial_heading_rad"] = math.radians(args.initial_heading)
        kw["heading_sigma_rad"] = math.radians(args.heading_sigma)
    return kw


def recorded_mission(args):
    """The mission of ``--data``/``--config`` as recorded, or the simulated one of ``--seed``/``--duration``."""
    from graphnav.io.loaders import load_mission
    if args.data is None:
        return load_mission(None, args.config, duration_s=args.duration, seed=args.seed)
    from graphnav.io.bags import parse_topics
    return load_mission(args.data, args.config, topics=parse_topics(getattr(args, "topic", None)))


def mission_from_args(args):
    """(mission with the IMU grade and outages applied, list of outages)."""
    from graphnav.evaluation.bench import degrade_imu
    mission = recorded_mission(args)
    if args.imu_grade != "as-recorded":
        import zlib
        mission = degrade_imu(mission, args.imu_grade, seed=zlib.crc32(mission.name.encode()) % 2**31)
    outages = []
    if check_scenario(args.scenario) != "none":
        starts = args.window_start or window_starts(mission.t0, mission.t1, args.window_s)
        outages = [scenario_outage(args.scenario, s, args.window_s) for s in starts]
        mission = mission.with_outage(*outages)
    return mission, outages


def accuracy_summary(sol, mission, outages) -> dict:
    """VRMSE over the mission and each outage window and the final horizontal position error (when GT)."""
    if mission.gt is None:
        return {"ground_truth": False}
    from graphnav.evaluation.metrics import horizontal_position_error, vrmse
    t_end = float(min(sol.t[-1], mission.gt.t[-1]))
    return {
        "ground_truth": True,
        "vrmse_mission_mps": float(vrmse(sol, mission.gt, mission.t0, mission.t1)),
        "windows": [{"start_s": o.start_s, "end_s": o.end_s, "missing_beams": [b + 1 for b in o.missing],
                     "vrmse_window_mps": float(vrmse(sol, mission.gt, o.start_s, o.end_s))} for o in outages],
        "final_horizontal_position_error_m": float(horizontal_position_error(sol, mission.gt, t_end)),
    }


def make_plots(out: Path, mission, solutions, outages, label: str) -> list[str]:
    from graphnav.evaluation import plots
    files = []
    if mission.gt is not None:
        files.append(plots.plot_trajectories(mission.gt, solutions, outages, out / "trajectory_ne.png",
                                             f"{mission.name}: {label}"))
        files.append(plots.plot_velocity_errors(mission.gt, solutions, outages, out / "velocity_error.png",
                                                f"{mission.name}: velocity error, {label}"))
    if any(s.cov_v_n is not None for s in solutions):
        files.append(plots.plot_velocity_std(solutions, outages, out / "velocity_std.png",
                                             f"{mission.name}: velocity std around the first window, {label}"))
    return [str(f) for f in files]


def print_summary(summary: dict, file=None) -> None:
    """Print a command's summary (to ``file``, default standard output)."""
    out = functools.partial(print, file=file)
    from graphnav.estimators.health import health_line
    acc = summary.get("accuracy", {})
    mode = f" ({summary['mode']})" if summary.get("mode") else ""
    out(f"{summary['method']}{mode} on {summary['mission']}: {summary['epochs']} epochs, {summary['duration_s']:.0f} s "
          f"of data in {summary['runtime_s']:.2f} s ({summary['realtime_factor']:.0f}x real time)")
    init = summary.get("initialisation") or {}
    if "heading_source" in init:
        done = init.get("completed_t")
        out(f"  initial state aligned from the sensors at t = {init['t']:.1f} s (heading: {init['heading_source']}"
            + (f"; alignment completed at t = {done:.1f} s)" if done is not None else ")"))
    refused = summary.get("refused")
    if refused:
        out(f"  refused samples (stream: field: count): {refused}")
    at_load = {k: v["refused"] for k, v in (summary.get("input_streams") or {}).items() if v.get("refused")}
    if at_load:
        out(f"  refused at load (stream: reason: count): {at_load}")
    for stream, entry in (summary.get("input_streams") or {}).items():
        for note in entry.get("notes", []):
            out(f"  {stream}: {note}")
    if acc.get("ground_truth"):
        out(f"  VRMSE mission {acc['vrmse_mission_mps']:.4f} m/s, final horizontal position error "
              f"{acc['final_horizontal_position_error_m']:.2f} m")
        for w in acc["windows"]:
            out(f"  window {w['start_s']:.0f}-{w['end_s']:.0f} s (beams {w['missing_beams']} missing): "
                  f"VRMSE {w['vrmse_window_mps']:.4f} m/s")
    for name, other in summary.get("compared", {}).items():
        if other.get("ground_truth"):
            windows = ", ".join(f"{w['vrmse_window_mps']:.4f}" for w in other["windows"])
            out(f"  compared {name}: VRMSE mission {other['vrmse_mission_mps']:.4f} m/s"
                  + (f", windows {windows} m/s" if windows else ""))
        if other.get("health") and other["health"].get("state", "ok") != "ok":
            out(f"  compared {name} {health_line(other['health'])}")
    line = health_line(summary.get("health"))
    if line:
        out(f"  {line}")
    timing = summary.get("update_timing")
    if timing:
        out(f"  solver update per keyframe: median {timing['median_ms']:.1f} ms, p99 {timing['p99_ms']:.1f} ms, "
              f"max {timing['max_ms']:.1f} ms")
    for name, path in summary.get("files", {}).items():
        out(f"  {name}: {path}")


# --- health of a run and the exit status -------------------------------------------------------------------
EXIT_EPILOG = ("exit status: 0 the run finished and its estimator was healthy at the end (ok or degraded: see "
               "'health' in summary.json and the health column); 1 an error in the input or the options (the message "
               "names the file, line and field; also when more than half of a stream was refused); 2 a usage error; "
               f"{EXIT_DIVERGED} the estimator DIVERGED and had not recovered at the end (the trajectory is written but "
               "must not be trusted); 130 interrupted")


def run_health_record(sol_info: dict, mission=None) -> dict:
    """The ``health`` of a summary: the NIS monitor's record plus ``state`` (ok / degraded / diverged) and
    ``why`` (:func:`graphnav.estimators.health.run_health`) over the run's info and the loader's streams."""
    health = dict(sol_info.get("health") or {})
    streams = (mission.meta.get("streams") if mission is not None else None) or None
    return {**health, **run_health(health, sol_info, streams)}


def exit_status(summary: dict) -> int:
    """:data:`EXIT_DIVERGED` when the run's health state is diverged, else 0."""
    return EXIT_DIVERGED if (summary.get("health") or {}).get("state") == "diverged" else 0

