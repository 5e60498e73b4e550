"""Loaders that only read, and the prepare step that estimates what a read mission needs (axis signs, time
offsets, a DVL clock, the GT at the IMU point): docs/decisions/loading-and-prepare.md."""
from __future__ import annotations

import dataclasses
import json
import re
import warnings

import numpy as np
import pytest

from graphnav.calibration.preparation import prepare
from graphnav.core.errors import ConfigError
from graphnav.io.loaders import read_mission
from graphnav.missions import load_mission
from graphnav.sim.simulate import simulate_mission


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kwargs)


def test_read_mission_only_reads(akit_dir):
    read = _quiet(read_mission, akit_dir / "Trajectory5")
    assert read.meta["prepared"] is False and read.meta["prepare"]["format"] == "akit"
    np.testing.assert_array_equal(read.config.imu_axis_signs, [1, 1, 1])         # the file's axes
    assert read.config.gt_time_offset_s == 0.0 and read.config.dvl_time_offset_s == 0.0
    assert read.dvl.t[0] == read.gt.t[0]                                        # the files' own stamps
    assert "time_offsets" not in read.meta and read.meta["gt_point_b"] == [0.0, 0.0, 0.0]


def test_prepare_of_read_is_load_mission(akit_dir):
    read = _quiet(read_mission, akit_dir / "Trajectory5")
    with pytest.warns(UserWarning, match="IMU axis convention"):
        prepared = prepare(read)
    loaded = _quiet(load_mission, akit_dir / "Trajectory5")
    assert read.meta["prepared"] is False                      # the mission read is not changed
    assert prepared.meta["prepared"] is True and set(prepared.meta["time_offsets"]) == {"gt", "dvl"}
    for a, b in ((prepared.imu.f_b, loaded.imu.f_b), (prepared.dvl.t, loaded.dvl.t), (prepared.gt.p_n, loaded.gt.p_n),
                 (prepared.depth.depth, loaded.depth.depth), (prepared.dvl.beams, loaded.dvl.beams)):
        np.testing.assert_array_equal(a, b)
    assert prepared.config.dvl_time_offset_s == loaded.config.dvl_time_offset_s
    np.testing.assert_array_equal(prepared.imu.omega_b[:, 1], -read.imu.omega_b[:, 1])     # y flipped


def test_explicit_values_are_used_as_given(akit_dir):
    read = _quiet(read_mission, akit_dir / "Trajectory5")
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=".*IMU axis convention")
        m = prepare(read, imu_axis_signs=(1, -1, 1), gt_time_offset_s=0.0, dvl_time_offset_s=1.0)
    np.testing.assert_array_equal(m.config.imu_axis_signs, [1, -1, 1])
    np.testing.assert_allclose(m.dvl.t, read.dvl.t + 1.0)
    assert m.meta["time_offsets"] == {}
    with pytest.raises(ConfigError, match=r"\+-1"):
        prepare(read, imu_axis_signs=(1, 2, 1))


def test_prepared_and_simulated_missions_pass_through():
    sim = simulate_mission(20.0, seed=1)
    assert prepare(sim) is sim
    with pytest.raises(ConfigError, match="prepared already"):
        prepare(sim, dvl_time_offset_s=0.5)
    with pytest.raises(ConfigError, match="simulated default"):
        read_mission(None)


@pytest.mark.parametrize("rate", [20.0, 50.0, 200.0])
def test_an_imu_at_another_rate_than_configured_is_noted_and_its_rate_used(rate, tmp_path, capsys):
    import json

    from graphnav import cli
    from graphnav.core.config import SensorConfig
    from graphnav.estimators.keyframes import Keyframer
    from graphnav.io.export import write_akit
    config = SensorConfig()
    config.imu_rate_hz = rate
    written = simulate_mission(duration_s=30.0, seed=1, config=config, gt_rate_hz=10.0 if rate > 20 else 5.0)
    folder = write_akit(written, tmp_path)["IMU"].parent
    cfg = written.config.to_dict()
    cfg["imu_rate_hz"] = 100.0
    (tmp_path / "cfg100.json").write_text(json.dumps(cfg))
    m = _quiet(load_mission, folder, tmp_path / "cfg100.json")
    assert m.config.imu_rate_hz == pytest.approx(rate, rel=1e-6)
    note = f"runs at {rate:g} Hz (stamp period {1e3 / rate:g} ms), not the configured imu_rate_hz 100 Hz"
    assert [n for n in m.meta["streams"]["imu"]["notes"] if note in n]
    # at 20 Hz against 100 every sample was an IMU gap to bridge (3000 warnings over 150 s)
    keyframer = Keyframer(m.config)
    for t, f, w in zip(m.imu.t, m.imu.f_b, m.imu.omega_b):
        keyframer.add_imu(float(t), tuple(f), tuple(w))
    assert keyframer.stats.imu_gaps == []
    assert _quiet(cli.main, ["info", str(folder), "--config", str(tmp_path / "cfg100.json")]) == 0
    assert note in capsys.readouterr().out
    # the configured rate, measured: nothing said
    same = _quiet(load_mission, folder)
    notes = same.meta["streams"]["imu"]["notes"]
    assert same.config.imu_rate_hz == rate and not [n for n in notes if "not the configured" in n]


