"""Would a gate on the fused completer's departure from the average protect the folds it loses? Every placement.

The fused completer (``Graph-HNI``'s: the IMU-aware fold network with its input envelope and the beam-only fold
ensemble, neither fading) is better than the average estimator over every placement of recursive 30-ping outages,
and worse at single placements (fold 1 with MEMS, fold 3). This study asks whether the
completer could tell such an outage at its start: at the outage's first ping (the history still holds true beams)
it measures how far the fused completion departs from the average's, in the average's own sigma,

    z0 = max over the missing beams of |b_fused - b_average| / sigma_average,

and a gate with threshold Z completes the whole outage with the average when ``z0 > Z``. Each outage starts its
history afresh (:func:`graphnav.nets.evaluate.outage_rollout`), so a gated window's squared errors are exactly the
average's in the same window, and one pass over the windows' first pings scores every threshold from the rows of
``experiments/outage_placement.py`` (which hold both completers' errors per window).

The threshold is chosen by the fadings' rule (fewest fold cells worse than the average over training draws, folds,
evaluation IMUs and beam / velocity, then the largest smallest pooled gain; a tie goes to the larger Z, i.e. less
gating), on all folds and leave-one-fold-out. The report gives, per threshold, the share of windows gated, the pooled
velocity gain per draw and IMU over every placement, the worst fold cell and the count of worse fold cells, over
every placement and at the studies' one placement (p = 0). Usage (the rows of the shipped pair, both draws)::

    .venv/bin/python experiments/departure_gate.py --rows out/decay/2_i1_b1.json --out out/gate/2_d1.json
    .venv/bin/python experiments/departure_gate.py --rows out/decay/s100_2_i1_b1.json --out out/gate/2_d2.json
    .venv/bin/python experiments/departure_gate.py --report out/gate/2_d1.json out/gate/2_d2.json

A run reads the scenario, the fold networks and their fadings from the rows (about 1 min a file on one core).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

NAME = "fused, envelope"
THRESHOLDS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, float("inf"))


def first_ping_departure(fused, average, series, starts, missing) -> list[float]:
    """``z0`` (module docstring) of each window ``(series index, first ping)`` of ``starts``: both completers' first
    completion from a history primed with the true pings before the window, as the rollout completes it."""
    from graphnav.estimators.history import BeamHistory
    valid = np.ones(4, dtype=bool)
    valid[list(missing)] = False
    out = []
    for i, start in starts:
        s = series[i]
        done = []
        for c in (fused, average):
            hist = BeamHistory(c.n_past)
            for k in range(start - c.n_past, start):
                hist.push(s.beams[k])
            imu = s.imu_window(start, c.imu_samples) if getattr(c, "needs_imu", False) else None
            done.append(hist.complete(c, s.beams[start], valid, imu=imu))
        (b_fused, _), (b_avg, s_avg) = done
        out.append(float(np.max(np.abs(b_fused[~valid] - b_avg[~valid]) / s_avg[~valid])))
    return out


def gated_sq(row: dict, threshold: float, select=None) -> tuple[list, list]:
    """(gated, average): per metric (beam, velocity) the windows' summed squared errors of the gated completer
    (the average's where ``z0 > threshold``, else the fused completer's) and of the average, over the windows
    ``select`` (a boolean mask; default all)."""
    use_average = np.asarray(row["z0"]) > threshold
    mask = np.ones(use_average.size, bool) if select is None else np.asarray(select, bool)
    gated, average = [], []
    for m in (0, 1):
        net, avg = np.asarray(row["sq"][NAME][m], float), np.asarray(row["sq"]["average"][m], float)
        gated.append(np.where(use_average, avg, net)[mask])
        average.append(avg[mask])
    return gated, average


def gate_gains(rows: list[dict], threshold: float, folds, placement: int | None = None):
    """(pooled, per_fold, share gated): velocity and beam gains (%) against the average of the gated completer,
    pooled over ``folds`` per (draw, IMU, metric) and per (draw, fold, IMU, metric), over every placement or only
    ``placement``: the placement study's :func:`decay_gains` on the gated windows."""
    from outage_placement import decay_gains, row_placements
    scored = []
    for r in rows:
        mask = None if placement is None else row_placements(r) == placement
        gated, average = gated_sq(r, threshold, mask)
        scored.append({**r, "sq": {NAME: gated, "average": average}})
    pooled, per_fold = decay_gains(scored, NAME, folds)
    share = np.mean([np.mean(np.asarray(r["z0"]) > threshold) for r in rows if r["fold"] in folds])
    return pooled, per_fold, float(share)


