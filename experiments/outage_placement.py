"""Does a fold's verdict through outages depend on where the outages fall? Every placement of a 30-ping outage.

The completer studies score recursive 30-ping outages at one placement: a window every 90 pings from ping
``OUTAGE_SETTLE`` (:mod:`graphnav.nets.imu_evaluate`), four windows on a 400-ping A-KIT trajectory, eight a fold.
Moving them 15 pings turned the beam-only ensemble from "worse in no fold" to "worse in folds 0 and 3"
(docs/decisions/completers.md). This study scores the same completers with a window starting every ``--stride``
pings (default 10; windows overlap, and each starts again from the true past, as every outage does):

- **placement p** (p = 0 .. 90 / stride - 1): the windows starting ``settle + p * stride + 90 k``, i.e. the
  studies' layout shifted by ``p * stride`` pings; p = 0 is the studies' own windows;
- **every placement**: all windows together, the expected gain over where an outage falls.

The completers are scored on the beams of the DVL their fold networks were trained for (see
``imu_beam_fused_folds.py``; the Snapir's unless trained with ``--config``), which each row names.

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

``--beam-nets pivot`` puts the pivot completer (its pivot length fitted on the other folds' trajectories) in the
beam-only networks' place, named ``pivot`` in the rows; ``--beam-nets pivot-pitch`` the pivot completer with its own
defaults (yaw and pitch, its own hold), named ``pivot-pitch``.

``--imu-decay`` / ``--beam-decay`` run the two fadings with another ``run_decay`` (default: the cards', each chosen
for its completer alone; ``Graph-HNI`` fuses them with :data:`graphnav.nets.imu_auto.FUSED_RUN_DECAY`), and
``--report FILES --choose-decays`` applies the fadings' rule (fewest fold cells worse than the average, then the
largest smallest pooled gain) to the pairs the files hold, over every placement and every training draw they hold
(a row names its fold networks): on all folds, and leave-one-fold-out with each fold scored on the pair the other
four chose::

    .venv/bin/python experiments/outage_placement.py --scenario 2-missing --imu-nets out/imu_folds/nets2 \\
        --beam-nets out/ens2/akit-residual-aug-ens5 --completers "fused, envelope" --imu-decay 1 --beam-decay 1 \\
        --out out/decay/2_i1_b1.json
    .venv/bin/python experiments/outage_placement.py --report out/decay/2_*.json --choose-decays
"""
from __future__ import annotations

import os
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


def rollout_windows(completers: dict, series, missing, settle: int, stride: int, spec=None) -> tuple[dict, list]:
    """Each completer's per-window summed squared errors (beam, velocity; two lists) through recursive outages
    starting every ``stride`` pings from ``settle``, and the windows' (series index, first ping). Velocities are
    solved with the geometry of the DVL ``spec`` (default: the Snapir's), the one the series' beams were made for."""
    from completer_fade_folds import WINDOW, window_sq

    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.evaluate import outage_rollout
    geometry = DvlGeometry.from_spec(spec or DvlSpec())
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