@pytest.mark.parametrize("rate", [20.0, 100.0, 200.0])
def test_a_live_stream_at_another_rate_than_its_configuration_is_not_a_gap_at_every_step(rate):
    """A stream's configuration line is not prepared: the keyframer measures the period itself (warned once), and a
    real gap is still bridged."""
    from graphnav.core.config import SensorConfig
    from graphnav.estimators.keyframes import Keyframer
    t = np.arange(0.0, 10.0, 1.0 / rate)
    t = np.concatenate([t, t[-1] + 1.0 + np.arange(0.0, 2.0, 1.0 / rate)])       # then a 1 s gap
    keyframer = Keyframer(SensorConfig())                                          # imu_rate_hz 100
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for t_k in t:
            keyframer.add_imu(float(t_k), (0.0, 0.0, -9.81), (0.0, 0.0, 0.0))
    said = [str(w.message) for w in caught if "not the configured imu_rate_hz" in str(w.message)]
    assert len(said) == (0 if rate == 100.0 else 1)
    gaps = [(g.t_start, round(g.t_end - g.t_start, 6)) for g in keyframer.stats.imu_gaps]
    assert gaps == [(t[int(10 * rate) - 1], 1.0)]
    assert keyframer.imu_period.period_s == pytest.approx(1.0 / rate)


def test_an_imu_with_stamps_in_whole_milliseconds_is_prepared_at_its_rate(tmp_path):
    """A 400 Hz IMU logged in ms (steps of 2 and 3 ms, one sample dropped) read 333 or 500 Hz from its median step:
    prepare reads 400 Hz from its mean step and says the stamps are quantised."""
    from graphnav.core.config import SensorConfig
    from graphnav.io.export import write_akit
    config = SensorConfig()
    config.imu_rate_hz = 400.0
    written = simulate_mission(duration_s=30.0, seed=1, config=config, gt_rate_hz=10.0)
    folder = write_akit(written, tmp_path)["IMU"].parent
    imu_file = next(folder.glob("IMU_*.csv"))
    header, *rows = imu_file.read_text().splitlines()
    del rows[1001]
    rows = [f"{round(float(r.split(',', 1)[0]) * 1e3 + 0.3) / 1e3:.3f},{r.split(',', 1)[1]}" for r in rows]
    imu_file.write_text("\n".join([header, *rows]) + "\n")
    m = _quiet(load_mission, folder)
    assert m.config.imu_rate_hz == pytest.approx(400.0, rel=1e-3)
    notes = m.meta["streams"]["imu"]["notes"]
    assert [n for n in notes if "stamps on a 1 ms grid, 40% of a step (steps of 2, 3 ms)" in n]


