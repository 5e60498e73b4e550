"""Runs whose number of measured beams changes: ``Graph-HNI``'s run settings where a third beam drops in and out of
a 2-missing outage, out of fold (docs/decisions/completers.md, "Runs whose number of measured beams changes").

``Graph-HNI`` screens a run of regressed beams until one completion is kept, then links the run's completions by
whitened differences with a correlation time chosen by the ping's number of measured beams
(``GraphOptions.regressed_error_tau_s``, shipped 10 s with two measured, 3 s with one). The regime windows never
change that number inside a run. Here they do: in each bench window (:func:`case_windows`, ``--max-windows``, the
bench's IMU grades and seeds) beams 1 and 3 are missing throughout (the ``2-missing`` preset) and beam 4 drops
in and out as a two-state Markov chain (``--flicker P_DROP P_RECOVER`` per ping, seeded by the trajectory and the
window start, :func:`flicker_seed`, so that each trajectory and window has its own pattern and every run of it the
same). The pings alternate between two measured beams (the 2-missing networks
complete) and one (the 3-missing networks complete), and the chains of beams 1 and 3 run through the changes.

Per held-out trajectory the completer is its fold's: the IMU-aware networks of both patterns
(``imu_completer_folds.py --save-nets``) fused with the beam-only fold ensembles of both patterns (``graphnav
eval-beams --folds --save-nets``), both members not fading (:data:`graphnav.nets.imu_auto.FUSED_RUN_DECAY`), and
the beam-only ensembles with their cards' fading where there is no IMU window: the shipped ``Graph-HNI`` with the
fold's weights. Variants per window:

- ``Graph-TC`` (measured beams only), ``all beams`` (no outage), ``Graph-HN`` (the average estimator, screened
  at each ping: the default hybrid); ``Graph-HNP`` (the pivot completer fitted online, with its method's run
  settings: no networks, so the same in every draw);
- ``HNI shipped``: ``Graph-HNI`` as shipped (its method defaults);
- ``HNI restart``: the same, but a change of the number of measured beams ends every run (the next completions
  meet the screening again, as at an outage's start);
- ``HNI tau T``: the same with one correlation time T s whatever the ping measured; ``HNI independent``: runs
  screened once, errors independent; ``HNI each ping``: every completion screened.

Printed: window VRMSE over Graph-TC's, pooled over the ten trajectories and in the worst fold, per IMU grade and
window, and the fold cells over 1.02x per variant; also the share of pings with one measured beam inside the windows
and how many measured-beam changes fall inside kept runs. Usage::

    .venv/bin/python experiments/count_change_runs.py --imu-nets out/imu_folds/nets2 out/imu_folds/nets3 \\
        --beam-nets out/ens2/akit-residual-aug-ens5 out/ens/akit-residual-aug-ens5 --out out/count_change.json --jobs 2
"""
from __future__ import annotations

import argparse
import sys
import zlib
from pathlib import Path

import numpy as np

VARIANTS = ("Graph-TC", "all beams", "Graph-HN", "Graph-HNP", "HNI shipped", "HNI restart", "HNI tau 10", "HNI tau 3",
            "HNI independent", "HNI each ping")
#: the flickering beam (0-based: beam 4) and the steady pair (beams 1 and 3) of the stress
FLICKER_BEAM = 3
STEADY_MISSING = (0, 2)
#: (p_drop, p_recover) per ping of the flickering beam: out half the time, in runs of 10 pings on average
FLICKER = (0.1, 0.1)


def _tau_variant(variant: str) -> bool:
    """True for "HNI tau T" with a time T > 0 s."""
    if not variant.startswith("HNI tau "):
        return False
    try:
        return float(variant.split()[-1]) > 0
    except ValueError:
        return False


def variant_options(variant: str) -> dict | None:
    """Graph options on top of ``Graph-HNI``'s defaults for an HNI variant (None: as shipped)."""
    if variant in ("HNI shipped", "HNI restart"):
        return None
    if variant == "HNI independent":
        return {"regressed_error_tau_s": None}
    if variant == "HNI each ping":
        return {"regressed_runs": "screen-each", "regressed_error_tau_s": None}
    if variant.startswith("HNI tau "):
        return {"regressed_error_tau_s": float(variant.split()[-1])}
    raise ValueError(f"unknown variant {variant!r}")


