"""The IMU-aware beam completer out of fold, trained with IMU grades (docs/decisions/completers.md).

Per leave-trajectories-out fold (:data:`graphnav.nets.crossval.AKIT_FOLDS`) the IMU-aware network is trained on
the fold's eight training trajectories, with the recorded IMU and one copy of each trajectory per IMU grade of
``--grades`` (the grade's errors added by :func:`graphnav.sim.imu_errors.corrupt_imu`, training seeds
``100 * copy + trajectory``), then scored on the two held-out trajectories with each evaluation IMU (recorded,
tactical, MEMS; evaluation seeds ``5000 + trajectory``, never trained on) by
:func:`graphnav.nets.imu_evaluate.evaluate_imu`: beam and velocity RMSE per ping and through recursive 30-ping
outages, against the average estimator (N = 5 for 3 missing beams) on the same pings, and the fraction of errors
within 1 and 2 sigma (Gaussian 0.683 / 0.954). Pooled (sample-weighted) numbers and the worst fold come from
:func:`graphnav.nets.crossval.summarise`. ``--missing 0-beams`` trains and scores a network for pings without a
measured beam (total outages; N = 3 past pings as with 3 missing beams), against the average with N = 5.

The schedule and IMU-grade copies are ``graphnav.nets.imu_recipes.IMU_RECIPES["graded"]``, shorter than the full
``ImuTrainOptions`` (60 epochs, 20 rollout epochs, 6 beam-noise draws) so that five trainings fit on the shared
machine; it is what the decision page reports, and the recipe the shipped weights were trained with on all ten
trajectories (``graphnav train-beams --imu --recipe graded``).
Rows are written to ``--out`` after every fold; ``--report`` prints the tables of such a file again.
``--config JSON`` trains and scores the fold networks for the DVL of a sensor configuration (beams made for it from
the recorded velocities), as ``graphnav train-beams --imu --config`` trains the final ones.

Calibration (``--calibrate DIR`` on the fold networks ``--save-nets DIR`` wrote): every fold network's and the
average's completions on its held-out pair are kept; then for fold k, from the **other four folds'** held-out
errors only (:mod:`graphnav.nets.outage_calibration`), the correlation of the network's and the average's errors
per ping, each one's sigma growth through an outage, and the network's ``drift_std`` for a calibrated 1-sigma band
are fitted, and fold k is scored with them: the network with that ``drift_std`` (its completions do not change,
its outage sigma does), and :class:`graphnav.nets.fused.FusedCompleter` with the correlation and growths. The
other folds' networks were trained on fold k's trajectories, but no error measured on fold k enters its numbers.
Usage::

    nice -n 10 .venv/bin/python experiments/imu_completer_folds.py --out out/imu_folds/rows.json
    .venv/bin/python experiments/imu_completer_folds.py --report out/imu_folds/rows.json
    nice -n 10 .venv/bin/python experiments/imu_completer_folds.py --missing 2-missing --save-nets out/imu_folds/nets2 --train-only
    .venv/bin/python experiments/imu_completer_folds.py --missing 2-missing --calibrate out/imu_folds/nets2 --out out/imu_folds/cal2.json
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

EVAL_GRADES = ("recorded", "tactical", "mems")
#: Beam-noise seed and evaluation-IMU seed base of every held-out scoring (evaluate_imu's defaults; never trained
#: on): every study that compares against the calibration study's pings makes its series with these.
HELD_OUT_BEAM_SEED, HELD_OUT_IMU_SEED = 1000, 5000


def held_out_series(held, akit_dir, grade: str, spec=None) -> list:
    """The held-out trajectories ``held`` as every scoring here sees them, with evaluation IMU ``grade`` and beams made
    for the DVL ``spec`` (default: the Snapir's; a fold network's ``trained_dvl_spec``)."""
    from graphnav.nets.imu_data import akit_imu_series, graded_series
    return graded_series(akit_imu_series(held, akit_dir, HELD_OUT_BEAM_SEED, spec=spec), grade, HELD_OUT_IMU_SEED)


def default_dvl_only(network, study: str) -> None:
    """Stop ``study``, which scores and fuses its fold networks on the default DVL's beams (the Snapir's), when the
    IMU-aware fold ``network`` was trained for another DVL (``imu_completer_folds.py --config``)."""
    from graphnav.nets.dvl_match import default_dvl_mismatch, dvl_name
    if default_dvl_mismatch(network.trained_T_b) is not None:
        raise SystemExit(f"{study}: its fold networks were trained for another DVL "
                         f"({dvl_name(network.trained_dvl_spec)}); it scores the default DVL's beams only "
                         "(imu_completer_folds.py and completer_fade_folds.py --imu score any)")


def rows_dvl(rows: list[dict], study: str) -> str:
    """The DVL a study's rows were scored on, as :func:`graphnav.nets.dvl_match.dvl_name` names it (rows without a
    ``dvl`` were scored on the Snapir's); stop ``study`` when they hold more than one: their gains do not pool."""
    from graphnav.nets.dvl_match import dvl_name, rows_dvls
    dvls = sorted(rows_dvls(rows))
    if len(dvls) > 1:
        raise SystemExit(f"{study}: the rows were scored on different DVLs ({'; '.join(dvls)}); report them apart")
    return dvls[0] if dvls else dvl_name()