def row_placements(row: dict) -> np.ndarray:
    """:func:`placement_of` each window of a row of :func:`run` (its ``starts``, ``settle`` and ``stride``)."""
    return placement_of([tuple(st) for st in row["starts"]], row["settle"], row["stride"])


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
        names=COMPLETERS, imu_decay: float | None = None, beam_decay: float | None = None) -> list[dict]:
    """Rows of :func:`rollout_windows` per fold and evaluation IMU for the completers ``names`` (a subset of
    :data:`COMPLETERS`; the average is always run), rewritten to ``out`` after every fold."""
    import json

    from completer_fade_folds import WINDOW
    from imu_beam_fused_folds import PIVOT_MEMBERS, fold_networks, member_label, pair_dvl
    from imu_completer_folds import EVAL_GRADES, held_out_series

    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.dvl_match import dvl_name
    from graphnav.nets.fused import FusedCompleter
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE
    if PERIOD % stride:
        raise ValueError(f"--stride must divide {PERIOD} so that every placement has the studies' spacing")
    nets = fold_networks(scenario, imu_dir, beam_dir, imu_decay, beam_decay, akit_dir)
    second = member_label(beam_dir)
    # the IMU-aware network whose envelope fallbacks are counted: its own completer's if it runs, else the fused
    # one's member (the beam-only member keeps counters of its own)
    counted = "IMU-aware, envelope" if "IMU-aware, envelope" in names else "fused, envelope"
    rows = []
    for f, held in enumerate(AKIT_FOLDS):
        net, beam_net = nets[f]
        spec = pair_dvl(net, beam_net, "outage_placement.py")
        imu = envelope_variants(net, akit_dir)
        t0 = time.perf_counter()
        for grade in EVAL_GRADES:
            series = held_out_series(held, akit_dir, grade, spec)
            enveloped = imu(True)
            makers = {"IMU-aware, fading": lambda: imu(False), second: lambda: beam_net,
                      "fused": lambda: FusedCompleter(imu(False), beam_net),
                      "IMU-aware, envelope": lambda: enveloped,
                      "fused, envelope": lambda: FusedCompleter(enveloped if counted == "fused, envelope" else imu(True),
                                                                beam_net)}
            own = [second if n == "beam-only, fading" else n for n in names]
            completers = {"average": AverageCompleter(AVERAGE_N_PAST[scenario])} | {n: makers[n]() for n in own}
            sq, starts = rollout_windows(completers, series, list(net.missing), OUTAGE_SETTLE, stride, spec)
            row = {"scenario": scenario, "fold": f, "held_out": list(held), "grade": grade, "dvl": dvl_name(spec),
                   "settle": OUTAGE_SETTLE, "stride": stride, "starts": starts, "sq": sq,
                   "run_decay": {"IMU-aware": net.run_decay, "beam-only": getattr(beam_net, "run_decay", 1.0)},
                   "nets": {"IMU-aware": str(imu_dir), "beam-only": str(beam_dir)}}
            if beam_dir in PIVOT_MEMBERS:
                row["pivot_m"], row["pitch_pivot_m"] = beam_net.lengths_m
                row["pivot_n_past"] = beam_net.n_past
            if counted in names:
                row |= {"envelope_fallbacks": enveloped.fallbacks["envelope"], "envelope_counted_in": counted,
                        "completions": len(starts) * WINDOW}
            rows.append(row)
        out.write_text(json.dumps(rows))
        print(f"fold {f} {list(held)}: {len(starts)} windows a grade in {time.perf_counter() - t0:.0f} s",
              file=sys.stderr, flush=True)
    return rows


def pivot_member(row: dict) -> str | None:
    """The pivot completer a row of :func:`run` had as its second member (``--beam-nets pivot`` or
    ``pivot-pitch``), or None."""
    from imu_beam_fused_folds import PIVOT_MEMBERS
    member = row.get("nets", {}).get("beam-only")
    return member if member in PIVOT_MEMBERS else None


def row_decays(row: dict) -> tuple[float, float]:
    """(IMU-aware, beam-only) ``run_decay`` a row was scored with."""
    if "run_decay" not in row:
        raise ValueError("a row without 'run_decay' (the fadings it was scored with): run it again to choose decays")
    return row["run_decay"]["IMU-aware"], row["run_decay"]["beam-only"]


def placements_worse(rows: list[dict], name: str) -> tuple[int, int]:
    """(worse, all): the (fold, evaluation IMU, placement) cells of ``rows`` (placements that hold a window) in
    which ``name``'s velocity gain against the average is negative."""
    worse = total = 0
    for r in rows:
        place = row_placements(r)
        for p in np.unique(place):
            worse += gain(r["sq"][name], r["sq"]["average"], place == p)[1] < 0
            total += 1
    return worse, total


def row_draw(row: dict) -> str:
    """The training draw a row was scored on: the folder of its IMU-aware fold networks."""
    if "nets" not in row:
        raise ValueError("a row without 'nets' (the fold networks it was scored on): run it again to choose decays")
    return os.path.normpath(row["nets"]["IMU-aware"])


def decay_gains(rows: list[dict], name: str, folds) -> tuple[dict, dict]:
    """Over every placement, for the completer ``name`` in ``rows`` of one scenario and one decay pair (one or more
    training draws, :func:`row_draw`): the pooled gain over ``folds`` per (draw, evaluation IMU, metric) and each
    fold's per (draw, fold, IMU, metric), in %."""
    pooled, per_fold = {}, {}
    for draw in dict.fromkeys(map(row_draw, rows)):
        for grade in dict.fromkeys(r["grade"] for r in rows):
            sel = [r for r in rows if row_draw(r) == draw and r["grade"] == grade and r["fold"] in folds]
            windows = {c: [[x for r in sel for x in r["sq"][c][m]] for m in (0, 1)] for c in (name, "average")}
            for m, g in enumerate(gain(windows[name], windows["average"])):
                pooled[draw, grade, m] = g
            for r in sel:
                for m, g in enumerate(gain(r["sq"][name], r["sq"]["average"])):
                    per_fold[draw, r["fold"], grade, m] = g
    return pooled, per_fold


