"""``graphnav start-sweep`` and ``graphnav consistency`` on a short simulated mission: files, table, resume,
refusals. The studies' numbers on the shared trajectories are in their decision pages; here the wiring."""
from __future__ import annotations

import json

import pytest

from graphnav.cli import main
from graphnav.evaluation.bench import find_trajectories
from graphnav.evaluation.startsweep import START_VRMSE_LIMIT, start_times, sweep_jobs

SIM = ["--sim-duration", "130", "--jobs", "1"]


def test_sweep_order_covers_every_start_once():
    source = find_trajectories(None, sim_duration_s=130.0)[0]
    jobs = sweep_jobs([source], ["none", "3-missing"], step_s=20.0, length_s=60.0)
    from graphnav.evaluation.startsweep import _mission
    starts = start_times(_mission(source), 20.0, 60.0)
    assert sorted((sc, t) for _, sc, t in jobs) == sorted((sc, t) for sc in ("none", "3-missing") for t in starts)
    assert len(jobs) == 2 * len(starts) == 8


def test_start_sweep_writes_records_and_table_and_resumes(tmp_path, capsys):
    out = tmp_path / "sweep"
    args = ["start-sweep", *SIM, "--methods", "TC", "--scenario", "3-missing", "--step", "40", "--out", str(out)]
    assert main(args) == 0
    records = json.loads((out / "start_sweep.json").read_text())
    assert [r["t_start"] for r in records] and {r["method"] for r in records} == {"TC"}
    assert all(r["error"] is None and r["vrmse_worst"] < START_VRMSE_LIMIT for r in records)
    assert all(len(r["vrmse_windows"]) == 2 for r in records)          # start-up window, outage window
    table = (out / "table.md").read_text()
    assert f"| 3-missing | TC | {len(records)} |" in table
    capsys.readouterr()
    assert main(args) == 1                                              # an earlier sweep is kept
    assert "--resume to continue" in capsys.readouterr().err
    assert main([*args, "--resume"]) == 0                               # nothing left to run
    assert json.loads((out / "start_sweep.json").read_text()) == records
    assert main(["start-sweep", "--table", str(out), "--methods", "TC", "--scenario", "3-missing"]) == 0
    assert f"{len(records)} (trajectory, start) pairs" in capsys.readouterr().out


@pytest.mark.parametrize("bad, message", [(["--step", "0"], "--step 0.0: must be > 0"),
                                          (["--window-s", "90"], "longer than --length"),
                                          (["--trajectories", "Trajectory99"], "Trajectory99: not found")])
def test_start_sweep_refuses_bad_arguments(tmp_path, capsys, bad, message):
    assert main(["start-sweep", *SIM, "--out", str(tmp_path / "o"), *bad]) == 1
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_consistency_rows_and_table(tmp_path, capsys):
    out = tmp_path / "cons"
    assert main(["consistency", "--sim-duration", "160", "--jobs", "1", "--methods", "TC", "Graph-TC",
                 "--scenario", "none", "--out", str(out), "--gt-sigma", "0.05", "0.05", "0.05"]) == 0
    rows = json.loads((out / "consistency.json").read_text())
    assert sorted((r["method"], r["setting"]) for r in rows) == [("Graph-TC", "off"), ("Graph-TC", "on"),
                                                                  ("TC", "off")]
    for r in rows:
        # the GT's own error widens P: the NEES can only fall
        assert 0 < r["nees_mission_gt"] < r["nees_mission"] and r["vrmse_window"] < 0.1
    table = (out / "table.md").read_text()
    assert "| Graph-TC | on |" in table and "| TC | on |" not in table
    assert main(["consistency", "--sim-duration", "160", "--out", str(out)]) == 1
    assert "--force" in capsys.readouterr().err


def test_consistency_position_heading_and_drift_columns_are_score_cases(tmp_path, capsys):
    """The rows' % DT and position / heading NEES are the bench's own (``score_case``, ``drift_pct_of``) for the
    same run, and the tables show them."""
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench import case_windows, drift_pct_of, prepared_mission, score_case
    from graphnav.evaluation.consistency_study import POSE_FIELDS, counted_distance
    from graphnav.evaluation.methods import run_method
    out = tmp_path / "cons"
    assert main(["consistency", "--sim-duration", "160", "--jobs", "1", "--methods", "TC", "--scenario", "none",
                 "3-missing", "--per-trajectory", "--out", str(out)]) == 0
    rows = {r["scenario"]: r for r in json.loads((out / "consistency.json").read_text())}
    mission = prepared_mission(find_trajectories(None, sim_duration_s=160.0)[0], "as-recorded")
    starts = case_windows(mission, 30.0)
    for scenario, row in rows.items():
        run = mission.with_outage(*[scenario_outage(scenario, s, 30.0) for s in starts])
        scores = score_case(run_method(run, "TC", scenario), mission, starts, 30.0)
        assert row["drift_pct_window"] == pytest.approx(drift_pct_of(scores), rel=1e-9)
        assert row["drift_pct_mission"] == pytest.approx(scores[0]["drift_pct_mission"], rel=1e-9)
        distance = row["distance_window_sum_m"]
        assert distance == pytest.approx(counted_distance(scores)) and distance > 50
        for key in POSE_FIELDS:                       # the 15-state EKF carries position and attitude covariances
            assert row[key] is not None and row[key] == pytest.approx(scores[0][key], rel=1e-9), key
    # (not ordered: on this short simulated mission the DVL error states let the all-beam run drift more)
    assert rows["3-missing"]["drift_pct_window"] > 0 and rows["none"]["drift_pct_window"] > 0
    table = (out / "table.md").read_text()
    assert "| % DT window none | % DT window 3-missing |" in table and "| position NEES (band) |" in table
    none = rows["none"]
    line = next(x for x in table.splitlines() if x.startswith("| TC | off |"))
    assert (f"| {none['drift_pct_window']:.2f} | {rows['3-missing']['drift_pct_window']:.2f} |" in line
            and f"| {none['nees_pos_mission']:.2f} ({none['nees_pos_mission']:.2f}-" in line
            and f"| {none['nees_heading_mission']:.2f} (" in line
            and line.endswith(f"| {none['drift_pct_mission']:.2f} |"))
    assert (f"| sim-seed0 | {none['nees_pos_mission']:.2f} / {none['nees_heading_mission']:.2f} / "
            f"{none['drift_pct_window']:.2f} / {none['drift_pct_mission']:.2f} |") in table


