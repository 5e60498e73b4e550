"""Score a written trajectory against a reference: APE and RPE through ``evo``'s library, VRMSE and NEES.

The estimate is what ``graphnav smooth`` / ``online`` write: ``trajectory.csv`` (positions, velocities,
attitude, velocity sigmas) or a TUM file (positions and attitude only). The reference is a TUM file, a
trajectory CSV, or any mission ``--data`` accepts (A-KIT folder, ROS 2 bag with a reference Odometry topic,
CSV log with a ``gt`` column map), whose ground truth is used; all of them on the mission clock.

* APE / RPE: :class:`evo.core.metrics.APE` / :class:`evo.core.metrics.RPE` on :class:`PoseTrajectory3D`s
  associated by ``evo.core.sync.associate_trajectories``, after the reference is interpolated (linear,
  slerp) to the estimate's stamps inside its span. Poses are
  compared as recorded (both in the mission's local NED frame); ``align=True`` first applies evo's Umeyama
  SE(3) alignment, as ``evo_ape --align`` does (for a reference in another frame).
* VRMSE (m/s): graphnav's own definition, on the reference interpolated to the estimate's stamps.
* Horizontal position NEES (2 dof) and heading NEES (1 dof), the benchmark's own
  (:func:`graphnav.evaluation.consistency.pose_nees`), when the estimate carries position / attitude sigmas;
  drift in % of the distance the reference travelled (end horizontal error / distance) and the estimate's own
  horizontal sigma at the end in % of its distance (:func:`graphnav.evaluation.metrics.drift_summary`).
* Velocity NEES (3 dof, mean 3 when consistent): the benchmark's own score, by the same function
  (:func:`graphnav.evaluation.consistency.reference_nees`): after the settling time, against the reference
  carried to the estimate's epochs by the mission's IMU when the reference is a mission (interpolated for a
  reference file), with the chi-square band of the independent epochs. Both need velocities on both sides (a
  TUM file has none) and, for NEES, the estimate's velocity covariance: the full one from the
  ``trajectory_cov.csv`` beside the file, else the CSV's sigmas (a diagonal covariance).

Positions follow :data:`graphnav.core.mission.NED_ORIGIN_CONVENTION` on every side (the loaders' ground
truth, the estimators, the writers): NED from the sea surface above the first fix, down = absolute depth. A
reference whose depth differs from the estimate's by a constant of metres (a file written with a depth
relative to the start) is warned about.
"""
from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import GroundTruth
from graphnav.core.solution import NavSolution
from graphnav.core.timeseries import finite_rows


def _require_evo():
    try:
        import evo  # noqa: F401
    except ImportError:
        raise ConfigError("APE/RPE use the evo package: pip install 'graphnav[eval]'") from None


def load_trajectory(path: str | Path) -> NavSolution:
    """A trajectory CSV (``.csv``) or TUM file (``.tum``/``.txt``; velocities NaN), with the full position,
    attitude and velocity covariances of the ``trajectory_cov.csv`` beside it when that file has the same stamps
    (:func:`_with_pose_covariance`: the CSV keeps sigmas only, a TUM file none)."""
    from graphnav.io.outputs import read_trajectory_csv, read_tum
    path = Path(path)
    if not path.is_file():
        raise DataError("trajectory file not found", str(path))
    if path.suffix.lower() == ".csv":
        est = read_trajectory_csv(path, method=path.stem)
    else:
        try:
            t, p, C = read_tum(path)
        except ValueError as exc:
            raise DataError(f"not a TUM file (timestamp tx ty tz qx qy qz qw per line): {exc}", str(path)) from None
        est = NavSolution(path.stem, t, p, np.full_like(p, np.nan), C)
    est = _with_pose_covariance(est, path.parent / "trajectory_cov.csv")
    est.info.update(run_frame(path))
    if est.info.pop(HOLDS_ORIGIN, False) and est.cov_p_n is not None:
        note = (f"{path}: written before the position frame (its summary.json has no position_frame.origin_sigma_m), "
                "its position covariance still holds the unknown start's place on Earth: the claimed position "
                "sigma and the position NEES cannot be scored from the start and are left out")
        warnings.warn(note, RuntimeWarning, stacklevel=2)
        est = replace(est, cov_p_n=None, info={**est.info, "position_claim_note": note})
    return est


