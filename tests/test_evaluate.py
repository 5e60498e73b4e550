"""`graphnav evaluate`: APE/RPE from evo's library beside VRMSE and NEES, against a TUM file or a mission."""
from __future__ import annotations

import json

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.errors import DataError
from graphnav.evaluation.metrics import nees_velocity, vrmse
from graphnav.io import bags
from graphnav.io.outputs import read_trajectory_csv
from graphnav.sim.simulate import simulate_mission


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    root = tmp_path_factory.mktemp("evaluate")
    mission = simulate_mission(duration_s=60.0, seed=2)
    mission.config.save(root / "config.json")
    bag = bags.write_mission_bag(mission, root / "mission_bag")
    out = root / "smooth"
    assert cli.main(["smooth", "--data", str(bag), "--config", str(root / "config.json"), "--method", "Graph-TC",
                     "--scenario", "2-missing", "--window-start", "20", "--out", str(out), "--no-plots"]) == 0
    return mission, root, out


def test_against_tum_and_mission_reference(run, capsys):
    mission, root, out = run
    sol = read_trajectory_csv(out / "trajectory.csv")
    p_ref, v_ref, _ = mission.gt.at(sol.t)
    ape_rmse = float(np.sqrt(np.mean(np.sum((sol.p_n - p_ref) ** 2, axis=1))))
    # TUM reference: poses only, so APE/RPE and no VRMSE/NEES.
    assert cli.main(["evaluate", str(out / "trajectory.csv"), "--ref", str(out / "groundtruth.tum"),
                     "--json", str(root / "tum.json")]) == 0
    tum = json.loads((root / "tum.json").read_text())
    assert tum["matched_poses"] == len(sol.t)
    assert tum["ape_translation_m"]["rmse"] == pytest.approx(ape_rmse, rel=1e-6)
    assert tum["rpe_translation_m"]["rmse"] > 0 and tum["vrmse_mps"] is None
    # the estimate has its velocity sigmas: the velocity NEES is missing for the reference's want of velocities
    assert tum["nees_velocity_mean"] is None and "sigmas" not in tum["nees_note"]
    assert f"the reference ({out / 'groundtruth.tum'}) has none" in tum["nees_note"]
    assert "the estimate" not in tum["nees_note"].split(":")[1]
    # Mission (bag) reference: its ground truth has velocities, so VRMSE and NEES too.
    assert cli.main(["evaluate", str(out / "trajectory.csv"), "--ref", str(root / "mission_bag"),
                     "--config", str(root / "config.json"), "--json", str(root / "bag.json")]) == 0
    res = json.loads((root / "bag.json").read_text())
    assert res["ape_translation_m"]["rmse"] == pytest.approx(ape_rmse, rel=1e-6)
    assert res["vrmse_mps"] == pytest.approx(vrmse(sol, mission.gt), rel=1e-9)
    summary = json.loads((out / "summary.json").read_text())
    assert res["vrmse_mps"] == pytest.approx(summary["accuracy"]["vrmse_mission_mps"], rel=1e-4)
    # the benchmark's NEES, by the benchmark's function, on the same settle time and reference
    from graphnav.evaluation.consistency import reference_nees
    from graphnav.evaluation.score import load_trajectory
    bench = reference_nees(load_trajectory(out / "trajectory.csv"), mission.gt, mission, res["nees_t0_s"], None)
    assert res["nees_velocity_mean"] == pytest.approx(bench["nees_mission"], rel=1e-9)
    # with the full velocity covariance of trajectory_cov.csv: smooth's own number, not the sigmas' one
    assert res["nees_velocity_mean"] == pytest.approx(summary["accuracy"]["consistency"]["velocity"]["nees"], rel=1e-6)
    assert res["nees_reference"] == "imu-carried"
    assert res["nees_velocity_mean"] != pytest.approx(float(np.mean(nees_velocity(sol, mission.gt))), rel=1e-6)
    # drift in % of distance travelled: the metrics' own numbers; NEES of what the CSV carries, else "-"
    from graphnav.evaluation.metrics import mission_drift
    drift = mission_drift(sol, mission.gt)
    assert res["drift_pct_mission"] == pytest.approx(drift["drift_pct"], rel=1e-9)
    assert res["end_horizontal_error_m"] == pytest.approx(drift["end_error_m"], rel=1e-9)
    assert res["distance_travelled_m"] == pytest.approx(drift["distance_m"], rel=1e-9)
    text = capsys.readouterr().out
    assert "APE translation" in text and "RPE translation per 10 m" in text and "velocity NEES" in text
    assert f"drift {drift['drift_pct']:.2f} % of distance travelled" in text
    if sol.cov_p_n is None:
        assert res["nees_position_mean"] is None and "horizontal position NEES: - (needs position sigmas" in text
    else:
        assert res["nees_position_mean"] > 0 and "horizontal position NEES mean" in text
    # the smooth summary of the same run: distance from the estimate, % DT against the mission's reference
    assert summary["drift"]["drift_pct"] == pytest.approx(drift["drift_pct"], rel=1e-3)
    assert summary["drift"]["distance_m"] > 0.5 * drift["distance_m"]


