"""Nothing lost: every command's --out checked before any work, results moved into place only when complete,
an earlier run kept unless --force (then replaced whole), --resume never writing an epoch twice, --stream on a
missing file, train-beams leaving the shipped weights alone unless --install-weights."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from graphnav.cli import main
from graphnav.commands import online as online_cmd
from graphnav.commands.common import StagedOut, check_out, check_out_file
from graphnav.core.errors import ConfigError
from graphnav.io.outputs import EpochCsvWriter, written_stamp


def _err(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


# --- the shared rules ----------------------------------------------------------------------------------------
def test_check_out_rules(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("x")
    with pytest.raises(ConfigError, match="is a file, not a folder"):
        check_out(afile)
    with pytest.raises(ConfigError, match="cannot be created, .*afile is a file"):
        check_out(afile / "sub" / "deeper")
    assert check_out(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"   # creatable
    full = tmp_path / "full"
    full.mkdir()
    (full / "summary.json").write_text("{}")
    with pytest.raises(ConfigError, match=r"holds the results of an earlier run \(summary.json\); they are kept"):
        check_out(full)
    with pytest.raises(ConfigError, match="or --resume to continue"):
        check_out(full, resume=False)
    assert check_out(full, force=True) == full and check_out(full, resume=True) == full
    with pytest.raises(ConfigError, match="exists and is kept"):
        check_out_file(full / "summary.json")
    with pytest.raises(ConfigError, match="is a folder"):
        check_out_file(full)


def test_force_never_empties_the_current_folder_or_a_parent(tmp_path, monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    (work / "notes.txt").write_text("mine")
    monkeypatch.chdir(work)
    for out in (".", str(work), str(tmp_path)):
        with pytest.raises(ConfigError, match="--force would delete the whole of"):
            check_out(out, force=True)
    assert (work / "notes.txt").read_text() == "mine"


def test_staged_out_moves_whole_or_not_at_all(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old_plot.png").write_text("old")
    with pytest.raises(RuntimeError):
        with StagedOut(out, force=True) as staged:
            (staged.path / "trajectory.csv").write_text("partial")
            raise RuntimeError("crash mid-run")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]          # no partial folder left
    assert sorted(p.name for p in out.iterdir()) == ["old_plot.png"]       # the earlier run untouched
    with StagedOut(out, force=True) as staged:
        (staged.path / "trajectory.csv").write_text("new")
        assert staged.final(staged.path / "trajectory.csv") == str(out / "trajectory.csv")
        assert (out / "old_plot.png").exists()                              # replaced only at the end
    assert sorted(p.name for p in out.iterdir()) == ["trajectory.csv"]      # replaced whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# --- smooth ------------------------------------------------------------------------------------------------
SMOOTH = ["smooth", "--duration", "30", "--no-plots", "--method", "Graph-TC-batch"]


@pytest.mark.parametrize("where, message", [("afile", "is a file, not a folder"),
                                            ("afile/sub", "cannot be created")])
def test_smooth_out_not_a_folder_before_any_work(where, message, tmp_path, capsys, monkeypatch):
    (tmp_path / "afile").write_text("x")
    from graphnav.commands import smooth
    monkeypatch.setattr(smooth, "mission_from_args", lambda args: pytest.fail("work started"))
    assert main([*SMOOTH, "--out", str(tmp_path / where)]) == 1
    assert message in _err(capsys)


def test_smooth_keeps_an_earlier_run_and_force_replaces_it_whole(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "velocity_error.png").write_text("plot of an earlier run")
    assert main([*SMOOTH, "--out", str(out)]) == 1
    assert "holds the results of an earlier run (velocity_error.png)" in _err(capsys)
    assert (out / "velocity_error.png").read_text() == "plot of an earlier run"
    assert main([*SMOOTH, "--out", str(out), "--force"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["groundtruth.tum", "summary.json", "trajectory.csv",
                                                     "trajectory.tum", "trajectory_cov.csv"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["files"]["trajectory_csv"] == str(out / "trajectory.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_smooth_carries_the_reference_once_for_the_tum_file_and_the_nees(tmp_path, monkeypatch):
    from graphnav.evaluation import consistency
    calls = []
    carry = consistency.scoring_reference
    monkeypatch.setattr(consistency, "scoring_reference", lambda sol, mission: calls.append(1) or carry(sol, mission))
    assert main([*SMOOTH, "--duration", "90", "--out", str(tmp_path / "out")]) == 0    # NEES from 60 s on
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert len(calls) == 1 and summary["accuracy"]["consistency"]["velocity"]["nees"] > 0


def test_smooth_crash_leaves_the_earlier_run(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    assert main([*SMOOTH, "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    from graphnav.evaluation import methods

    def diverge(*args, **kwargs):
        raise ConfigError("the estimator stopped")
    monkeypatch.setattr(methods, "run_method", diverge)
    assert main([*SMOOTH, "--out", str(out), "--force"]) == 1
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# --- online ------------------------------------------------------------------------------------------------
def test_resume_never_rewrites_an_epoch_whose_stamp_the_csv_rounds(tmp_path):
    """A real stamp (1234.56789012345 s) is held with 10 significant digits in the CSV; on --resume the epoch
    replayed with the full stamp must still count as written."""
    t = 1234.56789012345
    path = tmp_path / "online.csv"
    with EpochCsvWriter(path) as w:
        w.write(t - 1.0, np.zeros(3), np.zeros(3), np.eye(3))
        w.write(t, np.zeros(3), np.zeros(3), np.eye(3))
    with EpochCsvWriter(path, resume=True) as w:
        assert w.last_t == written_stamp(t) != t

        class Est:
            def __init__(self, t):
                self.t, self.p_n, self.v_n, self.C_b_n = t, np.zeros(3), np.zeros(3), np.eye(3)
                self.cov_v_n = self.bias = None

        class Bar:
            def update(self, n):
                pass
        sink = online_cmd.EpochSink(w, Bar(), w.last_t, realtime=False, speed=1.0)
        for s in (t - 1.0, t, t + 1.0):
            sink(Est(s))
    assert sink.n_replayed == 2 and sink.n_new == 1
    stamps = [float(r.split(",")[0]) for r in path.read_text().splitlines()[1:]]
    assert len(stamps) == len(set(stamps)) == 3


ONLINE = ["online", "--duration", "30", "--method", "Graph-TC", "--no-progress", "--no-plots"]


def test_online_out_rules(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "trajectory_ne.png").write_text("old")
    assert main([*ONLINE, "--out", str(out)]) == 1
    assert "or --resume to continue" in _err(capsys)
    assert main([*ONLINE, "--out", str(out), "--force"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["online.csv", "summary.json"]


def test_online_stream_missing_file(tmp_path, capsys):
    assert main(["online", "--stream", str(tmp_path / "nope.jsonl"), "--out", str(tmp_path / "o")]) == 1
    assert "--stream " + str(tmp_path / "nope.jsonl") + ": file not found" in _err(capsys)
    assert not (tmp_path / "o").exists()


# --- calibrate, simulate -----------------------------------------------------------------------------------
def test_calibrate_keeps_an_existing_config(tmp_path, capsys):
    cfg = tmp_path / "calibrated.json"
    cfg.write_text("{}")
    assert main(["calibrate", "--duration", "20", "--out", str(cfg), "--no-noise"]) == 1
    assert "exists and is kept" in _err(capsys) and cfg.read_text() == "{}"


def test_simulate_out_staged_and_kept(tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", "--duration", "20", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["Trajectory1", "trajectory1.png"]
    assert main(["simulate", "--duration", "20", "--out", str(out)]) == 1
    assert "holds the results of an earlier run" in _err(capsys)


# --- train-beams ---------------------------------------------------------------------------------------------
@pytest.fixture
def fake_training(tmp_path, monkeypatch):
    """train-beams with the training replaced by a stub that writes a file per scenario, and the package's
    weights folder redirected to a temporary one."""
    from graphnav.nets import storage, training
    shipped = tmp_path / "shipped"
    shipped.mkdir()
    (shipped / "2-missing.pt").write_text("shipped weights")
    monkeypatch.setattr(storage, "weights_dir", lambda: shipped)
    card = {"scenario": "2-missing", "training": {"epochs_run": 1, "best_epoch": 1, "time_s": 0.1},
            "metrics": {k: {"beam_rmse": 0.1, "vel_rmse": 0.1, "within_1sigma": 0.6, "within_2sigma": 0.9}
                        for k in ("val", "test")}, "constant_sigma": 0.1, "n_past": 3}
    monkeypatch.setattr(training, "train", lambda *a, **k: training.TrainResult(model=None, card=card))

    def save(result, directory):
        directory = Path(directory)
        (directory / "2-missing.pt").write_text("barely trained")
        (directory / "2-missing.json").write_text(json.dumps(result.card))
        return directory / "2-missing.pt", directory / "2-missing.json"
    monkeypatch.setattr(training, "save", save)
    return shipped


def test_train_beams_leaves_the_shipped_weights_alone(fake_training, tmp_path, capsys):
    out = tmp_path / "trained"
    assert main(["train-beams", "--scenario", "2-missing", "--epochs", "1", "--out", str(out), "--no-progress"]) == 0
    assert (fake_training / "2-missing.pt").read_text() == "shipped weights"
    assert (out / "2-missing.pt").read_text() == "barely trained"
    assert main(["train-beams", "--scenario", "2-missing", "--epochs", "1", "--out", str(out), "--force",
                 "--install-weights", "--no-progress"]) == 0
    assert (fake_training / "2-missing.pt").read_text() == "barely trained"
    assert sorted(p.name for p in fake_training.iterdir()) == ["2-missing.json", "2-missing.pt"]
    assert "installed 2-missing.pt, 2-missing.json" in capsys.readouterr().out


# --- a live stream shows life --------------------------------------------------------------------------------
def test_status_while_aligning(tmp_path):
    """A Navigator aligning from the sensors (given heading: 20 s of levelling): status records at the first
    record, then every `every_s` of (fake) wall time, saying what it waits for; one more when it navigates."""
    import io

    from graphnav.estimators.align import AlignOptions
    from graphnav.estimators.navigator import Navigator, NavigatorOptions
    from graphnav.estimators.replay import mission_records
    from graphnav.io.streamio import feed
    from graphnav.sim.simulate import simulate_mission
    mission = simulate_mission(40.0, seed=1)
    nav = Navigator(mission.config, "ekf", options=NavigatorOptions(align=AlignOptions(initial_heading_rad=0.0)))
    ticks = iter(np.arange(0.0, 1e4, 0.01))
    out, err = io.StringIO(), io.StringIO()
    status = online_cmd.StatusReporter(1.0, out=out, err=err, clock=lambda: float(next(ticks)))
    for rec in mission_records(mission, config=False):
        feed(nav, rec)
        status(nav, rec["t"])
    records = [json.loads(line) for line in out.getvalue().splitlines()]
    assert all(r["type"] == "status" for r in records)
    first, last = records[0], records[-1]
    assert first["state"] == "aligning" and first["t"] == 0.0
    assert set(first["alignment"]["waiting_for"]) == {"imu time", "dvl bottom lock"}
    assert first["alignment"]["heading"] == "given" and first["alignment"]["needed_s"] == 20.0
    assert last["state"] == "navigating" and 19.0 <= last["t"] <= 25.0
    aligning = [r for r in records if r["state"] == "aligning"]
    # one record per 100 ticks of 0.01 s (plus rounding of the tick sum): about every 1 s of wall time
    assert np.all(np.diff([r["wall_s"] for r in aligning]) >= 1.0 - 1e-9)
    assert len(aligning) >= 10
    assert np.all(np.diff([r["alignment"]["aligned_s"] for r in aligning]) > 0)
    lines = err.getvalue().splitlines()
    assert len(lines) == len(records) and "aligning from the sensors" in lines[0] and "navigating" in lines[-1]


def test_online_stream_prints_status_and_schema(tmp_path, capsys):
    stream = tmp_path / "s.jsonl"
    assert main(["simulate", "--duration", "40", "--stream", str(stream)]) == 0
    capsys.readouterr()
    assert main(["online", "--stream", str(stream), "--init", "sensors", "--initial-heading", "0",
                 "--out", str(tmp_path / "o"), "--method", "TC", "--no-plots"]) == 0
    captured = capsys.readouterr()
    kinds = [json.loads(line)["type"] for line in captured.out.splitlines()]
    assert kinds[0] == "status" and "estimate" in kinds
    assert "graphnav online: t = 0.0 s: aligning from the sensors" in captured.err
    assert main(["online", "--schema"]) == 0
    schema = capsys.readouterr().out
    assert "status" in schema and "imu.gyro_noise_density" in schema and "waiting_for" in schema
    with pytest.raises(SystemExit):
        main(["online", "--help"])
    assert "--schema" in capsys.readouterr().out


def test_silent_stream_says_it_waits(tmp_path):
    """Nothing on standard input: a 'waiting for data' status within a second or two, not silence."""
    import subprocess
    import sys
    proc = subprocess.Popen([sys.executable, "-m", "graphnav", "online", "--stream", "-", "--status-every", "0.5",
                             "--out", str(tmp_path / "o")], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    import threading
    killer = threading.Timer(120, proc.kill)       # a hung run fails the test instead of hanging it
    killer.start()
    try:
        first = proc.stderr.readline()             # blocks until the run says something
        proc.stdin.close()
        rest = proc.stderr.read()
        out = proc.stdout.read()
        proc.wait(timeout=60)
    finally:
        killer.cancel()
        if proc.poll() is None:
            proc.kill()
    err = first + rest
    status = [json.loads(line) for line in out.splitlines()]
    assert status and status[0]["state"] == "waiting for data" and status[0]["source"] == "<stdin>"
    assert "no record from <stdin> for" in err
    assert proc.returncode == 1 and "the stream holds no measurement record" in err


def test_staged_out_into_an_empty_existing_folder(tmp_path):
    out = tmp_path / "made_by_the_user"
    out.mkdir()
    inode = out.stat().st_ino
    with StagedOut(out) as staged:
        (staged.path / "a.csv").write_text("a")
    assert out.stat().st_ino == inode and [p.name for p in out.iterdir()] == ["a.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["made_by_the_user"]
