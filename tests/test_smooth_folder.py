"""`graphnav smooth --data FOLDER`: every mission of a folder of A-KIT missions, one results.json, resume,
the same records on a Dask LocalCluster as with --jobs 1; a single mission folder still works as before."""
from __future__ import annotations

import json

import pytest

from graphnav.cli import main
from graphnav.io.export import write_akit
from graphnav.sim.simulate import simulate_mission

MISSIONS = ("Trajectory1", "Trajectory2")
#: Keys that legitimately differ between two runs of the same missions (wall time, output folder).
VOLATILE = ("runtime_s", "files")


@pytest.fixture(scope="module")
def missions(tmp_path_factory):
    """Two simulated 100 s missions (one 30 s window of the 2-missing scenario each) as TrajectoryN folders."""
    root = tmp_path_factory.mktemp("missions")
    for number, seed in ((1, 0), (2, 1)):
        write_akit(simulate_mission(100.0, seed=seed), root, number=number)
    return root


def _smooth(data, out, *extra):
    return main(["smooth", "--data", str(data), "--out", str(out), "--scenario", "2-missing", "--method",
                 "Graph-TC", "--no-plots", *extra])


def _records(out):
    return json.loads((out / "results.json").read_text())


def _comparable(records):
    return sorted(({k: v for k, v in r.items() if k not in VOLATILE} for r in records), key=lambda r: r["mission"])


@pytest.fixture(scope="module")
def serial(missions, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    assert _smooth(missions, out, "--jobs", "1") == 0
    return out


def test_folder_smooths_every_mission(serial, missions, capsys):
    records = _records(serial)
    assert sorted(r["mission"] for r in records) == list(MISSIONS)
    for r in records:
        assert r["error"] is None and r["method"] == "Graph-TC" and r["scenario"] == "2-missing"
        assert r["ground_truth"] and r["health"]["ok"] and r["runtime_s"] > 0
        # Navigation-grade IMU, one window of 2 missing beams: the graph stays at the cm/s level.
        # (0.101 m/s on one mission with the DVL error states, on by default)
        assert r["vrmse_mission_mps"] < 0.12 and len(r["vrmse_windows_mps"]) == 1
        folder = serial / r["mission"]
        for name in ("trajectory.csv", "trajectory.tum", "groundtruth.tum", "summary.json"):
            assert (folder / name).stat().st_size > 0
        summary = json.loads((folder / "summary.json").read_text())
        assert summary["mission"] == r["mission"]
        assert summary["accuracy"]["vrmse_mission_mps"] == r["vrmse_mission_mps"]
        assert r["drift_pct"] == summary["drift"]["drift_pct"] and r["distance_m"] == summary["drift"]["distance_m"] > 0
        assert r["files"]["trajectory_csv"] == str(folder / "trajectory.csv")


def test_resume_runs_nothing_new_and_rejects_other_settings(serial, missions, capsys):
    before = _records(serial)
    assert _smooth(missions, serial, "--resume") == 0
    assert _records(serial) == before
    assert "2 already done" in capsys.readouterr().err
    rc = main(["smooth", "--data", str(missions), "--out", str(serial), "--method", "TC", "--no-plots", "--resume"])
    assert rc == 1 and "was smoothed with" in capsys.readouterr().err
    assert _records(serial) == before


def test_failed_mission_is_recorded_and_rerun_on_resume(missions, tmp_path):
    root = tmp_path / "data"
    root.mkdir()
    for name in MISSIONS:
        (root / name).symlink_to(missions / name)
    broken = root / "Trajectory3"
    broken.mkdir()
    for kind in ("IMU", "DVL", "GT"):
        (broken / f"{kind}_trajectory3.csv").write_text("not,a,header\n")
    out = tmp_path / "out"
    assert _smooth(root, out) == 1
    records = {r["mission"]: r for r in _records(out)}
    assert records["Trajectory3"]["error"] and records["Trajectory3"]["vrmse_mission_mps"] is None
    assert not records["Trajectory1"]["error"] and not records["Trajectory2"]["error"]
    # --resume keeps the two finished missions and tries the failed one again (and it fails again).
    assert _smooth(root, out, "--resume") == 1
    again = _records(out)
    assert [r["mission"] for r in again].count("Trajectory3") == 1 and len(again) == 3


def test_local_cluster_gives_the_same_records(serial, missions, tmp_path):
    pytest.importorskip("dask.distributed", reason="graphnav[dask] not installed (scripts/setup_env.sh installs it)")
    out = tmp_path / "dask"
    assert _smooth(missions, out, "--scheduler", "local", "--jobs", "1") == 0
    assert _comparable(_records(out)) == _comparable(_records(serial))
    assert (out / "Trajectory2" / "trajectory.csv").read_text() == (serial / "Trajectory2" / "trajectory.csv").read_text()


def test_single_mission_folder_unchanged(missions, tmp_path, capsys):
    out = tmp_path / "one"
    assert _smooth(missions / "Trajectory1", out) == 0
    assert (out / "summary.json").exists() and (out / "trajectory.csv").exists()
    assert not (out / "results.json").exists()
    assert "VRMSE mission" in capsys.readouterr().out
    assert _smooth(missions / "Trajectory1", out, "--resume") == 1
    assert "apply to a folder of missions" in capsys.readouterr().err
