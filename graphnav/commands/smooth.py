"""``graphnav smooth``: batch-smooth a mission and write the trajectory (CSV, TUM), a JSON summary and plots;
or every mission of a folder of missions (:func:`run_folder`), in parallel or on a Dask cluster, with one
``results.json`` over all of them.

Also home of the mission options shared with ``graphnav online`` (data, configuration, IMU grade and an
optional injected beam outage).
"""
from __future__ import annotations

import argparse
import functools
import time
from pathlib import Path

from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import SCENARIOS, scenario_outage, window_starts
from graphnav.evaluation.methods import METHODS, check_scenario


# --- options shared with `graphnav online` and `graphnav bench` ------------------------------------------
class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Show defaults in --help, except the uninformative None/False/[] of optional paths, flags and lists."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.default == []:
            return action.help
        return super()._get_help_string(action)


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
        if other.get("health") and not other["health"]["ok"]:
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


# --- the command ----------------------------------------------------------------------------------------
def register(subparsers) -> None:
    p = subparsers.add_parser(
        "smooth", help="batch-smooth a mission or a folder of missions (Graph-HN-batch); write CSV, TUM, JSON "
                       "summary and plots",
        description="Batch-smooth a whole mission with the factor graph (Levenberg-Marquardt over all "
                    "keyframes, regressed beams as weak factors) and write OUT/trajectory.csv, "
                    "OUT/trajectory.tum (for evo; also OUT/groundtruth.tum when the mission has GT), "
                    "OUT/summary.json and PNG plots. When --data is a folder of missions (A-KIT TrajectoryN "
                    "folders or ROS 2 bags), smooth each one with the same options into OUT/<mission>/ and "
                    "keep OUT/results.json (one record per mission, rewritten as each finishes) -- in "
                    "--jobs processes or on a Dask cluster (--scheduler), resumable with --resume.",
        formatter_class=HelpFormatter)
    add_mission_arguments(p)
    add_init_arguments(p)
    p.add_argument("--out", default="out/smooth", metavar="DIR", help="output folder")
    p.add_argument("--method", default="Graph-HN-batch", choices=METHODS, help="estimator to run")
    p.add_argument("--compare", nargs="*", default=[], choices=METHODS, metavar="METHOD",
                   help="also run these methods and draw them in the plots (e.g. HNTC Graph-HN)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--bag", choices=("none", "mcap", "sqlite3"), default="none",
                   help="also write the estimates as nav_msgs/Odometry with covariance in the ROS 2 bag "
                        "OUT/trajectory_bag (REP-103 frames; needs graphnav[ros])")
    g = p.add_argument_group("folder of missions")
    g.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="smooth N missions at once in worker processes (1 = one after the other in this process)")
    g.add_argument("--scheduler", metavar="ADDRESS|local",
                   help="smooth the missions on a Dask cluster (dask.distributed): a scheduler address such as "
                        "tcp://10.0.0.5:8786, or 'local' for a LocalCluster of --jobs worker processes; same "
                        "results.json and --resume as --jobs (needs graphnav[dask])")
    g.add_argument("--resume", action="store_true",
                   help="keep the missions already smoothed in OUT/results.json and smooth only the others "
                        "(failed ones again)")
    p.set_defaults(func=run)


#: The options a mission's smoothing depends on; a --resume must use the same ones as the results it keeps.
BATCH_SETTINGS: tuple[str, ...] = ("method", "scenario", "imu_grade", "window_s", "window_start", "init",
                                   "initial_position", "initial_heading", "heading_sigma", "config", "topic")


def smooth_mission(args, out: Path) -> dict:
    """Smooth the one mission of ``args`` (``--data`` and the mission, method and output options of
    ``graphnav smooth``) into the folder ``out``: trajectory CSV/TUM, optional bag, plots, summary.json.
    Returns the summary (also written to ``out/summary.json``)."""
    from graphnav.evaluation.methods import run_method
    from graphnav.io.outputs import write_json, write_trajectory_csv, write_tum
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    mission, outages = mission_from_args(args)
    start = time.perf_counter()
    init = {"init": args.init, "aligner_kwargs": aligner_kwargs(args)}
    sol = run_method(mission, args.method, args.scenario, **init)
    wall = time.perf_counter() - start
    files = {"trajectory_csv": str(write_trajectory_csv(out / "trajectory.csv", sol)),
             "trajectory_tum": str(write_tum(out / "trajectory.tum", sol))}
    if mission.gt is not None:
        from graphnav.core.solution import NavSolution
        gt = mission.gt
        files["groundtruth_tum"] = str(write_tum(out / "groundtruth.tum",
                                                 NavSolution("GT", gt.t, gt.p_n, gt.v_n, gt.C_b_n)))
    if args.bag != "none":
        import shutil

        from graphnav.io.bags import write_odometry_bag
        bag = out / "trajectory_bag"
        shutil.rmtree(bag, ignore_errors=True)   # rosbag2 writers only create new bags; a rerun replaces it
        files["trajectory_bag"] = str(write_odometry_bag(sol, bag, t0_unix_ns=int(mission.meta.get("t0_unix_ns", 0)),
                                                         storage=args.bag))
    others = [run_method(mission, m, args.scenario, **init) for m in args.compare if m != args.method]
    summary = {
        "method": args.method, "mission": mission.name, "scenario": args.scenario,
        "imu_grade": args.imu_grade, "completer": sol.info.get("completer"),
        "epochs": int(len(sol.t)), "duration_s": mission.duration, "runtime_s": wall,
        "initialisation": sol.info.get("alignment", {"source": "ground truth"}),
        "realtime_factor": mission.duration / wall if wall > 0 else float("nan"),
        "accuracy": accuracy_summary(sol, mission, outages), "health": sol.info.get("health"),
        "compared": {o.method: {**accuracy_summary(o, mission, outages), "health": o.info.get("health")}
                     for o in others},
    }
    if not args.no_plots:
        plots = make_plots(out, mission, [*others, sol], outages,
                           f"{args.scenario} scenario, {args.imu_grade} IMU")
        files.update({Path(p).stem: p for p in plots})
    summary["files"] = files
    files["summary_json"] = str(out / "summary.json")
    write_json(out / "summary.json", summary)
    return summary


