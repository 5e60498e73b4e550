"""How accurate a completer would have to be for the hybrid to help: completions with a known error, in the graph.

The regime table (``experiments/hybrid_imu_folds.py``) asks the hybrid for <= 0.7x Graph-TC wherever all four beams
measured would give <= 0.5x. No completer reaches it (docs/decisions/completers.md). This study asks what accuracy
would: in the same windows (``max_windows`` per trajectory, every A-KIT trajectory, tactical and MEMS IMU), Graph-HN
runs as shipped (default screening), but every regressed beam is replaced by the **true** beam (ground-truth
velocity and attitude, lever-arm term included) plus an error of known size, stated to the graph as its sigma:

- ``white s``: independent N(0, s^2) per beam and ping;
- ``serial s``: a first-order Gauss-Markov error per beam, standard deviation ``s``, correlation time
  :data:`SERIAL_TAU_PINGS` pings (the completers' errors stay off for about that long, integrated autocorrelation
  time 18-24 pings), stated sigma ``s`` as a completer would state it. The error advances once per ping with
  regressed beams (the windows are minutes apart, so a window starts from the last one's error).

The oracle's sigma is given as is, without the graph's floor for regressed beams (the beam noise, 0.042 m/s): an
oracle is as good as it says.

With ``--record DIR`` (the IMU-aware fold networks) and ``--beam-nets DIR`` (or ``pivot``: the pivot completer, its
pivot length fitted online, in the beam-only networks' place) it also runs the shipped ``Graph-HNI`` completer of
each trajectory's fold (``hybrid_imu_folds.py``'s ``HNI fold fused``) and records its completions'
error against the same truth: RMS through the windows, the sigma the history handed on (before the screening's
adaptive inflation), and how often the screening kept them. In a total outage no shipped network serves a ping
and the recorded completer is ``Graph-HNI``'s average fallback, unless ``--record`` also holds fold networks for
pings without a measured beam (``imu_completer_folds.py --missing 0-beams --save-nets``): then every held-out
trajectory completes with its fold's network (and the average where it has no IMU window). ``--drift D ...`` runs it again with those sigma growths per ping (``ImuAutoCompleter(drift_std=D)``;
the history's default is 0.03) and prints the growth the regime rule chooses, on all folds and leave-one-fold-out
(with ``--tau`` too, every growth also with each run setting, and the pair chosen together).
``--average`` records Graph-HN's own completer (the average estimator) the same way. ``--tau T ...`` runs the serial
oracles, the average and the recorded completer again with a run of regressed beams screened only until one of its
completions is kept (``GraphOptions.regressed_runs="screen-first"``) and, for T > 0, the graph modelling their errors
as a Gauss-Markov process of correlation time T s (``GraphOptions.regressed_error_tau_s``: the run's later
completions enter as whitened differences with the previous ones); it prints the T the regime rule chooses, on all
folds and leave-one-fold-out (with ``--joint``, on the cells of several scenarios together).
``--anchored`` runs the recorded completer (and with ``--average`` the average estimator) again screened at each
ping against the prediction of the graph without completions (``Graph-TC`` on the same run, :func:`twin_predictions`)
instead of the graph's own, which the completions already kept have pulled: a prediction anchored at the outage's
last measured state, carried through the outage by the IMU and the measured beams only.
``--over-draws`` runs nothing: given each training draw's results files (one ``--over-draws`` per draw, the files of
its scenarios) and ``--references`` (one per scenario), it prints the run setting (with ``--anchored``, the
anchored screening among them) the regime rule chooses with every draw's cells counted together (fold cells over
1.02x summed over the draws, then the mean pooled ratio over all of them), on all folds and leave-one-fold-out: a
default that must hold for whichever draw of the weights is shipped; and, per setting and draw, its worst fold cell
(the ratio to Graph-TC and where it is) and its fold cells over 1.02x.
``--recorded-draw T@F ...`` adds the fold cells over 1.02x of a draw whose runs were not kept (setting T s,
``each`` or ``anchored``, in fold F) to the counts, not to the means.
``--oracle-draws N`` runs every oracle N times with other draws of its errors (the same model and sigma) and prints,
per cell, the spread of its pooled and worst-fold ratios over the draws and how many fold cells each draw has over
1.02x: how often a completion the graph is told correctly fails "never worse" by chance in these windows.
The table prints each variant's window VRMSE over Graph-TC's, pooled over the ten trajectories and (in brackets)
the worst fold, beside all beams. ``--reference`` is the regime study's results file of the same scenario (its
Graph-TC, all-beams and Graph-HN runs). Usage::

    .venv/bin/python experiments/oracle_completions.py --scenario 3-missing --reference out/fusedens/hybrid3.json \\
        --record out/imu_folds/nets3 --beam-nets out/ens/akit-residual-aug-ens5 --drift 0 0.01 0.02 \\
        --out out/oracle/oracle3.json --jobs 2
"""
from __future__ import annotations

import argparse
import sys
import zlib
from contextlib import contextmanager
from pathlib import Path

import numpy as np

