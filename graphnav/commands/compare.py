"""``graphnav compare``: two bench runs' ``results.json`` record by record (did a change alter the results?).

The comparison is :func:`graphnav.evaluation.compare.compare_runs`; this module reads the two files (through
the results page's reader, which checks every record) and prints the report.
"""
from __future__ import annotations

from graphnav.commands.common import HelpFormatter


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "compare", help="compare two bench runs' results.json record by record (behaviour unchanged?)",
        description="Match the records of two `graphnav bench` runs by (trajectory, scenario, IMU grade, window "
                    "length, method, window start) and print: how many records both hold and how many are "
                    "identical (every field but runtime_s), the largest |change| of the window and mission VRMSE "
                    "and where, the largest change of every numeric field, the flags and errors that differ, "
                    "and the records only one run has. Exit status 0 when both runs hold the same records and "
                    "nothing differs by more than --tol, 1 otherwise (as diff). "
                    "Example: graphnav compare before/results.json after/results.json",
        formatter_class=HelpFormatter)
    p.add_argument("a", metavar="A", help="the first run: its results.json or its --out folder")
    p.add_argument("b", metavar="B", help="the second run: its results.json or its --out folder")
    p.add_argument("--tol", type=float, default=0.0, metavar="X",
                   help="numeric fields that differ by at most X (in their own unit) count as unchanged for the "
                        "exit status; the report still lists them")
    p.add_argument("--show", type=int, default=10, metavar="N", help="list at most N records per section")
    p.set_defaults(func=run)


def run(args) -> int:
    from graphnav.core.errors import ConfigError
    from graphnav.evaluation.compare import compare_runs, format_comparison
    from graphnav.evaluation.results_page import read_bench_records
    if args.tol < 0 or args.show < 0:
        raise ConfigError(f"--tol {args.tol} / --show {args.show}: give values >= 0")
    records_a, path_a = read_bench_records(args.a)
    records_b, path_b = read_bench_records(args.b)
    comparison = compare_runs(records_a, records_b, path_a, path_b)
    print(format_comparison(comparison, str(path_a), str(path_b), show=args.show))
    same = comparison.same(args.tol)
    print(f"\n{'same results' if same else 'results differ'}" + (f" (tolerance {args.tol:g})" if args.tol else ""))
    return 0 if same else 1
