"""Edges a second read of the real-logs and bad-input work found: each a behaviour a user relies on."""
from __future__ import annotations

import io
import json
import warnings

import numpy as np
import pytest

from graphnav.core.config import ConfigOverrides, SensorConfig
from graphnav.core.errors import ConfigError, DataError


def test_a_velocity_only_stream_refused_whole_stops_the_run():
    """Every DVL velocity in mm/s (refused as beyond the DVL's range): the run ends with an error naming the
    stream, as a beam stream does, not with "health: ok"."""
    from graphnav.estimators.navigator import Navigator
    from graphnav.sim.simulate import simulate_mission
    mission = simulate_mission(duration_s=20.0, seed=1, dvl_output="velocity")
    nav = Navigator(mission.config)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for t, v in zip(mission.dvl.t, mission.dvl.v_d):
            if np.all(np.isfinite(v)):
                nav.add_dvl_velocity(float(t), v * 1000.0)
        with pytest.raises(DataError, match="dvl_velocity"):
            nav.finish()


def test_config_values_are_checked_as_a_whole():
    """A key-by-key override runs the dataclasses' own checks: a reversed depth range is refused at once."""
    with pytest.raises(ConfigError, match="depth_range_m"):
        ConfigOverrides.parse({"depth_range_m": [6000, -10]}, "cfg.json").over(SensorConfig())


def test_stream_units_apply_to_fixes_and_headings():
    from graphnav.io.streamio import StreamReader
    lines = [{"type": "units", "time": "ms"},
             {"type": "depth", "t": 1000, "depth_m": 5.0},
             {"type": "fix", "t": 1500, "lat": 0.5, "lon": 0.1, "sigma_m": 2.0},
             {"type": "heading", "t": 1500, "yaw": 0.1, "sigma": 0.01}]
    recs = list(StreamReader(io.StringIO("\n".join(json.dumps(r) for r in lines) + "\n"), "s.jsonl"))
    assert [r["t"] for r in recs] == pytest.approx([1.0, 1.5, 1.5])


def test_depth_of_the_dvl_moves_with_its_clock():
    """A PD0's pressure (``file:pressure``) is the DVL's instrument (``file:vel_bt``): one clock."""
    from graphnav.calibration.clock import _same_instrument
    assert _same_instrument("/x/log.pd0:vel_bt", "/x/log.pd0:pressure")
    assert not _same_instrument("/x/log.pd0:vel_bt", "/x/depth.csv")


def test_online_without_an_estimate_exits_with_an_error(tmp_path, capsys):
    """60 s of a stream cannot gyrocompass (300 s): no estimate, said plainly, exit 1, summary written."""
    from graphnav import cli
    stream = tmp_path / "s.jsonl"
    assert cli.main(["simulate", "--duration", "60", "--stream", str(stream)]) == 0
    code = cli.main(["online", "--stream", str(stream), "--out", str(tmp_path / "out"), "--no-plots",
                     "--no-progress"])
    assert code == 1
    assert "no estimate was made" in capsys.readouterr().err
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["health"]["state"] == "degraded"


def test_online_summary_counts_what_it_repaired_in_the_imu_stream(tmp_path, capsys):
    """An IMU stream in packets of 10 (stamped on receipt) with a 0.5 s dropout: the Navigator restamps the packets
    and bridges the gap as the samples come; summary.json and the printed summary now say how many (before, only the
    warnings did)."""
    from graphnav import cli
    stream = tmp_path / "s.jsonl"
    assert cli.main(["simulate", "--duration", "60", "--stream", str(stream)]) == 0
    records = [json.loads(line) for line in stream.read_text().splitlines()]
    imu = [r for r in records if r.get("type") == "imu"]
    for i, r in enumerate(imu):                   # each packet stamped at its last sample's stamp
        r["t"] = imu[min(10 * (i // 10) + 9, len(imu) - 1)]["t"] - 1e-5 * (9 - i % 10)
    records = [r for r in records if not (r.get("type") == "imu" and 30.0 < r["t"] < 30.5)]
    stream.write_text("\n".join(json.dumps(r) for r in records) + "\n")
    cli.main(["online", "--stream", str(stream), "--out", str(tmp_path / "out"), "--no-plots", "--no-progress"])
    repairs = json.loads((tmp_path / "out" / "summary.json").read_text())["imu_repairs"]
    assert repairs["restamped"] > 4000 and repairs["gaps"] == 1 and repairs["zero_rows"] == 0, repairs
    assert "IMU stream repaired as it came (what: count): {'gaps': 1, 'restamped': " in capsys.readouterr().err


def test_online_summary_counts_the_samples_it_used_though_doubted(tmp_path, capsys):
    """The IMU repeating one reading for 0.6 s in the stream's first second, then silent 1.5 s: with no second of
    samples either side the Navigator uses the samples and counts them as doubted (a stall it cannot tell there), but
    neither summary.json nor the printed summary said so (the count was only in the Navigator's info)."""
    from graphnav import cli
    from graphnav.core.screening import IMU_STALL_UNTOLD
    stream = tmp_path / "s.jsonl"
    assert cli.main(["simulate", "--duration", "20", "--stream", str(stream)]) == 0
    records = [json.loads(line) for line in stream.read_text().splitlines()]
    read = next(r for r in records if r.get("type") == "imu" and r["t"] >= 0.2)
    records = [dict(r, f_b=read["f_b"], omega_b=read["omega_b"]) if r.get("type") == "imu" and 0.2 < r["t"] < 0.8
               else r for r in records if not (r.get("type") == "imu" and 0.8 <= r["t"] < 2.3)]
    stream.write_text("\n".join(json.dumps(r) for r in records) + "\n")
    cli.main(["online", "--stream", str(stream), "--out", str(tmp_path / "out"), "--no-plots", "--no-progress"])
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["doubted"] == {"imu": {IMU_STALL_UNTOLD: 59}}, summary.get("doubted")
    assert f"used despite a doubt (stream: reason: count): {{'imu': {{\"{IMU_STALL_UNTOLD}\": 59}}}}" \
        in capsys.readouterr().err
