"""Helpers shared by the ``graphnav`` subcommands: the mission and initial-state options (``smooth``,
``online``), the mission they describe, the accuracy summary, plots and the printed summary, the help
formatter of every command, and the output folder rules (:func:`add_out_arguments`, :func:`check_out`,
:class:`StagedOut`). Every command module imports these from here, none from another command.

Output folders: ``--out`` is checked before any work (a folder that exists or can be created, writable); a
folder that already holds files is kept unless ``--force`` (replace it whole) or, where a command has it,
``--resume``. Batch commands write into a hidden folder beside ``--out`` and move it into place only when
complete, so a crash never mixes with, nor destroys, an earlier run.
"""
from __future__ import annotations

import argparse
import functools
import os
import shutil
from pathlib import Path

import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import SCENARIOS, scenario_outage, window_starts
from graphnav.estimators.health import EXIT_DIVERGED, run_health
from graphnav.evaluation.methods import METHODS, check_scenario, completer_fallbacks_line


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Show defaults in --help, except the uninformative None/False/[] of optional paths, flags and lists."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.default == []:
            return action.help
        return super()._get_help_string(action)


def methods_help(names=None) -> str:
    """One line per method of the registry for ``--help``: its name and description."""
    return "; ".join(f"{n} - {METHODS[n].description}" for n in (names or METHODS))


#: The default of ``--window-s``, s.
WINDOW_S_DEFAULT = 30.0


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def positive_seconds(text: str) -> float:
    """An argparse ``type``: a duration in s, finite and > 0 (argparse names the option in its error)."""
    value = _number(text)
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a duration > 0 s, got {text}")
    return value


def finite_seconds(text: str) -> float:
    """An argparse ``type``: a time in s, finite (argparse names the option in its error)."""
    value = _number(text)
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite time in s, got {text}")
    return value


def add_mission_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("mission")
    g.add_argument("--data", metavar="PATH",
                   help="trajectory folder in the published A-KIT layout (IMU_*.csv, DVL_*.csv, GT_*.csv), a ROS 2 "
                        "bag (ROS 1 .bag, .mcap, .db3 or a bag folder, recognised by content), a PD0 file (RDI/VmDAS "
                        "ensembles in any frame, any name; without an IMU in --config's column map `smooth` "
                        "dead-reckons it, DVL-DR) or a CSV log with the column map of --config; "
                        "`smooth` also takes a folder of missions (TrajectoryN folders or "
                        "bags, as `bench --data` finds them); default: the simulated 400 s mission")
    g.add_argument("--topic", action="append", metavar="STREAM=TOPIC",
                   help="bags: read STREAM (imu, dvl, depth, heading, gt) from TOPIC instead of the topic chosen "
                        "by message type and plausibility (repeatable)")
    g.add_argument("--config", metavar="JSON", help="sensor configuration (e.g. from `graphnav calibrate`)")
    g.add_argument("--repair-stamps", action="store_true",
                   help="A-KIT folders and column-map CSV logs: drop rows whose stamp repeats an earlier one "
                        "and sort the rest (warned and counted) instead of refusing the file (without it, a row "
                        "repeating an earlier one exactly, or the row before it in every value under half a step "
                        "later, is dropped, warned and counted; an IMU's packets sharing "
                        "one stamp, or a clock coarser than its period, are restamped at its period, not dropped)")
    g.add_argument("--seed", type=int, default=0, help="simulator seed when --data is not given")
    g.add_argument("--duration", type=float, default=400.0, metavar="S",
                   help="simulated mission length in s when --data is not given")
    g.add_argument("--imu-grade", default="as-recorded", metavar="GRADE",
                   help="'as-recorded' or an IMU grade (tactical, mems) whose errors are added to "
                        "the recorded IMU, seeded, as in `graphnav bench`")
    g.add_argument("--scenario", default="none", choices=sorted(SCENARIOS),
                   help="inject a beam outage: 2-missing (beams 1, 3), 3-missing (only beam 2 left) or none "
                        "(data as recorded)")
    g.add_argument("--window-start", type=finite_seconds, action="append", metavar="S",
                   help="start of an outage window in s (repeatable); default: windows spread over the "
                        "mission as in the benchmark (60 s in, then every window + 60 s)")
    g.add_argument("--window-s", type=positive_seconds, default=WINDOW_S_DEFAULT, metavar="S",
                   help="outage window length")


