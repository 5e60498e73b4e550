"""``graphnav start-sweep``: start every method from many start times of each mission; worst window VRMSE.

The sweep is :func:`graphnav.evaluation.startsweep.run_sweep` (one start = :func:`~graphnav.evaluation.
startsweep.run_start`); this module reads the arguments, keeps ``OUT/start_sweep.json`` up to date as starts
finish (so ``--resume`` continues a sweep cut short) and writes the table to ``OUT/table.md``.
"""
from __future__ import annotations

import shlex
import sys
import time
from pathlib import Path

from graphnav.commands.common import HelpFormatter, add_parallel_arguments, methods_help
from graphnav.core.scenarios import SCENARIOS
from graphnav.evaluation.methods import BENCH_METHODS, METHODS

RECORDS_FILE = "start_sweep.json"
TABLE_FILE = "table.md"


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "start-sweep", help="start every method every STEP s of each mission; worst window VRMSE per start",
        description="For every mission (the simulated default, or each trajectory under --data), start time "
                    "(every --step s while --length s of data remain), scenario and method: cut the mission at "
                    "the start, start the method from the ground truth there, run --length s and score "
                    "consecutive --window-s windows (the first holds the start-up, the second the scenario's "
                    "beam outage). Writes OUT/start_sweep.json (one record per start and method, rewritten as "
                    "starts finish) and OUT/table.md: per scenario and method the worst window VRMSE over all "
                    "starts and where, the median, and the failed starts (worst >= 0.5 m/s, diverged or "
                    "crashed). Starts run fastest manoeuvres first, so a sweep cut short covers every mission. "
                    "Example: graphnav start-sweep --data ../shared/data/snapir-2022-akit --jobs 2",
        formatter_class=HelpFormatter)
    p.add_argument("--data", metavar="DIR",
                   help="a folder of trajectories in the A-KIT layout, one trajectory folder or a folder of ROS 2 "
                        "bags (with ground truth), as `bench --data`; default: the simulated mission")
    p.add_argument("--config", metavar="JSON", help="sensor configuration for every mission")
    p.add_argument("--trajectories", nargs="+", metavar="NAME", help="only these missions (folder names)")
    p.add_argument("--sim-seeds", type=int, default=1, metavar="N",
                   help="without --data: number of simulated missions (seeds 0..N-1)")
    p.add_argument("--sim-duration", type=float, default=400.0, metavar="S",
                   help="without --data: simulated mission length, s")
    p.add_argument("--methods", nargs="+", default=list(BENCH_METHODS), choices=METHODS, metavar="METHOD",
                   help=f"methods to start ({methods_help()})")
    p.add_argument("--scenario", nargs="+", default=["none", "2-missing", "3-missing"],
                   choices=sorted(SCENARIOS), help="beam outage of the second window")
    p.add_argument("--step", type=float, default=10.0, metavar="S", help="time between start times, s")
    p.add_argument("--length", type=float, default=60.0, metavar="S", help="data run after each start, s")
    p.add_argument("--window-s", type=float, default=30.0, metavar="S", help="scored window length, s")
    add_parallel_arguments(p, "starts")
    p.add_argument("--out", default="out/start_sweep", metavar="DIR",
                   help="output folder (one that already holds files needs --resume or --force)")
    p.add_argument("--force", action="store_true",
                   help="empty an --out that already holds files before the run (without it, such a folder is "
                        "refused and kept)")
    p.add_argument("--resume", action="store_true",
                   help="keep the records in OUT/start_sweep.json and run only the starts they lack")
    p.add_argument("--table", metavar="JSON",
                   help="only print the table of an earlier sweep's start_sweep.json (or its --out folder), "
                        "finished or not; runs nothing")
    p.set_defaults(func=run)


