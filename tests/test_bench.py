"""Benchmark record schema, window scoring, incremental results.json, resume, and report aggregation.

The estimator is replaced by a fake (ground truth plus a known velocity error inside outage windows) so
the numbers in records and report are known exactly; the real estimators run in tests/test_apps.py.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from graphnav.core.mission import DvlData, GroundTruth, ImuData, Mission
from graphnav.core.scenarios import scenario_outage
from graphnav.core.solution import NavSolution
from graphnav.evaluation import bench
from graphnav.evaluation.bench import (
    RECORD_KEYS,
    BenchCase,
    TrajectorySource,
    aggregate,
    make_cases,
    make_report,
    run_bench,
    run_case,
)

#: Fake velocity error (m/s, north) inside outage windows, per method; outside windows the error is 0.01.
FAKE_ERR = {"TC": 0.5, "HNTC": 0.2, "Average-TC": 0.3, "Graph-HN": 0.1, "Graph-TC": 0.4, "LC": 2.0}
OUTSIDE = 0.01


def synthetic_mission(name: str = "fake", duration: float = 200.0) -> Mission:
    """Straight line at 1.5 m/s north; IMU at 10 Hz, DVL and GT at 1 Hz (enough for scoring)."""
    t_imu = np.arange(0.0, duration + 1e-9, 0.1)
    t = np.arange(0.0, duration + 1e-9, 1.0)
    v = np.tile([1.5, 0.0, 0.0], (len(t), 1))
    gt = GroundTruth(t, np.column_stack([1.5 * t, 0 * t, 0 * t]), v, np.tile(np.eye(3), (len(t), 1, 1)))
    imu = ImuData(t_imu, np.tile([0.0, 0.0, -9.8], (len(t_imu), 1)), np.zeros((len(t_imu), 3)))
    dvl = DvlData(t, np.full((len(t), 4), 0.5), np.ones((len(t), 4), bool))
    return Mission(name, imu, dvl, gt=gt)


def fake_run_method(mission, method, scenario, **_):
    """GT velocity plus FAKE_ERR[method] north inside the mission's outage windows (any scenario)."""
    if method == "Graph-TC" and mission.name == "broken":
        raise RuntimeError("solver exploded")
    gt = mission.gt
    err = np.full(len(gt.t), OUTSIDE)
    for o in mission.meta.get("outages", []):
        err[(gt.t >= o.start_s) & (gt.t <= o.end_s)] = FAKE_ERR[method]
    v = gt.v_n.copy()
    v[:, 0] += err
    p = gt.p_n.copy()
    p[:, 0] += np.concatenate([[0.0], np.cumsum(err[1:] * np.diff(gt.t))])
    return NavSolution(method, gt.t.copy(), p, v, gt.C_b_n.copy(), runtime_s=0.5, info={"completer": "fake"})


@pytest.fixture
def fake_world(monkeypatch):
    missions = {}

    def load_source(source):
        return missions.setdefault(source.name, synthetic_mission(source.name))

    monkeypatch.setattr(bench.cases, "load_source", load_source)
    monkeypatch.setattr(bench.runner, "run_method", fake_run_method)
    bench.prepared_mission.cache_clear()
    yield
    bench.prepared_mission.cache_clear()


def test_run_case_records(fake_world):
    case = BenchCase(TrajectorySource("t1"), "2-missing", "as-recorded", "HNTC", 30.0)
    records = run_case(case)
    # 200 s mission: windows at 60 s and 150 s (60 s settle, then every 30 + 60 s, ending >= 5 s early).
    assert [r["window_start_s"] for r in records] == [60.0, 150.0]
    for r in records:
        assert set(RECORD_KEYS) <= set(r) and "error" not in r
        assert (r["trajectory"], r["scenario"], r["imu_grade"], r["method"], r["window_s"]) == \
            ("t1", "2-missing", "as-recorded", "HNTC", 30.0)
        assert r["vrmse_window"] == pytest.approx(0.2)
        # Over the window the fake drifts 0.2 m/s north for 30 s (stamps 60..90 s at 1 Hz).
        assert r["pos_err_window_end_m"] == pytest.approx(0.2 * 30, rel=0.05)
        assert r["runtime_s"] >= 0 and r["mission_duration_s"] == pytest.approx(200.0)
        assert r["nees_window"] is None  # the fake has no covariance
    n_in = 2 * 31
    expect_mission = math.sqrt((n_in * 0.2 ** 2 + (201 - n_in) * OUTSIDE ** 2) / 201)
    assert records[0]["vrmse_mission"] == pytest.approx(expect_mission, rel=1e-6)


