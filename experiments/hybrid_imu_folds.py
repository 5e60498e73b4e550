"""The IMU-aware completer inside the factor graph, out of fold: the hybrid's regime cells on held-out trajectories
(docs/decisions/completers.md).

``graphnav bench`` loads one set of weights for every trajectory, so it cannot score a fold's network on that
fold's held-out pair only. This study does: per leave-trajectories-out fold (``nets.crossval.AKIT_FOLDS``) the fold's
IMU-aware network (``experiments/imu_completer_folds.py --save-nets DIR``, trained without the pair) runs in
``Graph-HN`` in place of the average estimator on the pair's bench windows (``case_windows``, ``--max-windows``;
the bench's IMU grades and seeds, :func:`graphnav.evaluation.bench.cases.prepared_mission`). Methods per window:

- ``Graph-TC``: measured beams only; ``all beams``: Graph-TC without the outage (the room there is to help);
- ``Graph-HN``: the average estimator (the default completer);
- ``HNI fold``: the fold's IMU-aware network, the average where it has no IMU window (``Graph-HNI`` falls
  back to the beam-only networks instead);
- ``HNI fused``: the same fused with the average (:class:`graphnav.nets.fused.FusedCompleter`) with the fold's
  correlation and outage growths, fitted on the other folds (``imu_completer_folds.py --calibrate``, rows of the
  evaluation IMU of the run's grade);
- ``HNI fused plain``: the same fusion with independent errors and no growth of its own (nothing fitted);
- ``HNI fold fading``: ``HNI fold`` with the network fading to the average through a run of regressed pings
  (``run_decay`` :data:`IMU_FADE`, chosen out of fold by ``experiments/completer_fade_folds.py --imu``);
- ``HNI fold fused`` (with ``--beam-nets DIR`` too): the fold's IMU-aware network fused with its beam-only network,
  both fading as the shipped fused completer's members do (:data:`graphnav.nets.imu_auto.FUSED_RUN_DECAY`); the
  beam-only network with its card's ``run_decay`` serves the pings without an IMU window
  (:class:`graphnav.nets.ImuAutoCompleter` ``beam_correlation``, as ``Graph-HNI`` runs the shipped pair);
- ``HN-net fold`` (with ``--beam-nets DIR``, ``graphnav eval-beams --folds --save-nets``): the fold's beam-only
  network, as ``Graph-HN-net`` runs the shipped one.

``--variants`` picks the runs (default the six above; Graph-TC and all beams are needed for the tables).

Printed: window VRMSE mean per cell and method, the ratio to Graph-TC pooled and per fold (targets: <= 1.02x
everywhere, <= 0.7x where all beams give <= 0.5x). Usage::

    nice -n 10 .venv/bin/python experiments/hybrid_imu_folds.py --nets out/imu_folds/nets3 \\
        --calibration out/imu_folds/cal3.json --out out/imu_folds/hybrid3.json --jobs 2
"""
from __future__ import annotations

import argparse
import functools
import json
import sys
from pathlib import Path

import numpy as np

#: The study's runs per window (registry methods with a given completer; module docstring).
#: Suffixes of screening_rho_folds.py's runs: the same completer with the fitted ``rho``, and with it the completion
#: variance scaled by the errors' autocorrelation time ``tau``.
FITTED = " rho fitted"
SERIAL = " rho, tau fitted"
VARIANTS = ("Graph-TC", "all beams", "Graph-HN", "HNI fold", "HNI fused", "HNI fused plain")
#: ``run_decay`` of the variant "HNI fold fading" (the fade study's choice, 2 and 3 missing beams)
IMU_FADE = 0.95


#: Correlation of the IMU-aware network's and the pivot completer's per-ping errors (each over its own sigma), for the
#: sigma of ``HNI fold fused`` with the pivot completer as the fused member: every A-KIT fold's network and pivot
#: completer (its length fitted on the other folds) on the fold's held-out pair, recorded IMU
#: (``imu_beam_fused_folds.py --beam-nets pivot``, first training draw; 0.71-0.72 / 0.75-0.76 with the other IMUs).
IMU_PIVOT_ERROR_CORRELATION = {"2-missing": 0.72, "3-missing": 0.76}


@functools.lru_cache(maxsize=None)
def shipped_run_decay(scenario: str) -> float:
    """The shipped beam-only completer's ``run_decay`` (the fold ensembles fade as it does); loaded once per process."""
    from graphnav.nets.network import load_completer
    return load_completer(scenario).run_decay


