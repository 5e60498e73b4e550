"""Position fixes: the Mission's fix stream, its replay to the Navigator, the simulator's surfacings, and what
the fixes buy the graph (the DVL scale becomes observable, the drift is bound)."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from graphnav.core.errors import DataError
from graphnav.core.mission import PositionFixData
from graphnav.estimators.replay import replay, mission_records
from graphnav.evaluation.fixes import drift_before_surfacings, path_length, run_case, study_mission
from graphnav.sim.simulate import DEFAULT_ORIGIN_LLA, SurfacingProfile, simulate_mission

#: A short mission with two surfacings: every 75 s, 20 s at the surface, survey at 6-8 m.
SHORT = SurfacingProfile(interval_s=75.0, stay_s=20.0, dive_depth_m=(6.0, 8.0))


@pytest.fixture(scope="module")
def short_mission():
    """240 s, two stays at the surface with 1 Hz fixes, a 2 % DVL scale error (seeded)."""
    return study_mission(0, 240.0, SHORT, scale=0.02)


# --- data model -----------------------------------------------------------------------------------

def _fixes(**kw):
    base = dict(t=np.array([1.0, 2.0]), lat=np.full(2, 0.57), lon=np.full(2, 0.61), sigma_m=np.full(2, 2.5))
    return PositionFixData(**{**base, **kw})


@pytest.mark.parametrize("field, value, words", [
    ("lat", np.array([0.57, 32.8]), "latitude"),
    ("lon", np.array([0.61, 400.0]), "longitude"),
    ("sigma_m", np.array([2.5, 0.0]), "sigma"),
    ("sigma_m", np.array([2.5, 1e7]), "sigma"),
    ("lat", np.array([0.57, np.nan]), "not finite"),
    ("t", np.array([2.0, 1.0]), "out of order"),
])
def test_bad_fixes_are_refused_naming_index_and_field(field, value, words):
    with pytest.raises(DataError) as err:
        _fixes(**{field: value}).validate()
    msg = str(err.value)
    assert words in msg and "fix" in msg and field in msg and "1" in msg


def test_mission_slice_keeps_the_fixes_inside(short_mission):
    part = short_mission.slice(100.0, 180.0)
    assert len(part.fixes.t) and np.all((part.fixes.t >= 100.0) & (part.fixes.t <= 180.0))
    inside = (short_mission.fixes.t >= 100.0) & (short_mission.fixes.t <= 180.0)
    assert len(part.fixes.t) == int(inside.sum())


def test_replay_feeds_fixes_in_time_order_before_the_ping_of_their_stamp(short_mission):
    samples = list(replay(short_mission))
    fixes = [(t, p) for kind, t, p in samples if kind == "fix"]
    assert len(fixes) == len(short_mission.fixes.t)
    f = short_mission.fixes
    assert fixes[0] == (f.t[0], (f.lat[0], f.lon[0], f.sigma_m[0]))
    stamps = [t for _, t, _ in samples]
    assert stamps == sorted(stamps)
    # at a shared stamp the fix comes before the DVL ping and the IMU sample (a keyframe holds both)
    kinds_at = [kind for kind, t, _ in samples if t == f.t[0]]
    assert kinds_at.index("fix") < kinds_at.index("dvl") < kinds_at.index("imu")
    assert not any(kind == "fix" for kind, _, _ in replay(short_mission, fixes=False))
    records = [r for r in mission_records(short_mission, config=False) if r["type"] == "fix"]
    assert len(records) == len(f.t) and records[0]["lat"] == f.lat[0] and records[0]["sigma_m"] == f.sigma_m[0]


# --- simulator ------------------------------------------------------------------------------------

def test_missions_without_surfacings_are_unchanged():
    """The seeded default mission as it was before surfacings existed (values recorded from that version)."""
    m = simulate_mission(300, seed=3)
    assert m.fixes is None and "surface_windows" not in m.meta
    np.testing.assert_allclose(m.imu.f_b[12345], [0.2864408931900784, -0.28679117101723306, -9.795302964184176],
                               rtol=1e-12)
    np.testing.assert_allclose(m.dvl.beams[200], [0.5616219455313988, -0.5438520608750966, -0.4907197314603625,
                                                  0.4037180390187908], rtol=1e-12)
    np.testing.assert_allclose(m.gt.p_n[-1], [192.34221658457915, 181.87982423039722, 23.9712967879782],
                               rtol=1e-12)
    assert m.depth.depth[777] == pytest.approx(23.97642345683865, rel=1e-12)


def test_surfacings_reach_the_surface_and_fixes_come_only_there(short_mission):
    m = short_mission
    windows = m.meta["surface_windows"]
    assert len(windows) == 2
    for w0, w1 in windows:
        assert w1 - w0 == pytest.approx(SHORT.stay_s)
        at = (m.depth.t >= w0) & (m.depth.t <= w1)
        assert np.all(m.depth.depth[at] < 1.0) and np.all(m.depth.depth[at] > 0.0)
    between = (m.depth.t > windows[0][1]) & (m.depth.t < windows[1][0])
    assert m.depth.depth[between].max() > 5.0                 # dived again between the two
    inside = np.zeros(len(m.fixes.t), bool)
    for w0, w1 in windows:
        inside |= (m.fixes.t >= w0) & (m.fixes.t <= w1)
    assert inside.all() and len(m.fixes.t) == 2 * 20
    assert np.all(np.diff(m.fixes.t)[np.diff(m.fixes.t) < 5] == pytest.approx(1.0))
    assert np.all((m.fixes.sigma_m >= 2.0) & (m.fixes.sigma_m <= 3.0))


def test_fix_errors_have_the_sigma_they_report():
    """The fixes, converted back to NED at the ground truth's origin, scatter about the true position with
    their reported sigma (chi-square of 2 x 100+ normalised errors)."""
    m = simulate_mission(1300.0, seed=4, surfacing=SurfacingProfile(interval_s=200.0, stay_s=30.0))
    assert m.gt.origin_lla == DEFAULT_ORIGIN_LLA
    err = m.fixes.ne_m(m.gt.origin_lla) - m.gt.at(m.fixes.t)[0][:, :2]
    z2 = float(np.mean((err / m.fixes.sigma_m[:, None]) ** 2))
    n = err.size
    assert n >= 200
    assert abs(z2 - 1.0) < 4 * np.sqrt(2.0 / n)
    noiseless = simulate_mission(1300.0, seed=4, noiseless=True, surfacing=SurfacingProfile(interval_s=200.0,
                                                                                           stay_s=30.0))
    exact = noiseless.fixes.ne_m(noiseless.gt.origin_lla) - noiseless.gt.at(noiseless.fixes.t)[0][:, :2]
    assert np.abs(exact).max() < 0.01


def test_surfacing_profile_checks_its_values():
    from graphnav.core.errors import ConfigError
    for bad in (dict(interval_s=0.0), dict(fix_sigma_m=(3.0, 2.0)), dict(dive_depth_m=(0.8, 5.0)),
                dict(pitch_deg=45.0)):
        with pytest.raises(ConfigError):
            SurfacingProfile(**bad)


# --- what the fixes buy -----------------------------------------------------------------------------

def test_drift_is_error_over_distance_since_the_last_fix(short_mission):
    m = short_mission
    t = np.arange(0.0, 240.0, 1.0)
    err = 0.01 * path_length(m, t)                  # an error of exactly 1 % of the distance from the start
    from_start = drift_before_surfacings(m, t, err, fixes_used=False)
    assert [d["percent_dt"] for d in from_start] == pytest.approx([1.0, 1.0], rel=1e-3)
    since_fix = drift_before_surfacings(m, t, err, fixes_used=True)
    assert since_fix[1]["distance_m"] < from_start[1]["distance_m"]
    assert since_fix[1]["percent_dt"] > 1.0


def test_fixes_make_the_dvl_scale_observable_and_bound_the_drift(short_mission):
    """Fixed-lag graph with DVL error states on a 240 s mission with a 2 % DVL scale error and two
    surfacings: with the fixes the scale estimate ends closer to the truth than its prior (0) and than
    without fixes, its sigma shrinks, and the final position error is far smaller."""
    m = short_mission
    truth = 0.02
    with_fixes = run_case(m, fixes=True, dvl_error_states=True, batch=False)[0]
    without = run_case(m, fixes=False, dvl_error_states=True, batch=False)[0]
    assert with_fixes.scale_x_true == pytest.approx(truth)
    end_with, end_without = abs(with_fixes.scale_x[-1] - truth), abs(without.scale_x[-1] - truth)
    assert end_with < 0.5 * truth
    assert end_with < end_without
    prior_sigma = with_fixes.scale_x_sigma[0]
    assert with_fixes.scale_x_sigma[-1] < 0.7 * prior_sigma
    assert with_fixes.scale_x_sigma[-1] <= without.scale_x_sigma[-1]
    assert with_fixes.err_h[-1] < 0.25 * without.err_h[-1]
    assert with_fixes.err_h[-1] < 1.0
    # the filter's horizontal sigma drops at a surfacing and its errors are consistent with it
    w0, w1 = m.meta["surface_windows"][1]
    before = with_fixes.sigma_h[np.flatnonzero((with_fixes.t < w0) & np.isfinite(with_fixes.sigma_h))[-1]]
    after = with_fixes.sigma_h[np.flatnonzero((with_fixes.t <= w1) & np.isfinite(with_fixes.sigma_h))[-1]]
    assert after < 0.75 * before
    assert np.nanmean(with_fixes.nees_h) < 6.0


# --- a bag's GNSS ---------------------------------------------------------------------------------

def test_bag_navsatfix_round_trip(tmp_path):
    """Fixes written as sensor_msgs/NavSatFix come back as Mission.fixes (stamps on the IMU clock, lat/lon in
    rad, sigma from the covariance)."""
    pytest.importorskip("rosbags")
    from graphnav.io import bags
    m = simulate_mission(200.0, seed=2, surfacing=SurfacingProfile(interval_s=60.0, stay_s=10.0,
                                                                   dive_depth_m=(5.0, 6.0)))
    f = m.fixes
    path = bags.write_mission_bag(m, tmp_path / "run", gt=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        loaded = bags.load_bag(path)
    got = loaded.fixes
    assert got is not None and len(got.t) == len(f.t)
    np.testing.assert_allclose(got.t, f.t, atol=1e-6)
    np.testing.assert_allclose(got.lat, f.lat, atol=1e-12)
    np.testing.assert_allclose(got.lon, f.lon, atol=1e-12)
    np.testing.assert_allclose(got.sigma_m, f.sigma_m, rtol=1e-9)
    assert loaded.meta["streams"]["fix"]["read"] == len(f.t)


def test_navsatfix_without_a_fix_is_refused_and_counted():
    """A receiver under water publishes status -1 (and often NaN); an unknown covariance gets the default sigma."""
    from types import SimpleNamespace as NS

    from graphnav.io import bag_convert as conv

    def msg(status, lat, cov_type=2, var=4.0):
        return NS(status=NS(status=status), latitude=lat, longitude=34.9,
                  position_covariance=[var, 0, 0, 0, var, 0, 0, 0, var], position_covariance_type=cov_type)
    rows = [msg(0, 32.8), msg(-1, float("nan")), msg(-1, 32.8), msg(0, 32.8, cov_type=0), msg(0, 32.8)]
    t_ns = np.array([1, 2, 3, 4, 4]) * 1_000_000_000
    meta: dict = {}
    with pytest.warns(RuntimeWarning, match="2 of 5|3 of 5"):
        f = conv.fixes(conv.Stream("/gnss", "sensor_msgs/msg/NavSatFix", t_ns, rows), 0, "bag", meta)
    assert f.t.tolist() == [1.0, 4.0]
    np.testing.assert_allclose(f.sigma_m, [2.0, conv.DEFAULT_FIX_SIGMA_M])
    np.testing.assert_allclose(f.lat, np.radians(32.8))
    refused = meta["streams"]["fix"]["refused"]
    assert refused["no fix (NavSatStatus -1)"] == 2 and refused["stamp repeated or out of order"] == 1