def test_pose_nees_and_drift_of_known_errors_and_the_position_plot(tmp_path, capsys):
    """An estimate 1 m north and 2 m east of the truth with position sigmas 1 m / 2 m scores a horizontal
    position NEES of exactly 2; a heading 1 deg off with a 0.5 deg sigma a heading NEES of 4; --plots draws
    the error with its 2-sigma sleeve."""
    from graphnav.core.mission import GroundTruth
    from graphnav.core.rotations import euler_to_C_b_n
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.plots import plot_position_error
    from graphnav.evaluation.score import evaluate, format_report
    t = np.arange(0.0, 200.01, 1.0)
    zero = np.zeros_like(t)
    yaw = np.deg2rad(179.5) + zero                                           # the estimate wraps to -179.5
    north = np.minimum(t, 100.0)                                               # 150 m south, then 150 m east
    p = np.c_[-1.5 * north, 1.5 * (t - north), 10 + zero]
    gt = GroundTruth(t, p, np.gradient(p, t, axis=0), euler_to_C_b_n(zero, zero, yaw))
    C_est = euler_to_C_b_n(zero, zero, yaw + np.deg2rad(1.0))
    est = NavSolution("est", t, gt.p_n + [1.0, 2.0, 0.0], gt.v_n, C_est,
                      cov_p_n=np.tile(np.diag([1.0, 4.0, 0.01]), (len(t), 1, 1)),
                      cov_rot_b=np.tile(np.diag([1e-4, 1e-4, np.deg2rad(0.5) ** 2]), (len(t), 1, 1)))
    res = evaluate(est, gt)
    assert res["nees_position_mean"] == pytest.approx(2.0, rel=1e-9)
    assert res["nees_heading_mean"] == pytest.approx(4.0, rel=1e-9)
    assert res["nees_position_95pct_band"][0] < 2.0 < res["nees_position_95pct_band"][1]
    assert res["nees_heading_95pct_band"][1] < 4.0                            # a constant error: one epoch
    assert res["end_horizontal_error_m"] == pytest.approx(np.sqrt(5.0))
    assert res["distance_travelled_m"] == pytest.approx(300.0)
    assert res["drift_pct_mission"] == pytest.approx(np.sqrt(5.0) / 3.0)
    assert res["sigma_h_end_m"] == pytest.approx(np.sqrt(5.0))
    text = format_report(res, "est", "gt")
    assert "horizontal position NEES mean 2.00 (consistent: 2" in text and "heading NEES mean 4.00" in text
    assert "drift 0.75 % of distance travelled" in text
    aligned = evaluate(est, gt, align=True)
    assert aligned["nees_position_mean"] is None and aligned["drift_pct_mission"] is None
    assert "not computed with --align" in format_report(aligned, "est", "gt")
    est.cov_p_n[:10] = np.nan                                                  # rows a file left empty
    path = plot_position_error(gt, [est, NavSolution("no-cov", t, gt.p_n + 0.5, gt.v_n, gt.C_b_n)], [],
                               tmp_path / "position_error.png", "test")
    assert path.exists() and path.stat().st_size > 10000