def completer(method: str, scenario: str, nets_dir: str, fold: int, fit: dict | None, noise_std: float, config=None):
    """The completer of one study method (None: the method's own). ``HNI fold fused`` with the beam-only networks'
    folder :data:`imu_beam_fused_folds.PIVOT_MEMBER` (``pivot``): the IMU-aware network fused with the pivot completer,
    which also serves the pings the network cannot, its pivot length fitted online over the mission's measured pings
    as ``Graph-HNP``'s (``config``: the mission's sensors, which it is built for); with ``pivot-pitch`` the pivot
    completer with its own defaults (yaw and pitch lengths fitted online, its own hold)."""
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.fused import FusedCompleter
    from graphnav.nets.imu_auto import ImuAutoCompleter
    from graphnav.nets.imu_network import load_imu_completer
    from graphnav.nets.network import load_completer
    method = method.removesuffix(FITTED).removesuffix(SERIAL)
    if method == "HNI fold fused":
        from graphnav.nets.imu_auto import FUSED_RUN_DECAY, load_imu_auto_completer
        imu_dir, beam_dir = nets_dir
        from imu_beam_fused_folds import PIVOT_MEMBERS, pivot_member_options
        if beam_dir in PIVOT_MEMBERS:
            from graphnav.core.config import SensorConfig
            from graphnav.core.scenarios import is_total_outage
            from graphnav.evaluation.methods import pivot_completer
            pivot = pivot_completer(scenario, config if config is not None else SensorConfig(),
                                    **pivot_member_options(beam_dir, scenario))
            # no network serves a total outage (the pivot completer does); the pair still holds the folder's
            # 3-missing network, as a shipped pair would hold its networks whatever the outage
            pattern = "3-missing" if is_total_outage(scenario) else scenario
            net = load_imu_completer(pattern, Path(imu_dir) / f"fold{fold}", run_decay=FUSED_RUN_DECAY[pattern]["IMU-aware"])
            return ImuAutoCompleter([net], pivot, {pattern: IMU_PIVOT_ERROR_CORRELATION[pattern]})
        beam = load_completer(scenario, directory=Path(beam_dir) / f"fold{fold}", run_decay=shipped_run_decay(scenario))
        fused_beam = load_completer(scenario, directory=Path(beam_dir) / f"fold{fold}",
                                    run_decay=FUSED_RUN_DECAY[scenario]["beam-only"])
        return load_imu_auto_completer({scenario: Path(imu_dir) / f"fold{fold}"}, beam, fused_beam_only=fused_beam,
                                       patterns=(scenario,))
    if method == "HN-net fold":
        return load_completer(scenario, directory=Path(nets_dir) / f"fold{fold}")
    if not method.startswith("HNI"):
        return None
    average = AverageCompleter(n_past=AVERAGE_N_PAST[scenario], noise_std=noise_std)
    decay = IMU_FADE if method == "HNI fold fading" else 1.0     # the other variants never fade
    hni = ImuAutoCompleter([load_imu_completer(scenario, Path(nets_dir) / f"fold{fold}", run_decay=decay)], average)
    if method in ("HNI fold", "HNI fold fading"):
        return hni
    # the average keeps no state: the fallback and the fused member can be the same one
    if method == "HNI fused plain":
        return FusedCompleter(hni, average)
    return FusedCompleter(hni, average, fit["rho"], (fit["growth_net"], fit["growth_avg"]))


def window_task(item):
    """Window VRMSE (m/s) of one study variant on one held-out trajectory, grade and window length. ``item``:
    (source, grade, scenario, window_s, max_windows, variant, nets_dir, fold, fit[, options]); ``options``: the
    estimator's options on top of the method's (``run_method``), e.g. ``{"screening.correlation": 0.3}``."""
    source, grade, scenario, window_s, max_windows, method, nets_dir, fold, fit, *rest = item
    options = rest[0] if rest else None
    import warnings
    warnings.simplefilter("ignore")
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench.cases import case_windows, prepared_mission
    from graphnav.evaluation.bench.scoring import score_case
    from graphnav.evaluation.methods import run_method
    mission = prepared_mission(source, grade)
    starts = case_windows(mission, window_s, max_windows)
    run = mission if method == "all beams" else mission.with_outage(
        *[scenario_outage(scenario, s, window_s) for s in starts])
    comp = completer(method, scenario, nets_dir, fold, fit, mission.config.dvl.beam_noise_std, mission.config)
    name = ("Graph-TC" if method == "all beams" else "Graph-HN" if method.startswith(("HNI", "HN-net", "Graph-HN"))
            else method)
    sol = run_method(run, name, scenario, completer=comp, options=options)
    return ((source.name, grade, window_s, method),
            [r["vrmse_window"] for r in score_case(sol, mission, starts, window_s)])


