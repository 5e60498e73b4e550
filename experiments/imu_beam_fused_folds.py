"""The IMU-aware completer fused with the beam-only ensemble, out of fold (docs/decisions/completers.md).

Each fading completer misses the goal somewhere else: the IMU-aware one (``graded-fade``) is worse than the average
in fold 3's outages, the beam-only ensemble (``akit-residual-aug-ens5-fade``) leaves 2-missing cells under 15 %.
Their errors come from different inputs (the IMU's turn against the past beams' trend), so a combination may hold
where each fails. For every A-KIT fold the fold's two networks (the IMU-aware one of
``experiments/imu_completer_folds.py --save-nets``, the beam-only ensemble of ``graphnav eval-beams --folds
--save-nets``; neither saw the fold) each fade to the average with its shipped ``run_decay``, and
:class:`graphnav.nets.fused.FusedCompleter` combines them per missing beam:

- ``fused, rho 0``: inverse-variance weights (the members' own sigmas);
- ``fused, rho fitted``: the weights with the correlation of the two members' per-ping errors (each over its own
  sigma) fitted on the **other four folds'** held-out pings with the same evaluation IMU;
- ``fused, rho 0, sigma with rho fitted``: the inverse-variance completion with the sigma of that combination
  when the errors are correlated by the fitted correlation (``sigma_rho``);
- ``equal weights``: the mean of the two completions (sigma: the members' mean, a bound).

``--beam-nets pivot`` puts the pivot completer (:mod:`graphnav.nets.pivot`: the average estimator with the hull's
sideslip in turns from the gyro), its pivot length fitted on the other four folds' trajectories, in the beam-only
networks' place: the variants are then named with ``pivot`` for ``beam-only, fading``. It models the yaw alone and
holds the average's past pings, as ``Graph-HNP`` did when the study was first run. ``--beam-nets pivot-pitch`` puts
the pivot completer with its own defaults there (the hull's heave in pitch beside its sway in yaw, both lengths
fitted on the other folds, and its hold :data:`graphnav.nets.pivot.DEFAULT_N_PAST`), named ``pivot-pitch``.

Through a recursive 30-ping outage the fused completion goes back into the history, and each member fades with
the run steps the history hands on. Every variant is scored beside the two members alone and the average
estimator, per ping and through the outages of :mod:`graphnav.nets.imu_evaluate`, with each evaluation IMU
(recorded, tactical, MEMS), on the pings of the IMU-aware study. Rows are written to ``--out`` after every fold.

The pair is scored on the beams of the DVL its networks were trained for (their cards' ``data.beam_model``; the
Snapir's unless ``imu_completer_folds.py --config`` and ``graphnav eval-beams --folds --config`` trained them for
another), and each row names it. The two members must have been trained for the same DVL; a pivot member is built for
it. Usage::

    .venv/bin/python experiments/imu_beam_fused_folds.py --scenario 2-missing --imu-nets out/imu_folds/nets2 \\
        --beam-nets out/ens2/akit-residual-aug-ens5 --out out/fusedens/rows2.json
    .venv/bin/python experiments/imu_beam_fused_folds.py --report out/fusedens/rows2.json
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

#: The combination :class:`graphnav.nets.ImuAutoCompleter` makes with ``beam_correlation`` (``Graph-HNI``).
SHIPPED = "fused, rho 0, sigma with rho fitted"
VARIANTS = ("IMU-aware, fading", "beam-only, fading", "fused, rho 0", "fused, rho fitted",
            "fused, rho 0, sigma with rho fitted", "equal weights")
#: ``--beam-nets pivot``: the pivot completer (:mod:`graphnav.nets.pivot`), its pivot length fitted on the other
#: folds' trajectories, is the second member in place of the beam-only networks (it reads the tail of the IMU-aware
#: network's window); the yaw alone, holding the average's past pings
PIVOT_MEMBER = "pivot"
#: ``--beam-nets pivot-pitch``: the pivot completer with its own defaults (yaw and pitch, its own hold)
PIVOT_PITCH_MEMBER = "pivot-pitch"
PIVOT_MEMBERS = (PIVOT_MEMBER, PIVOT_PITCH_MEMBER)


def pivot_member_options(member: str, scenario: str) -> dict:
    """The pivot completer's settings (``axes``, ``n_past``) of the pivot member ``member`` in ``scenario``, on top
    of ``Graph-HNP``'s (:func:`graphnav.evaluation.methods.pivot_completer`): none for :data:`PIVOT_MEMBER`, the
    completer's own defaults for :data:`PIVOT_PITCH_MEMBER`."""
    from graphnav.nets.pivot import DEFAULT_AXES, DEFAULT_N_PAST
    return {"axes": DEFAULT_AXES, "n_past": DEFAULT_N_PAST[scenario]} if member == PIVOT_PITCH_MEMBER else {}