def pivot_member_of(beam_dirs) -> str | None:
    """The pivot completer ``--beam-nets`` puts in the beam-only networks' place (one of
    :data:`imu_beam_fused_folds.PIVOT_MEMBERS`, the same for both patterns), or None; a :class:`ValueError` for a
    pivot completer in one pattern only, or two different ones."""
    from imu_beam_fused_folds import PIVOT_MEMBERS
    pivots = set(beam_dirs or ()) & set(PIVOT_MEMBERS)
    if not pivots:
        return None
    if len(set(beam_dirs)) != 1:
        raise ValueError(f"--beam-nets: one of {', '.join(PIVOT_MEMBERS)} for both patterns or none, got "
                         f"{' '.join(beam_dirs)}")
    return pivots.pop()


def fold_completer(imu_dirs, beam_dirs, fold: int, config=None):
    """The shipped ``Graph-HNI`` completer with fold ``fold``'s networks of both patterns: ``imu_dirs`` and
    ``beam_dirs`` are (2-missing, 3-missing) directories holding ``fold<k>``. The beam-only fold ensembles fade as the
    shipped beam-only networks' cards say where they serve alone, and not at all as the fused member. ``beam_dirs``
    both :data:`imu_beam_fused_folds.PIVOT_MEMBER`: the pivot completer in their place (fitted online as
    ``Graph-HNP``'s, for the mission's sensors ``config``), as ``hybrid_imu_folds.completer`` builds the pair; both
    ``PIVOT_PITCH_MEMBER``: the pivot completer with its own defaults
    (``imu_beam_fused_folds.pivot_member_options``)."""
    from hybrid_imu_folds import IMU_PIVOT_ERROR_CORRELATION, shipped_run_decay

    from graphnav.nets.imu_auto import FUSED_RUN_DECAY, ImuAutoCompleter, load_imu_auto_completer
    from graphnav.nets.imu_network import load_imu_completer
    from graphnav.nets.network import load_completer
    scenarios = ("2-missing", "3-missing")
    fold_dir = lambda d: Path(d) / f"fold{fold}"  # noqa: E731

    def beam_only(decay_of):
        return load_completer("auto", directory=dict(zip(scenarios, map(fold_dir, beam_dirs))),
                              run_decay={s: decay_of(s) for s in scenarios})
    try:
        pivot_member = pivot_member_of(beam_dirs)
    except ValueError as e:
        raise SystemExit(str(e)) from None
    if pivot_member:
        from imu_beam_fused_folds import pivot_member_options

        from graphnav.core.config import SensorConfig
        from graphnav.evaluation.methods import pivot_completer
        # one pivot completer serves both patterns, as Graph-HNP's does in this stress
        pivot = pivot_completer("2-missing", config if config is not None else SensorConfig(),
                                **pivot_member_options(pivot_member, "2-missing"))
        imu = [load_imu_completer(s, fold_dir(d), run_decay=FUSED_RUN_DECAY[s]["IMU-aware"])
               for s, d in zip(scenarios, imu_dirs)]
        return ImuAutoCompleter(imu, pivot, IMU_PIVOT_ERROR_CORRELATION)
    return load_imu_auto_completer(dict(zip(scenarios, map(fold_dir, imu_dirs))), beam_only(shipped_run_decay),
                                   fused_beam_only=beam_only(lambda s: FUSED_RUN_DECAY[s]["beam-only"]),
                                   patterns=scenarios)


def flicker_seed(trajectory: str, start_s: float) -> int:
    """Seed of the flickering beam's chain in one window: from the trajectory's name and the window's start (ms), so
    that each trajectory and window has a pattern of its own (the bench puts every trajectory's windows at the same
    times) and every run of them the same one."""
    return zlib.crc32(f"{trajectory}@{round(start_s * 1e3)}".encode())