def calibration_fits(path, scenario: str) -> dict:
    """The ``--calibrate`` rows of ``scenario`` in the file ``path`` by (fold, evaluation IMU): each row carries the
    numbers fitted for that fold (``rho``, ``growth_net``, ``growth_avg``, ``drift_net``)."""
    fits = {(r["fold"], r["variant"].split(",")[0].removeprefix("IMU ")): r
            for r in json.loads(Path(path).read_text()) if "rho" in r and r["scenario"] == scenario}
    if not fits:
        raise SystemExit(f"{path} has no calibration rows of {scenario}")
    return fits


def fold_rows(fold: int, held: tuple[int, ...], scenario: str, completer, akit_dir, fused: bool = False
              ) -> list[dict]:
    """:func:`evaluate_imu` rows of one fold's network on its held-out pair, per evaluation IMU, renamed for
    :func:`graphnav.nets.crossval.summarise` (the IMU-aware network is ``network``; the grade is the variant).
    With ``fused``, the network combined with the average by their sigmas (``imu+average``) is the ``network``
    of the variant "IMU <grade>, fused", beside a copy of the average's rows."""
    from graphnav.nets.dvl_match import dvl_name
    from graphnav.nets.imu_evaluate import evaluate_imu
    rows, dvl = [], dvl_name(completer.trained_dvl_spec)
    for grade in EVAL_GRADES:
        for r in evaluate_imu((scenario,), held, akit_dir=akit_dir, completers={scenario: completer},
                              imu_grade=None if grade == "recorded" else grade, fused=fused,
                              beam_seed=HELD_OUT_BEAM_SEED, imu_seed=HELD_OUT_IMU_SEED):
            base = {**r, "fold": fold, "held_out": list(held), "dataset": "A-KIT", "dvl": dvl}
            if r["method"] == "imu+average":
                rows.append({**base, "method": "network", "variant": f"IMU {grade}, fused"})
                continue
            if r["method"] == "network":    # the shipped beam-only network, trained on every trajectory
                continue
            method = {"imu-network": "network"}.get(r["method"], r["method"])
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


class _RawSigma:
    """A completer that records the sigma it returned at every call (before the history grows it)."""

    def __init__(self, completer):
        self.completer, self.raw = completer, []
        self.n_past = completer.n_past
        self.needs_imu = getattr(completer, "needs_imu", False)
        self.takes_run_steps = getattr(completer, "takes_run_steps", False)
        self.takes_past_dt = getattr(completer, "takes_past_dt", False)
        if self.needs_imu:
            self.imu_samples, self.ping_dt = completer.imu_samples, completer.ping_dt

    def complete(self, past, measured, **kwargs):
        beams, sigma = self.completer.complete(past, measured, **kwargs)
        self.raw.append(sigma)
        return beams, sigma


