"""The generated results page (``graphnav results``): numbers from the records, provenance, refusals.

Records are written by hand with known window VRMSEs, so every cell of the page is known exactly.
"""
from __future__ import annotations

import json

import pytest

from graphnav.cli import main
from graphnav.evaluation.results_page import GENERATED_MARK, RUN_RECORD, results_page


def records() -> list[dict]:
    """Two trajectories x two windows; TC worse than Graph-TC; one diverged Graph-TC window; one failed case."""
    err = {"TC": (0.20, 0.40), "Graph-TC": (0.10, 0.30), "Graph-HN-batch": (0.05, 0.07)}
    out = []
    for traj in ("Trajectory2", "Trajectory10"):
        for scenario, extra in (("none", 0.0), ("3-missing", 0.1)):
            for i, start in enumerate((60.0, 150.0)):
                for method, (a, b) in err.items():
                    v = (a if traj == "Trajectory2" else b) + extra
                    diverged = (traj, scenario, i, method) == ("Trajectory10", "3-missing", 1, "Graph-TC")
                    out.append({"trajectory": traj, "scenario": scenario, "imu_grade": "as-recorded",
                                "window_start_s": start, "window_s": 30.0, "method": method,
                                "vrmse_window": 5.0 if diverged else v, "vrmse_mission": v / 2,
                                "pos_err_window_end_m": 1.0, "runtime_s": 2.0 if method == "TC" else 4.0,
                                "mission_duration_s": 400.0, "diverged": diverged,
                                "divergence_reason": "window VRMSE >= 3 m/s" if diverged else None})
    out.append({"trajectory": "Trajectory2", "scenario": "none", "imu_grade": "as-recorded", "window_s": 30.0,
                "method": "LC", "window_start_s": None, "vrmse_window": None, "vrmse_mission": None,
                "pos_err_window_end_m": None, "runtime_s": None, "error": "RuntimeError: boom"})
    return out


def row(page: str, grade_heading: str, method: str) -> list[str]:
    section = page[page.index(grade_heading):]
    line = next(ln for ln in section.splitlines() if ln.startswith(f"| {method} |"))
    return [c.strip() for c in line.strip("|").split("|")]


def test_vrmse_table_numbers():
    page = results_page(records(), "out/bench/results.json", "2026-01-02 03:04 UTC")
    # columns in the bench's scenario order: method | 3-missing | none | mission
    assert "| method | 3-missing | none | mission VRMSE (all scenarios) |" in page
    tc = row(page, "## IMU: as-recorded", "TC")
    assert tc[2] == "0.300 (0.400)"                  # mean of 0.2, 0.2, 0.4, 0.4; worst 0.4
    assert tc[1] == "0.400 (0.500)"
    assert tc[3] == "0.175"                          # mission: mean over scenarios of (0.15, 0.20)
    graph = row(page, "## IMU: as-recorded", "Graph-TC")
    # the diverged window is left out and counted: mean of 0.2, 0.2, 0.4
    assert graph[1] == f"{(0.2 + 0.2 + 0.4) / 3:.3f} (0.400) [1 diverged]"
    batch = row(page, "## IMU: as-recorded", "Graph-HN-batch")
    assert batch[2] == "**0.060** (0.070)" and batch[1].startswith("**0.160**")
    assert row(page, "## IMU: as-recorded", "LC")[2] == "- [1 failed]"


def test_provenance_and_runtime():
    run = {"command": "graphnav bench --data /d --jobs 1", "graphnav_version": "9.9", "finished_utc": "x",
           "wall_time_s": 123.4, "jobs": 1}
    page = results_page(records(), "out/bench/results.json", "2026-01-02 03:04 UTC", run,
                        "graphnav results --from out/bench/results.json --out docs/results.md")
    assert page.splitlines()[0] == GENERATED_MARK
    assert ("Generated on 2026-01-02 03:04 UTC by `graphnav results --from out/bench/results.json --out "
            "docs/results.md` from `out/bench/results.json` (25 window records, 1 of them failed cases)") in page
    assert "`graphnav bench --data /d --jobs 1` (graphnav 9.9" in page and "123 s with 1 job(s)" in page
    assert "Trajectories (2): Trajectory2, Trajectory10." in page           # natural order
    rt = row(page, "## Runtime", "TC")
    assert rt[1:] == ["2.00", "200x", "4"]                                   # one runtime per run, not per window
    assert row(page, "## Runtime", "Graph-TC")[1:] == ["4.00", "100x", "4"]
    # the regime section of the bench report is reused (Graph-TC is present)
    assert "## Regimes" in page
    regime = row(page, "## Regimes", "as-recorded")
    assert regime[3] == f"{(0.2 + 0.2 + 0.4) / 3:.3f} (0.400)"            # diverged window left out here too
    assert "issue" not in page.lower()
    without = results_page(records(), "r.json", "now")
    assert "its command was not recorded" in without


def test_command_writes_replaces_and_refuses(tmp_path, capsys):
    bench_out = tmp_path / "bench"
    bench_out.mkdir()
    (bench_out / "results.json").write_text(json.dumps(records()))
    (bench_out / RUN_RECORD).write_text(json.dumps({"command": "graphnav bench --x"}))
    page = tmp_path / "docs" / "results.md"
    assert main(["results", "--from", str(bench_out), "--out", str(page)]) == 0
    text = page.read_text()
    assert text.startswith(GENERATED_MARK) and "`graphnav bench --x`" in text
    assert str(bench_out / "results.json") in text
    # a page this command made is regenerated in place
    assert main(["results", "--from", str(bench_out / "results.json"), "--out", str(page)]) == 0
    # a hand-written file is kept unless --force
    hand = tmp_path / "notes.md"
    hand.write_text("# my notes\n")
    assert main(["results", "--from", str(bench_out), "--out", str(hand)]) == 1
    assert "was not made by `graphnav results`" in capsys.readouterr().err
    assert hand.read_text() == "# my notes\n"
    assert main(["results", "--from", str(bench_out), "--out", str(hand), "--force"]) == 0
    assert hand.read_text().startswith(GENERATED_MARK)


@pytest.mark.parametrize("content, message", [
    (None, "no such file"),
    ("{not json", "not valid JSON"),
    ("[]", "holds no records"),
    (json.dumps([{"trajectory": "a", "scenario": "none", "imu_grade": "as-recorded", "method": "TC",
                  "window_s": 30.0, "window_start_s": 60.0, "vrmse_window": 0.1, "runtime_s": 1.0}]),
     "record 0 has no 'vrmse_mission'"),
    (json.dumps([3]), "record 0 is a int"),
])
def test_bad_input_is_a_clear_error(tmp_path, capsys, content, message):
    src = tmp_path / "results.json"
    if content is not None:
        src.write_text(content)
    rc = main(["results", "--from", str(src), "--out", str(tmp_path / "page.md")])
    err = capsys.readouterr().err
    assert rc == 1 and message in err and str(src) in err and "Traceback" not in err
    assert not (tmp_path / "page.md").exists()
