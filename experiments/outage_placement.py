"""Does a fold's verdict through outages depend on where the outages fall? Every placement of a 30-ping outage.

The completer studies score recursive 30-ping outages at one placement: a window every 90 pings from ping
``OUTAGE_SETTLE`` (:mod:`graphnav.nets.imu_evaluate`), four windows on a 400-ping A-KIT trajectory, eight a fold.
Moving them 15 pings turned the beam-only ensemble from "worse in no fold" to "worse in folds 0 and 3"
(docs/decisions/completers.md). This study scores the same completers with a window starting every ``--stride``
pings (default 10; windows overlap, and each starts again from the true past, as every outage does):

- **placement p** (p = 0 .. 90 / stride - 1): the windows starting ``settle + p * stride + 90 k``, i.e. the
  studies' layout shifted by ``p * stride`` pings; p = 0 is the studies' own windows;
- **every placement**: all windows together, the expected gain over where an outage falls.

For each fold's held-out pair, each evaluation IMU and each completer (the IMU-aware fold network fading, the
beam-only fold ensemble fading, and the two fused as ``Graph-HNI`` fuses them: inverse-variance weights, the sigma
does not change the completion; the IMU-aware network and the fusion again with the IMU-aware network's input
envelope, the range and steps of the beams it was trained on, outside which it hands the ping to the average
estimator as the beam-only network does), it keeps every window's summed squared beam and velocity errors beside the
average estimator's on the same window. The report gives per fold the gain against the average at p = 0, its
range over the placements, the gain over every placement with a 90 % interval (the windows of one 90-ping block of
a trajectory drawn again together: overlapping windows are not independent evidence), and in how many placements
the fold is worse. ``--completers`` scores only some of them (the average is always run); the two fused ones alone
take about half the time. Usage::

    .venv/bin/python experiments/outage_placement.py --scenario 2-missing --imu-nets out/imu_folds/nets2 \\
        --beam-nets out/ens2/akit-residual-aug-ens5 --out out/placement/rows2.json
    .venv/bin/python experiments/outage_placement.py --scenario 2-missing --imu-nets out/imu_folds/nets2s100 \\
        --beam-nets out/ens2-s100/akit-residual-aug-ens5 --completers fused "fused, envelope" \\
        --out out/placement/s100_2.json
    .venv/bin/python experiments/outage_placement.py --report out/placement/rows2.json out/placement/rows3.json
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

PERIOD = 90          # pings from one outage window to the next in the studies (30-ping window, 60-ping gap)
COMPLETERS = ("IMU-aware, fading", "beam-only, fading", "fused", "IMU-aware, envelope", "fused, envelope")


def window_starts(series, n_past: int, settle: int, stride: int) -> list[tuple[int, int]]:
    """(series index, first ping) of every outage window :func:`rollout_windows` makes, in its order."""
    from completer_fade_folds import WINDOW

    from graphnav.nets.evaluate import outage_window_starts
    return [(i, start) for i, s in enumerate(series)
            for start in outage_window_starts(len(s.beams), n_past, WINDOW, stride - WINDOW, settle)]


def rollout_windows(completers: dict, series, missing, settle: int, stride: int) -> tuple[dict, list]:
    """Each completer's per-window summed squared errors (beam, velocity; two lists) through recursive outages
    starting every ``stride`` pings from ``settle``, and the windows' (series index, first ping)."""
    from completer_fade_folds import WINDOW, window_sq

    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.evaluate import outage_rollout
    geometry = DvlGeometry.from_spec(DvlSpec())
    sq, reference, n_past = {}, None, None
    for name, comp in completers.items():
        full, _, samples = outage_rollout(comp, series, missing, window=WINDOW, gap=stride - WINDOW, settle=settle)
        if reference is not None and not np.array_equal(samples.beams, reference.beams):
            raise RuntimeError(f"the outage pings of {name} differ from the first completer's")
        reference, n_past = samples, comp.n_past if n_past is None else n_past
        sq[name] = window_sq(full, samples, missing, geometry)
    return sq, window_starts(series, n_past, settle, stride)


