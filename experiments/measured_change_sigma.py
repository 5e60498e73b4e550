"""The completions' sigma judged by the beams still measured, on the completers alone (docs/decisions/completers.md,
"The completions judged by the beams still measured").

Through recursive outages of 2 or 3 missing beams on the A-KIT trajectories, the completers of ``Graph-HN`` (the
average estimator) and ``Graph-HNP`` (the pivot completer, its length fitted online over the trajectory's measured
pings before each outage, as ``pivot_completer_folds.py --priors`` does) complete the missing beams through
:class:`graphnav.estimators.history.BeamHistory`, as the estimators do, once with the history's fixed growth and once
with ``run_sigma = "measured-change"``. The completions are the same; the sigmas differ. Per fold (the completer
studies' folds) and pooled, for the missing beams' errors against the measured beams (as
``calibrate_drift.py`` scores them, the beam noise in the error):

- ``z RMS``: the RMS of error / sigma, and the share within 1 and 2 sigma (Gaussian: 0.683 / 0.954); in brackets
  against ``sqrt(sigma^2 + noise^2)``, the beam noise the errors hold added to the sigma;
- ``corr``: per outage, the RMS sigma against the RMS error, their correlation over the outages (Pearson, and of
  their logs): whether the sigma ranks the outages;
- ``per ping``: the correlation, per ping, of the sigma with the missing beams' RMS error at that ping.

Outages of ``--outage`` pings (several lengths), a start every ``--stride`` pings from ping ``--first`` with every
beam measured over the hold and the outage. About 3 min per IMU copy on one core::

    .venv/bin/python experiments/measured_change_sigma.py --outage 30 60 --out out/measured_sigma/completers.json
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

SCENARIOS = ("2-missing", "3-missing")
COMPLETERS = ("average", "pivot")
SIGMAS = ("growth", "measured-change")


def outage_rows(completer, mission, missing, start: int, length: int) -> dict:
    """Per ping of one recursive outage from ``start``: the missing beams' errors (pings, missing) m/s against the
    measured beams, and their sigma with each of :data:`SIGMAS`."""
    from graphnav.estimators.history import BeamHistory
    from graphnav.nets.imu_window import imu_window_at
    t, beams = mission.dvl.t, mission.dvl.beams
    n = completer.n_past
    valid = np.ones(4, bool)
    valid[list(missing)] = False
    out = {"err": [], **{s: [] for s in SIGMAS}}
    for mode in SIGMAS:
        completer.run_sigma = mode
        history = BeamHistory(n)
        for k in range(start - n, start):
            history.push(beams[k], t[k])
        for k in range(start, start + length):
            imu = imu_window_at(mission.imu, t[k], completer.imu_samples) \
                if getattr(completer, "needs_imu", False) else None
            full, sigma = history.complete(completer, beams[k], valid, imu=imu, t=t[k])
            out[mode].append(sigma[~valid])
            if mode == SIGMAS[0]:
                out["err"].append(full[~valid] - beams[k][~valid])
    completer.run_sigma = None
    return {k: np.array(v) for k, v in out.items()}


def trajectory_rows(source, grade: str, lengths, stride: int, first: int) -> dict:
    """Per scenario, completer and outage length: the list of outages (:func:`outage_rows`, as lists) of one
    trajectory."""
    from pivot_completer_folds import online_fits

    from graphnav.core.dvl import DvlGeometry
    from graphnav.core.scenarios import SCENARIOS as PATTERNS
    from graphnav.evaluation.bench.cases import prepared_mission
    from graphnav.evaluation.methods import PIVOT_AXES, average_completer, pivot_completer
    mission = prepared_mission(source, grade)
    geometry = DvlGeometry.from_spec(mission.config.dvl)
    usable = mission.dvl.valid.all(axis=1)
    noise = mission.config.dvl.beam_noise_std
    rows = {}
    for scenario in SCENARIOS:
        members = {"average": average_completer(scenario, noise), "pivot": pivot_completer(scenario, mission.config)}
        fits = online_fits(mission, geometry, members["pivot"].n_past, PIVOT_AXES)
        for name, completer in members.items():
            n = completer.n_past
            for length in lengths:
                starts = [s for s in range(max(first, n), len(usable) - length + 1, stride)
                          if usable[s - n:s + length].all()]
                outages = []
                for s in starts:
                    if name == "pivot":
                        completer.fit.num, completer.fit.den = fits[s]
                    outages.append({k: v.tolist() for k, v in outage_rows(completer, mission, PATTERNS[scenario],
                                                                           s, length).items()})
                rows[f"{scenario}|{name}|{length}"] = outages
    return rows


def _corr(sig: np.ndarray, err: np.ndarray) -> float:
    """Pearson correlation of sigmas and errors; nan when the sigmas do not vary (a constant sigma ranks nothing)."""
    return float(np.corrcoef(sig, err)[0, 1]) if np.std(sig) > 0 else float("nan")


def scores(outages: list, mode: str, noise: float) -> dict:
    """Calibration and ranking (module docstring) of the sigma ``mode`` over ``outages``."""
    err = np.concatenate([np.ravel(o["err"]) for o in outages])
    sig = np.concatenate([np.ravel(o[mode]) for o in outages])
    z, zn = err / sig, err / np.sqrt(sig ** 2 + noise ** 2)
    per_err = np.array([np.sqrt(np.mean(np.square(o["err"]))) for o in outages])
    per_sig = np.array([np.sqrt(np.mean(np.square(o[mode]))) for o in outages])
    corr, log_corr = _corr(per_sig, per_err), _corr(np.log(per_sig), np.log(per_err))
    ping_err = np.concatenate([np.sqrt(np.mean(np.square(o["err"]), axis=1)) for o in outages])
    ping_sig = np.concatenate([np.sqrt(np.mean(np.square(o[mode]), axis=1)) for o in outages])
    ping_corr = _corr(ping_sig, ping_err)
    return {"per ping": ping_corr, "z rms": float(np.sqrt(np.mean(z ** 2))), "in 1": float(np.mean(np.abs(z) < 1)),
            "in 2": float(np.mean(np.abs(z) < 2)), "z rms n": float(np.sqrt(np.mean(zn ** 2))),
            "in 1 n": float(np.mean(np.abs(zn) < 1)), "in 2 n": float(np.mean(np.abs(zn) < 2)),
            "corr": corr, "log corr": log_corr, "rms err": float(np.sqrt(np.mean(err ** 2))),
            "rms sigma": float(np.sqrt(np.mean(sig ** 2))), "outages": len(outages)}


def report(saved: dict) -> str:
    from graphnav.nets.crossval import AKIT_FOLDS
    results, noise = saved["results"], saved["noise"]
    lines = ["| IMU | scenario | completer | pings | sigma | RMS error / sigma m/s | z RMS (noise added) | "
             "within 1 / 2 sigma (noise added) | corr per outage (logs) | per ping | folds' z RMS | folds' corr |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    grades = sorted({g for r in results.values() for g in r})
    for grade in grades:
        for key in sorted(next(iter(results.values()))[grade]):
            scenario, name, length = key.split("|")
            for mode in SIGMAS:
                pooled = scores([o for r in results.values() for o in r[grade][key]], mode, noise)
                folds = [scores([o for k in pair for o in results[f"Trajectory{k}"][grade][key]], mode, noise)
                         for pair in AKIT_FOLDS]
                z_folds = " ".join(f"{f['z rms']:.2f}" for f in folds)
                corr_folds = " ".join(f"{f['corr']:.2f}" for f in folds)
                lines.append(f"| {grade} | {scenario} | {name} | {length} | {mode} | {pooled['rms err']:.3f} / "
                             f"{pooled['rms sigma']:.3f} | {pooled['z rms']:.2f} ({pooled['z rms n']:.2f}) | "
                             f"{pooled['in 1']:.2f} / {pooled['in 2']:.2f} ({pooled['in 1 n']:.2f} / "
                             f"{pooled['in 2 n']:.2f}) | {pooled['corr']:.2f} ({pooled['log corr']:.2f}) | "
                             f"{pooled['per ping']:.2f} | {z_folds} | {corr_folds} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--outage", nargs="+", type=int, default=[30, 60], help="outage lengths, pings (default 30 60)")
    p.add_argument("--stride", type=int, default=10, help="pings between outage starts (default 10)")
    p.add_argument("--first", type=int, default=60, help="the first ping an outage may start at (default 60)")
    p.add_argument("--grades", nargs="+", default=["as-recorded"], choices=("as-recorded", "tactical", "mems"),
                   help="IMU copies (the pivot completer's gyro)")
    p.add_argument("--out", help="results (JSON)")
    p.add_argument("--report", help="print the table of a results file and stop")
    a = p.parse_args(argv)
    if a.report:
        print(report(json.loads(Path(a.report).read_text())))
        return 0
    warnings.simplefilter("ignore", UserWarning)
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    sources = {s.name: s for s in find_trajectories(str(akit_trajectories(a.data)[0].parent))}
    results = {}
    for k in (k for pair in AKIT_FOLDS for k in pair):
        name = f"Trajectory{k}"
        results[name] = {g: trajectory_rows(sources[name], g, a.outage, a.stride, a.first) for g in a.grades}
        print(f"{name} done", file=sys.stderr, flush=True)
    from graphnav.core.config import SensorConfig
    saved = {"outage": a.outage, "stride": a.stride, "first": a.first, "noise": SensorConfig().dvl.beam_noise_std,
             "results": results}
    if a.out:
        Path(a.out).parent.mkdir(parents=True, exist_ok=True)
        Path(a.out).write_text(json.dumps(saved))
    print(report(saved))
    return 0


if __name__ == "__main__":
    sys.exit(main())