def member_label(beam_dir: str) -> str:
    """The second member's name in the rows: one of :data:`PIVOT_MEMBERS` or ``beam-only, fading``."""
    return beam_dir if beam_dir in PIVOT_MEMBERS else "beam-only, fading"


def variants(second: str) -> tuple[str, ...]:
    """:data:`VARIANTS` with the second member named ``second`` (:func:`member_label`)."""
    return tuple(second if v == "beam-only, fading" else v for v in VARIANTS)


def row_variants(rows: list[dict]) -> list[str]:
    """The variants the rows hold (the part of ``variant`` after the evaluation IMU), in their order."""
    return list(dict.fromkeys(r["variant"].split(", ", 1)[1] for r in rows))


class EqualBlend:
    """The mean of two completers' completions of each missing beam, sigma the mean of theirs (the blend's sigma
    if the errors were fully correlated, a bound); the same arguments as :class:`~graphnav.nets.fused.FusedCompleter`
    (IMU window and run steps handed to the members that take them)."""

    def __init__(self, fused):
        self.fused = fused
        for k in ("n_past", "needs_imu", "takes_run_steps", "takes_past_dt", "imu_samples", "imu_rate_hz", "ping_dt"):
            if hasattr(fused, k):
                setattr(self, k, getattr(fused, k))

    def complete(self, past, measured, imu=None, run_steps=None, past_dt_s=None):
        b1, s1, b2, s2 = self.fused.members(past, measured, imu, run_steps, past_dt_s)
        return 0.5 * (b1 + b2), 0.5 * (s1 + s2)


def per_ping(imu_net, beam_net, scenario: str, series) -> dict:
    """Per-ping completions (full, sigma) of the IMU-aware network, the beam-only one and the average on the same
    pings (every ping completed from its true past), with those pings' beams and DVL velocity."""
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.evaluate import predict_completer
    from graphnav.nets.imu_data import imu_windows
    from graphnav.nets.imu_evaluate import predict_imu_network
    average = AverageCompleter(AVERAGE_N_PAST[scenario])
    n_past = max(imu_net.n_past, beam_net.n_past, average.n_past)
    samples = imu_windows(series, n_past, imu_net.imu_samples, imu_net.ping_dt)
    own = imu_windows(series, imu_net.n_past, imu_net.imu_samples, imu_net.ping_dt, pings=slice(n_past, None))
    if not np.array_equal(own.beams, samples.beams):
        raise RuntimeError("IMU network samples are not the pings of the other completers")
    second = (predict_with_imu(beam_net, series, n_past, imu_net.imu_samples, imu_net.missing)
              if getattr(beam_net, "needs_imu", False) else predict_completer(beam_net, samples, imu_net.missing))
    if len(second[0]) != len(samples.beams):
        raise RuntimeError("the second member's pings are not the IMU network's")
    return {"samples": samples, "imu": predict_imu_network(imu_net.model, own), "beam": second,
            "average": predict_completer(average, samples, imu_net.missing)}


def predict_with_imu(completer, series, n_past: int, n_imu: int, missing) -> tuple[np.ndarray, np.ndarray]:
    """(full, sigma) (K, 4) of a completer that needs the IMU (the pivot completer) on the pings
    :func:`graphnav.nets.imu_data.imu_windows` takes with ``n_past`` and ``n_imu``, each from its true past, with
    the IMU window ending at the ping."""
    full, sigma = [], []
    for s in series:
        for k in np.flatnonzero(s.usable(n_past, n_imu)):
            measured = s.beams[k].copy()
            measured[list(missing)] = np.nan
            b, sg = completer.complete(s.beams[k - completer.n_past:k], measured,
                                       imu=s.imu_window(k, completer.imu_samples))
            full.append(b)
            sigma.append(sg)
    return np.array(full), np.array(sigma)