#: correlation time of the serial oracle's errors, pings (1 Hz DVL)
SERIAL_TAU_PINGS = 20.0
#: error sizes (m/s) of the oracle completions
SIGMAS = (0.02, 0.05, 0.1)
RECORDED = "Graph-HNI (fold)"
#: Graph-HN's default completer (the average estimator), recorded like the fold networks
AVERAGE = "Graph-HN (average)"
#: the pivot completer (graphnav.nets.pivot) with the fold's pivot length fitted on the other folds, recorded likewise
PIVOT = "Graph-HN (pivot)"
#: the pivot completer fitting its pivot length online over the mission's measured pings (--pivot-online PRIOR)
PIVOT_ONLINE = "Graph-HN (pivot online)"
#: variant suffix: the graph models the completion errors' correlation (GraphOptions.regressed_error_tau_s, s)
TAU = " tau "
#: variant suffix of an oracle: another draw of its errors (the same model, another seed)
DRAW = " draw "
#: variant suffix: screened at each ping against the graph without completions (:func:`twin_predictions`)
ANCHORED = " anchored"
#: its regime-rule label
ANCHORED_LABEL = "screen-each, anchored"
#: the regime-rule label of a run screened at each ping (``screen_first_label`` gives the others)
SCREEN_EACH = "screen-each"


def oracle_variants(sigmas=SIGMAS) -> list[str]:
    return [f"{kind} {s:g}" for kind in ("white", "serial") for s in sigmas]


def draw_names(oracle: str, draws: int) -> list[str]:
    """The variant names of ``draws`` draws of an oracle's errors (the first is the oracle itself)."""
    return [oracle] + [f"{oracle}{DRAW}{k}" for k in range(2, draws + 1)]


def oracle_seed(trajectory: str, grade: str, scenario: str, window_s: float, variant: str, draw: str = "") -> int:
    """The seed of an oracle's errors in one run: the run's own (``draw`` "" or "1", so stored runs stay valid) or,
    for draw k > 1, another one."""
    key = (trajectory, grade, scenario, window_s, variant)
    return zlib.crc32(repr(key + ((int(draw),) if draw and int(draw) > 1 else ())).encode())


class TruthBeams:
    """The true beams of a mission at a ping (m/s): ``predict_beams`` at the ground-truth attitude and velocity."""

    def __init__(self, mission):
        self.gt = mission.gt

    def at(self, t: float, rows_b: np.ndarray, omega_b: np.ndarray, lever_arm_b: np.ndarray) -> np.ndarray:
        from graphnav.core.timeseries import interp_rows
        from graphnav.factors import predict_beams
        i = int(np.argmin(np.abs(self.gt.t - t)))
        return predict_beams(rows_b, self.gt.C_b_n[i], interp_rows(t, self.gt.t, self.gt.v_n), omega_b,
                             np.zeros(3), lever_arm_b)


class OracleError:
    """Per-beam errors (m/s) of one oracle: white, or Gauss-Markov with correlation time ``tau`` pings."""

    def __init__(self, sigma: float, tau: float | None, seed: int):
        self.sigma, self.rng = sigma, np.random.default_rng(seed)
        self.phi = 0.0 if tau is None else float(np.exp(-1.0 / tau))
        self.e = self.rng.normal(0.0, sigma, 4)
        self.t = None

    def at(self, t: float) -> np.ndarray:
        """The four beams' errors at ping time t (advanced once per new ping)."""
        if self.t is None or t != self.t:
            if self.t is not None:
                self.e = self.phi * self.e + np.sqrt(1 - self.phi ** 2) * self.rng.normal(0.0, self.sigma, 4)
            self.t = t
        return self.e