def test_pooled_window_drift_is_summed_drift_over_summed_distance():
    from graphnav.evaluation.consistency_study import _pct_window
    rows = [{"drift_pct_window": 100 * 3.0 / 300.0, "distance_window_sum_m": 300.0},
            {"drift_pct_window": 100 * 1.0 / 100.0, "distance_window_sum_m": 100.0},
            {"drift_pct_window": float("nan"), "distance_window_sum_m": 0.0}]
    assert _pct_window(rows) == f"{100 * 4.0 / 400.0:.2f}" and _pct_window(rows[2:]) == "-"


def test_a_mean_nees_over_trajectories_is_judged_by_the_band_of_such_a_mean():
    """Ten trajectories of 10 independent epochs, position NEES 3.0 each: inside one trajectory's 95 % band
    (0.96-3.42, 2 dof) but not the mean's (200 dof over 10: 1.63-2.41), which the table used to miss."""
    from graphnav.evaluation.consistency_study import _pose_cell
    rows = [{"nees_pos_mission": 3.0, "nees_pos_n_independent": 10} for _ in range(10)]
    assert _pose_cell(rows, "nees_pos", 2) == ("3.00 (3.00-3.00; band 0.96-3.42; mean above its band: over-confident "
                                               "(band over 10 traj. 1.63-2.41))")
    assert _pose_cell(rows[:1], "nees_pos", 2) == "3.00 (3.00-3.00; band 0.96-3.42)"


def _drift_rows(text: str) -> dict:
    """``method -> (delta s, % DT window, without the offset)`` of a printed drift-check table."""
    out = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if line.startswith("| sim-seed0 |"):
            out[cells[1]] = tuple(float(c) for c in cells[2:5])
    return out


def test_consistency_drift_check_recovers_an_injected_stamp_offset(monkeypatch, capsys):
    """The estimate's stamps moved 0.3 s late: the fitted delta grows by 0.3 s and the window % DT without the
    fitted offset is the undamaged run's."""
    import dataclasses

    from graphnav.evaluation import methods
    args = ["consistency", "--drift-check", "--sim-duration", "250", "--jobs", "1", "--methods", "TC"]
    assert main(args) == 0
    base = _drift_rows(capsys.readouterr().out)["TC"]
    run_method = methods.run_method

    def late(*a, **k):
        sol = run_method(*a, **k)
        return dataclasses.replace(sol, t=sol.t + 0.3)
    monkeypatch.setattr(methods, "run_method", late)
    assert main(args) == 0
    shifted = _drift_rows(capsys.readouterr().out)["TC"]
    assert shifted[0] - base[0] == pytest.approx(0.3, abs=0.05)
    assert shifted[1] > base[1] + 0.2                           # the offset costs % DT as scored ...
    assert shifted[2] == pytest.approx(base[2], abs=0.05)       # ... and the fit takes it out again


def test_stamp_offset_fit_of_the_reference_itself():
    """The reference as an estimate, its stamps late by 0.25 s: the whole error is the offset."""
    import dataclasses

    import numpy as np

    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.consistency_study import stamp_offset_fit
    from graphnav.sim.simulate import simulate_mission
    mission = simulate_mission(200.0, seed=3)
    t = np.arange(mission.gt.t[0] + 5.0, mission.gt.t[-1] - 5.0, 1.0)
    p, v, C = mission.gt.at(t - 0.25)
    sol = NavSolution(t=t, p_n=p, v_n=v, C_b_n=C, method="reference")
    assert stamp_offset_fit(sol, mission.gt) == pytest.approx(0.25, abs=0.01)
    assert stamp_offset_fit(dataclasses.replace(sol, t=t - 0.25), mission.gt) == pytest.approx(0.0, abs=0.01)


def test_consistency_reference_check_and_errors(capsys):
    assert main(["consistency", "--reference-check", "--sim-duration", "100"]) == 0
    assert "| sim-seed0 |" in capsys.readouterr().out
    assert main(["consistency", "--gt-sigma", "-1", "0", "0"]) == 1
    assert main(["consistency", "--data", "/nonexistent/folder"]) == 1
    err = capsys.readouterr().err
    assert "--gt-sigma" in err and "/nonexistent/folder: not a folder" in err and "Traceback" not in err


@pytest.mark.parametrize("command", ["start-sweep", "consistency"])
def test_help(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0 and "Example: graphnav" in capsys.readouterr().out