def fitted_rho(others: list[dict], missing) -> float:
    """Correlation of the two members' per-ping errors, each over its own sigma, on other folds' pings."""
    from graphnav.nets.outage_calibration import error_correlation
    m = list(missing)
    err = {k: np.concatenate([o[k][0][:, m] - o["samples"].beams[:, m] for o in others]) for k in ("imu", "beam")}
    sig = {k: np.concatenate([o[k][1][:, m] for o in others]) for k in ("imu", "beam")}
    return error_correlation(err["imu"], sig["imu"], err["beam"], sig["beam"])


def fold_rows(fold: int, held, scenario: str, grade: str, imu_net, beam_net, series, pp: dict, rho: float,
              second: str = "beam-only, fading") -> list[dict]:
    """Rows for :func:`graphnav.nets.crossval.summarise` (each variant the ``network`` beside the average), velocities
    solved with the geometry of the DVL the pair was trained for (:func:`pair_dvl`), which each row names."""
    from completer_fade_folds import WINDOW, window_sq

    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.data import BeamSamples
    from graphnav.nets.dvl_match import dvl_name
    from graphnav.nets.evaluate import completion_metrics, outage_rollout
    from graphnav.nets.fused import FusedCompleter, fuse
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE
    miss = list(imu_net.missing)
    samples = pp["samples"]
    pp_samples = BeamSamples(np.zeros((len(samples.beams), 0, 4)), samples.beams, samples.v_b)
    made_pp = {"IMU-aware, fading": pp["imu"], second: pp["beam"],
               "fused, rho 0": fuse(*pp["imu"], *pp["beam"]), "fused, rho fitted": fuse(*pp["imu"], *pp["beam"], rho),
               "fused, rho 0, sigma with rho fitted": fuse(*pp["imu"], *pp["beam"], 0.0, rho),
               "equal weights": (0.5 * (pp["imu"][0] + pp["beam"][0]), 0.5 * (pp["imu"][1] + pp["beam"][1]))}
    outage = {"average": AverageCompleter(AVERAGE_N_PAST[scenario]), "IMU-aware, fading": imu_net,
              second: beam_net, "fused, rho 0": FusedCompleter(imu_net, beam_net),
              "fused, rho fitted": FusedCompleter(imu_net, beam_net, rho),
              "fused, rho 0, sigma with rho fitted": FusedCompleter(imu_net, beam_net, sigma_rho=rho),
              "equal weights": EqualBlend(FusedCompleter(imu_net, beam_net))}
    made_out, out_samples = {}, None
    for name, comp in outage.items():
        full, sigma, osamp = outage_rollout(comp, series, miss, window=WINDOW, gap=60, settle=OUTAGE_SETTLE)
        if out_samples is not None and not np.array_equal(osamp.beams, out_samples.beams):
            raise RuntimeError(f"the outage pings of {name} differ from the average's")
        made_out[name], out_samples = (full, sigma), osamp
    spec = pair_dvl(imu_net, beam_net, "imu_beam_fused_folds.py")
    base = {"fold": fold, "held_out": list(held), "dataset": "A-KIT", "scenario": scenario, "rho": rho,
            "dvl": dvl_name(spec)}
    geometry = DvlGeometry.from_spec(spec)
    rows = []
    for mode, made, samp, avg in (("per ping", made_pp, pp_samples, pp["average"]),
                                  ("outage 30 s", made_out, out_samples, made_out["average"])):
        avg_m = completion_metrics(*avg, samp, miss, geometry)
        for variant in variants(second):
            net_m = completion_metrics(*made[variant], samp, miss, geometry)
            v = f"IMU {grade}, {variant}"
            extra = ({"window_sq": window_sq(made[variant][0], samp, miss, geometry)},
                     {"window_sq": window_sq(avg[0], samp, miss, geometry)}) if mode == "outage 30 s" else ({}, {})
            rows.append({**base, "mode": mode, "variant": v, "method": "network", **net_m, **extra[0]})
            rows.append({**base, "mode": mode, "variant": v, "method": "average", **avg_m, **extra[1]})
    return rows