def rule_key(pooled: dict, per_fold: dict) -> tuple[int, float]:
    """The fadings' rule as a sort key on :func:`decay_gains`' output (smaller is better): the fold cells worse than
    the average, then the smallest pooled gain, negated. Each study adds its own tie-break."""
    return sum(g < 0 for g in per_fold.values()), -min(pooled.values())


def choose_decays(by_pair: dict, name: str, folds):
    """The fadings' rule over every placement: the (IMU-aware, beam-only) ``run_decay`` pair with the fewest fold
    cells (training draw x fold x evaluation IMU x beam / velocity) worse than the average, then the largest smallest
    pooled gain (over draws, IMUs and metrics)."""
    def key(pair):
        return *rule_key(*decay_gains(by_pair[pair], name, folds)), pair   # a tie: the faster fading
    return min(by_pair, key=key)


def decay_report(rows: list[dict], name: str = "fused, envelope") -> str:
    """Per scenario, every (IMU-aware, beam-only) ``run_decay`` pair the rows hold in every training draw they hold,
    scored over every placement; the pair :func:`choose_decays` picks on all folds and, leave-one-fold-out, the pair
    each fold gets from the other folds with that fold's gains and the pooled out-of-fold gains (each fold scored
    with its own pair), per draw."""
    lines = [f"`run_decay` of the two fadings for `{name}` over every placement (gain against the average, %, "
             "beam / velocity; worse: fold x IMU x metric cells below the average; placements worse: fold x IMU x "
             "placement cells whose velocity gain is below the average's, which the rule does not count)", ""]
    if not rows:
        raise ValueError("no rows to choose run_decay from")
    from imu_completer_folds import rows_dvl
    rows_dvl(rows, "outage_placement.py --choose-decays")
    if any(map(pivot_member, rows)):
        raise ValueError("rows with the pivot completer as the second member (--beam-nets pivot or pivot-pitch): it "
                         "does not fade, "
                         "and the choice is between the beam-only networks' fadings")
    for sc in dict.fromkeys(r["scenario"] for r in rows):
        sel = [r for r in rows if r["scenario"] == sc and name in r["sq"]]
        if len({(r["settle"], r["stride"]) for r in sel}) > 1:
            raise ValueError(f"{sc}: the rows place their windows differently (settle, stride "
                             f"{sorted({(r['settle'], r['stride']) for r in sel})}); choose over one layout")
        draws = list(dict.fromkeys(map(row_draw, sel)))
        folds = sorted({r["fold"] for r in sel})
        by_pair: dict = {}
        seen = set()
        for r in sel:
            key = (tuple(row_decays(r)), row_draw(r), r["fold"], r["grade"])
            if key in seen:
                raise ValueError(f"{sc}: two rows of run_decay {key[0]}, networks {key[1]}, fold {key[2]}, "
                                 f"{key[3]} IMU (a file given twice?)")
            seen.add(key)
            by_pair.setdefault(key[0], []).append(r)
        # a pair is compared only where it holds every fold of every draw
        by_pair = {k: v for k, v in by_pair.items()
                   if {(row_draw(r), r["fold"]) for r in v} == {(d, f) for d in draws for f in folds}}
        if not by_pair:
            raise ValueError(f"{sc}: no run_decay pair holds every fold of every training draw {draws}")
        grades = list(dict.fromkeys(r["grade"] for r in sel))
        lines += [f"### {sc} (training draws: " + ", ".join(f"{k + 1} = {d}" for k, d in enumerate(draws)) + ")", "",
                  "| IMU-aware / beam-only decay | draw | " + " | ".join(f"pooled, {g}" for g in grades)
                  + " | worst fold cell | worse | placements worse (velocity) |",
                  "| --- | --- |" + " --- |" * (len(grades) + 3)]
        for pair in sorted(by_pair):
            for k, draw in enumerate(draws):
                part = [r for r in by_pair[pair] if row_draw(r) == draw]
                pooled, per_fold = decay_gains(part, name, folds)
                worst = min(per_fold, key=per_fold.get)
                lines.append(f"| {pair[0]:g} / {pair[1]:g} | {k + 1} | " + " | ".join(
                    f"{pooled[draw, g, 0]:+.1f} / {pooled[draw, g, 1]:+.1f}" for g in grades)
                    + f" | {per_fold[worst]:+.1f} (fold {worst[1]}, {worst[2]}, {('beam', 'velocity')[worst[3]]}) | "
                    f"{sum(g < 0 for g in per_fold.values())} | {'{} of {}'.format(*placements_worse(part, name))} |")
        chosen = choose_decays(by_pair, name, folds)
        lines += ["", f"Chosen on all folds: {chosen[0]:g} / {chosen[1]:g}. Chosen without the fold it is scored on:"]
        oof_rows, worse = [], 0
        for f in folds:
            pair = choose_decays(by_pair, name, [o for o in folds if o != f])
            _, per_fold = decay_gains(by_pair[pair], name, [f])
            worse += sum(g < 0 for g in per_fold.values())
            lines.append(f"- fold {f}: {pair[0]:g} / {pair[1]:g} -> " + "; ".join(
                f"draw {k + 1} " + ", ".join(f"{g} {per_fold[d, f, g, 0]:+.1f} / {per_fold[d, f, g, 1]:+.1f}"
                                             for g in grades) for k, d in enumerate(draws)))
            oof_rows += [r for r in by_pair[pair] if r["fold"] == f]
        oof, _ = decay_gains(oof_rows, name, folds)     # each fold with the pair the other folds chose
        lines += ["", "Out of fold, pooled: " + "; ".join(f"draw {k + 1} " + ", ".join(
            f"{g} {oof[draw, g, 0]:+.1f} / {oof[draw, g, 1]:+.1f}" for g in grades) for k, draw in enumerate(draws))
            + f"; fold cells worse: {worse}", ""]
    return "\n".join(lines)