def _with_pose_covariance(est: NavSolution, cov_path: Path) -> NavSolution:
    """``est`` with the position, attitude and velocity covariances of ``cov_path`` (``graphnav smooth``'s
    ``trajectory_cov.csv``; a file written before the velocity block has none) when it exists and holds the same
    stamps (to the microsecond the files are written with); else ``est`` as read. Scored with the written sigmas
    only, a run's NEES differed from its summary's (Trajectory1 from the sensors: position 1.27 against 1.73,
    velocity 1.46 against 1.91)."""
    if not cov_path.is_file():
        return est
    from graphnav.io.outputs import read_pose_covariance_csv
    t, *covariances = read_pose_covariance_csv(cov_path)
    if len(t) != len(est.t) or not np.allclose(t, est.t, rtol=0.0, atol=1e-6):
        return est
    full = {name: cov for name, cov in zip(("cov_p_n", "cov_rot_b", "cov_v_n"), covariances) if cov is not None}
    return replace(est, **full, info={**est.info, "pose_covariance": str(cov_path)})


#: ``run_frame``'s key for a run written before the position frame whose start was unknown: its covariance
#: counts from the origin's 100 m (``AlignOptions.local_origin_sigma_m``), not from the start.
HOLDS_ORIGIN = "covariance_holds_origin"


def _holds_origin(summary: dict) -> bool:
    """Whether a summary's run started without its position and was written before its frame kept the origin's
    place on Earth out of the covariance (no ``origin_sigma_m`` in ``position_frame`` or ``initialisation``)."""
    from graphnav.core.solution import FRAME_UNKNOWN_START, LOCAL_ORIGIN
    frame, alignment = summary.get("position_frame"), summary.get("initialisation")
    if isinstance(frame, dict):
        return frame.get("set_by") == FRAME_UNKNOWN_START and "origin_sigma_m" not in frame
    return (isinstance(alignment, dict) and alignment.get("position_source") == LOCAL_ORIGIN
            and "origin_sigma_m" not in alignment)


#: The summary's ``files`` that hold the run's estimate, in its frame. ``groundtruth_tum`` (the reference) is in it
#: only when the summary says ``groundtruth_in_estimate_frame`` (``graphnav smooth`` writes it so since that key
#: exists; before, in the reference's own frame).
ESTIMATE_FILES = ("trajectory_csv", "trajectory_tum", "online_csv")


def run_frame(path: Path) -> dict:
    """How the run that wrote the trajectory file ``path`` placed its positions, from the summary.json beside it
    when that summary lists the file as one of the estimate's (:data:`ESTIMATE_FILES`; ``graphnav smooth`` /
    ``online`` write one): ``position_frame``
    (:func:`graphnav.core.solution.position_frame`; from a summary written before it, the ``alignment`` the
    frame follows from) and ``n_fixes``, the keys a :class:`NavSolution`'s info holds them in; {} without one.
    For the run's ``groundtruth.tum`` written in its frame, ``position_frame`` only (scored through it, the
    reference is the reference again).
    A trajectory file has no place for them that evo and other readers would still read."""
    summary, listed = _summary_listing(path, warn=True)
    if "groundtruth_tum" in listed and summary.get("groundtruth_in_estimate_frame") and summary.get("position_frame"):
        return {"position_frame": summary["position_frame"]}       # the reference, written in the run's frame
    if not listed & set(ESTIMATE_FILES):
        return {}
    out = {"n_fixes": int((summary.get("drift") or {}).get("fixes_used") or 0), HOLDS_ORIGIN: _holds_origin(summary)}
    if summary.get("position_frame"):
        out["position_frame"] = summary["position_frame"]
    elif isinstance(summary.get("initialisation"), dict):
        out["alignment"] = summary["initialisation"]
    return out