def add_init_arguments(parser: argparse.ArgumentParser) -> None:
    """Where the estimator starts: the ground truth or an alignment from the sensors (shared with online)."""
    g = parser.add_argument_group("initial state")
    g.add_argument("--init", default="auto", choices=("auto", "gt", "sensors"),
                   help="the ground truth at the first ping (gt), an alignment from the sensors (sensors: "
                        "levelling, gyrocompassing or a heading record, DVL velocity), or gt when the data "
                        "has ground truth (auto)")
    g.add_argument("--initial-position", type=float, nargs=2, metavar=("LAT", "LON"),
                   help="with sensor alignment: the starting position, degrees (else a local origin)")
    g.add_argument("--initial-position-sigma", type=float, metavar="M",
                   help="horizontal 1-sigma of --initial-position per axis, m (default 5: a GNSS fix at launch)")
    g.add_argument("--initial-heading", type=float, metavar="DEG",
                   help="with sensor alignment: the starting heading, degrees (else gyrocompassing or the "
                        "first heading record)")
    g.add_argument("--heading-sigma", type=float, default=2.0, metavar="DEG",
                   help="1-sigma of --initial-heading, degrees")


def align_options(args):
    """The alignment's :class:`~graphnav.estimators.align.AlignOptions` with --initial-position /
    --initial-heading."""
    import math
    from graphnav.estimators.align import AlignOptions
    kw = {}
    if args.initial_position is not None:
        kw["initial_lla"] = (math.radians(args.initial_position[0]), math.radians(args.initial_position[1]), 0.0)
        if args.initial_position_sigma is not None:
            kw["initial_position_sigma_m"] = args.initial_position_sigma
    elif args.initial_position_sigma is not None:
        raise ConfigError("--initial-position-sigma needs --initial-position (the position it is the sigma of)")
    if args.initial_heading is not None:
        kw["initial_heading_rad"] = math.radians(args.initial_heading)
        kw["heading_sigma_rad"] = math.radians(args.heading_sigma)
    return AlignOptions(**kw)


def recorded_mission(args):
    """The mission of ``--data``/``--config``, read and prepared (axis signs, time offsets and clocks estimated
    from the data unless the configuration sets them), or the simulated one of ``--seed``/``--duration``."""
    if args.data is None:
        from graphnav.missions import simulated_mission
        return simulated_mission(args.config, duration_s=args.duration, seed=args.seed)
    from graphnav.calibration.preparation import prepare
    from graphnav.io.bags import parse_topics
    from graphnav.io.loaders import read_mission
    # only when asked: read_mission refuses it for bags
    repair = {"repair": True} if getattr(args, "repair_stamps", False) else {}
    return prepare(read_mission(args.data, args.config, topics=parse_topics(getattr(args, "topic", None)), **repair))


def mission_from_args(args):
    """(mission with the IMU grade and outages applied, list of outages)."""
    from graphnav.evaluation.bench import degrade_imu
    mission = recorded_mission(args)
    if args.imu_grade != "as-recorded":
        import zlib
        mission = degrade_imu(mission, args.imu_grade, seed=zlib.crc32(mission.name.encode()) % 2**31)
    outages = []
    if check_scenario(args.scenario) != "none":
        check_windows(args.window_start, args.window_s, mission)
        starts = args.window_start or window_starts(mission.t0, mission.t1, args.window_s)
        outages = [scenario_outage(args.scenario, s, args.window_s) for s in starts]
        mission = mission.with_outage(*outages)
    elif args.window_start or args.window_s != WINDOW_S_DEFAULT:
        import warnings
        warnings.warn(f"--window-start / --window-s ignored: they place the outage windows of --scenario, which is "
                      f"'{args.scenario}'", RuntimeWarning, stacklevel=2)
    return mission, outages


