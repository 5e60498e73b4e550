"""Start-time sweep: every method from a start every --step s of each shared trajectory; worst window VRMSE.

For each trajectory, start time (every 10 s by default), scenario and method, the mission is cut at the
start and the method runs over the next --length s (:mod:`graphnav.evaluation.startsweep`: first window = start-up with
all beams, second window = the scenario's outage). Prints, per scenario, the worst window VRMSE (m/s) of each
method over all starts and trajectories, the count of failed starts (worst >= 0.5 m/s, diverged or crashed)
and where the worst one was; writes every record to --out (JSON, rewritten as results arrive).

    nice -n 10 .venv/bin/python scripts/start_sweep.py --jobs 2
"""
from __future__ import annotations

import argparse
import functools
import json
import math
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path


@functools.lru_cache(maxsize=None)     # ten small missions (2 MB of IMU each): load each once per process
def _mission(folder: str):
    from graphnav.io.loaders import load_mission
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_mission(folder)


def _start_job(folder: str, scenario: str, t_start: float, methods: list[str], length: float,
               window: float) -> list[dict]:
    from graphnav.evaluation.startsweep import run_start
    return [run_start(_mission(folder), m, scenario, t_start, length, window) for m in methods]


def ordered_jobs(folders, scenarios, step, length) -> list[tuple[str, str, float]]:
    """(folder, scenario, start) in the order they are run: first the three fastest-manoeuvre starts of every
    trajectory, then the starts on a 3-step grid, then the rest, each scenario by scenario, so that a sweep
    cut short still covers every trajectory (the table says how many starts it holds)."""
    from graphnav.evaluation.startsweep import fastest_starts, start_times
    jobs = []
    for f in folders:
        starts = start_times(_mission(str(f)), step, length)
        fast = set(fastest_starts(_mission(str(f)), starts, n=3))
        for i, t in enumerate(starts):
            priority = 0 if t in fast else (1 if i % 3 == 0 else 2)
            jobs += [(priority, k, str(f), sc, t) for k, sc in enumerate(scenarios)]
    return [(f, sc, t) for _, _, f, sc, t in sorted(jobs, key=lambda j: (j[0], j[1], j[4], j[2]))]


def table(records: list[dict], methods: list[str], scenarios: list[str]) -> str:
    from graphnav.evaluation.startsweep import START_VRMSE_LIMIT, failed
    lines = [f"Worst window VRMSE (m/s) over all starts; failed = worst >= {START_VRMSE_LIMIT} m/s, diverged "
             "or crashed; starts = (trajectory, start) pairs run.", "",
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
    from graphnav.evaluation.methods import BENCH_METHODS
    from graphnav.io.loaders import list_akit
    from graphnav.io.paths import akit_dir
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT root (default: the shared data)")
    p.add_argument("--trajectories", nargs="*", help="trajectory folder names (default: all)")
    p.add_argument("--methods", nargs="*", default=list(BENCH_METHODS))
    p.add_argument("--scenarios", nargs="*", default=["none", "2-missing", "3-missing"])
    p.add_argument("--step", type=float, default=10.0, help="s between start times")
    p.add_argument("--length", type=float, default=60.0, help="s of data after each start")
    p.add_argument("--window", type=float, default=30.0, help="scored window length, s")
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--out", default="out/start_sweep.json")
    p.add_argument("--resume", action="store_true", help="keep the records in --out and skip their starts")
    p.add_argument("--table", metavar="JSON", help="only print the table of a (possibly partial) --out file")
    args = p.parse_args(argv)
    if args.table:
        records = json.loads(Path(args.table).read_text())
        pairs = len({(r['trajectory'], r['t_start']) for r in records})
        print(f"{pairs} (trajectory, start) pairs from {args.table}\n")
        print(table(records, args.methods, args.scenarios))
        return 0
    root = Path(args.data) if args.data else akit_dir()
    if root is None:
        p.error("no A-KIT data (set GRAPHNAV_DATA or --data)")
    folders = [f for f in list_akit(root) if not args.trajectories or Path(f).name in args.trajectories]
    jobs = ordered_jobs(folders, args.scenarios, args.step, args.length)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    records: list[dict] = json.loads(out.read_text()) if args.resume and out.exists() else []
    done = {(r["trajectory"], r["scenario"], r["t_start"]) for r in records}
    jobs = [j for j in jobs if (_mission(j[0]).name, j[1], j[2]) not in done]
    start = time.perf_counter()
    os.environ.update({k: "1" for k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")})
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(_start_job, f, sc, t, args.methods, args.length, args.window): (f, sc, t)
                   for f, sc, t in jobs}
        for n, fut in enumerate(as_completed(futures), 1):
            records.extend(fut.result())
            out.write_text(json.dumps(records, indent=1, default=str))
            f, sc, t = futures[fut]
            print(f"{n}/{len(jobs)} {Path(f).name} {sc} {t:.0f} s ({time.perf_counter() - start:.0f} s)",
                  file=sys.stderr, flush=True)
    print(f"Command: {' '.join(['scripts/start_sweep.py', *(argv if argv is not None else sys.argv[1:])])}")
    print(f"{len(folders)} trajectories, starts every {args.step:g} s, {args.length:g} s after each, "
          f"{args.window:g} s windows; wall time {time.perf_counter() - start:.0f} s\n")
    print(table(records, args.methods, args.scenarios))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