def load_reference(ref: str | Path, config_path: str | Path | None = None,
                   topics: dict[str, str] | None = None) -> GroundTruth:
    """The reference trajectory: a TUM/CSV file, or the ground truth of a mission ``--data`` path."""
    return load_reference_mission(ref, config_path, topics)[0]


def load_reference_mission(ref: str | Path, config_path: str | Path | None = None,
                           topics: dict[str, str] | None = None):
    """(reference :class:`GroundTruth`, the mission it came from or None for a TUM/CSV file). The mission
    (its IMU) is what the velocity NEES carries the reference to the estimate's epochs with, as the
    benchmark does (:func:`graphnav.evaluation.consistency.reference_nees`)."""
    path = Path(ref)
    if path.is_file() and path.suffix.lower() in (".tum", ".txt") or (
            path.suffix.lower() == ".csv" and not (config_path and _has_csv_map(config_path))):
        sol = load_trajectory(path)
        return GroundTruth(sol.t, sol.p_n, sol.v_n, sol.C_b_n, None, str(path)), None
    from graphnav.calibration.preparation import prepare
    from graphnav.io.loaders import read_mission
    mission = prepare(read_mission(path, config_path, topics=topics))
    if mission.gt is None:
        raise DataError("the mission has no reference trajectory (ground truth / reference Odometry topic)",
                        str(path), field="gt")
    return mission.gt, mission


def _has_csv_map(config_path) -> bool:
    from graphnav.core.config import SensorConfig
    return bool(SensorConfig.load(config_path).csv_columns)


def _evo_trajectory(t, p, C, name: str):
    from evo.core.trajectory import PoseTrajectory3D
    q = Rotation.from_matrix(C).as_quat()          # x y z w
    return PoseTrajectory3D(positions_xyz=np.asarray(p, float), orientations_quat_wxyz=q[:, [3, 0, 1, 2]],
                            timestamps=np.asarray(t, float), meta={"name": name})


#: A constant depth difference (m) between estimate and reference above which ``evaluate`` warns that one
#: of them is likely relative to the start rather than the absolute depth.
DEPTH_OFFSET_WARN_M = 2.0


def _warn_depth_offset(dz: np.ndarray, name: str) -> None:
    """Warn when the estimate's depth minus the reference's (``dz``, m) is a near-constant offset of metres."""
    import warnings
    dz = dz[np.isfinite(dz)]
    if dz.size < 2:
        return
    offset, spread = float(np.median(dz)), float(np.std(dz))
    if abs(offset) > DEPTH_OFFSET_WARN_M and spread < 0.25 * abs(offset):
        warnings.warn(f"{name}: the estimate is {offset:+.2f} m deeper than the reference throughout (spread "
                      f"{spread:.2f} m): is one of them a depth relative to the start? graphnav writes and reads "
                      "positions with down = absolute depth; APE includes this offset (--align removes it)",
                      RuntimeWarning, stacklevel=3)


def _stats(metric) -> dict:
    return {k: float(v) for k, v in metric.get_all_statistics().items()}