def held_out_arrays(held, scenario: str, network, akit_dir, grade: str) -> dict:
    """One fold network's and the average's completions on the held-out trajectories with evaluation IMU
    ``grade``: per ping (``pp_*``) and through the 30-ping recursive outages of
    :func:`graphnav.nets.imu_evaluate.evaluate_imu` (``out_*``; ``out_raw_*`` the completer's own sigma,
    before the history's growth), with the recorded beams and velocity of the same pings."""
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.evaluate import outage_rollout, predict_completer
    from graphnav.nets.imu_data import imu_windows
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE, predict_imu_network
    series = held_out_series(held, akit_dir, grade, network.trained_dvl_spec)
    average = AverageCompleter(AVERAGE_N_PAST[scenario])
    n_past = max(network.n_past, average.n_past)
    samples = imu_windows(series, n_past, network.imu_samples, network.ping_dt)
    own = imu_windows(series, network.n_past, network.imu_samples, network.ping_dt, pings=slice(n_past, None))
    if not np.array_equal(own.beams, samples.beams):
        raise RuntimeError("IMU network samples are not the pings of the average")
    out = {"pp_beams": samples.beams, "pp_v_b": samples.v_b}
    out["pp_full_net"], out["pp_sigma_net"] = predict_imu_network(network.model, own)
    out["pp_full_avg"], out["pp_sigma_avg"] = predict_completer(average, samples, network.missing)
    for name, comp in (("net", network), ("avg", average)):
        rec = _RawSigma(comp)
        full, _, osamples = outage_rollout(rec, series, network.missing, gap=60, settle=OUTAGE_SETTLE)
        if "out_beams" in out and not np.array_equal(out["out_beams"], osamples.beams):
            raise RuntimeError("the network's and the average's outage pings differ")
        out[f"out_full_{name}"], out[f"out_raw_{name}"] = full, np.array(rec.raw)
        out["out_beams"], out["out_v_b"] = osamples.beams, osamples.v_b
    return out


def fit_fold(others: list[dict], missing) -> dict:
    """Calibration numbers from other folds' held-out arrays (:func:`held_out_arrays`), :mod:`graphnav.nets.
    outage_calibration`: the network-average error correlation per ping, each member's growth for the fusion
    (variance target, :func:`member_sigma`) and the network's ``drift_std`` for the sigma it hands on through
    an outage (1-sigma coverage target, the history's growth)."""
    from graphnav.nets.outage_calibration import error_correlation, fit_drift, member_sigma
    m = list(missing)

    def cat(key, windows=False):
        parts = [o[key][:, m] for o in others]
        return np.concatenate([x.reshape(-1, 30, len(m)) for x in parts]) if windows else np.concatenate(parts)
    rho = error_correlation(cat("pp_full_net") - cat("pp_beams"), cat("pp_sigma_net"),
                            cat("pp_full_avg") - cat("pp_beams"), cat("pp_sigma_avg"))
    fit = {"rho": rho}
    for name in ("net", "avg"):
        err = cat(f"out_full_{name}", True) - cat("out_beams", True)
        raw = cat(f"out_raw_{name}", True)
        fit[f"growth_{name}"] = fit_drift(err, raw, member_sigma, "variance")
        fit[f"drift_{name}"] = fit_drift(err, raw)
    return fit