def check_windows(window_start: list[float] | None, window_s: float, mission) -> None:
    """Refuse, before any estimator runs, an ``--window-start`` (s) whose window ``[start, start + window_s]``
    lies wholly outside the mission's span (ConfigError naming the option and the span); warn when a window
    runs past the mission's end (it is scored over its part inside)."""
    t0, t1 = float(mission.t0), float(mission.t1)
    for start in window_start or []:
        if start + window_s <= t0 or start >= t1:
            raise ConfigError(f"--window-start {start:g}: the window [{start:g}, {start + window_s:g}] s lies "
                              f"outside the mission {mission.name}, which spans [{t0:.1f}, {t1:.1f}] s")
        if start < t0 or start + window_s > t1:
            import warnings
            warnings.warn(f"--window-start {start:g}: the window [{start:g}, {start + window_s:g}] s runs past "
                          f"the mission {mission.name} ([{t0:.1f}, {t1:.1f}] s); scored over its part inside",
                          RuntimeWarning, stacklevel=3)


def accuracy_summary(sol, mission, outages, reference=None) -> dict:
    """VRMSE over the mission and each outage window and the final horizontal position error (when GT), with
    ``reference_point`` when the reference is scored at the IMU point without its point given and
    ``reference_time`` when the data contradict its given time offset
    (:func:`graphnav.calibration.preparation.reference_notes`);
    ``reference``: the NEES's reference at ``sol``'s epochs when the caller has carried it (None: carried here)."""
    if mission.gt is None:
        return {"ground_truth": False}
    from graphnav.calibration.preparation import reference_notes
    from graphnav.evaluation.metrics import horizontal_position_error, vrmse
    t_end = float(min(sol.t[-1], mission.gt.t[-1]))
    return {**reference_notes(mission),
        "ground_truth": True,
        "vrmse_mission_mps": float(vrmse(sol, mission.gt, mission.t0, mission.t1)),
        "windows": [{"start_s": o.start_s, "end_s": o.end_s, "missing_beams": [b + 1 for b in o.missing],
                     "vrmse_window_mps": float(vrmse(sol, mission.gt, o.start_s, o.end_s))} for o in outages],
        "final_horizontal_position_error_m": float(horizontal_position_error(sol, mission.gt, t_end)),
        "consistency": consistency_summary(sol, mission, reference),
    }


def regressed_beams_summary(sol_info: dict) -> dict | None:
    """What became of the beams a completer regressed in a run: ``regressed`` (beams handed to the estimator),
    ``entered`` (those that became factors of the graph, or went into the EKF's update, whose innovation gate can
    still reject the whole ping), and the screening's counters (``decorrelated_out``: no information beyond the
    estimator's own prediction of the beam; ``gated``: too far from it; ``inflated``: entered with a wider
    sigma; ``continued``: entered unscreened as the rest of a run,
    :attr:`graphnav.estimators.graph.GraphOptions.regressed_runs`). Beams neither entered nor dropped were
    replaced by the graph's motion prior (a ping without any measured beam). ``retired``: entered beams taken out
    of the graph again when the measured beams returned (``GraphOptions.retire_completions``). None when no beam
    was regressed (a method without a completer, or no outage). A hybrid whose completions all drop out gives the
    tightly coupled method's answer; this record is where a user sees it."""
    screening = sol_info.get("regressed_screening") or {}
    regressed = int(sol_info.get("regressed_beams") or 0)
    if not regressed or "entered" not in screening:
        return None
    return {"regressed": regressed, **{k: int(v) for k, v in screening.items() if k != "offered"},
            **({"retired": int(sol_info["completions_retired"])} if sol_info.get("completions_retired") else {})}