def test_failed_case_is_recorded_not_raised(fake_world):
    records = run_case(BenchCase(TrajectorySource("broken"), "3-missing", "as-recorded", "Graph-TC"))
    assert len(records) == 1 and "solver exploded" in records[0]["error"]
    assert records[0]["vrmse_window"] is None


def test_degraded_grade_changes_imu_and_model(fake_world):
    mission = bench.prepared_mission(TrajectorySource("t1"), "tactical")
    ref = bench.prepared_mission(TrajectorySource("t1"), "as-recorded")
    assert mission.config.imu.name == "tactical"
    assert not np.allclose(mission.imu.f_b, ref.imu.f_b)
    again = bench.degrade_imu(ref, "tactical", seed=mission.meta["imu_degrade_seed"])
    np.testing.assert_array_equal(again.imu.f_b, mission.imu.f_b)  # seeded: every method sees the same IMU


def test_results_written_per_case_and_resume(fake_world, tmp_path, monkeypatch):
    cases = make_cases([TrajectorySource("t1"), TrajectorySource("t2")], ["2-missing"], ["as-recorded"],
                       ["TC", "HNTC"], 30.0)
    assert len(cases) == 4
    calls = []

    def interrupting(mission, method, scenario, **kw):
        calls.append((mission.name, method))
        if len(calls) == 3:
            raise KeyboardInterrupt
        return fake_run_method(mission, method, scenario, **kw)

    monkeypatch.setattr(bench.runner, "run_method", interrupting)
    with pytest.raises(KeyboardInterrupt):
        run_bench(cases, tmp_path, jobs=1, progress=False)
    kept = json.loads((tmp_path / "results.json").read_text())
    assert {(r["trajectory"], r["method"]) for r in kept} == {("t1", "TC"), ("t1", "HNTC")}
    assert len(kept) == 4  # two windows each

    calls.clear()
    monkeypatch.setattr(bench.runner, "run_method", fake_run_method)
    records = run_bench(cases, tmp_path, jobs=1, resume=True, progress=False)
    assert len(records) == 8
    assert len(json.loads((tmp_path / "results.json").read_text())) == 8
    # Without --resume everything runs again from scratch.
    records = run_bench(cases[:1], tmp_path, jobs=1, progress=False)
    assert len(records) == 2


def fake_records() -> list[dict]:
    out = []
    for traj in ("a", "b"):
        for w, start in enumerate((60.0, 150.0)):
            for method, err in FAKE_ERR.items():
                # Trajectory b, second window: Graph-HN is worse than HNTC there.
                v = 0.3 if (traj, w, method) == ("b", 1, "Graph-HN") else err
                out.append({"trajectory": traj, "scenario": "2-missing", "imu_grade": "tactical",
                            "window_start_s": start, "window_s": 30.0, "method": method,
                            "vrmse_window": v, "vrmse_mission": v / 5, "pos_err_window_end_m": 30 * v,
                            "runtime_s": 2.0 if method.startswith("Graph") else 0.5,
                            "mission_duration_s": 400.0, "completer": "fake"})
    out.append({"trajectory": "a", "scenario": "2-missing", "imu_grade": "tactical", "window_start_s": None,
                "window_s": 30.0, "method": "Graph-HN-batch", "vrmse_window": None, "vrmse_mission": None,
                "pos_err_window_end_m": None, "runtime_s": None, "error": "RuntimeError: boom"})
    return out


def test_aggregate_numbers():
    agg = aggregate(fake_records())
    g = agg[("tactical", "2-missing", "Graph-HN")]
    assert g["vrmse_window_mean"] == pytest.approx((0.1 * 3 + 0.3) / 4)
    assert g["vrmse_window_worst"] == pytest.approx(0.3)
    assert g["n_windows"] == 4 and g["n_failed"] == 0
    assert g["realtime_factor"] == pytest.approx(200.0)
    assert agg[("tactical", "2-missing", "Graph-HN-batch")]["n_failed"] == 1
    assert bench.improvement_pct(0.15, 0.2) == pytest.approx(25.0)
    assert bench.improvement_pct(0.3, 0.2) == pytest.approx(-50.0)


