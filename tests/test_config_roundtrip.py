"""A configuration survives a round trip: what graphnav writes (``SensorConfig.save``, a mission's configuration,
``graphnav calibrate``) means the same when read back, and a dump of the defaults leaves to the data what the
defaults leave to it (the IMU axes and the time offsets, null in the file)."""
from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest

from graphnav.core.config import SensorConfig, read_config
from graphnav.missions import load_mission
from graphnav.sim.simulate import simulate_mission


@pytest.fixture(scope="module")
def sim():
    return simulate_mission(duration_s=120.0, seed=4)


def _load(data, config=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_mission(data, config)


def _streams(m) -> dict:
    """Every array of every stream of ``m``, by stream and field."""
    out = {}
    for name in ("imu", "dvl", "gt", "depth"):
        stream = getattr(m, name)
        for f in dataclasses.fields(stream) if stream is not None else ():
            value = getattr(stream, f.name)
            if isinstance(value, np.ndarray):
                out[f"{name}.{f.name}"] = value
    return out


def _same(a, b, meta=True, renamed=("", "")):
    """``a`` and ``b`` hold the same streams and configuration (and ``meta``, the name ``renamed[0]`` read as
    ``renamed[1]`` in ``b``'s: its notes name the configuration file)."""
    sa, sb = _streams(a), _streams(b)
    assert sa.keys() == sb.keys()
    for key in sa:
        np.testing.assert_array_equal(sa[key], sb[key], err_msg=key)
    assert json.dumps(a.config.to_dict(), sort_keys=True) == json.dumps(b.config.to_dict(), sort_keys=True)
    if meta:
        text_b = json.dumps(b.meta, sort_keys=True, default=str).replace(*renamed)
        assert json.dumps(a.meta, sort_keys=True, default=str) == text_b


def _csv_log(tmp_path, m, late_s=0.0):
    """``m`` as a column-map log, its reference stamped ``late_s`` late; the column map."""
    from graphnav.core.rotations import C_b_n_to_euler

    def write(name, header, columns):
        rows = [",".join(header)] + [",".join(f"{x:.12g}" for x in row) for row in np.column_stack(columns)]
        (tmp_path / name).write_text("\n".join(rows) + "\n")
    write("imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], [m.imu.t, m.imu.f_b, m.imu.omega_b])
    write("dvl.csv", ["t", "vx", "vy", "vz"], [m.dvl.t, m.gt.v_b[np.searchsorted(m.gt.t, m.dvl.t)]])
    write("gt.csv", ["t", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
          [m.gt.t + late_s, m.gt.p_n, m.gt.v_n, C_b_n_to_euler(m.gt.C_b_n)])
    return {"imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"],
                    "frame": "frd"},
            "dvl": {"file": "dvl.csv", "t": "t", "v_b": ["vx", "vy", "vz"], "clock": "auto"},
            "gt": {"file": "gt.csv", "t": "t", "p_n": ["n", "e", "d"], "v_n": ["vn", "ve", "vd"],
                   "euler": ["roll", "pitch", "yaw"], "angle_unit": "rad"}}


def test_a_dump_of_the_defaults_leaves_the_offsets_and_axes_to_the_data(sim, tmp_path):
    """``SensorConfig().save`` wrote the default 0 s offsets and (1, 1, 1) signs as numbers, read back as given: a
    column-map log's late reference stayed 0.4 s late."""
    dump = SensorConfig(csv_columns=_csv_log(tmp_path, sim, late_s=0.4))
    dump.save(tmp_path / "dump.json")
    written = json.loads((tmp_path / "dump.json").read_text())
    assert written["gt_time_offset_s"] is None and written["imu_axis_signs"] is None
    assert not read_config(tmp_path / "dump.json").sets("gt_time_offset_s")
    m = _load(tmp_path, tmp_path / "dump.json")
    np.testing.assert_allclose(m.gt.t, sim.gt.t, atol=2e-3)
    assert m.config.gt_time_offset_s == pytest.approx(-0.4, abs=2e-3)
    # a value given in the file is still used as given
    written["gt_time_offset_s"] = 0.0
    (tmp_path / "given.json").write_text(json.dumps(written))
    np.testing.assert_allclose(_load(tmp_path, tmp_path / "given.json").gt.t, sim.gt.t + 0.4, atol=1e-9)


def test_a_dump_of_the_akit_defaults_loads_as_no_configuration(akit_dir, tmp_path):
    """The A-KIT loader's defaults dumped and read back: the same mission as without a configuration (it was read
    with 0 s offsets, the DVL 1 s off, and the IMU's y axis as the file has it)."""
    from graphnav.io.loaders import akit_default_config
    folder = akit_dir / "Trajectory1"
    akit_default_config().save(tmp_path / "dump.json")
    plain, dumped = _load(folder), _load(folder, tmp_path / "dump.json")
    np.testing.assert_array_equal(dumped.config.imu_axis_signs, [1, -1, 1])
    _same(plain, dumped, meta=False)            # the file's latitude and gravity are noted as replaced by the GT's


def _flu_log(tmp_path, m):
    """``m`` as a column-map log (:func:`_csv_log`) whose IMU is written in FLU axes, its frame not declared."""
    cmap = _csv_log(tmp_path, m)
    imu = np.loadtxt(tmp_path / "imu.csv", delimiter=",", skiprows=1)
    imu[:, [2, 3, 5, 6]] *= -1
    np.savetxt(tmp_path / "imu.csv", imu, delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="", fmt="%.12g")
    del cmap["imu"]["frame"]
    return cmap


@pytest.mark.parametrize("kind", ["akit", "csv", "flu", "bag"])
def test_a_configuration_written_back_loads_the_same_mission(kind, sim, akit_dir, tmp_path):
    """A configuration read and written again by ``SensorConfig.save`` is the same file and loads the same mission;
    a mission's configuration written back loads the same streams (its offsets and axes then given)."""
    if kind == "akit":
        data = akit_dir / "Trajectory1"
        from graphnav.io.loaders import akit_default_config
        first = akit_default_config()
    elif kind == "csv":
        data, first = tmp_path, SensorConfig(csv_columns=_csv_log(tmp_path, sim, late_s=0.4))
    elif kind == "flu":         # the axes corrected from the data, (1, -1, -1), written back and given
        data, first = tmp_path, SensorConfig(csv_columns=_flu_log(tmp_path, sim))
    else:
        from graphnav.io.bags import write_mission_bag
        data, first = write_mission_bag(sim, tmp_path / "log.mcap"), SensorConfig(bag_topics={"depth": {}})
    first.save(tmp_path / "c1.json")
    SensorConfig.load(tmp_path / "c1.json").save(tmp_path / "c2.json")
    assert (tmp_path / "c1.json").read_text() == (tmp_path / "c2.json").read_text()
    m1, m2 = _load(data, tmp_path / "c1.json"), _load(data, tmp_path / "c2.json")
    _same(m1, m2, renamed=("c2.json", "c1.json"))
    m1.config.save(tmp_path / "own.json")
    _same(m1, _load(data, tmp_path / "own.json"), meta=False)


def test_axis_signs_a_configuration_gives_a_log_are_applied_and_its_declared_frame_checked_on_them(sim, tmp_path):
    """A column-map log's ``imu_axis_signs`` multiply its IMU axes on top of the declared frame, as an A-KIT folder's
    do: an FLU IMU declared 'frd' with signs (1, -1, -1) reads as the FRD log (it was refused for needing the signs it
    was given); signs that leave the declared frame contradicted are refused naming them."""
    from graphnav.core.errors import DataError
    (tmp_path / "frd").mkdir()
    frd = _csv_log(tmp_path / "frd", sim)
    SensorConfig(csv_columns=frd).save(tmp_path / "frd.json")
    cmap = _flu_log(tmp_path, sim)
    SensorConfig(csv_columns={**cmap, "imu": {**cmap["imu"], "frame": "frd"}}, imu_axis_signs=[1, -1, -1]).save(
        tmp_path / "signs.json")
    m = _load(tmp_path, tmp_path / "signs.json")
    assert m.config.imu_axis_signs.tolist() == [1, -1, -1]
    np.testing.assert_array_equal(m.imu.f_b, _load(tmp_path / "frd", tmp_path / "frd.json").imu.f_b)
    SensorConfig(csv_columns=frd, imu_axis_signs=[1, -1, -1]).save(tmp_path / "wrong.json")
    with pytest.raises(DataError, match=r"frame 'frd' with the configuration's imu_axis_signs \(1, -1, -1\): as read "
                                        r"they need no axis signs \(the data already hold the frame.*remove "
                                        r"imu_axis_signs from the configuration"):
        _load(tmp_path / "frd", tmp_path / "wrong.json")
    # an FLU log declared 'frd' with signs that leave it FLU: named as FLU against the data as read, 'flu' offered
    SensorConfig(csv_columns={**cmap, "imu": {**cmap["imu"], "frame": "frd"}}, imu_axis_signs=[-1, -1, 1]).save(
        tmp_path / "flu_wrong.json")
    with pytest.raises(DataError, match=r"as read they need axis signs \(1, -1, -1\) on x, y, z \(FLU axes.*"
                                        r"set csv_columns.imu.frame to 'flu' if the file holds that frame"):
        _load(tmp_path, tmp_path / "flu_wrong.json")


def test_given_akit_offsets_and_signs_the_data_disagree_with_are_used_and_warned(akit_dir, tmp_path):
    """A configuration written before null meant 'not given' holds 0 s, 0 s and (1, 1, 1) as numbers: used as
    given (the DVL 0.98 s and the GT 0.41 s off, the y axis the wrong way on Trajectory1), now with a warning each,
    naming the file, key, both values and null, and counted as doubted (the depth placed where the data put the GT);
    the trajectory's own values given: silent."""
    from graphnav.io.loaders import akit_default_config
    data = akit_dir / "Trajectory1"
    c = akit_default_config()
    c.gt_time_offset_s, c.dvl_time_offset_s, c.imu_axis_signs = 0.0, 0.0, np.ones(3)
    c.save(tmp_path / "old.json")
    c.gt_time_offset_s, c.dvl_time_offset_s, c.imu_axis_signs = -0.410, 0.976, np.array([1, -1, 1])
    c.save(tmp_path / "own.json")
    old_said = []
    for name, keys in (("old.json", ["imu_axis_signs", "gt_time_offset_s", "dvl_time_offset_s"]), ("own.json", [])):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            m = load_mission(data, tmp_path / name)
        said = [str(w.message) for w in caught if "is given, but" in str(w.message)]
        assert [s.split(": ")[1].split(" = ")[0] for s in said] == keys, said
        assert all(s.startswith(str(tmp_path / name)) and "to null" in s for s in said)
        doubted = [k for e in m.meta["streams"].values() for k in (e.get("doubted") or {})]
        # and the depth, the GT's altitude, placed where the data put the GT
        assert len(doubted) == len(keys) + bool(keys)
        old_said = old_said if keys == [] else said
    assert "the data say (1, -1, 1)" in old_said[0] and "the data say -0.410 s" in old_said[1]
