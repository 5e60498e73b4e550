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