def test_empty_sigma_rows_are_left_out_and_a_lost_estimate_is_said(run, tmp_path, capsys):
    """A trajectory CSV with empty velocity-sigma fields: the NEES of the other epochs, and how many were left out;
    with empty velocity fields (the estimator lost track): no VRMSE or velocity NEES from the rest, and why."""
    mission, root, out = run
    lines = (out / "trajectory.csv").read_text().splitlines()[:56]    # ends before 60 s: every epoch is scored
    header = lines[0].split(",")

    def blank(columns, rows):
        idx = [header.index(c) for c in columns]
        body = []
        for k, line in enumerate(lines[1:]):
            fields = line.split(",")
            for i in idx if k in rows else ():
                fields[i] = ""
            body.append(",".join(fields))
        path = tmp_path / f"{columns[0]}.csv"
        path.write_text("\n".join([lines[0], *body]) + "\n")
        return str(path)
    ref = ["--ref", str(root / "mission_bag"), "--config", str(root / "config.json")]
    sigmas = blank(["sigma_v_north_mps", "sigma_v_east_mps", "sigma_v_down_mps"], range(30, 35))
    assert cli.main(["evaluate", sigmas, *ref]) == 0
    text = capsys.readouterr().out
    assert "5 epoch(s) without a velocity sigma left out" in text and "velocity NEES mean" in text
    lost = blank(["v_north_mps", "v_east_mps", "v_down_mps"], range(30, 32))
    cli.main(["evaluate", lost, *ref])
    text = capsys.readouterr().out
    assert "VRMSE: not finite (2 epoch(s) of the estimate without a finite velocity (lost track))" in text
    assert "velocity NEES: not finite" in text and "2 epoch(s) without a finite velocity or attitude estimate" in text
    lost_attitude = blank(["roll_rad", "pitch_rad", "yaw_rad"], range(30, 33))   # read back: no SVD failure
    assert cli.main(["evaluate", lost_attitude, *ref]) == 0
    text = capsys.readouterr().out
    assert "3 epoch(s) without a finite velocity or attitude estimate" in text and "APE: not computed" in text
    lost_pose = blank(["p_north_m", "p_east_m"], range(30, 33))       # evo cannot take them: no APE, and why
    assert cli.main(["evaluate", lost_pose, *ref]) == 0
    text = capsys.readouterr().out
    assert "APE: not computed (3 epoch(s) of the estimate without a finite pose (lost track)" in text
    assert "horizontal position NEES: not finite" in text and "VRMSE: 0." in text


def test_evaluate_plots_option_writes_the_position_error_figure(run, tmp_path):
    mission, root, out = run
    assert cli.main(["evaluate", str(out / "trajectory.csv"), "--ref", str(out / "groundtruth.tum"),
                     "--plots", str(tmp_path / "figs")]) == 0
    assert (tmp_path / "figs" / "position_error.png").stat().st_size > 10000
    (tmp_path / "afile").write_text("x")
    assert cli.main(["evaluate", str(out / "trajectory.csv"), "--ref", str(out / "groundtruth.tum"),
                     "--plots", str(tmp_path / "afile")]) != 0


def test_aligned_ape_removes_a_frame_offset(run, tmp_path):
    from graphnav.core.mission import GroundTruth
    from graphnav.evaluation.score import evaluate, load_trajectory
    mission, _, out = run
    sol = load_trajectory(out / "trajectory.csv")
    g = mission.gt
    shifted = GroundTruth(g.t, g.p_n + [100.0, -50.0, 3.0], g.v_n, g.C_b_n)
    with pytest.warns(RuntimeWarning, match="deeper than the reference"):
        raw = evaluate(sol, shifted)
    aligned = evaluate(sol, shifted, align=True)
    assert raw["ape_translation_m"]["rmse"] > 100
    assert aligned["ape_translation_m"]["rmse"] < 2.0
    with pytest.raises(DataError, match="mission clock"):
        evaluate(sol, GroundTruth(g.t + 1e4, g.p_n, g.v_n, g.C_b_n))


