"""Speed of the DVL beam model where it runs hot (prints a table; no assertions).

    .venv/bin/python benchmarks/beam_model_speed.py [--repeat 5]

Rows:
- GTSAM factor: one ``linearize`` of a 4-beam epoch factor (``beam_factor``) and of one with the DVL error
  states (``beam_factor_dvl_errors``) on a Values of the factor's own variables (the C++ optimisers call the
  same Python ``error`` callback), microseconds per call;
- batch: ``StackedBeams.linearize`` of a 1 h mission's beams (3600 keyframes x 4 beams), with and without
  DVL error states, ms per call;
- EKF: ``ErrorStateEkf.predicted_beams`` (h and H of one ping), microseconds per call.

Each number is the best of ``--repeat`` timing runs (the machine is shared: compare within one run, or the
best of several runs).
"""
from __future__ import annotations

import argparse
import timeit

import gtsam
import numpy as np
from graphnav.factors import beam_factor, beam_factor_dvl_errors
from gtsam.symbol_shorthand import B, D, V, X

from graphnav.core.config import SensorConfig
from graphnav.core.dvl import DvlGeometry
from graphnav.estimators.ekf import ErrorStateEkf
from graphnav.estimators.graph.batch import StackedBeams
from graphnav.estimators.graph.builder import BeamGroup
from graphnav.estimators.ins import StrapdownState


def best_us(fn, number: int, repeat: int) -> float:
    return 1e6 * min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def factor_rows(geo, rng, repeat):
    pose = gtsam.Pose3(gtsam.Rot3.RzRyRx(0.1, -0.2, 0.7), np.zeros(3))
    values = gtsam.Values()
    values.insert(X(0), pose)
    values.insert(V(0), np.array([1.2, -0.3, 0.1]))
    values.insert(B(0), gtsam.imuBias.ConstantBias(np.zeros(3), np.array([1e-4, -2e-4, 3e-4])))
    values.insert(D(0), rng.normal(0, 0.01, 7))
    y, sig, omega = rng.normal(0, 1, 4), np.full(4, 0.02), np.array([0.01, -0.02, 0.05])
    plain = beam_factor(X(0), V(0), B(0), geo.T_b, y, sig, omega, geo.lever_arm_b)
    with_d = beam_factor_dvl_errors(X(0), V(0), B(0), D(0), geo.T_b, np.arange(4), geo.C_d_b, y, sig, omega,
                                    geo.lever_arm_b)
    return [("GTSAM factor, 4-beam epoch: linearize", f"{best_us(lambda: plain.linearize(values), 2000, repeat):.1f} us"),
            ("GTSAM factor with DVL error states: linearize",
             f"{best_us(lambda: with_d.linearize(values), 2000, repeat):.1f} us")]


def batch_rows(geo, rng, repeat, n=3600):
    rows = []
    for with_d in (False, True):
        groups = [BeamGroup(k, geo.T_b, rng.normal(0, 1, 4), np.full(4, 0.02), None, rng.normal(0, 0.05, 3),
                            geo.lever_arm_b, False, np.arange(4) if with_d else None,
                            geo.C_d_b if with_d else None) for k in range(n)]
        beams = StackedBeams(groups)
        C = np.array([gtsam.Rot3.Expmap(rng.normal(0, 1, 3)).matrix() for _ in range(n)])
        v, bg = rng.normal(0, 1, (n, 3)), rng.normal(0, 1e-4, (n, 3))
        d = rng.normal(0, 0.01, (n, 7)) if with_d else None
        t = best_us(lambda: beams.linearize(C, v, bg, d), 20, repeat) / 1e3
        rows.append((f"batch StackedBeams.linearize, {n} x 4 beams{' + DVL error states' if with_d else ''}",
                     f"{t:.2f} ms"))
    return rows


def ekf_rows(repeat):
    rows = []
    for with_d in (False, True):
        from graphnav.estimators.ekf import EkfOptions
        ekf = ErrorStateEkf(SensorConfig(), StrapdownState(0.0, np.eye(3), np.array([1.0, 0.2, 0.0]), np.zeros(3)),
                            EkfOptions(dvl_error_states=with_d))
        omega = np.array([0.01, -0.02, 0.05])
        rows.append((f"EKF predicted_beams{' + DVL error states' if with_d else ''}",
                     f"{best_us(lambda: ekf.predicted_beams(omega), 5000, repeat):.1f} us"))
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    geo = DvlGeometry.from_spec(SensorConfig().dvl)
    out = factor_rows(geo, rng, args.repeat) + batch_rows(geo, rng, args.repeat) + ekf_rows(args.repeat)
    width = max(len(r[0]) for r in out)
    print(f"| {'what'.ljust(width)} | time (best of {args.repeat}) |")
    print(f"|{'-' * (width + 2)}|{'-' * 21}|")
    for label, value in out:
        print(f"| {label.ljust(width)} | {value.rjust(19)} |")


if __name__ == "__main__":
    main()