def evaluate(est: NavSolution, ref: GroundTruth, *, mission=None, align: bool = False, rpe_delta: float = 10.0,
             rpe_unit: str = "m", max_diff_s: float = 0.01) -> dict:
    """APE (translation, m; rotation, deg), RPE (translation, m per ``rpe_delta`` ``rpe_unit``), VRMSE and
    NEES of ``est`` against ``ref``; a dict of plain floats (``None`` where not computable, with the reason).

    Positions on both sides follow :data:`graphnav.core.mission.NED_ORIGIN_CONVENTION` (down = absolute
    depth). ``mission``: the mission ``ref`` belongs to (:func:`load_reference_mission`), for the velocity
    NEES against the IMU-carried reference after the settling time, the benchmark's own score
    (:func:`graphnav.evaluation.consistency.reference_nees`)."""
    _require_evo()
    from evo.core import metrics, sync
    from evo.core.metrics import PoseRelation, Unit
    units = {"m": Unit.meters, "frames": Unit.frames}
    if rpe_unit not in units:
        raise ConfigError(f"rpe unit {rpe_unit!r}: choose m or frames")
    from graphnav.evaluation.consistency import scoring_reference
    from graphnav.evaluation.metrics import align as align_to_reference
    from graphnav.evaluation.metrics import scored
    # The reference (often at another rate, e.g. 1 Hz GT vs keyframes at DVL pings with a time offset) is
    # taken at the estimate's stamps inside its span, so evo's association pairs every epoch: with a mission, the
    # GT carried there by its IMU (the NEES's reference, and the one `smooth` writes to groundtruth.tum), else
    # interpolated.
    poses = ref if mission is None else scoring_reference(est, mission)
    frame_note = _frame_not_applied(est, ref)
    est = scored(est, poses)            # evo's positions are the ones drift and NEES score
    at = align_to_reference(est, poses)
    if not at.mask.any():
        raise DataError(f"no estimate epoch inside the reference span [{poses.t[0]:.3f}, {poses.t[-1]:.3f}] s; are "
                        "both on the mission clock?", est.method, field="t")
    lost = int(np.sum(~(finite_rows(est.p_n[at.mask]) & finite_rows(est.C_b_n[at.mask]))))
    if lost:
        # the estimator lost track: no APE or RPE from the epochs it kept (evo cannot take a non-finite pose)
        note = f"{lost} epoch(s) of the estimate without a finite pose (lost track): no number from part of the run"
        out: dict = {"matched_poses": int(at.mask.sum()), "aligned": bool(align), "ape_translation_m": None,
                     "ape_rotation_deg": None, "ape_note": note, "rpe_translation_m": None, "rpe_note": note}
    else:
        traj_ref = _evo_trajectory(at.t, at.p_true_n, at.C_true_b_n, "reference")
        traj_est = _evo_trajectory(est.t[at.mask], est.p_n[at.mask], est.C_b_n[at.mask], est.method or "estimate")
        try:
            traj_ref, traj_est = sync.associate_trajectories(traj_ref, traj_est, max_diff=max_diff_s)
        except sync.SyncException as exc:
            raise DataError(f"no common stamps with the reference within {max_diff_s} s ({exc}); are both on the "
                            "mission clock?", est.method, field="t") from None
        out = {"matched_poses": int(traj_est.num_poses), "aligned": bool(align)}
        if not align:
            _warn_depth_offset(est.p_n[at.mask, 2] - at.p_true_n[:, 2], est.method)
        if align:
            traj_est.align(traj_ref, correct_scale=False)
        for name, relation in (("ape_translation_m", PoseRelation.translation_part),
                               ("ape_rotation_deg", PoseRelation.rotation_angle_deg)):
            ape = metrics.APE(relation)
            ape.process_data((traj_ref, traj_est))
            out[name] = _stats(ape)
        delta = rpe_delta if rpe_unit == "m" else int(rpe_delta)
        rpe = metrics.RPE(PoseRelation.translation_part, delta=delta, delta_unit=units[rpe_unit], all_pairs=False)
        try:
            rpe.process_data((traj_ref, traj_est))
            out["rpe_translation_m"] = _stats(rpe)
        except metrics.MetricsException as exc:
            out["rpe_translation_m"] = None
            out["rpe_note"] = str(exc)
    out["rpe_delta"] = f"{rpe_delta:g} {rpe_unit}"
    if est.info.get("position_frame"):
        out["position_frame"] = est.info["position_frame"]
    if frame_note:
        out["position_frame_note"] = frame_note
    from graphnav.evaluation.metrics import vrmse
    without = _without_velocities(est, ref)
    if without:
        out["vrmse_mps"] = None
        out["vrmse_note"] = f"needs velocities in the estimate and the reference: {without}"
    else:
        out["vrmse_mps"] = vrmse(est, ref)
        if not np.isfinite(out["vrmse_mps"]):
            lost = int(np.sum(~finite_rows(est.v_n[at.mask])))
            out["vrmse_note"] = f"{lost} epoch(s) of the estimate without a finite velocity (lost track)"
    if est.cov_v_n is None or out["vrmse_mps"] is None:
        out["nees_velocity_mean"] = out["nees_velocity_body_axes"] = None
        out["nees_note"] = (out["vrmse_note"] if without else
                            "needs velocity sigmas in the estimate (trajectory.csv sigma_* columns)")
    else:
        out.update(_nees(est, ref, mission, poses))
    if align:
        # both are frame-dependent: the estimate is in another frame than the reference
        note = "not computed with --align (the estimate is in another frame)"
        out.update(drift_pct_mission=None, end_horizontal_error_m=None, drift_note=note,
                   **{f"nees_{q}_{k}": None for q in ("position", "heading")
                      for k in ("mean", "95pct_band", "n_independent")},
                   nees_position_note=note, nees_heading_note=note)
    else:
        out.update(_drift(est, ref, mission))
        out.update(_pose_nees(est, ref, mission, poses))
        if est.info.get("position_claim_note"):
            out["nees_position_note"] = est.info["position_claim_note"]
    return out


