"""Where the position goes in an outage and after it: the hybrids' velocity gain against their position, in the
regime windows (docs/decisions/completers.md, "A completer that models the turn", "Position through and after the
outage").

The regime table scores the window VRMSE. A navigator is judged by its position too, and two readings of it
differ in a smoother: the filtered position *during* the outage (what the vehicle navigates on), and the position
*after* the beams return, when the graph has re-estimated the outage's states with the new measurements. Per
window, against the horizontal error at its start (mean over the 5 s before it):

- ``end 10 s``: the horizontal error, RMS over the outage's last 10 s (0.5 s steps), less the start's;
- ``after 20-40 s``: the horizontal error, RMS from 20 to 40 s after the outage (0.5 s steps), less the start's;
- ``bench``: the bench's "drift" (``graphnav.evaluation.metrics.position_drift``: the error interpolated at the
  window's end, which on 1.0025 s pings falls between the last outage ping and the first measured one, whose
  filtered position the returning beams already corrected).

``--pivot-runs T ...`` adds ``Graph-HNP`` with other run settings: screened at each ping (``Graph-HNP each ping``,
``Graph-HN``'s) and, per T, a run of its completions screened until one is kept, their errors correlated over T s
whatever the ping measured (``Graph-HNP tau T``; 0 = independent errors), to see what the run setting trades between the velocity and the position after the
outage. ``--hni-runs T ...`` adds the same runs of ``Graph-HNI`` (``Graph-HNI each ping``, ``Graph-HNI tau T``).
``--rehearsed M ...`` adds ``Graph-HNP`` with rehearsed outages of margin M (``Graph-HNP rehearsed M``,
``GraphOptions.rehearsed_outages``: a completion kept only where the mission's own past says it beats the graph's
IMU-only prediction at its horizon into the outage, by the margin M), and prints how often the rehearsals chose the
graph, per IMU grade and scenario. ``--hni-rehearsed M ...`` adds the same for ``Graph-HNI`` out of fold (``Graph-HNI
rehearsed M``): its fold completer serves one missing pattern, and the rehearsals run its IMU-aware network fed its
own completions, the pattern's measured beam(s) given, both sides scored on the missing beams (no variant; in a
total outage the shipped completer, two patterns, cannot rehearse and is refused). ``--rehearsal-variants twin``,
``correlated`` or ``twin correlated`` adds each rehearsed run with the graph's twin (``rehearsal_graph="twin"``: the
IMU-carried velocity fused with the beams the pattern still measures) and/or the two rehearsed errors' covariance
deciding (``rehearsal_fusion="correlated"``; its margin unused, so only the first margin's label); ``--predictiveness``
records, per window and range of horizons of each rehearsed run, the rehearsals' ``e_comp``, ``e_graph`` read there and
the actual errors of the completions and of Graph-TC's beam prediction against the true beams, and prints how often the
rehearsals' choice was right.
``--pivot-priors P ...`` adds ``Graph-HNP`` with the pivot completer's ``prior_turn`` P instead of the shipped
:data:`graphnav.evaluation.methods.PIVOT_PRIOR_TURN` (``Graph-HNP prior P``). ``--pivot-axes A ...`` adds ``Graph-HNP``
whose pivot completer models the turn axes A (``yaw`` or ``yaw+pitch``: the heave from the pitch rate too) instead of
the shipped :data:`graphnav.evaluation.methods.PIVOT_AXES` (``Graph-HNP axes A``); ``--pivot-holds N ...`` adds
``Graph-HNP`` holding N past pings in every scenario instead of its shipped hold of the scenario
(:data:`graphnav.evaluation.methods.PIVOT_N_PAST`; ``Graph-HNP hold N``; with
``--pivot-axes``, each axes with each hold too). ``--relinearised W`` adds Graph-TC
relinearising every update the keyframes of its last W s (``Graph-TC relinearised W``): how much Graph-TC's own
readings move with an equally valid linearisation, the noise floor of a ratio to it. ``--retired`` adds each method with a completer once more with its completions taken out of the graph when
the beams return (``<method> retired``, ``GraphOptions.retire_completions``), or, for a method that does so by
default, once more with its completions kept (``<method> kept``).

The methods with a network completer (``Graph-HNI``, ``Graph-HNI-batch``, ``Graph-HN-net``, ...) run out of fold:
``--fold-nets SCENARIO IMU_DIR BEAM_DIR`` gives, per scenario with a measured beam, the IMU-aware fold networks
(``imu_completer_folds.py --save-nets``) and the beam-only fold ensembles (``graphnav eval-beams --folds
--save-nets``), and each trajectory runs the completer of the fold that held it out (``hybrid_imu_folds.py``'s ``HNI
fold fused``, the shipped pair's structure, or ``HN-net fold``). Their shipped networks were trained on these
trajectories, so a scenario with a measured beam and no fold networks is refused, and so is a fold network whose
model card does not say the trajectory was held out. In a total outage
no network serves a ping (the completer falls back to the average estimator) and the shipped completer runs.
``BEAM_DIR`` ``pivot`` puts the pivot completer in the beam-only ensembles' place (the pair of section "The IMU-aware
network fused with the pivot completer" in docs/decisions/completers.md), as ``Graph-HNP`` runs it; ``pivot-pitch``
the pivot completer with its own defaults (the pitch too, its own hold); given for a total outage too
(``--fold-nets 0-beams IMU_DIR pivot``, the folder's 3-missing networks), the pair runs there, its pivot member
serving each ping.
``--measured-sigma [K ...]`` adds ``Graph-HN`` and ``Graph-HNP`` (those of ``--methods``) with the sigma of a run of
completions judged by the beams still measured instead of the history's fixed growth (``<method> measured-sigma``:
the completer's ``run_sigma = "measured-change"``, :mod:`graphnav.estimators.history`; per K other than 1, that sigma
times K, ``<method> measured-sigma K``; docs/decisions/completers.md, "The completions judged by the beams still
measured").
``--measured-both M ...`` adds the same runs with a completion kept only where its recent error (that sigma) beats
the graph's own recent prediction error on the measured beams by the margin M (``<method> measured-both M``,
``GraphOptions.measured_both_margin``), and prints, per fold, how well each error read predicts the outage's actual
one (the graph's predicted missing beams and the completions against the true beams; docs/decisions/completers.md,
"Both errors read on the beams still measured").
``--claim-collect`` records, in Graph-TC's windows, the graph's claimed variance of each missing beam and its actual
error, and every beam's from 60 s before the outage with the measured beams' innovations (``claim_calibration.py
--run-time``); ``--claim-fit DIR`` (with ``--out`` that run's file; ``--claim-edges`` the ranges of time into the
outage) runs nothing and writes each fold's table of prediction variance scales, fitted on the other folds'
records only; ``--calibrated-claim DIR ...`` adds ``Graph-HN`` and ``Graph-HNP`` (those of ``--methods``) with the
measured-change sigma and the screening's claimed variance scaled by the table of the fold that holds the trajectory
out (``<method> measured-sigma calibrated <DIR's name>``, ``screening.prediction_var_table``; claim_calibration.py;
docs/decisions/completers.md, "The graph's claimed variance calibrated out of fold"). ``--folds F ...`` runs the
trajectories of those folds only.
``--over-draws FILE ...`` runs nothing: it makes the choice over the files of several training draws of the fold
networks, a fold cell of every draw counted.

Every A-KIT trajectory with the bench's windows (``--max-windows``, the regime table's 2), each IMU grade and
scenario; pooled and per fold (the folds of the completer studies), and each method's ratio to Graph-TC. About 2
min on two cores for the default cells. Usage::

    .venv/bin/python experiments/outage_position_drift.py --out out/position/drift.json --jobs 2
"""
from __future__ import annotations

