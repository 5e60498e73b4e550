"""Print the fault-injection outcome table: every fault of ``graphnav.evaluation.faults.FAULTS`` on a simulated mission
per IMU grade (navigation, tactical, MEMS), run through the online graph (Graph-TC, Graph-HN), the batch
smoother (Graph-HN-batch) and the EKF (TC, HNTC), with each estimator's VRMSE against its bound
(``graphnav.evaluation.faults.EXPECTED``) and its mean velocity NEES, or the error that stopped the input.

    .venv/bin/python scripts/fault_report.py                        # all three grades
    .venv/bin/python scripts/fault_report.py --grade navigation     # the grade the bounds are stated for
    .venv/bin/python scripts/fault_report.py --seed 2 --grade tactical

Bounds are relative (factor x the estimator's VRMSE on the fault-free mission of the same grade). A cell
reads ``VRMSE<=bound NEES``; NEES is the mean over the estimator's pure-inertial spans when it reported one
(``*``), else over the mission (3 for a consistent estimator). Verdicts (``graphnav.evaluation.faults.judge``): PASS
within the bound; PI where the bound cannot hold (pure inertial longer than ``max_pure_inertial_s``) but the
estimator warned so and its NEES is at most ``NEES_COVER_MAX`` (the covariance covers the error); FAIL
otherwise.
"""
from __future__ import annotations

import argparse
import tempfile
import time

from graphnav.evaluation.faults import (
    EXPECTED,
    FAULT_GRADES,
    FAULT_METHODS,
    FAULTS,
    NEES_COVER_MAX,
    fault_mission,
    judge,
    run_fault,
)


def report_grade(grade: str, seed: int, duration: float, workdir: str) -> int:
    """Print the table of one grade; return the number of faults outside their stated outcome."""
    mission = fault_mission(grade, seed, duration)
    print(f"\n## {grade}: mission {mission.name} ({duration:g} s, seed {seed}); VRMSE m/s <= bound, mean NEES")
    width = max(len(f) for f in FAULTS)
    print(f"{'fault':{width}}  {'outcome':9} " + " ".join(f"{e:>22}" for e in FAULT_METHODS) + "  factor  check")
    base: dict[str, dict[str, float]] = {}
    n_fail = 0
    for fault, expected in EXPECTED.items():
        start = time.perf_counter()
        outcomes = run_fault(fault, FAULT_METHODS, mission, f"{workdir}/{grade}")
        wall = time.perf_counter() - start
        if fault.startswith("none"):
            base[fault] = {o.estimator: o.vrmse for o in outcomes}
        if outcomes[0].stopped:
            err = outcomes[0].error
            ok = expected.stop and str(err.source).endswith(expected.source) and err.field == expected.field \
                and (expected.line is None or err.line == expected.line)
            n_fail += not ok
            print(f"{fault:{width}}  {'stopped':9} {type(err).__name__}: {err}"[:width + 160]
                  + f"  {'PASS' if ok else 'FAIL'}")
            continue
        ref = base[expected.baseline]
        verdicts = [judge(expected, o, ref[o.estimator]) for o in outcomes]
        ok = not expected.stop and "FAIL" not in verdicts
        n_fail += not ok
        cells = [f"{o.vrmse:.3f}<={expected.factor * ref[o.estimator]:.3f} {o.nees:4.1f}"
                 + ("*" if o.solution.info.get("pure_inertial_spans") else " ")
                 + {"PASS": " ", "PASS-PI": "PI", "FAIL": "!!"}[v][:2] for o, v in zip(outcomes, verdicts)]
        print(f"{fault:{width}}  {'completed':9} " + " ".join(f"{c:>22}" for c in cells)
              + f"  {expected.factor:6g}  {'PASS' if ok else 'FAIL'}  ({wall:.1f} s)", flush=True)
    print(f"{len(EXPECTED) - n_fail}/{len(EXPECTED)} faults within their stated outcome ({grade})")
    return n_fail


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=float, default=200.0, help="mission length, s")
    parser.add_argument("--seed", type=int, default=1, help="simulator seed")
    parser.add_argument("--grade", "--imu-grade", default="all", choices=(*FAULT_GRADES, "all"),
                        help="IMU grade (default all three)")
    args = parser.parse_args()
    grades = FAULT_GRADES if args.grade == "all" else (args.grade,)
    print(f"PI: bound exceeded, but the estimator warned 'pure inertial' and its NEES <= {NEES_COVER_MAX}; "
          f"!!: outside the stated outcome; *: NEES over the pure-inertial span")
    with tempfile.TemporaryDirectory() as workdir:
        n_fail = sum(report_grade(g, args.seed, args.duration, workdir) for g in grades)
    return 1 if n_fail else 0


if __name__ == "__main__":
    raise SystemExit(main())