def choose_threshold(rows: list[dict], folds, thresholds=THRESHOLDS) -> float:
    """The fadings' rule over ``thresholds`` on ``folds``: fewest fold cells worse than the average, then the
    largest smallest pooled gain, then the larger threshold (less gating)."""
    from outage_placement import rule_key
    return min(thresholds, key=lambda z: (*rule_key(*gate_gains(rows, z, folds)[:2]), -z))


def variants_report(rows: list[dict], variants, score, choose, label, extra=None, what="gated completer",
                    scope="every placement") -> str:
    """Per scenario of ``rows``: a table of each variant's velocity gains against the average, pooled per training
    draw and evaluation IMU, its worst fold cell and the fold cells worse, over every window and at p = 0; then the
    variant the rule picks on all folds and for each fold left out, with that fold's worst velocity cell.

    ``variants(sel)`` lists the variants of one scenario's rows ``sel``; ``score(sel, v, folds, placement)`` gives
    (pooled, per_fold) gains (:func:`outage_placement.decay_gains`' keys); ``choose(sel, folds, variants)`` the rule;
    ``label(v)`` the text of a variant (``label(None)``: of the variants' parameter); ``extra``: an optional (header,
    ``cell(sel, v, folds)``) column; ``what`` and ``scope`` name the completer and the windows scored."""
    from outage_placement import row_draw
    lines = []
    for scenario in dict.fromkeys(r["scenario"] for r in rows):
        sel = [r for r in rows if r["scenario"] == scenario]
        draws = list(dict.fromkeys(map(row_draw, sel)))
        folds = sorted({r["fold"] for r in sel})
        grades = list(dict.fromkeys(r["grade"] for r in sel))
        names = variants(sel)
        head = [label(None)] + ([extra[0]] if extra else [])
        lines += [f"### {scenario} (draws: " + ", ".join(f"{k + 1} = {d}" for k, d in enumerate(draws)) + ")", "",
                  f"Gain against the average (%) of the {what}: velocity, pooled per draw over "
                  + " / ".join(grades) + "; the worst pooled cell and the worst fold cell over beam and velocity, "
                  "and the fold cells worse", "",
                  "| " + " | ".join(head) + " | " + " | ".join(f"pooled, draw {k + 1}" for k in range(len(draws)))
                  + " | worst fold cell | worse | at p = 0: worst pooled | worst fold cell | worse |",
                  "| --- " * (5 + len(head) + len(draws)) + "|"]

        def cell(key, v):
            return f"{v:+.1f} (draw {draws.index(key[0]) + 1}, fold {key[1]}, {key[2]}, {('beam', 'velocity')[key[3]]})"
        for v in names:
            pooled, per_fold = score(sel, v, folds, None)
            p0, f0 = score(sel, v, folds, 0)
            worst = min(per_fold, key=per_fold.get)
            worst0 = min(f0, key=f0.get)
            lines.append(f"| {label(v)} | " + (f"{extra[1](sel, v, folds)} | " if extra else "") + " | ".join(
                " / ".join(f"{pooled[d, g, 1]:+.1f}" for g in grades) for d in draws)
                + f" | {cell(worst, per_fold[worst])} | {sum(x < 0 for x in per_fold.values())} | "
                f"{min(p0.values()):+.1f} | {cell(worst0, f0[worst0])} | {sum(x < 0 for x in f0.values())} |")
        lines += ["", f"Chosen on all folds: {label(None)} = {label(choose(sel, folds, names))}. Chosen without the "
                  f"fold it is scored on (that fold's worst velocity cell, {scope}; at p = 0):"]
        for f in folds:
            v = choose(sel, [g for g in folds if g != f], names)
            _, per_fold = score(sel, v, [f], None)
            _, f0 = score(sel, v, [f], 0)
            lines.append(f"- fold {f}: {label(None)} = {label(v)} -> "
                         f"{min(x for k, x in per_fold.items() if k[3] == 1):+.1f}; "
                         f"{min(x for k, x in f0.items() if k[3] == 1):+.1f}")
        lines.append("")
    return "\n".join(lines)


