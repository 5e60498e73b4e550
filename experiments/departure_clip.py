"""Would bounding the fused completer's departure from the average *through* an outage protect the folds it loses?

The fused completer (``Graph-HNI``'s: the IMU-aware fold network with its input envelope and the beam-only fold
ensemble) beats the average estimator over every placement of recursive 30-ping outages but loses single
placements (fold 1 with MEMS, fold 3). ``experiments/departure_gate.py`` found that a gate at an outage's first
ping cannot see those outages: the completion agrees with the average there and goes wrong later. This study bounds
the departure at every ping of the outage instead. Beside the fused completer it runs the average estimator's own
recursion from the true past before the outage (the *anchor*: what the average estimator would complete at this
ping of the run), and hands on

    b = b_anchor + clip(b_fused - b_anchor, -Z s_k, +Z s_k),      s_k = sqrt(s_0^2 + k g^2)

per missing beam, where ``s_0`` is the average's sigma at the run's first ping (from the true past), ``k`` the
regressed pings of the run before this one and ``g`` the history's sigma growth (0.03 m/s per ping,
:class:`graphnav.estimators.history.BeamHistory`): the average's own error grows with the vehicle's change of
velocity through the outage, so the room given to the network grows with it. ``Z = 0`` is the average, ``Z = inf``
the fused completer; the clipped completions go into the history, so the bound also holds the recursion. The
sigma handed on is the fused completer's (the estimator's weighting is not what is asked here).

The windows start every ``--stride`` pings (default 30: placements 0, 3 and 6 of the placement study's 10-ping
stride; each window starts afresh from the true past, so these are exactly those placements' windows, and the
unclipped completer's errors are read from the placement study's rows, ``--rows``, checked against the average's
errors this run makes again). Z is chosen by the fadings' rule (fewest fold cells worse than the average over
training draws, folds, evaluation IMUs and beam / velocity, then the largest smallest pooled gain; a tie goes to the
larger Z), on all folds and leave-one-fold-out. Usage (the rows of the shipped pair, both draws)::

    .venv/bin/python experiments/departure_clip.py --rows out/decay/2_i1_b1.json --out out/clip/2_d1.json
    .venv/bin/python experiments/departure_clip.py --report out/clip/2_d1.json out/clip/2_d2.json

A run reads the scenario, the fold networks and their fadings from the rows (about 12 min a file with one torch
thread, the default; one run on each core).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

NAME = "fused, envelope"
THRESHOLDS = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0)
GROWTH = 0.03          # m/s per ping: BeamHistory's default sigma growth through a run
STRIDE = 30


class DepartureClip:
    """A completer that bounds ``inner``'s completion of each missing beam to ``z`` grown sigmas of the average
    estimator's own recursion through the run (module docstring). ``n_past_average``: the average's N."""

    takes_run_steps = True

    def __init__(self, inner, n_past_average: int, z: float, growth: float = GROWTH):
        from graphnav.nets.average import AverageCompleter
        if not z >= 0:
            raise ValueError(f"z must be >= 0, got {z}")
        self.inner, self.z, self.growth = inner, float(z), float(growth)
        self.average = AverageCompleter(n_past_average)
        self.n_past = max(inner.n_past, n_past_average)
        for attr in ("needs_imu", "imu_samples", "imu_rate_hz", "ping_dt", "drift_std", "takes_past_dt"):
            if hasattr(inner, attr):
                setattr(self, attr, getattr(inner, attr))
        self._shadow = None      # (n_past_average, 4): the anchor's own history
        self._s0 = np.zeros(4)

    def complete(self, past, measured, imu=None, run_steps=None, past_dt_s=None):
        from graphnav.estimators.history import complete_with
        past = np.asarray(past, float)
        measured = np.asarray(measured, float)
        missing = ~np.isfinite(measured)
        steps = np.zeros(4, int) if run_steps is None else np.asarray(run_steps, int)
        n = self.average.n_past
        fresh = missing & (steps == 0)
        if self._shadow is None:
            self._shadow = past[-n:].copy()
        # a beam's run starts: its anchor restarts from the true past, its sigma is the average's there
        self._shadow[:, fresh] = past[-n:, fresh]
        if fresh.any():
            _, s_first = self.average.complete(past[-n:], measured)
            self._s0 = np.where(fresh, s_first, self._s0)
        anchor, _ = self.average.complete(self._shadow, measured)
        beams, sigma = complete_with(self.inner, past, measured, imu=imu, run_steps=run_steps, past_dt_s=past_dt_s)
        self._shadow = np.vstack([self._shadow[1:], anchor])
        if np.isinf(self.z):
            return beams, sigma
        bound = self.z * np.sqrt(self._s0 ** 2 + steps * self.growth ** 2)
        return np.where(missing, anchor + np.clip(beams - anchor, -bound, bound), beams), sigma


def placement_rows(rows: list[dict], stride: int) -> list[dict]:
    """The placement study's ``rows`` cut to the windows of a ``stride``-ping layout (placements ``k * stride /
    row stride``), in the rollout's order."""
    from outage_placement import row_placements
    out = []
    for r in rows:
        if stride % r["stride"]:
            raise ValueError(f"--stride {stride} is not a multiple of the rows' stride {r['stride']}")
        keep = row_placements(r) % (stride // r["stride"]) == 0
        # the envelope counters were counted over every window: dropped rather than left to mislead
        kept = {k: v for k, v in r.items() if k not in ("envelope_fallbacks", "envelope_counted_in", "completions")}
        out.append({**kept, "stride": stride, "starts": [s for s, k in zip(r["starts"], keep) if k],
                    "sq": {c: [list(np.asarray(m)[keep]) for m in v] for c, v in r["sq"].items()}})
    return out


def run(rows: list[dict], rows_path: Path, out: Path, stride: int = STRIDE, thresholds=THRESHOLDS,
        data=None) -> list[dict]:
    """Each row of ``rows`` (read from ``rows_path``) cut to ``stride`` with the clipped completer's errors for each
    of ``thresholds`` added as ``"Z=<z>"``, rewritten to ``out`` after every row."""
    from departure_gate import row_networks, rows_scenario
    from imu_completer_folds import default_dvl_only, held_out_series
    from outage_placement import envelope_variants, rollout_windows

    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.fused import FusedCompleter
    n_avg = AVERAGE_N_PAST[rows_scenario(rows, rows_path)]
    nets, done = {}, []
    out.parent.mkdir(parents=True, exist_ok=True)
    for r in placement_rows(rows, stride):
        t0 = time.perf_counter()
        net, beam_net = row_networks(r, nets)
        default_dvl_only(net, "departure_clip.py")
        imu = envelope_variants(net, data)
        series = held_out_series(AKIT_FOLDS[r["fold"]], data, r["grade"])
        completers = {"average": AverageCompleter(n_avg)} | {
            f"Z={z:g}": DepartureClip(FusedCompleter(imu(True), beam_net), n_avg, z) for z in thresholds}
        sq, starts = rollout_windows(completers, series, list(net.missing), r["settle"], stride)
        if [list(s) for s in starts] != [list(s) for s in r["starts"]]:
            raise RuntimeError(f"fold {r['fold']} {r['grade']}: the windows differ from the rows' at stride {stride}")
        for m in (0, 1):
            if not np.allclose(sq["average"][m], r["sq"]["average"][m], rtol=1e-9, atol=1e-12):
                raise RuntimeError(f"fold {r['fold']} {r['grade']}: the average's errors differ from the rows'")
        r["sq"] = {"average": r["sq"]["average"], "Z=inf": r["sq"][NAME]} | {
            k: v for k, v in sq.items() if k != "average"}
        done.append(r)
        out.write_text(json.dumps(done))
        print(f"fold {r['fold']} {r['grade']}: {len(starts)} windows in {time.perf_counter() - t0:.0f} s",
              file=sys.stderr, flush=True)
    return done


def clip_names(rows: list[dict]) -> list[str]:
    """The ``"Z=<z>"`` completers every row holds, in increasing Z."""
    names = set.intersection(*({k for k in r["sq"] if k.startswith("Z=")} for r in rows))
    return sorted(names, key=lambda k: float(k[2:]))


def clip_gains(rows: list[dict], name: str, folds, placement: int | None = None):
    """(pooled, per_fold) gains (%) of the completer ``name`` against the average (the placement study's
    :func:`decay_gains`), over every window or only the placement study's ``placement``."""
    from outage_placement import decay_gains, row_placements
    scored = []
    for r in rows:
        mask = np.ones(len(r["starts"]), bool) if placement is None else row_placements(r) == placement
        scored.append({**r, "sq": {c: [np.asarray(m)[mask] for m in r["sq"][c]] for c in (name, "average")}})
    return decay_gains(scored, name, folds)


def choose(rows: list[dict], folds, names) -> str:
    """The fadings' rule over ``names`` on ``folds``: fewest fold cells worse than the average, then the largest
    smallest pooled gain, then the larger Z."""
    from outage_placement import rule_key
    return min(names, key=lambda name: (*rule_key(*clip_gains(rows, name, folds)), -float(name[2:])))


def report(rows: list[dict]) -> str:
    from departure_gate import variants_report
    return variants_report(rows, clip_names, clip_gains, choose, lambda name: "Z" if name is None else name[2:],
                           what=f"clipped completer, windows every {rows[0]['stride']} pings",
                           scope=f"windows every {rows[0]['stride']} pings")


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from departure_gate import read_rows
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rows", help="experiments/outage_placement.py rows scoring 'fused, envelope' (JSON)")
    p.add_argument("--out", help="the rows cut to --stride with each Z's errors (JSON)")
    p.add_argument("--stride", type=int, default=STRIDE, help=f"pings between windows (default {STRIDE})")
    p.add_argument("--z", type=float, nargs="+", default=list(THRESHOLDS), help="bounds, in grown average sigmas "
                   "(default " + " ".join(f"{z:g}" for z in THRESHOLDS) + ")")
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--threads", type=int, default=1, help="torch threads (default 1: the networks complete one ping "
                   "at a time, and two runs with two threads each on two cores take four times as long)")
    p.add_argument("--report", nargs="+", metavar="CLIP_JSON", help="only print the tables of finished runs")
    a = p.parse_args(argv)

    row_keys = ("scenario", "fold", "grade", "starts", "settle", "stride", "sq", "nets")
    if a.report:
        print(report([r for path in a.report for r in read_rows(p, path, row_keys)]))
        return 0
    if not (a.rows and a.out):
        p.error("--rows and --out are needed (or --report)")
    from outage_placement import PERIOD
    if a.stride < 1 or PERIOD % a.stride:
        p.error(f"--stride must divide {PERIOD} (the placement study's period), got {a.stride}")
    if any(not z >= 0 for z in a.z):
        p.error(f"--z: bounds must be >= 0, got {a.z}")
    if a.threads < 1:
        p.error(f"--threads must be >= 1, got {a.threads}")
    rows = read_rows(p, a.rows, row_keys + ("run_decay",))
    import torch
    torch.set_num_threads(a.threads)
    print(report(run(rows, Path(a.rows), Path(a.out), a.stride, tuple(a.z), a.data)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