def test_report_tables():
    text = make_report(fake_records(), {"command": "graphnav bench --x", "window_s": 30.0, "wall_time_s": 12.0})
    assert "graphnav bench --x" in text and "Wall time: 12 s" in text
    assert "## IMU grade: tactical (IMU degraded:" in text and "deg/h" in text
    assert "1 case(s) failed" in text
    # Paper-style row: mean (worst) per method.
    row = next(line for line in text.splitlines() if line.startswith("| 2-missing |"))
    assert "0.150 (0.300)" in row and "0.500 (0.500)" in row
    # Detailed table: HNTC vs TC baseline = (0.5 - 0.2) / 0.5 = +60 %, vs Average-TC (0.3) = +33 %.
    hntc = next(line for line in text.splitlines() if line.startswith("| HNTC |"))
    assert "+60%" in hntc and "+33%" in hntc
    # Headline: Graph-HN 0.15 vs HNTC 0.2, lower in 3 of 4 windows.
    assert "Graph-HN beats HNTC: window VRMSE 0.150 vs 0.200 m/s (+25%), lower in 3 of 4 windows" in text
    runtime = next(line for line in text.splitlines() if line.startswith("| Graph-HN | 2.00"))
    assert "200x" in runtime
    # Per-trajectory appendix: trajectory b's Graph-HN mean is (0.1 + 0.3) / 2.
    appendix = text[text.index("## Per trajectory"):]
    row_b = next(line for line in appendix.splitlines() if line.startswith("| b |"))
    assert row_b.split(" | ")[6] == "0.200"


def test_diverged_windows_are_marked_and_kept_out_of_the_means(fake_world, monkeypatch):
    """A run whose error explodes in one window, and one whose health monitor diverged in a window, are
    marked in the records and reported separately (count + list), not averaged in."""
    def diverging(mission, method, scenario, **kw):
        sol = fake_run_method(mission, method, scenario, **kw)
        if method == "TC":                       # 262 m/s in the second window: the EKF lockout
            sol.v_n[sol.t >= 150.0, 0] += 262.0
        if method == "HNTC":                     # accurate, but its monitor says it diverged in 55-70 s
            sol.info["health"] = {"n_divergences": 1, "n_reacquired": 1, "nis_mean_per_dof": 3.0,
                                  "divergence_intervals": [[55.0, 70.0, "5 measurements in a row rejected"]]}
        return sol

    monkeypatch.setattr(bench.runner, "run_method", diverging)
    records = []
    for method in ("TC", "HNTC", "Graph-HN"):
        records += run_case(BenchCase(TrajectorySource("t1"), "2-missing", "as-recorded", method, 30.0))
    by = {(r["method"], r["window_start_s"]): r for r in records}
    assert by[("TC", 150.0)]["diverged"] and "window VRMSE" in by[("TC", 150.0)]["divergence_reason"]
    assert not by[("TC", 60.0)]["diverged"] and by[("TC", 60.0)]["divergence_reason"] is None
    assert by[("HNTC", 60.0)]["diverged"] and "health monitor" in by[("HNTC", 60.0)]["divergence_reason"]
    assert not by[("HNTC", 150.0)]["diverged"]
    assert not any(r["diverged"] for r in records if r["method"] == "Graph-HN")
    assert by[("HNTC", 60.0)]["health_reacquired"] == 1
    agg = aggregate(records)
    tc = agg[("as-recorded", "2-missing", "TC")]
    assert tc["n_diverged"] == 1 and tc["n_windows"] == 1
    assert tc["vrmse_window_mean"] == pytest.approx(0.5) and tc["vrmse_window_worst"] == pytest.approx(0.5)
    text = make_report(records)
    row = next(line for line in text.splitlines() if line.startswith("| 2-missing |"))
    assert "0.500 (0.500) [1 diverged]" in row
    section = text[text.index("## Diverged runs"):text.index("## Runtime")]
    assert "2 window(s) diverged" in section
    assert "t1 150: window VRMSE" in section and "t1 60: health monitor" in section
    healthy = make_report([r for r in records if r["method"] == "Graph-HN"])
    assert "None: no window diverged." in healthy