def report(rows: list[dict], thresholds=THRESHOLDS) -> str:
    return variants_report(
        rows, lambda sel: thresholds, lambda sel, z, folds, placement: gate_gains(sel, z, folds, placement)[:2],
        choose_threshold, lambda z: "Z" if z is None else f"{z:g}",
        ("windows gated", lambda sel, z, folds: f"{gate_gains(sel, z, folds)[2]:.2f}"))


def read_rows(parser, path: str, needs: tuple[str, ...], hints: dict | None = None) -> list[dict]:
    """The rows of the JSON file ``path``; ``parser.error`` names the file if it cannot be read or a row lacks a key
    of ``needs`` (with ``hints[key]`` added after the keys when that key is among the missing)."""
    try:
        rows = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        parser.error(f"{path}: cannot read rows ({exc})")
    missing = [k for k in needs if not (isinstance(rows, list) and rows and all(k in r for r in rows))]
    if missing:
        parser.error(f"{path}: rows without {', '.join(repr(k) for k in missing)}"
                     + "".join(text for k, text in (hints or {}).items() if k in missing))
    return rows


def rows_scenario(rows: list[dict], rows_path) -> str:
    """The one scenario of ``outage_placement.py`` ``rows`` (read from ``rows_path``) that score ``NAME``; a
    :class:`SystemExit` naming the file otherwise."""
    if not rows or any(NAME not in r["sq"] for r in rows) or len({r["scenario"] for r in rows}) != 1:
        raise SystemExit(f"{rows_path}: not outage_placement.py rows of one scenario scoring '{NAME}'")
    return rows[0]["scenario"]


def row_networks(row: dict, loaded: dict):
    """(IMU-aware, beam-only) fold networks a row was scored with (its networks' folders and fadings), loaded once
    per folders and fadings into ``loaded``."""
    from imu_beam_fused_folds import fold_networks
    key = (row["nets"]["IMU-aware"], row["nets"]["beam-only"], row["run_decay"]["IMU-aware"],
           row["run_decay"]["beam-only"])
    if key not in loaded:
        loaded[key] = fold_networks(row["scenario"], *key)
    return loaded[key][row["fold"]]


def run(rows: list[dict], rows_path: Path, out: Path, data=None) -> list[dict]:
    """``z0`` of every window of ``outage_placement.py`` ``rows`` (read from ``rows_path``, ``NAME`` scored), with
    the rows' fold networks and fadings; the rows with ``z0`` added are written to ``out``."""
    from imu_completer_folds import default_dvl_only, held_out_series
    from outage_placement import envelope_variants

    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.fused import FusedCompleter
    scenario = rows_scenario(rows, rows_path)
    nets = {}
    for r in rows:
        net, beam_net = row_networks(r, nets)
        default_dvl_only(net, "departure_gate.py")
        fused = FusedCompleter(envelope_variants(net, data)(True), beam_net)
        series = held_out_series(AKIT_FOLDS[r["fold"]], data, r["grade"])
        r["z0"] = first_ping_departure(fused, AverageCompleter(AVERAGE_N_PAST[scenario]), series,
                                       [tuple(s) for s in r["starts"]], net.missing)
        print(f"fold {r['fold']} {r['grade']}: {len(r['z0'])} windows", file=sys.stderr, flush=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(rows))
    return rows


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rows", help="experiments/outage_placement.py rows scoring 'fused, envelope' (JSON)")
    p.add_argument("--out", help="the rows with each window's z0 (JSON)")
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--report", nargs="+", metavar="GATE_JSON", help="only print the tables of finished runs")
    a = p.parse_args(argv)

    row_keys = ("scenario", "fold", "grade", "starts", "settle", "stride", "sq", "nets")
    if a.report:
        print(report([r for path in a.report for r in read_rows(
            p, path, row_keys + ("z0",), {"z0": " (run --rows ... --out first)"})]))
        return 0
    if not (a.rows and a.out):
        p.error("--rows and --out are needed (or --report)")
    rows = read_rows(p, a.rows, row_keys + ("run_decay",))
    print(report(run(rows, Path(a.rows), Path(a.out), a.data)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