def regressed_beams_line(record: dict | None) -> str:
    """One line of :func:`regressed_beams_summary` for command output ("" without a record)."""
    if not record:
        return ""
    extra = [f"{record[k]} {what}" for k, what in (("inflated", "with a widened sigma"),
                                                    ("continued", "unscreened as a run's continuation"))
             if record.get(k)]
    dropped = record.get("decorrelated_out", 0) + record.get("gated", 0)
    replaced = record["regressed"] - record["entered"] - dropped
    return (f"regressed beams: {record['entered']} of {record['regressed']} entered"
            + (f" ({', '.join(extra)})" if extra else "")
            + f"; {record.get('decorrelated_out', 0)} added nothing to the estimator's own prediction, "
            f"{record.get('gated', 0)} gated as too far from it"
            + (f", {replaced} replaced by the motion prior" if replaced > 0 else "")
            + (f"; {record['retired']} taken out again when the measured beams returned" if record.get("retired")
               else ""))


def consistency_summary(sol, mission, reference=None) -> dict:
    """Velocity (3 dof), horizontal position (2 dof) and heading (1 dof) NEES over the mission after the
    settling time against the IMU-carried reference, each with its 95 % chi-square band, as the benchmark
    scores them (:func:`graphnav.evaluation.consistency.mission_nees`); None where the solution carries no
    such covariance or the reference is too short to score. When the mission knows its reference's own velocity
    error (``meta["gt_velocity_sigma_n"]``: the A-KIT loader's, a CSV map's ``gt.velocity_sigma``), the velocity
    entry also holds ``nees_with_reference_error``, the NEES with that error added to the covariance. The velocity
    entry's ``per_body_axis``: the normalised squared error along forward, starboard and down (1 each when
    consistent; :func:`graphnav.evaluation.consistency.body_axis_nees`).
    ``reference``: :func:`~graphnav.evaluation.consistency.scoring_reference` of ``sol`` when the caller has it."""
    from graphnav.evaluation.consistency import BODY_AXES, DOF, HEADING_DOF, POSITION_DOF, chi2_band, mission_nees
    try:
        nees = mission_nees(sol, mission, reference)
    except (ValueError, IndexError):
        return {"velocity": None, "position": None, "heading": None}
    out = {}
    for name, key, n_key, dof in (("velocity", "nees_mission", "nees_n_independent", DOF),
                                  ("position", "nees_pos_mission", "nees_pos_n_independent", POSITION_DOF),
                                  ("heading", "nees_heading_mission", "nees_heading_n_independent", HEADING_DOF)):
        mean = nees.get(key)
        out[name] = None if mean is None or not np.isfinite(mean) else {
            "nees": float(mean), "dof": dof, "band_95": list(chi2_band(int(nees.get(n_key) or 1), dof))}
    if out["velocity"] is not None and nees.get("nees_axes_b") is not None:
        out["velocity"]["per_body_axis"] = dict(zip(BODY_AXES, nees["nees_axes_b"]))
    with_reference = nees.get("nees_mission_gt")
    if out["velocity"] is not None and with_reference is not None and np.isfinite(with_reference):
        # the reference's own error added to the estimate's covariance: what of the NEES the reference explains
        out["velocity"]["nees_with_reference_error"] = float(with_reference)
    return out


def make_plots(out: Path, mission, solutions, outages, label: str) -> list[str]:
    from graphnav.evaluation import plots
    files = []
    if mission.gt is not None:
        files.append(plots.plot_trajectories(mission.gt, solutions, outages, out / "trajectory_ne.png",
                                             f"{mission.name}: {label}"))
        files.append(plots.plot_velocity_errors(mission.gt, solutions, outages, out / "velocity_error.png",
                                                f"{mission.name}: velocity error, {label}"))
    if any(s.cov_v_n is not None for s in solutions):
        files.append(plots.plot_velocity_std(solutions, outages, out / "velocity_std.png",
                                             f"{mission.name}: velocity std around the first window, {label}"))
    return [str(f) for f in files]


