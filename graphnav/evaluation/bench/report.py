"""The bench report: records aggregated per IMU grade x scenario x method (:func:`aggregate`), the regime summary,
the NEES section and ``report.md`` (:func:`make_report`)."""
from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np

from graphnav.core.config import imu_grade as imu_grade_spec
from graphnav.evaluation.bench.cases import IMU_GRADE_CHOICES, SCENARIO_NAMES
from graphnav.evaluation.bench.scoring import DIVERGED_VRMSE_MPS
from graphnav.evaluation.consistency import NEES_SETTLE_S
from graphnav.evaluation.methods import (
    GRAPH_HN,
    GRAPH_HN_BATCH,
    GRAPH_HNI,
    GRAPH_HNI_BATCH,
    GRAPH_MP,
    GRAPH_TC,
    GRAPH_TC_BATCH,
    HNTC,
    HNTC_IMU,
    METHODS,
    TC,
)


#: Methods of the regime summary (report section "Regimes"), the hybrid first, its reference second.
REGIME_METHODS: tuple[str, ...] = (GRAPH_TC, GRAPH_HN, GRAPH_HN_BATCH, GRAPH_TC_BATCH, GRAPH_MP, TC,
                                    HNTC, GRAPH_HNI, GRAPH_HNI_BATCH, HNTC_IMU)