def _without_velocities(est: NavSolution, ref: GroundTruth) -> str | None:
    """Which side has no velocity at all (a TUM file has none; a file whose velocity fields are all empty
    neither), in words; None when both have some."""
    missing = [f"{name} ({source}) has none" for name, source, v_n in (
        ("the estimate", est.method, est.v_n), ("the reference", ref.source, ref.v_n)) if np.all(np.isnan(v_n))]
    return (" and ".join(missing) + " (a TUM file holds no velocities; a file whose velocity fields are all empty "
            "neither)") if missing else None


def _summary_listing(path: Path, warn: bool = False) -> tuple[dict, set]:
    """(the summary.json beside ``path``, the keys of its ``files`` that name ``path``); ({}, set()) without a
    readable one (warned with ``warn``: the file is then scored as if started from the reference)."""
    import json
    summary_path = path.parent / "summary.json"
    if not summary_path.is_file():
        return {}, set()
    try:
        summary = json.loads(summary_path.read_text())
    except (OSError, ValueError) as exc:
        if warn:
            warnings.warn(f"{summary_path}: not read ({exc}); {path.name} is scored as if started from the "
                          "reference", RuntimeWarning, stacklevel=3)
        return {}, set()
    if not isinstance(summary, dict):
        return {}, set()
    return summary, {key for key, f in (summary.get("files") or {}).items() if Path(str(f)).name == path.name}


def _written_in_estimate_frame(ref: GroundTruth) -> bool:
    """True for a run's groundtruth.tum that ``graphnav smooth`` wrote in its estimate's frame (the summary.json
    beside it lists it and says ``groundtruth_in_estimate_frame``): compared as written, nothing is missing."""
    summary, listed = _summary_listing(Path(str(ref.source)))
    return "groundtruth_tum" in listed and bool(summary.get("groundtruth_in_estimate_frame"))


def _frame_not_applied(est: NavSolution, ref: GroundTruth) -> str | None:
    """Why the estimate's positions cannot be put in the reference's frame, warned: its frame is placed on Earth
    (an initial latitude/longitude or a fix) and the reference has no latitude/longitude origin (a TUM or CSV
    file), so both are compared as they are, each from its own origin. None when nothing is missing."""
    from graphnav.core.solution import FRAME_FIRST_FIX, FRAME_FIX_AT_START, FRAME_INITIAL_LLA
    frame = est.info.get("position_frame") or {}
    if ref.origin_lla is not None or frame.get("set_by") not in (FRAME_INITIAL_LLA, FRAME_FIX_AT_START,
                                                                 FRAME_FIRST_FIX) or _written_in_estimate_frame(ref):
        return None
    note = (f"the estimate's positions are placed on Earth ({frame['set_by']}) but the reference {ref.source} has "
            "no latitude/longitude origin: its frame is not applied, the positions are compared as they are "
            "(each from its own origin: right for a reference written in the estimate's frame, as smooth's "
            "groundtruth.tum)")
    warnings.warn(note, RuntimeWarning, stacklevel=3)
    return note


