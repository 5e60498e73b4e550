"""The screening's correlation between a completion and the graph's own prediction, fitted out of fold
(docs/decisions/completers.md).

The hybrid's screening treats the error of a completed beam as correlated with the error of the graph's
prediction of that beam with a fixed ``rho`` (``screening.correlation``, 0.5). ``experiments/regressed_correlation.py``
measures the true correlation in the plain hybrid: 0.15-0.59 depending on the IMU and the outage. This study fits
it per leave-trajectories-out fold (``nets.crossval.AKIT_FOLDS``): on the fold's eight training trajectories, per
IMU grade and scenario, from every regressed beam of every bench window of both lengths (the average
estimator's completions, which fit nothing on the data), as the correlation of the completion's error over its
sigma and the prediction's error over its sigma (the screening's model: ``cov = rho sqrt(a s_c^2)`` per beam;
``collect`` runs the plain hybrid, screening off, and ``a`` without ``prediction_var_scale``, a constant factor
this correlation does not see); then it runs ``Graph-HN`` with that ``rho`` on the
held-out pair's bench windows (``--max-windows``), beside Graph-TC, all beams and the default Graph-HN on the
same windows (``experiments/hybrid_imu_folds.py``'s task and tables).

With ``--completer`` one of ``hybrid_imu_folds.py``'s fold-network completers (the IMU-aware ``HNI fold``, ``HNI
fused``, ``HNI fused plain``, or the beam-only ``HN-net fold``; ``--nets`` and ``--calibration`` as there), the errors
of every trajectory are those of the network of
the fold that holds that trajectory out, so the ``rho`` of fold k comes from the other folds' networks on
trajectories they never saw (cross-fitted, as ``imu_completer_folds.py --calibrate``); then that completer runs
with the default ``rho`` and with the fitted one on fold k's pair. The networks need a measured beam: one scenario,
2-missing or 3-missing.

Each fold also gets ``tau``, the integrated autocorrelation time (pings) of the completion errors over their sigma
(``nets.outage_calibration.integrated_autocorrelation``, from the same errors): the run `` rho, tau fitted`` adds
``screening.completion_var_scale = tau`` to the fitted ``rho`` (completions that stay off for many pings together
weigh as about n / tau independent ones). Usage::

    nice -n 5 .venv/bin/python experiments/screening_rho_folds.py --scenario 3-missing 0-beams --jobs 2 \\
        --out out/screening_rho
    nice -n 5 .venv/bin/python experiments/screening_rho_folds.py --scenario 3-missing --completer "HNI fused" \\
        --nets out/imu_folds/nets3 --calibration out/imu_folds/cal3.json --jobs 2 --out out/screening_rho_hni
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def variants(completer: str) -> tuple[str, ...]:
    """The runs per window: Graph-TC, all beams, the default Graph-HN, the study's completer with the default and
    the fitted ``rho`` (the average's default run is Graph-HN itself)."""
    from hybrid_imu_folds import FITTED, SERIAL
    if completer == "average":
        return ("Graph-TC", "all beams", "Graph-HN", "Graph-HN" + FITTED, "Graph-HN" + SERIAL)
    return ("Graph-TC", "all beams", "Graph-HN", completer, completer + FITTED, completer + SERIAL)


def beam_sequences(rows: np.ndarray, scenario: str) -> list[np.ndarray]:
    """The normalised errors e_c / s_c of one run's regressed beams (``collect`` rows, keyframe by keyframe, the
    scenario's missing beams at each), one sequence per beam. The rows do not say where one outage window ends,
    so a run's windows stay joined and the longer lags pair the end of one window with the start of the next (an
    approximation of this study); a keyframe with another number of regressed beams is refused."""
    from graphnav.core.scenarios import SCENARIOS
    m = len(SCENARIOS[scenario])
    if len(rows) % m:
        raise ValueError(f"{len(rows)} regressed beams are not {m} per keyframe ({scenario})")
    z = (rows[:, 0] / np.sqrt(rows[:, 3])).reshape(-1, m)
    return [z[:, b] for b in range(m)]


def correlation_task(item):
    """Rows (e_c, e_p, a, s_c^2) of every regressed beam of one trajectory's plain hybrid (``collect``), with the
    completer of ``hybrid_imu_folds.completer`` (method, nets, fold, fit; the average when the method is not
    an IMU-aware one)."""
    source, grade, scenario, window_s, method, nets_dir, fold, fit = item
    import warnings
    warnings.simplefilter("ignore")
    from graphnav.evaluation.bench import prepared_mission
    from hybrid_imu_folds import completer
    from regressed_correlation import collect
    mission = prepared_mission(source, grade)
    comp = completer(method, scenario, nets_dir, fold, fit, mission.config.dvl.beam_noise_std)
    return (source.name, grade, scenario, window_s), collect(mission, scenario, window_s, comp).tolist()


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from hybrid_imu_folds import add_regime_window_arguments
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--scenario", nargs="+", default=["3-missing", "0-beams"], help="scenarios")
    add_regime_window_arguments(p)
    p.add_argument("--out", default="out/screening_rho", help="folder for the collected errors and the runs")
    p.add_argument("--completer", default="average",
                   choices=["average", "HNI fold", "HNI fused", "HNI fused plain", "HN-net fold"],
                   help="the hybrid's completer (default the average estimator; the others: hybrid_imu_folds.py)")
    p.add_argument("--nets", help="fold networks of a network --completer (imu_completer_folds.py --save-nets DIR; "
                   "for 'HN-net fold', graphnav eval-beams --folds --save-nets DIR: DIR/<recipe>)")
    p.add_argument("--calibration", help="fitted rows of --completer 'HNI fused' (imu_completer_folds.py --calibrate)")
    a = p.parse_args(argv)
    from hybrid_imu_folds import FITTED, SERIAL, fold_table, load_runs, save_runs, table, window_task
    study = variants(a.completer)
    fold_nets = a.completer != "average"     # each trajectory completed by the fold network that holds it out
    if fold_nets and (a.nets is None or (a.completer == "HNI fused" and a.calibration is None)):
        p.error(f"--completer {a.completer!r} needs --nets"
                + (" and --calibration" if a.completer == "HNI fused" else ""))
    if fold_nets and (len(a.scenario) != 1 or a.scenario[0] not in ("2-missing", "3-missing")):
        p.error("a network --completer needs a measured beam: one --scenario, 2-missing or 3-missing")

    from graphnav.evaluation.bench import find_trajectories
    from graphnav.evaluation.tasks import run_tasks
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.outage_calibration import error_correlation, integrated_autocorrelation
    folders = akit_trajectories(a.data)
    sources = {s.name: s for s in find_trajectories(str(folders[0].parent))}
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    name = lambda n: f"Trajectory{n}"  # noqa: E731
    names = [name(k) for pair in AKIT_FOLDS for k in pair]

    from imu_completer_folds import calibration_fits
    fits = calibration_fits(a.calibration, a.scenario[0]) if a.completer == "HNI fused" else {}
    fold_of = {name(k): f for f, pair in enumerate(AKIT_FOLDS) for k in pair}

    def fit(f, g):
        return {key: fits[f, g][key] for key in ("rho", "growth_net", "growth_avg")} if fits else None
    # what made the errors (the average fits nothing: no settings)
    source_settings = {"completer": a.completer, "nets": str(Path(a.nets).resolve()),
                       "calibration": a.calibration and str(Path(a.calibration).resolve())} if fold_nets else {}
    errs_file = out / "errors.json"
    errors = {k: np.array(v).reshape(-1, 4) for k, v in load_runs(errs_file, source_settings)[0].items()}
    todo = [(sources[n], g, sc, w, a.completer, a.nets, fold_of[n], fit(fold_of[n], g))
            for n in names for g in a.grades for sc in a.scenario for w in a.window_s if (n, g, sc, w) not in errors]

    def got_errors(r):
        errors[r[0]] = np.array(r[1]).reshape(-1, 4)
        save_runs(errs_file, source_settings, {k: v.tolist() for k, v in errors.items()})
    print(f"{len(todo)} correlation runs to do", file=sys.stderr, flush=True)
    run_tasks(correlation_task, todo, got_errors, jobs=a.jobs)

    rho, tau = {}, {}
    print("Fitted on each fold's training trajectories (the regressed beams, both window lengths): rho, the "
          "correlation of e_c / s_c and e_p / sqrt(a); tau, the integrated autocorrelation time of e_c / s_c (pings)")
    print("| IMU | scenario | " + " | ".join(f"fold {f}" for f in range(len(AKIT_FOLDS))) + " | all ten |")
    print("| --- | --- | " + " | ".join("---" for _ in AKIT_FOLDS) + " | --- |")
    for g in a.grades:
        for sc in a.scenario:
            cells = []
            for f, pair in enumerate([*AKIT_FOLDS, ()]):
                runs = [errors[n, g, sc, w] for n in names if n not in {name(k) for k in pair} for w in a.window_s]
                d = np.vstack(runs)
                # the screening's model: cov(e_c, e_p) = rho sqrt(a s_c^2) per beam, so the correlation of the
                # errors each over its own sigma (kept in [0, 0.99], the range the option takes)
                r = error_correlation(d[:, 0], np.sqrt(d[:, 3]), d[:, 1], np.sqrt(d[:, 2]))
                rho[f, g, sc] = float(np.clip(r, 0.0, 0.99))
                tau[f, g, sc] = integrated_autocorrelation([z for run in runs for z in beam_sequences(run, sc)])
                cells.append(f"{rho[f, g, sc]:.2f}, {tau[f, g, sc]:.1f}")
            print(f"| {g} | {sc} | " + " | ".join(cells) + " |")

    for sc in a.scenario:
        runs_file = out / f"runs-{sc}.json"
        settings = {"scenario": sc, "max_windows": a.max_windows, "window_s": a.window_s, "grades": a.grades,
                    **source_settings}
        fitted = {f"{f} {g}": rho[f, g, sc] for f in range(len(AKIT_FOLDS)) for g in a.grades}
        fitted_tau = {f"{f} {g}": tau[f, g, sc] for f in range(len(AKIT_FOLDS)) for g in a.grades}
        results, extra = load_runs(runs_file, settings)
        if extra.get("rho") != fitted:      # runs with another fit are not these
            results = {k: v for k, v in results.items() if not k[3].endswith((FITTED, SERIAL))}
        if extra.get("tau") != fitted_tau:
            results = {k: v for k, v in results.items() if not k[3].endswith(SERIAL)}
        items = []
        for f, pair in enumerate(AKIT_FOLDS):
            for k in pair:
                for g in a.grades:
                    for w in a.window_s:
                        for v in study:
                            if (name(k), g, w, v) in results:
                                continue
                            options = None
                            if v.endswith((FITTED, SERIAL)):
                                options = {"screening.correlation": rho[f, g, sc]}
                            if v.endswith(SERIAL):
                                options["screening.completion_var_scale"] = tau[f, g, sc]
                            items.append((sources[name(k)], g, sc, w, a.max_windows, v, a.nets, f, fit(f, g),
                                          options))

        def got_run(r, results=results, runs_file=runs_file, settings=settings, fitted=fitted, fitted_tau=fitted_tau):
            results[r[0]] = r[1]
            save_runs(runs_file, settings, results, rho=fitted, tau=fitted_tau)
        print(f"{sc}: {len(items)} runs to do", file=sys.stderr, flush=True)
        run_tasks(window_task, items, got_run, jobs=a.jobs)
        print(f"\n{sc}, {a.max_windows} windows per held-out trajectory; window VRMSE mean, ratio to Graph-TC")
        print(table(results, AKIT_FOLDS, a.grades, a.window_s, study))
        print()
        print(fold_table(results, AKIT_FOLDS, a.grades, a.window_s, study))
    return 0


if __name__ == "__main__":
    sys.exit(main())
