"""``graphnav smooth``: batch-smooth a mission and write the trajectory (CSV, TUM), a JSON summary and plots;
or every mission of a folder of missions (:func:`run_folder`), in parallel or on a Dask cluster, with one
``results.json`` over all of them.
"""
from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from graphnav.commands.common import (
    EXIT_EPILOG,
    HelpFormatter,
    StagedOut,
    accuracy_summary,
    add_init_arguments,
    add_mission_arguments,
    add_out_arguments,
    check_out,
    clear_out,
    align_options,
    exit_status,
    make_plots,
    methods_help,
    mission_from_args,
    print_summary,
    regressed_beams_summary,
    run_health_record,
)
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.solution import LOCAL_ORIGIN, position_frame
from graphnav.estimators.health import EXIT_DIVERGED
from graphnav.evaluation.methods import GRAPH_HN_BATCH, METHODS
from graphnav.evaluation.metrics import drift_summary, fix_stamps, frame_shift


# --- the command ----------------------------------------------------------------------------------------
def register(subparsers) -> None:
    p = subparsers.add_parser(
        "smooth", help="batch-smooth a mission or a folder of missions (Graph-HN-batch); write CSV, TUM, JSON "
                       "summary and plots",
        description="Batch-smooth a whole mission with the factor graph (Gauss-Newton over all keyframes; with "
                    "the default Graph-HN-batch, regressed beams as weak factors only in an outage the mission "
                    "ends in: one that measured beams end is bridged by the IMU from both sides) and write "
                    "OUT/trajectory.csv, "
                    "OUT/trajectory.tum (for evo; also OUT/groundtruth.tum, the GT carried to the estimate's "
                    "stamps by the IMU (the NEES's reference), when the mission has GT: `evo_ape tum "
                    "OUT/groundtruth.tum OUT/trajectory.tum` pairs every epoch), OUT/trajectory_cov.csv (the position, "
                    "attitude and velocity covariance of each TUM line), "
                    "OUT/summary.json and PNG plots. When --data is a folder of missions (A-KIT TrajectoryN "
                    "folders or ROS 2 bags), smooth each one with the same options into OUT/<mission>/ and "
                    "keep OUT/results.json (one record per mission, rewritten as each finishes) -- in "
                    "--jobs processes or on a Dask cluster (--scheduler), resumable with --resume. An --out that "
                    "already holds files is refused (--force replaces it whole); one mission's results appear in "
                    "--out only once complete. A DVL file without an IMU (a PD0 file alone) gives DVL-DR, a dead "
                    "reckoning of the instrument's own velocity over ground and attitude, with a warning: "
                    "`graphnav info FILE` tells which it is.",
        epilog=EXIT_EPILOG, formatter_class=HelpFormatter)
    add_mission_arguments(p)
    add_init_arguments(p)
    add_out_arguments(p, "out/smooth")
    p.add_argument("--method", default=GRAPH_HN_BATCH, choices=METHODS, metavar="METHOD",
                   help=f"method to run ({methods_help()})")
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