def _nees_entry(name: str, entry: dict | None) -> str:
    """One quantity of :func:`consistency_summary` as the summary prints it: the mean NEES, its band, the NEES with
    the reference's own error, and which side of the band it lies when outside (what that says)."""
    if not entry:
        return f"{name} -"
    from graphnav.evaluation.consistency import outside_band
    notes = [f"{entry['band_95'][0]:.2f}-{entry['band_95'][1]:.2f}"]
    if "nees_with_reference_error" in entry:
        notes.append(f"{entry['nees_with_reference_error']:.2f} with the reference's own error")
    side = outside_band(entry["nees"], entry["band_95"])
    return f"{name} {entry['nees']:.2f} ({'; '.join(notes + ([side] if side else []))})"


def print_summary(summary: dict, file=None) -> None:
    """Print a command's summary (to ``file``, default standard output)."""
    out = functools.partial(print, file=file)
    from graphnav.calibration.preparation import REFERENCE_NOTE_KEYS
    from graphnav.estimators.health import health_line
    acc = summary.get("accuracy", {})
    mode = f" ({summary['mode']})" if summary.get("mode") else ""
    out(f"{summary['method']}{mode} on {summary['mission']}: {summary['epochs']} epochs, {summary['duration_s']:.0f} s "
          f"of data in {summary['runtime_s']:.2f} s ({summary['realtime_factor']:.0f}x real time)")
    init = summary.get("initialisation") or {}
    if "heading_source" in init:
        done = init.get("completed_t")
        out(f"  initial state aligned from the sensors at t = {init['t']:.1f} s (heading: {init['heading_source']}"
            + (f"; alignment completed at t = {done:.1f} s)" if done is not None else ")"))
    from graphnav.core.solution import position_frame_line
    line = position_frame_line(summary.get("position_frame"))
    if line:
        out(f"  {line}")
    refused = summary.get("refused")
    if refused:
        out(f"  refused samples (stream: field: count): {refused}")
    if summary.get("doubted"):     # the Navigator's: samples used as they came though doubted
        out(f"  used despite a doubt (stream: reason: count): {summary['doubted']}")
    repairs = {k: n for k, n in (summary.get("imu_repairs") or {}).items() if n}
    if repairs:
        out(f"  IMU stream repaired as it came (what: count): {repairs}")
    streams = summary.get("streams") or {}
    at_load = {k: v["refused"] for k, v in streams.items() if v.get("refused")}
    if at_load:
        out(f"  refused at load (stream: reason: count): {at_load}")
    doubted = {k: v["doubted"] for k, v in streams.items() if v.get("doubted")}
    if doubted:
        out(f"  read despite a doubt (stream: reason: count): {doubted}")
    for stream, entry in streams.items():
        for note in entry.get("notes", []):
            out(f"  {stream}: {note}")
    if acc.get("ground_truth"):
        out(f"  VRMSE mission {acc['vrmse_mission_mps']:.4f} m/s, final horizontal position error "
              f"{acc['final_horizontal_position_error_m']:.2f} m")
        for key in REFERENCE_NOTE_KEYS:
            if acc.get(key):
                out(f"  note: {acc[key]}")
        for w in acc["windows"]:
            out(f"  window {w['start_s']:.0f}-{w['end_s']:.0f} s (beams {w['missing_beams']} missing): "
                  f"VRMSE {w['vrmse_window_mps']:.4f} m/s")
        cons = acc.get("consistency") or {}
        if any(cons.values()):
            out("  NEES (consistent = dof; 95 % band): " + ", ".join(
                _nees_entry(name, c) for name, c in cons.items()))
            axes = (cons.get("velocity") or {}).get("per_body_axis")
            if axes:
                out("  velocity NEES per body axis (consistent = 1): "
                    + ", ".join(f"{axis} {value:.2f}" for axis, value in axes.items()))
    line = regressed_beams_line(summary.get("regressed_beams"))
    if line:
        out(f"  {line}")
    line = completer_fallbacks_line(summary.get("completer_fallbacks"))
    if line:
        out(f"  {line}")
    state = summary.get("completer_state") or {}
    if "pivot_length_m" in state:
        how = (f"fitted online over {state['pivot_fit_pairs']} pairs of fully measured pings"
               if "pivot_fit_pairs" in state else "given")
        refused = state.get("pivot_observations_refused")
        pitch = (f", {state['pitch_pivot_length_m']:.2f} m in pitch" if "pitch_pivot_length_m" in state else "")
        out(f"  pivot length {state['pivot_length_m']:.2f} m ahead of the IMU in yaw{pitch} ({how}"
            + (f"; {refused} fully measured ping(s) with a non-finite beam or rate left out" if refused else "") + ")")
    for name, other in summary.get("compared", {}).items():
        if other.get("ground_truth"):
            windows = ", ".join(f"{w['vrmse_window_mps']:.4f}" for w in other["windows"])
            out(f"  compared {name}: VRMSE mission {other['vrmse_mission_mps']:.4f} m/s"
                  + (f", windows {windows} m/s" if windows else ""))
        line = regressed_beams_line(other.get("regressed_beams"))
        if line:
            out(f"  compared {name} {line}")
        if other.get("health") and other["health"].get("state", "ok") != "ok":
            out(f"  compared {name} {health_line(other['health'])}")
    if summary.get("drift"):
        from graphnav.evaluation.metrics import drift_line
        out(f"  {drift_line(summary['drift'])}")
    line = uncertainty_line(summary.get("uncertainty"))
    if line:
        out(f"  {line}")
    line = health_line(summary.get("health"))
    if line:
        out(f"  {line}")
    timing = summary.get("update_timing")
    if timing:
        out(f"  solver update per keyframe: median {timing['median_ms']:.1f} ms, p99 {timing['p99_ms']:.1f} ms, "
              f"max {timing['max_ms']:.1f} ms")
    for name, path in summary.get("files", {}).items():
        out(f"  {name}: {path}")