def _akit_mission(tmp_path):
    """A 60 s simulated mission written in the A-KIT layout (GT at 10 Hz, pings 0.37 s off the GT stamps)
    and loaded back through the A-KIT loader with its own config."""
    from graphnav.io.export import write_akit
    from graphnav.missions import load_mission
    sim = simulate_mission(60.0, seed=3, dvl_stamp_offset_s=0.37)
    paths = write_akit(sim, tmp_path)
    folder = paths["IMU"].parent
    return sim, folder, paths["config"], load_mission(folder, paths["config"])


def test_akit_reference_has_absolute_depth_and_a_known_offset_is_recovered(tmp_path, capsys):
    """One position convention: the A-KIT GT's down is the absolute depth (origin at the surface above the
    first fix), so an estimate equal to the truth plus a known offset scores exactly that offset."""
    from graphnav.core.solution import NavSolution
    from graphnav.io.outputs import write_trajectory_csv
    sim, folder, config, loaded = _akit_mission(tmp_path)
    assert loaded.gt.origin_lla[2] == 0.0
    # absolute depth (the GT moved from the published GT point to the IMU's, a few decimetres)
    np.testing.assert_allclose(loaded.gt.p_n[:, 2], sim.gt.p_n[:, 2], atol=0.5)
    assert sim.gt.p_n[0, 2] > 1.0 and sim.gt.p_n[:, 2].max() > 5.0
    np.testing.assert_allclose(loaded.depth.depth, loaded.gt.p_n[:, 2])
    # origin above the first fix of the published GT point, 1.9 m forward of the IMU
    assert np.linalg.norm(loaded.gt.p_n[0, :2]) < 2.0
    offset = np.array([3.0, -4.0, 1.5])
    t = loaded.dvl.t[(loaded.dvl.t > loaded.gt.t[0]) & (loaded.dvl.t < loaded.gt.t[-1])]
    p, v, C = loaded.gt.at(t)
    write_trajectory_csv(tmp_path / "est.csv", NavSolution("est", t, p + offset, v, C))
    assert cli.main(["evaluate", str(tmp_path / "est.csv"), "--ref", str(folder), "--config", str(config),
                     "--json", str(tmp_path / "res.json")]) == 0
    res = json.loads((tmp_path / "res.json").read_text())
    assert res["ape_translation_m"]["rmse"] == pytest.approx(np.linalg.norm(offset), abs=1e-3)
    assert res["ape_translation_m"]["max"] == pytest.approx(np.linalg.norm(offset), abs=1e-3)
    from graphnav.evaluation.metrics import horizontal_distance
    assert res["end_horizontal_error_m"] == pytest.approx(5.0, abs=1e-3)          # the injected 3 m N, -4 m E
    distance = horizontal_distance(loaded.gt.t, loaded.gt.p_n, t[0], t[-1])
    assert res["drift_pct_mission"] == pytest.approx(5.0 / distance * 100, rel=1e-3)
    assert "down = absolute depth" in capsys.readouterr().out


def test_a_depth_relative_to_the_start_is_warned(tmp_path):
    from graphnav.core.mission import GroundTruth
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.score import evaluate
    sim = simulate_mission(30.0, seed=4)
    g = sim.gt
    # a vehicle at 15 m more depth than this start, scored against a depth relative to its start
    deep = g.p_n + [0.0, 0.0, 15.0]
    relative = GroundTruth(g.t, deep - deep[0] * [0, 0, 1], g.v_n, g.C_b_n)
    with pytest.warns(RuntimeWarning, match="relative to the start"):
        res = evaluate(NavSolution("est", g.t, deep, g.v_n, g.C_b_n), relative)
    assert res["ape_translation_m"]["rmse"] == pytest.approx(deep[0, 2], rel=1e-6)