def _settle_t0(est: NavSolution, ref: GroundTruth, mission) -> float:
    """First stamp the NEES scores: the benchmark's settling time after the start, or the whole overlap for
    an estimate too short for it."""
    from graphnav.evaluation.consistency import NEES_SETTLE_S
    t0 = (mission.t0 if mission is not None else float(ref.t[0])) + NEES_SETTLE_S
    if not np.any((est.t >= t0) & (est.t <= ref.t[-1])):
        t0 = float(max(est.t[0], ref.t[0]))          # a short estimate: score it all rather than nothing
    return t0


def _drift(est: NavSolution, ref: GroundTruth, mission=None) -> dict:
    """Mission drift in % of the distance travelled (:func:`graphnav.evaluation.metrics.drift_summary`):
    ``drift_pct_mission``, ``end_horizontal_error_m``, ``distance_travelled_m`` (the reference's),
    ``sigma_h_end_m`` and ``sigma_h_end_pct`` (the estimate's own claim; None without position sigmas), and the
    whole ``drift`` summary (with fixes used, the drift before each stay at the surface)."""
    from graphnav.evaluation.metrics import drift_summary, fix_stamps
    d = drift_summary(est, ref, fix_stamps(mission))
    return {"drift_pct_mission": d["drift_pct"], "end_horizontal_error_m": d["end_error_m"],
            "distance_travelled_m": d["reference_distance_m"], "sigma_h_end_m": d["sigma_h_end_m"],
            "sigma_h_end_pct": d["sigma_h_end_pct"], "drift": d}


def _pose_nees(est: NavSolution, ref: GroundTruth, mission, reference: GroundTruth) -> dict:
    """The benchmark's horizontal position NEES (2 dof) and heading NEES (1 dof) of ``est`` after the settling
    time with their 95 % bands (:func:`graphnav.evaluation.consistency.pose_nees`) against ``reference`` (the
    mission's GT carried to the estimate's stamps, or ``ref``); None (with a note) where the estimate carries
    no position / attitude covariance."""
    from graphnav.evaluation.consistency import HEADING_DOF, POSITION_DOF, chi2_band, pose_nees
    t0 = _settle_t0(est, ref, mission)
    out = {}
    if est.cov_p_n is None and est.cov_rot_b is None:
        scores = {}
    else:
        scores = pose_nees(est, reference, t0)
    for key, name, dof, field in (("nees_pos", "position", POSITION_DOF, "position sigmas"),
                                  ("nees_heading", "heading", HEADING_DOF, "an attitude covariance")):
        mean, n = scores.get(f"{key}_mission"), scores.get(f"{key}_n_independent")
        out[f"nees_{name}_mean"] = mean
        out[f"nees_{name}_95pct_band"] = None if mean is None else list(chi2_band(n, dof))
        out[f"nees_{name}_n_independent"] = n
        out[f"nees_{name}_note"] = (f"needs {field} in the estimate" if mean is None else
                                    f"{dof} dof, after {t0:.1f} s" + _per_epoch(scores[f"{key}_decorrelation_s"])
                                    + _left_out(scores, key, name, name))
    return out


