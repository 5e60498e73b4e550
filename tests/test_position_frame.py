"""Where a run's positions are on Earth (``info["position_frame"]``) and how a reference scores them: a start
without its position (from the start), a start a later fix placed (through latitude and longitude), and a run
that used fixes (its drift before each stay at the surface)."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.earth import lla_to_ned, ned_to_lla
from graphnav.core.mission import GroundTruth
from graphnav.core.solution import FRAME_FIRST_FIX, FRAME_UNKNOWN_START, LOCAL_ORIGIN, NavSolution, position_frame
from graphnav.evaluation.consistency import pose_nees
from graphnav.evaluation.metrics import drift_line, drift_summary, in_reference_frame, mission_drift

ORIGIN = (np.radians(32.8), np.radians(34.9), 0.0)


def _truth() -> GroundTruth:
    """400 s at 2 m/s: 400 m north, then 400 m east; 10 m deep; in the NED frame at :data:`ORIGIN`."""
    t = np.arange(0.0, 400.01, 1.0)
    north = 2.0 * np.minimum(t, 200.0)
    p = np.c_[north, 2.0 * t - north, 10.0 + 0 * t]
    return GroundTruth(t, p, np.gradient(p, t, axis=0), np.tile(np.eye(3), (len(t), 1, 1)), ORIGIN)


def _estimate(gt: GroundTruth, p_n: np.ndarray, sigma_h: np.ndarray, info: dict) -> NavSolution:
    cov = np.zeros((len(gt.t), 3, 3))
    cov[:, 0, 0] = cov[:, 1, 1] = sigma_h ** 2
    cov[:, 2, 2] = 0.01
    return NavSolution("est", gt.t.copy(), p_n, gt.v_n.copy(), gt.C_b_n.copy(), cov_p_n=cov,
                       cov_rot_b=np.tile(np.eye(3) * 1e-6, (len(gt.t), 1, 1)), info=info)


def _unknown_start(gt: GroundTruth) -> NavSolution:
    """Dead-reckoned from a start 3 m north of the truth's (the unknown origin's error) with a drift growing
    east 1 cm per second; sigma 1 cm/s since the start (the origin's 100 m is the frame's)."""
    drift = np.c_[0 * gt.t, 0.01 * gt.t, 0 * gt.t]
    info = {"alignment": {"position_source": LOCAL_ORIGIN, "origin_sigma_m": 100.0}}
    return _estimate(gt, gt.p_n + [3.0, 0.0, 0.0] + drift, np.maximum(0.01 * gt.t, 1e-3), info)


def test_a_start_without_its_position_counts_its_error_from_the_start():
    # the end error was absolute: the start's 3 m (the origin's) counted as drift, beside a from-start sigma
    gt = _truth()
    sol = _unknown_start(gt)
    m = mission_drift(sol, gt)
    assert m["end_error_m"] == pytest.approx(4.0, abs=1e-9)            # 1 cm/s over 400 s, not |(3, 4)| = 5
    assert m["drift_pct"] == pytest.approx(0.5)
    scores = pose_nees(sol, gt, 60.0)
    assert scores["nees_pos_mission"] == pytest.approx(1.0, abs=1e-6)  # e = (0, 0.01 t), sigma 0.01 t per axis


def test_evaluate_scores_a_written_run_as_its_summary_says_it_started(tmp_path):
    # the written files did not say the start was unknown: evaluate scored 141 m of origin sigma as a drift
    from graphnav.io.outputs import write_json, write_trajectory_csv, write_tum
    gt = _truth()
    sol = _unknown_start(gt)
    write_trajectory_csv(tmp_path / "run" / "trajectory.csv", sol)
    write_tum(tmp_path / "gt.tum", NavSolution("GT", gt.t, gt.p_n, gt.v_n, gt.C_b_n))
    frame = position_frame(sol.info)
    assert frame["set_by"] == FRAME_UNKNOWN_START
    write_json(tmp_path / "run" / "summary.json", {"position_frame": frame, "drift": {"fixes_used": 0},
                                                   "files": {"trajectory_csv": "run/trajectory.csv"}})
    assert cli.main(["evaluate", str(tmp_path / "run" / "trajectory.csv"), "--ref", str(tmp_path / "gt.tum"),
                     "--json", str(tmp_path / "ev.json")]) == 0
    res = json.loads((tmp_path / "ev.json").read_text())
    assert res["end_horizontal_error_m"] == pytest.approx(4.0, abs=1e-4)
    assert res["sigma_h_end_pct"] == pytest.approx(np.hypot(4.0, 4.0) / 8.02, rel=1e-3)  # 5.66 m, the estimate's 802 m
    assert res["nees_position_mean"] == pytest.approx(1.0, rel=1e-3)
    assert res["position_frame"]["set_by"] == FRAME_UNKNOWN_START
    # a summary that does not list the file says nothing about it
    write_json(tmp_path / "run" / "summary.json", {"position_frame": frame, "files": {"other": "x.csv"}})
    assert cli.main(["evaluate", str(tmp_path / "run" / "trajectory.csv"), "--ref", str(tmp_path / "gt.tum"),
                     "--json", str(tmp_path / "ev.json")]) == 0
    assert json.loads((tmp_path / "ev.json").read_text())["end_horizontal_error_m"] == pytest.approx(5.0, abs=1e-4)


def _placed_by_a_fix(gt: GroundTruth, k_fix: int = 100) -> NavSolution:
    """Started without its position, placed by a fix at epoch ``k_fix``: the NED frame at the fix's latitude and
    longitude, offset so that the fix sits at the dead-reckoned position there (``_Aided.fix_ne``)."""
    dead_reckoned = gt.p_n - gt.p_n[0] + [0.0, 0.0, gt.p_n[0, 2]]       # from a local origin at the start
    fix_lla = ned_to_lla(gt.p_n[k_fix:k_fix + 1] * [1, 1, 0], ORIGIN)[0]
    origin = (fix_lla[0], fix_lla[1], 0.0)
    info = {"alignment": {"position_source": LOCAL_ORIGIN}, "n_fixes": 1}
    info["position_frame"] = position_frame(info, origin, dead_reckoned[k_fix, :2], float(gt.t[k_fix]))
    sigma = np.where(gt.t < gt.t[k_fix], 100.0, 1.0)
    return _estimate(gt, dead_reckoned, sigma, info)


def test_a_start_placed_by_a_fix_is_scored_through_latitude_and_longitude():
    gt = _truth()
    gt.p_n[:, :2] += [250.0, -120.0]                  # the truth's own origin is elsewhere
    sol = _placed_by_a_fix(gt)
    assert sol.info["position_frame"]["set_by"] == FRAME_FIRST_FIX and not sol.origin_unknown
    # within the few mm by which two tangent planes 300 m apart differ over 400 m
    np.testing.assert_allclose(in_reference_frame(sol, gt).p_n, gt.p_n, atol=0.01)
    assert mission_drift(sol, gt)["end_error_m"] < 0.01  # was the frame shift, 277 m
    assert pose_nees(sol, gt, 150.0)["nees_pos_mission"] < 1e-4
    # the position is placed: no "unknown start" in what the summary claims, and lat/lon come back from the frame
    line = drift_line(drift_summary(sol))
    assert "unknown start" not in line and "after 1 position fixes" in line
    frame = sol.info["position_frame"]
    lla = ned_to_lla(sol.p_n[-1:] - [*frame["offset_ne_m"], 0.0],
                     (np.radians(frame["origin_lat_deg"]), np.radians(frame["origin_lon_deg"]), 0.0))
    np.testing.assert_allclose(lla_to_ned(lla[:, 0], lla[:, 1], lla[:, 2], ORIGIN)[0, :2], gt.p_n[-1, :2], atol=0.01)


def test_the_navigator_exports_the_frame_its_first_fix_placed():
    from graphnav.estimators.align import AlignOptions
    from graphnav.estimators.runs import run_graph
    from graphnav.sim.simulate import SurfacingProfile, simulate_mission
    m = simulate_mission(160.0, seed=4, surfacing=SurfacingProfile(interval_s=60.0, stay_s=10.0))
    yaw0 = float(np.arctan2(m.gt.C_b_n[0, 1, 0], m.gt.C_b_n[0, 0, 0]))
    sol = run_graph(m, init="sensors", backend="fixed-lag", align=AlignOptions(initial_heading_rad=yaw0))
    frame = sol.info["position_frame"]
    assert frame["set_by"] == FRAME_FIRST_FIX and frame["first_fix_t_s"] == pytest.approx(m.fixes.t[0], abs=1.0)
    k = int(np.searchsorted(sol.t, frame["first_fix_t_s"]))
    np.testing.assert_allclose(frame["offset_ne_m"], sol.p_n[k, :2], atol=1.0)   # the dead-reckoned position
    assert not sol.origin_unknown
    # scored through the frame, the error is the navigation's (metres), not the start's unknown offset
    assert mission_drift(sol, m.gt)["end_error_m"] < 1.5              # 0.39 m; 6.21 m without the frame


def test_with_fixes_the_summary_reports_the_drift_before_each_stay_at_the_surface():
    gt = _truth()
    t_fix = np.r_[np.arange(150.0, 160.0), np.arange(300.0, 310.0)]     # two stays at the surface
    # the error grows 1 cm/s east and a fix resets it (the estimate is the truth at each fix)
    since = gt.t - np.where(gt.t >= 310.0, 310.0, np.where(gt.t >= 160.0, 160.0, 0.0))
    since[(gt.t >= 150.0) & (gt.t < 160.0) | (gt.t >= 300.0) & (gt.t < 310.0)] = 0.0
    sol = _estimate(gt, gt.p_n + np.c_[0 * since, 0.01 * since, 0 * since], 0.01 * since + 0.5,
                    {"n_fixes": len(t_fix)})
    d = drift_summary(sol, gt, t_fix)
    stays = d["drift_before_fixes"]
    assert [s["t"] for s in stays] == [149.0, 299.0]
    assert stays[0]["error_m"] == pytest.approx(1.49) and stays[0]["distance_m"] == pytest.approx(298.0)
    assert stays[1]["error_m"] == pytest.approx(1.39) and stays[1]["distance_m"] == pytest.approx(280.0)
    assert stays[1]["drift_pct"] == pytest.approx(1.39 / 2.8)          # since the last fix, at 159 s
    # the JSON says what the line says: no whole-mission drift or claimed % DT, bounded by the last fix
    assert d["drift_pct"] is None and d["sigma_h_end_pct"] is None and d["end_error_m"] == pytest.approx(0.9)
    line = drift_line(d)
    assert "bounded by the last fix, not a drift" in line and "0.50 % DT (1.39 m over 280.0 m)" in line


def test_the_epochs_before_the_fix_that_placed_the_frame_are_counted_from_the_start():
    # Before its first fix the run's start was unknown: those epochs' error counts from the start, the later ones'
    # through the frame (a 3 m start error scored as 3 m of error before the fix)
    from graphnav.evaluation.metrics import scored
    gt = _truth()
    k_fix = 200
    drift = np.c_[0 * gt.t, 0.01 * gt.t, 0 * gt.t]
    p_n = gt.p_n + drift + np.where(gt.t[:, None] < gt.t[k_fix], [3.0, 0.0, 0.0], 0.0)
    info = {"alignment": {"position_source": LOCAL_ORIGIN, "origin_sigma_m": 100.0}, "n_fixes": 10}
    info["position_frame"] = position_frame(info, ORIGIN, (0.0, 0.0), float(gt.t[k_fix]))
    sol = _estimate(gt, p_n, np.maximum(0.01 * gt.t, 1e-3), info)
    error = scored(sol, gt).p_n[:, :2] - gt.p_n[:, :2]
    np.testing.assert_allclose(error[:k_fix], drift[:k_fix, :2], atol=1e-9)
    np.testing.assert_allclose(error[k_fix:], drift[k_fix:, :2], atol=1e-9)


def test_every_position_number_of_a_run_goes_through_its_frame(tmp_path):
    # the final horizontal error, the bench's window drift and evo's APE took the positions as written: 277 m
    from graphnav.evaluation.metrics import horizontal_position_error, horizontal_position_rmse, window_drift
    from graphnav.evaluation.score import evaluate
    gt = _truth()
    gt.p_n[:, :2] += [250.0, -120.0]
    sol = _placed_by_a_fix(gt)
    assert horizontal_position_error(sol, gt) < 0.01
    assert horizontal_position_rmse(sol, gt, 150.0) < 0.01
    assert window_drift(sol, gt, 50.0, 150.0)["drift_m"] < 0.01
    res = evaluate(sol, gt)
    assert res["ape_translation_m"]["rmse"] < 0.01
    assert res["end_horizontal_error_m"] == pytest.approx(res["ape_translation_m"]["max"], abs=0.01)


def test_a_reference_without_an_origin_says_the_frame_is_not_applied(tmp_path):
    # the frame line was printed as if applied while the TUM reference, without latitude/longitude, skipped it
    from graphnav.evaluation.score import evaluate, format_report
    gt = _truth()
    gt.p_n[:, :2] += [250.0, -120.0]
    sol = _placed_by_a_fix(gt)
    tum = GroundTruth(gt.t, gt.p_n, gt.v_n, gt.C_b_n, None, "gt.tum")
    with pytest.warns(RuntimeWarning, match="no latitude/longitude origin"):
        res = evaluate(sol, tum)
    assert "frame NOT applied" in format_report(res, "est", "gt.tum")
    assert evaluate(sol, gt).get("position_frame_note") is None
    # the run's own groundtruth.tum, written in its frame (its summary says so), is compared as written, unwarned
    from graphnav.io.outputs import write_json
    (tmp_path / "run").mkdir()
    write_json(tmp_path / "run" / "summary.json", {"files": {"groundtruth_tum": "run/groundtruth.tum"},
                                                   "groundtruth_in_estimate_frame": True})
    written = GroundTruth(gt.t, gt.p_n, gt.v_n, gt.C_b_n, None, str(tmp_path / "run" / "groundtruth.tum"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert evaluate(sol, written).get("position_frame_note") is None


def test_groundtruth_tum_is_written_in_the_estimate_frame(tmp_path):
    # groundtruth.tum held the reference in its own frame: evo_ape compared positions 277 m apart
    from graphnav.evaluation.metrics import frame_shift
    from graphnav.io.outputs import read_tum, write_reference_tum
    gt = _truth()
    gt.p_n[:, :2] += [250.0, -120.0]
    sol = _placed_by_a_fix(gt)
    _, p, _ = read_tum(write_reference_tum(tmp_path / "groundtruth.tum", sol, gt, frame_shift(sol, gt)))
    np.testing.assert_allclose(p, sol.p_n, atol=0.01)
    started_from_gt = NavSolution("est", gt.t, gt.p_n + 0.5, gt.v_n, gt.C_b_n)
    _, p, _ = read_tum(write_reference_tum(tmp_path / "gt2.tum", started_from_gt, gt, frame_shift(started_from_gt, gt)))
    np.testing.assert_allclose(p, gt.p_n, atol=1e-6)


def test_the_run_frame_applies_to_the_estimate_files_only(tmp_path):
    # evaluate X/groundtruth.tum put the reference through the estimate's frame: APE 0 m beside an end error of 68 m
    from graphnav.evaluation.score import run_frame
    from graphnav.io.outputs import write_json
    gt = _truth()
    frame = _placed_by_a_fix(gt).info["position_frame"]
    files = {"trajectory_csv": "run/trajectory.csv", "groundtruth_tum": "run/groundtruth.tum"}
    write_json(tmp_path / "summary.json", {"position_frame": frame, "files": files})
    assert run_frame(tmp_path / "trajectory.csv")["position_frame"] == frame
    assert run_frame(tmp_path / "groundtruth.tum") == {}
    # smooth now writes its groundtruth.tum in the run's frame, and says so: the frame takes it back to the reference's
    write_json(tmp_path / "summary.json", {"position_frame": frame, "files": files,
                                           "groundtruth_in_estimate_frame": True})
    assert run_frame(tmp_path / "groundtruth.tum") == {"position_frame": frame}


def test_a_run_written_before_the_frame_is_not_scored_from_the_start(tmp_path):
    # its covariance holds the unknown start's 100 m per axis: scored from the start it claimed 141 m, NEES 0.00
    from graphnav.io.outputs import write_json, write_trajectory_csv, write_tum
    gt = _truth()
    sol = _unknown_start(gt)
    sol.cov_p_n[:, :2, :2] += np.eye(2) * 100.0 ** 2
    write_trajectory_csv(tmp_path / "run" / "trajectory.csv", sol)
    write_tum(tmp_path / "gt.tum", NavSolution("GT", gt.t, gt.p_n, gt.v_n, gt.C_b_n))
    write_json(tmp_path / "run" / "summary.json", {"initialisation": {"position_source": LOCAL_ORIGIN},
                                                   "files": {"trajectory_csv": "run/trajectory.csv"}})
    with pytest.warns(RuntimeWarning, match="written before the position frame"):
        assert cli.main(["evaluate", str(tmp_path / "run" / "trajectory.csv"), "--ref", str(tmp_path / "gt.tum"),
                         "--json", str(tmp_path / "ev.json")]) == 0
    res = json.loads((tmp_path / "ev.json").read_text())
    assert res["sigma_h_end_m"] is None and res["nees_position_mean"] is None
    assert "cannot be scored from the start" in res["nees_position_note"]
    assert res["end_horizontal_error_m"] == pytest.approx(4.0, abs=1e-4)       # the error is still from the start


def test_a_first_fix_far_from_a_given_start_is_warned_about():
    # A start given 55 m off was pulled onto the fixes without a word (about 10 of its 5 m sigmas)
    from graphnav.core.earth import ned_to_lla
    from graphnav.estimators.align import AlignOptions
    from graphnav.estimators.runs import run_graph
    from graphnav.sim.simulate import SurfacingProfile, default_config, simulate_mission
    m = simulate_mission(600.0, "navigation", 1, config=default_config(), surfacing=SurfacingProfile(interval_s=300))
    p0 = m.gt.at(np.array([m.imu.t[0]]))[0][0]
    for north, warned in ((0.0, False), (55.0, True)):
        lla = ned_to_lla(np.array([[p0[0] + north, p0[1], 0.0]]), m.gt.origin_lla)[0]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = run_graph(m, backend="fixed-lag", init="sensors",
                            align=AlignOptions(initial_lla=(lla[0], lla[1], 0.0)))
        assert any("first position fix" in str(w.message) for w in caught) == warned
        assert (sol.info["first_fix_departure_sigmas"] > 5.0) == warned


def test_groundtruth_tum_carries_the_frame_across_a_lost_estimate(tmp_path):
    # at epochs without a finite estimate the shift into its frame was written as zero: the reference jumped by the
    # frame's offset (250 m here) for as long as the estimate was lost
    from graphnav.evaluation.metrics import frame_shift
    from graphnav.io.outputs import read_tum, write_reference_tum
    gt = _truth()
    gt.p_n[:, :2] += [250.0, -120.0]
    for sol in (_unknown_start(gt), _placed_by_a_fix(gt)):
        _, whole, _ = read_tum(write_reference_tum(tmp_path / "whole.tum", sol, gt, frame_shift(sol, gt)))
        sol.p_n[95:106] = np.nan                   # lost across the fix that placed the frame (epoch 100)
        sol.p_n[300:311] = np.nan
        sol.p_n[-5:] = np.nan
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            t, lost, _ = read_tum(write_reference_tum(tmp_path / "lost.tum", sol, gt, frame_shift(sol, gt)))
        assert len(t) == len(gt.t)
        np.testing.assert_allclose(lost, whole, atol=1e-3)      # the tangent planes differ by a mm
    # no finite estimate before the fix: the frame there is unknown, so those rows are left out, warned and counted
    sol.p_n[:100] = np.nan
    with pytest.warns(RuntimeWarning, match="100 epoch"):
        t, p, _ = read_tum(write_reference_tum(tmp_path / "late.tum", sol, gt, frame_shift(sol, gt)))
    np.testing.assert_allclose(t, gt.t[100:])
    np.testing.assert_allclose(p, whole[100:], atol=1e-3)