def test_smooth_tum_pair_works_with_evo_ape_at_its_defaults(tmp_path):
    """`evo_ape tum groundtruth.tum trajectory.tum` (evo's own CLI, default options) pairs every estimate
    epoch and reports the APE graphnav computes, on an A-KIT layout whose GT stamps are not the pings'."""
    import subprocess
    import sys
    from pathlib import Path
    evo_ape = Path(sys.executable).parent / "evo_ape"
    if not evo_ape.exists():
        pytest.skip("evo's CLI (evo_ape) is not installed: pip install 'graphnav[eval]'")
    sim, folder, config, loaded = _akit_mission(tmp_path)
    out = tmp_path / "smooth"
    assert cli.main(["smooth", "--data", str(folder), "--config", str(config), "--method", "Graph-TC",
                     "--out", str(out), "--no-plots"]) == 0
    est = read_trajectory_csv(out / "trajectory.csv")
    gt_t = np.loadtxt(out / "groundtruth.tum")[:, 0]
    inside = (est.t >= loaded.gt.t[0]) & (est.t <= loaded.gt.t[-1])
    np.testing.assert_allclose(gt_t, est.t[inside], atol=1e-6)   # TUM 1e-9 s, the CSV 1e-6 s
    assert not np.isin(np.round(est.t, 6), np.round(loaded.gt.t, 6)).any()        # pings are off the GT stamps
    home = tmp_path / "home"                 # evo keeps its settings in ~/.evo: a fresh one = evo's defaults
    home.mkdir()
    run = subprocess.run([str(evo_ape), "tum", str(out / "groundtruth.tum"), str(out / "trajectory.tum")],
                         capture_output=True, text=True, timeout=120,
                         env={"HOME": str(home), "PATH": str(evo_ape.parent), "MPLBACKEND": "Agg"})
    assert run.returncode == 0, run.stdout + run.stderr
    stats = dict(line.split() for line in run.stdout.splitlines()
                 if line.split() and line.split()[0] in ("rmse", "max", "mean"))
    p_ref, _, _ = loaded.gt.at(est.t[inside])
    rmse = float(np.sqrt(np.mean(np.sum((est.p_n[inside] - p_ref) ** 2, axis=1))))
    assert float(stats["rmse"]) == pytest.approx(rmse, rel=1e-4)
    assert rmse < 5.0                  # absolute depth on both sides: metres, not the start depth


def test_the_reference_tum_is_the_reference_the_nees_is_scored_against(tmp_path):
    """With a 1 Hz GT and pings between its samples, `smooth`'s groundtruth.tum holds the GT carried to the pings
    by the IMU, the reference of its own NEES: `evaluate` against the TUM file gives the heading NEES it gives
    against the mission. (It held the GT interpolated between its samples: on A-KIT Trajectory1 0.5 deg off in roll
    and 0.2 deg in heading, heading NEES 16.4 against 0.01.)"""
    from graphnav.io.export import write_akit
    sim = simulate_mission(duration_s=120.0, seed=3, gt_rate_hz=1.0, dvl_stamp_offset_s=0.3700004)
    folder = write_akit(sim, tmp_path)["IMU"].parent
    out = tmp_path / "smooth"
    assert cli.main(["smooth", "--data", str(folder), "--method", "Graph-TC", "--out", str(out), "--no-plots"]) == 0
    scores = {}
    for name, ref in (("tum", out / "groundtruth.tum"), ("mission", folder)):
        assert cli.main(["evaluate", str(out / "trajectory.csv"), "--ref", str(ref),
                         "--json", str(tmp_path / f"{name}.json")]) == 0
        scores[name] = json.loads((tmp_path / f"{name}.json").read_text())
    assert scores["tum"]["nees_heading_mean"] == pytest.approx(scores["mission"]["nees_heading_mean"], rel=1e-3)
    assert scores["tum"]["matched_poses"] == scores["mission"]["matched_poses"]      # every epoch, the first too
    # and the APE against the mission is scored against the same carried attitude
    assert scores["tum"]["ape_rotation_deg"]["rmse"] == pytest.approx(scores["mission"]["ape_rotation_deg"]["rmse"],
                                                                       rel=1e-3)


