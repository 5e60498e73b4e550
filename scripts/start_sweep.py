"""Start-time sweep: every method from a start every --step s of each shared trajectory; worst window VRMSE.

For each trajectory, start time (every 10 s by default), scenario and method, the mission is cut at the
start and the method runs over the next --length s (:mod:`graphnav.startsweep`: first window = start-up with
all beams, second window = the scenario's outage). Prints, per scenario, the worst window VRMSE (m/s) of each
method over all starts and trajectories, the count of failed starts (worst >= 0.5 m/s, diverged or crashed)
and where the worst one was; writes every record to --out (JSON, rewritten as results arrive).

    nice -n 10 .venv/bin/python scripts/start_sweep.py --jobs 2
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path


def _trajectory_jobs(folder: str, scenario: str, methods: list[str], step: float, length: float,
                     window: float) -> list[dict]:
    from graphnav.loaders import load_mission
    from graphnav.startsweep import run_start, start_times
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mission = load_mission(folder)
    return [run_start(mission, m, scenario, t, length, window)
            for t in start_times(mission, step, length) for m in methods]


def table(records: list[dict], methods: list[str], scenarios: list[str]) -> str:
    from graphnav.startsweep import START_VRMSE_LIMIT, failed
    lines = [f"Worst window VRMSE (m/s) over all starts; failed = worst >= {START_VRMSE_LIMIT} m/s, diverged "
             "or crashed.", "",
             "| scenario | method | starts | worst window VRMSE | at (trajectory, start s) | median of worst | "
             "failed | re-acquired runs | health trips |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for sc in scenarios:
        for m in methods:
            rs = [r for r in records if r["scenario"] == sc and r["method"] == m]
            if not rs:
                continue
            worst = max(rs, key=lambda r: r["vrmse_worst"])
            finite = sorted(r["vrmse_worst"] for r in rs if math.isfinite(r["vrmse_worst"]))
            median = finite[len(finite) // 2] if finite else float("nan")
            n_fail = sum(failed(r) for r in rs)
            reacq = sum(bool(r["health"] and r["health"]["n_reacquired"]) for r in rs)
            trips = sum(bool(r["health"] and r["health"]["diverged"]) for r in rs)
            lines.append(f"| {sc} | {m} | {len(rs)} | {worst['vrmse_worst']:.3f} | {worst['trajectory']}, "
                         f"{worst['t_start']:.0f} | {median:.3f} | {n_fail} | {reacq} | {trips} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from graphnav.loaders import list_akit
    from graphnav.methods import METHODS
    from graphnav.paths import akit_dir
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT root (default: the shared data)")
    p.add_argument("--trajectories", nargs="*", help="trajectory folder names (default: all)")
    p.add_argument("--methods", nargs="*", default=list(METHODS))
    p.add_argument("--scenarios", nargs="*", default=["none", "2-missing", "3-missing"])
    p.add_argument("--step", type=float, default=10.0, help="s between start times")
    p.add_argument("--length", type=float, default=60.0, help="s of data after each start")
    p.add_argument("--window", type=float, default=30.0, help="scored window length, s")
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--out", default="out/start_sweep.json")
    p.add_argument("--table", metavar="JSON", help="only print the table of a (possibly partial) --out file")
    args = p.parse_args(argv)
    if args.table:
        records = json.loads(Path(args.table).read_text())
        print(f"{len({(r['trajectory'], r['t_start']) for r in records})} (trajectory, start) pairs from {args.table}\n")
        print(table(records, args.methods, args.scenarios))
        return 0
    root = Path(args.data) if args.data else akit_dir()
    if root is None:
        p.error("no A-KIT data (set GRAPHNAV_DATA or --data)")
    folders = [f for f in list_akit(root) if not args.trajectories or Path(f).name in args.trajectories]
    jobs = [(str(f), sc) for sc in args.scenarios for f in folders]      # scenario by scenario
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    records: list[dict] = []
    start = time.perf_counter()
    os.environ.update({k: "1" for k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")})
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(_trajectory_jobs, f, sc, args.methods, args.step, args.length, args.window):
                   (f, sc) for f, sc in jobs}
        for fut in as_completed(futures):
            records.extend(fut.result())
            out.write_text(json.dumps(records, indent=1, default=str))
            f, sc = futures[fut]
            print(f"done {Path(f).name} {sc} ({time.perf_counter() - start:.0f} s)", file=sys.stderr, flush=True)
    print(f"Command: {' '.join(['scripts/start_sweep.py', *(argv if argv is not None else sys.argv[1:])])}")
    print(f"{len(folders)} trajectories, starts every {args.step:g} s, {args.length:g} s after each, "
          f"{args.window:g} s windows; wall time {time.perf_counter() - start:.0f} s\n")
    print(table(records, args.methods, args.scenarios))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