def oracle_task(item):
    """Window VRMSE (m/s) of one run, and for the recorded completer its completion errors. ``item``: (source,
    grade, scenario, window_s, max_windows, variant, nets, fold)."""
    source, grade, scenario, window_s, max_windows, full_variant, nets, fold = item
    # "<variant> tau <T>": a run of regressed beams is screened until one is kept (regressed_runs="screen-first"),
    # and with T > 0 the graph models their errors as Gauss-Markov with correlation time T s
    drawn, _, draw = full_variant.partition(DRAW)    # draw "" for the first, whose seed is the variant's alone
    anchored = drawn.endswith(ANCHORED)
    variant, _, tau = drawn.removesuffix(ANCHORED).partition(TAU)
    options = None
    if tau:
        options = {"regressed_runs": "screen-first", "regressed_error_tau_s": float(tau) if float(tau) > 0 else None}
    import warnings
    warnings.simplefilter("ignore")
    from hybrid_imu_folds import completer

    from graphnav.core.scenarios import is_total_outage, scenario_outage
    from graphnav.estimators.graph import builder as builder_mod
    from graphnav.estimators.graph.dvl_errors import beam_index
    from graphnav.evaluation.bench.cases import case_windows, prepared_mission
    from graphnav.evaluation.bench.scoring import score_case
    from graphnav.evaluation.methods import pivot_completer, run_method
    mission = prepared_mission(source, grade)
    starts = case_windows(mission, window_s, max_windows)
    run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
    truth = TruthBeams(mission)
    errors: list[float] = []
    stated: list[float] = []
    if variant.startswith((RECORDED, AVERAGE, PIVOT, PIVOT_ONLINE)):
        comp = None     # AVERAGE: Graph-HN's own completer (the average estimator)
        if variant.startswith(PIVOT):   # nets: the fold's pivot length, m
            comp = pivot_completer(scenario, mission.config, pivot_m=nets)
        elif variant.startswith(PIVOT_ONLINE):     # nets: its prior_turn
            comp = pivot_completer(scenario, mission.config, prior_turn=nets)
        elif variant.startswith(RECORDED) and is_total_outage(scenario) and total_outage_network(nets[0], fold):
            # the fold's IMU-aware network for pings without a measured beam (it serves every ping of a total outage
            # with an IMU window; the average estimator the others)
            comp = completer("HNI fold", scenario, nets[0], fold, None, mission.config.dvl.beam_noise_std)
        elif variant.startswith(RECORDED) and is_total_outage(scenario):
            # a total outage: no shipped network serves a ping without a measured beam, and Graph-HNI's completer
            # fills them with its beam-only fallback's average; nothing fitted runs, so it is out of fold
            from graphnav.evaluation.methods import completer_for
            comp = completer_for("Graph-HNI", scenario, mission.config.dvl.beam_noise_std)[0]
        elif variant.startswith(RECORDED):
            comp = completer("HNI fold fused", scenario, nets, fold, None, mission.config.dvl.beam_noise_std,
                             mission.config)
        if variant.startswith(RECORDED + " drift "):     # "<RECORDED> drift <d>": the history's sigma
            from graphnav.nets.imu_auto import ImuAutoCompleter     # growth per ping, m/s
            comp = ImuAutoCompleter(comp.networks.values(), comp.beam_only, comp.beam_correlation,
                                    drift_std=float(variant.split()[-1]), fused_beam_only=comp.fused_beam_only)

        def at_regressed(rows, sel, y_true, t, geometry):
            errors.extend((rows.y[sel] - y_true).tolist())
            stated.extend(rows.sigma[sel].tolist())
    else:
        comp = None
        kind, size = variant.split()
        seed = oracle_seed(source.name, grade, scenario, window_s, variant, draw)
        oracle = OracleError(float(size), SERIAL_TAU_PINGS if kind == "serial" else None, seed)

        def at_regressed(rows, sel, y_true, t, geometry):
            rows.y[sel] = y_true + oracle.at(t)[beam_index(rows.rows_b[sel], geometry.T_b)]
            rows.sigma[sel] = max(oracle.sigma, 1e-4)
    original = builder_mod.GraphContext.beam_rows

    def beam_rows(self, ping, used):
        """The ping's rows as the graph makes them, with ``at_regressed`` given its regressed beams' true values
        (rows.y and rows.sigma are the rows' own copies)."""
        rows = original(self, ping, used)
        if rows.regressed.any():
            sel = rows.regressed
            y_true = truth.at(ping.t, rows.rows_b[sel], ping.omega_b, self.geometry.lever_arm_b)
            at_regressed(rows, sel, y_true, ping.t, self.geometry)
        return rows
    twin = twin_predictions(run, scenario) if anchored else None
    builder_mod.GraphContext.beam_rows = beam_rows
    try:
        with screened_against(twin) as anchored_count:
            sol = run_method(run, "Graph-HN", scenario, completer=comp, options=options)
    finally:
        builder_mod.GraphContext.beam_rows = original
    screening = sol.info.get("regressed_screening", {})
    if anchored:
        screening = {**screening, "anchored": anchored_count[0]}
    return ((source.name, grade, window_s, full_variant),
            {"vrmse": [r["vrmse_window"] for r in score_case(sol, mission, starts, window_s)],
             "errors": errors, "stated_sigma": stated, "screening": screening})


def total_outage_network(nets_dir, fold: int) -> bool:
    """Whether the fold networks in ``nets_dir`` include an IMU-aware network for pings without a measured beam
    (``imu_completer_folds.py --missing 0-beams --save-nets``)."""
    from graphnav.nets.imu_network import imu_weights_name
    return (Path(nets_dir) / f"fold{fold}" / f"{imu_weights_name('0-beams')}.pt").exists()


def twin_predictions(run, scenario: str) -> dict:
    """The graph's predictions (:class:`graphnav.estimators.graph.regressed.VelocityPrediction`, by keyframe time s) of
    ``Graph-TC`` on the mission ``run``: the graph without completions, whose prediction through an outage is its
    last measured state carried by the IMU and the measured beams alone. Computed at every keyframe after the first
    as the hybrid computes its own (the previous keyframe's marginal velocity covariance plus the preintegrated
    noise)."""
    from graphnav.estimators.graph import incremental
    from graphnav.evaluation.methods import run_method
    predictions: dict = {}
    original = incremental._IncrementalGraph._prediction

    def record(self, kf, v_n_pred, bias):
        if kf.index > 0:
            predictions[kf.t] = self.predicted_state(kf, v_n_pred, bias)
        return original(self, kf, v_n_pred, bias)
    incremental._IncrementalGraph._prediction = record
    try:
        run_method(run, "Graph-TC", scenario)
    finally:
        incremental._IncrementalGraph._prediction = original
    return predictions