def placement_of(starts: list[tuple[int, int]], settle: int, stride: int) -> np.ndarray:
    """Placement index of each window: 0 for the studies' windows (``settle + 90 k``), p for those shifted by
    ``p * stride`` pings."""
    return np.array([((start - settle) % PERIOD) // stride for _, start in starts])


def block_of(starts: list[tuple[int, int]], settle: int) -> np.ndarray:
    """Block of each window: windows starting in the same 90-ping stretch of the same series share one."""
    keys = [(i, (start - settle) // PERIOD) for i, start in starts]
    index = {k: n for n, k in enumerate(dict.fromkeys(keys))}
    return np.array([index[k] for k in keys])


def gain(net_sq, avg_sq, select=None) -> list[float]:
    """``1 - sqrt(sum net / sum avg)`` per metric (beam, velocity) over the selected windows, in %."""
    out = []
    for a, b in zip(net_sq, avg_sq):
        a, b = np.asarray(a), np.asarray(b)
        if select is not None:
            a, b = a[select], b[select]
        out.append(100.0 * (1.0 - np.sqrt(a.sum() / b.sum())))
    return out


def block_interval(net_sq, avg_sq, blocks: np.ndarray, draws: int = 2000, seed: int = 0) -> list[tuple[float, float]]:
    """90 % interval (%) of the every-placement gain per metric when the 90-ping blocks are drawn again with
    replacement, each with all its windows."""
    rng = np.random.default_rng(seed)
    n = int(blocks.max()) + 1
    out = []
    for a, b in zip(net_sq, avg_sq):
        a_blk = np.bincount(blocks, weights=np.asarray(a), minlength=n)
        b_blk = np.bincount(blocks, weights=np.asarray(b), minlength=n)
        idx = rng.integers(0, n, (draws, n))
        g = 100.0 * (1.0 - np.sqrt(a_blk[idx].sum(axis=1) / b_blk[idx].sum(axis=1)))
        out.append(tuple(float(x) for x in np.percentile(g, [5, 95])))
    return out


def envelope_variants(net, akit_dir):
    """A function making the IMU-aware fold network ``net`` afresh (its counters at zero), without an input envelope
    (``False``) or with the envelope of the beams it was trained on (``True``: its card's, or rebuilt from the
    card's training trajectories for cards saved before cards held one)."""
    from graphnav.nets.imu_network import ImuNetworkCompleter
    from graphnav.nets.imu_training import card_envelope
    card = dict(net.card)
    envelope = card.pop("envelope", None) or card_envelope(card, akit_dir)
    return lambda enveloped: ImuNetworkCompleter(net.model, {**card, "envelope": envelope} if enveloped else card,
                                                 run_decay=net.run_decay)


def run(scenario: str, imu_dir: str, beam_dir: str, akit_dir, out: Path, stride: int,
        names=COMPLETERS) -> list[dict]:
    """Rows of :func:`rollout_windows` per fold and evaluation IMU for the completers ``names`` (a subset of
    :data:`COMPLETERS`; the average is always run), rewritten to ``out`` after every fold."""
    import json

    from completer_fade_folds import WINDOW
    from imu_beam_fused_folds import fold_networks
    from imu_completer_folds import EVAL_GRADES, held_out_series

    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.fused import FusedCompleter
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE
    if PERIOD % stride:
        raise ValueError(f"--stride must divide {PERIOD} so that every placement has the studies' spacing")
    nets = fold_networks(scenario, imu_dir, beam_dir)
    # the IMU-aware network whose envelope fallbacks are counted: its own completer's if it runs, else the fused
    # one's member (the beam-only member keeps counters of its own)
    counted = "IMU-aware, envelope" if "IMU-aware, envelope" in names else "fused, envelope"
    rows = []
    for f, held in enumerate(AKIT_FOLDS):
        net, beam_net = nets[f]
        imu = envelope_variants(net, akit_dir)
        t0 = time.perf_counter()
        for grade in EVAL_GRADES:
            series = held_out_series(held, akit_dir, grade)
            enveloped = imu(True)
            makers = {"IMU-aware, fading": lambda: imu(False), "beam-only, fading": lambda: beam_net,
                      "fused": lambda: FusedCompleter(imu(False), beam_net),
                      "IMU-aware, envelope": lambda: enveloped,
                      "fused, envelope": lambda: FusedCompleter(enveloped if counted == "fused, envelope" else imu(True),
                                                                beam_net)}
            completers = {"average": AverageCompleter(AVERAGE_N_PAST[scenario])} | {n: makers[n]() for n in names}
            sq, starts = rollout_windows(completers, series, list(net.missing), OUTAGE_SETTLE, stride)
            row = {"scenario": scenario, "fold": f, "held_out": list(held), "grade": grade,
                   "settle": OUTAGE_SETTLE, "stride": stride, "starts": starts, "sq": sq}
            if counted in names:
                row |= {"envelope_fallbacks": enveloped.fallbacks["envelope"], "envelope_counted_in": counted,
                        "completions": len(starts) * WINDOW}
            rows.append(row)
        out.write_text(json.dumps(rows))
        print(f"fold {f} {list(held)}: {len(starts)} windows a grade in {time.perf_counter() - t0:.0f} s",
              file=sys.stderr, flush=True)
    return rows


def report(rows: list[dict]) -> str:
    lines = ["Gain against the average estimator through recursive 30-ping outages, beam / velocity RMSE (%): at the "
             "studies' placement (p = 0), the range over the placements, and over every placement with its 90 % "
             "interval (90-ping blocks drawn again); `worse in` counts the placements where the fold's velocity "
             "gain is negative.", ""]
    for sc in dict.fromkeys(r["scenario"] for r in rows):
        for grade in dict.fromkeys(r["grade"] for r in rows if r["scenario"] == sc):
            sel = sorted((r for r in rows if (r["scenario"], r["grade"]) == (sc, grade)), key=lambda r: r["fold"])
            settle, stride = sel[0]["settle"], sel[0]["stride"]
            n_place = PERIOD // stride
            lines += [f"### {sc}, {grade} IMU ({n_place} placements, a window every {stride} pings)", "",
                      "| completer | fold | p = 0 | range over placements (velocity) | every placement | 90 % "
                      "interval (velocity) | worse in |", "| --- | --- | --- | --- | --- | --- | --- |"]
            for name in (n for n in COMPLETERS if all(n in r["sq"] for r in sel)):
                pooled = {"p0": [[], []], "all": [[], []], "avg_p0": [[], []], "avg_all": [[], []]}
                place_pooled = [[[0.0, 0.0], [0.0, 0.0]] for _ in range(n_place)]
                for r in sel:
                    place = placement_of([tuple(s) for s in r["starts"]], settle, stride)
                    blocks = block_of([tuple(s) for s in r["starts"]], settle)
                    net, avg = r["sq"][name], r["sq"]["average"]
                    by_place = [gain(net, avg, place == p) for p in range(n_place)]
                    vel = [g[1] for g in by_place]
                    g0, g_all = by_place[0], gain(net, avg)
                    lo, hi = block_interval(net, avg, blocks)[1]
                    lines.append(f"| {name} | {r['fold']} | {g0[0]:+.1f} / {g0[1]:+.1f} | {min(vel):+.1f}..{max(vel):+.1f}"
                                 f" | {g_all[0]:+.1f} / {g_all[1]:+.1f} | {lo:+.1f}..{hi:+.1f} | "
                                 f"{sum(v < 0 for v in vel)} of {n_place} |")
                    for m in (0, 1):
                        a, b = np.asarray(net[m]), np.asarray(avg[m])
                        for p in range(n_place):
                            place_pooled[p][0][m] += a[place == p].sum()
                            place_pooled[p][1][m] += b[place == p].sum()
                        pooled["all"][m].append(a.sum())
                        pooled["avg_all"][m].append(b.sum())
                pv = [100 * (1 - np.sqrt(n[1] / d[1])) for n, d in place_pooled]
                g_all = [100 * (1 - np.sqrt(sum(pooled["all"][m]) / sum(pooled["avg_all"][m]))) for m in (0, 1)]
                p0 = [100 * (1 - np.sqrt(place_pooled[0][0][m] / place_pooled[0][1][m])) for m in (0, 1)]
                lines.append(f"| {name} | pooled | {p0[0]:+.1f} / {p0[1]:+.1f} | {min(pv):+.1f}..{max(pv):+.1f} | "
                             f"{g_all[0]:+.1f} / {g_all[1]:+.1f} | | {sum(v < 0 for v in pv)} of {n_place} |")
            if "envelope_fallbacks" in sel[0]:
                lines += ["", "Completions the IMU-aware network left to the average (outside its envelope; in "
                          f"`{sel[0].get('envelope_counted_in', 'IMU-aware, envelope')}`): " + "; ".join(
                    f"fold {r['fold']} {r['envelope_fallbacks']} of {r['completions']}" for r in sel)]
            lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from imu_beam_fused_folds import fold_network_parser, report_or_run
    p = fold_network_parser(__doc__, "out/placement/rows.json")
    p.add_argument("--stride", type=int, default=10, help="pings between window starts (divides 90; default 10)")
    p.add_argument("--completers", nargs="+", choices=COMPLETERS, default=list(COMPLETERS), metavar="NAME",
                   help="completers scored against the average (default all: " + ", ".join(f"'{n}'" for n in COMPLETERS)
                   + "); the two fused ones alone take about half the time")
    a = p.parse_args(argv)
    return report_or_run(p, a, report, lambda out: run(a.scenario, a.imu_nets, a.beam_nets, a.data, out, a.stride,
                                                       a.completers))


if __name__ == "__main__":
    sys.exit(main())