import argparse
import contextlib
import json
import re
import sys
from pathlib import Path

import numpy as np

METRICS = ("vrmse", "end 10 s", "after 20-40 s", "bench")


def horizontal_error(sol, gt, t: np.ndarray) -> np.ndarray:
    """Estimate minus reference, north and east (len(t), 2) m, the estimate interpolated at ``t`` (s)."""
    from graphnav.core.timeseries import interp_rows
    return interp_rows(t, sol.t, sol.p_n[:, :2]) - gt.at(np.atleast_1d(t))[0][:, :2]


def position_metrics(sol, gt, start: float, window_s: float) -> dict:
    """``end 10 s`` and ``after 20-40 s`` (module docstring), m, for the outage ``[start, start + window_s]`` (s)."""
    end = start + window_s
    e0 = horizontal_error(sol, gt, np.arange(start - 5.0, start + 1e-9, 0.5)).mean(axis=0)
    last = horizontal_error(sol, gt, np.arange(end - 10.0, end + 1e-9, 0.5)) - e0
    stop = min(end + 40.0, gt.t[-1], sol.t[-1])
    after = horizontal_error(sol, gt, np.arange(min(end + 20.0, stop), stop + 1e-9, 0.5)) - e0
    return {"end 10 s": float(np.sqrt(np.mean(np.sum(last ** 2, axis=1)))),
            "after 20-40 s": float(np.sqrt(np.mean(np.sum(after ** 2, axis=1))))}


def window_metrics(sol, gt, start: float, window_s: float) -> dict:
    """The metrics of the module docstring for the outage ``[start, start + window_s]`` (s)."""
    from graphnav.evaluation.metrics import position_drift, vrmse
    return {"vrmse": float(vrmse(sol, gt, start, start + window_s)), **position_metrics(sol, gt, start, window_s),
            "bench": float(position_drift(sol, gt, start, start + window_s))}


#: Run-label suffixes of other run settings (``<method> each ping``, ``<method> tau T``: ``--pivot-runs``,
#: ``--hni-runs``; the retirement, the relinearisation, the pivot prior).
EACH_PING = " each ping"
TAU = " tau "
RETIRED = " retired"
KEPT = " kept"
RELINEARISED = " relinearised "
PRIOR = " prior "
REHEARSED = " rehearsed "
#: ``--rehearsal-variants``: the graph's twin, and the two errors' correlation deciding (after `` rehearsed M``)
TWIN = " twin"
CORRELATED = " correlated"
REHEARSAL_VARIANTS = {"twin": TWIN, "correlated": CORRELATED, "twin correlated": TWIN + CORRELATED}
#: `` prior P`` anywhere in a run label (P a number), the pivot completer's ``prior_turn``
_PRIOR_RE = re.compile(r" prior ([0-9.eE+-]+)")
AXES = " axes "
#: `` axes A`` anywhere in a run label (A: ``yaw`` or ``yaw+pitch``), the pivot completer's turn axes
_AXES_RE = re.compile(r" axes ([a-z+]+)")
HOLD = " hold "
#: `` hold N`` anywhere in a run label, the past pings the pivot completer holds
_HOLD_RE = re.compile(r" hold ([0-9]+)(?![0-9.])")
#: `` measured-sigma`` (or `` measured-sigma K``) anywhere in a run label: its completer's run sigma judged by the
#: beams still measured (times K)
MEASURED = " measured-sigma"
_MEASURED_RE = re.compile(re.escape(MEASURED) + r"(?: ([0-9.]+))?(?![0-9a-z.-])")
#: `` measured-both M`` anywhere in a run label: the measured-change sigma, and a completion kept only where it beats
#: the graph's own recent prediction error on the measured beams by the margin M (``measured_both_margin``)
_BOTH_RE = re.compile(r" measured-both ([0-9.]+)(?![0-9.])")
#: `` calibrated NAME`` anywhere in a run label: the screening's claimed variance scaled by the table of the fold that
#: holds the trajectory out, from the folder NAME of ``--calibrated-claim`` (``screening.prediction_var_table``)
CALIBRATED = " calibrated "
_CALIBRATED_RE = re.compile(CALIBRATED + r"([A-Za-z0-9_.-]+)")


def variant_run(label: str) -> tuple[str, dict | None]:
    """(registry method, graph options on top of its defaults) of a run label: a method name, ``<method> each
    ping``, ``<method> tau T`` (T = 0: independent errors; ``Graph-HNP``'s and ``Graph-HNI``'s in the studies), any
    of them followed by `` retired`` or `` kept`` (its completions taken out of the graph when the beams return or
    not, ``GraphOptions.retire_completions``), or a method followed by `` relinearised W`` (ISAM2 relinearising every
    update the keyframes of the last W s, instead of every 10th update those of the last 5 s: the estimator's own
    sensitivity to its linearisation), or a method followed by `` prior P`` (its pivot completer's ``prior_turn``,
    :func:`pivot_prior`), `` axes A`` (its turn axes, :func:`pivot_axes`) or `` hold N`` (the past pings it holds,
    :func:`pivot_hold`): no graph option; they may come before or after the other suffixes)."""
    if _CALIBRATED_RE.search(label):
        # the table is the fold's (claim_options): no option of its own
        return variant_run(_CALIBRATED_RE.sub("", label, count=1))
    both = _BOTH_RE.search(label)
    if both:
        name, options = variant_run(_BOTH_RE.sub("", label, count=1))
        return name, {**(options or {}), "measured_both_margin": float(both.group(1))}
    for pattern in (_PRIOR_RE, _AXES_RE, _HOLD_RE, _MEASURED_RE):
        if pattern.search(label):
            return variant_run(pattern.sub("", label, count=1))
    for suffix, key, value in ((CORRELATED, "rehearsal_fusion", "correlated"), (TWIN, "rehearsal_graph", "twin")):
        if REHEARSED in label and label.endswith(suffix):
            name, options = variant_run(label[:-len(suffix)])
            return name, {**options, key: value}
    for suffix, retire in ((RETIRED, True), (KEPT, False)):
        if label.endswith(suffix):
            name, options = variant_run(label[:-len(suffix)])
            return name, {**(options or {}), "retire_completions": retire}
    if RELINEARISED in label:
        name, window = label.split(RELINEARISED)
        inner, options = variant_run(name)
        return inner, {**(options or {}), "relin_window_s": float(window), "relinearize_skip": 1}
    if REHEARSED in label:
        name, margin = label.rsplit(REHEARSED, 1)
        inner, options = variant_run(name)
        return inner, {**(options or {}), "rehearsed_outages": float(margin)}
    if label.endswith(EACH_PING):
        return label[:-len(EACH_PING)], {"regressed_runs": "screen-each", "regressed_error_tau_s": None}
    if TAU in label:
        name, tau = label.rsplit(TAU, 1)
        tau = float(tau)
        return name, {"regressed_runs": "screen-first", "regressed_error_tau_s": tau if tau > 0 else None}
    return label, None


def pivot_prior(label: str) -> float | None:
    """The pivot completer's ``prior_turn`` ((rad/s)^2) of a run label with `` prior P`` (:func:`variant_run`);
    None otherwise."""
    found = _PRIOR_RE.search(label)
    return float(found.group(1)) if found else None