@contextmanager
def screened_against(predictions: dict | None):
    """Context in which the hybrid screens its regressed beams against ``predictions`` (keyframe time s ->
    prediction, :func:`twin_predictions`) instead of its own prediction; None: its own (nothing changes). The value
    of the ``with`` is a one-element list counting the keyframes screened against ``predictions``."""
    from graphnav.estimators.graph import incremental
    original, count = incremental.keyframe_factors, [0]

    def keyframe_factors(kf, builder, C_b_n_pred, p_n_pred=None, prediction=None):
        if prediction is not None and kf.n_regressed and kf.t in predictions:
            prediction = predictions[kf.t]
            count[0] += 1
        return original(kf, builder, C_b_n_pred, p_n_pred, prediction)
    if predictions is not None:
        incremental.keyframe_factors = keyframe_factors
    try:
        yield count
    finally:
        incremental.keyframe_factors = original


def _vrmse(runs: dict, reference: dict, name: str, g: str, w: float, method: str) -> list[float]:
    if method in ("Graph-TC", "all beams", "Graph-HN"):
        return reference[(name, g, w, method)]
    return runs[(name, g, w, method)]["vrmse"]


def ratio(runs: dict, reference: dict, folds, g: str, w: float, method: str) -> float:
    """Mean window VRMSE of ``method`` over Graph-TC's on the trajectories of ``folds`` (indices of AKIT_FOLDS)."""
    from graphnav.nets.crossval import AKIT_FOLDS
    names = [f"Trajectory{k}" for f in folds for k in AKIT_FOLDS[f]]
    return float(np.mean(np.concatenate([_vrmse(runs, reference, n, g, w, method) for n in names]))
                 / np.mean(np.concatenate([_vrmse(runs, reference, n, g, w, "Graph-TC") for n in names])))