def table(results: dict, folds, grades, windows, variants=VARIANTS) -> str:
    """Per cell: mean window VRMSE per variant and each completing variant's ratio to Graph-TC, pooled and in the
    worst fold."""
    name = lambda n: f"Trajectory{n}"  # noqa: E731
    compared = [m for m in variants if m not in ("Graph-TC", "all beams")]
    lines = ["| IMU | window s | " + " | ".join(f"{m} m/s" for m in variants) + " | all/TC | "
             + " | ".join(f"{m}/TC (worst fold)" for m in compared) + " |",
             "| --- | --- | " + " | ".join("---" for _ in variants) + " | --- | "
             + " | ".join("---" for _ in compared) + " |"]
    for g in grades:
        for w in windows:
            def mean(method, pair):
                v = [x for k in pair for x in results.get((name(k), g, w, method), [])]
                return float(np.mean(v)) if v else float("nan")
            everything = [k for pair in folds for k in pair]
            means = {m: mean(m, everything) for m in variants}
            tc = means["Graph-TC"]

            def worst(method):
                ratios = [(mean(method, pair) / mean("Graph-TC", pair), f) for f, pair in enumerate(folds)]
                r, f = max(ratios)
                return f"{means[method] / tc:.2f} ({r:.2f}, fold {f})"
            lines.append(f"| {g} | {w:g} | " + " | ".join(f"{means[m]:.3f}" for m in variants)
                         + f" | {means['all beams'] / tc:.2f} | " + " | ".join(worst(m) for m in compared) + " |")
    return "\n".join(lines)