def stress_mask(t: np.ndarray, starts, window_s: float, trajectory: str, flicker=FLICKER) -> np.ndarray:
    """(M, 4) bool, True where the stress removes a beam at the DVL stamps ``t`` (s): beams 1 and 3 through each window
    starting at ``starts`` (s), ``window_s`` long, and beam 4 where its two-state Markov chain (``flicker``: per-ping
    p_drop, p_recover; :func:`graphnav.core.scenarios.markov_dropout`, seeded by :func:`flicker_seed`) is off."""
    from graphnav.core.scenarios import markov_dropout
    mask = np.zeros((len(t), 4), dtype=bool)
    for start in starts:
        inside = (t >= start) & (t < start + window_s)
        mask[np.ix_(inside, list(STEADY_MISSING))] = True
        on = markov_dropout(int(inside.sum()), *flicker, seed=flicker_seed(trajectory, start))
        mask[inside, FLICKER_BEAM] = ~on[:, FLICKER_BEAM]
    return mask


class RunCounter:
    """:func:`graphnav.estimators.graph.builder.continue_regressed_runs` (``original``) wrapped: it counts the pings at
    which some regressed beam continues its run (``continued_pings``) and, of them, those whose number of measured
    beams differs from the previous such call's (``changes_in_runs``). With ``restart`` a change of that number first
    ends every run (``builder.regressed_links`` cleared): the ping's regressed beams meet the screening again, as at
    an outage's start."""

    def __init__(self, original, restart: bool = False):
        self.original, self.restart = original, restart
        self.counts = {"changes_in_runs": 0, "continued_pings": 0}
        self.last_measured: int | None = None

    def __call__(self, kf, builder, m, sel, omega_b, use_d):
        measured = int(np.count_nonzero(~m.regressed))
        changed = self.last_measured not in (None, measured)
        if self.restart and changed:
            builder.regressed_links.clear()
        result = self.original(kf, builder, m, sel, omega_b, use_d)
        if len(sel) > len(result[0]):          # the rows left for the screening are the ones not continued
            self.counts["continued_pings"] += 1
            self.counts["changes_in_runs"] += int(changed)
        self.last_measured = measured
        return result


def window_task(item):
    """(key, {"vrmse": window VRMSEs, "one_measured": share of window pings with one measured beam, and for the HNI
    variants the :class:`RunCounter` counts and the screening's}) of one run. ``item``: (source, grade, window_s,
    max_windows, variant, imu_dirs, beam_dirs, fold, flicker)."""
    source, grade, window_s, max_windows, variant, imu_dirs, beam_dirs, fold, flicker = item
    import warnings
    warnings.simplefilter("ignore")
    from graphnav.estimators.graph import builder as builder_mod
    from graphnav.evaluation.bench.cases import case_windows, prepared_mission
    from graphnav.evaluation.methods import run_method
    mission = prepared_mission(source, grade)
    starts = case_windows(mission, window_s, max_windows)
    if variant == "all beams":
        sol = run_method(mission, "Graph-TC")
        return (source.name, grade, window_s, variant), {"vrmse": _vrmse(sol, mission, starts, window_s)}
    removed = stress_mask(mission.dvl.t, starts, window_s, source.name, flicker)
    run = mission.with_dvl_valid(mission.dvl.valid & ~removed)
    original = builder_mod.continue_regressed_runs
    counter = RunCounter(original, restart=variant == "HNI restart")
    if variant in ("Graph-TC", "Graph-HN"):
        # Graph-HN: the average estimator of the 2-missing preset (N = 3) at every ping, one measured beam or two
        sol = run_method(run, variant, "2-missing")
    else:
        # the runs that continue regressed beams: counted through the builder's hook
        if variant == "Graph-HNP":
            method, kwargs = variant, {}
        else:
            method = "Graph-HNI"
            kwargs = {"completer": fold_completer(imu_dirs, beam_dirs, fold, mission.config),
                      "options": variant_options(variant)}
        builder_mod.continue_regressed_runs = counter
        try:
            sol = run_method(run, method, "2-missing", **kwargs)
        finally:
            builder_mod.continue_regressed_runs = original
    result = {"vrmse": _vrmse(sol, mission, starts, window_s), **counter.counts,
              "screening": sol.info.get("regressed_screening", {})}
    inside = removed[:, STEADY_MISSING[0]]          # the steady pair is out exactly inside the windows
    result["one_measured"] = float(np.mean(run.dvl.valid[inside].sum(axis=1) == 1))
    return (source.name, grade, window_s, variant), result