def window_interval(rows: list[dict], scenario: str, variant: str, fold: int, draws: int = 2000, seed: int = 0
                    ) -> list[tuple[float, float]]:
    """90 % interval of one fold's outage gain (beam, velocity; %) when its outage windows are drawn again with
    replacement (errors within a window are correlated: a window is the unit of evidence)."""
    from completer_fade_folds import gain_interval
    sel = [r for r in rows if (r["scenario"], r["mode"], r["variant"], r["fold"]) == (scenario, "outage 30 s",
                                                                                       variant, fold)]
    net, avg = (next(r for r in sel if r["method"] == m) for m in ("network", "average"))
    return [(100 * lo, 100 * hi) for lo, hi in gain_interval(net["window_sq"], avg["window_sq"], draws, seed)]


def pair_dvl(imu_net, second, study: str):
    """The DVL (:class:`~graphnav.core.config.DvlSpec`) a fold's pair is scored on: the one the IMU-aware network
    ``imu_net`` was trained for (its card's). Stop ``study`` when the second member was trained or built for another:
    a network whose card records another DVL, or a pivot completer with other beams."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.dvl_match import beam_direction_mismatch, beam_model_record, dvl_name
    spec = imu_net.trained_dvl_spec
    if hasattr(second, "trained_dvl_spec"):
        other = second.trained_dvl_spec
        differs = beam_model_record(other) != beam_model_record(spec)
    else:
        other = None
        differs = beam_direction_mismatch(DvlGeometry.from_spec(spec).T_b, second.T_b) is not None
    if differs:
        theirs = ("its beams differ" if other is None else
                  "the same beams, other errors" if dvl_name(other) == dvl_name(spec) else dvl_name(other))
        raise SystemExit(f"{study}: the IMU-aware fold network was trained for the DVL {dvl_name(spec)}, the second "
                         f"member for another ({theirs}); train both for one DVL (--config)")
    return spec


def fold_networks(scenario: str, imu_dir: str, beam_dir: str, imu_decay: float | None = None,
                  beam_decay: float | None = None, akit_dir=None) -> dict:
    """Fold -> (IMU-aware network, beam-only network) of ``scenario``, each fading with ``run_decay`` (default: the
    shipped card's). ``beam_dir`` one of :data:`PIVOT_MEMBERS`: the pivot completer with the fold's lengths fitted on
    the other folds' trajectories (``akit_dir``) in place of the beam-only network (it does not fade), built for the
    DVL the fold's IMU-aware network was trained for."""
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.dvl_match import dvl_name
    from graphnav.nets.imu_network import load_imu_completer
    from graphnav.nets.network import load_completer
    imu_decay = load_imu_completer(scenario).run_decay if imu_decay is None else imu_decay
    imu = [load_imu_completer(scenario, f"{imu_dir}/fold{f}", run_decay=imu_decay) for f in range(len(AKIT_FOLDS))]
    if len({dvl_name(net.trained_dvl_spec) for net in imu}) > 1:
        raise SystemExit(f"{imu_dir}: the fold networks were trained for different DVLs")
    if beam_dir in PIVOT_MEMBERS:
        if beam_decay is not None:
            raise SystemExit("--beam-decay: the pivot completer does not fade")
        second = fold_pivot_completers(scenario, akit_dir, pitch=beam_dir == PIVOT_PITCH_MEMBER,
                                       spec=imu[0].trained_dvl_spec)
        print(f"run_decay: IMU-aware {imu_decay:g}; pivot lengths (yaw, pitch) "
              f"{[tuple(round(x, 2) for x in c.lengths_m) for c in second]} m, holding {second[0].n_past}",
              file=sys.stderr, flush=True)
    else:
        beam_decay = load_completer(scenario).run_decay if beam_decay is None else beam_decay
        print(f"run_decay: IMU-aware {imu_decay:g}, beam-only {beam_decay:g}", file=sys.stderr, flush=True)
        second = [load_completer(scenario, directory=f"{beam_dir}/fold{f}", run_decay=beam_decay)
                  for f in range(len(AKIT_FOLDS))]
    return {f: (imu[f], second[f]) for f in range(len(AKIT_FOLDS))}


def fold_pivot_completers(scenario: str, akit_dir=None, pitch: bool = False, spec=None) -> list:
    """Per A-KIT fold, the pivot completer for the beams of the DVL ``spec`` (default: the Snapir's) with the pivot
    lengths fitted on the other folds' trajectories (:func:`graphnav.evaluation.pivot_folds.fold_pivot_lengths`,
    from their recorded Snapir beams: the lengths are the hull's): the yaw alone holding the average's N, or with
    ``pitch`` the completer's defaults (yaw and pitch lengths, its own hold)."""
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.evaluation.pivot_folds import fold_pivot_lengths
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.average import AVERAGE_N_PAST
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.pivot import DEFAULT_AXES, PivotCompleter
    sources = {s.name: s for s in find_trajectories(str(akit_trajectories(akit_dir)[0].parent))}
    geometry = DvlGeometry.from_spec(spec or DvlSpec())
    if not pitch:
        return [PivotCompleter(geometry.T_b, geometry.lever_arm_b, length, n_past=AVERAGE_N_PAST[scenario],
                               axes=("yaw",)) for length in fold_pivot_lengths(sources, AKIT_FOLDS)]
    return [PivotCompleter(geometry.T_b, geometry.lever_arm_b, yaw, pitch_pivot_m=pitch_m,
                           **pivot_member_options(PIVOT_PITCH_MEMBER, scenario))
            for yaw, pitch_m in fold_pivot_lengths(sources, AKIT_FOLDS, DEFAULT_AXES)]


def held_out_per_ping(nets: dict, scenario: str, akit_dir) -> tuple[dict, dict]:
    """Each fold's held-out series, its beams made for the DVL of the fold's pair (:func:`pair_dvl`), and
    :func:`per_ping` completions by (fold, evaluation IMU)."""
    from imu_completer_folds import EVAL_GRADES, held_out_series

    from graphnav.nets.crossval import AKIT_FOLDS
    series, pp = {}, {}
    for f, held in enumerate(AKIT_FOLDS):
        spec = pair_dvl(*nets[f], "imu_beam_fused_folds.py")
        t0 = time.perf_counter()
        for grade in EVAL_GRADES:
            series[f, grade] = held_out_series(held, akit_dir, grade, spec)
            pp[f, grade] = per_ping(*nets[f], scenario, series[f, grade])
        print(f"fold {f}: per ping in {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return series, pp


def run(scenario: str, imu_dir: str, beam_dir: str, akit_dir, out: Path, imu_decay: float | None,
        beam_decay: float | None) -> list[dict]:
    from imu_completer_folds import EVAL_GRADES

    from graphnav.nets.crossval import AKIT_FOLDS
    nets = fold_networks(scenario, imu_dir, beam_dir, imu_decay, beam_decay, akit_dir)
    series, pp = held_out_per_ping(nets, scenario, akit_dir)
    rows = []
    # the correlation for completers trained on all ten trajectories: every fold network on its held-out pair
    rho_all = {grade: fitted_rho([pp[g, grade] for g in nets], nets[0][0].missing) for grade in EVAL_GRADES}
    for f, held in enumerate(AKIT_FOLDS):
        t0 = time.perf_counter()
        for grade in EVAL_GRADES:
            rho = fitted_rho([pp[g, grade] for g in nets if g != f], nets[f][0].missing)
            rows += [{**r, "rho_all_folds": rho_all[grade]}
                     for r in fold_rows(f, held, scenario, grade, *nets[f], series[f, grade], pp[f, grade], rho,
                                        member_label(beam_dir))]
        out.write_text(json.dumps(rows, indent=1))
        print(f"fold {f} {list(held)}: outages in {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return rows


def _gains(rows: list[dict], scenario: str, variant: str, folds) -> tuple[list[float], list[float]]:
    """Pooled gains against the average over ``folds`` (every mode, IMU and metric of ``variant``) and the fold
    gains, in %."""
    pooled, per_fold = [], []
    for mode in ("per ping", "outage 30 s"):
        for grade in dict.fromkeys(r["variant"].split(",")[0] for r in rows):
            sel = [r for r in rows if (r["scenario"], r["mode"], r["variant"]) == (scenario, mode,
                                                                                  f"{grade}, {variant}")
                   and r["fold"] in folds]
            for m in ("beam_rmse", "vel_rmse"):
                net = {r["fold"]: r for r in sel if r["method"] == "network"}
                avg = {r["fold"]: r for r in sel if r["method"] == "average"}
                pooled.append(100 * (1 - np.sqrt(sum(net[f][m] ** 2 * net[f]["n"] for f in folds)
                                                 / sum(avg[f][m] ** 2 * avg[f]["n"] for f in folds))))
                per_fold += [100 * (1 - net[f][m] / avg[f][m]) for f in folds]
    return pooled, per_fold


def choose(rows: list[dict], scenario: str, folds) -> str:
    """The rule of the fading study: fewest fold cells worse than the average (every mode, IMU and metric), then
    the largest smallest pooled gain."""
    def key(variant):
        pooled, per_fold = _gains(rows, scenario, variant, folds)
        return (sum(g < 0 for g in per_fold), -min(pooled))
    return min(row_variants([r for r in rows if r["scenario"] == scenario]), key=key)


def choice_table(rows: list[dict]) -> str:
    """Per scenario and variant: worse fold cells, smallest pooled gain; the rule's choice on all folds and
    leave-one-fold-out (scored on the fold left out: its worst cell)."""
    lines = ["| scenario | variant | worse fold cells (of 60) | smallest pooled gain |", "| --- | --- | --- | --- |"]
    picks = []
    for sc in dict.fromkeys(r["scenario"] for r in rows):
        folds = sorted({r["fold"] for r in rows if r["scenario"] == sc})
        for v in row_variants([r for r in rows if r["scenario"] == sc]):
            pooled, per_fold = _gains(rows, sc, v, folds)
            lines.append(f"| {sc} | {v} | {sum(g < 0 for g in per_fold)} | {min(pooled):+.1f} % |")
        nested = []
        for f in folds:
            v = choose(rows, sc, [o for o in folds if o != f])
            nested.append(f"fold {f}: {v} (its worst cell there {min(_gains(rows, sc, v, [f])[1]):+.1f} %)")
        picks.append(f"{sc}: chosen on all folds: {choose(rows, sc, folds)}; without the fold scored: "
                     + "; ".join(nested))
    return "\n".join(lines + [""] + picks)


def coverage_table(rows: list[dict]) -> str:
    """Pooled fraction of filled-beam errors within 1 / 2 sigma and z RMS per scenario, mode and variant (every
    evaluation IMU)."""
    lines = ["| scenario | mode | variant | within 1 / 2 sigma | z RMS |", "| --- | --- | --- | --- | --- |"]
    for sc in dict.fromkeys(r["scenario"] for r in rows):
        for mode in ("per ping", "outage 30 s"):
            for v in row_variants([r for r in rows if r["scenario"] == sc]):
                sel = [r for r in rows if r["scenario"] == sc and r["mode"] == mode and r["method"] == "network"
                       and r["variant"].endswith(f", {v}")]
                n = np.array([r["n"] for r in sel], float)
                w1, w2 = (float(n @ [r[k] for r in sel] / n.sum()) for k in ("within_1sigma", "within_2sigma"))
                z = float(np.sqrt(n @ np.square([r["z_rms"] for r in sel]) / n.sum()))
                lines.append(f"| {sc} | {mode} | {v} | {w1:.3f} / {w2:.3f} | {z:.2f} |")
    return "\n".join(lines)


def interval_table(rows: list[dict]) -> str:
    lines = []
    for sc in dict.fromkeys(r["scenario"] for r in rows):
        for grade in dict.fromkeys(r["variant"].split(",")[0] for r in rows):
            v = f"{grade}, {SHIPPED}"
            cells = []
            for f in sorted({r["fold"] for r in rows if r["scenario"] == sc}):
                (b0, b1), (v0, v1) = window_interval(rows, sc, v, f)
                cells.append(f"fold {f} {b0:+.0f}..{b1:+.0f} / {v0:+.0f}..{v1:+.0f}")
            lines.append(f"{sc}, {grade}: " + "; ".join(cells))
    return "\n".join(lines)


def report(rows: list[dict]) -> str:
    from imu_completer_folds import fold_tables, rows_dvl
    dvl = rows_dvl(rows, "imu_beam_fused_folds.py")
    rhos = sorted({(r["scenario"], r["variant"].split(",")[0], r["fold"], round(r["rho"], 3)) for r in rows})
    return "\n\n".join([f"The DVL the pairs were trained for and scored on: {dvl}"] + fold_tables(rows, "variant") + [
        "Sigma coverage (Gaussian 0.683 / 0.954, z RMS 1):",
        coverage_table(rows),
        f"90 % interval of each fold's outage gain for '{SHIPPED}' over its outage windows drawn again "
        "(beam / velocity, %):",
        interval_table(rows),
        "Choosing the combination (per ping and outage, beam and velocity, three evaluation IMUs: 60 fold cells):",
        choice_table(rows),
        "rho fitted on the other folds (scenario, eval IMU, fold, rho): "
        + "; ".join(f"{s} {g} fold {f} {r:.3f}" for s, g, f, r in rhos),
        "rho on every fold network's held-out pings (scenario, eval IMU, rho): " + "; ".join(
            f"{s} {g} {r:.3f}" for s, g, r in sorted({(r["scenario"], r["variant"].split(",")[0],
                                                       round(r["rho_all_folds"], 3)) for r in rows}))])


def fold_network_parser(description: str, out_default: str) -> argparse.ArgumentParser:
    """The command line of a study on each fold's two networks: scenario, the networks' folders, their fadings'
    ``run_decay``, the data, the rows file and ``--report``."""
    p = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenario", choices=["2-missing", "3-missing"])
    p.add_argument("--imu-nets", help="IMU-aware fold networks (experiments/imu_completer_folds.py --save-nets DIR)")
    p.add_argument("--beam-nets", help="beam-only fold networks (graphnav eval-beams --folds --save-nets DIR: "
                   f"DIR/<recipe>), or '{PIVOT_MEMBER}': the pivot completer in their place, its pivot length fitted "
                   f"on the other folds' trajectories (the yaw alone, the average's hold), or '{PIVOT_PITCH_MEMBER}': "
                   "the pivot completer with its own defaults (yaw and pitch lengths fitted on the other folds, its "
                   "own hold)")
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--out", default=out_default, help="rows (JSON), rewritten after every fold")
    p.add_argument("--report", nargs="+", metavar="ROWS_JSON", help="only print the tables of finished runs")
    p.add_argument("--imu-decay", type=float, help="IMU-aware run_decay (default: the shipped card's)")
    p.add_argument("--beam-decay", type=float, help="beam-only run_decay (default: the shipped card's)")
    return p


def report_or_run(p: argparse.ArgumentParser, a: argparse.Namespace, report_rows, run_rows) -> int:
    """Print ``report_rows`` of the ``--report`` files, or of ``run_rows(out_path)`` (the networks' arguments
    required)."""
    if a.report:
        if a.imu_decay is not None or a.beam_decay is not None:
            p.error("--imu-decay / --beam-decay set a run; --report reads the decays its rows were run with")
        print(report_rows([r for path in a.report for r in json.loads(Path(path).read_text())]))
        return 0
    if not (a.scenario and a.imu_nets and a.beam_nets):
        p.error("--scenario, --imu-nets and --beam-nets are needed (or --report)")
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    print(report_rows(run_rows(out)))
    return 0


def main(argv=None) -> int:
    p = fold_network_parser(__doc__, "out/fusedens/rows.json")
    a = p.parse_args(argv)
    return report_or_run(p, a, report, lambda out: run(a.scenario, a.imu_nets, a.beam_nets, a.data, out,
                                                       a.imu_decay, a.beam_decay))


if __name__ == "__main__":
    sys.exit(main())