def smooth_mission(args, out: Path, final=str) -> dict:
    """Smooth the one mission of ``args`` (``--data`` and the mission, method and output options of
    ``graphnav smooth``) into the folder ``out``: trajectory CSV/TUM with the TUM lines' pose and velocity covariances
    (``trajectory_cov.csv``), optional bag, plots, summary.json (with ``uncertainty``, the run's own sigmas, and
    ``regressed_beams``, what became of a completer's beams).
    Returns the summary (also written to ``out/summary.json``); ``final`` maps a path written in ``out``
    to the one the summary names (where a staged folder will be moved)."""
    from graphnav.evaluation.methods import run_method
    from graphnav.io.dvl_files import holds_dvl_only
    from graphnav.io.outputs import (
        uncertainty_summary,
        write_json,
        write_pose_covariance_csv,
        write_trajectory_csv,
        write_tum,
    )
    from graphnav.io.stream_counts import ensure_streams
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if args.data is not None and holds_dvl_only(args.data, _config(args)):
        return smooth_dvl_only(args, out, final)
    mission, outages = mission_from_args(args)
    start = time.perf_counter()
    init = {"init": args.init, "align": align_options(args)}
    sol = run_method(mission, args.method, args.scenario, options=_printed_covariances(args.method), **init)
    wall = time.perf_counter() - start
    files = {"trajectory_csv": str(write_trajectory_csv(out / "trajectory.csv", sol)),
             "trajectory_tum": str(write_tum(out / "trajectory.tum", sol)),
             "trajectory_cov": str(write_pose_covariance_csv(out / "trajectory_cov.csv", sol))}
    carried = None          # the scoring reference, carried once for groundtruth.tum and the NEES summary
    if mission.gt is not None:
        # the reference at the estimate's stamps (evo_ape at its defaults pairs every epoch), the one the NEES is
        # scored against: a 1 Hz GT interpolated in waves is off by 0.5 deg in roll, 0.2 deg in heading
        from graphnav.evaluation.consistency import scoring_reference
        from graphnav.io.outputs import write_reference_tum
        try:
            reference = carried = scoring_reference(sol, mission)
        except (ValueError, DataError) as exc:     # the estimate's stamps are not increasing: say so, keep the GT
            warnings.warn(f"{out / 'groundtruth.tum'}: the GT interpolated to the estimate's stamps, not carried "
                          f"there by the IMU ({exc})", RuntimeWarning, stacklevel=2)
            reference = mission.gt
        written = write_reference_tum(out / "groundtruth.tum", sol, reference, frame_shift(sol, reference))
        if written is not None:
            files["groundtruth_tum"] = str(written)
    if args.bag != "none":
        import shutil

        from graphnav.io.bags import write_odometry_bag
        bag = out / "trajectory_bag"
        shutil.rmtree(bag, ignore_errors=True)   # rosbag2 writers only create new bags; a rerun replaces it
        files["trajectory_bag"] = str(write_odometry_bag(sol, bag, t0_unix_ns=int(mission.meta.get("t0_unix_ns", 0)),
                                                         storage=args.bag))
    others = [run_method(mission, m, args.scenario, options=_printed_covariances(m), **init)
              for m in args.compare if m != args.method]
    summary = {
        "method": args.method, "mission": mission.name, "scenario": args.scenario,
        "imu_grade": args.imu_grade, "completer": sol.info.get("completer"),
        "epochs": int(len(sol.t)), "duration_s": mission.duration, "runtime_s": wall,
        "initialisation": sol.info.get("alignment", {"source": "ground truth"}),
        "realtime_factor": mission.duration / wall if wall > 0 else float("nan"),
        "accuracy": accuracy_summary(sol, mission, outages, carried),
        "drift": drift_summary(sol, mission.gt, fix_stamps(mission)),
        "position_frame": sol.info.get("position_frame"),
        "groundtruth_in_estimate_frame": "groundtruth_tum" in files,       # write_reference_tum
        "uncertainty": uncertainty_summary(sol), "health": run_health_record(sol.info, mission),
        "regressed_beams": regressed_beams_summary(sol.info),
        "completer_state": sol.info.get("completer_state", {}),
        "completer_fallbacks": sol.info.get("completer_fallbacks", {}),
        "compared": {o.method: {**accuracy_summary(o, mission, outages), "health": run_health_record(o.info, mission),
                                "regressed_beams": regressed_beams_summary(o.info),
                                "completer_state": o.info.get("completer_state", {}),
                                "completer_fallbacks": o.info.get("completer_fallbacks", {})}
                     for o in others},
        "streams": ensure_streams(mission),
    }
    if not args.no_plots:
        plots = make_plots(out, mission, [*others, sol], outages,
                           f"{args.scenario} scenario, {args.imu_grade} IMU")
        files.update({Path(p).stem: p for p in plots})
    files["summary_json"] = str(out / "summary.json")
    summary["files"] = {k: final(v) for k, v in files.items()}
    write_json(out / "summary.json", summary)
    return summary


def _printed_covariances(method: str) -> dict | None:
    """The estimator options a smoothed mission's outputs need: every covariance of a graph method (the CSV,
    the TUM side file, the bag and the summary print them); the EKF gives what its P holds."""
    return {"marginals": "full"} if METHODS[method].family == "graph" else None


def _config(args):
    from graphnav.core.config import SensorConfig
    return SensorConfig.load(args.config) if args.config else None


#: What ``smooth`` says when it dead-reckons a DVL log that came without an IMU.
DVL_ONLY_WARNING = (
    "{data} holds a DVL log and no IMU: the output is DVL-DR, a dead reckoning of the instrument's own velocity "
    "over ground and attitude (its error grows with the compass error times the distance run), not graphnav's "
    "IMU/DVL estimator ({method}). To run the estimator, give the IMU in the configuration's csv_columns map "
    "(--config with \"csv_columns\": {{\"imu\": {{\"file\": ..., \"t\": ..., \"f_b\": [...], \"omega_b\": [...]}}, "
    "\"dvl\": {{\"pd0\": \"{name}\"}}}}; see graphnav.io.generic_csv)")