def _vrmse(sol, mission, starts, window_s) -> list[float]:
    from graphnav.evaluation.bench.scoring import score_case
    return [r["vrmse_window"] for r in score_case(sol, mission, starts, window_s)]


def ratio(runs: dict, trajectories, grade: str, window_s: float, variant: str) -> float:
    """Mean window VRMSE of ``variant`` over Graph-TC's on ``trajectories`` (numbers of A-KIT trajectories)."""
    def pooled(v):
        return np.mean(np.concatenate([runs[(f"Trajectory{k}", grade, window_s, v)]["vrmse"] for k in trajectories]))
    return float(pooled(variant) / pooled("Graph-TC"))


def report(runs: dict, grades, windows, variants) -> str:
    """Pooled (worst fold) ratio to Graph-TC per cell and variant, then the fold cells over 1.02x per variant."""
    from graphnav.nets.crossval import AKIT_FOLDS
    everything = [k for pair in AKIT_FOLDS for k in pair]
    compared = [v for v in variants if v != "Graph-TC"]
    lines = ["| IMU | window s | Graph-TC m/s | " + " | ".join(compared) + " |",
             "| --- | --- | --- | " + " | ".join("---" for _ in compared) + " |"]
    over = dict.fromkeys(compared, 0)
    for g in grades:
        for w in windows:
            tc = np.mean(np.concatenate([runs[(f"Trajectory{k}", g, w, "Graph-TC")]["vrmse"] for k in everything]))
            cells = []
            for v in compared:
                per = [ratio(runs, pair, g, w, v) for pair in AKIT_FOLDS]
                over[v] += sum(r > 1.02 for r in per)
                cells.append(f"{ratio(runs, everything, g, w, v):.2f} ({max(per):.2f})")
            lines.append(f"| {g} | {w:g} | {tc:.3f} | " + " | ".join(cells) + " |")
    lines.append("fold cells over 1.02x Graph-TC (of {}): ".format(len(grades) * len(windows) * len(AKIT_FOLDS))
                 + "; ".join(f"{v}: {n}" for v, n in over.items() if v != "all beams"))
    one = [r["one_measured"] for k, r in runs.items() if "one_measured" in r]
    hni = [r for k, r in runs.items() if k[3] == "HNI shipped"]
    if one:
        lines.append(f"pings with one measured beam inside the windows: {np.mean(one):.2f}")
    if hni:
        lines.append(f"HNI shipped: pings continuing a run {sum(r['continued_pings'] for r in hni)}, of them after a "
                     f"change of measured beams {sum(r['changes_in_runs'] for r in hni)}")
    return "\n".join(lines)