def test_window_lengths_and_regime_summary(fake_world):
    from graphnav.evaluation.bench import regime_summary
    cases = make_cases([TrajectorySource("sim", None, 0, 200.0)], ["0-beams", "markov"], ["as-recorded", "mems"],
                       ["Graph-TC"], window_s=[30.0, 60.0])
    assert {(c.scenario, c.imu_grade, c.window_s) for c in cases} == {
        (s, g, w) for s in ("0-beams", "markov") for g in ("as-recorded", "mems") for w in (30.0, 60.0)}
    records = []
    for w, hn in ((60.0, 0.05), (120.0, 0.12)):       # Graph-HN helps at 60 s, hurts at 120 s
        for method, v in (("Graph-TC", 0.1), ("Graph-HN", hn), ("Graph-HN-batch", 0.07)):
            records.append({"trajectory": "a", "scenario": "3-missing", "imu_grade": "mems", "window_s": w,
                            "window_start_s": 60.0, "method": method, "vrmse_window": v})
    # every beam measured: Graph-TC 0.08 at 120 s, so 0.7x Graph-TC (0.084 there) needs little more than that
    records.append({"trajectory": "a", "scenario": "none", "imu_grade": "mems", "window_s": 120.0,
                    "window_start_s": 60.0, "method": "Graph-TC", "vrmse_window": 0.08})
    text = "\n".join(regime_summary(records))
    row = next(line for line in text.splitlines() if line.startswith("| mems | 3-missing | 60 |"))
    assert "0.050 (0.050)" in row and "| 0.50 | 0.70 | - |" in row
    row = next(line for line in text.splitlines() if line.startswith("| mems | 3-missing | 120 |"))
    assert "| 1.20 | 0.70 | 0.80 |" in row
    assert "fails in 1 of 2; in 1 of these even Graph-TC with all four beams measured is above 0.7x " \
           "(mems/3-missing/120 s)" in text
    assert "helps (< 0.95x) in 1, neutral in 0, hurts (> 1.02x) in 1" in text
    assert "hurts: mems/3-missing/120 s (1.20x)" in text
    assert "never hurts (Graph-HN <= 1.02x Graph-TC in every regime): fails in 1 of 2" in text
    assert "batch smoother <= 0.8x Graph-TC in every cell with missing beams: holds" in text


def test_regime_targets_per_cell():
    """Per cell: never worse than Graph-TC (<= 1.02x), and <= 0.7x only where all four beams measured give
    <= 0.5x Graph-TC; without an all-beams run the second target is not judged."""
    from graphnav.evaluation.bench import regime_summary
    records = []
    for grade, scenario, w, hn, all_beams in (("tactical", "0-beams", 60.0, 0.06, 0.04),
                                              ("mems", "0-beams", 60.0, 0.08, 0.07),
                                              ("mems", "3-missing", 120.0, 0.103, None)):
        for method, v in (("Graph-TC", 0.1), ("Graph-HN", hn)):
            records.append({"trajectory": "a", "scenario": scenario, "imu_grade": grade, "window_s": w,
                            "window_start_s": 60.0, "method": method, "vrmse_window": v})
        if all_beams is not None:
            records.append({"trajectory": "a", "scenario": "none", "imu_grade": grade, "window_s": w,
                            "window_start_s": 60.0, "method": "Graph-TC", "vrmse_window": all_beams})
    text = "\n".join(regime_summary(records))
    assert "| tactical | 0-beams | 60 | 0.60 | 0.40 | pass | pass |" in text
    assert "| mems | 0-beams | 60 | 0.80 | 0.70 | pass | not required |" in text
    assert "| mems | 3-missing | 120 | 1.03 | - | fail | - (no all-beams run) |" in text