def fold_table(results: dict, folds, grades, windows, variants=VARIANTS) -> str:
    """Per cell and fold: each completing variant's window VRMSE mean over Graph-TC's on the fold's pair."""
    name = lambda n: f"Trajectory{n}"  # noqa: E731
    methods = [m for m in variants if m not in ("Graph-TC", "all beams")]
    lines = ["Per fold, " + " / ".join(methods) + " over Graph-TC:",
             "| IMU | window s | " + " | ".join(f"fold {f} ({', '.join(map(str, p))})" for f, p in enumerate(folds))
             + " |", "| --- | --- | " + " | ".join("---" for _ in folds) + " |"]
    for g in grades:
        for w in windows:
            cells = []
            for pair in folds:
                tc = np.mean([x for k in pair for x in results.get((name(k), g, w, "Graph-TC"), [])])
                cells.append(" / ".join(
                    f"{np.mean([x for k in pair for x in results.get((name(k), g, w, m), [])]) / tc:.2f}"
                    for m in methods))
            lines.append(f"| {g} | {w:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def load_runs(path: Path, settings: dict) -> tuple[dict, dict]:
    """(runs keyed (trajectory, grade, window_s, variant), the file's other entries) of a results file written
    with the same ``settings`` (scenario, windows, ...); an absent file: nothing yet. A file of other settings is
    refused: its window errors would stand in for these."""
    if not path.exists():
        return {}, {}
    saved = json.loads(path.read_text())
    if not isinstance(saved, dict) or saved.get("settings") != settings:
        found = saved.get("settings") if isinstance(saved, dict) else "none"
        raise SystemExit(f"{path} holds runs of other settings ({found}, here {settings}): give another --out or "
                         "delete it")
    return _runs_of(saved), {k: v for k, v in saved.items() if k not in ("settings", "runs")}


def read_results(path: Path) -> tuple[dict, dict]:
    """(settings, runs) of an existing results file of :func:`save_runs`, whatever its settings: for a reader that
    takes them from the file (parsed once)."""
    saved = json.loads(path.read_text())
    if not isinstance(saved, dict) or "settings" not in saved or "runs" not in saved:
        raise SystemExit(f"{path} is not a results file (no settings and runs)")
    return saved["settings"], _runs_of(saved)


def _runs_of(saved: dict) -> dict:
    return {tuple(k): v for k, v in saved["runs"]}


def save_runs(path: Path, settings: dict, runs: dict, **extra) -> None:
    """Write ``runs`` with their ``settings`` (and ``extra`` entries) for :func:`load_runs`."""
    path.write_text(json.dumps({"settings": settings, **extra, "runs": [[list(k), v] for k, v in runs.items()]}))


def run_saving(task, items: list, runs: dict, out: Path, settings: dict, jobs: int) -> None:
    """Run ``task`` on every item (``graphnav.evaluation.tasks``), each result ``(key, value)`` going into ``runs``
    and the file ``out`` (:func:`save_runs`) as it comes, so that an interrupted study resumes."""
    from graphnav.evaluation.tasks import run_tasks

    def finished(r):
        runs[r[0]] = r[1]
        save_runs(out, settings, runs)
    print(f"{len(items)} runs to do", file=sys.stderr, flush=True)
    run_tasks(task, items, finished, jobs=jobs)


def add_regime_window_arguments(p: argparse.ArgumentParser) -> None:
    """The regime table's windows as a study's options: ``--grades``, ``--window-s``, ``--max-windows`` (per
    trajectory) and ``--jobs`` (worker processes)."""
    p.add_argument("--grades", nargs="+", default=["tactical", "mems"], help="IMU grades (default tactical mems)")
    p.add_argument("--window-s", nargs="+", type=float, default=[60.0, 120.0], help="outage lengths, s")
    p.add_argument("--max-windows", type=int, default=2, help="windows per trajectory (as the regime table)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (graphnav.evaluation.tasks)")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--nets", help="the IMU-aware fold networks (imu_completer_folds.py --save-nets DIR)")
    p.add_argument("--calibration", help="rows of imu_completer_folds.py --calibrate (JSON), for 'HNI fused'")
    p.add_argument("--beam-nets", help="'pivot' (HNI fold fused with the pivot completer fitted online in their place, "
                   "as Graph-HNP runs it), 'pivot-pitch' (the pivot completer with its own defaults there), or "
                   "the beam-only fold networks of one recipe (graphnav eval-beams --folds "
                   "--save-nets DIR: DIR/<recipe>), for 'HN-net fold'")
    p.add_argument("--variants", nargs="+", default=list(VARIANTS),
                   choices=[*VARIANTS, "HN-net fold", "HNI fold fading", "HNI fold fused"],
                   help="the runs per window (default: " + ", ".join(VARIANTS) + ")")
    p.add_argument("--scenario", default="3-missing", help="beam-outage scenario (default 3-missing)")
    add_regime_window_arguments(p)
    p.add_argument("--out", default="out/imu_folds/hybrid.json", help="results (JSON); a rerun with the same "
                   "settings resumes from it")
    a = p.parse_args(argv)
    if not {"Graph-TC", "all beams"} <= set(a.variants):
        p.error("--variants needs Graph-TC and all beams: the tables are ratios to Graph-TC, beside all beams")
    if a.nets is None and any(v.startswith("HNI") for v in a.variants):
        p.error("the HNI variants need --nets")
    if a.calibration is None and "HNI fused" in a.variants:
        p.error("HNI fused needs --calibration")
    if a.beam_nets is None and {"HN-net fold", "HNI fold fused"} & set(a.variants):
        p.error("HN-net fold and HNI fold fused need --beam-nets")
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    folders = akit_trajectories(a.data)
    sources = {s.name: s for s in find_trajectories(str(folders[0].parent))}
    from imu_completer_folds import calibration_fits
    fits = calibration_fits(a.calibration, a.scenario) if a.calibration else {}
    out = Path(a.out)
    resolved = lambda path: path and str(Path(path).resolve())  # noqa: E731
    settings = {"scenario": a.scenario, "max_windows": a.max_windows, "nets": resolved(a.nets),
                "calibration": resolved(a.calibration)}
    if a.beam_nets:     # files of the first form (no beam-only networks) keep their settings
        from imu_beam_fused_folds import PIVOT_MEMBERS
        settings["beam_nets"] = a.beam_nets if a.beam_nets in PIVOT_MEMBERS else resolved(a.beam_nets)
    results, _ = load_runs(out, settings)
    items = []
    for f, pair in enumerate(AKIT_FOLDS):
        for k in pair:
            for g in a.grades:
                fit = {key: fits[f, g][key] for key in ("rho", "growth_net", "growth_avg")} if fits else None
                for w in a.window_s:
                    for m in a.variants:
                        if (f"Trajectory{k}", g, w, m) not in results:
                            nets = (a.beam_nets if m.startswith("HN-net") else (a.nets, a.beam_nets)
                                    if m == "HNI fold fused" else a.nets)
                            items.append((sources[f"Trajectory{k}"], g, a.scenario, w, a.max_windows, m, nets, f,
                                          fit))

    run_saving(window_task, items, results, out, settings, a.jobs)
    print(f"{a.scenario}, {a.max_windows} windows per held-out trajectory; window VRMSE mean, ratio to Graph-TC")
    print(table(results, AKIT_FOLDS, a.grades, a.window_s, a.variants))
    print()
    print(fold_table(results, AKIT_FOLDS, a.grades, a.window_s, a.variants))
    return 0


if __name__ == "__main__":
    sys.exit(main())
