"""The mission data model: validation errors name stream, index and field; slicing; outages."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from graphnav.core.config import SensorConfig
from graphnav.core.errors import DataError
from graphnav.core.mission import DepthData, DvlData, GroundTruth, ImuData, Mission
from graphnav.core.scenarios import scenario_outage


def _mission(n_imu: int = 101, n_dvl: int = 11) -> Mission:
    t_imu = np.arange(n_imu) / 100.0
    imu = ImuData(t_imu, np.tile([0.0, 0.0, -9.8], (n_imu, 1)), np.zeros((n_imu, 3)))
    t_dvl = np.arange(n_dvl) / 10.0
    dvl = DvlData(t_dvl, np.ones((n_dvl, 4)), np.ones((n_dvl, 4), bool), np.ones((n_dvl, 3)))
    gt = GroundTruth(t_dvl, np.zeros((n_dvl, 3)), np.zeros((n_dvl, 3)), np.tile(np.eye(3), (n_dvl, 1, 1)))
    depth = DepthData(t_dvl, np.full(n_dvl, 10.0))
    return Mission("unit", imu, dvl, SensorConfig(), gt, depth)


def _expect(exc_info, source, index, field):
    err = exc_info.value
    assert (err.source, err.line, err.field) == (source, index, field)
    assert source in str(err) and f"'{field}'" in str(err)
    if index is not None:
        assert f"index {index}" in str(err)


def test_a_valid_mission_builds():
    m = _mission()
    assert m.duration == pytest.approx(1.0) and m.t0 == 0.0


def test_nan_value_names_stream_index_and_field():
    m = _mission()
    f_b = m.imu.f_b.copy()
    f_b[37, 1] = np.nan
    with pytest.raises(DataError) as info:
        dataclasses.replace(m, imu=dataclasses.replace(m.imu, f_b=f_b))
    _expect(info, "imu", 37, "f_b")


def test_duplicated_and_out_of_order_stamps_name_the_index():
    m = _mission()
    t = m.dvl.t.copy()
    t[5] = t[4]
    with pytest.raises(DataError, match="duplicated") as info:
        dataclasses.replace(m, dvl=dataclasses.replace(m.dvl, t=t))
    _expect(info, "dvl", 5, "t")
    t = m.imu.t.copy()
    t[[20, 21]] = t[[21, 20]]
    with pytest.raises(DataError, match="out of order") as info:
        dataclasses.replace(m, imu=dataclasses.replace(m.imu, t=t))
    _expect(info, "imu", 21, "t")
    t = m.gt.t.copy()
    t[3] = np.inf
    with pytest.raises(DataError, match="not finite") as info:
        dataclasses.replace(m, gt=dataclasses.replace(m.gt, t=t))
    _expect(info, "gt", 3, "t")


def test_wrong_shape_names_the_field():
    m = _mission()
    with pytest.raises(DataError, match="shape") as info:
        dataclasses.replace(m, gt=dataclasses.replace(m.gt, p_n=np.zeros((len(m.gt.t), 2))))
    _expect(info, "gt", None, "p_n")
    with pytest.raises(DataError, match="shape") as info:
        dataclasses.replace(m, depth=dataclasses.replace(m.depth, depth=np.zeros(3)))
    _expect(info, "depth", None, "depth")
    with pytest.raises(DataError, match="bool") as info:
        dataclasses.replace(m, dvl=dataclasses.replace(m.dvl, valid=np.ones((len(m.dvl.t), 4))))
    _expect(info, "dvl", None, "valid")


def test_nan_is_allowed_only_where_a_beam_is_invalid():
    m = _mission()
    beams = m.dvl.beams.copy()
    beams[2, 1] = np.nan
    with pytest.raises(DataError) as info:
        dataclasses.replace(m, dvl=dataclasses.replace(m.dvl, beams=beams))
    _expect(info, "dvl", 2, "beams")
    valid = m.dvl.valid.copy()
    valid[2, 1] = False
    dataclasses.replace(m, dvl=dataclasses.replace(m.dvl, beams=beams, valid=valid))   # fine
    # v_b may be NaN only where fewer than 3 beams are valid
    v_b = m.dvl.v_b.copy()
    v_b[2] = np.nan
    with pytest.raises(DataError) as info:
        dataclasses.replace(m, dvl=dataclasses.replace(m.dvl, beams=beams, valid=valid, v_b=v_b))
    _expect(info, "dvl", 2, "v_b")
    valid[2, :2] = False
    dataclasses.replace(m, dvl=dataclasses.replace(m.dvl, beams=beams, valid=valid, v_b=v_b))


def test_file_sources_are_reported_as_lines():
    err = DataError("bad value", "/data/IMU_trajectory1.csv", 12, "ACC X [m/s^2]")
    assert str(err) == "/data/IMU_trajectory1.csv, line 12, field 'ACC X [m/s^2]': bad value"


def test_slice_keeps_every_stream_inside_the_window():
    m = _mission()
    s = m.slice(0.25, 0.65)
    assert s.imu.t[0] == pytest.approx(0.25) and s.imu.t[-1] == pytest.approx(0.65)
    assert len(s.imu.t) == 41
    for stream in (s.dvl.t, s.depth.t):
        assert stream.min() >= 0.25 and stream.max() <= 0.65
    # the ground truth keeps one sample either side, so that it can be interpolated at every stamp inside
    assert s.gt.t[0] <= 0.25 and s.gt.t[-1] >= 0.65
    assert np.sum(s.gt.t < 0.25) <= 1 and np.sum(s.gt.t > 0.65) <= 1
    s.gt.at(s.imu.t)
    np.testing.assert_array_equal(s.dvl.t, [0.3, 0.4, 0.5, 0.6])
    assert s.dvl.v_b.shape == (4, 3) and s.meta["slice"] == (0.25, 0.65)
    assert len(m.imu.t) == 101                                   # the original is untouched


def test_with_outage_removes_the_scenario_beams_inside_the_window_only():
    m = _mission()
    out = m.with_outage(scenario_outage("2-missing", start_s=0.3, duration_s=0.4))
    inside = (m.dvl.t >= 0.3) & (m.dvl.t < 0.7)
    assert not out.dvl.valid[inside][:, [0, 2]].any() and out.dvl.valid[inside][:, [1, 3]].all()
    assert out.dvl.valid[~inside].all()
    assert m.dvl.valid.all()                                     # the original is untouched
    out2 = out.with_outage(scenario_outage("3-missing", start_s=0.0, duration_s=0.2))
    assert out2.dvl.valid[:2].sum(axis=1).tolist() == [1, 1]
    assert len(out2.meta["outages"]) == 2
    np.testing.assert_array_equal(out.dvl.beams, m.dvl.beams)   # beams stay; only the mask changes


def test_with_dvl_valid_replaces_the_mask():
    m = _mission()
    valid = np.zeros((len(m.dvl.t), 4), bool)
    valid[:, 1] = True
    assert m.with_dvl_valid(valid).dvl.n_valid.tolist() == [1] * len(m.dvl.t)


def test_a_float32_rdi_flag_is_counted_as_the_flag_not_as_a_speed_beyond_range():
    """A bag's float32 beam holding -32.768 reads as -32.76800155 in float64: it was warned about as a value beyond
    10 m/s with '[0 seen]' flags; it is RDI's flag, matched at float32 precision."""
    import warnings
    beams = np.full((3, 4), 0.5)
    beams[1, 2] = np.float32(-32.768)
    dvl = DvlData(np.arange(3.0), beams, np.ones((3, 4), bool), None, "bag.db3:/dvl")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        clean = dvl.sanitized()
    assert "[1 seen]" in str(caught[0].message)
    assert not clean.valid[1, 2] and clean.valid.sum() == 11