def test_records_carry_drift_in_percent_of_distance_and_pose_nees(fake_world, monkeypatch):
    """Window and mission % DT from the fake's known drift; position and heading NEES from a covariance the
    fake states (heading 1 deg off with a 0.5 deg sigma: NEES 4); None where the run carries no covariance."""
    from graphnav.core.rotations import euler_to_C_b_n
    records = run_case(BenchCase(TrajectorySource("t1"), "2-missing", "as-recorded", "HNTC", 30.0))
    sol = fake_run_method(bench.prepared_mission(TrajectorySource("t1"), "as-recorded")
                          .with_outage(*[scenario_outage("2-missing", s, 30.0) for s in (60.0, 150.0)]),
                          "HNTC", "2-missing")
    for r in records:
        assert r["distance_window_m"] == pytest.approx(45.0)                     # 1.5 m/s for 30 s
        assert r["drift_pct_window"] == pytest.approx(r["pos_err_window_end_m"] / 45.0 * 100)
        assert r["drift_pct_window"] == pytest.approx(0.2 * 30 / 45.0 * 100, rel=0.05)
        assert r["distance_mission_m"] == pytest.approx(300.0)
        assert r["pos_err_mission_end_m"] == pytest.approx(sol.p_n[-1, 0] - 300.0)
        assert r["drift_pct_mission"] == pytest.approx((sol.p_n[-1, 0] - 300.0) / 3.0)
        assert r["nees_pos_window"] is None and r["nees_heading_window"] is None and r["nees_pos_mission"] is None

    sigma_p, sigma_psi = 2.0, np.deg2rad(0.5)

    def with_covariance(mission, method, scenario, **kw):
        s = fake_run_method(mission, method, scenario, **kw)
        s.C_b_n = euler_to_C_b_n(np.zeros(len(s.t)), np.zeros(len(s.t)), np.full(len(s.t), np.deg2rad(1.0)))
        s.cov_p_n = np.tile(np.diag([sigma_p ** 2, sigma_p ** 2, 0.01]), (len(s.t), 1, 1))
        s.cov_rot_b = np.tile(np.diag([1e-4, 1e-4, sigma_psi ** 2]), (len(s.t), 1, 1))
        return s

    monkeypatch.setattr(bench.runner, "run_method", with_covariance)
    records = run_case(BenchCase(TrajectorySource("t1"), "2-missing", "as-recorded", "HNTC", 30.0))
    inside = (sol.t >= 60.0) & (sol.t <= 90.0)
    e_n = sol.p_n[inside, 0] - 1.5 * sol.t[inside]
    assert records[0]["nees_pos_window"] == pytest.approx(np.mean(e_n ** 2) / sigma_p ** 2, rel=1e-6)
    after = sol.t >= 60.0
    assert records[0]["nees_pos_mission"] == pytest.approx(
        np.mean((sol.p_n[after, 0] - 1.5 * sol.t[after]) ** 2) / sigma_p ** 2, rel=1e-6)
    assert records[0]["nees_heading_window"] == pytest.approx(4.0, rel=1e-6)
    assert records[0]["nees_heading_mission"] == pytest.approx(4.0, rel=1e-6)
    assert records[0]["nees_heading_n_independent"] >= 1 and records[0]["nees_pos_n_independent"] >= 1
    json.dumps(records)                                                          # plain values for results.json

    text = make_report(records)
    table = next(line for line in text.splitlines() if line.startswith("| HNTC | 0.200"))
    assert f"| {bench.drift_pct_of(records):.2f} | {records[0]['drift_pct_mission']:.2f} |" in table
    assert "% DT window | % DT mission" in text
    pose = text[text.index("### Position and heading NEES: as-recorded, 2-missing"):]
    row = next(line for line in pose.splitlines() if line.startswith("| HNTC |"))
    assert "4.00 (4.00-4.00)" in row                                             # heading NEES


def test_report_of_records_without_the_new_fields_shows_dashes():
    """Records written before the position metrics existed: the report shows "-" and no pose NEES table."""
    text = make_report(fake_records())
    hntc = next(line for line in text.splitlines() if line.startswith("| HNTC |"))
    assert hntc.split(" | ")[5:7] == ["-", "-"]
    assert "### Position and heading NEES" not in text
    assert bench.drift_pct_of([{"pos_err_window_end_m": 1.0, "distance_window_m": 100.0},
                               {"pos_err_window_end_m": 3.0, "distance_window_m": 100.0},
                               {"pos_err_window_end_m": 9.0, "distance_window_m": 1.0}]) == pytest.approx(2.0)


def test_regime_table_has_the_windows_drift_in_percent():
    from graphnav.evaluation.bench import regime_summary
    records = [{"trajectory": "a", "scenario": "3-missing", "imu_grade": "mems", "window_s": 30.0,
                "window_start_s": s, "method": m, "vrmse_window": 0.1, "pos_err_window_end_m": e,
                "distance_window_m": 50.0}
               for m, e in (("Graph-TC", 1.0), ("Graph-HN", 0.5)) for s in (60.0, 150.0)]
    text = "\n".join(regime_summary(records))
    assert "% DT TC / HN / batch" in text
    row = next(line for line in text.splitlines() if line.startswith("| mems | 3-missing | 30 |"))
    assert "| 2.00 / 1.00 / - |" in row