def check_args(args) -> None:
    from graphnav.core.errors import ConfigError
    for name in ("step", "length", "window_s"):
        value = getattr(args, name)
        if not value > 0:
            raise ConfigError(f"--{name.replace('_', '-')} {value}: must be > 0 s")
    if args.window_s > args.length:
        raise ConfigError(f"--window-s {args.window_s} is longer than --length {args.length}: no window to score")
    if args.jobs < 1:
        raise ConfigError(f"--jobs {args.jobs}: give 1 or more")


def read_records(path) -> tuple[list[dict], Path]:
    """The records of a sweep's ``start_sweep.json`` (or its folder), checked: a list of objects with the keys
    the table needs; errors name the file and the record's index."""
    from graphnav.core.errors import ConfigError, DataError
    from graphnav.evaluation.bench import load_results
    path = Path(path)
    if path.is_dir():
        path = path / RECORDS_FILE
    if not path.is_file():
        raise ConfigError(f"{path}: no such file; give the {RECORDS_FILE} of a `graphnav start-sweep` run or its "
                          "--out folder")
    records = load_results(path)
    for i, r in enumerate(records):
        missing = [k for k in ("trajectory", "method", "scenario", "t_start", "vrmse_worst", "diverged", "error",
                               "health") if not isinstance(r, dict) or k not in r]
        if missing:
            raise DataError(f"{path}: record {i} has no {', '.join(missing)} (not a start-sweep file?)")
    return records, path


def pick_sources(args):
    from graphnav.core.errors import ConfigError
    from graphnav.evaluation.bench import find_trajectories
    sources = find_trajectories(args.data, sim_seeds=args.sim_seeds, sim_duration_s=args.sim_duration,
                                config_path=args.config)
    if args.trajectories:
        unknown = sorted(set(args.trajectories) - {s.name for s in sources})
        if unknown:
            raise ConfigError(f"--trajectories {' '.join(unknown)}: not found; the missions are "
                              f"{', '.join(s.name for s in sources)}")
        sources = [s for s in sources if s.name in args.trajectories]
    return sources


def run(args) -> int:
    from graphnav.commands.common import check_out, clear_out
    from graphnav.evaluation.startsweep import run_sweep, sweep_table
    from graphnav.io.outputs import write_json
    if args.table:
        records, path = read_records(args.table)
        pairs = len({(r["trajectory"], r["t_start"]) for r in records})
        print(f"{pairs} (trajectory, start) pairs from {path}\n")
        print(sweep_table(records, args.methods, args.scenario))
        return 0
    check_args(args)
    out = check_out(args.out, force=args.force, resume=args.resume)
    if args.force and not args.resume and out.exists():
        clear_out(out)
    sources = pick_sources(args)
    out.mkdir(parents=True, exist_ok=True)
    records_path = out / RECORDS_FILE
    done = read_records(records_path)[0] if args.resume and records_path.exists() else []
    start = time.perf_counter()
    records = list(done)

    def finished(new: list[dict]) -> None:
        records.extend(new)
        write_json(records_path, records)
        r = new[0]
        print(f"{len(records) // max(1, len(args.methods))} starts: {r['trajectory']} {r['scenario']} "
              f"{r['t_start']:.0f} s ({time.perf_counter() - start:.0f} s)", file=sys.stderr, flush=True)
    run_sweep(sources, args.methods, args.scenario, args.step, args.length, args.window_s, done=done,
              finished=finished, jobs=args.jobs, scheduler=args.scheduler)
    command = "graphnav start-sweep " + " ".join(shlex.quote(a) for a in sys.argv[2:]) \
        if Path(sys.argv[0]).name in ("graphnav", "__main__.py") else "graphnav start-sweep (called from Python)"
    text = (f"Command: {command}\n\n{len(sources)} missions, starts every {args.step:g} s, {args.length:g} s after "
            f"each, {args.window_s:g} s windows; wall time {time.perf_counter() - start:.0f} s\n\n"
            + sweep_table(records, args.methods, args.scenario) + "\n")
    (out / TABLE_FILE).write_text(text, encoding="utf-8")
    print(text)
    print(f"records: {records_path}; table: {out / TABLE_FILE}", file=sys.stderr)
    return 0