def nees_section(records: list[dict], grades, scenarios, methods) -> list[str]:
    """Report lines: velocity NEES per method over the mission and in the windows, with the 95 % chi-square
    band, the share of trajectories inside it, and how much of the NEES the GT's own error explains."""
    from graphnav.evaluation.consistency import chi2_band
    lines = ["## Consistency (NEES)", "",
             "Mean velocity NEES (3 dof; 3 = consistent) over each mission after "
             f"{NEES_SETTLE_S:g} s (`mission`, mean and range over trajectories) and over the windows (`windows`). "
             "Band: 95 % chi-square band of a mission mean, counting one independent epoch per decorrelation "
             "time of the normalised velocity error (at least 10 s); the band shown is at the median count over "
             "trajectories, `inside` counts each trajectory against its own (errors are correlated in time; "
             "`graphnav.evaluation.consistency`). `+GT`: NEES with the ground truth's own velocity error added to "
             "the estimator's covariance (A-KIT: its white error identified by "
             "`experiments/identify_noise.py`, an upper bound; the GT's slow error is not in it); `GT share`: "
             "the part of the NEES that the GT's error explains, `1 - NEES(+GT) / NEES`. "
             "The reference at an estimate's epoch is the nearest GT sample carried to it by the IMU (a 1 Hz GT "
             "linearly interpolated misses the motion within the second: 0.1 m/s in waves at the surface); "
             "`interp. GT`: the mission NEES against the linearly interpolated GT, as scored before. One "
             "trajectory with a bad stretch dominates a mean; the median over trajectories does not. A run that "
             "lost track (an epoch without a finite estimate: no NEES from part of the run) is left out of the "
             "NEES tables; in a window it counts as diverged.", ""]
    for grade in grades:
        for sc in scenarios:
            rows = []
            for m in methods:
                # finite only, as the pose table: a lost run's NaN in memory is the None of a reloaded results.json
                rs = [r for r in records if (r["imu_grade"], r["scenario"], r["method"]) == (grade, sc, m)
                      and not r.get("error") and r.get("nees_mission") is not None
                      and math.isfinite(r["nees_mission"])]
                if not rs:
                    continue
                per_traj = {r["trajectory"]: r for r in rs}.values()     # one mission value per trajectory
                nees = [r["nees_mission"] for r in per_traj]
                n_each = [r["nees_n_independent"] for r in per_traj]
                lo, hi = chi2_band(int(np.median(n_each)))
                inside = sum(chi2_band(n)[0] <= x <= chi2_band(n)[1] for x, n in zip(nees, n_each))
                gt = [r["nees_mission_gt"] for r in per_traj if r.get("nees_mission_gt") is not None]
                gt_mean = _mean(gt) if gt else float("nan")
                share = 1.0 - gt_mean / _mean(nees) if gt else float("nan")
                interp = [r["nees_mission_interp"] for r in per_traj if r.get("nees_mission_interp") is not None]
                rows.append(f"| {m} | {_f(_mean(nees), 1)} ({_f(min(nees), 1)}-{_f(max(nees), 1)}) | "
                            f"{_f(float(np.median(nees)), 1)} | "
                            f"{_f(_mean(r.get('nees_window') for r in rs), 1)} | {lo:.2f}-{hi:.2f} | "
                            f"{inside}/{len(nees)} | {_f(gt_mean, 1)} | "
                            f"{'-' if not math.isfinite(share) else f'{share * 100:.0f}%'} | "
                            f"{_f(_mean(interp), 1) if interp else '-'} |")
            if rows:
                lines += [f"### NEES: {grade}, {sc}", "",
                          "| method | mission NEES (range) | median | windows NEES | 95 % band | inside | +GT "
                          "| GT share | interp. GT |",
                          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |", *rows, ""]
            pose = pose_nees_rows(records, grade, sc, methods)
            if pose:
                lines += [f"### Position and heading NEES: {grade}, {sc}", "",
                          "| method | position NEES (range) | windows | 95 % band | inside | heading NEES (range) "
                          "| windows | 95 % band | inside |",
                          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |", *pose, ""]
    lines[4:4] = ["Position and heading: horizontal position NEES (2 dof; 2 = consistent; north-east, the depth "
                  "being measured directly) and heading NEES (1 dof; 1 = consistent; yaw error wrapped across "
                  "+-180 deg) over each mission after the same settling time, against the GT's position and the "
                  "reference attitude. Their errors are integrals and stay correlated for long: independent epochs "
                  "are counted one per decorrelation time of the normalised error (at least 10 s), so the band "
                  "is wide; `inside` counts trajectories inside their own band. `-`: the estimator reports no "
                  "such covariance.", ""]
    return lines


def _pose_cells(rs: list[dict], key: str, dof: int) -> list[str]:
    """Mission NEES mean (range), window mean, 95 % band at the median independent epochs, trajectories inside
    their own band; "-" cells without values."""
    from graphnav.evaluation.consistency import chi2_band
    # finite only: a lost estimate's NaN in memory is the None of a reloaded results.json
    per_traj = [r for r in {r["trajectory"]: r for r in rs}.values()
                if r.get(f"{key}_mission") is not None and math.isfinite(r[f"{key}_mission"])]
    if not per_traj:
        return ["-"] * 4
    nees = [r[f"{key}_mission"] for r in per_traj]
    n_ind = [r[f"{key}_n_independent"] for r in per_traj]
    lo, hi = chi2_band(int(np.median(n_ind)), dof)
    inside = sum(chi2_band(n, dof)[0] <= x <= chi2_band(n, dof)[1] for x, n in zip(nees, n_ind))
    window = _mean(r.get(f"{key}_window") for r in rs)
    return [f"{_f(_mean(nees), 2)} ({_f(min(nees), 2)}-{_f(max(nees), 2)})", _f(window, 2),
            f"{lo:.2f}-{hi:.2f}", f"{inside}/{len(nees)}"]


def pose_nees_rows(records: list[dict], grade: str, scenario: str, methods) -> list[str]:
    """Table rows of the position (2 dof) and heading (1 dof) NEES per method; only methods with one of them."""
    from graphnav.evaluation.consistency import HEADING_DOF, POSITION_DOF
    rows = []
    for m in methods:
        rs = [r for r in records if (r["imu_grade"], r["scenario"], r["method"]) == (grade, scenario, m)
              and not r.get("error")]
        if not any(r.get("nees_pos_mission") is not None or r.get("nees_heading_mission") is not None for r in rs):
            continue
        cells = _pose_cells(rs, "nees_pos", POSITION_DOF) + _pose_cells(rs, "nees_heading", HEADING_DOF)
        rows.append(f"| {m} | " + " | ".join(cells) + " |")
    return rows


def _num(x) -> float:
    return float("nan") if x is None else float(x)


def _mean(values) -> float:
    v = [x for x in values if x is not None and math.isfinite(x)]
    return float(np.mean(v)) if v else float("nan")


def _max(values) -> float:
    v = [x for x in values if x is not None and math.isfinite(x)]
    return float(np.max(v)) if v else float("nan")


def improvement_pct(model: float, ref: float) -> float:
    """Signed VRTE, %: ``(ref - model) / ref * 100``; positive when ``model`` has the smaller error.
    (The paper's VRTE is the magnitude of this.)"""
    if not (math.isfinite(model) and math.isfinite(ref)) or ref <= 0:
        return float("nan")
    return (ref - model) / ref * 100.0


def aggregate(records: list[dict]) -> dict:
    """Per (imu_grade, scenario, method): window VRMSE mean/worst, mission VRMSE mean, drift mean, counts,
    the per-window values keyed by (trajectory, window_start_s), mean runtime and real-time factor.

    Diverged windows (``diverged`` true) are left out of the statistics and counted in ``n_diverged`` and
    listed in ``diverged`` as (trajectory, window_start_s, reason)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in records:
        groups[(r["imu_grade"], r["scenario"], r["method"])].append(r)
    out = {}
    for key, rs in groups.items():
        ran = [r for r in rs if not r.get("error")]
        ok = [r for r in ran if not r.get("diverged")]
        bad = [r for r in ran if r.get("diverged")]
        runs = {(r["trajectory"], r["window_s"]): r for r in ran}.values()  # one runtime per run
        runtime = _mean(r["runtime_s"] for r in runs)
        duration = _mean(r.get("mission_duration_s") for r in runs)
        out[key] = {
            "vrmse_window_mean": _mean(r["vrmse_window"] for r in ok),
            "vrmse_window_worst": _max(r["vrmse_window"] for r in ok),
            "vrmse_mission_mean": _mean(r["vrmse_mission"] for r in ok),
            "drift_mean": _mean(r["pos_err_window_end_m"] for r in ok),
            "drift_pct_window": drift_pct_of(ok),
            "drift_pct_mission_mean": _mean(r.get("drift_pct_mission")
                                            for r in {r["trajectory"]: r for r in ok}.values()),
            "nees_mean": _mean(r.get("nees_window") for r in ok),
            "n_windows": len(ok), "n_failed": len(rs) - len(ran), "n_diverged": len(bad),
            "diverged": [(r["trajectory"], r["window_start_s"], r.get("divergence_reason")) for r in bad],
            "per_window": {(r["trajectory"], r["window_start_s"]): _num(r["vrmse_window"]) for r in ok},
            "runtime_mean_s": runtime, "duration_mean_s": duration,
            "realtime_factor": duration / runtime if runtime and runtime > 0 else float("nan"),
            "completers": sorted({r.get("completer", "?") for r in ran}),
        }
    return out


def drift_pct_of(records: list[dict]) -> float:
    """% DT of a set of windows: their summed drift over their summed distance travelled (windows under
    :data:`graphnav.evaluation.metrics.MIN_DISTANCE_M` and records without a distance left out); a mean of
    per-window ratios would let the slowest window dominate. NaN when nothing is left."""
    from graphnav.evaluation.metrics import MIN_DISTANCE_M
    pairs = [(r.get("pos_err_window_end_m"), r.get("distance_window_m")) for r in records]
    pairs = [(e, d) for e, d in pairs if e is not None and d is not None and math.isfinite(e) and math.isfinite(d)
             and d >= MIN_DISTANCE_M]
    distance = sum(d for _, d in pairs)
    return 100.0 * sum(e for e, _ in pairs) / distance if distance > 0 else float("nan")


def natural_key(name: str) -> list:
    """Sort key that puts Trajectory2 before Trajectory10."""
    import re
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", name)]


def _f(x: float, digits: int = 3) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _pct(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x:+.0f}%"


def headline(agg: dict, grade: str, scenario: str, model: str = GRAPH_HN, ref: str = HNTC) -> str | None:
    """One sentence: does ``model`` beat ``ref`` in this grade and scenario, by how much, in how many windows."""
    a, b = agg.get((grade, scenario, model)), agg.get((grade, scenario, ref))
    if not a or not b or not a["n_windows"] or not b["n_windows"]:
        return None
    common = sorted(set(a["per_window"]) & set(b["per_window"]))
    wins = sum(a["per_window"][k] < b["per_window"][k] for k in common)
    gain = improvement_pct(a["vrmse_window_mean"], b["vrmse_window_mean"])
    verdict = "beats" if gain >= 0.5 else ("does not beat" if gain <= -0.5 else "ties with")
    return (f"{model} {verdict} {ref}: window VRMSE {_f(a['vrmse_window_mean'])} vs "
            f"{_f(b['vrmse_window_mean'])} m/s ({_pct(gain)}), lower in {wins} of {len(common)} windows")


def aggregate_regimes(records: list[dict]) -> dict:
    """Per (imu_grade, scenario, window_s, method): window VRMSE mean and worst, number of windows, and the
    windows' % DT (:func:`drift_pct_of`)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in records:
        if not r.get("error") and r.get("vrmse_window") is not None:
            groups[(r["imu_grade"], r["scenario"], float(r["window_s"]), r["method"])].append(r)
    return {k: {"mean": _mean(r["vrmse_window"] for r in v), "worst": _max(r["vrmse_window"] for r in v),
                "n": len(v), "drift_pct": drift_pct_of(v)} for k, v in groups.items()}


def _ratio(agg: dict, regime: tuple, model: str, ref: str = GRAPH_TC, model_regime: tuple | None = None) -> float:
    """Mean window VRMSE of ``model`` (in ``model_regime``, default ``regime``) over ``ref``'s in ``regime``."""
    a, b = agg.get((*(model_regime or regime), model)), agg.get((*regime, ref))
    if not a or not b or not (b["mean"] > 0):
        return float("nan")
    return a["mean"] / b["mean"]


def _all_beams_ratio(agg: dict, regime: tuple) -> float:
    """Graph-TC with every beam measured (scenario ``none``) over Graph-TC in ``regime``, on the same grade
    and window length: the lowest ratio to Graph-TC a completion can give, since a completion made from past
    pings and the IMU carries no more than the beam it stands for."""
    return _ratio(agg, regime, GRAPH_TC, model_regime=(regime[0], "none", regime[2]))


#: Ratio thresholds of the regime verdicts (mean window VRMSE of a method / Graph-TC's).
HELPS_BELOW, HURTS_ABOVE = 0.95, 1.02


#: The hybrid's targets per cell: never above HURTS_ABOVE x Graph-TC; at most HELPS_TARGET x Graph-TC wherever
#: Graph-TC with all four beams measured is at most ALL_BEAMS_REACH x Graph-TC (a completion could get there).
HELPS_TARGET, ALL_BEAMS_REACH = 0.7, 0.5


def target_cells(agg: dict, regimes: list[tuple], model: str = GRAPH_HN) -> list[str]:
    """Markdown table: per regime ``model``/Graph-TC, all-beams/Graph-TC and pass / fail against the two
    targets (never worse: <= :data:`HURTS_ABOVE`; helps: <= :data:`HELPS_TARGET` where all-beams/TC <=
    :data:`ALL_BEAMS_REACH`, else not required)."""
    lines = [f"Per cell ({model}; helps required where all-beams/TC <= {ALL_BEAMS_REACH:g}):", "",
             f"| IMU | scenario | window s | {model}/TC | all-beams/TC | never worse (<= {HURTS_ABOVE:g}x) | "
             f"helps (<= {HELPS_TARGET:g}x) |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in regimes:
        x, best = _ratio(agg, r, model), _all_beams_ratio(agg, r)
        never_worse = "pass" if x <= HURTS_ABOVE else "fail"
        if not best <= ALL_BEAMS_REACH:
            helps = "not required" if math.isfinite(best) else "- (no all-beams run)"
        else:
            helps = "pass" if x <= HELPS_TARGET else "fail"
        lines.append(f"| {r[0]} | {r[1]} | {r[2]:g} | {_f(x, 2)} | {_f(best, 2)} | {never_worse} | {helps} |")
    return lines


def regime_summary(records: list[dict]) -> list[str]:
    """Markdown: the regime table (IMU grade x scenario x window length; mean and worst window VRMSE per
    method of :data:`REGIME_METHODS`, Graph-HN and the batch as a ratio of Graph-TC) and, generated from
    those numbers, where the hybrid helps, where it is neutral, where it hurts, and the hybrid's targets."""
    agg = aggregate_regimes(records)
    regimes = sorted({k[:3] for k in agg}, key=lambda r: (
        list(dict.fromkeys((*IMU_GRADE_CHOICES, r[0]))).index(r[0]),
        list(dict.fromkeys((*SCENARIO_NAMES, r[1]))).index(r[1]), r[2]))
    methods = [m for m in REGIME_METHODS if any(k[3] == m for k in agg)]
    if not regimes or GRAPH_TC not in methods:
        return []
    lines = ["## Regimes", "",
             "Window VRMSE, m/s, mean (worst) over all windows of all trajectories, per IMU grade, scenario and "
             "window length; `HN/TC` and `batch/TC` are Graph-HN's and Graph-HN-batch's mean divided by "
             "Graph-TC's; `all-beams/TC` is Graph-TC with every beam measured (scenario `none`, same grade and "
             "window length) divided by Graph-TC: the lowest `HN/TC` a completion can reach. `% DT TC / HN / "
             "batch`: drift over the windows in % of the distance travelled in them (summed drift / summed "
             "distance) of Graph-TC, Graph-HN and Graph-HN-batch.", "",
             "| IMU | scenario | window s | " + " | ".join(methods)
             + " | HN/TC | batch/TC | all-beams/TC | % DT TC / HN / batch | windows |",
             "| --- | --- | --- |" + " --- |" * (len(methods) + 5)]
    for reg in regimes:
        cells = [f"{_f(agg[(*reg, m)]['mean'])} ({_f(agg[(*reg, m)]['worst'])})" if (*reg, m) in agg else "-"
                 for m in methods]
        n = agg.get((*reg, GRAPH_TC), {}).get("n", 0)
        lines.append(f"| {reg[0]} | {reg[1]} | {reg[2]:g} | " + " | ".join(cells) +
                     f" | {_f(_ratio(agg, reg, GRAPH_HN), 2)} | {_f(_ratio(agg, reg, GRAPH_HN_BATCH), 2)}"
                     f" | {_f(_all_beams_ratio(agg, reg), 2)} | "
                     + " / ".join(_f(agg.get((*reg, m), {}).get("drift_pct", float("nan")), 2)
                                  for m in (GRAPH_TC, GRAPH_HN, GRAPH_HN_BATCH))
                     + f" | {n} |")
    lines.append("")
    lossy = [r for r in regimes if r[1] != "none"]

    def verdicts(model: str, ref: str = GRAPH_TC) -> list[str]:
        rated = [(r, _ratio(agg, r, model, ref)) for r in lossy]
        rated = [(r, x) for r, x in rated if math.isfinite(x)]
        if not rated:
            return []
        name = lambda r, x: f"{r[0]}/{r[1]}/{r[2]:g} s ({x:.2f}x)"  # noqa: E731
        helps = [name(r, x) for r, x in rated if x < HELPS_BELOW]
        neutral = [name(r, x) for r, x in rated if HELPS_BELOW <= x <= HURTS_ABOVE]
        hurts = [name(r, x) for r, x in rated if x > HURTS_ABOVE]
        out = [f"- {model} vs {ref} over {len(rated)} regimes with missing beams: "
               f"helps (< {HELPS_BELOW:g}x) in {len(helps)}, neutral in {len(neutral)}, "
               f"hurts (> {HURTS_ABOVE:g}x) in {len(hurts)}."]
        if helps:
            out.append(f"  - helps: {', '.join(helps)}")
        if hurts:
            out.append(f"  - hurts: {', '.join(hurts)}")
        best = min(rated, key=lambda rx: rx[1])
        out.append(f"  - largest gain: {name(*best)}; worst case: {name(*max(rated, key=lambda rx: rx[1]))}")
        return out

    lines += ["Where the hybrid helps (generated from the table):", ""]
    for model in (GRAPH_HN, GRAPH_HN_BATCH, GRAPH_MP):
        lines += verdicts(model)
    # the batch's gain split: smoothing alone (Graph-TC-batch) against what the completions add to it (Graph-HN-batch
    # leaves out those of an outage the measured beams end, so in the bench's windows about nothing)
    lines += verdicts(GRAPH_TC_BATCH)
    lines += verdicts(GRAPH_HN_BATCH, GRAPH_TC_BATCH)
    # the hybrid's targets, checked on the same numbers
    checks = []
    hn = [(r, _ratio(agg, r, GRAPH_HN)) for r in lossy]
    hn = [(r, x) for r, x in hn if math.isfinite(x)]
    if hn:
        bad = [r for r, x in hn if x > HURTS_ABOVE]
        checks.append(f"- never hurts (Graph-HN <= {HURTS_ABOVE:g}x Graph-TC in every regime): "
                      + ("holds" if not bad else f"fails in {len(bad)} of {len(hn)}"))
    hard = [(r, x) for r, x in hn if r[0] in ("tactical", "mems") and (r[1] == "3-missing" or "0-" in r[1]
                                                                        or "outage" in r[1]) and r[2] >= 60]
    if hard:
        bad = [r for r, x in hard if x > 0.7]
        out_of_reach = [r for r in bad if _all_beams_ratio(agg, r) > 0.7]
        checks.append("- helps where it can (Graph-HN <= 0.7x Graph-TC, tactical/MEMS, 3-missing and total "
                      "outage, 60-120 s): " + ("holds" if not bad else f"fails in {len(bad)} of {len(hard)}")
                      + (f"; in {len(out_of_reach)} of these even Graph-TC with all four beams measured is above "
                         f"0.7x ({', '.join(f'{r[0]}/{r[1]}/{r[2]:g} s' for r in out_of_reach)})"
                         if out_of_reach else ""))
    if hard:
        checks += ["", *target_cells(agg, [r for r, _ in hard])]
    bt = [(r, _ratio(agg, r, GRAPH_HN_BATCH)) for r in lossy]
    bt = [(r, x) for r, x in bt if math.isfinite(x)]
    if bt:
        bad = [r for r, x in bt if x > 0.8]
        checks.append("- batch smoother <= 0.8x Graph-TC in every cell with missing beams: "
                      + ("holds" if not bad else f"fails in {len(bad)} of {len(bt)}"))
    if checks:
        lines += ["", "Targets of the hybrid methods (docs/decisions/regressed-beams.md):", ""] + checks
    return lines + [""]


def make_report(records: list[dict], meta: dict | None = None) -> str:
    """``report.md`` text: per IMU grade the paper-style table and a detailed table per scenario, the
    Graph-HN vs HNTC headline, runtime and real-time factor per method, and the benchmark's settings."""
    meta = meta or {}
    agg = aggregate(records)
    grades = [g for g in (*IMU_GRADE_CHOICES, *sorted({r["imu_grade"] for r in records}))
              if any(k[0] == g for k in agg)]
    grades = list(dict.fromkeys(grades))
    scenarios = [s for s in SCENARIO_NAMES if any(k[1] == s for k in agg)]
    methods = [m for m in METHODS if any(k[2] == m for k in agg)]
    methods += sorted({k[2] for k in agg} - set(methods))
    trajectories = sorted({r["trajectory"] for r in records}, key=natural_key)
    lines = ["# graphnav benchmark report", ""]
    if meta.get("command"):
        lines += [f"Command: `{meta['command']}`", ""]
    lines += [f"Trajectories ({len(trajectories)}): {', '.join(trajectories)}  ",
              f"Windows: {', '.join(f'{w:g}' for w in np.atleast_1d(meta.get('window_s', 30.0)))} s outages "
              "starting 60 s into each mission and then every "
              f"window + 60 s (>= 60 s of full beams between windows; each window scored on its own; "
              f"`none` scores the same windows with all beams).  ",
              "VRMSE: m/s against ground truth, over the window (mean and worst over windows and "
              "trajectories) and over the whole mission (mean). VRTE: signed improvement "
              "`(ref - model) / ref` of the mean window VRMSE, positive = better than the reference; "
              "baseline = LC for LC/Average-LC/HNLC and TC for the rest, average = Average-LC or Average-TC "
              "likewise. Drift: horizontal position error accumulated over the window, m. % DT window: that drift "
              "in % of the horizontal distance the reference travelled in the window (summed drift over summed "
              "distance of all windows); % DT mission: horizontal error at the mission's end in % of the "
              "distance travelled over the mission (mean over trajectories). NEES: mean velocity "
              "NEES over the window (3 = consistent; much larger = the estimator's sigma is too small). "
              f"Diverged windows (non-finite, window VRMSE >= {DIVERGED_VRMSE_MPS:g} m/s, or the estimator's "
              "health monitor diverged during the window) are not averaged in: they are counted in brackets "
              "and listed under 'Diverged runs'.", ""]
    if len(np.atleast_1d(meta.get("window_s", 30.0))) > 1:
        lines += ["With several window lengths, the per-grade tables below pool them; the regime table "
                  "separates them.", ""]
    lines += regime_summary(records)
    if meta.get("wall_time_s") is not None:
        lines += [f"Wall time: {meta['wall_time_s']:.0f} s with {meta.get('jobs', 1)} job(s).", ""]
    failed = [r for r in records if r.get("error")]
    if failed:
        lines += [f"**{len(failed)} case(s) failed** (first: {failed[0]['method']} on {failed[0]['trajectory']}"
                  f" {failed[0]['imu_grade']} {failed[0]['scenario']}: {failed[0]['error'][:200]})", ""]

    for grade in grades:
        title = grade
        if grade != "as-recorded":
            spec = imu_grade_spec(grade)
            title += (f" (IMU degraded: accel bias {spec.accel_bias_sigma:.3g} m/s^2, gyro bias "
                      f"{np.rad2deg(spec.gyro_bias_sigma) * 3600:.3g} deg/h, accel noise "
                      f"{spec.accel_noise_density:.3g} m/s^2/sqrt(Hz), gyro noise "
                      f"{np.rad2deg(spec.gyro_noise_density) * 60:.3g} deg/sqrt(h), bias random walk "
                      f"{spec.accel_bias_rw:.2g} m/s^3/sqrt(Hz), {spec.gyro_bias_rw:.2g} rad/s^2/sqrt(Hz))")
        lines += [f"## IMU grade: {title}", "",
                  "Window VRMSE, m/s, mean (worst):", "",
                  "| scenario | " + " | ".join(methods) + " |",
                  "| --- |" + " --- |" * len(methods)]
        for sc in scenarios:
            cells = []
            for m in methods:
                a = agg.get((grade, sc, m))
                cells.append("-" if not a else f"{_f(a['vrmse_window_mean'])} ({_f(a['vrmse_window_worst'])})"
                             + (f" [{a['n_diverged']} diverged]" if a["n_diverged"] else ""))
            lines.append(f"| {sc} | " + " | ".join(cells) + " |")
        lines.append("")
        for sc in scenarios:
            heads = [h for h in (headline(agg, grade, sc), headline(agg, grade, sc, GRAPH_HN_BATCH))
                     if h]
            lines += [f"### {grade}, {sc}", ""] + [f"- {h}" for h in heads] + ([""] if heads else [])
            lines += ["| method | VRMSE window mean | worst | VRMSE mission | drift (m) | % DT window | % DT mission "
                      "| VRTE vs baseline | VRTE vs average | NEES | windows | completer |",
                      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
            for m in methods:
                a = agg.get((grade, sc, m))
                if not a:
                    continue
                # a name the registry does not know (results of another version) is compared with nothing
                record = METHODS.get(m)
                base_name, avg_name = (record.baseline, record.average) if record else (m, m)
                base = agg.get((grade, sc, base_name), {}).get("vrmse_window_mean", float("nan"))
                avg = agg.get((grade, sc, avg_name), {}).get("vrmse_window_mean", float("nan"))
                vs_base = "-" if m == base_name else _pct(improvement_pct(a["vrmse_window_mean"], base))
                vs_avg = "-" if m == avg_name else _pct(improvement_pct(a["vrmse_window_mean"], avg))
                n = f"{a['n_windows']}" + (f" ({a['n_failed']} failed)" if a["n_failed"] else "") \
                    + (f" (+{a['n_diverged']} diverged)" if a["n_diverged"] else "")
                lines.append(f"| {m} | {_f(a['vrmse_window_mean'])} | {_f(a['vrmse_window_worst'])} | "
                             f"{_f(a['vrmse_mission_mean'])} | {_f(a['drift_mean'], 2)} | "
                             f"{_f(a['drift_pct_window'], 2)} | {_f(a['drift_pct_mission_mean'], 2)} | "
                             f"{vs_base} | {vs_avg} | "
                             f"{_f(a['nees_mean'], 1)} | {n} | {', '.join(a['completers'])} |")
            lines.append("")

    diverged = [(k, a) for k, a in sorted(agg.items()) if a["n_diverged"]]
    lines += ["## Diverged runs", ""]
    if not diverged:
        lines += ["None: no window diverged.", ""]
    else:
        lines += [f"{sum(a['n_diverged'] for _, a in diverged)} window(s) diverged; they are not in the means "
                  "above.", "", "| IMU grade | scenario | method | windows | trajectory, window start (s): reason |",
                  "| --- | --- | --- | --- | --- |"]
        for (grade, sc, m), a in diverged:
            listed = "; ".join(f"{t} {s:.0f}: {why}" for t, s, why in a["diverged"][:10])
            more = f"; ... {a['n_diverged'] - 10} more" if a["n_diverged"] > 10 else ""
            lines.append(f"| {grade} | {sc} | {m} | {a['n_diverged']} | {listed}{more} |")
        lines.append("")


    lines += nees_section(records, grades, scenarios, methods)
    lines += ["## Runtime", "", "Wall time of one method run over a whole mission (mean over runs) and the "
              "real-time factor (mission duration / wall time).", "",
              "| method | runtime (s) | real-time factor | runs |", "| --- | --- | --- | --- |"]
    for m in methods:
        runs = {(r["trajectory"], r["imu_grade"], r["scenario"]): r for r in records
                if r["method"] == m and not r.get("error")}.values()
        rt = _mean(r["runtime_s"] for r in runs)
        dur = _mean(r.get("mission_duration_s") for r in runs)
        rtf = dur / rt if rt and math.isfinite(rt) and rt > 0 else float("nan")
        lines.append(f"| {m} | {_f(rt, 2)} | {_f(rtf, 0) + ('x' if math.isfinite(rtf) else '')} | {len(runs)} |")
    lines.append("")
    if len(trajectories) > 1:
        lines += ["## Per trajectory", "", "Window VRMSE (m/s), mean over the windows of each trajectory.", ""]
        for grade in grades:
            for sc in [s for s in scenarios if s != "none"]:
                lines += [f"### Per trajectory: {grade}, {sc}", "", "| trajectory | " + " | ".join(methods) + " |",
                          "| --- |" + " --- |" * len(methods)]
                for traj in trajectories:
                    cells = [_f(_mean(r["vrmse_window"] for r in records
                                      if (r["imu_grade"], r["scenario"], r["method"], r["trajectory"])
                                      == (grade, sc, m, traj) and not r.get("error") and not r.get("diverged")))
                             for m in methods]
                    lines.append(f"| {traj} | " + " | ".join(cells) + " |")
                lines.append("")
    if meta.get("plots"):
        lines += ["## Plots", ""] + [f"- [{Path(p).name}]({p})" for p in meta["plots"]] + [""]
    return "\n".join(lines)