def pivot_axes(label: str) -> tuple[str, ...] | None:
    """The turn axes of the pivot completer of a run label with `` axes A`` (``yaw+pitch``: ``("yaw", "pitch")``),
    checked (:func:`graphnav.nets.pivot.check_axes`); None otherwise."""
    from graphnav.nets.pivot import check_axes
    found = _AXES_RE.search(label)
    return check_axes(found.group(1).split("+")) if found else None


def pivot_hold(label: str) -> int | None:
    """The past pings the pivot completer of a run label with `` hold N`` holds; None otherwise."""
    found = _HOLD_RE.search(label)
    return int(found.group(1)) if found else None


def pivot_setting(label: str) -> bool:
    """Whether a run label sets its pivot completer (`` prior P``, `` axes A``, `` hold N``)."""
    return any(f(label) is not None for f in (pivot_prior, pivot_axes, pivot_hold))


def check_pivot_member(label: str, beam_dir: str | None) -> None:
    """Refuse a beam-only folder of :data:`imu_beam_fused_folds.PIVOT_MEMBERS` for a run label whose method runs the
    beam-only networks alone (the pivot completer stands in for them only in the fused pair)."""
    from imu_beam_fused_folds import PIVOT_MEMBERS

    from graphnav.evaluation.methods import get_method
    if beam_dir in PIVOT_MEMBERS and get_method(variant_run(label)[0]).completer == "network":
        raise ValueError(f"{label}: '{beam_dir}' stands in for the beam-only networks of the fused pair only")


def check_pivot_setting(label: str) -> None:
    """Refuse a run label with `` prior P``, `` axes A`` or `` hold N`` whose method does not complete with the pivot
    completer (the setting would replace its completer)."""
    from graphnav.evaluation.methods import get_method
    name = variant_run(label)[0]
    if get_method(name).completer != "pivot":
        what = ("a prior_turn" if pivot_prior(label) is not None else "axes" if pivot_axes(label) is not None
                else "a hold")
        raise ValueError(f"{label}: {what} is a setting of the pivot completer, which {name} does not run")


def resolved_options(label: str) -> dict:
    """Every setting the run ``label`` (:func:`variant_run`) gives its estimator, as JSON reads it back: a results
    file is resumed only by runs of the same settings, so a registry default that changed since refuses it."""
    import dataclasses

    from graphnav.evaluation.methods import estimator_options
    from graphnav.io.outputs import to_jsonable
    return to_jsonable(dataclasses.asdict(estimator_options(*variant_run(label))))


def other_retirement(label: str) -> str | None:
    """The run ``label`` (:func:`variant_run`) with its completions' retirement the other way round (None without
    a completer)."""
    from graphnav.evaluation.methods import get_method
    name, options = variant_run(label)
    method = get_method(name)
    if method.completer == "none":
        return None
    return label + (KEPT if {**method.defaults, **(options or {})}.get("retire_completions") else RETIRED)


#: The registry's completer kinds that run trained networks (``Method.completer``), which run out of fold here
#: (``--fold-nets``), each as the fold's networks of the study that made them.
FOLD_NETWORK_COMPLETERS = {"imu-network": "HNI fold fused", "network": "HN-net fold"}


def needs_fold_nets(method: str, scenario: str) -> bool:
    """Whether the run ``method`` (:func:`variant_run`) in ``scenario`` must run a fold's networks: the methods whose
    completer is a trained network, wherever a beam is measured (in a total outage no network serves a ping)."""
    from graphnav.core.scenarios import is_total_outage
    from graphnav.evaluation.methods import get_method
    return get_method(variant_run(method)[0]).completer in FOLD_NETWORK_COMPLETERS and not is_total_outage(scenario)


def check_held_out(card: dict, trajectory: int, where: str) -> None:
    """Refuse a fold network (found in ``where``) whose model card does not say that A-KIT ``trajectory`` was held out
    from its training: the IMU-aware cards list ``split.train_trajectories``, the beam-only fold cards
    ``data.held_out``."""
    trained = (card.get("split") or {}).get("train_trajectories")
    held_out = (card.get("data") or {}).get("held_out")
    if trained is None and held_out is None:
        raise SystemExit(f"{where}: the card names neither its training nor its held-out trajectories, so it "
                         f"cannot be run out of fold on trajectory {trajectory}")
    if (trained is not None and trajectory in trained) or (held_out is not None and trajectory not in held_out):
        raise SystemExit(f"{where}: trained on trajectory {trajectory}, which it would score (trained on "
                         f"{trained}, held out {held_out}): give the folder of every fold's networks")


def fold_completer(method: str, scenario: str, fold_nets: dict, fold: int, mission, trajectory: int):
    """The completer of the run ``method`` on A-KIT ``trajectory``, held out by ``fold``: for
    :func:`needs_fold_nets`, the fold's networks as ``hybrid_imu_folds.py`` runs them (``fold_nets[scenario]``:
    (IMU-aware folder, beam-only folder)), after their cards confirm the trajectory was held out
    (:func:`check_held_out`): the IMU-aware network fused with the beam-only ensemble, or the beam-only ensemble
    alone for a method of the beam-only network. A beam-only folder of :data:`imu_beam_fused_folds.PIVOT_MEMBERS`
    (``pivot``, ``pivot-pitch``) puts the pivot completer in the ensemble's place, in a total outage too (its pivot
    member serves there). Otherwise None (the method's own)."""
    from hybrid_imu_folds import completer
    from imu_beam_fused_folds import PIVOT_MEMBERS

    from graphnav.evaluation.methods import get_method
    kind = get_method(variant_run(method)[0]).completer
    # the pivot pair runs in a total outage too: its pivot member serves there, as it would as shipped
    pivot_pair = kind == "imu-network" and fold_nets.get(scenario, [None, None])[1] in PIVOT_MEMBERS
    if not (needs_fold_nets(method, scenario) or pivot_pair):
        return None
    imu_dir, beam_dir = fold_nets[scenario]
    variant = FOLD_NETWORK_COMPLETERS[kind]
    fused = variant == "HNI fold fused"
    try:
        check_pivot_member(method, beam_dir)
    except ValueError as e:
        raise SystemExit(str(e)) from None
    comp = completer(variant, scenario, (imu_dir, beam_dir) if fused else beam_dir, fold, None,
                     mission.config.dvl.beam_noise_std, mission.config)
    # the cards the loaders read, of every network the completer runs (the fused pair's fallback is a second
    # load of its fused beam-only member's folder; the pivot completer in its place has nothing trained)
    beam_members = [] if beam_dir in PIVOT_MEMBERS else [(beam_dir, comp.fused_beam_only if fused else comp)]
    members = beam_members + ([(imu_dir, n) for n in comp.networks.values()] if fused else [])
    for folder, network in members:
        check_held_out(network.card, trajectory, f"{Path(folder) / f'fold{fold}'} ({scenario})")
    return comp


def study_items(sources: dict, a, fold_nets: dict, runs: dict, folds) -> list[tuple]:
    """The :func:`trajectory_task` items not yet in ``runs``: every trajectory of ``folds`` (with the index of the
    fold that holds it out, whose networks it runs), IMU grade, scenario and window length of the options ``a``."""
    calibrated = getattr(a, "calibrated_claim", None)
    flags = ((["predictiveness"] if a.predictiveness else [])
             + (["claims"] if getattr(a, "claim_collect", False) else [])
             + ([{"claim_folders": dict(calibrated)}] if calibrated else []))
    return [(sources[f"Trajectory{k}"], g, sc, w, a.max_windows, a.methods, a.backend, fold_nets, f, *flags)
            for f, pair in enumerate(folds) for k in pair for g in a.grades for sc in a.scenarios
            for w in a.window_s if (f"Trajectory{k}", g, sc, w) not in runs]