def calibrated_rows(fold: int, held, scenario: str, network, akit_dir, grade: str, arrays: dict, fit: dict
                    ) -> list[dict]:
    """Rows of fold ``fold`` for :func:`graphnav.nets.crossval.summarise`: variant "IMU <grade>, network, outage
    drift fitted" (the network's completions, its outage sigma grown with the fitted ``drift_std``) and "IMU
    <grade>, fused, rho and growth fitted" (:class:`~graphnav.nets.fused.FusedCompleter` with the fitted
    correlation and growths), each beside the average (history default growth), scored on the held-out pair."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.estimators.history import BeamHistory
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.data import BeamSamples
    from graphnav.nets.evaluate import completion_metrics, outage_rollout
    from graphnav.nets.fused import FusedCompleter, fuse
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE
    from graphnav.nets.outage_calibration import history_sigma
    miss = list(network.missing)
    geometry = DvlGeometry.from_spec(network.trained_dvl_spec)
    a = arrays
    pp = BeamSamples(np.zeros((len(a["pp_beams"]), 0, 4)), a["pp_beams"], a["pp_v_b"])
    osamp = BeamSamples(np.zeros((len(a["out_beams"]), 0, 4)), a["out_beams"], a["out_v_b"])

    def grown(raw, drift):
        return history_sigma(raw.reshape(-1, 30, 4), drift).reshape(-1, 4)
    default = BeamHistory(1).drift_std
    fused_pp = fuse(a["pp_full_net"], a["pp_sigma_net"], a["pp_full_avg"], a["pp_sigma_avg"], fit["rho"])
    series = held_out_series(held, akit_dir, grade, network.trained_dvl_spec)
    fused = FusedCompleter(network, AverageCompleter(AVERAGE_N_PAST[scenario]), fit["rho"],
                           (fit["growth_net"], fit["growth_avg"]))
    f_full, f_sigma, f_samp = outage_rollout(fused, series, miss, gap=60, settle=OUTAGE_SETTLE)
    if not np.array_equal(f_samp.beams, osamp.beams):
        raise RuntimeError("the fused rollout's pings are not the stored ones")
    made = {
        ("network, outage drift fitted", "per ping"): (a["pp_full_net"], a["pp_sigma_net"], pp),
        ("network, outage drift fitted", "outage 30 s"): (a["out_full_net"], grown(a["out_raw_net"],
                                                                                   fit["drift_net"]), osamp),
        ("fused, rho and growth fitted", "per ping"): (*fused_pp, pp),
        ("fused, rho and growth fitted", "outage 30 s"): (f_full, f_sigma, osamp),
    }
    rows = []
    for (what, mode), (full, sigma, samp) in made.items():
        variant = f"IMU {grade}, {what}"
        avg = ((a["pp_full_avg"], a["pp_sigma_avg"]) if mode == "per ping"
               else (a["out_full_avg"], grown(a["out_raw_avg"], default)))
        base = {"fold": fold, "held_out": list(held), "dataset": "A-KIT", "scenario": scenario, "mode": mode,
                "variant": variant, **{k: v for k, v in fit.items()}}
        net_m = completion_metrics(full, sigma, samp, miss, geometry)
        avg_m = completion_metrics(*avg, samp, miss, geometry)
        rows.append({**base, "method": "network", **net_m,
                     "beam_gain_pct": 100 * (1 - net_m["beam_rmse"] / avg_m["beam_rmse"]),
                     "vel_gain_pct": 100 * (1 - net_m["vel_rmse"] / avg_m["vel_rmse"])})
        rows.append({**base, "method": "average", **avg_m, "beam_gain_pct": 0.0, "vel_gain_pct": 0.0})
    return rows


def calibrate(nets_dir: Path, scenario: str, akit_dir, out: Path) -> list[dict]:
    """The calibration study (module docstring): held-out arrays of every fold network (cached as
    ``nets_dir/fold<k>_<grade>.npz``), then each fold scored with numbers fitted on the other folds."""
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.imu_network import load_imu_completer
    nets = {f: load_imu_completer(scenario, nets_dir / f"fold{f}") for f in range(len(AKIT_FOLDS))}
    arrays = {}
    for f, net in nets.items():
        for grade in EVAL_GRADES:
            cache = nets_dir / f"fold{f}_{grade}.npz"
            if not cache.exists():
                t0 = time.perf_counter()
                np.savez(cache, **held_out_arrays(AKIT_FOLDS[f], scenario, net, akit_dir, grade))
                print(f"fold {f} {grade}: held-out arrays in {time.perf_counter() - t0:.0f} s", file=sys.stderr,
                      flush=True)
            arrays[f, grade] = dict(np.load(cache))
    rows = json.loads(out.read_text()) if out.exists() else []
    # only calibration rows (they carry the fitted numbers) count as done: a plain study's rows in the same file
    # must not stand in for them
    done = {(r["fold"], r["variant"].split(",")[0]) for r in rows if "rho" in r}
    for f, net in nets.items():
        for grade in EVAL_GRADES:
            if (f, f"IMU {grade}") in done:
                continue
            fit = fit_fold([arrays[g, grade] for g in nets if g != f], net.missing)
            print(f"fold {f} {grade}: fitted on the other folds {fit}", file=sys.stderr, flush=True)
            rows += calibrated_rows(f, AKIT_FOLDS[f], scenario, net, akit_dir, grade, arrays[f, grade], fit)
            out.write_text(json.dumps(rows, indent=1))
    return rows


def fit_table(rows: list[dict]) -> str:
    """The fitted numbers per scenario, evaluation IMU and fold."""
    lines = ["| scenario | eval IMU | fold | rho | fused growth net / avg m/s/ping | network drift_std m/s/ping |",
             "| --- | --- | --- | --- | --- | --- |"]
    seen = set()
    for r in rows:
        key = (r["scenario"], r["variant"].split(",")[0], r["fold"])
        if "rho" not in r or key in seen:
            continue
        seen.add(key)
        lines.append(f"| {key[0]} | {key[1]} | {key[2]} | {r['rho']:.3f} | {r['growth_net']:.4f} / "
                     f"{r['growth_avg']:.4f} | {r['drift_net']:.4f} |")
    return "\n".join(lines)


def fold_tables(rows: list[dict], what: str = "IMU-aware network") -> list[str]:
    """The pooled table (:func:`graphnav.nets.crossval.summarise`) and the per-fold gains of ``rows``, titled."""
    from graphnav.nets.crossval import format_fold_gains, format_summary, summarise
    return [f"Pooled over the folds ({what} / average, m/s; gain = 1 - {what}/average; worst fold = largest "
            "ratio):", format_summary(summarise(rows)),
            "Gain against the average per fold (beam / velocity RMSE):", format_fold_gains(rows)]


def report(rows: list[dict]) -> str:
    return "\n\n".join(fold_tables(rows) + [
        "Sigma coverage of the IMU-aware network (Gaussian 0.683 / 0.954):",
        coverage_table(rows)] + (["Fitted on the other folds:", fit_table(rows)]
                                 if any("rho" in r for r in rows) else []))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--missing", default="3-missing", help="scenario (default 3-missing; 0-beams: a network for "
                   "pings without a measured beam, scored against the average in total outages)")
    from graphnav.nets.imu_recipes import IMU_RECIPES, ImuTrainOptions
    study, full = IMU_RECIPES["graded"], ImuTrainOptions()     # the study's schedule; the full one
    p.add_argument("--grades", nargs="*", default=list(study.imu_grades), help="IMU grades of the extra training "
                   f"copies (default {' '.join(study.imu_grades)}; none: recorded IMU only)")
    p.add_argument("--folds", nargs="+", type=int, help="fold indices to run (default all five)")
    p.add_argument("--epochs", type=int, default=study.epochs, help=f"one-step epochs (full: {full.epochs})")
    p.add_argument("--rollout-epochs", type=int, default=study.rollout_epochs,
                   help=f"recursive-stage epochs (full: {full.rollout_epochs})")
    p.add_argument("--rollout-stride", type=int, default=study.rollout_stride,
                   help=f"pings between rollout starts (full: {full.rollout_stride})")
    p.add_argument("--draws", type=int, default=study.draws, help=f"beam-noise draws per IMU copy (full: {full.draws})")
    p.add_argument("--sigma-epochs", type=int, default=study.sigma_epochs,
                   help=f"sigma-head epochs (full: {full.sigma_epochs})")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--fused", action="store_true", help="also the network combined with the average by their "
                   "sigmas (graphnav.nets.fused), reported as the variants 'IMU <grade>, fused'")
    p.add_argument("--save-nets", metavar="DIR", help="also write each fold's network to DIR/fold<k> (weights and "
                   "card), for --calibrate")
    p.add_argument("--calibrate", metavar="DIR", help="the calibration study on the fold networks --save-nets "
                   "wrote to DIR: correlation and outage growth fitted on the other folds' held-out errors")
    p.add_argument("--train-only", action="store_true", help="with --save-nets: train and save, score nothing")
    p.add_argument("--config", metavar="JSON", help="train the fold networks for the DVL of this sensor configuration "
                   "(graphnav train-beams --imu --config); they are scored on beams made for it (default: the "
                   "Snapir's DVL)")
    p.add_argument("--out", default="out/imu_folds/rows.json", help="rows (JSON), rewritten after every fold")
    p.add_argument("--report", nargs="+", metavar="ROWS_JSON", help="only print the tables of finished runs "
                   "(several files: folds run in separate processes, joined)")
    a = p.parse_args(argv)
    if a.report:
        print(report([r for f in a.report for r in json.loads(Path(f).read_text())]))
        return 0
    from graphnav.commands.common import config_dvl
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.dvl_match import dvl_name, rows_dvls
    from graphnav.nets.imu_network import ImuNetworkCompleter
    from graphnav.nets.imu_training import train_imu
    from graphnav.nets.training import save
    from graphnav.nets.model import normalize_missing, scenario_name
    akit_dir = akit_trajectories(a.data)[0].parent
    spec = config_dvl(a.config)
    scenario = scenario_name(normalize_missing(a.missing))
    opt = replace(study, epochs=a.epochs, rollout_epochs=a.rollout_epochs, rollout_stride=a.rollout_stride,
                  draws=a.draws, sigma_epochs=a.sigma_epochs, seed=a.seed, threads=1, imu_grades=tuple(a.grades))
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if a.calibrate:
        print(report(calibrate(Path(a.calibrate), scenario, akit_dir, out)))
        return 0
    rows = json.loads(out.read_text()) if out.exists() else []
    other = rows_dvls(rows) - {dvl_name(spec)}
    if other:
        raise SystemExit(f"{out} holds rows made for another DVL ({sorted(other)[0]}); give another --out")
    done = {r["fold"] for r in rows}
    for f in a.folds if a.folds is not None else range(len(AKIT_FOLDS)):
        if f in done:
            print(f"fold {f}: already in {out}", file=sys.stderr)
            continue
        held = AKIT_FOLDS[f]
        train = tuple(t for pair in AKIT_FOLDS for t in pair if t not in held)
        t0 = time.perf_counter()
        result = train_imu(scenario, opt, akit_dir, progress=False, evaluate=False, trajectories=train, spec=spec)
        t1 = time.perf_counter()
        if a.save_nets:
            save(result, Path(a.save_nets) / f"fold{f}")
        if a.train_only:
            print(f"fold {f} {list(held)}: trained in {t1 - t0:.0f} s", file=sys.stderr, flush=True)
            continue
        new = fold_rows(f, held, scenario, ImuNetworkCompleter(result.model, result.card), akit_dir, a.fused)
        for r in new:
            r["train_time_s"] = result.card["training"]["time_s"]
        rows += new
        out.write_text(json.dumps(rows, indent=1))
        print(f"fold {f} {list(held)}: training {t1 - t0:.0f} s (stages {result.card['training']['time_s']} s), "
              f"scoring {time.perf_counter() - t1:.0f} s", file=sys.stderr, flush=True)
    if not a.train_only:
        print(report(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