def uncertainty_line(uncertainty: dict | None) -> str:
    """One line of a summary's ``uncertainty`` (:func:`graphnav.io.outputs.uncertainty_summary`): the estimator's
    own position and heading sigmas at the end and their largest values, and what it does not estimate."""
    if not uncertainty or "final_horizontal_position_sigma_m" not in uncertainty:
        return ""
    u = uncertainty
    parts = []
    if u["final_position_sigma_ned_m"] is not None:
        n, e, d = u["final_position_sigma_ned_m"]
        horizontal, largest = u["final_horizontal_position_sigma_m"], u["max_horizontal_position_sigma_m"]
        parts.append(f"position sigma N/E/D {n:.2f}/{e:.2f}/{d:.2f} m (horizontal {horizontal:.2f} m, largest "
                     f"{largest:.2f} m)")
    if u["final_heading_sigma_deg"] is not None:
        parts.append(f"heading sigma {u['final_heading_sigma_deg']:.3f} deg (largest "
                     f"{u['max_heading_sigma_deg']:.3f} deg)")
    missing = u.get("not_estimated") or []
    return ("estimator's own uncertainty at the end: " + ("; ".join(parts) if parts else "none")
            + (f"; not estimated: {', '.join(missing)}" if missing else ""))


# --- output folders ------------------------------------------------------------------------------------------
def name_value_pairs(items) -> dict[str, float]:
    """``["name=1e-3", ...]`` (a ``NAME=VALUE`` option's items) -> ``{"name": 0.001}``; ConfigError naming the item
    that is not ``name=number``."""
    out = {}
    for item in items or []:
        name, _, value = item.partition("=")
        try:
            out[name] = float(value)
        except ValueError:
            raise ConfigError(f"expected name=value with a number, got '{item}'") from None
    return out