def trajectory_task(item):
    """(key, {method: [window metrics]}) of one trajectory, grade, scenario and window length. ``item``: (source,
    grade, scenario, window_s, max_windows, methods, backend, fold_nets, fold), the last two for
    :func:`fold_completer`."""
    source, grade, scenario, window_s, max_windows, methods, backend, fold_nets, fold, *flags = item
    import warnings

    from claim_calibration import PAST_S, claims_in, claims_read, innovations_in
    warnings.simplefilter("ignore")
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench.cases import case_windows, prepared_mission
    from graphnav.evaluation.methods import run_method
    mission = prepared_mission(source, grade)
    starts = case_windows(mission, window_s, max_windows)
    run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
    result, reference = {}, None
    for method in methods:
        name, options = variant_run(method)
        comp = fold_completer(method, scenario, fold_nets, fold, mission, int(source.name.removeprefix("Trajectory")))
        if pivot_setting(method):
            from graphnav.evaluation.methods import PIVOT_AXES, PIVOT_PRIOR_TURN, pivot_completer
            check_pivot_setting(method)
            prior = pivot_prior(method)
            comp = pivot_completer(scenario, mission.config,
                                   prior_turn=PIVOT_PRIOR_TURN if prior is None else prior,
                                   axes=pivot_axes(method) or PIVOT_AXES, n_past=pivot_hold(method))
        measured = _MEASURED_RE.search(method)
        if measured or _BOTH_RE.search(method):
            from graphnav.evaluation.methods import completer_for
            comp = comp or completer_for(name, scenario, mission.config.dvl.beam_noise_std, mission.config)[0]
            comp.run_sigma = "measured-change"
            comp.run_sigma_scale = float(measured.group(1) or 1.0) if measured else 1.0
        claims = (claims_read([(s - PAST_S, s + window_s) for s in starts])
                  if "claims" in flags and method == "Graph-TC" else contextlib.nullcontext())
        options = claim_options(method, options, fold, *(f for f in flags if isinstance(f, dict)))
        with rehearsals_made() as made, both_errors_read() as read, claims as claimed:
            sol = run_method(run, name, scenario, completer=comp, options=options, backend=backend)
        result[method] = [window_metrics(sol, mission.gt, s, window_s) for s in starts]
        for window, s in zip(result[method], starts) if claimed else ():
            window["claim"] = claims_in(claimed, mission, s, window_s)
            window["innovations"] = innovations_in(claimed, mission, s, window_s)
        if read:
            for window, s in zip(result[method], starts):
                window["both"] = both_errors_in(read, mission, s, window_s)
        if "measured_both" in sol.info:
            result[method][0]["measured_both"] = dict(sol.info["measured_both"])
        reference = sol if reference is None else reference
        if "predictiveness" in flags and made:
            for window, s in zip(result[method], starts):
                window["predicted"] = outage_predictiveness(made[-1].decisions, reference, mission, s, window_s)
        if "outage_rehearsal" in sol.info:
            # the decisions of the whole run: every outage ping of the run is in its windows
            result[method][0]["rehearsal"] = dict(sol.info["outage_rehearsal"])
    return (source.name, grade, scenario, window_s), result


def claim_options(method: str, options: dict | None, fold: int, flags: dict | None = None) -> dict | None:
    """``options`` of the run ``method`` with, for a label with `` calibrated NAME``, the prediction variance table
    of ``fold`` from the folder ``flags["claim_folders"][NAME]`` (claim_calibration.py; fitted without the fold)."""
    found = _CALIBRATED_RE.search(method)
    if not found:
        return options
    from claim_calibration import read_table
    table = read_table(Path(flags["claim_folders"][found.group(1)]), fold)
    return {**(options or {}), "screening.prediction_var_table": table}


@contextlib.contextmanager
def rehearsals_made():
    """The :class:`~graphnav.estimators.rehearsal.OutageRehearsal` made inside the ``with`` (a list), to read the
    decisions of a run's rehearsals."""
    from graphnav.estimators.rehearsal import OutageRehearsal
    made, init = [], OutageRehearsal.__init__

    def recording(self, *args, **kwargs):
        init(self, *args, **kwargs)
        made.append(self)
    OutageRehearsal.__init__ = recording
    try:
        yield made
    finally:
        OutageRehearsal.__init__ = init


@contextlib.contextmanager
def both_errors_read():
    """What ``GraphOptions.measured_both_margin`` read at each keyframe of an outage made inside the ``with`` (a
    list of (t s, s_graph^2, the regressed rows' sigma^2 (k,), their completions (k,), the graph's predicted beams
    there (k,), their body-frame rows (k,3), kept (k,) bool)), to score both errors against the true beams."""
    from graphnav.estimators.graph import incremental
    from graphnav.estimators.graph.regressed import predicted_beams
    made, factors = [], incremental.keyframe_factors

    def recording(kf, builder, C_b_n_pred, p_n_pred=None, prediction=None):
        out = factors(kf, builder, C_b_n_pred, p_n_pred, prediction)
        judge = builder.graph_error
        if judge is None or kf.ping is None or kf.ping.is_velocity or prediction is None:
            return out
        m = builder.beam_rows(kf.ping, kf.beams_used)
        if not m.regressed.any() or m.regressed.all():
            return out
        rows = m.rows_b[m.regressed]
        # the A-KIT lever arm is zero: no gyro-rate term
        y_p, _ = predicted_beams(rows, C_b_n_pred, np.zeros(3), builder.geometry.lever_arm_b, prediction)
        s_graph2 = judge.innovation2.less_noise(judge.beam_sigma)
        sigma2 = m.sigma[m.regressed] ** 2
        made.append((kf.t, s_graph2, sigma2, m.y[m.regressed], y_p, rows, sigma2 < judge.margin * s_graph2))
        return out
    incremental.keyframe_factors = recording
    try:
        yield made
    finally:
        incremental.keyframe_factors = factors