def table(runs: dict, reference: dict, grades, windows, variants) -> str:
    """Window VRMSE over Graph-TC's (the reference file's runs of the same windows) per cell: pooled over the ten
    trajectories, and (in brackets) the worst fold (a fold's pair pooled)."""
    from graphnav.nets.crossval import AKIT_FOLDS
    folds = range(len(AKIT_FOLDS))
    lines = ["| IMU | window s | all beams | Graph-HN (average) | " + " | ".join(variants) + " |",
             "| --- | --- | --- | --- | " + " | ".join("---" for _ in variants) + " |"]
    for g in grades:
        for w in windows:
            cells = []
            for m in ("all beams", "Graph-HN", *variants):
                try:
                    worst = max(ratio(runs, reference, [f], g, w, m) for f in folds)
                    cells.append(f"{ratio(runs, reference, folds, g, w, m):.2f} ({worst:.2f})")
                except KeyError:
                    cells.append("-")
            lines.append(f"| {g} | {w:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def draws_table(runs: dict, reference: dict, grades, windows, oracles, draws: int) -> str:
    """Per oracle and cell: the range over ``draws`` draws of its errors of the pooled ratio to Graph-TC and of the
    worst fold's, and per oracle the fold cells over 1.02x in each draw (draw 1 is the variant itself)."""
    from graphnav.nets.crossval import AKIT_FOLDS
    folds = range(len(AKIT_FOLDS))
    lines = ["| oracle | IMU | window s | pooled, min-max over draws | worst fold, min-max over draws |",
             "| --- | --- | --- | --- | --- |"]
    counts = {}      # oracle -> fold cells over 1.02x in each draw
    for v in oracles:
        names = draw_names(v, draws)
        counts[v] = [0] * len(names)
        for g in grades:
            for w in windows:
                pooled = [ratio(runs, reference, folds, g, w, n) for n in names]
                per_fold = [[ratio(runs, reference, [f], g, w, n) for f in folds] for n in names]
                counts[v] = [c + sum(x > 1.02 for x in per) for c, per in zip(counts[v], per_fold)]
                worst = [max(per) for per in per_fold]
                lines.append(f"| {v} | {g} | {w:g} | {min(pooled):.2f}-{max(pooled):.2f} | "
                             f"{min(worst):.2f}-{max(worst):.2f} |")
    lines += [f"{v}: fold cells over 1.02x per draw: {', '.join(map(str, c))} "
              f"(of {len(grades) * len(windows) * len(folds)})" for v, c in counts.items()]
    return "\n".join(lines)


def fold_cell_ratios(sets: dict, keys, folds, grades, windows, variant: str) -> list[tuple]:
    """Every fold cell of ``variant`` in the scenarios ``keys`` of ``sets`` (key -> (runs, reference)), with every IMU
    grade and window, in each of ``folds``: (ratio to Graph-TC, scenario key, IMU grade, window s, fold), in that
    order of keys, grades, windows and folds."""
    return [(ratio(*sets[k], [f], g, w, variant), k, g, w, f) for k in keys for g in grades for w in windows
            for f in folds]


def fold_cells_over(sets: dict, keys, folds, grades, windows, variant: str) -> int:
    """Fold cells of ``variant`` over 1.02x Graph-TC (:func:`fold_cell_ratios`)."""
    return sum(cell[0] > 1.02 for cell in fold_cell_ratios(sets, keys, folds, grades, windows, variant))


def regime_choice(sets: dict, grades, windows, candidates: dict, what: str, recorded_over: dict | None = None) -> str:
    """The candidate (``what``: e.g. the recorded completer's sigma growth) chosen by the regime rule (fewest fold
    cells over 1.02x Graph-TC, then the smallest mean pooled ratio) on all folds, and leave-one-fold-out: each fold
    scored with the candidate chosen on the other four (``candidates``: label -> variant). ``sets``: scenario ->
    (runs, reference) of that scenario; the cells are every scenario's IMUs and windows. ``recorded_over``: label ->
    folds of further cells over 1.02x known only as counts (a draw whose runs were not kept): they add to the count
    (left out with their fold), not to the mean."""
    recorded_over = recorded_over or {}
    from graphnav.nets.crossval import AKIT_FOLDS
    folds = list(range(len(AKIT_FOLDS)))
    cells = [(sc, g, w) for sc in sets for g in grades for w in windows]

    def r(use, sc, g, w, m):
        return ratio(*sets[sc], use, g, w, m)

    def key(use, label):
        m = candidates[label]
        worse = fold_cells_over(sets, sets, use, grades, windows, m)
        worse += sum(f in use for f in recorded_over.get(label, []))
        return worse, float(np.mean([r(use, sc, g, w, m) for sc, g, w in cells]))
    scores = {c: key(folds, c) for c in candidates}
    lines = [f"{what}: fold cells over 1.02x, mean pooled ratio: " + "; ".join(
        f"{c}: {worse}, {mean:.3f}" for c, (worse, mean) in scores.items()),
        f"chosen on all folds: {min(scores, key=scores.get)}"]
    picks = {f: min(candidates, key=lambda c: key([o for o in folds if o != f], c)) for f in folds}
    lines.append("chosen without fold f: " + ", ".join(f"fold {f}: {c}" for f, c in picks.items()))
    lines += ["| scenario | IMU | window s | out of fold, pooled (worst fold) | folds 0-4 |",
              "| --- | --- | --- | --- | --- |"]
    for sc, g, w in cells:
        runs, reference = sets[sc]
        per = [r([f], sc, g, w, candidates[picks[f]]) for f in folds]
        num = sum(np.sum(_vrmse(runs, reference, f"Trajectory{k}", g, w, candidates[picks[f]]))
                  for f in folds for k in AKIT_FOLDS[f])
        den = sum(np.sum(_vrmse(runs, reference, f"Trajectory{k}", g, w, "Graph-TC"))
                  for f in folds for k in AKIT_FOLDS[f])
        lines.append(f"| {sc} | {g} | {w:g} | {num / den:.2f} ({max(per):.2f}) | " + ", ".join(f"{p:.2f}" for p in per)
                     + " |")
    return "\n".join(lines)


def screen_first_label(tau: float) -> str:
    """The regime-rule label of a run screened until one completion is kept, its errors correlated over ``tau`` s
    (0: independent errors)."""
    return "screen-first" + (f", tau {tau:g} s" if tau else "")


def run_settings(base: str, taus, prefix: str = "", anchored: bool = False) -> dict:
    """The run settings of variant ``base`` as regime-rule candidates (label -> variant): screened at each ping, or
    until one completion is kept with each correlation time in ``taus`` (0: independent errors), and with ``anchored``
    screened at each ping against the graph without completions."""
    return {prefix + SCREEN_EACH: base, **{prefix + screen_first_label(t): f"{base}{TAU}{t:g}" for t in taus},
            **({prefix + ANCHORED_LABEL: base + ANCHORED} if anchored else {})}


def choice_over_draws(draws: list, references: list, taus, grades, windows, base: str = RECORDED,
                      recorded: list = (), anchored: bool = False) -> str:
    """The regime rule's choice among ``base``'s run settings with the cells of every training draw together.
    ``draws``: per draw, its results files (one per scenario; a scenario's runs that use no fitted network, as the
    total outage's, may be the same file in every draw); ``references``: one hybrid_imu_folds.py file per scenario.
    The fold cells over 1.02x are summed over the draws. ``recorded``: ``"T@F"`` (or ``"each@F"``), one per fold
    cell over 1.02x of a further draw whose runs were not kept, known as a count: setting T s in fold F; they count
    against the setting (leave-one-fold-out, not when F is left out) and do not enter the mean. ``anchored``: the
    screening against the graph without completions (``--anchored``) is a candidate too."""
    from hybrid_imu_folds import read_results

    from graphnav.nets.crossval import AKIT_FOLDS
    refs = {}
    for path in map(Path, references):
        settings, runs = read_results(path)
        refs[settings["scenario"]] = (runs, settings["max_windows"])
    candidates = run_settings(base, taus, anchored=anchored)
    folds = range(len(AKIT_FOLDS))
    by_setting = {"each": SCREEN_EACH, **{f"{t:g}": screen_first_label(t) for t in taus},
                  **({"anchored": ANCHORED_LABEL} if anchored else {})}
    recorded_over: dict = {}
    for entry in recorded:
        setting, _, fold = entry.partition("@")
        if setting not in by_setting or not fold.isdigit() or int(fold) not in folds:
            raise SystemExit(f"--recorded-draw {entry}: give SETTING@FOLD, SETTING one of {', '.join(by_setting)} "
                             f"and FOLD 0-{len(folds) - 1}")
        recorded_over.setdefault(by_setting[setting], []).append(int(fold))
    names = [f"Trajectory{k}" for pair in AKIT_FOLDS for k in pair]
    sets = {}
    draw_scenarios: list[list[str]] = []     # per draw, its scenarios (keys of sets: "<scenario>, draw <d>")
    for d, files in enumerate(draws, 1):
        draw_scenarios.append([])
        for path in map(Path, files):
            settings, runs = read_results(path)
            scenario = settings["scenario"]
            if scenario in draw_scenarios[-1]:
                raise SystemExit(f"{path}: a second {scenario} file in draw {d}")
            if scenario not in refs:
                raise SystemExit(f"{path}: no --references file for scenario {scenario}")
            if settings["max_windows"] != refs[scenario][1]:
                raise SystemExit(f"{path} has {settings['max_windows']} windows per trajectory, its reference "
                                 f"{refs[scenario][1]}")
            missing = [(n, g, w, v) for n in names for g in grades for w in windows for v in candidates.values()
                       if (n, g, w, v) not in runs]
            if missing:
                raise SystemExit(f"{path}: {len(missing)} of the runs the choice reads are not there (the first: "
                                 f"{missing[0]}); finish the study with --tau {' '.join(f'{t:g}' for t in taus)}"
                                 + " --anchored" * anchored)
            sets[f"{scenario}, draw {d}"] = (runs, refs[scenario][0])
            draw_scenarios[-1].append(scenario)
    if any(set(sc) != set(draw_scenarios[0]) for sc in draw_scenarios):
        held = "; ".join(", ".join(sorted(sc)) for sc in draw_scenarios)
        raise SystemExit(f"the draws hold different scenarios ({held}): each draw's cells must be the same")
    # every fold cell of each setting, per draw: counted over 1.02x, and its highest ratio (max keeps the first cell
    # on a tie)
    cells = {c: [fold_cell_ratios(sets, [f"{sc}, draw {d}" for sc in scs], folds, grades, windows, v)
                 for d, scs in enumerate(draw_scenarios, 1)] for c, v in candidates.items()}
    per_draw = {c: [sum(cell[0] > 1.02 for cell in draw) for draw in by_draw] for c, by_draw in cells.items()}
    worst = {c: [max(draw, key=lambda cell: cell[0]) for draw in by_draw] for c, by_draw in cells.items()}
    extra = f" and {len(recorded)} recorded fold cells" if recorded else ""
    return (regime_choice(sets, grades, windows, candidates, f"{base} over {len(draws)} training draw"
                          f"{'s' * (len(draws) > 1)}{extra}: regressed runs", recorded_over)
            + "\nworst fold cell per draw (ratio to Graph-TC, scenario, IMU, window, fold): "
            + "; ".join(f"{c}: " + ", ".join(f"{x:.3f} ({k.partition(', draw')[0]}, {g}, {w:g} s, fold {f})"
                                             for x, k, g, w, f in cs) for c, cs in worst.items())
            + "\nfold cells over 1.02x per draw: "
            + "; ".join(f"{c}: {', '.join(map(str, n))}"
                        + (f" (recorded: folds {', '.join(map(str, recorded_over[c]))})" if c in recorded_over else "")
                        for c, n in per_draw.items()))


def recorded_table(runs: dict, grades, windows, variant: str = RECORDED) -> str:
    """RMS of the recorded completer's completions against the truth, the share that became factors (not dropped by the
    screening) and the share of those that continued a run without being screened (``regressed_runs='screen-first'``)."""
    lines = ["| IMU | window s | completions | RMS error m/s | RMS sigma handed on m/s | within 1 / 2 sigma | factors "
             "| of which continued unscreened |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for g in grades:
        for w in windows:
            sel = [r for k, r in runs.items() if k[1:] == (g, w, variant)]
            if not sel:
                continue
            e = np.concatenate([r["errors"] for r in sel])
            s = np.concatenate([r["stated_sigma"] for r in sel])
            z = np.abs(e) / s
            dropped = sum(r["screening"].get("decorrelated_out", 0) + r["screening"].get("gated", 0) for r in sel)
            continued = sum(r["screening"].get("continued", 0) for r in sel)
            lines.append(f"| {g} | {w:g} | {len(e)} | {np.sqrt(np.mean(e ** 2)):.3f} | "
                         f"{np.sqrt(np.mean(s ** 2)):.3f} | {np.mean(z < 1):.2f} / {np.mean(z < 2):.2f} | "
                         f"{1 - dropped / max(len(e), 1):.2f} | {continued / max(len(e) - dropped, 1):.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from hybrid_imu_folds import add_regime_window_arguments, load_runs, read_results, run_saving
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--scenario", default="3-missing", help="beam-outage scenario (default 3-missing)")
    add_regime_window_arguments(p)
    p.add_argument("--sigmas", nargs="+", type=float, default=list(SIGMAS), help="oracle error sizes, m/s")
    p.add_argument("--reference", help="hybrid_imu_folds.py results (JSON) of the same scenario "
                   "and windows: its Graph-TC, all beams and Graph-HN runs")
    p.add_argument("--record", help="IMU-aware fold networks: also run and record the Graph-HNI fold completer "
                   "(in a total outage: the folds' networks for pings without a measured beam, if DIR has them)")
    p.add_argument("--beam-nets", help="beam-only fold networks of the recorded completer (not used in a total "
                   "outage), or 'pivot': the pivot completer fitted online in their place (as Graph-HNP runs it), "
                   "or 'pivot-pitch': the pivot completer with its own defaults there")
    p.add_argument("--drift", nargs="*", type=float, default=[], help="the recorded completer again with these "
                   "sigma growths per ping (m/s; BeamHistory's drift_std, 0.03 by default)")
    p.add_argument("--joint", nargs="*", default=[], metavar="FILE", help="pairs of another scenario's results and "
                   "reference files (OUT REFERENCE ...): the correlation time is then chosen on the cells of every "
                   "scenario together")
    p.add_argument("--no-oracle", action="store_true", help="no oracle runs")
    p.add_argument("--average", action="store_true", help="also Graph-HN's own completer (the average estimator) "
                   "recorded against the truth")
    p.add_argument("--pivot", action="store_true", help="also the pivot completer (graphnav.nets.pivot: the average "
                   "with the hull's sideslip in turns), its pivot length fitted on the other folds, recorded likewise")
    p.add_argument("--pivot-online", type=float, metavar="PRIOR", help="also the pivot completer fitting its pivot "
                   "length online over the mission's measured pings, with this prior_turn ((rad/s)^2)")
    p.add_argument("--tau", nargs="*", type=float, default=[], help="the serial oracles, the average and the recorded "
                   "completer again with a run of regressed beams screened until one is kept (GraphOptions."
                   "regressed_runs='screen-first') and the graph modelling their errors as Gauss-Markov with these "
                   "correlation times (s; GraphOptions.regressed_error_tau_s; 0: independent errors)")
    p.add_argument("--anchored", action="store_true", help="the recorded completer (and with --average the "
                   "average) again, screened at each ping against the prediction of the graph without completions "
                   "(Graph-TC on the same run) instead of its own")
    p.add_argument("--oracle-draws", type=int, default=1, help="draws of each oracle's errors (default 1; more: "
                   "the spread of its ratios over the draws)")
    p.add_argument("--over-draws", action="append", nargs="+", metavar="FILE", help="one training draw's results "
                   "files (its scenarios' --out): with --references and --tau, run nothing and print the run setting "
                   "the regime rule chooses over every draw given (repeat per draw)")
    p.add_argument("--recorded-draw", nargs="+", default=[], metavar="SETTING@FOLD", help="with --over-draws: the "
                   "fold cells over 1.02x of a further draw whose runs were not kept, one per cell (SETTING: a --tau "
                   "value, 'each' or with --anchored 'anchored'): they count against the setting, not in the mean")
    p.add_argument("--references", nargs="+", default=[], metavar="FILE", help="with --over-draws: the reference "
                   "file (hybrid_imu_folds.py) of each scenario")
    p.add_argument("--out", help="results (JSON); a rerun with the same scenario and windows resumes "
                   "from it")
    a = p.parse_args(argv)
    if a.over_draws:
        if not (a.tau and a.references):
            p.error("--over-draws needs --tau (the settings to choose from) and --references")
        print(choice_over_draws(a.over_draws, a.references, a.tau, a.grades, a.window_s, recorded=a.recorded_draw,
                                anchored=a.anchored))
        return 0
    if a.recorded_draw:
        p.error("--recorded-draw goes with --over-draws")
    from graphnav.core.scenarios import is_total_outage
    if a.anchored and is_total_outage(a.scenario):
        p.error("--anchored with a total outage: the prediction also chooses the motion prior there "
                "(GraphOptions.motion_prior='total-if-uncertain'), which the screening's comparison would not separate")
    if not (a.reference and a.out):
        p.error("--reference and --out are required (unless --over-draws is given)")
    if a.beam_nets and not a.record:
        p.error("--beam-nets goes with --record")
    if a.record and not a.beam_nets and not is_total_outage(a.scenario):
        p.error("--record needs --beam-nets (the fused completer's beam-only member) unless the scenario is a total "
                "outage, where no beam-only network runs")
    if a.drift and not a.record:
        p.error("--drift varies the recorded completer: give --record and --beam-nets")

    from graphnav.evaluation.bench import find_trajectories
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    reference_path = Path(a.reference)
    reference_settings, reference = read_results(reference_path)
    if reference_settings["scenario"] != a.scenario or reference_settings["max_windows"] != a.max_windows:
        raise SystemExit(f"{reference_path} holds {reference_settings}, not {a.scenario} with {a.max_windows} windows")
    folders = akit_trajectories(a.data)
    sources = {s.name: s for s in find_trajectories(str(folders[0].parent))}
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    settings = {"scenario": a.scenario, "max_windows": a.max_windows, "oracle_tau_pings": SERIAL_TAU_PINGS}
    if a.record:        # the recorded completer's networks: a file resumes only with the same ones
        from imu_beam_fused_folds import PIVOT_MEMBERS
        settings["record"] = str(Path(a.record).resolve())
        if a.beam_nets:
            settings["beam_nets"] = a.beam_nets if a.beam_nets in PIVOT_MEMBERS else str(Path(a.beam_nets).resolve())
    runs, _ = load_runs(out, settings)     # a file of another scenario or windows is refused
    recorded = [RECORDED] + [f"{RECORDED} drift {d:g}" for d in a.drift] if a.record else []
    variants = ([] if a.no_oracle else oracle_variants(a.sigmas)) + [AVERAGE] * a.average + [PIVOT] * a.pivot \
        + [PIVOT_ONLINE] * (a.pivot_online is not None) + recorded
    variants += [f"{v}{TAU}{t:g}" for v in variants
                 if v in (AVERAGE, PIVOT, PIVOT_ONLINE) or v.startswith(("serial", RECORDED))
                 for t in a.tau]
    if a.anchored:
        variants += [f"{v}{ANCHORED}" for v in [AVERAGE] * a.average + recorded[:1]]
    oracles = [v for v in variants if v.startswith(("white", "serial"))]
    variants += [n for v in oracles for n in draw_names(v, a.oracle_draws)[1:]]
    from graphnav.evaluation.pivot_folds import fold_pivot_lengths
    pivots = fold_pivot_lengths(sources, AKIT_FOLDS) if a.pivot else None
    if pivots:
        print("pivot length per fold (fitted on the other folds), m: " + ", ".join(f"{x:.2f}" for x in pivots))
    items = [(sources[f"Trajectory{k}"], g, a.scenario, w, a.max_windows, v,
              (a.record, a.beam_nets) if v.startswith(RECORDED) else pivots[f] if v.startswith(PIVOT)
              else a.pivot_online if v.startswith(PIVOT_ONLINE) else None, f)
             for f, pair in enumerate(AKIT_FOLDS) for k in pair for g in a.grades for w in a.window_s for v in variants
             if (f"Trajectory{k}", g, w, v) not in runs]

    run_saving(oracle_task, items, runs, out, settings, a.jobs)
    print(f"{a.scenario}, {a.max_windows} windows per trajectory; window VRMSE over Graph-TC's, pooled")
    print(table(runs, reference, a.grades, a.window_s, [v for v in variants if DRAW not in v]))
    if a.oracle_draws > 1:
        print(f"\nthe oracles over {a.oracle_draws} draws of their errors")
        print(draws_table(runs, reference, a.grades, a.window_s, oracles, a.oracle_draws))
    for v in [v for v in variants if v.startswith((RECORDED, AVERAGE, PIVOT, PIVOT_ONLINE))]:
        print(f"\n{v}")
        print(recorded_table(runs, a.grades, a.window_s, v))
    if a.drift:
        print("\nthe recorded completer's sigma growth, chosen by the regime rule")
        print(regime_choice({a.scenario: (runs, reference)}, a.grades, a.window_s,
                            {"0.03 (history's)": RECORDED, **{f"{d:g}": f"{RECORDED} drift {d:g}" for d in a.drift}},
                            "growth per ping (m/s)"))
    sets = {a.scenario: (runs, reference)}
    if a.joint:      # one choice for the cells of every scenario
        for out_path, ref_path in zip(a.joint[::2], a.joint[1::2]):
            other, other_reference = read_results(Path(ref_path))
            sets[other["scenario"]] = (load_runs(Path(out_path), {**settings, "scenario": other["scenario"]})[0],
                                       other_reference)

    pivots_run = [PIVOT] * a.pivot + [PIVOT_ONLINE] * (a.pivot_online is not None)
    for base in [AVERAGE] * a.average + pivots_run * bool(a.tau) + recorded[:1] * bool(a.tau or a.anchored):
        print(f"\n{base}: a run of regressed beams screened at each ping or until one is kept, with the errors' "
              "correlation time in the graph (regressed_runs, regressed_error_tau_s), chosen by the regime rule")
        print(regime_choice(sets, a.grades, a.window_s, run_settings(base, a.tau, anchored=a.anchored),
                            "regressed runs"))
    if a.drift and a.tau:
        print(f"\n{RECORDED}: its sigma growth and the run screening chosen together by the regime rule")
        print(regime_choice(sets, a.grades, a.window_s,
                            {k: v for base, growth in zip(recorded, ["0.03"] + [f"{d:g}" for d in a.drift])
                             for k, v in run_settings(base, a.tau, f"growth {growth}, ").items()},
                            "growth per ping (m/s) and regressed runs"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
