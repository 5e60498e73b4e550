"""Can a trajectory's own recent pings tell when the fused completer will be worse than the average in an outage?
(docs/decisions/completers.md)

Through 30-ping outages with 2 missing beams the fused completer (``Graph-HNI``'s: the IMU-aware and beam-only
fold networks, both fading, inverse-variance weights, sigma with the correlation fitted on the other folds) is worse
than the average estimator in fold 3's velocity (trajectories 6 and 13), and no rule fitted on the other folds
(a fading, a gate on steadiness, a fusion with the average) protects that fold. This study fits nothing: it mixes the
fused completion ``b_F`` with the average's ``b_A`` by what the two did on the same trajectory just before,

    b = w b_F + (1 - w) b_A

with ``e_F``, ``e_A`` the mean squared errors of the missing beams over the last ``K`` measured pings, and

- ``select K``: ``w = 1`` where ``e_F <= e_A``, else 0;
- ``inverse K``: ``w = e_A / (e_F + e_A)`` (inverse mean squared error).

The errors come from one of two sources, both available online since those pings were measured:

- ``per ping``: each completer's one-step completion of the last ``K`` pings from their true past;
- ``rollout``: each completer run recursively through the last ``K`` pings as if the beams had been missing (a
  rehearsal of the outage on the pings just before it).

Per ping, the weights of ping ``k`` come from the one-step errors of pings ``k-K .. k-1``; through an outage the
weights are made at its first ping and kept, and each member completes the outage on its own history. Scored per
fold and evaluation IMU against the average (beam / velocity RMSE gain, %), on the pings and outage windows of
``experiments/imu_beam_fused_folds.py`` (on the beams of the DVL the pair was trained for). Usage::

    .venv/bin/python experiments/recent_error_mixture.py --scenario 2-missing --imu-nets out/imu_folds/nets2s100 \\
        --beam-nets out/ens2-s100/akit-residual-aug-ens5 --out out/mixture/mix2.json
    .venv/bin/python experiments/recent_error_mixture.py --report out/mixture/mix2.json
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

WINDOW, GAP = 30, 60        # the outage windows of imu_beam_fused_folds.py (outage_rollout's defaults)
KS = (10, 20, 30)


def row_index(series, n_past: int, n_imu: int) -> dict:
    """(series index, ping) -> row of :func:`imu_beam_fused_folds.per_ping`'s samples (the usable pings from
    ``n_past`` on, series after series)."""
    rows, i = {}, 0
    for si, s in enumerate(series):
        ok = s.usable(n_past, n_imu)
        ok[:n_past] = False
        for k in np.flatnonzero(ok):
            rows[si, int(k)] = i
            i += 1
    return rows


def outage_starts(series, n_past: int, settle: int) -> list[tuple[int, int]]:
    """(series index, first ping) of every outage window of :func:`graphnav.nets.evaluate.outage_rollout`."""
    from graphnav.nets.evaluate import outage_window_starts
    return [(si, start) for si, s in enumerate(series)
            for start in outage_window_starts(len(s.beams), n_past, WINDOW, GAP, settle)]


def rehearsal_errors(completers, s, missing, start: int, k_pings: int) -> tuple[float, ...] | None:
    """Each completer's mean squared error of the missing beams when it completes pings ``start - K .. start - 1``
    of series ``s`` recursively, as if they had been missing (None where the IMU window or the past is too short, or
    a beam it would read is not finite). Nothing from ``start`` on is read."""
    from graphnav.estimators.history import BeamHistory
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE
    first = start - k_pings
    n_past = max(c.n_past for c in completers)
    if first < OUTAGE_SETTLE or first - n_past < 0 or not np.all(np.isfinite(s.beams[first - n_past:start])):
        return None
    valid = np.ones(4, dtype=bool)
    valid[missing] = False
    out = []
    for comp in completers:
        hist = BeamHistory(comp.n_past)
        for k in range(first - comp.n_past, first):
            hist.push(s.beams[k])
        total = 0.0
        for k in range(first, start):
            imu = s.imu_window(k, comp.imu_samples) if getattr(comp, "needs_imu", False) else None
            b, _ = hist.complete(comp, s.beams[k], valid, imu=imu)
            total += float(np.sum((b[missing] - s.beams[k][missing]) ** 2))
        out.append(total / k_pings)
    return tuple(out)


def mixed(fused: np.ndarray, average: np.ndarray, errors: dict, rule: str) -> np.ndarray:
    """``fused`` and ``average`` completions (N, 4) mixed row by row with weights from ``errors`` (row -> (e_F,
    e_A); rows without an entry keep the fused completion)."""
    out = fused.copy()
    for i, (e_f, e_a) in errors.items():
        w = float(e_f <= e_a) if rule == "select" else e_a / (e_f + e_a + 1e-12)
        out[i] = w * fused[i] + (1.0 - w) * average[i]
    return out


def squared_errors(full: np.ndarray, samples, missing, geometry) -> list[float]:
    """Summed squared beam and velocity errors and the number of pings."""
    eb = np.sum((full[:, missing] - samples.beams[:, missing]) ** 2)
    ev = np.sum((geometry.velocity_from_beams(full) - samples.v_b) ** 2)
    return [float(eb), float(ev), len(full)]


def fold_rows(fold: int, grade: str, scenario: str, nets, series, pp: dict, rho: float) -> list[dict]:
    """Rows of one fold and evaluation IMU, velocities solved with the geometry of the DVL the pair was trained for
    (:func:`imu_beam_fused_folds.pair_dvl`; the series' beams were made for it), which each row names."""
    from imu_beam_fused_folds import pair_dvl

    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.dvl_match import dvl_name
    from graphnav.nets.evaluate import outage_rollout
    from graphnav.nets.fused import FusedCompleter, fuse
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE
    imu_net, beam_net = nets
    miss = list(imu_net.missing)
    spec = pair_dvl(imu_net, beam_net, "recent_error_mixture.py")
    geometry = DvlGeometry.from_spec(spec)
    average = AverageCompleter(AVERAGE_N_PAST[scenario])
    samples = pp["samples"]
    rows = row_index(series, max(imu_net.n_past, beam_net.n_past, average.n_past), imu_net.imu_samples)
    if len(rows) != len(samples.beams):
        raise RuntimeError(f"{len(rows)} usable pings, {len(samples.beams)} per-ping samples")
    fused_pp = fuse(*pp["imu"], *pp["beam"], 0.0, rho)[0]
    avg_pp = pp["average"][0]
    sq = {name: np.sum((b[:, miss] - samples.beams[:, miss]) ** 2, axis=1) for name, b in (("F", fused_pp),
                                                                                        ("A", avg_pp))}

    def recent(si: int, k: int, k_pings: int):
        idx = [rows[si, j] for j in range(k - k_pings, k) if (si, j) in rows]
        return (float(sq["F"][idx].mean()), float(sq["A"][idx].mean())) if len(idx) >= k_pings // 2 else None

    base = {"fold": fold, "grade": grade, "scenario": scenario, "rho": rho, "dvl": dvl_name(spec)}
    by_row = {i: key for key, i in rows.items()}
    made = {"average": squared_errors(avg_pp, samples, miss, geometry),
            "fused": squared_errors(fused_pp, samples, miss, geometry)}
    for k_pings in KS:
        errs = {i: e for i in range(len(samples.beams)) if (e := recent(*by_row[i], k_pings)) is not None}
        for rule in ("select", "inverse"):
            made[f"{rule} {k_pings}, per ping"] = squared_errors(mixed(fused_pp, avg_pp, errs, rule), samples, miss,
                                                                 geometry)
    out = [{**base, "mode": "per ping", "sq": made}]

    fc = FusedCompleter(imu_net, beam_net, sigma_rho=rho)
    f_out, _, o_samples = outage_rollout(fc, series, miss, window=WINDOW, gap=GAP, settle=OUTAGE_SETTLE)
    a_out, _, a_samples = outage_rollout(average, series, miss, window=WINDOW, gap=GAP, settle=OUTAGE_SETTLE)
    if not np.array_equal(o_samples.beams, a_samples.beams):
        raise RuntimeError("the outage pings of the fused completer and the average differ")
    starts = outage_starts(series, fc.n_past, OUTAGE_SETTLE)
    if len(starts) * WINDOW != len(o_samples.beams):
        raise RuntimeError(f"{len(starts)} outage windows for {len(o_samples.beams)} outage pings")
    made = {"average": squared_errors(a_out, o_samples, miss, geometry),
            "fused": squared_errors(f_out, o_samples, miss, geometry)}
    picks = {}      # "K, source" -> [outages where the fused completer had the smaller recent error, outages scored]
    for k_pings in KS:
        sources = {"per ping": {}, "rollout": {}}
        for w, (si, start) in enumerate(starts):
            window_rows = range(w * WINDOW, (w + 1) * WINDOW)
            for source, e in (("per ping", recent(si, start, k_pings)),
                              ("rollout", rehearsal_errors((fc, average), series[si], miss, start, k_pings))):
                if e is None:
                    continue
                sources[source].update({i: e for i in window_rows})
                count = picks.setdefault(f"{k_pings}, {source}", [0, 0])
                count[0] += int(e[0] <= e[1])
                count[1] += 1
        for source, errs in sources.items():
            for rule in ("select", "inverse"):
                made[f"{rule} {k_pings}, {source}"] = squared_errors(mixed(f_out, a_out, errs, rule), o_samples,
                                                                     miss, geometry)
    return out + [{**base, "mode": "outage 30 s", "sq": made, "picks": picks}]


def run(scenario: str, imu_dir: str, beam_dir: str, akit_dir, out: Path, imu_decay: float | None = None,
        beam_decay: float | None = None) -> list[dict]:
    from imu_beam_fused_folds import fitted_rho, fold_networks, held_out_per_ping
    from imu_completer_folds import EVAL_GRADES
    nets = fold_networks(scenario, imu_dir, beam_dir, imu_decay, beam_decay)
    series, pp = held_out_per_ping(nets, scenario, akit_dir)
    rows = []
    for f in nets:
        t0 = time.perf_counter()
        for grade in EVAL_GRADES:
            rho = fitted_rho([pp[g, grade] for g in nets if g != f], nets[f][0].missing)
            rows += fold_rows(f, grade, scenario, nets[f], series[f, grade], pp[f, grade], rho)
        out.write_text(json.dumps(rows, indent=1))
        print(f"fold {f}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return rows


def report(rows: list[dict]) -> str:
    """Per scenario, mode and variant: pooled gain against the average (beam / velocity, %), the worst fold cell
    (fold and evaluation IMU) and the number of fold cells worse than the average."""
    from imu_completer_folds import rows_dvl
    lines = [f"The DVL: {rows_dvl(rows, 'recent_error_mixture.py')}", "",
             "| scenario | mode | variant | pooled beam / velocity gain | worst fold cell (beam / velocity) | "
             "worse fold cells (beam / velocity) |", "| --- | --- | --- | --- | --- | --- |"]
    for sc in dict.fromkeys(r["scenario"] for r in rows):
        for mode in ("per ping", "outage 30 s"):
            sel = [r for r in rows if (r["scenario"], r["mode"]) == (sc, mode)]
            for variant in sel[0]["sq"]:
                if variant == "average":
                    continue
                pooled, worst, worse = [], [], []
                for m in (0, 1):
                    net = sum(r["sq"][variant][m] for r in sel)
                    avg = sum(r["sq"]["average"][m] for r in sel)
                    pooled.append(100 * (1 - np.sqrt(net / avg)))
                    cells = {(r["fold"], r["grade"]): 100 * (1 - np.sqrt(r["sq"][variant][m] / r["sq"]["average"][m]))
                             for r in sel}
                    key = min(cells, key=cells.get)
                    worst.append(f"{cells[key]:+.1f} (fold {key[0]}, {key[1]})")
                    worse.append(sum(g < 0 for g in cells.values()))
                lines.append(f"| {sc} | {mode} | {variant} | {pooled[0]:+.1f} / {pooled[1]:+.1f} | "
                             f"{worst[0]} / {worst[1]} | {worse[0]} / {worse[1]} |")
    lines += ["", "Outages before which the fused completer had the smaller recent error (of those with K measured "
              "pings before them), per fold, summed over the evaluation IMUs:"]
    for sc in dict.fromkeys(r["scenario"] for r in rows):
        sel = [r for r in rows if (r["scenario"], r["mode"]) == (sc, "outage 30 s")]
        for key in sel[0]["picks"]:
            cells = []
            for f in sorted({r["fold"] for r in sel}):
                n = np.sum([r["picks"].get(key, [0, 0]) for r in sel if r["fold"] == f], axis=0)
                cells.append(f"fold {f} {n[0]} of {n[1]}")
            lines.append(f"{sc}, K = {key}: " + "; ".join(cells))
    return "\n".join(lines)


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from imu_beam_fused_folds import fold_network_parser, report_or_run
    p = fold_network_parser(__doc__, "out/mixture/mix.json")
    a = p.parse_args(argv)
    return report_or_run(p, a, report, lambda out: run(a.scenario, a.imu_nets, a.beam_nets, a.data, out,
                                                       a.imu_decay, a.beam_decay))


if __name__ == "__main__":
    sys.exit(main())