def test_a_solution_started_without_its_position_claims_its_drift_beside_the_unknown_start():
    from graphnav.core.solution import LOCAL_ORIGIN, NavSolution
    from graphnav.evaluation.metrics import drift_line, drift_summary, from_start
    t = np.arange(0.0, 101.0)
    p = np.c_[t, 0 * t, 10 + 0 * t]
    growth = 0.1 * t
    cov = np.zeros((len(t), 3, 3))
    cov[:, 0, 0] = cov[:, 1, 1] = growth ** 2                       # the covariance counts from the start
    cov[:, 2, 2] = 0.01
    sol = NavSolution("est", t, p + [2.0, 0.0, 0.0], np.tile([1.0, 0, 0], (len(t), 1)),
                      np.tile(np.eye(3), (len(t), 1, 1)), cov_p_n=cov,
                      info={"alignment": {"position_source": LOCAL_ORIGIN, "origin_sigma_m": 100.0}})
    assert sol.origin_unknown and sol.origin_sigma_m == 100.0
    assert from_start(sol) is sol                          # without a reference nothing to count from
    d = drift_summary(sol)
    assert d["sigma_h_origin_m"] == pytest.approx(np.sqrt(2) * 100.0)
    assert d["sigma_h_end_m"] == pytest.approx(np.sqrt(2 * (1e4 + 100.0)))
    assert d["sigma_h_end_pct"] == pytest.approx(np.sqrt(2) * 10.0)        # 14.1 m over 100 m
    assert "141.42 m of it the unknown start" in drift_line(d) and "since the start 14.14 m" in drift_line(d)


def _graph_from_the_truth(mission, position_sigma_m):
    """The graph started on the truth with a horizontal position prior of ``position_sigma_m``."""
    import dataclasses

    from graphnav.estimators.replay import first_ping_time
    from graphnav.estimators.runs import run_graph
    from graphnav.estimators.types import InitialState
    initial = InitialState.from_ground_truth(mission, first_ping_time(mission))
    C = initial.pose.rotation().matrix()
    cov_pose = np.zeros((6, 6))
    cov_pose[:3, :3] = np.eye(3) * 1e-6
    cov_pose[3:, 3:] = C.T @ np.diag([position_sigma_m ** 2, position_sigma_m ** 2, 0.01]) @ C   # NED to body
    return run_graph(mission, initial=dataclasses.replace(initial, cov_pose=cov_pose))


def test_depth_factors_tell_the_graph_nothing_about_the_horizontal_position():
    # Nothing here measures the horizontal position: a 100 m prior on it must stay 100 m. With 1 km horizontal
    # sigmas on each depth factor the 200 keyframes made it 58 m after 200 s.
    m = simulate_mission(duration_s=200.0, seed=5)
    sol = _graph_from_the_truth(m, 100.0)
    assert np.all(np.sqrt(np.diagonal(sol.cov_p_n[-1])[:2]) > 99.0)


def test_a_run_started_from_the_sensors_counts_its_covariance_from_the_start():
    # The unknown start's 100 m is the frame's, not the covariance's: a covariance holding it could not show the
    # drift since the start beside it (its marginals' noise and an EKF's information on the start made it 0 m).
    from graphnav.estimators.runs import run_ekf, run_graph
    from graphnav.evaluation.consistency import pose_nees
    from graphnav.evaluation.metrics import drift_summary
    m = simulate_mission(duration_s=200.0, seed=5)
    for sol in (run_graph(m, init="sensors"), run_ekf(m, init="sensors")):
        assert sol.origin_unknown and sol.origin_sigma_m == 100.0
        assert np.all(np.sqrt(np.diagonal(sol.cov_p_n[-1])[:2]) < 10.0)
        d = drift_summary(sol, m.gt)
        assert d["sigma_h_origin_m"] == pytest.approx(141.42, abs=0.01)
        assert 0.3 < d["sigma_h_end_pct"] < 3.0                              # the drift claimed from the start
        # a covariance holding the start's 100 m would give ~1e-3 (graph 0.18, EKF 0.24 here)
        assert 0.1 < pose_nees(sol, m.gt, sol.t[0] + 30.0)["nees_pos_mission"] < 10.0


def test_a_given_start_position_is_a_prior_not_a_singular_one(tmp_path):
    # --initial-position with the sensor alignment gave the start a zero horizontal variance: an indeterminate
    # linear system at the first keyframe
    assert cli.main(["simulate", "--duration", "60", "--seed", "3", "--out", str(tmp_path / "sim")]) == 0
    assert cli.main(["smooth", "--data", str(tmp_path / "sim" / "Trajectory1"), "--init", "sensors",
                     "--initial-heading", "0", "--initial-position", "32.8", "34.9", "--method", "Graph-TC",
                     "--out", str(tmp_path / "out"), "--no-plots"]) == 0
    frame = json.loads((tmp_path / "out" / "summary.json").read_text())["position_frame"]
    assert frame["set_by"] == "initial_lla" and frame["origin_lat_deg"] == pytest.approx(32.8)
    # the position given is a GNSS fix's: a few metres (--initial-position-sigma, 5 m by default), not 1 m
    from graphnav.io.outputs import read_trajectory_csv
    first = read_trajectory_csv(tmp_path / "out" / "trajectory.csv").cov_p_n[0]
    assert np.sqrt(first[0, 0]) == pytest.approx(5.0, rel=0.05)


