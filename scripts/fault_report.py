"""Print the fault-injection outcome table: every fault of ``graphnav.faults.FAULTS`` on a simulated mission,
run through the online graph (Graph-TC, Graph-HN), the batch smoother (Graph-HN-batch) and the EKF (TC,
HNTC), with each estimator's VRMSE against its bound (``graphnav.faults.EXPECTED``), or the error that
stopped the input.

    .venv/bin/python scripts/fault_report.py               # the mission the bounds are stated for
    .venv/bin/python scripts/fault_report.py --seed 2 --imu-grade tactical

Bounds are relative (factor x the estimator's VRMSE on the fault-free mission); with another seed or
grade the PASS column shows how well the stated bounds carry over.
"""
from __future__ import annotations

import argparse
import tempfile
import time

from graphnav.faults import ESTIMATORS, EXPECTED, FAULTS, run_fault
from graphnav.simulate import simulate_mission


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=float, default=200.0, help="mission length, s")
    parser.add_argument("--seed", type=int, default=1, help="simulator seed")
    parser.add_argument("--imu-grade", default="navigation", help="navigation, tactical or mems")
    args = parser.parse_args()
    mission = simulate_mission(args.duration, args.imu_grade, seed=args.seed, dvl_stamp_offset_s=0.37)
    print(f"mission: {mission.name} ({args.duration:g} s, {args.imu_grade}, seed {args.seed}); "
          f"VRMSE m/s, bound = factor x fault-free VRMSE of the same estimator\n")
    base: dict[str, dict[str, float]] = {}
    width = max(len(f) for f in FAULTS)
    print(f"{'fault':{width}}  {'outcome':9} " + " ".join(f"{e:>15}" for e in ESTIMATORS) + "  factor  check  note")
    n_fail = 0
    with tempfile.TemporaryDirectory() as workdir:
        for fault, expected in EXPECTED.items():
            start = time.perf_counter()
            outcomes = run_fault(fault, ESTIMATORS, mission, workdir)
            wall = time.perf_counter() - start
            if fault.startswith("none"):
                base[fault] = {o.estimator: o.vrmse for o in outcomes}
            if outcomes[0].stopped:
                err = outcomes[0].error
                ok = expected.stop and str(err.source).endswith(expected.source) and err.field == expected.field \
                    and (expected.line is None or err.line == expected.line)
                n_fail += not ok
                print(f"{fault:{width}}  {'stopped':9} {type(err).__name__}: {err}"[:width + 200]
                      + f"  {'PASS' if ok else 'FAIL'}")
                continue
            ref = base[expected.baseline]
            cells, ok = [], not expected.stop
            for o in outcomes:
                bound = expected.factor * ref[o.estimator]
                ok &= o.vrmse <= bound
                cells.append(f"{o.vrmse:.4f}<={bound:.4f}")
            warned = expected.warning is None or all(any(expected.warning in w for w in o.warnings)
                                                     for o in outcomes)
            ok &= warned
            n_fail += not ok
            note = next((w for w in outcomes[0].warnings if expected.warning and expected.warning in w), "")
            print(f"{fault:{width}}  {'completed':9} " + " ".join(f"{c:>15}" for c in cells)
                  + f"  {expected.factor:6g}  {'PASS' if ok else 'FAIL'}  ({wall:.1f} s) {note[:90]}")
    print(f"\n{len(EXPECTED) - n_fail}/{len(EXPECTED)} faults within their stated outcome")
    return 1 if n_fail else 0


if __name__ == "__main__":
    raise SystemExit(main())