def _nees(est: NavSolution, ref: GroundTruth, mission, reference: GroundTruth) -> dict:
    """The benchmark's velocity NEES (:func:`graphnav.evaluation.consistency.reference_nees`) of ``est``, against
    ``reference`` (as :func:`_pose_nees`)."""
    from graphnav.evaluation.consistency import BODY_AXES, chi2_band, reference_nees
    t0 = _settle_t0(est, ref, mission)
    sigma = None if mission is None else mission.meta.get("gt_velocity_sigma_n")
    scores = reference_nees(est, ref, mission, t0, sigma, reference=reference)
    if scores["nees_mission"] is None:
        return {"nees_velocity_mean": None, "nees_velocity_body_axes": None,
                "nees_note": f"no epoch after {t0:.1f} s with a finite velocity sigma"}
    lo, hi = chi2_band(scores["nees_n_independent"])
    cov = est.cov_v_n[finite_rows(est.cov_v_n)]            # a file's empty sigma rows say nothing of the shape
    diagonal = bool(len(cov)) and bool(np.allclose(cov, np.einsum("kii->ki", cov)[:, :, None] * np.eye(3)))
    return {"nees_velocity_mean": scores["nees_mission"], "nees_velocity_with_gt_error": scores["nees_mission_gt"],
            "nees_velocity_95pct_band": [lo, hi], "nees_n_independent": scores["nees_n_independent"],
            "nees_t0_s": t0, "nees_reference": scores["nees_reference"],
            "nees_velocity_body_axes": (None if scores["nees_axes_b"] is None
                                        else dict(zip(BODY_AXES, scores["nees_axes_b"]))),
            "nees_epochs_without_sigma": scores["nees_epochs_without_sigma"],
            "nees_epochs_lost": scores["nees_epochs_lost"],
            "nees_note": (f"3 dof, after {t0:.1f} s, against the {scores['nees_reference']} reference"
                          + _per_epoch(scores["nees_decorrelation_s"])
                          + ("; diagonal covariance (the trajectory CSV's sigmas, no velocity block in a "
                             "trajectory_cov.csv beside it)" if diagonal else "")
                          + _left_out(scores, "nees", "velocity", "velocity or attitude"))}


def _per_epoch(decorrelation_s) -> str:
    """The band's count, when there is one (a run lost at every epoch has none)."""
    return "" if decorrelation_s is None else f", one independent epoch per {decorrelation_s:.0f} s"


def _left_out(scores: dict, key: str, sigma_of: str, estimate_of: str) -> str:
    """What of the scored epochs has no NEES (:func:`graphnav.evaluation.consistency.reference_nees`'s counts):
    those without a ``sigma_of`` sigma, and those without a finite ``estimate_of`` estimate."""
    text = ""
    if scores.get(f"{key}_epochs_without_sigma"):
        text += f"; {scores[f'{key}_epochs_without_sigma']} epoch(s) without a {sigma_of} sigma left out"
    if scores.get(f"{key}_epochs_lost"):
        text += (f"; {scores[f'{key}_epochs_lost']} epoch(s) without a finite {estimate_of} estimate (lost "
                 "track): no mean from part of the run")
    return text


def _verdict(mean: float, band) -> str:
    """``: <which side, what it means>`` for a mean NEES outside its band
    (:func:`graphnav.evaluation.consistency.outside_band`); "" inside."""
    from graphnav.evaluation.consistency import outside_band
    side = outside_band(mean, band)
    return f": {side}" if side else ""