def run(args) -> int:
    from graphnav.evaluation.bench import mission_collection
    missions = mission_collection(args.data, args.config)
    if missions is not None:
        return run_folder(args, missions)
    if args.jobs != 1 or args.scheduler is not None or args.resume:
        raise ConfigError("--jobs, --scheduler and --resume apply to a folder of missions (TrajectoryN folders "
                          f"or ROS 2 bags); --data {args.data} is one mission")
    print_summary(smooth_mission(args, Path(args.out)))
    return 0


# --- a folder of missions -------------------------------------------------------------------------------
def mission_record(name: str, summary: dict | None, error: str | None = None) -> dict:
    """One line of OUT/results.json: the mission, its settings, accuracy and health (when GT), runtime,
    files, and the error when it failed (then the metrics are None)."""
    s = summary or {}
    acc = s.get("accuracy") or {}
    health = s.get("health") or {}
    return {
        "mission": name, "method": s.get("method"), "scenario": s.get("scenario"), "imu_grade": s.get("imu_grade"),
        "epochs": s.get("epochs"), "duration_s": s.get("duration_s"),
        "ground_truth": acc.get("ground_truth"),
        "vrmse_mission_mps": acc.get("vrmse_mission_mps"),
        "vrmse_windows_mps": [w["vrmse_window_mps"] for w in acc.get("windows", [])] if acc else None,
        "final_horizontal_position_error_m": acc.get("final_horizontal_position_error_m"),
        "health": {k: health.get(k) for k in ("ok", "diverged_at_end", "n_divergences", "n_reacquired",
                                              "n_rejected", "nis_mean_per_dof")} if health else None,
        "runtime_s": s.get("runtime_s"), "files": s.get("files", {}), "error": error,
    }


def smooth_task(task: tuple[str, str, dict, str]) -> tuple[dict, dict | None]:
    """Smooth one mission of a folder (runs in a worker): ``task`` = (name, path, options of the command
    as a dict, output folder). Returns (its results.json record, its summary or None). A failure becomes a
    record with ``error`` set, so one bad mission does not stop the others."""
    name, path, options, out = task
    args = argparse.Namespace(**{**options, "data": path})
    try:
        summary = smooth_mission(args, Path(out))
    except Exception as exc:  # noqa: BLE001 - reported in results.json and the exit code, not swallowed
        return mission_record(name, None, f"{type(exc).__name__}: {exc}"), None
    return mission_record(name, summary), summary


def run_folder(args, missions) -> int:
    """Smooth every mission of a folder into OUT/<mission>/ and keep OUT/results.json (atomically rewritten
    after each mission; --resume keeps its finished missions). Exit code 1 when a mission failed."""
    import sys

    from graphnav.evaluation.bench import load_results
    from graphnav.evaluation.tasks import run_tasks
    from graphnav.io.outputs import write_json
    # Absolute paths: Dask workers elsewhere (another working directory or host) read and write the same
    # places, which on a lab cluster must be a shared filesystem.
    out = Path(args.out).absolute()
    out.mkdir(parents=True, exist_ok=True)
    results_path = out / "results.json"
    args = argparse.Namespace(**{**vars(args), "config": str(Path(args.config).absolute()) if args.config else None})
    settings = {k: getattr(args, k) for k in BATCH_SETTINGS}
    records = [r for r in load_results(results_path) if not r.get("error")] if args.resume else []
    for r in records:
        if r.get("settings", settings) != settings:
            raise ConfigError(f"{results_path}: mission {r.get('mission')} was smoothed with {r.get('settings')}, "
                              f"not {settings}; use another --out or run without --resume")
    done = {r["mission"] for r in records}
    options = {k: v for k, v in vars(args).items() if k != "func"}
    todo = [(m.name, str(Path(m.folder).absolute()), options, str(out / m.name)) for m in missions
            if m.name not in done]
    print(f"smooth: {len(missions)} missions under {args.data}, {len(missions) - len(todo)} already done, "
          + (f"Dask scheduler {args.scheduler}" if args.scheduler else f"{args.jobs} job(s)")
          + f"; results in {results_path}", file=sys.stderr)

    def finished(result) -> None:
        record, summary = result
        records.append({**record, "settings": settings})
        write_json(results_path, records)
        print(f"[{len(records)}/{len(missions)}] {record['mission']}", flush=True)
        if summary is not None:
            print_summary(summary)
        else:
            print(f"  FAILED: {record['error']}", flush=True)

    write_json(results_path, records)
    run_tasks(smooth_task, todo, finished, args.jobs, args.scheduler)
    failed = [r["mission"] for r in records if r.get("error")]
    print(f"smooth: {len(records) - len(failed)} of {len(missions)} missions smoothed"
          + (f"; FAILED: {', '.join(failed)}" if failed else "") + f"; {results_path}")
    return 1 if failed else 0
