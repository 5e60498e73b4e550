"""The three uses end to end on short simulated missions: smooth, online (flush, resume, Ctrl-C), bench.

Also the method registry (which completer each method gets). Real estimators, short missions.
"""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from graphnav.nets import AverageCompleter

from graphnav.cli import main
from graphnav.evaluation import methods
from graphnav.io.outputs import CSV_COLUMNS, read_trajectory_csv, read_tum


@pytest.mark.parametrize("command", ["smooth", "online", "bench"])
def test_help(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    assert "--out" in capsys.readouterr().out


def test_completer_registry(monkeypatch):
    assert methods.completer_for("TC", "2-missing")[0] is None
    assert methods.completer_for("Graph-TC", "3-missing")[0] is None
    for scenario, n in (("2-missing", 3), ("3-missing", 5), ("none", 5)):
        c, _ = methods.completer_for("Average-LC", scenario)
        assert isinstance(c, AverageCompleter) and c.n_past == n
    # the hybrid graph methods default to the average estimator (out-of-fold choice, docs/decisions/completers.md)
    assert methods.HYBRID_COMPLETER == "average"
    for method in ("Graph-HN", "Graph-HN-batch"):
        c, described = methods.completer_for(method, "3-missing")
        assert isinstance(c, AverageCompleter) and c.n_past == 5 and described == "average(n_past=5)"
    assert methods.get_method("Graph-HN-net").completer == "network"
    assert "Graph-HN-net" not in methods.BENCH_METHODS and "Graph-HN" in methods.BENCH_METHODS
    assert methods.baseline_of("HNLC") == "LC" and methods.baseline_of("Graph-HN") == "TC"
    assert methods.average_of("Graph-HN-batch") == "Average-TC"

    def no_weights(missing):
        raise FileNotFoundError(f"no weights for {missing}")

    monkeypatch.setattr(methods, "_network", no_weights)
    with pytest.warns(RuntimeWarning, match="average estimator instead"):
        c, described = methods.completer_for("Graph-HN-net", "3-missing")
    assert isinstance(c, AverageCompleter) and c.n_past == 5 and "fallback" in described
    with pytest.raises(Exception, match="unknown method"):
        methods.completer_for("EKF", "none")


def test_smooth_outputs(tmp_path, capsys):
    out = tmp_path / "smooth"
    rc = main(["smooth", "--duration", "120", "--scenario", "2-missing", "--out", str(out)])
    assert rc == 0
    summary = json.loads((out / "summary.json").read_text())
    sol = read_trajectory_csv(out / "trajectory.csv")
    t, p, C = read_tum(out / "trajectory.tum")
    assert summary["method"] == "Graph-HN-batch" and summary["epochs"] == len(sol.t) == len(t) > 100
    np.testing.assert_allclose(p, sol.p_n, atol=1e-5)
    np.testing.assert_allclose(C, sol.C_b_n, atol=1e-6)
    assert sol.cov_v_n is not None
    acc = summary["accuracy"]
    # Navigation-grade IMU, one 30 s window of 2 missing beams: the smoother stays at the cm/s level.
    assert acc["vrmse_mission_mps"] < 0.05
    assert [w["start_s"] for w in acc["windows"]] == [60.0]
    assert acc["windows"][0]["vrmse_window_mps"] < 0.05
    # velocity, position and heading NEES with their bands, as the benchmark scores them
    cons = acc["consistency"]
    assert [cons[q]["dof"] for q in ("velocity", "position", "heading")] == [3, 2, 1]
    assert all(0 < cons[q]["nees"] < 20 and cons[q]["band_95"][0] < cons[q]["dof"] < cons[q]["band_95"][1]
               for q in cons)
    for name in ("trajectory_ne.png", "velocity_error.png", "velocity_std.png", "groundtruth.tum"):
        assert (out / name).stat().st_size > 0
    printed = capsys.readouterr().out
    assert "VRMSE mission" in printed
    # the smoother's own uncertainty: sigmas in the CSV, the pose covariance of each TUM line, the summary
    assert sol.cov_p_n is not None and sol.cov_rot_b is not None
    from graphnav.io.outputs import read_pose_covariance_csv
    t_cov, cov_p, cov_rot, _ = read_pose_covariance_csv(out / "trajectory_cov.csv")
    np.testing.assert_allclose(t_cov, t, atol=1e-9)
    np.testing.assert_allclose(np.sqrt(np.diagonal(cov_p, axis1=1, axis2=2)),
                               np.sqrt(np.diagonal(sol.cov_p_n, axis1=1, axis2=2)), rtol=1e-8)
    u = summary["uncertainty"]
    assert u["not_estimated"] == [] and 0 < u["final_horizontal_position_sigma_m"] <= u["max_horizontal_position_sigma_m"]
    assert 0 < u["final_heading_sigma_deg"] < 1
    assert "position sigma N/E/D" in printed and "heading sigma" in printed
    # the estimator's health (graph innovation NIS) is in the summary and the printout
    assert summary["health"]["ok"] and summary["health"]["n_measurements"] > 100
    assert "health: ok; NIS/dof" in printed
    # distance travelled and drift in % of it: the end error is the accuracy summary's final error
    drift = summary["drift"]
    assert drift["end_error_m"] == pytest.approx(acc["final_horizontal_position_error_m"], rel=1e-9)
    assert drift["drift_pct"] == pytest.approx(100 * drift["end_error_m"] / drift["reference_distance_m"])
    assert drift["distance_m"] == pytest.approx(drift["reference_distance_m"], rel=0.05)
    assert "horizontal distance travelled" in printed and "% DT against the reference" in printed
    # what became of the completer's beams: one 30 s window at 1 Hz, two beams regressed per ping
    regressed = summary["regressed_beams"]
    assert regressed["regressed"] == 60
    assert regressed["entered"] == regressed["regressed"] - regressed["decorrelated_out"] - regressed["gated"]
    assert summary["compared"] == {}                                  # --compare not given
    assert f"regressed beams: {regressed['entered']} of 60 entered" in printed


def test_regressed_beams_record_counts_what_entered():
    from graphnav.commands.common import regressed_beams_line, regressed_beams_summary
    # no beam regressed (a method without a completer, or no outage): no record
    assert regressed_beams_summary({"regressed_beams": 0, "regressed_screening": {"entered": 0}}) is None
    assert regressed_beams_summary({"health": {}}) is None
    # the EKF's screening also counts what it was offered; the record takes that from the keyframe statistics
    record = regressed_beams_summary({"regressed_beams": 10, "regressed_screening": {
        "offered": 10, "gated": 1, "decorrelated_out": 6, "inflated": 2, "entered": 3}})
    assert record == {"regressed": 10, "entered": 3, "gated": 1, "decorrelated_out": 6, "inflated": 2}
    line = regressed_beams_line(record)
    assert line.startswith("regressed beams: 3 of 10 entered (2 with a widened sigma)")
    assert "6 added nothing" in line and "1 gated" in line and "motion prior" not in line
    assert regressed_beams_line(None) == ""


def _online(out, *extra):
    return main(["online", "--duration", "120", "--scenario", "3-missing", "--method", "Graph-TC",
                 "--out", str(out), "--no-progress", "--no-plots", *extra])


def test_online_resume_continues_identically(tmp_path):
    full = tmp_path / "full"
    assert _online(full) == 0
    reference = (full / "online.csv").read_text()
    rows = reference.splitlines()
    assert rows[0].split(",") == list(CSV_COLUMNS) + ["health"] and len(rows) > 100
    assert {r.rsplit(",", 1)[1] for r in rows[1:]} <= {"ok", "degraded", "diverged"}
    summary = json.loads((full / "summary.json").read_text())
    assert summary["epochs"] == len(rows) - 1 and summary["accuracy"]["vrmse_mission_mps"] < 0.2
    assert summary["drift"]["distance_m"] > 50 and summary["drift"]["drift_pct"] is not None
    # the filter's position and heading sigmas in every row and in the summary
    written = read_trajectory_csv(full / "online.csv")
    assert np.all(np.isfinite(written.cov_p_n)) and np.all(np.isfinite(written.cov_rot_b))
    assert summary["uncertainty"]["final_horizontal_position_sigma_m"] > 0

    # An interrupted run: the first half written, then a torn line.
    part = tmp_path / "part"
    part.mkdir()
    half = len(rows) // 2
    (part / "online.csv").write_text("\n".join(rows[:half]) + "\n" + rows[half][:17])
    assert _online(part, "--resume") == 0
    assert (part / "online.csv").read_text() == reference
    resumed = json.loads((part / "summary.json").read_text())
    assert resumed["epochs_replayed"] == half - 1 and resumed["epochs_this_run"] == len(rows) - half


def test_online_ctrl_c_keeps_written_epochs(tmp_path):
    out = tmp_path / "online"
    cmd = [sys.executable, "-m", "graphnav", "online", "--duration", "120", "--method", "Graph-TC",
           "--realtime", "--speed", "10", "--out", str(out), "--no-progress", "--no-plots"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    csv_path = out / "online.csv"
    deadline = time.monotonic() + 60
    try:
        while time.monotonic() < deadline:
            if csv_path.exists() and len(csv_path.read_text().splitlines()) > 10:
                break
            time.sleep(0.2)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "interrupted" in err
    text = csv_path.read_text()
    assert text.endswith("\n")
    sol = read_trajectory_csv(csv_path)
    # Paced at 10x, the run was stopped well before the end; everything produced so far is there.
    assert 10 <= len(sol.t) < 110 and np.all(np.diff(sol.t) > 0)


def test_bench_end_to_end(tmp_path):
    out = tmp_path / "bench"
    rc = main(["bench", "--sim-duration", "200", "--scenario", "2-missing", "--imu-grade", "tactical",
               "--methods", "TC", "Average-TC", "--jobs", "2", "--out", str(out), "--no-progress"])
    assert rc == 0
    records = json.loads((out / "results.json").read_text())
    assert len(records) == 2 * 2  # two windows (60 s, 150 s) x two methods
    for r in records:
        assert set(r) >= {"trajectory", "scenario", "imu_grade", "window_start_s", "window_s", "method",
                          "vrmse_window", "vrmse_mission", "pos_err_window_end_m", "runtime_s"}
        assert r["imu_grade"] == "tactical" and "error" not in r
        assert 0 < r["vrmse_window"] < 1.0 and 0 < r["vrmse_mission"] < 1.0
    assert {r["window_start_s"] for r in records} == {60.0, 150.0}
    report = (out / "report.md").read_text()
    assert "## IMU grade: tactical" in report and "| TC |" in report and "| Average-TC |" in report
    run = json.loads((out / "bench_run.json").read_text())
    assert run["command"].startswith("graphnav bench") and run["window_s"] == [30.0] and run["wall_time_s"] > 0
    # the results page from this run quotes the bench command and holds both methods
    assert main(["results", "--from", str(out), "--out", str(tmp_path / "results.md")]) == 0
    page = (tmp_path / "results.md").read_text()
    assert f"`{run['command']}`" in page and "| TC |" in page and "| Average-TC |" in page
    plots = sorted(p.name for p in (out / "plots").iterdir())
    assert "vrmse_bars_tactical.png" in plots
    assert "trajectory_sim-seed0_tactical_2-missing.png" in plots
    # --resume with nothing left to do keeps the records and runs nothing.
    before = (out / "results.json").read_text()
    assert main(["bench", "--sim-duration", "200", "--scenario", "2-missing", "--imu-grade", "tactical",
                 "--methods", "TC", "Average-TC", "--jobs", "1", "--out", str(out), "--no-progress",
                 "--resume", "--no-plots"]) == 0
    assert json.loads((out / "results.json").read_text()) == json.loads(before)


def test_resume_skips_the_last_written_epoch_despite_the_csv_rounding(tmp_path):
    """The per-epoch CSV keeps stamps to the microsecond: the last stamp read back (21.227533) is 3e-7 s below
    the epoch's own (21.2275333333...), which must still count as written (else it is written twice)."""
    from types import SimpleNamespace

    import numpy as np

    from graphnav.commands.online import EpochSink
    from graphnav.io.outputs import EpochCsvWriter
    t_true = 21.0 + 0.37 - 0.1424666667 + 1e-10 / 3
    path = tmp_path / "online.csv"
    with EpochCsvWriter(path) as w:
        w.write(t_true, np.zeros(3), np.zeros(3), np.eye(3))
    with EpochCsvWriter(path, resume=True) as w:
        assert w.last_t != t_true and abs(w.last_t - t_true) < 1e-6
        sink = EpochSink(w, SimpleNamespace(update=lambda n: None), w.last_t, False, 1.0)
        for t in (t_true, t_true + 1.0):
            sink(SimpleNamespace(t=t, p_n=np.zeros(3), v_n=np.zeros(3), C_b_n=np.eye(3), cov_v_n=None, bias=None))
    assert sink.n_replayed == 1 and sink.n_new == 1
    assert len(path.read_text().splitlines()) == 3


def test_ekf_hybrid_counts_the_completions_it_updates_with():
    """The EKF hybrid's record: every completion its screening was offered was dropped or went into the update,
    and the summary reports the same."""
    from graphnav.commands.common import regressed_beams_summary
    from graphnav.core.scenarios import scenario_outage
    from graphnav.sim.simulate import simulate_mission
    m = simulate_mission(120, imu_grade="mems", seed=3).with_outage(scenario_outage("2-missing", 40.0, 40.0))
    sol = methods.run_method(m, "Average-TC", "2-missing")
    screening = sol.info["regressed_screening"]
    assert screening["offered"] == sol.info["regressed_beams"] == 2 * 40
    assert screening["entered"] == screening["offered"] - screening["decorrelated_out"] - screening["gated"]
    record = regressed_beams_summary(sol.info)
    assert record["regressed"] == 80 and record["entered"] == screening["entered"] and "offered" not in record