def format_report(result: dict, est_name: str, ref_name: str) -> str:
    """The evaluation as a few lines of text."""
    from graphnav.core.mission import NED_ORIGIN_CONVENTION
    from graphnav.core.solution import position_frame_line
    lines = [f"{est_name} vs {ref_name}: {result['matched_poses']} matched poses"
             + (" (SE(3)-aligned)" if result["aligned"] else ""),
             f"  positions: {NED_ORIGIN_CONVENTION}"]
    frame = position_frame_line(result.get("position_frame"))
    if frame:
        lines.append(f"  estimate's {frame} (from the run's summary.json)")
    if result.get("position_frame_note"):
        lines.append(f"  frame NOT applied: {result['position_frame_note']}")
    for key, label, unit in (("ape_translation_m", "APE translation", "m"),
                             ("ape_rotation_deg", "APE rotation", "deg"),
                             ("rpe_translation_m", f"RPE translation per {result['rpe_delta']}", "m")):
        s = result.get(key)
        if s:
            lines.append(f"  {label}: rmse {s['rmse']:.4f} {unit}, mean {s['mean']:.4f}, median {s['median']:.4f}, "
                         f"max {s['max']:.4f}")
        elif key == "rpe_translation_m":
            lines.append(f"  {label}: not computed ({result.get('rpe_note')})")
        elif key == "ape_translation_m":
            lines.append(f"  APE: not computed ({result.get('ape_note')})")
    if result["vrmse_mps"] is not None and not np.isfinite(result["vrmse_mps"]):
        lines.append(f"  VRMSE: not finite ({result['vrmse_note']})")
    elif result["vrmse_mps"] is not None:
        lines.append(f"  VRMSE: {result['vrmse_mps']:.4f} m/s")
    else:
        lines.append(f"  VRMSE: not computed ({result['vrmse_note']})")
    from graphnav.calibration.preparation import REFERENCE_NOTE_KEYS
    lines += [f"  note: {result[k]}" for k in REFERENCE_NOTE_KEYS if result.get(k)]
    if result["nees_velocity_mean"] is not None and not np.isfinite(result["nees_velocity_mean"]):
        lines.append(f"  velocity NEES: not finite ({result['nees_note']})")
    elif result["nees_velocity_mean"] is not None:
        lo, hi = result["nees_velocity_95pct_band"]
        lines.append(f"  velocity NEES mean {result['nees_velocity_mean']:.2f} (consistent: 3; 95 % band "
                     f"{lo:.2f}-{hi:.2f} for {result['nees_n_independent']} independent epochs; "
                     f"{result['nees_note']})" + _verdict(result['nees_velocity_mean'], (lo, hi)))
        if result.get("nees_velocity_body_axes"):
            lines.append("  velocity NEES per body axis (consistent: 1): " + ", ".join(
                f"{axis} {value:.2f}" for axis, value in result["nees_velocity_body_axes"].items()))
    else:
        lines.append(f"  velocity NEES: not computed ({result['nees_note']})")
    for name, dof in (("position", 2), ("heading", 1)):
        label = "horizontal position NEES" if name == "position" else "heading NEES"
        mean = result.get(f"nees_{name}_mean")
        if mean is None or not np.isfinite(mean):
            lines.append(f"  {label}: {'-' if mean is None else 'not finite'} "
                         f"({result.get(f'nees_{name}_note', 'not computed')})")
            continue
        lo, hi = result[f"nees_{name}_95pct_band"]
        lines.append(f"  {label} mean {mean:.2f} (consistent: {dof}; 95 % band {lo:.2f}-{hi:.2f} for "
                     f"{result[f'nees_{name}_n_independent']} independent epochs; {result[f'nees_{name}_note']})"
                     + _verdict(mean, (lo, hi)))
    if result.get("drift_note"):
        lines.append(f"  drift in % of distance travelled: - ({result['drift_note']})")
    drift = result.get("drift") or {}
    if drift.get("fixes_used") or drift.get("sigma_h_origin_m") is not None:
        from graphnav.evaluation.metrics import drift_line
        lines.append(f"  {drift_line(drift)}")
    elif result.get("end_horizontal_error_m") is not None:
        pct = result["drift_pct_mission"]
        claim = result.get("sigma_h_end_pct")
        lines.append(f"  drift {'-' if pct is None else f'{pct:.2f}'} % of distance travelled (horizontal error at "
                     f"the end {result['end_horizontal_error_m']:.2f} m over {result['distance_travelled_m']:.1f} m "
                     "travelled by the reference); claimed by the estimate: "
                     + ("-" if result.get("sigma_h_end_m") is None else
                        f"{result['sigma_h_end_m']:.2f} m ({'-' if claim is None else f'{claim:.2f}'} % DT)"))
    return "\n".join(lines)