def report(rows: list[dict]) -> str:
    from imu_completer_folds import rows_dvl
    lines = ["Gain against the average estimator through recursive 30-ping outages, beam / velocity RMSE (%): at the "
             "studies' placement (p = 0), the range over the placements, and over every placement with its 90 % "
             "interval (90-ping blocks drawn again); `worse in` counts the placements where the fold's velocity "
             f"gain is negative. The DVL: {rows_dvl(rows, 'outage_placement.py')}.", ""]
    # rows written before rows held their run_decay ran the cards' fadings; a pivot row's second member is the
    # pivot completer, which is another pair than the beam-only networks' whatever the decays
    decays = [(tuple(row_decays(r)) if "run_decay" in r else None, pivot_member(r),
               row_draw(r) if "nets" in r else None) for r in rows]    # rows of before rows named their networks
    several_draws = len({d[2] for d in decays}) > 1
    for sc, pair in dict.fromkeys((r["scenario"], d) for r, d in zip(rows, decays)):
        for grade in dict.fromkeys(r["grade"] for r, d in zip(rows, decays) if (r["scenario"], d) == (sc, pair)):
            sel = sorted((r for r, d in zip(rows, decays) if (r["scenario"], r["grade"], d) == (sc, grade, pair)),
                         key=lambda r: r["fold"])
            settle, stride = sel[0]["settle"], sel[0]["stride"]
            n_place = PERIOD // stride
            (fades, pivot, draw) = pair
            fading = ("the cards'" if fades is None else f"{fades[0]:g} / {fades[1]:g}") if not pivot else \
                f"{fades[0]:g} (IMU-aware), second member the pivot completer ({pivot})"
            fading += f", networks {draw}" if several_draws else ""
            lines += [f"### {sc}, {grade} IMU, run_decay {fading} ({n_place} placements, a window every {stride} "
                      "pings)", "",
                      "| completer | fold | p = 0 | range over placements (velocity) | every placement | 90 % "
                      "interval (velocity) | worse in |", "| --- | --- | --- | --- | --- | --- | --- |"]
            for name in (n for n in dict.fromkeys(k for r in sel for k in r["sq"])
                         if n != "average" and all(n in r["sq"] for r in sel)):
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
    p.add_argument("--choose-decays", metavar="NAME", nargs="?", const="fused, envelope", choices=COMPLETERS,
                   help="with --report: choose the two fadings' run_decay pair for NAME (default 'fused, envelope') "
                   "over every placement and training draw, on all folds and leave-one-fold-out, among the pairs "
                   "the rows were run with (each row records its run_decay and fold networks)")
    a = p.parse_args(argv)
    if a.choose_decays and not a.report:
        p.error("--choose-decays reads finished runs: give them with --report")
    def chosen_report(rows):
        if not a.choose_decays:
            return report(rows)
        try:
            return decay_report(rows, a.choose_decays)
        except ValueError as exc:     # rows that cannot be compared: say why, without a traceback
            p.error(f"--choose-decays: {exc}")
    return report_or_run(p, a, chosen_report, lambda out: run(a.scenario, a.imu_nets, a.beam_nets, a.data, out, a.stride,
                                                       a.completers, a.imu_decay, a.beam_decay))


if __name__ == "__main__":
    sys.exit(main())
