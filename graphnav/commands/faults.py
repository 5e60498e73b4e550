"""``graphnav faults``: the fault table -- damaged inputs through the real commands, each with its verdict.

Each case writes a damaged copy of a clean input (a simulated mission in the A-KIT layout, its JSON-lines
stream, its configuration; with ``--data`` also the first 150 s of a shared A-KIT trajectory) and runs
``graphnav smooth`` / ``online`` / ``evaluate`` / ``train-beams`` on it in a subprocess with a time limit, then
says what a user got: clear error, warning (result within 1.5x of the clean run), ok, warning with a degraded
result, traceback, hang or silent garbage (:mod:`graphnav.evaluation.faults`). ``--estimators`` prints the
in-memory table instead: every injected log fault through every estimator, per IMU grade.
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from graphnav.commands.common import HelpFormatter


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "faults", help="run the fault table: damaged inputs through the commands, verdict per case",
        description="Run a table of damaged inputs (IMU spikes, swapped or mis-scaled axes, stamps in ms, DVL "
                    "gaps and NaN runs, clocks days apart, bad configs, bad stream lines, unwritable --out, "
                    "interrupted and resumed runs, ...) through graphnav's own commands, each in a subprocess "
                    "with a time limit, and print per case what a user gets: clear error / warning (result "
                    "within 1.5x of the clean run) / ok / warning, degraded / traceback / hang / silent garbage. "
                    "The table (markdown) is printed and written to --out. Exit code 1 when any case is a "
                    "traceback, a hang, silent garbage or an unexplained exit. With --data, the cases marked "
                    "'real' run on the first 150 s of a shared A-KIT trajectory too (and train-beams on the "
                    "BeamsNet data, the shipped weights backed up and restored). --estimators prints the "
                    "in-memory table instead (every log fault through every estimator, per IMU grade).",
        formatter_class=HelpFormatter)
    p.add_argument("--data", metavar="PATH",
                   help="the shared data folder (or its snapir-2022-akit): add the real-trajectory cases")
    p.add_argument("--trajectory", type=int, default=1, metavar="N", help="A-KIT TrajectoryN of the real cases")
    p.add_argument("--out", default="out/faults.md", metavar="FILE", help="write the table (markdown) here")
    p.add_argument("--jobs", type=int, default=2, metavar="N", help="cases run at once")
    p.add_argument("--case", action="append", metavar="TEXT",
                   help="run only the cases whose name contains TEXT (and the clean runs they are scored against)")
    p.add_argument("--workdir", metavar="DIR", help="keep the damaged inputs and outputs here (default: a "
                                                    "temporary folder, removed at the end)")
    p.add_argument("--seed", type=int, default=1, help="simulator seed of the clean mission")
    p.add_argument("--estimators", action="store_true",
                   help="instead: the in-memory table, every log fault through every estimator (graph online, "
                        "batch, EKF), VRMSE against its bound and NEES, per IMU grade")
    p.add_argument("--grade", "--imu-grade", default="all", metavar="GRADE",
                   help="--estimators: navigation, tactical, mems or all")
    p.add_argument("--duration", type=float, default=200.0, metavar="S", help="--estimators: mission length")
    p.set_defaults(func=run)


def run(args) -> int:
    from graphnav.core.errors import ConfigError
    from graphnav.evaluation import faults
    out = Path(args.out)
    if out.is_dir():
        raise ConfigError(f"--out {out} is a folder; give the file to write the table to (e.g. {out}/faults.md)")
    if args.estimators:
        return _estimators(args, faults)
    with tempfile.TemporaryDirectory(prefix="graphnav-faults-") as tmp:
        root = Path(args.workdir) if args.workdir else Path(tmp)
        start = time.perf_counter()
        data = None if args.data is None else Path(args.data).resolve()    # cases run in other folders
        ws = faults.make_workspace(root, data, args.trajectory, args.seed)
        cases = faults.CLI_CASES
        if args.case:
            chosen = [c for c in cases if any(t in c.name for t in args.case)]
            if not chosen:
                raise ConfigError(f"--case {args.case}: no case matches; the cases are: "
                                  + "; ".join(c.name for c in cases))
            needed = {c.baseline for c in chosen} | {c.name for c in chosen}
            cases = tuple(c for c in cases if c.name in needed)
        results = faults.run_table(ws, cases, args.jobs, progress=_progress)
        title = (f"## graphnav faults: {len(results)} cases, simulated mission {faults.SIM_DURATION_S:g} s "
                 f"(seed {args.seed})" + (f", A-KIT Trajectory{args.trajectory} first {faults.REAL_DURATION_S:g} s"
                                          if ws.real_folder is not None else "")
                 + f"; {time.perf_counter() - start:.0f} s\n")
        table = faults.format_table(results, title)
        if ws.skipped:
            table += (f"\nNot run ({len(ws.skipped)}; they need --data with the shared A-KIT and BeamsNet data): "
                      + "; ".join(ws.skipped) + ".")
    print(table)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(table + "\n")
    print(f"\ntable written to {out}", file=sys.stderr)
    return 1 if any(r.verdict in faults.BAD_VERDICTS for r in results) else 0


def _progress(result) -> None:
    mark = "" if result.as_expected else "  (expected " + " / ".join(result.case.expected) + ")"
    print(f"[{result.wall_s:5.1f} s] {result.case.name}: {result.verdict}{mark}", file=sys.stderr, flush=True)


def _estimators(args, faults) -> int:
    from graphnav.core.errors import ConfigError
    grades = faults.FAULT_GRADES if args.grade == "all" else (args.grade,)
    if any(g not in faults.FAULT_GRADES for g in grades):
        raise ConfigError(f"--grade {args.grade}: choose one of {', '.join(faults.FAULT_GRADES)} or all")
    lines: list[str] = [f"PI: bound exceeded, but the estimator warned 'pure inertial' and its NEES <= "
                        f"{faults.NEES_COVER_MAX}; !!: outside the stated outcome; *: NEES over the pure-inertial span"]

    def out(line: str) -> None:
        print(line, flush=True)
        lines.append(line)
    print(lines[0])
    with tempfile.TemporaryDirectory() as workdir:
        n_fail = sum(faults.estimator_table(g, args.seed, args.duration, workdir, out) for g in grades)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text("\n".join(lines) + "\n")
    return 1 if n_fail else 0
