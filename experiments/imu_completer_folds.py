"""The IMU-aware beam completer out of fold, trained with IMU grades (docs/decisions/completers.md).

Per leave-trajectories-out fold (:data:`graphnav.nets.crossval.AKIT_FOLDS`) the IMU-aware network is trained on
the fold's eight training trajectories, with the recorded IMU and one copy of each trajectory per IMU grade of
``--grades`` (the grade's errors added by :func:`graphnav.sim.imu_errors.corrupt_imu`, training seeds
``100 * copy + trajectory``), then scored on the two held-out trajectories with each evaluation IMU (recorded,
tactical, MEMS; evaluation seeds ``5000 + trajectory``, never trained on) by
:func:`graphnav.nets.imu_evaluate.evaluate_imu`: beam and velocity RMSE per ping and through recursive 30-ping
outages, against the average estimator (N = 5 for 3 missing beams) on the same pings, and the fraction of errors
within 1 and 2 sigma (Gaussian 0.683 / 0.954). Pooled (sample-weighted) numbers and the worst fold come from
:func:`graphnav.nets.crossval.summarise`.

The schedule is shorter than the shipped one (``ImuTrainOptions``: 60 epochs, 20 rollout epochs, 6 beam-noise
draws) so that five trainings fit on the shared machine; the defaults below are what the decision page reports.
Rows are written to ``--out`` after every fold; ``--report`` prints the tables of such a file again. Usage::

    nice -n 10 .venv/bin/python experiments/imu_completer_folds.py --out out/imu_folds/rows.json
    .venv/bin/python experiments/imu_completer_folds.py --report out/imu_folds/rows.json
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

EVAL_GRADES = ("recorded", "tactical", "mems")


def fold_rows(fold: int, held: tuple[int, ...], scenario: str, completer, akit_dir, fused: bool = False
              ) -> list[dict]:
    """:func:`evaluate_imu` rows of one fold's network on its held-out pair, per evaluation IMU, renamed for
    :func:`graphnav.nets.crossval.summarise` (the IMU-aware network is ``network``; the grade is the variant).
    With ``fused``, the network combined with the average by their sigmas (``imu+average``) is the ``network``
    of the variant "IMU <grade>, fused", beside a copy of the average's rows."""
    from graphnav.nets.imu_evaluate import evaluate_imu
    rows = []
    for grade in EVAL_GRADES:
        for r in evaluate_imu((scenario,), held, akit_dir=akit_dir, completers={scenario: completer},
                              imu_grade=None if grade == "recorded" else grade, fused=fused):
            base = {**r, "fold": fold, "held_out": list(held), "dataset": "A-KIT"}
            if r["method"] == "imu+average":
                rows.append({**base, "method": "network", "variant": f"IMU {grade}, fused"})
                continue
            method = {"imu-network": "network", "network": "beam-network"}.get(r["method"], r["method"])
            rows.append({**base, "method": method, "variant": f"IMU {grade}"})
            if fused and method == "average":
                rows.append({**base, "method": method, "variant": f"IMU {grade}, fused"})
    return rows


def coverage_table(rows: list[dict]) -> str:
    """Sigma coverage of the IMU-aware network per scenario, evaluation IMU and mode: per fold and pooled
    (weighted by n)."""
    folds = sorted({r["fold"] for r in rows})
    lines = ["| scenario | eval IMU | mode | " + " | ".join(f"fold {f}" for f in folds)
             + " | pooled in 1s / 2s | z RMS pooled |",
             "| --- | --- | --- | " + " | ".join("---" for _ in folds) + " | --- | --- |"]
    for scen in dict.fromkeys(r["scenario"] for r in rows):
        for var in dict.fromkeys(r["variant"] for r in rows):
            for mode in dict.fromkeys(r["mode"] for r in rows):
                sel = [r for r in rows if (r["scenario"], r["variant"], r["mode"], r["method"])
                       == (scen, var, mode, "network")]
                if not sel:
                    continue
                n = np.array([r["n"] for r in sel], float)
                cells = [f"{r['within_1sigma']:.2f} / {r['within_2sigma']:.2f}"
                         for r in sorted(sel, key=lambda r: r["fold"])]
                p1 = float(np.sum(n * [r["within_1sigma"] for r in sel]) / n.sum())
                p2 = float(np.sum(n * [r["within_2sigma"] for r in sel]) / n.sum())
                z = float(np.sqrt(np.sum(n * np.array([r["z_rms"] for r in sel]) ** 2) / n.sum()))
                lines.append(f"| {scen} | {var} | {mode} | " + " | ".join(cells)
                             + f" | {p1:.3f} / {p2:.3f} | {z:.2f} |")
    return "\n".join(lines)