def both_errors_in(read, mission, start: float, window_s: float) -> dict | None:
    """For the outage ``[start, start + window_s]`` (s) of :func:`both_errors_read`'s records: the RMS (m/s) of the
    graph's recent error on the measured beams (``s graph``) and of the completions' sigma (``s comp``), the actual
    RMS errors against the true beams (GT velocity and attitude) of the graph's predicted missing beams (``act
    graph``) and of the completions (``act comp``), and the share of completions kept."""
    from oracle_completions import TruthBeams
    inside = [r for r in read if start <= r[0] <= start + window_s]
    if not inside:
        return None
    truth, lever = TruthBeams(mission), mission.config.dvl.lever_arm_b
    true = [truth.at(t, rows, np.zeros(3), lever) for t, *_, rows, _ in inside]
    rms = lambda x: float(np.sqrt(np.mean(np.square(np.concatenate([np.atleast_1d(v) for v in x])))))  # noqa: E731
    return {"n": len(inside), "s graph": float(np.sqrt(np.mean([r[1] for r in inside]))),
            "s comp": rms([np.sqrt(r[2]) for r in inside]),
            "act graph": rms([r[4] - tr for r, tr in zip(inside, true)]),
            "act comp": rms([r[3] - tr for r, tr in zip(inside, true)]),
            "kept": float(np.mean(np.concatenate([r[6] for r in inside])))}


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of a and b, nan where either does not vary."""
    return float(np.corrcoef(a, b)[0, 1]) if np.std(a) > 0 and np.std(b) > 0 else float("nan")


def both_errors_report(runs: dict, methods, folds) -> str:
    """Per ``measured-both`` run and fold (every IMU, scenario and window length; one row per outage window): the
    correlation over the windows of the graph's recent error on the measured beams with its actual error on the
    missing ones, the same for the completions' sigma, how often the smaller of the two read was the smaller actual
    one, the share of completions kept, and the RMS of each reading."""
    lines = ["| run | fold | windows | corr. s_graph / act graph | corr. s_comp / act comp | right | kept | "
             "RMS s_graph / act graph / s_comp / act comp m/s |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for method in [m for m in methods if _BOTH_RE.search(m)]:
        for f, pair in enumerate([*folds, None]):
            names = {f"Trajectory{k}" for k in (pair if pair is not None else [k for p in folds for k in p])}
            w = [x["both"] for key, r in runs.items() if key[0] in names and method in r for x in r[method]
                 if x.get("both")]
            if len(w) < 3:
                continue
            col = {k: np.array([x[k] for x in w]) for k in ("s graph", "act graph", "s comp", "act comp", "kept")}
            right = np.mean((col["s comp"] < col["s graph"]) == (col["act comp"] < col["act graph"]))
            q = lambda k: float(np.sqrt(np.mean(col[k] ** 2)))  # noqa: E731
            lines.append(f"| {method} | {'all' if pair is None else f} | {len(w)} | "
                         f"{_corr(col['s graph'], col['act graph']):.2f} | {_corr(col['s comp'], col['act comp']):.2f} | "
                         f"{right:.0%} | {np.mean(col['kept']):.0%} | {q('s graph'):.3f} / {q('act graph'):.3f} / "
                         f"{q('s comp'):.3f} / {q('act comp'):.3f} |")
    return "\n".join(lines)


#: Horizon ranges (pings into the outage) the predictiveness is read over.
HORIZON_RANGES = ((1, 30), (31, 60), (61, 120))


def outage_predictiveness(decisions, reference, mission, start: float, window_s: float) -> list[dict]:
    """Per range of :data:`HORIZON_RANGES` of the outage ``[start, start + window_s]`` (s): the rehearsals' RMS
    ``e_comp`` and ``e_graph`` as read by the decisions there (the rehearsals before the outage; against the
    measured beams, their noise in), and the actual RMS errors (m/s) against the true beams (the GT's velocity and
    attitude) of the completions and of ``reference``'s (Graph-TC's) beam prediction (its NED velocity and
    attitude; no gyro-rate term: the A-KIT lever arm is zero)."""
    from oracle_completions import TruthBeams

    from graphnav.core.dvl import DvlGeometry
    from graphnav.core.timeseries import interp_rows
    from graphnav.factors import predict_beams
    rows, lever = DvlGeometry.from_spec(mission.config.dvl).T_b, mission.config.dvl.lever_arm_b
    truth, out = TruthBeams(mission), []
    inside = [d for d in decisions if start <= d[0] <= start + window_s and np.isfinite(d[4])]
    for lo, hi in HORIZON_RANGES:
        sel = [d for d in inside if lo <= d[1] <= hi]
        if not sel:
            continue
        true = np.array([truth.at(t, rows[[b]], np.zeros(3), lever)[0] for t, _, _, b, *_ in sel])
        graph = np.array([predict_beams(rows[[b]], reference.C_b_n[np.argmin(np.abs(reference.t - t))],
                                        interp_rows(t, reference.t, reference.v_n), np.zeros(3), np.zeros(3),
                                        lever)[0] for t, _, _, b, *_ in sel])
        rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
        out.append({"h": [lo, hi], "n": len(sel), "beam sigma": float(mission.config.dvl.beam_noise_std),
                    "completer kept": sum(d[2] == "completer" for d in sel),
                    "pred comp": rms([d[4] for d in sel]), "pred graph": rms([d[5] for d in sel]),
                    "act comp": rms(np.array([d[6] for d in sel]) - true), "act graph": rms(graph - true)})
    return out


def predictiveness_report(runs: dict, methods, folds) -> str:
    """Per rehearsed run, IMU and scenario: how often the rehearsals' choice (completer or graph, per window and
    horizon range) was the actual better one, pooled and per fold, and the medians of predicted / actual."""
    lines = ["| run | IMU | scenario | ranges | right, pooled | right per fold | rehearsal: completer / actually "
             "completer | pred / actual comp (median) | pred / actual graph (median) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    fold_of = {f"Trajectory{k}": f for f, pair in enumerate(folds) for k in pair}
    for method in (m for m in methods if REHEARSED in m):
        for grade, scenario in sorted({k[1:3] for k in runs}, key=lambda c: (c[0] != "tactical", c[1])):
            rows = [(fold_of[key[0]], r) for key, result in runs.items() if key[1:3] == (grade, scenario)
                    and method in result for w in result[method] for r in w.get("predicted", [])]
            if not rows:
                continue
            said = np.array([r["pred comp"] < r["pred graph"] for _, r in rows])
            truly = np.array([r["act comp"] < r["act graph"] for _, r in rows])
            fold = np.array([f for f, _ in rows])
            per_fold = " ".join(f"{np.mean((said == truly)[fold == f]):.0%}" if np.any(fold == f) else "-"
                                for f in range(len(folds)))
            # the rehearsals score against the measured beams: their noise taken out too (in brackets)
            ratio = {w: np.median([r[f"pred {w}"] / r[f"act {w}"] for _, r in rows]) for w in ("comp", "graph")}
            clean = {w: np.median([np.sqrt(max(r[f"pred {w}"] ** 2 - r["beam sigma"] ** 2, 0.0)) / r[f"act {w}"]
                                   for _, r in rows]) for w in ("comp", "graph")}
            lines.append(f"| {method} | {grade} | {scenario} | {len(rows)} | {np.mean(said == truly):.0%} | "
                         f"{per_fold} | {np.mean(said):.0%} / {np.mean(truly):.0%} | {ratio['comp']:.2f} "
                         f"({clean['comp']:.2f}) | {ratio['graph']:.2f} ({clean['graph']:.2f}) |")
    return "\n".join(lines)


def rehearsal_report(runs: dict, methods) -> str:
    """Per rehearsed run, IMU grade and scenario: the regressed beams the rehearsals left to the graph, kept, and
    left to the screening (no rehearsal yet), summed over the trajectories and window lengths."""
    lines = ["| run | IMU | scenario | graph better | completer kept | unrehearsed |",
             "| --- | --- | --- | --- | --- | --- |"]
    for method in (m for m in methods if REHEARSED in m):
        for grade, scenario in sorted({k[1:3] for k in runs}, key=lambda c: (c[0] != "tactical", c[1])):
            total = {"graph": 0, "completer": 0, "unrehearsed": 0}
            for key, result in runs.items():
                if key[1:3] == (grade, scenario) and method in result:
                    for what, n in result[method][0].get("rehearsal", {}).items():
                        total[what] += n
            n = max(sum(total.values()), 1)
            lines.append(f"| {method} | {grade} | {scenario} | " + " | ".join(
                f"{total[w]} ({total[w] / n:.0%})" for w in ("graph", "completer", "unrehearsed")) + " |")
    return "\n".join(lines)


def cells_of(runs: dict) -> list[tuple]:
    """The (IMU, scenario, window s) cells of ``runs``, tactical first."""
    return sorted({k[1:] for k in runs}, key=lambda c: (c[0] != "tactical", c[1], c[2]))


def mean_metric(runs: dict, trajectories, cell, method: str, metric: str) -> float:
    """``metric`` of ``method`` averaged over the windows of ``trajectories`` (A-KIT numbers) in ``cell``."""
    vals = [w[metric] for k in trajectories if (f"Trajectory{k}", *cell) in runs
            for w in runs[(f"Trajectory{k}", *cell)][method]]
    return float(np.mean(vals)) if vals else float("nan")


def tc_ratio(runs: dict, pairs, cell, method: str, metric: str, reference: str = "Graph-TC") -> float:
    """``method``'s mean ``metric`` over the trajectories of the folds ``pairs``, divided by ``reference``'s."""
    trajectories = [k for pair in pairs for k in pair]
    return mean_metric(runs, trajectories, cell, method, metric) / mean_metric(runs, trajectories, cell, reference,
                                                                               metric)


def against_reference(runs: dict, methods, reference: str, folds) -> str:
    """Per run of ``methods``: its fold cells over 1.02x ``reference`` and the range of its fold-cell and pooled
    ratios to it, per reading (:data:`CHOICE_METRICS` and ``end 10 s``): a batch against Graph-TC-batch, smoothing's
    own gain left out."""
    cells = cells_of(runs)
    lines = [f"| run | reading | fold cells over 1.02x {reference} | fold-cell ratios | pooled ratios |",
             "| --- | --- | --- | --- | --- |"]
    for method in methods:
        for metric in ("vrmse", "end 10 s", "after 20-40 s"):
            per_fold = [tc_ratio(runs, [pair], cell, method, metric, reference) for pair in folds for cell in cells]
            pooled = [tc_ratio(runs, folds, cell, method, metric, reference) for cell in cells]
            lines.append(f"| {method} | {metric} | {sum(r > 1.02 for r in per_fold)} of {len(per_fold)} | "
                         f"{min(per_fold):.3f}-{max(per_fold):.3f} | {min(pooled):.3f}-{max(pooled):.3f} |")
    return "\n".join(lines)


def report(runs: dict, methods, folds) -> str:
    """Per cell: each metric's mean over the windows, pooled, and each method's ratio to Graph-TC (worst fold)."""
    lines = ["| IMU | scenario | window s | method | " + " | ".join(f"{m} (m/s or m)" if m == "vrmse" else m
                                                                   for m in METRICS) + " |",
             "| --- | --- | --- | --- | " + " | ".join("---" for _ in METRICS) + " |"]
    everyone = [k for pair in folds for k in pair]
    for cell in cells_of(runs):
        for method in methods:
            parts = []
            for metric in METRICS:
                if method == "Graph-TC":
                    value = mean_metric(runs, everyone, cell, method, metric)
                    parts.append(f"{value:.3f}" if metric == "vrmse" else f"{value:.2f}")
                    continue
                worst = max(tc_ratio(runs, [pair], cell, method, metric) for pair in folds)
                parts.append(f"{tc_ratio(runs, folds, cell, method, metric):.2f}x ({worst:.2f}x)")
            lines.append(f"| {cell[0]} | {cell[1]} | {cell[2]:g} | {method} | " + " | ".join(parts) + " |")
    return "\n".join(lines)


#: The readings the choice scores: the velocity through the outage and the position after it.
CHOICE_METRICS = ("vrmse", "after 20-40 s")


def reading_scores(runs: dict, folds, method: str) -> tuple[list[int], list[float]]:
    """Per reading of :data:`CHOICE_METRICS`, on the folds ``folds``: ``method``'s fold cells over 1.02x Graph-TC,
    and its pooled ratio to Graph-TC averaged over the cells."""
    cells = cells_of(runs)
    over = [sum(tc_ratio(runs, [pair], cell, method, m) > 1.02 for pair in folds for cell in cells)
            for m in CHOICE_METRICS]
    means = [float(np.mean([tc_ratio(runs, folds, cell, method, m) for cell in cells])) for m in CHOICE_METRICS]
    return over, means


def rule_key(runs: dict, folds, method: str) -> tuple[int, float]:
    """The regime rule with both readings of :data:`CHOICE_METRICS` (:func:`reading_scores`): (fold cells over
    1.02x Graph-TC, counted per reading, the mean pooled ratio over the cells and readings)."""
    over, means = reading_scores(runs, folds, method)
    return sum(over), float(np.mean(means))


def choice(runs: dict, candidates: list[str], folds) -> str:
    """The candidate run (of one registry method) the rule (:func:`rule_key`) picks on all folds and with each fold
    left out, and each left-out fold's worst cell with the pick made without it. A tie goes to the first candidate
    (the method's default run); a fold cell without runs stops the choice (it would count as within 1.02x)."""
    cells = cells_of(runs)
    missing = [(c, cell, f) for c in candidates for cell in cells for f, pair in enumerate(folds)
               for m in CHOICE_METRICS if not np.isfinite(tc_ratio(runs, [pair], cell, c, m))]
    if missing:
        return f"not chosen: {len(missing)} fold cells have no runs, e.g. {missing[0]}"
    lines = ["| candidate | fold cells over 1.02x: velocity / position after | mean pooled ratio: velocity / "
             "position after |", "| --- | --- | --- |"]
    for c in candidates:
        over, means = reading_scores(runs, folds, c)
        lines.append(f"| {c} | {over[0]} / {over[1]} of {len(cells) * len(folds)} | {means[0]:.3f} / {means[1]:.3f} |")
    lines.append(f"chosen on all folds: {min(candidates, key=lambda c: rule_key(runs, folds, c))}")
    for f, pair in enumerate(folds):
        pick = min(candidates, key=lambda c: rule_key(runs, [p for p in folds if p != pair], c))
        worst = [max(tc_ratio(runs, [pair], cell, pick, m) for cell in cells) for m in CHOICE_METRICS]
        lines.append(f"fold {f} left out: {pick}; its worst cell {worst[0]:.3f}x in velocity, {worst[1]:.3f}x in "
                     "the position after")
    return "\n".join(lines)


def runs_over_draws(paths) -> tuple[dict, list[str]]:
    """(runs, methods) of several results files, each a training draw of the networks the runs use, as one set of
    cells: a later file's cells are told apart by ``@<its place>`` after the scenario, so that the rule
    (:func:`choice`) counts a fold cell of every draw. Every file must hold the first one's runs with the same
    settings (the estimators' options included), and no two the same fold networks."""
    from hybrid_imu_folds import read_results
    runs, first, networks = {}, None, []
    for i, path in enumerate(paths):
        settings, draw = read_results(Path(path))
        same = {k: v for k, v in settings.items() if k != "fold_nets"}
        if first is None:
            first = same
        elif same != first:
            differ = sorted(k for k in {*same, *first} if same.get(k) != first.get(k))
            raise SystemExit(f"{path} holds other runs or settings than {paths[0]} ({', '.join(differ)}): the draws "
                             "must run the same ones")
        if settings.get("fold_nets") is not None and settings["fold_nets"] in networks:
            raise SystemExit(f"{path} ran the same fold networks as an earlier file: not another draw")
        networks.append(settings.get("fold_nets"))
        runs.update({(k[0], k[1], k[2] + (f"@{i}" if i else ""), k[3]): v for k, v in draw.items()})
    return runs, first["methods"]


def print_choices(runs: dict, methods: list[str], folds) -> None:
    """For each registry method with several runs in ``methods``: the run the rule picks (:func:`choice`)."""
    families: dict[str, list[str]] = {}
    for m in methods[1:]:
        families.setdefault(variant_run(m)[0], []).append(m)
    for name, candidates in families.items():
        if len(candidates) > 1:
            print(f"\n{name}: the run chosen on the velocity and the position after the outage")
            print(choice(runs, candidates, folds))


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from hybrid_imu_folds import load_runs, run_saving
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    from graphnav.evaluation.methods import GRAPH_HN, GRAPH_HNI, GRAPH_HNP, GRAPH_TC, GRAPH_TC_BATCH, get_method
    p.add_argument("--methods", nargs="+", default=[GRAPH_TC, GRAPH_HN, GRAPH_HNP], help="graph methods (Graph-TC "
                   "first: the ratios are to it; default: Graph-TC, Graph-HN, Graph-HNP)")
    p.add_argument("--pivot-runs", nargs="*", type=float, metavar="T", help="also Graph-HNP screened at each ping "
                   "and, per T, with its completions' errors correlated over T s (module docstring)")
    p.add_argument("--rehearsed", nargs="+", type=float, metavar="M", help="also Graph-HNP with rehearsed outages of "
                   "margin M (module docstring)")
    p.add_argument("--hni-rehearsed", nargs="+", type=float, metavar="M", help="also Graph-HNI with rehearsed "
                   "outages of margin M, its fold networks' recursion rehearsed (module docstring)")
    p.add_argument("--rehearsal-variants", nargs="+", choices=tuple(REHEARSAL_VARIANTS), default=[], metavar="V",
                   help="also each --rehearsed run with the graph's twin (twin), its errors' correlation deciding "
                   "(correlated: the margin unused, the first margin's label only) or both (module docstring)")
    p.add_argument("--predictiveness", action="store_true", help="record, per window of each rehearsed run, the "
                   "rehearsals' predicted errors and the actual ones against the true beams (module docstring)")
    p.add_argument("--pivot-priors", nargs="+", type=float, metavar="P", help="also Graph-HNP with its pivot "
                   "completer's prior_turn P instead of the shipped one (module docstring)")
    p.add_argument("--pivot-axes", nargs="+", choices=("yaw", "yaw+pitch"), metavar="A", help="also Graph-HNP with "
                   "its pivot completer modelling the turn axes A: yaw, yaw+pitch (module docstring)")
    p.add_argument("--pivot-holds", nargs="+", type=int, metavar="N", help="also Graph-HNP with its pivot completer "
                   "holding N past pings in every scenario run, instead of its shipped hold of each (module "
                   "docstring)")
    p.add_argument("--measured-sigma", nargs="*", type=float, metavar="K", help="also Graph-HN and Graph-HNP (those "
                   "of --methods) with their runs' sigma judged by the beams still measured, times each K (default: "
                   "1; module docstring)")
    p.add_argument("--measured-both", nargs="+", type=float, metavar="M", help="also Graph-HN and Graph-HNP (those "
                   "of --methods) with the measured-change sigma, a completion kept only where its recent error beats "
                   "the graph's own on the measured beams by the margin M (<method> measured-both M, "
                   "GraphOptions.measured_both_margin); prints how well each error read predicts the outage's")
    p.add_argument("--claim-collect", action="store_true", help="record, in Graph-TC's windows, its claimed variance "
                   "of each missing beam and its actual error, and every beam's from 60 s before the outage with the "
                   "measured beams' innovations (claim_calibration.py)")
    p.add_argument("--claim-fit", metavar="DIR", help="run nothing: fit each fold's table of prediction variance "
                   "scales on the other folds' records of --out (a --claim-collect run) and write DIR/fold<k>.json")
    p.add_argument("--claim-edges", nargs="+", type=float, metavar="S", help="the starts (s, from 0) of the ranges of "
                   "time into the outage --claim-fit fits a scale to (default: claim_calibration.TIME_EDGES_S; "
                   "0 alone: one scale per number of measured beams)")
    p.add_argument("--calibrated-claim", nargs="+", metavar="DIR", help="also Graph-HN and Graph-HNP (those of "
                   "--methods) with the measured-change sigma and the screening's claimed variance scaled by each "
                   "trajectory's fold's table in DIR (--claim-fit; <method> measured-sigma calibrated <DIR's name>)")
    p.add_argument("--folds", nargs="+", type=int, metavar="F", help="run the trajectories of these folds only "
                   "(default: all)")
    p.add_argument("--hni-runs", nargs="*", type=float, metavar="T", help="the same for Graph-HNI (module "
                   "docstring)")
    p.add_argument("--relinearised", type=float, metavar="W", help="also Graph-TC relinearising every update the "
                   "keyframes of its last W s (module docstring)")
    p.add_argument("--retired", action="store_true", help="also each method with a completer with its completions "
                   "taken out when the beams return, or kept if it takes them out (module docstring)")
    p.add_argument("--scenarios", nargs="+", default=["3-missing", "0-beams"], help="beam-outage scenarios")
    p.add_argument("--grades", nargs="+", default=["tactical", "mems"], help="IMU grades")
    p.add_argument("--window-s", nargs="+", type=float, default=[120.0], help="outage lengths, s")
    p.add_argument("--max-windows", type=int, default=2, help="windows per trajectory (as the regime table)")
    p.add_argument("--backend", default="isam2", choices=("isam2", "fixed-lag"), help="the graph's smoother (default: "
                   "isam2, as the regime table; fixed-lag is graphnav online's default)")
    p.add_argument("--fold-nets", nargs=3, action="append", default=[], metavar=("SCENARIO", "IMU_DIR", "BEAM_DIR"),
                   help="the fold networks of the methods with a network completer (Graph-HNI, Graph-HN-net, ...) "
                        "for a scenario (repeat per scenario): the IMU-aware ones (imu_completer_folds.py "
                        "--save-nets) and the beam-only ensembles (graphnav eval-beams --folds --save-nets), or "
                        "'pivot' for the pivot completer in their place as Graph-HNP runs it, or 'pivot-pitch' with "
                        "its own defaults (a total outage too); each trajectory runs its own fold's (module "
                        "docstring)")
    p.add_argument("--over-draws", nargs="+", metavar="FILE", help="run nothing: the choice over the results files "
                   "of several training draws of the fold networks, their fold cells counted together")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (graphnav.evaluation.tasks)")
    p.add_argument("--out", default="out/position/drift.json", help="results (JSON); a rerun with the same "
                   "settings resumes from it")
    a = p.parse_args(argv)
    from graphnav.nets.crossval import AKIT_FOLDS
    if a.over_draws:
        runs, methods = runs_over_draws(a.over_draws)
        print(f"{len(a.over_draws)} training draws, their fold cells counted together")
        print_choices(runs, methods, AKIT_FOLDS)
        return 0
    if a.claim_fit:
        from claim_calibration import main as fit_claims
        return fit_claims([a.out, a.claim_fit, *(["--edges", *map(str, a.claim_edges)] if a.claim_edges else [])])
    if a.methods[0] != GRAPH_TC:
        p.error("--methods must start with Graph-TC (the ratios are to it)")
    for flag, method, times in (("--pivot-runs", GRAPH_HNP, a.pivot_runs), ("--hni-runs", GRAPH_HNI, a.hni_runs)):
        if times is not None:
            if not all(t >= 0 for t in times):
                p.error(f"{flag}: correlation times must be >= 0 s (0: independent errors)")
            a.methods += [f"{method} each ping", *(f"{method} tau {t:g}" for t in times)]
    if a.rehearsed:
        if not all(m > 0 for m in a.rehearsed):
            p.error("--rehearsed: the margin must be > 0")
        a.methods += [f"{GRAPH_HNP}{REHEARSED}{m:g}" for m in a.rehearsed]
        a.methods += [f"{GRAPH_HNP}{REHEARSED}{m:g}{REHEARSAL_VARIANTS[v]}" for v in a.rehearsal_variants
                      for m in (a.rehearsed[:1] if CORRELATED in REHEARSAL_VARIANTS[v] else a.rehearsed)]
    elif a.rehearsal_variants or a.predictiveness:
        p.error("--rehearsal-variants and --predictiveness need --rehearsed")
    if a.hni_rehearsed:
        if not all(m > 0 for m in a.hni_rehearsed):
            p.error("--hni-rehearsed: the margin must be > 0")
        a.methods += [f"{GRAPH_HNI}{REHEARSED}{m:g}" for m in a.hni_rehearsed]
    if a.pivot_priors:
        if not all(prior >= 0 for prior in a.pivot_priors):
            p.error("--pivot-priors: prior_turn must be >= 0 (rad/s)^2")
        a.methods += [f"{GRAPH_HNP}{PRIOR}{prior:g}" for prior in a.pivot_priors]
    for axes in a.pivot_axes or []:
        a.methods.append(f"{GRAPH_HNP}{AXES}{axes}")
    if a.pivot_holds:
        if not all(n >= 1 for n in a.pivot_holds):
            p.error("--pivot-holds: the pivot completer holds at least 1 past ping")
        a.methods += [f"{base}{HOLD}{n}" for base in [GRAPH_HNP, *(f"{GRAPH_HNP}{AXES}{x}" for x in a.pivot_axes or [])]
                      for n in a.pivot_holds]
    if a.measured_sigma is not None:
        if not all(k > 0 for k in a.measured_sigma):
            p.error("--measured-sigma: the factor K must be > 0")
        a.methods += [f"{m}{MEASURED}" + (f" {k:g}" if k != 1 else "") for k in a.measured_sigma or [1.0]
                      for m in a.methods if m in (GRAPH_HN, GRAPH_HNP)]
    if a.measured_both:
        if not all(k > 0 for k in a.measured_both):
            p.error("--measured-both: the margin M must be > 0")
        a.methods += [f"{m} measured-both {k:g}" for k in a.measured_both for m in a.methods
                      if m in (GRAPH_HN, GRAPH_HNP)]
    if a.calibrated_claim:
        a.calibrated_claim = [(Path(d).name, str(Path(d))) for d in a.calibrated_claim]
        a.methods += [f"{m}{MEASURED}{CALIBRATED}{name}" for name, _ in a.calibrated_claim for m in a.methods
                      if m in (GRAPH_HN, GRAPH_HNP)]
    if a.relinearised is not None:
        a.methods.append(f"{GRAPH_TC}{RELINEARISED}{a.relinearised:g}")
    if a.retired:
        a.methods += [o for o in map(other_retirement, a.methods) if o is not None]
    from imu_beam_fused_folds import PIVOT_MEMBERS, PIVOT_PITCH_MEMBER
    fold_nets = {scenario: [str(Path(imu)), beam if beam in PIVOT_MEMBERS else str(Path(beam))]
                 for scenario, imu, beam in a.fold_nets}
    unserved = sorted({(m, sc) for m in a.methods for sc in a.scenarios
                       if needs_fold_nets(m, sc) and sc not in fold_nets})
    if unserved:
        p.error(f"{unserved[0][0]} with {unserved[0][1]} runs its networks out of fold: give --fold-nets "
                f"{unserved[0][1]} IMU_DIR BEAM_DIR (its shipped networks were trained on these trajectories)")
    kinds = {m: get_method(variant_run(m)[0]).completer for m in a.methods}
    for m in a.methods:
        if (_MEASURED_RE.search(m) or _BOTH_RE.search(m)) and kinds[m] not in ("average", "pivot"):
            p.error(f"{m}: the measured-change sigma needs the average estimator or the pivot completer, which "
                    f"{variant_run(m)[0]} does not run")
    for m in a.methods:
        try:
            if pivot_setting(m):
                check_pivot_setting(m)
            for sc in a.scenarios:
                check_pivot_member(m, fold_nets.get(sc, [None, None])[1])
        except ValueError as e:
            p.error(str(e))
    from claim_calibration import read_table

    from graphnav.evaluation.bench import find_trajectories
    from graphnav.io.paths import akit_trajectories
    folders = akit_trajectories(a.data)
    sources = {s.name: s for s in find_trajectories(str(folders[0].parent))}
    settings = {"max_windows": a.max_windows, "methods": a.methods, "metrics": list(METRICS), "backend": a.backend,
                **({"predictiveness": True} if a.predictiveness else {}),
                **({"claim_collect": True} if a.claim_collect else {}),
                # as JSON reads them back: a results file resumes only under the same tables
                **({"claim_tables": json.loads(json.dumps(
                    {name: [read_table(Path(d), f) for f in range(len(AKIT_FOLDS))]
                     for name, d in a.calibrated_claim}))} if a.calibrated_claim else {}),
                "estimator_options": {m: resolved_options(m) for m in a.methods},
                **({"fold_nets": fold_nets} if fold_nets else {})}
    if "pivot" in kinds.values() or set(PIVOT_MEMBERS) & {beam for _, beam in fold_nets.values()}:
        # the shipped prior of the runs that do not name theirs: a results file resumes only under the same one
        from graphnav.evaluation.methods import PIVOT_AXES, PIVOT_N_PAST, PIVOT_PRIOR_TURN
        settings["pivot_prior_turn"] = PIVOT_PRIOR_TURN
        settings["pivot_axes"] = list(PIVOT_AXES)
        settings["pivot_n_past"] = dict(PIVOT_N_PAST)
    if PIVOT_PITCH_MEMBER in {beam for _, beam in fold_nets.values()}:
        # the pivot completer's own defaults, which that member runs
        from graphnav.nets.pivot import DEFAULT_AXES, DEFAULT_N_PAST
        settings["pivot_pitch_member"] = {"axes": list(DEFAULT_AXES), "n_past": dict(DEFAULT_N_PAST)}
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    runs, _ = load_runs(out, settings)
    items = [i for i in study_items(sources, a, fold_nets, runs, AKIT_FOLDS) if a.folds is None or i[8] in a.folds]
    run_saving(trajectory_task, items, runs, out, settings, a.jobs)
    print(f"{a.max_windows} windows per trajectory; horizontal position error less the window start's, m; Graph-TC "
          "in its units, the others as ratios to it, pooled (worst fold)")
    # a study of some folds reports on those (its worst fold among them) and makes no choice, which needs every fold
    print(report(runs, a.methods, AKIT_FOLDS if a.folds is None else [AKIT_FOLDS[f] for f in a.folds]))
    batches = [m for m in a.methods if m != GRAPH_TC_BATCH and get_method(variant_run(m)[0]).batch]
    if GRAPH_TC_BATCH in a.methods and batches:
        print(f"\nThe batch runs against {GRAPH_TC_BATCH} (per fold cell and pooled)")
        print(against_reference(runs, batches, GRAPH_TC_BATCH, AKIT_FOLDS))
    if a.rehearsed or a.hni_rehearsed:
        print("\nRegressed beams the rehearsals decided (summed over trajectories and windows)")
        print(rehearsal_report(runs, a.methods))
    if a.predictiveness:
        print("\nThe rehearsals' choice against the outage (per window and horizon range: right when the one "
              "with the smaller rehearsed error had the smaller actual one)")
        print(predictiveness_report(runs, a.methods, AKIT_FOLDS))
    if a.measured_both:
        print("\nBoth errors read on the measured beams against the outage's actual ones (per outage window)")
        print(both_errors_report(runs, a.methods, AKIT_FOLDS))
    if a.folds is None:
        print_choices(runs, a.methods, AKIT_FOLDS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