def over_draws(paths, grades, windows) -> str:
    """Per variant run in every file (one per training draw; Graph-TC's runs are each file's own): per draw, its fold
    cells over 1.02x Graph-TC and its worst fold cell; per cell, the pooled ratio's range over the draws."""
    from hybrid_imu_folds import read_results

    from graphnav.nets.crossval import AKIT_FOLDS
    draws = [read_results(Path(p))[1] for p in paths]
    variants = [v for v in dict.fromkeys(k[3] for k in draws[0])
                if v != "Graph-TC" and all(any(k[3] == v for k in runs) for runs in draws)]
    everything = [k for pair in AKIT_FOLDS for k in pair]
    lines = ["| variant | fold cells over 1.02x per draw | worst fold cell per draw | "
             + " | ".join(f"{g} {w:g} s pooled, min-max" for g in grades for w in windows) + " |",
             "| --- | --- | --- | " + " | ".join("---" for _ in grades for _ in windows) + " |"]
    for v in variants:
        over, worst, pooled = [], [], []
        for runs in draws:
            per = [ratio(runs, pair, g, w, v) for g in grades for w in windows for pair in AKIT_FOLDS]
            over.append(sum(r > 1.02 for r in per))
            worst.append(max(per))
        for g in grades:
            for w in windows:
                cell = [ratio(runs, everything, g, w, v) for runs in draws]
                pooled.append(f"{min(cell):.2f}-{max(cell):.2f}")
        lines.append(f"| {v} | {', '.join(map(str, over))} | {', '.join(f'{x:.3f}' for x in worst)} | "
                     + " | ".join(pooled) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from hybrid_imu_folds import add_regime_window_arguments, load_runs, run_saving
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--over-draws", nargs="+", metavar="FILE", help="run nothing: the results files of several "
                   "training draws (one each), summarised together")
    p.add_argument("--imu-nets", nargs=2, metavar=("DIR2", "DIR3"),
                   help="the IMU-aware fold networks of 2 and of 3 missing beams (imu_completer_folds.py --save-nets)")
    p.add_argument("--beam-nets", nargs=2, metavar=("DIR2", "DIR3"),
                   help="the beam-only fold ensembles of 2 and of 3 missing beams (eval-beams --folds --save-nets "
                        "DIR: DIR/<recipe>), or 'pivot pivot': the pivot completer in their place as Graph-HNP runs "
                        "it, or 'pivot-pitch pivot-pitch': with its own defaults")
    p.add_argument("--flicker", nargs=2, type=float, default=list(FLICKER), metavar=("P_DROP", "P_RECOVER"),
                   help=f"per-ping drop and recovery probabilities of beam 4 (default {FLICKER[0]:g} {FLICKER[1]:g})")
    p.add_argument("--variants", nargs="+", default=list(VARIANTS), help="runs per window (default: all)")
    add_regime_window_arguments(p)
    p.add_argument("--out", default="out/count_change.json", help="results (JSON); a rerun with the same settings "
                   "resumes from it")
    a = p.parse_args(argv)
    if a.over_draws:
        print(over_draws(a.over_draws, a.grades, a.window_s))
        return 0
    if any(v.startswith("HNI") for v in a.variants) and not (a.imu_nets and a.beam_nets):
        p.error("the HNI variants need --imu-nets and --beam-nets (or --over-draws)")
    unknown = [v for v in a.variants if v not in VARIANTS and not _tau_variant(v)]
    if unknown or "Graph-TC" not in a.variants:
        p.error(f"variants: Graph-TC and any of {', '.join(VARIANTS)} or 'HNI tau T' with T > 0 s "
                f"(unknown: {unknown})")
    try:
        pivot_member_of(a.beam_nets)
    except ValueError as e:
        p.error(str(e))
    if not all(0.0 < x <= 1.0 for x in a.flicker):
        p.error("--flicker probabilities must be in (0, 1]")
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    folders = akit_trajectories(a.data)
    sources = {s.name: s for s in find_trajectories(str(folders[0].parent))}
    from imu_beam_fused_folds import PIVOT_MEMBERS
    resolved = [d if d in PIVOT_MEMBERS else str(Path(d).resolve())
                for d in (*(a.imu_nets or ()), *(a.beam_nets or ()))]
    settings = {"max_windows": a.max_windows, "nets": resolved, "flicker": list(a.flicker),
                "flicker_seed": "trajectory and window start"}
    out = Path(a.out)
    runs, _ = load_runs(out, settings)
    items = [(sources[f"Trajectory{k}"], g, w, a.max_windows, v, a.imu_nets, a.beam_nets, f, a.flicker)
             for f, pair in enumerate(AKIT_FOLDS) for k in pair for g in a.grades for w in a.window_s
             for v in a.variants if (f"Trajectory{k}", g, w, v) not in runs]
    run_saving(window_task, items, runs, out, settings, a.jobs)
    print(f"beams 1 and 3 missing, beam 4 flickering (p_drop {a.flicker[0]:g}, p_recover {a.flicker[1]:g}); "
          f"{a.max_windows} windows per trajectory; window VRMSE over Graph-TC's, pooled (worst fold)")
    print(report(runs, a.grades, a.window_s, a.variants))
    return 0


if __name__ == "__main__":
    sys.exit(main())
