"""Can the fusion of the IMU-aware network with the average see the network going wrong in an outage?
(docs/decisions/completers.md)

Through recursive outages the IMU-aware network fails on some held-out trajectories (MEMS IMU, trajectories 2 and
5). Two rules that use the members' disagreement ``d = b_net - b_avg`` against its stated spread
``var_d = s_net^2 + s_avg^2 - 2 rho s_net s_avg`` (sigmas grown as :class:`graphnav.nets.fused.FusedCompleter`):

- ``gate:K``: where ``d^2 > K^2 var_d``, the average alone (its sigma), elsewhere the fusion;
- ``inflate``: the disagreement the sigmas do not explain, ``max(d^2 - var_d, 0)``, is added to the network's
  variance before fusing (the network is the member whose errors compound).

Each with the fold's fitted correlation and growths (``cal``, from ``imu_completer_folds.py --calibrate``) or
with none (``plain``: independent, no growth). Scored on the fold networks' held-out pairs through the 30-ping
recursive outages of the calibration study (the same pings), against the average. Usage::

    nice -n 10 .venv/bin/python experiments/fused_disagreement.py --missing 2-missing --nets out/imu_folds/nets2 \\
        --calibration out/imu_folds/cal2.json
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

from graphnav.nets.fused import FusedCompleter, fuse

RULES = ("gate:3:cal", "gate:2:cal", "inflate:cal", "gate:3:plain", "inflate:plain")


class DisagreementFused(FusedCompleter):
    """:class:`FusedCompleter` with one of the disagreement rules of the module docstring (``rule`` "gate" with
    ``k``, or "inflate")."""

    def __init__(self, first, second, rho=0.0, growth=None, rule="gate", k=3.0):
        super().__init__(first, second, rho, growth)
        self.rule, self.k = rule, float(k)

    def complete(self, past, measured, imu=None, run_steps=None, past_dt_s=None):
        b1, s1, b2, s2 = self.members(past, measured, imu, run_steps, past_dt_s)
        regressed = (s1 > 0) & (s2 > 0)
        d2 = (b1 - b2) ** 2
        var_d = s1 ** 2 + s2 ** 2 - 2.0 * self.rho * s1 * s2
        if self.rule == "gate":
            out = regressed & (d2 > self.k ** 2 * var_d)
            b, s = fuse(b1, s1, b2, s2, self.rho)
            return np.where(out, b2, b), np.where(out, s2, s)
        s1 = np.sqrt(s1 ** 2 + np.where(regressed, np.maximum(d2 - var_d, 0.0), 0.0))
        return fuse(b1, s1, b2, s2, self.rho)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--missing", default="3-missing", help="scenario (default 3-missing)")
    p.add_argument("--nets", required=True, help="fold networks and held-out arrays (imu_completer_folds.py "
                   "--save-nets DIR, then --calibrate DIR)")
    p.add_argument("--calibration", required=True, help="rows of imu_completer_folds.py --calibrate (JSON)")
    p.add_argument("--grades", nargs="+", default=["recorded", "mems"], help="evaluation IMUs (default recorded "
                   "mems)")
    p.add_argument("--rules", nargs="+", default=list(RULES), help=f"rules (default {' '.join(RULES)})")
    a = p.parse_args(argv)
    warnings.simplefilter("ignore")
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.data import BeamSamples
    from graphnav.nets.evaluate import completion_metrics, outage_rollout
    from imu_completer_folds import calibration_fits, default_dvl_only, held_out_series
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE
    from graphnav.nets.imu_network import load_imu_completer
    akit = akit_trajectories(a.data)[0].parent
    nets_dir = Path(a.nets)
    fits = calibration_fits(a.calibration, a.missing)
    res = {}
    for f, held in enumerate(AKIT_FOLDS):
        net = load_imu_completer(a.missing, nets_dir / f"fold{f}")
        default_dvl_only(net, "fused_disagreement.py")
        for grade in a.grades:
            arrays = dict(np.load(nets_dir / f"fold{f}_{grade}.npz"))
            series = held_out_series(held, akit, grade)
            samples = BeamSamples(np.zeros((len(arrays["out_beams"]), 0, 4)), arrays["out_beams"], arrays["out_v_b"])
            avg = completion_metrics(arrays["out_full_avg"], np.ones_like(arrays["out_full_avg"]), samples,
                                     net.missing)
            fit = fits[f, grade]
            for rule in a.rules:
                parts = rule.split(":")
                cal = parts[-1] == "cal"
                comp = DisagreementFused(net, AverageCompleter(AVERAGE_N_PAST[a.missing]),
                                         fit["rho"] if cal else 0.0,
                                         (fit["growth_net"], fit["growth_avg"]) if cal else None,
                                         parts[0], parts[1] if parts[0] == "gate" else 0.0)
                full, sigma, got = outage_rollout(comp, series, net.missing, gap=60, settle=OUTAGE_SETTLE)
                if not np.array_equal(got.beams, samples.beams):
                    raise RuntimeError("the rollout's pings are not the calibration study's")
                m = completion_metrics(full, sigma, samples, net.missing)
                res[rule, grade, f] = (m["beam_rmse"], m["vel_rmse"], avg["beam_rmse"], avg["vel_rmse"], m["n"])
    print(f"{a.missing}, 30-ping recursive outages: gain against the average, beam / velocity RMSE")
    print("| rule | eval IMU | pooled | " + " | ".join(f"fold {f}" for f in range(len(AKIT_FOLDS))) + " |")
    print("| --- | --- | --- | " + " | ".join("---" for _ in AKIT_FOLDS) + " |")
    for rule in a.rules:
        for grade in a.grades:
            r = np.array([res[rule, grade, f] for f in range(len(AKIT_FOLDS))])
            n = r[:, 4]

            def pooled(i, j):
                return 100.0 * (1.0 - np.sqrt(np.sum(n * r[:, i] ** 2) / np.sum(n * r[:, j] ** 2)))
            folds = " | ".join(f"{100 * (1 - x[0] / x[2]):+.1f} / {100 * (1 - x[1] / x[3]):+.1f}" for x in r)
            print(f"| {rule} | {grade} | {pooled(0, 2):+.1f} / {pooled(1, 3):+.1f} | {folds} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