def test_online_started_from_the_sensors_claims_its_drift_from_the_start(tmp_path, capsys):
    assert cli.main(["simulate", "--duration", "120", "--seed", "3", "--out", str(tmp_path / "sim")]) == 0
    assert cli.main(["online", "--data", str(tmp_path / "sim" / "Trajectory1"), "--method", "Graph-TC",
                     "--init", "sensors", "--out", str(tmp_path / "on"), "--no-plots"]) == 0
    drift = json.loads((tmp_path / "on" / "summary.json").read_text())["drift"]
    assert drift["sigma_h_origin_m"] > 140.0 and drift["sigma_h_end_pct"] < 5.0
    assert "of it the unknown start" in capsys.readouterr().out


def test_an_initial_position_sigma_without_the_position_is_refused(tmp_path):
    assert cli.main(["simulate", "--duration", "30", "--seed", "3", "--out", str(tmp_path / "sim")]) == 0
    assert cli.main(["smooth", "--data", str(tmp_path / "sim" / "Trajectory1"), "--init", "sensors",
                     "--initial-position-sigma", "3", "--out", str(tmp_path / "out"), "--no-plots"]) != 0


def test_evaluate_scores_a_written_run_with_its_full_pose_covariance(tmp_path):
    # trajectory.csv keeps the sigmas only: scored from them, a run's position NEES differed from its summary's
    # (Trajectory1 from the sensors: 1.27 against 1.73); the trajectory_cov.csv beside it holds the full covariance
    from graphnav.core.mission import GroundTruth
    from graphnav.core.rotations import euler_to_C_b_n
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.consistency import pose_nees
    from graphnav.evaluation.score import evaluate, load_trajectory
    from graphnav.io.outputs import write_pose_covariance_csv, write_trajectory_csv, write_tum
    t = np.arange(0.0, 401.0)
    yaw = np.full_like(t, 0.6)
    p = np.c_[1.2 * t, 0.9 * t, 10.0 + 0 * t]
    gt = GroundTruth(t, p, np.gradient(p, t, axis=0), euler_to_C_b_n(0 * t, 0 * t, yaw))
    cov = np.tile(np.array([[4.0, 3.0, 0.0], [3.0, 4.0, 0.0], [0.0, 0.0, 0.01]]), (len(t), 1, 1))  # correlated N/E
    rng = np.random.default_rng(3)
    err = rng.multivariate_normal([0.0, 0.0], cov[0, :2, :2], size=len(t))
    est = NavSolution("est", t, p + np.c_[err, 0 * t], gt.v_n, gt.C_b_n, cov_p_n=cov,
                      cov_rot_b=np.tile(np.eye(3) * 1e-6, (len(t), 1, 1)))
    write_trajectory_csv(tmp_path / "trajectory.csv", est)
    write_tum(tmp_path / "trajectory.tum", est)
    write_pose_covariance_csv(tmp_path / "trajectory_cov.csv", est)
    want = pose_nees(est, gt, 60.0)["nees_pos_mission"]
    for name in ("trajectory.csv", "trajectory.tum"):
        read = load_trajectory(tmp_path / name)
        np.testing.assert_allclose(read.cov_p_n[:, :2, :2], cov[:, :2, :2], rtol=1e-9)
        assert evaluate(read, gt)["nees_position_mean"] == pytest.approx(want, rel=1e-6)