def add_parallel_arguments(parser: argparse.ArgumentParser, what: str, jobs_note: str = "") -> None:
    """``--jobs N`` (worker processes, default min(2, CPUs)) and ``--scheduler ADDRESS|local`` (a Dask cluster)
    of the commands that run many independent ``what`` (cases, starts, trajectories) through
    :func:`graphnav.evaluation.tasks.run_tasks`."""
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), metavar="N",
                        help=f"parallel worker processes{jobs_note} (1 = run in this process)")
    parser.add_argument("--scheduler", metavar="ADDRESS|local",
                        help=f"run the {what} on a Dask cluster (dask.distributed): a scheduler address such as "
                             "tcp://10.0.0.5:8786, or 'local' for a LocalCluster of --jobs worker processes; the "
                             "same results as the process pool (needs graphnav[dask])")


def add_out_arguments(parser: argparse.ArgumentParser, default: str | None, what: str = "output folder") -> None:
    """``--out DIR`` and ``--force`` (replace an existing, non-empty ``--out`` whole)."""
    parser.add_argument("--out", default=default, metavar="DIR", help=what)
    parser.add_argument("--force", action="store_true",
                        help="replace an --out folder that already holds files (its whole content goes; without "
                             "--force such a folder is refused and kept)")


def _writable_parent(path: Path, option: str) -> None:
    """The nearest existing ancestor of ``path`` must be a folder this process may write into."""
    parent = path.parent if path.parent != path else path
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise ConfigError(f"{option} {path}: cannot be created, {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"{option} {path}: cannot be created, no permission to write in {parent}")


def _entries(path: Path) -> list[str]:
    return sorted(p.name for p in path.iterdir())


def check_out(out, *, force: bool = False, resume: bool | None = None, option: str = "--out") -> Path:
    """Check an output folder before any work: it exists as a folder or can be created, it is writable, and
    it holds no earlier results unless ``force`` (they will be replaced) or ``resume`` (continued; None: the
    command has no ``--resume``).

    Raises:
        ConfigError: naming the folder and what to do instead.
    """
    out = Path(out)
    if out.exists():
        if not out.is_dir():
            raise ConfigError(f"{option} {out}: is a file, not a folder; give a folder")
        if not os.access(out, os.W_OK | os.X_OK):
            raise ConfigError(f"{option} {out}: no permission to write in this folder")
        entries = _entries(out)
        if entries and force and not resume:
            _refuse_replacing(out, option)
        if entries and not (force or resume):
            shown = ", ".join(entries[:4]) + (", ..." if len(entries) > 4 else "")
            raise ConfigError(f"{option} {out}: holds the results of an earlier run ({shown}); they are kept. "
                              f"Give another {option}, or --force to replace them"
                              + (", or --resume to continue" if resume is not None else ""))
    else:
        _writable_parent(out, option)
        _probe_create(out, option)
    return out


def _probe_create(out: Path, option: str) -> None:
    """Create and remove ``out`` (and the parents it needs): ``os.access`` says yes to root everywhere, even
    where the filesystem refuses (``/proc``, a read-only mount), and the answer must come before any work."""
    made = []
    try:
        for folder in reversed([out, *out.parents]):
            if not folder.exists():
                folder.mkdir()
                made.append(folder)
    except OSError as exc:
        raise ConfigError(f"{option} {out}: cannot be created ({exc.strerror or exc})") from None
    finally:
        for folder in reversed(made):
            folder.rmdir()


def _refuse_replacing(out: Path, option: str) -> None:
    """--force never empties the current folder, one of its parents, or the home folder."""
    real, cwd = out.resolve(), Path.cwd().resolve()
    if real == cwd or real in cwd.parents or real == Path.home().resolve():
        raise ConfigError(f"{option} {out}: --force would delete the whole of {real} (the current folder, one of "
                          "its parents or the home folder); give a folder of its own to --out")


def check_out_file(path, *, force: bool = False, option: str = "--out") -> Path | None:
    """Check an output file before any work: not a folder, its folder creatable and writable, and not an
    existing file unless ``force``. None passes through (no file asked for)."""
    if path is None:
        return None
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"{option} {path}: is a folder; give a file name")
    if path.exists() and not force:
        raise ConfigError(f"{option} {path}: exists and is kept; give another name, or --force to replace it")
    _writable_parent(path, option)
    if path.exists() and not os.access(path, os.W_OK):
        raise ConfigError(f"{option} {path}: no permission to write this file")
    return path


