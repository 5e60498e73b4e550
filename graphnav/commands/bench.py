"""``graphnav bench``: the comparison benchmark (every method, scenario, IMU grade and window position).

Writes ``OUT/results.json`` after every finished case, then ``OUT/report.md``, ``OUT/bench_run.json`` (the
command and its settings, for ``graphnav results``) and PNG plots in
``OUT/plots/``. See :mod:`graphnav.evaluation.bench` for how windows and IMU grades are made.
"""
from __future__ import annotations

import shlex
import sys
import time
from pathlib import Path

from graphnav.commands.common import HelpFormatter, add_parallel_arguments, methods_help
from graphnav.evaluation.bench import IMU_GRADE_CHOICES, SCENARIO_NAMES
from graphnav.evaluation.methods import BENCH_METHODS, GRAPH_HN, GRAPH_HN_BATCH, GRAPH_HNP, GRAPH_TC, HNTC, METHODS, TC


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "bench", help="compare every method over scenarios, IMU grades and outage windows; report + plots",
        description="Run every method on every trajectory (the simulated default, or each trajectory under "
                    "--data), scenario and IMU grade, with outage windows spread over each mission, and "
                    "write OUT/results.json (one record per window, written as cases finish), "
                    "OUT/report.md (paper-style tables, VRTE, runtime) and OUT/plots/*.png.",
        formatter_class=HelpFormatter)
    p.add_argument("--data", metavar="DIR",
                   help="a folder of trajectories in the A-KIT layout (e.g. ../shared/data/snapir-2022-akit) "
                        "or one trajectory folder, or a ROS 2 bag or a folder of bags (with a reference Odometry "
                        "topic); default: the simulated mission")
    p.add_argument("--config", metavar="JSON", help="sensor configuration for every trajectory")
    p.add_argument("--sim-seeds", type=int, default=1, metavar="N",
                   help="without --data: number of simulated trajectories (seeds 0..N-1)")
    p.add_argument("--sim-duration", type=float, default=400.0, metavar="S",
                   help="without --data: simulated mission length, s")
    p.add_argument("--scenario", nargs="+", default=list(SCENARIO_NAMES), choices=SCENARIO_NAMES,
                   help="beam-outage scenarios")
    p.add_argument("--imu-grade", nargs="+", default=list(IMU_GRADE_CHOICES), metavar="GRADE",
                   help="'as-recorded' and/or grades whose errors are added to the recorded IMU "
                        "(tactical, mems)")
    p.add_argument("--window-s", type=float, nargs="+", default=[30.0], metavar="S",
                   help="outage window length(s), s; several = each case once per length (e.g. 30 60 120)")
    p.add_argument("--max-windows", type=int, default=None, metavar="N",
                   help="at most N windows per mission (evenly thinned); default: as many as fit")
    p.add_argument("--methods", nargs="+", default=list(BENCH_METHODS), choices=METHODS, metavar="METHOD",
                   help=f"methods to run ({methods_help()})")
    add_parallel_arguments(p, "cases")
    p.add_argument("--out", default="out/bench", metavar="DIR",
                   help="output folder (one that already holds files needs --resume or --force)")
    p.add_argument("--force", action="store_true",
                   help="empty an --out that already holds files before the run (without it, such a folder is "
                        "refused and kept)")
    p.add_argument("--resume", action="store_true",
                   help="keep the finished cases in OUT/results.json and run only the others")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def bench_plots(out: Path, records: list[dict], trajectories, grades, scenarios, methods,
                window_s: float = 30.0) -> list[Path]:
    """Bar chart per IMU grade, and for the first trajectory (whose solutions were kept) the trajectory,
    velocity-error and velocity-std figures per grade and outage scenario."""
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation import plots
    from graphnav.evaluation.bench import (
        case_windows,
        load_solution,
        prepared_mission,
        solution_file,
    )
    pdir = out / "plots"
    files = []
    for g in grades:
        if any(r["imu_grade"] == g and not r.get("error") for r in records):
            files.append(plots.plot_vrmse_bars(records, pdir / f"vrmse_bars_{g}.png", imu_grade=g))
    first = trajectories[0]
    for g in grades:
        mission = None
        for sc in scenarios:
            sols = []
            for m in methods:
                f = solution_file(out / "runs", first.name, g, sc, m)
                if f.exists():
                    sols.append(load_solution(f))
            if not sols:
                continue
            if mission is None:
                mission = prepared_mission(first, g)
            starts = case_windows(mission, window_s)
            outages = [scenario_outage(sc, s, window_s) for s in starts] if sc != "none" else []
            tag = f"{first.name}_{g}_{sc}"
            label = f"{first.name}, {g} IMU, {sc}"
            files.append(plots.plot_trajectories(mission.gt, sols, outages, pdir / f"trajectory_{tag}.png",
                                                 f"{label}: North-East track"))
            # Sleeves need a covariance; show the strongest EKF and graph methods so the figure stays readable.
            pick = [s for s in sols if s.method in (TC, HNTC, GRAPH_TC, GRAPH_HN, GRAPH_HNP, GRAPH_HN_BATCH)]
            if outages:
                a, b = outages[0].start_s - 20.0, outages[0].end_s + 40.0
            else:
                a, b = mission.t0, mission.t1
            files.append(plots.plot_velocity_errors(mission.gt, pick or sols, outages,
                                                    pdir / f"velocity_error_{tag}.png",
                                                    f"{label}: velocity error around the first window",
                                                    t_range=(a, b)))
            files.append(plots.plot_velocity_std(pick or sols, outages, pdir / f"velocity_std_{tag}.png",
                                                 f"{label}: velocity std around the first window"))
            files.append(plots.plot_nees(mission, pick or sols, outages, pdir / f"nees_{tag}.png",
                                         f"{label}: velocity NEES over time"))
            files.append(plots.plot_position_error(mission.gt, pick or sols, outages,
                                                   pdir / f"position_error_{tag}.png",
                                                   f"{label}: position error with +-2 sigma"))
    return files


