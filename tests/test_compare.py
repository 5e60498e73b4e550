"""``graphnav compare``: two bench runs matched record by record; known changes found, sizes exact."""
from __future__ import annotations

import copy
import json

import pytest

from graphnav.cli import main
from graphnav.core.errors import DataError
from graphnav.evaluation.compare import compare_runs


def records() -> list[dict]:
    out = []
    for traj in ("Trajectory2", "Trajectory10"):
        for method in ("TC", "Graph-TC", "Graph-HN"):
            for start in (60.0, 150.0):
                out.append({"trajectory": traj, "scenario": "3-missing", "imu_grade": "as-recorded",
                            "window_s": 30.0, "method": method, "window_start_s": start,
                            "vrmse_window": 0.1 + start / 1000, "vrmse_mission": 0.05, "pos_err_window_end_m": 1.0,
                            "runtime_s": 3.0, "diverged": False, "divergence_reason": None,
                            "nees_axes_b": [1.1, 0.9, 0.4]})
    return out


def write(path, recs):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(recs))
    return str(path)


def test_identical_runs_differ_only_in_runtime(tmp_path, capsys):
    a = records()
    b = copy.deepcopy(a)[::-1]                     # another order, other wall times: still the same results
    for r in b:
        r["runtime_s"] = 9.0
    c = compare_runs(a, b)
    assert (c.identical, len(c.diffs), c.same()) == (12, 0, True)
    code = main(["compare", write(tmp_path / "a" / "results.json", a), str(write(tmp_path / "b" / "results.json", b))])
    out = capsys.readouterr().out
    assert code == 0 and "12 records in both, 12 identical" in out and "same results" in out


def test_changes_are_found_and_sized(tmp_path, capsys):
    a, b = records(), records()
    b[3]["vrmse_window"] += 0.0123                 # Trajectory2 Graph-TC window 150
    b[7]["vrmse_mission"] -= 0.002
    b[5]["diverged"] = True
    b.pop(0)
    c = compare_runs(a, b)
    assert c.identical == 8 and len(c.diffs) == 3 and len(c.only_a) == 1 and not c.only_b
    delta, key = c.max_delta("vrmse_window")
    assert delta == pytest.approx(0.0123) and key == ("Trajectory2", "3-missing", "as-recorded", 30.0, "Graph-TC", 150.0)
    assert c.max_delta("vrmse_mission")[0] == pytest.approx(0.002)
    assert not c.same(tol=0.1)                    # the flag and the missing record are never within a tolerance
    code = main(["compare", write(tmp_path / "a.json", a), write(tmp_path / "b.json", b)])
    out = capsys.readouterr().out
    assert code == 1 and "max |delta vrmse_window| = 0.0123 m/s at Trajectory2 3-missing as-recorded Graph-TC" in out
    assert "diverged: False -> True" in out and "1 only in A" in out


def test_tolerance_sets_the_exit_status(tmp_path, capsys):
    a, b = records(), records()
    b[2]["vrmse_window"] += 1e-12
    pa, pb = write(tmp_path / "a.json", a), write(tmp_path / "b.json", b)
    assert main(["compare", pa, pb]) == 1
    assert main(["compare", pa, pb, "--tol", "1e-9"]) == 0
    # a list of numbers (the velocity NEES per body axis) within the same tolerance, element by element
    b[4]["nees_axes_b"][2] += 1e-12
    pb = write(tmp_path / "b.json", b)
    assert main(["compare", pa, pb, "--tol", "1e-9"]) == 0
    b[4]["nees_axes_b"][2] += 0.5
    c = compare_runs(a, b)
    assert c.max_delta("nees_axes_b[2]")[0] == pytest.approx(0.5) and not c.same(tol=1e-9)
    b[4]["nees_axes_b"] = None                                   # a run without the covariance: differs at all
    assert not compare_runs(a, b).same(tol=10.0)


def test_bad_input_is_a_clear_error(tmp_path, capsys):
    a = records()
    with pytest.raises(DataError, match="records 0 and 12 have the same key"):
        compare_runs(a + [a[0]], a, "x.json")
    assert main(["compare", str(tmp_path / "missing.json"), write(tmp_path / "b.json", a)]) == 1
    err = capsys.readouterr().err
    assert "missing.json: no such file" in err and "Traceback" not in err
    bad = tmp_path / "bad.json"
    bad.write_text("[{\"trajectory\": 1}]")
    assert main(["compare", str(bad), str(bad)]) == 1
    assert "record 0 has no" in capsys.readouterr().err


def test_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["compare", "--help"])
    assert exc.value.code == 0 and "window start" in capsys.readouterr().out