def clear_out(out: Path) -> None:
    """Empty an output folder (``--force``): nothing of an earlier run stays beside the new files."""
    for entry in out.iterdir():
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()


class StagedOut:
    """Write a command's results into a hidden folder beside ``--out`` and move it into place whole when the
    command completes; on an error or Ctrl-C the partial folder is removed and the earlier ``--out``, if any,
    is untouched. ``--force`` replaces an earlier ``--out`` only at that final move.

    Use ``with StagedOut(out, force) as staged:`` and write into ``staged.path``; :meth:`final` names a file as
    it will be after the move (for summaries).
    """

    def __init__(self, out, force: bool = False, option: str = "--out"):
        self.shown = check_out(out, force=force, option=option)
        self.out = self.shown.absolute()
        self.path = self.out.parent / f".{self.out.name}.partial-{os.getpid()}"

    def final(self, path) -> str:
        """Where ``path`` (inside the staging folder) will be once in place, as the user named ``--out``."""
        return str(self.shown / Path(path).absolute().relative_to(self.path))

    def __enter__(self) -> "StagedOut":
        try:
            self.out.parent.mkdir(parents=True, exist_ok=True)
            shutil.rmtree(self.path, ignore_errors=True)
            self.path.mkdir()
        except OSError as exc:
            raise ConfigError(f"--out {self.shown}: cannot write beside it ({exc.strerror or exc})") from None
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            shutil.rmtree(self.path, ignore_errors=True)
            return
        if self.out.is_dir() and not any(self.out.iterdir()):
            # an empty folder the user made (perhaps the current one) stays; the results move into it
            for entry in self.path.iterdir():
                os.replace(entry, self.out / entry.name)
            self.path.rmdir()
            return
        old = self.out.parent / f".{self.out.name}.replaced-{os.getpid()}"
        if self.out.exists():
            os.replace(self.out, old)
        os.replace(self.path, self.out)
        shutil.rmtree(old, ignore_errors=True)


# --- health of a run and the exit status -------------------------------------------------------------------
EXIT_EPILOG = ("exit status: 0 the run finished and its estimator was healthy at the end (ok or degraded: see "
               "'health' in summary.json and the health column); 1 an error in the input or the options (the message "
               "names the file, line and field; also when more than half of a stream was refused, or when no "
               "estimate was made); 2 a usage error; "
               f"{EXIT_DIVERGED} the estimator DIVERGED and had not recovered at the end, or lost track (no estimate "
               "after it; the trajectory is written but must not be trusted); 130 interrupted")


def run_health_record(sol_info: dict, mission=None) -> dict:
    """The ``health`` of a summary: the NIS monitor's record plus ``state`` (ok / degraded / diverged) and
    ``why`` (:func:`graphnav.estimators.health.run_health`) over the run's info and the loader's streams."""
    health = dict(sol_info.get("health") or {})
    streams = (mission.meta.get("streams") if mission is not None else None) or None
    return {**health, **run_health(health, sol_info, streams)}


def exit_status(summary: dict) -> int:
    """:data:`EXIT_DIVERGED` when the run's health state is diverged, else 0."""
    return EXIT_DIVERGED if (summary.get("health") or {}).get("state") == "diverged" else 0


def config_dvl(path):
    """The DVL of the sensor configuration ``path`` (``--config``), None without one (the default, the Snapir's);
    :class:`ConfigError` naming the file on a bad one."""
    from graphnav.core.config import SensorConfig
    return SensorConfig.load(path).dvl if path else None