def command_line() -> str:
    """The command as typed (``graphnav bench ...``, ``python -m graphnav bench ...`` or ``scripts/bench.py``)."""
    argv = sys.argv[1:]
    if Path(sys.argv[0]).name not in ("graphnav", "__main__.py", "bench.py"):
        return "graphnav bench (called from Python)"
    if "bench" in argv and Path(sys.argv[0]).name != "bench.py":
        argv = argv[argv.index("bench") + 1:]
    return "graphnav bench " + " ".join(shlex.quote(a) for a in argv)


def run(args) -> int:
    from graphnav.evaluation.bench import (
        find_trajectories,
        make_cases,
        make_report,
        run_bench,
    )

    from graphnav.commands.common import check_out, clear_out
    out = check_out(args.out, force=args.force, resume=args.resume)
    if args.force and not args.resume and out.exists():
        clear_out(out)
    out.mkdir(parents=True, exist_ok=True)
    trajectories = find_trajectories(args.data, args.sim_seeds, args.sim_duration, args.config)
    cases = make_cases(trajectories, args.scenario, args.imu_grade, args.methods, args.window_s,
                       args.max_windows, save_dir=None if args.no_plots else str(out / "runs"))
    print(f"bench: {len(trajectories)} trajectories x {len(args.scenario)} scenarios x {len(args.imu_grade)} "
          f"IMU grades x {len(args.window_s)} window lengths x {len(args.methods)} methods = {len(cases)} runs, "
          + (f"Dask scheduler {args.scheduler}" if args.scheduler else f"{args.jobs} job(s)") + f"; results in {out}",
          file=sys.stderr)
    start = time.perf_counter()
    records = run_bench(cases, out, jobs=args.jobs, resume=args.resume, progress=not args.no_progress,
                        scheduler=args.scheduler)
    wall = time.perf_counter() - start
    plot_files = []
    if not args.no_plots:
        plot_files = bench_plots(out, records, trajectories, args.imu_grade, args.scenario, args.methods,
                                 args.window_s[0])
    command = command_line()
    report = make_report(records, {"command": command, "window_s": args.window_s, "wall_time_s": wall,
                                   "jobs": args.jobs,
                                   "plots": [str(p.relative_to(out)) for p in plot_files]})
    (out / "report.md").write_text(report)
    from graphnav.evaluation.results_page import write_run_record
    write_run_record(out, command, args.window_s, args.jobs, wall)
    from graphnav.evaluation.bench import aggregate, headline
    agg = aggregate(records)
    for g in args.imu_grade:
        for sc in args.scenario:
            for model in (GRAPH_HN, GRAPH_HN_BATCH):
                line = headline(agg, g, sc, model)
                if line:
                    print(f"{g:>12} {sc:>9}: {line}")
    n_failed = sum(1 for r in records if r.get("error"))
    print(f"bench: {len(records)} window records in {wall:.0f} s ({n_failed} failed); "
          f"report {out / 'report.md'}, results {out / 'results.json'}, plots {out / 'plots'}")
    return 1 if n_failed else 0