def report(rows: list[dict]) -> str:
    from graphnav.nets.crossval import format_fold_gains, format_summary, summarise
    return "\n\n".join([
        "Pooled over the folds (IMU-aware network / average, m/s; gain = 1 - net/avg; worst fold = largest ratio):",
        format_summary(summarise(rows)),
        "Gain against the average per fold (beam / velocity RMSE):",
        format_fold_gains(rows),
        "Sigma coverage of the IMU-aware network (Gaussian 0.683 / 0.954):",
        coverage_table(rows)])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--missing", default="3-missing", help="scenario (default 3-missing)")
    p.add_argument("--grades", nargs="*", default=["tactical", "mems"], help="IMU grades of the extra training "
                   "copies (default tactical mems; none: recorded IMU only)")
    p.add_argument("--folds", nargs="+", type=int, help="fold indices to run (default all five)")
    p.add_argument("--epochs", type=int, default=15, help="one-step epochs (shipped: 60)")
    p.add_argument("--rollout-epochs", type=int, default=3, help="recursive-stage epochs (shipped: 20)")
    p.add_argument("--rollout-stride", type=int, default=6, help="pings between rollout starts (shipped: 3)")
    p.add_argument("--draws", type=int, default=2, help="beam-noise draws per IMU copy (shipped: 6)")
    p.add_argument("--sigma-epochs", type=int, default=10, help="sigma-head epochs (shipped: 20)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--fused", action="store_true", help="also the network combined with the average by their "
                   "sigmas (graphnav.nets.fused), reported as the variants 'IMU <grade>, fused'")
    p.add_argument("--out", default="out/imu_folds/rows.json", help="rows (JSON), rewritten after every fold")
    p.add_argument("--report", nargs="+", metavar="ROWS_JSON", help="only print the tables of finished runs "
                   "(several files: folds run in separate processes, joined)")
    a = p.parse_args(argv)
    if a.report:
        print(report([r for f in a.report for r in json.loads(Path(f).read_text())]))
        return 0
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.imu_network import ImuNetworkCompleter
    from graphnav.nets.imu_training import ImuTrainOptions, train_imu
    from graphnav.nets.model import normalize_missing, scenario_name
    akit_dir = akit_trajectories(a.data)[0].parent
    scenario = scenario_name(normalize_missing(a.missing))
    opt = ImuTrainOptions(epochs=a.epochs, rollout_epochs=a.rollout_epochs, rollout_stride=a.rollout_stride,
                          draws=a.draws, sigma_epochs=a.sigma_epochs, seed=a.seed, threads=1,
                          imu_grades=tuple(a.grades))
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    rows = json.loads(out.read_text()) if out.exists() else []
    done = {r["fold"] for r in rows}
    for f in a.folds if a.folds is not None else range(len(AKIT_FOLDS)):
        if f in done:
            print(f"fold {f}: already in {out}", file=sys.stderr)
            continue
        held = AKIT_FOLDS[f]
        train = tuple(t for pair in AKIT_FOLDS for t in pair if t not in held)
        t0 = time.perf_counter()
        result = train_imu(scenario, opt, akit_dir, progress=False, evaluate=False, trajectories=train)
        t1 = time.perf_counter()
        new = fold_rows(f, held, scenario, ImuNetworkCompleter(result.model, result.card), akit_dir, a.fused)
        for r in new:
            r["train_time_s"] = result.card["training"]["time_s"]
        rows += new
        out.write_text(json.dumps(rows, indent=1))
        print(f"fold {f} {list(held)}: training {t1 - t0:.0f} s (stages {result.card['training']['time_s']} s), "
              f"scoring {time.perf_counter() - t1:.0f} s", file=sys.stderr, flush=True)
    print(report(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