def test_evaluate_scores_a_written_run_with_its_full_velocity_covariance(tmp_path):
    # trajectory.csv keeps the velocity sigmas only: scored from them, Trajectory1 from the sensors gave a velocity
    # NEES of 1.46 (under its band) against smooth's 1.91; trajectory_cov.csv now holds the velocity block too
    from graphnav.core.mission import GroundTruth
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.consistency import reference_nees
    from graphnav.evaluation.score import evaluate, load_trajectory
    from graphnav.io.outputs import write_pose_covariance_csv, write_trajectory_csv
    t = np.arange(0.0, 401.0)
    p = np.c_[1.2 * t, 0.9 * t, 10.0 + 0 * t]
    gt = GroundTruth(t, p, np.gradient(p, t, axis=0), np.tile(np.eye(3), (len(t), 1, 1)))
    cov = np.tile(np.array([[4e-4, 3.6e-4, 0.0], [3.6e-4, 4e-4, 0.0], [0.0, 0.0, 1e-4]]), (len(t), 1, 1))
    # the error across the track, where the correlated north/east sigma is tight (0.0063 m/s; each axis 0.02 m/s)
    err = np.random.default_rng(5).normal(0.0, np.sqrt(4e-5), len(t))[:, None] * [0.5 ** 0.5, -0.5 ** 0.5, 0.0]
    est = NavSolution("est", t, p, gt.v_n + err, gt.C_b_n, cov_v_n=cov)
    write_trajectory_csv(tmp_path / "trajectory.csv", est)
    want = reference_nees(est, gt, None, 60.0, None)["nees_mission"]
    diagonal = evaluate(load_trajectory(tmp_path / "trajectory.csv"), gt)
    assert want == pytest.approx(1.0, abs=0.3) and diagonal["nees_velocity_mean"] < 0.2
    assert "diagonal covariance" in diagonal["nees_note"]
    write_pose_covariance_csv(tmp_path / "trajectory_cov.csv", est)
    read = load_trajectory(tmp_path / "trajectory.csv")
    np.testing.assert_allclose(read.cov_v_n, cov, rtol=1e-9)
    full = evaluate(read, gt)
    assert full["nees_velocity_mean"] == pytest.approx(want, rel=1e-6)
    assert "diagonal covariance" not in full["nees_note"]


def test_a_nees_outside_its_band_says_which_side_and_what_it_means():
    # a heading NEES far under its band (a run started from the reference keeps its heading prior) was printed
    # without a word; now evaluate and the smooth / online summary say which side and what it means
    from graphnav.commands.common import _nees_entry
    from graphnav.core.mission import GroundTruth
    from graphnav.core.rotations import euler_to_C_b_n
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.score import evaluate, format_report
    t = np.arange(0.0, 200.01, 1.0)
    zero = np.zeros_like(t)
    p = np.c_[1.5 * t, zero, 10 + zero]
    gt = GroundTruth(t, p, np.gradient(p, t, axis=0), euler_to_C_b_n(zero, zero, zero))
    for heading_sigma_deg, side in ((20.0, "below its band: under-confident, the claimed sigma is larger than the "
                                     "error"), (0.5, "above its band: over-confident, the error is larger than the "
                                     "claimed sigma")):
        est = NavSolution("est", t, gt.p_n + [1.0, 2.0, 0.0], gt.v_n, euler_to_C_b_n(zero, zero, zero + 0.0175),
                          cov_p_n=np.tile(np.diag([1.0, 4.0, 0.01]), (len(t), 1, 1)),
                          cov_rot_b=np.tile(np.diag([1e-4, 1e-4, np.deg2rad(heading_sigma_deg) ** 2]),
                                            (len(t), 1, 1)))
        res = evaluate(est, gt)
        lines = format_report(res, "est", "gt").splitlines()
        heading = next(line for line in lines if "heading NEES mean" in line)
        position = next(line for line in lines if "horizontal position NEES mean" in line)
        assert heading.endswith(f"): {side}")
        assert position.endswith(")")                                           # 2.00: inside its band
        entry = {"nees": res["nees_heading_mean"], "dof": 1, "band_95": res["nees_heading_95pct_band"]}
        assert _nees_entry("heading", entry).endswith(f"; {side})")
    assert _nees_entry("position", {"nees": 2.0, "dof": 2, "band_95": [0.4, 4.8]}) == "position 2.00 (0.40-4.80)"
    assert _nees_entry("position", None) == "position -"