def smooth_dvl_only(args, out: Path, final=str) -> dict:
    """``smooth`` of a DVL file without an IMU: the DVL-DR track (:func:`graphnav.estimators.dead_reckoning.
    dvl_dead_reckoning`) written like a smoothed mission (trajectory CSV/TUM, optional bag, summary.json with
    ``"method": "DVL-DR"``, the streams and the warning that this is not the IMU/DVL estimator)."""
    import warnings

    from graphnav.core.streams import say_doubted
    from graphnav.estimators.dead_reckoning import dvl_dead_reckoning
    from graphnav.io.dvl_files import read_dvl
    from graphnav.io.inspect import describe_dvl_log
    from graphnav.io.outputs import (
        uncertainty_summary,
        write_json,
        write_pose_covariance_csv,
        write_trajectory_csv,
        write_tum,
    )
    from graphnav.io.pd0 import with_spread_times
    data = Path(args.data)
    start = time.perf_counter()
    log = read_dvl(data, _config(args))         # a file graphnav cannot use stops here, with its reason
    log, spread = with_spread_times(log)        # one stamp per ping, as beside an IMU
    message = DVL_ONLY_WARNING.format(data=data, method=args.method, name=data.name)
    warnings.warn(message, RuntimeWarning, stacklevel=2)
    ignored = [f"--{k.replace('_', '-')} {v}" for k, v, default in (
        ("scenario", args.scenario, "none"), ("imu_grade", args.imu_grade, "as-recorded"), ("init", args.init, "auto"))
        if v != default] + [f"--{k.replace('_', '-')} {' '.join(map(str, v))}" for k in (
            "compare", "window_start", "initial_position") if (v := getattr(args, k, None))] + (
        [f"--initial-heading {args.initial_heading:g}"] if getattr(args, "initial_heading", None) is not None else [])
    said = [message]
    if ignored:
        said.append(f"{data}: {', '.join(ignored)} ignored: they apply to the IMU/DVL estimators")
        warnings.warn(said[-1], RuntimeWarning, stacklevel=2)
    sol = dvl_dead_reckoning(log)
    wall = time.perf_counter() - start
    files = {"trajectory_csv": str(write_trajectory_csv(out / "trajectory.csv", sol)),
             "trajectory_tum": str(write_tum(out / "trajectory.tum", sol)),
             "trajectory_cov": str(write_pose_covariance_csv(out / "trajectory_cov.csv", sol))}
    if args.bag != "none":
        import shutil

        from graphnav.io.bags import write_odometry_bag
        bag = out / "trajectory_bag"
        shutil.rmtree(bag, ignore_errors=True)
        files["trajectory_bag"] = str(write_odometry_bag(sol, bag, storage=args.bag))
    duration = float(sol.t[-1] - sol.t[0])
    streams = describe_dvl_log(log)["streams"]
    for text, reason, n in spread:
        say_doubted({"streams": streams}, "dvl", log.source, text, reason, n)
        said.append(f"{log.source}: {text}")
    gaps = sol.info["gaps"]
    if gaps:
        streams["dvl"]["notes"].append(f"{len(gaps)} gap(s) bridged by dead reckoning (longest "
                                       f"{max(g['length_s'] for g in gaps):.1f} s)")
    summary = {
        "method": "DVL-DR", "mission": data.stem, "scenario": "none", "imu_grade": None, "completer": None,
        "epochs": int(len(sol.t)), "duration_s": duration, "runtime_s": wall,
        "initialisation": {"source": "origin at the first ping with a velocity over ground"},
        "realtime_factor": duration / wall if wall > 0 else float("nan"),
        "accuracy": {"ground_truth": False}, "health": None, "compared": {}, "drift": drift_summary(sol),
        # dead reckoned from the first ping, whose place on Earth the DVL log does not say
        "position_frame": position_frame({"alignment": {"position_source": LOCAL_ORIGIN}}),
        "uncertainty": uncertainty_summary(sol),
        "dead_reckoning": sol.info, "streams": streams, "warnings": said,
        "clock": "Unix seconds" if sol.t[0] > 1e8 else "the log's clock, s",
    }
    if not args.no_plots:
        from graphnav.evaluation.plots import plot_trajectories
        files["trajectory_ne"] = str(plot_trajectories(None, [sol], [], out / "trajectory_ne.png",
                                                       f"{data.name}: DVL dead reckoning (no IMU)"))
    files["summary_json"] = str(out / "summary.json")
    summary["files"] = {k: final(v) for k, v in files.items()}
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
    with StagedOut(args.out, args.force) as staged:
        summary = smooth_mission(args, staged.path, staged.final)
    print_summary(summary)
    return exit_status(summary)


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
        "distance_m": (s.get("drift") or {}).get("distance_m"), "drift_pct": (s.get("drift") or {}).get("drift_pct"),
        "final_horizontal_position_sigma_m": (s.get("uncertainty") or {}).get("final_horizontal_position_sigma_m"),
        "final_heading_sigma_deg": (s.get("uncertainty") or {}).get("final_heading_sigma_deg"),
        "health": {k: health.get(k) for k in ("state", "why", "ok", "diverged_at_end", "n_divergences",
                                              "n_reacquired", "n_rejected", "nis_mean_per_dof")} if health else None,
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
    out = check_out(args.out, force=args.force, resume=args.resume).absolute()
    if args.force and out.exists() and not args.resume:
        clear_out(out)
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
    diverged = [r["mission"] for r in records if (r.get("health") or {}).get("state") == "diverged"]
    if diverged:
        print(f"smooth: DIVERGED (estimates not to be trusted): {', '.join(diverged)}")
    return 1 if failed else (EXIT_DIVERGED if diverged else 0)
