"""Option errors of the command line come before any work and name the option: argparse types, the subcommand's own
usage for an unknown option, an outage window outside the mission refused before an estimator runs."""
from __future__ import annotations

import pytest

from graphnav.cli import main
from graphnav.commands import common
from graphnav.evaluation import methods
from graphnav.sim.simulate import simulate_mission


@pytest.fixture
def nothing_loaded(monkeypatch):
    """Reading a mission fails the test: the option error must come first."""
    def loaded(args):
        raise AssertionError("the mission was loaded before the option was checked")
    monkeypatch.setattr(common, "recorded_mission", loaded)


def test_an_unknown_option_is_the_subcommands_error(capsys, nothing_loaded):
    with pytest.raises(SystemExit) as exc:
        main(["smooth", "--metod", "TC"])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert "usage: graphnav smooth" in err and "--metod (did you mean --method?)" in err


@pytest.mark.parametrize("option, value, says", [("--window-s", "-5", "must be a duration > 0 s, got -5"),
                                                 ("--window-s", "0", "must be a duration > 0 s, got 0"),
                                                 ("--window-s", "abc", "not a number: 'abc'"),
                                                 ("--window-start", "nan", "must be a finite time in s, got nan")])
def test_window_options_are_checked_when_parsed(capsys, nothing_loaded, option, value, says):
    with pytest.raises(SystemExit) as exc:
        main(["smooth", "--scenario", "3-missing", option, value])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and f"argument {option}: {says}" in err and "usage: graphnav smooth" in err


@pytest.fixture
def short_mission(monkeypatch):
    """A 40 s simulated mission read instead of --data, and no estimator: the check must come before it."""
    mission = simulate_mission(40.0, seed=1)
    monkeypatch.setattr(common, "recorded_mission", lambda args: mission)

    def solved(*args, **kwargs):
        raise AssertionError("an estimator ran before the window was checked")
    monkeypatch.setattr(methods, "run_method", solved)
    return mission


def test_a_window_outside_the_mission_is_refused_before_solving(tmp_path, capsys, short_mission):
    rc = main(["smooth", "--scenario", "3-missing", "--window-start", "500", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 1
    assert "--window-start 500: the window [500, 530] s lies outside the mission" in err
    assert f"spans [{short_mission.t0:.1f}, {short_mission.t1:.1f}] s" in err


def test_a_window_past_the_end_is_warned_about(short_mission):
    with pytest.warns(RuntimeWarning, match=r"--window-start 30: the window \[30, 60\] s runs past the mission"):
        common.check_windows([30.0], 30.0, short_mission)
    with pytest.warns(RuntimeWarning, match="--window-start / --window-s ignored"):
        import argparse
        common.mission_from_args(argparse.Namespace(imu_grade="as-recorded", scenario="none", window_start=[10.0],
                                                    window_s=30.0))


def test_the_printed_summary_says_what_was_refused_at_load_and_the_loaders_notes():
    """smooth and online print the streams' refusals and notes from the summary's ``streams`` (they read a key
    the summary no longer had, so neither line was ever printed)."""
    import io

    from graphnav.commands.common import print_summary
    summary = {"method": "Graph-HN-batch", "mission": "Trajectory1", "epochs": 149, "duration_s": 150.0,
               "runtime_s": 1.0, "realtime_factor": 150.0,
               "streams": {"imu": {"refused": {"spike in 'GYRO Z [rad/s]'": 1}, "notes": ["axis signs applied"]},
                           "dvl": {"refused": {}, "notes": []}}}
    buf = io.StringIO()
    print_summary(summary, file=buf)
    text = buf.getvalue()
    assert "refused at load (stream: reason: count): {'imu': {\"spike in 'GYRO Z [rad/s]'\": 1}}" in text
    assert "  imu: axis signs applied" in text


def test_a_command_prints_its_warnings_as_warning_lines_without_graphnavs_source(tmp_path):
    """smooth printed Python's default warning form (graphnav's file and line, then the source line that warned);
    a command now prints 'warning: <message>', the message naming the user's input, as info does."""
    import subprocess
    import sys

    from graphnav.io.export import write_akit
    from graphnav.sim.simulate import simulate_mission
    paths = write_akit(simulate_mission(60.0, seed=5), tmp_path)
    imu = paths["IMU"].read_text().splitlines()
    cells = imu[2001].split(",")
    cells[1] = "nan"                              # one refused row: a warning naming the file and line
    imu[2001] = ",".join(cells)
    paths["IMU"].write_text("\n".join(imu) + "\n")
    run = subprocess.run([sys.executable, "-m", "graphnav", "smooth", "--data", str(tmp_path / "Trajectory1"),
                          "--out", str(tmp_path / "out"), "--no-plots"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    assert f"warning: {paths['IMU']}: 1 imu sample(s) refused (1 empty or NaN in" in run.stderr
    assert "RuntimeWarning" not in run.stderr and "graphnav/io/" not in run.stderr