def test_a_prepared_mission_written_as_an_akit_folder_reads_back_as_it_was(tmp_path):
    """A prepared mission's files hold its data with the axis signs and time offsets applied. The configuration
    written beside them held those signs and offsets, so reading the folder back applied them again (a y gyro
    flipped back); it now says (1, 1, 1) and 0 s, and the data read back as written. A value in that configuration
    the data disagree with is named by the file it came from, not 'the configuration'."""
    from graphnav.io.export import write_akit
    m = simulate_mission(duration_s=120.0, seed=3)
    m.config = dataclasses.replace(m.config, imu_axis_signs=(1.0, -1.0, 1.0), gt_time_offset_s=-0.4,
                                   dvl_time_offset_s=0.9)        # as a prepared A-KIT mission records them
    paths = write_akit(m, tmp_path)
    written = json.loads(paths["config"].read_text())
    assert (written["imu_axis_signs"], written["gt_time_offset_s"], written["dvl_time_offset_s"]) == ([1, 1, 1], 0, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = load_mission(paths["config"].parent)
    np.testing.assert_allclose(back.imu.omega_b, m.imu.omega_b, atol=1e-9)
    np.testing.assert_allclose(back.dvl.t, m.dvl.t, atol=1e-9)
    written["gt_time_offset_s"] = 0.5
    paths["config"].write_text(json.dumps(written))
    with pytest.warns(RuntimeWarning, match=rf"^{re.escape(str(paths['config']))}: gt_time_offset_s = \+0\.500 s is "
                                            "given, but the data say"):
        load_mission(paths["config"].parent)


@pytest.mark.parametrize("k, spacing_s", [(10, 1e-5), (3, 1e-4), (10, 1e-3)])
def test_an_imu_stamped_in_packets_is_put_back_on_its_period(k, spacing_s, tmp_path, capsys):
    """A driver stamping k samples together on receipt (each packet at its last sample's stamp, ``spacing_s`` apart):
    the A-KIT reader refused the folder (median step 1e-05 s, no plausible period), and a log read anyway integrated
    each sample at its packet's stamp (a column map declaring seconds: VRMSE 0.045 m/s for packets of 10 against
    0.0026). prepare puts the stamps back on the period (spread back from each packet's last one), warned once, noted
    and counted; the clean folder keeps its stamps, bit for bit. Samples 1 ms apart inside a packet (a serial driver)
    were split where a step was under a tenth of the period: 1659 of 6001 stamps moved and imu_rate_hz 1000 Hz
    written and the warning said packets of 9. The warning says a driver stamping a packet's first sample leaves
    the stamps (k - 1) periods early."""
    from graphnav import cli
    from graphnav.io.export import write_akit
    clean = simulate_mission(duration_s=30.0, seed=1)
    n = clean.imu.t.size // k * k                       # whole packets
    clean = dataclasses.replace(clean, imu=clean.imu.take(slice(0, n)))
    i = np.arange(n)
    stamped = clean.imu.t[i // k * k + k - 1] + i % k * spacing_s
    folder = write_akit(dataclasses.replace(clean, imu=dataclasses.replace(clean.imu, t=stamped)),
                        tmp_path / "packets")["IMU"].parent
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(folder)
    said = [str(w.message) for w in caught if "stamped in packets" in str(w.message)]
    assert len(said) == 1 and said[0].startswith(f"imu: {folder / 'IMU_trajectory1.csv'}: stamped in packets of {k} ")
    assert "restamped at the period 10 ms" in said[0] and f"leaves them {k - 1} period" in said[0]
    np.testing.assert_allclose(m.imu.t, clean.imu.t + (k - 1) * spacing_s, rtol=0, atol=1e-9)     # on the receipt
    entry = m.meta["streams"]["imu"]
    assert entry["restamped"] == n - n // k and entry["rate_hz"] == pytest.approx(100.0)
    assert [note for note in entry["notes"] if note in said[0]]
    assert _quiet(cli.main, ["info", str(folder)]) == 0
    assert f"imu: stamped in packets of {k} " in capsys.readouterr().out
    written = write_akit(clean, tmp_path / "clean")["IMU"].parent
    even = _quiet(load_mission, written)
    assert "restamped" not in even.meta["streams"]["imu"]
    as_written = np.loadtxt(written / "IMU_trajectory1.csv", delimiter=",", skiprows=1)[:, 0]
    np.testing.assert_array_equal(even.imu.t, as_written)


def _akit_with_imu_stamps(clean, stamps, folder):
    """``clean`` written as an A-KIT folder under ``folder`` with its IMU rows kept where ``stamps`` (s, one per
    sample) is finite, at those stamps: the IMU file's path."""
    from graphnav.io.export import write_akit
    path = write_akit(clean, folder)["IMU"]
    lines = path.read_text().splitlines()
    rows = [f"{float(s)!r}{line[line.index(','):]}" for s, line in zip(stamps, lines[1:]) if np.isfinite(s)]
    path.write_text("\n".join([lines[0]] + rows) + "\n")
    return path


def test_shared_stamp_packets_missing_samples_keep_the_period_and_are_restamped_once(tmp_path):
    """Packets of 10 sharing one stamp at 100 Hz with 5 % of the samples lost: the period was samples over time,
    10.5 ms, and every stamp but a packet's last was spread back over up to 33 ms too long; now the cycle over the
    count, 10 ms. A 200 Hz IMU logged in rounded 10 ms (stamps shared by one and three samples in turn) was restamped
    by the reader as packets of 2 and again by prepare as packets of 4: two warnings, the second count written over
    the first; now the reader's restamp alone."""
    from graphnav.core.config import SensorConfig
    clean = simulate_mission(duration_s=20.0, seed=1)
    t = clean.imu.t
    i = np.arange(t.size)
    lost = (np.random.default_rng(0).random(t.size) < 0.05) & (i >= 10)         # the clock starts at the first
    shared = np.where(lost, np.nan, t[np.minimum(i // 10 * 10 + 9, t.size - 1)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(_akit_with_imu_stamps(clean, shared, tmp_path / "lost").parent)
    assert m.config.imu_rate_hz == pytest.approx(100.0, rel=1e-3)
    early = t[~lost] - m.imu.t          # a sample before a lost one in its packet goes one period late
    assert np.all(early < 1e-9) and np.mean(early > -1e-9) > 0.75 and np.min(early) > -0.031
    assert "restamped at the period 10 ms" in m.meta["streams"]["imu"]["notes"][0]
    fast = simulate_mission(duration_s=20.0, seed=1, config=dataclasses.replace(SensorConfig(), imu_rate_hz=200.0))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(_akit_with_imu_stamps(fast, np.round(fast.imu.t / 0.01) * 0.01, tmp_path / "q").parent)
    said = [str(w.message) for w in caught if re.search("stamped in packets|ms clock", str(w.message))]
    assert len(said) == 1 and f"{m.meta['streams']['imu']['restamped']} of {fast.imu.t.size} stamps" in said[0]


@pytest.mark.parametrize("rate_hz, grid_s, how", [(200.0, 0.01, "jitter"), (400.0, 0.01, "round"),
                                                  (2000.0, 0.001, "jitter")])
def test_an_imu_on_a_clock_coarser_than_its_period_loads_at_its_rate(rate_hz, grid_s, how, tmp_path):
    """A 200 Hz IMU logged in whole 10 ms with 0.5 ms jitter (400 Hz in rounded 10 ms, 2 kHz in whole ms with jitter)
    was read as packets sharing one stamp, each run squeezed into the room before it, and prepare wrote 233.7 (458,
    2337) Hz into the configuration. Now its stamps are put on one even grid at the period and the rate written is
    that period's. A rate that contradicts the period the stamps were restamped at (the restamping misread them) was
    refused, losing the log: it is now warned about, counted as doubted, and the rate the stamps give is used."""
    from graphnav.core.config import SensorConfig
    clean = simulate_mission(duration_s=20.0, seed=1, config=dataclasses.replace(SensorConfig(), imu_rate_hz=rate_hz))
    t = clean.imu.t
    if how == "jitter":
        t = np.floor(np.sort(t + np.random.default_rng(0).normal(0.0, 0.1 / rate_hz, t.size)) / grid_s) * grid_s
    else:
        t = np.round(t / grid_s) * grid_s
    folder = _akit_with_imu_stamps(clean, t, tmp_path).parent
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(folder)
        entry = m.meta["streams"]["imu"]
        assert m.config.imu_rate_hz == pytest.approx(rate_hz, rel=1e-3) == entry["rate_hz"]
        assert f"{1e3 * grid_s:g} ms clock" in entry["notes"][0] and entry["restamped"] > 0.4 * t.size
    read = read_mission(folder)
    read.meta["streams"]["imu"]["restamp_period_s"] *= 1.1
    with pytest.warns(RuntimeWarning, match=r"field 't': IMU stamps restamped at the period .* ms read .* Hz"):
        again = prepare(read)
    assert again.config.imu_rate_hz == pytest.approx(rate_hz, rel=1e-3)
    assert again.meta["streams"]["imu"]["doubted"]["restamped off the period"] == entry["restamped"]


@pytest.mark.parametrize("rate_hz", [100.0, 50.0])
def test_an_imu_on_a_clock_as_coarse_as_its_period_or_half_of_it_loads_at_its_rate(rate_hz, tmp_path):
    """100 Hz logged in whole 10 ms with 1 ms of jitter (most steps 10 ms, some 0 and 20 ms) was refused as
    duplicated stamps; it loads now, every sample kept, put on an even grid at its rate and said. 50 Hz in whole
    10 ms with the same jitter (steps of 10, 20, 30 ms) was written 42.7 or 60 Hz into the configuration, silently:
    now 50 Hz."""
    from graphnav.core.config import SensorConfig
    clean = simulate_mission(duration_s=30.0, seed=1, config=dataclasses.replace(SensorConfig(), imu_rate_hz=rate_hz))
    rng = np.random.default_rng(4)
    t = np.floor(np.sort(clean.imu.t + rng.normal(0.0, 1e-3, clean.imu.t.size)) / 0.01) * 0.01
    folder = _akit_with_imu_stamps(clean, t, tmp_path).parent
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(folder)
    assert m.imu.t.size == clean.imu.t.size
    assert m.config.imu_rate_hz == pytest.approx(rate_hz, rel=1e-3) == m.meta["streams"]["imu"]["rate_hz"]
    if rate_hz == 100.0:
        said = [str(w.message) for w in caught if "ms clock" in str(w.message)]
        assert len(said) == 1 and "10 ms clock, about as coarse as the IMU's 10 ms period" in said[0]
        assert m.meta["streams"]["imu"]["restamped"] > 0.9 * t.size
        assert np.max(np.abs(m.imu.t - clean.imu.t)) < 0.005


def _column_map_with_imu_stamps(clean, stamps, folder):
    """``clean``'s IMU at ``stamps`` (s) and its DVL beams written as a column-map folder under ``folder``; the map."""
    for name, columns in (("imu", [stamps, clean.imu.f_b, clean.imu.omega_b]), ("dvl", [clean.dvl.t, clean.dvl.beams])):
        rows = [",".join(f"{x!r}" for x in row) for row in np.column_stack(columns).tolist()]
        header = "t,ax,ay,az,gx,gy,gz" if name == "imu" else "t,b1,b2,b3,b4"
        (folder / f"{name}.csv").write_text("\n".join([header] + rows) + "\n")
    return {"imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"]},
            "dvl": {"file": "dvl.csv", "t": "t", "beams": ["b1", "b2", "b3", "b4"]}}


def _written_with_imu_stamps(clean, stamps, reader, cfg, folder):
    """``clean`` with its IMU at ``stamps`` (s) written under the new ``folder`` for ``reader`` ("akit" or "column
    map"), the configuration ``cfg`` (a dict, a column map's ``csv_columns`` added) beside it as config.json: the
    folder to read."""
    folder.mkdir()
    if reader == "akit":
        read = _akit_with_imu_stamps(clean, stamps, folder).parent
    else:
        read, cfg["csv_columns"] = folder, _column_map_with_imu_stamps(clean, stamps, folder)
    (folder.parent / "config.json").write_text(json.dumps(cfg))
    return read


@pytest.mark.parametrize("reader", ["akit", "column map"])
def test_the_imu_stream_shows_the_rate_measured_from_its_stamps_not_its_median_step(reader, tmp_path):
    """A 70 Hz IMU on a 10 ms clock (steps of 10 and 20 ms) configured at 100 Hz is taken at 70 Hz, but the stream's
    entry, what ``graphnav info`` prints, said 100 Hz, the median step, for every reader; a 97 Hz IMU configured at
    100 Hz (within the tolerance: taken at 100 Hz) showed 100 Hz. It shows the rate measured from the stamps."""
    from graphnav.core.config import SensorConfig
    for rate, stamps_of in ((70.0, lambda n: np.floor(np.arange(n) / 70.0 / 0.01 + 1e-9) * 0.01),
                            (97.0, lambda n: np.arange(n) / 97.0)):
        simulated = 70.0 if rate == 70.0 else 100.0         # the simulator's rates divide its 10 Hz depth
        clean = simulate_mission(duration_s=30.0, seed=1,
                                 config=dataclasses.replace(SensorConfig(), imu_rate_hz=simulated))
        stamps = stamps_of(clean.imu.t.size)
        cfg = dataclasses.replace(clean.config, imu_rate_hz=100.0).to_dict()
        folder = _written_with_imu_stamps(clean, stamps, reader, cfg, tmp_path / f"{reader}-{rate:g}")
        m = _quiet(load_mission, folder, tmp_path / "config.json")
        assert m.config.imu_rate_hz == pytest.approx(70.0 if rate == 70.0 else 100.0, rel=1e-3)
        assert m.meta["streams"]["imu"]["rate_hz"] == pytest.approx(rate, rel=1e-6)


def test_an_imu_rate_within_the_tolerance_of_the_configured_one_says_the_configured_one_is_kept(tmp_path, capsys):
    """A 97 Hz IMU configured at 100 Hz showed 97 Hz in ``graphnav info`` but nothing said the run keeps 100 Hz for
    its IMU gap limits and bridging (within the 5 % tolerance): a note says so and how to change it; at 99.5 Hz
    (within 1 %) and the configured 100 Hz nothing is said."""
    from graphnav import cli
    from graphnav.core.config import SensorConfig
    clean = simulate_mission(duration_s=30.0, seed=1, config=dataclasses.replace(SensorConfig(), imu_rate_hz=100.0))
    said, folders = {}, {}
    for rate in (97.0, 99.5, 100.0):
        folder = tmp_path / f"{rate:g}"
        folder.mkdir()
        folders[rate] = _akit_with_imu_stamps(clean, np.arange(clean.imu.t.size) / rate, folder).parent
        m = _quiet(load_mission, folders[rate])
        assert m.config.imu_rate_hz == 100.0
        said[rate] = [n for n in m.meta["streams"]["imu"]["notes"] if "is kept" in n]
    assert said[97.0] == ["stamps say 97 Hz; the configured 100 Hz is kept (within 5%) for the IMU gap limits and "
                          "bridging: set imu_rate_hz if 97 Hz is right"]
    assert not said[99.5] and not said[100.0]
    capsys.readouterr()
    assert _quiet(cli.main, ["info", str(folders[97.0])]) == 0
    assert "  imu: stamps say 97 Hz; the configured 100 Hz is kept" in capsys.readouterr().out


def test_an_imu_a_little_slower_than_its_clock_grid_shows_its_rate_and_the_note(tmp_path, capsys):
    """A 97 Hz IMU logged in whole 10 ms configured at 100 Hz (every 33rd or 34th step 20 ms) showed 100 Hz in
    ``graphnav info``, its median step, and no note: it shows samples over time, 97 Hz, with the note that the
    configured 100 Hz is kept (within 5 %), for both readers."""
    from graphnav import cli
    from graphnav.core.config import SensorConfig
    clean = simulate_mission(duration_s=30.0, seed=1, config=dataclasses.replace(SensorConfig(), imu_rate_hz=100.0))
    stamps = np.floor(np.arange(clean.imu.t.size) / 97.0 / 0.01 + 1e-9) * 0.01
    for reader in ("akit", "column map"):
        folder = _written_with_imu_stamps(clean, stamps, reader, clean.config.to_dict(), tmp_path / reader)
        m = _quiet(load_mission, folder, tmp_path / "config.json")
        entry = m.meta["streams"]["imu"]
        assert m.config.imu_rate_hz == 100.0 and entry["rate_hz"] == pytest.approx(97.0, rel=1e-3)
        assert [n for n in entry["notes"] if "is kept" in n] == [
            "stamps say 97.02 Hz; the configured 100 Hz is kept (within 5%) for the IMU gap limits and bridging: set "
            "imu_rate_hz if 97.02 Hz is right"]
    capsys.readouterr()
    assert _quiet(cli.main, ["info", str(folder), "--config", str(tmp_path / "config.json")]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^imu +3001 +3001 +0 +97.02 ", out, re.M) and "  imu: stamps say 97.02 Hz; the configured" in out


def test_a_step_of_the_imu_clock_or_a_gap_in_an_even_log_is_warned_and_counted(tmp_path):
    """An even 100 Hz column-map log whose IMU stamps step +5 ms (or -5 ms, still increasing) half-way loaded with no
    word: the step is no whole number of periods, so no samples lost explain it: a clock step, warned naming the
    file, line and field and counted as doubted. A +0.5 s step is 50 whole periods: a gap (or a clock step of whole
    periods: said so), warned and counted the same. One sample lost, jitter (0.1 ms) and the plain log say nothing;
    a -0.5 s step is refused as out of order, as before."""
    from graphnav.core.errors import DataError
    from graphnav.core.screening import CLOCK_STEP, IMU_GAP
    clean = simulate_mission(duration_s=30.0, seed=1)
    n = clean.imu.t.size
    jitter = np.random.default_rng(0).normal(0.0, 1e-4, n)
    said = {CLOCK_STEP: r"the IMU clock steps [+-][45][.\d]* ms off its period \([+-]0.[45]\d* periods: no whole",
            IMU_GAP: r"a gap of 0.5 s in the stamps \(50 periods, a whole number: 50 samples lost, or the clock"}
    for step, reason, stamps in ((0.005, CLOCK_STEP, clean.imu.t), (-0.005, CLOCK_STEP, clean.imu.t + jitter),
                                 (0.5, IMU_GAP, clean.imu.t), (0.0, None, clean.imu.t),
                                 (0.0, None, clean.imu.t + jitter),
                                 (0.01, None, clean.imu.t), (-0.5, None, clean.imu.t)):
        folder = tmp_path / f"{step:+g}-{reason}-{stamps is clean.imu.t}"
        folder.mkdir()
        t = stamps + np.where(np.arange(n) >= n // 2, step, 0.0)
        cfg = clean.config.to_dict()
        cfg["csv_columns"] = _column_map_with_imu_stamps(clean, t, folder)
        (folder / "config.json").write_text(json.dumps(cfg))
        if step == -0.5:
            with pytest.raises(DataError, match="time stamp out of order"):
                _quiet(load_mission, folder, folder / "config.json")
            continue
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            m = load_mission(folder, folder / "config.json")
        steps = [str(w.message) for w in caught if "off its period" in str(w.message) or "a gap of" in str(w.message)]
        assert m.imu.t.size == n
        if reason is None:
            assert not steps and "doubted" not in m.meta["streams"]["imu"]
            continue
        assert len(steps) == 1 and re.search(said[reason], steps[0])
        assert steps[0].startswith(f"imu: {folder / 'imu.csv'}, line {n // 2 + 2}, field 't': ")
        assert m.meta["streams"]["imu"]["doubted"] == {reason: 1}


@pytest.mark.parametrize("rate_hz, k, quantum_s", [(100.0, 10, 0.0), (400.0, 4, 1e-3)])
def test_an_imu_whose_packets_share_one_stamp_loads_restamped_at_its_period(rate_hz, k, quantum_s, tmp_path):
    """An A-KIT folder whose IMU packets share one stamp (10 samples to a stamp at 100 Hz; a 400 Hz IMU in packets of
    4 logged in whole ms) was refused (duplicated stamps), and with repair=True refused again once k - 1 in k samples
    were dropped ("check the units and the configuration's sensor ranges"). It loads now, with or without repair,
    every sample kept, its stamps back on the period (within the logging's rounding), warned once and counted."""
    from graphnav.core.config import SensorConfig
    from graphnav.io.export import write_akit
    clean = simulate_mission(duration_s=20.0, seed=1, config=dataclasses.replace(SensorConfig(), imu_rate_hz=rate_hz))
    t = clean.imu.t
    i = np.arange(t.size)
    shared = t[np.minimum(i // k * k + k - 1, t.size - 1)]
    shared = np.round(shared / quantum_s) * quantum_s if quantum_s else shared
    path = write_akit(clean, tmp_path)["IMU"]
    lines = path.read_text().splitlines()
    rows = [f"{float(s)!r}{line[line.index(','):]}" for s, line in zip(shared, lines[1:])]
    path.write_text("\n".join([lines[0]] + rows) + "\n")
    for repair in (False, True):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            m = load_mission(path.parent, repair=repair)
        said = [str(w.message) for w in caught if "stamped in packets" in str(w.message)]
        assert len(said) == 1 and said[0].startswith(f"imu: {path}: stamped in packets of {k} ")
        np.testing.assert_allclose(m.imu.t, t, rtol=0, atol=0.51 * quantum_s + 1e-9)
        entry = m.meta["streams"]["imu"]
        assert entry["restamped"] == np.sum(shared != m.imu.t) > 0.7 * t.size and not entry["refused"]
        assert m.config.imu_rate_hz == pytest.approx(rate_hz, rel=1e-3)