def test_an_in_memory_ping_without_a_valid_beam_is_named_by_its_sample_and_stamp():
    """An in-memory mission has no file: its pings without a valid beam are named 'sample i at t = ... s'."""
    import warnings
    from graphnav.io.stream_counts import record_streams
    valid = np.ones((5, 4), bool)
    valid[3] = False
    dvl = DvlData(np.arange(5) * 0.2 + 1.0, np.full((5, 4), 0.5), valid, None, "dvl")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        record_streams({}, dvl=dvl)
    assert "first at sample 3 at t = 1.600 s" in str(caught[0].message)


def test_an_error_about_a_sample_of_a_file_names_no_line_of_it():
    """The mission's checks index arrays: a stamp asked of the reference outside its span said 'nav.csv, line 0,
    field 't'' (the index of the stamp asked for), an unordered stamp the array index as a line of the file."""
    gt = GroundTruth(np.array([10.0, 11.0]), np.zeros((2, 3)), np.zeros((2, 3)), np.repeat(np.eye(3)[None], 2, 0),
                     None, "nav.csv")
    with pytest.raises(DataError) as err:
        gt.at(0.0)
    assert str(err.value) == "nav.csv: stamp 0.000 s outside the ground truth span [10.000, 11.000] s"
    with pytest.raises(DataError) as err:
        DepthData(np.array([0.0, 2.0, 1.0]), np.zeros(3), "depth.csv").validate()
    assert err.value.line is None and "(sample 2 of the stream)" in str(err.value)
    with pytest.raises(DataError) as err:
        DepthData(np.array([0.0, 2.0, 1.0]), np.zeros(3), "depth").validate()
    assert str(err.value).startswith("depth, index 2, field 't'")
