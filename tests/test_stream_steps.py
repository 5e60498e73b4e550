"""The live stream (a Navigator fed record by record, as ``graphnav online --stream``) across a step of the shared
clock or a loss of every sensor at once: the alignment from the sensors does not carry its attitude over the gap,
and a clock jump of days is refused naming the jump."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from graphnav.core.config import SensorConfig
from graphnav.core.errors import DataError
from graphnav.estimators.navigator import Navigator
from graphnav.estimators.replay import mission_records
from graphnav.io.streamio import feed
from graphnav.sim.simulate import simulate_mission

T_STEP = 140.0      # s: the 140 s before it are enough to align at the end of the data (min_duration_s 120 s)


@pytest.fixture(scope="module")
def records():
    m = simulate_mission(duration_s=200.0, seed=1)
    return m.config, [r for r in mission_records(m, config=False)]


def _stepped(recs, step_s: float):
    """Every record from T_STEP on stamped ``step_s`` later (the clock stepped)."""
    return [dict(r, t=r["t"] + step_s) if r["t"] >= T_STEP else r for r in recs]


def _stepped_at(recs, step_s: float, start_s: float):
    """Every record from ``start_s`` on stamped ``step_s`` later (the clock stepped)."""
    return [dict(r, t=r["t"] + step_s) if r["t"] >= start_s else r for r in recs]


def _lost(recs, length_s: float, start_s: float = T_STEP):
    """Every record from ``start_s`` for ``length_s`` gone (every sensor silent)."""
    return [r for r in recs if not start_s <= r["t"] < start_s + length_s]


def _run(config, recs):
    nav = Navigator(config, "fixed-lag")
    out = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for rec in recs:
            out += feed(nav, rec)
        out += nav.finish()
    return nav, out, [str(w.message) for w in caught]


def _largest_distance(a, b) -> float:
    """Largest horizontal distance, m, between two runs' estimates at the stamps they share."""
    ta, tb = np.round([e.t for e in a], 6), np.round([e.t for e in b], 6)
    _, ia, ib = np.intersect1d(ta, tb, return_indices=True)
    pa, pb = np.array([a[i].p_n for i in ia]), np.array([b[i].p_n for i in ib])
    return float(np.max(np.linalg.norm(pa[:, :2] - pb[:, :2], axis=1)))


@pytest.mark.parametrize("damage", ["clock step 5 s", "every sensor lost 5 s"])
def test_a_shared_5_s_step_or_loss_while_aligning_costs_imu_only_drift(records, damage):
    """The alignment held the gap's one sample over 5 s: 0.014 rad/s of roll tilted the rest 4 deg, and the
    gyrocompassed heading came out 145 deg off (737 m off the clean run after 200 s). Aligned over the 140 s before
    the gap, the run bridges it as the estimator does any IMU gap: metres (5 s at 1.6 m/s after a clock step,
    whose stamps then lag the clean run's by 5 s; measured 16.8 m and 5.7 m)."""
    config, recs = records
    _, clean, _ = _run(config, recs)
    damaged = _stepped(recs, 5.0) if damage.startswith("clock") else _lost(recs, 5.0)
    nav, out, said = _run(config, damaged)
    assert abs(nav.alignment.info["duration_s"] - T_STEP) < 1.0       # the stretch before the gap
    heading = [np.arctan2(x.C_b_n[1, 0], x.C_b_n[0, 0]) for x in (nav.alignment, clean[0])]
    assert abs(np.degrees(np.angle(np.exp(1j * (heading[0] - heading[1]))))) < 3.0
    assert _largest_distance(out, clean) < 25.0
    assert any("gap of 5.010 s after t = 139.990 s bridged" in w for w in said)


def test_a_gap_splitting_the_alignment_short_says_so(records):
    """Neither side of a gap covers the 120 s an alignment at the end of the data needs: no estimate, and the
    reason names the gap (it was aligned across it, 145 deg off, and said ok)."""
    config, recs = records
    nav, out, said = _run(config, _lost([r for r in recs if r["t"] < 160.0], 5.0, 70.0))
    assert out == []
    assert any("no estimate was made" in w and "IMU gap 5.01 s after t = 69.990 s splits the data" in w
               for w in said), said


def test_a_clock_jump_of_days_is_refused_naming_the_jump_and_its_stream(records):
    """Every stream stepped 2 days: refused naming the jump, where it happened and the stream that showed it first
    (a jump of 30 % of the stream was refused sample by sample, and one of half as "751 of 1501 depth samples
    refused", as if the depth sensor were at fault); it stops once the IMU has been 1 s past it, not at the end."""
    config, recs = records
    with pytest.raises(DataError) as err:
        _run(config, _stepped(recs, 2 * 86400.0))
    text = str(err.value)
    assert "the clock jumped 172800 s ahead at t = 139.990 s, first on the depth stream" in text, text
    assert "100 of 14100 imu samples refused after it" in text and "split the stream there" in text


def _stalled(recs, start_s: float, length_s: float):
    """The IMU repeating the reading at ``start_s`` for ``length_s`` (a driver re-sending its last sample)."""
    imu = [r for r in recs if r["type"] == "imu"]
    read = next(r for r in imu if r["t"] >= start_s)
    return [dict(r, f_b=read["f_b"], omega_b=read["omega_b"])
            if r["type"] == "imu" and start_s < r["t"] < start_s + length_s else r for r in recs]


def test_a_stalled_imu_in_the_live_stream_is_refused_and_bridged_as_the_loaders_do(records):
    """The IMU repeating one reading for 2 s: the loaders refuse the repeats (screening.imu_stalled) and the run
    bridges them; the live stream integrated them (42.7 m off the clean run, DIVERGED at the end). Now refused in
    the loaders' words, counted, and bridged: metres (measured 6.2 m)."""
    config, recs = records
    _, clean, _ = _run(config, recs)
    nav, out, said = _run(config, _stalled(recs, 160.0, 2.0))
    assert any("199 imu sample(s) refused (199 stalled (repeats the row before it in every value for 0.5 s or more))"
               " from t = 160.010 to 161.990 s" in w for w in said), said
    assert any("gap of 2.000 s after t = 160.000 s bridged" in w for w in said)
    assert nav.refused["imu"] == {"stalled (repeats the row before it in every value for 0.5 s or more)": 199}
    assert _largest_distance(out, clean) < 10.0 and out[-1].health == "ok"


def test_a_short_run_of_repeats_goes_on_in_stamp_order(records, monkeypatch):
    """0.3 s of one reading is no stall (IMU_STALL_MIN_S 0.5 s): held while it might be one, then let go before the
    sample that ended it and the pings that waited, in stamp order: nothing refused, the estimates those of the
    same stream never held."""
    config, recs = records
    damaged = _stalled(recs, 160.0, 0.3)
    nav, out, said = _run(config, damaged)
    assert "imu" not in nav.refused and not any("stalled" in w for w in said)
    from graphnav.core.screening import ImuStallTest
    monkeypatch.setattr(ImuStallTest, "repeats", lambda self, values: False)
    _, never_held, _ = _run(config, damaged)
    assert [e.t for e in out] == [e.t for e in never_held] and len(out) == 201
    np.testing.assert_array_equal([e.p_n for e in out], [e.p_n for e in never_held])


def test_an_imu_gap_of_a_fifth_of_a_second_or_less_is_held_over_by_the_alignment(records):
    """Samples refused as out of order leave holes of a few samples (0.06 s: 0.09 deg of heading, bridged): the
    alignment keeps its data over them (restarting there left a 150 s stream without an estimate); over a gap of up to
    2.5 s it joins the data either side, over a longer one it starts again, and its progress names the gap."""
    from graphnav.estimators.align import GAP_CARRIED_S, Aligner
    config, _ = records
    a = Aligner(config)
    for t in (0.0, 0.01, 0.02):
        a.add_imu(t, [0.0, 0.0, -9.8], [0.0, 0.0, 0.0])
    a.imu_gap(0.02, 0.02 + GAP_CARRIED_S)
    a.add_imu(0.02 + GAP_CARRIED_S, [0.0, 0.0, -9.8], [0.0, 0.0, 0.0])
    assert a.t_first == 0.0 and a.progress()["imu_gaps"] == ""
    a.imu_gap(0.22, 1.23)             # joined: the alignment fits the turn across it (GAP_JOINED_S)
    a.add_imu(1.23, [0.0, 0.0, -9.8], [0.0, 0.0, 0.0])
    assert a.t_first == 0.0 and a.progress()["imu_gaps"] == "" and a.joined_gaps == [(0.22, 1.23)]
    a.imu_gap(1.23, 4.24)
    a.add_imu(4.24, [0.0, 0.0, -9.8], [0.0, 0.0, 0.0])
    assert a.t_first == 4.24
    assert a.progress()["imu_gaps"].startswith("the IMU gap 3.01 s after t = 1.230 s splits the data")


def test_isolated_stamps_corrupted_days_ahead_are_refused_one_by_one_not_taken_for_a_clock_step(records):
    """120 single IMU samples stamped 2 days ahead, spread over the stream (the clock went on after each): each is
    one bad stamp, refused alone. Counted together as 1 s of the IMU past a jump, they stopped the stream at
    168 s with "the clock jumped 172800 s ahead at t = 21.480 s" and no estimate."""
    config, recs = records
    imu = [i for i, r in enumerate(recs) if r["type"] == "imu" and r["t"] > 20.0]
    bad = set(imu[148::148][:120])
    nav, out, said = _run(config, [dict(r, t=r["t"] + 2 * 86400.0) if i in bad else r for i, r in enumerate(recs)])
    assert len(bad) == 120 and sum(nav.refused["imu"].values()) == 120 and len(out) == 201


def test_a_vehicle_at_rest_repeating_one_reading_is_not_held_back(records):
    """60 s on deck, the IMU repeating one reading of a vehicle at rest on coarse counts (no stall, whatever its
    length): the samples go on as they come. Held as a possible stall, the alignment's status said 0.0 s of IMU
    data and 0 DVL pings after 59 s (the estimates of a navigating run came as late as the rest lasted)."""
    config, recs = records
    rest = [dict(r, f_b=[0.0, 0.0, -9.80665], omega_b=[0.0, 0.0, 0.0]) if r["type"] == "imu" and r["t"] < 60.0
            else r for r in recs]
    nav = Navigator(config, "fixed-lag")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for rec in rest:
            if rec["t"] > 59.0:
                break
            feed(nav, rec)
    progress = nav.aligner.progress()
    assert progress["aligned_s"] > 58.5 and progress["dvl_pings"] >= 55, progress


def test_a_dvl_on_its_own_clock_days_ahead_is_named_as_such_not_as_a_step_to_split_at(records):
    """Every DVL record stamped 2 days ahead while the IMU and depth go on: the DVL's own clock is off. It was
    told as "the clock jumped 172800 s ahead at t = 0.000 s ... split the stream there", which no split mends."""
    config, recs = records
    with pytest.raises(DataError) as err:
        _run(config, [dict(r, t=r["t"] + 2 * 86400.0) if r["type"] == "dvl" else r for r in recs])
    text = str(err.value)
    assert "201 of 201 dvl samples are stamped more than 86400 s ahead" in text, text
    assert "the dvl stamps are not on the clock the other streams share" in text and "split" not in text


def test_a_loss_of_a_third_of_a_second_while_aligning_is_joined_by_the_alignment(records):
    """0.3 s of every sensor lost at 60 s: held over, the alignment's attitude crossed it and the run drifted 9-12 m
    more than the clean one over 200 s (seeds 2-4); then it started again after it, with no estimates before
    60.3 s. Now the alignment joins the data either side, the turn across the gap fitted (align.GAP_JOINED_S):
    estimates from the start, within 1.2 m of the clean run (seed 1)."""
    config, recs = records
    nav, out, said = _run(config, _lost(recs, 0.3, 60.0))
    _, clean, _ = _run(config, recs)
    assert nav.alignment.info["imu_gaps_joined"] == 1 and out[0].t < 1.0
    assert _largest_distance(out, clean) < 3.0


def test_an_imu_gap_is_said_once_though_the_alignment_buffer_is_replayed(records):
    """Every stream stepped 5 s, or only the IMU silent for 5 s while the DVL and depth go on: the bridged gap was
    said twice (the alignment's keyframer, then the one replaying its buffer); now once."""
    config, recs = records
    for damaged in (_stepped(recs, 5.0), [r for r in recs if not (r["type"] == "imu" and 150.0 <= r["t"] < 155.0)]):
        _, _, said = _run(config, damaged)
        bridged = [w for w in said if "bridged" in w]
        assert len(bridged) == 1, bridged


def test_a_bad_first_stamp_is_not_trusted_over_the_stream_after_it(records):
    """The first record stamped 0, every later one on Unix time: the stream was refused from its second record on
    ("the clock jumped 1.7e+09 s ahead at t = 0.000 s ... split the stream there"), no estimate. Now the one sample
    before the step is refused, and the stream starts over on the clock the second of IMU samples after it
    confirmed (that second is refused too): 200 of the clean run's 201 estimates, metres from them."""
    config, recs = records
    t0 = 1.7e9
    late = [dict(r, t=r["t"] + t0) for r in recs]
    late[0] = dict(late[0], t=0.0)
    _, clean, _ = _run(config, recs)
    nav, out, said = _run(config, late)
    assert any("after only 1 depth sample(s): those are refused" in w and "starts over on that clock" in w
               for w in said), said
    assert nav.refused == {"depth": {"t": 10}, "dvl": {"t": 1}, "imu": {"t": 100}}, nav.refused
    at = {round(e.t, 3): e for e in clean}
    assert len(out) == 200
    assert max(np.linalg.norm(e.p_n[:2] - at[round(e.t - t0, 3)].p_n[:2]) for e in out) < 5.0


@pytest.mark.parametrize("length_s, refused, largest_m", [(0.6, 59, 2.0), (5.0, 499, 10.0), (20.0, 1999, 40.0)])
def test_a_stall_in_the_streams_first_second_is_judged_by_the_second_after_it_and_refused(records, length_s, refused,
                                                                                         largest_m):
    """The IMU repeating the reading at 0.2 s for 0.6, 5 or 20 s: with no second of samples before it, the stall was
    used, warned and counted as doubted: 0.04 m, 37 m (still "ok") from the clean run, and at 20 s a numpy "Singular
    matrix" traceback from the smoother's innovation check once aligned. Now judged by the second of samples after it
    (the loaders' rule: they repeat seldom), refused in the stall's words and bridged as any IMU gap: estimates where
    the clean run's are (measured 1.1, 7.1 and 32.5 m from it, the last two aligned after the stall, within 8.8-12.2 m
    of the truth as the clean run's 9.7 m)."""
    config, recs = records
    _, clean, _ = _run(config, recs)
    nav, out, said = _run(config, _stalled(recs, 0.2, length_s))
    end = 0.2 + length_s - 0.01
    assert any(f"{refused} imu sample(s) refused ({refused} stalled (repeats the row before it in every value for 0.5 s"
               f" or more)) from t = 0.210 to {end:.3f} s (the reading at t = 0.200 s repeated in the stream's first 1 "
               "s, judged by the 1 s of samples after it as the loaders do)" in w for w in said), said
    assert nav.refused["imu"] == {"stalled (repeats the row before it in every value for 0.5 s or more)": refused}
    assert "imu" not in nav.doubted and not any("is repeated in every value" in w for w in said)
    assert len(out) >= 200 - length_s and all(e.health == "ok" for e in out)
    assert _largest_distance(out, clean) < largest_m


def test_a_run_in_the_streams_first_second_that_the_second_after_it_does_not_call_a_stall_goes_on(records):
    """The reading at 0.2 s repeated for 0.6 s, and the second after it repeating every other reading (an IMU whose
    counts are coarser than its noise): no stall by the loaders' rule, so used as received, neither refused nor
    doubted (the samples after it told)."""
    config, recs = records
    damaged = _stalled(recs, 0.2, 0.6)
    imu = [i for i, r in enumerate(damaged) if r["type"] == "imu" and 0.8 < r["t"] <= 1.8]
    for i, j in zip(imu[::2], imu[1::2]):
        damaged[j] = dict(damaged[j], f_b=damaged[i]["f_b"], omega_b=damaged[i]["omega_b"])
    nav, out, said = _run(config, damaged)
    assert "imu" not in nav.refused and "imu" not in nav.doubted, (nav.refused, nav.doubted)
    assert not any("stalled" in w or "is repeated in every value" in w for w in said), said
    assert len(out) == 201


def test_a_stall_in_the_streams_first_second_with_no_samples_after_it_is_doubted_and_said(records):
    """The reading at 0.2 s repeated for 0.6 s, then the IMU silent 1.5 s: no samples within a second either side to
    tell a stall from an IMU repeating from its start, so it goes on (the loaders keep such a run too), warned and
    counted as doubted; the silence is bridged as an IMU gap."""
    config, recs = records
    damaged = [r for r in _stalled(recs, 0.2, 0.6) if not (r["type"] == "imu" and 0.8 <= r["t"] < 2.3)]
    nav, out, said = _run(config, damaged)
    assert any("the reading at t = 0.200 s is repeated in every value for 0.510 s or more in the stream's first 1 s"
               in w for w in said), said
    from graphnav.core.screening import IMU_STALL_UNTOLD
    assert nav.doubted == {"imu": {IMU_STALL_UNTOLD: 59}} and nav.info["doubted"] == nav.doubted
    assert "imu" not in nav.refused and len(out) == 201


def test_a_first_half_second_on_the_boot_clock_is_not_trusted_over_the_stream_after_it(records):
    """The first 0.5 s of every stream stamped from 0 (a logger that started before its clock was set), every later
    record on Unix time: more than the reorder buffer's 0.2 s had left it when the step was confirmed, and the
    stream stopped ("the clock jumped 1.7e+09 s ahead at t = 0.490 s ... split the stream there"), no estimate. Half a
    second is no more to trust than the second of IMU samples on the new clock that confirmed the step: refused, and
    the stream starts over on the new clock, as after a single bad first stamp."""
    config, recs = records
    t0 = 1.7e9
    late = [dict(r, t=r["t"] + t0) if r["t"] >= 0.5 else r for r in recs]
    nav, out, said = _run(config, late)
    assert any("after only 5 depth, 1 dvl, 50 imu sample(s): those are refused" in w for w in said), said
    assert nav.refused["imu"] == {"t": 150} and len(out) == 200 and out[0].t > t0


def test_a_stall_just_after_an_imu_gap_is_judged_by_the_second_after_it_not_said_to_be_in_the_first_second(records):
    """Every sensor lost 5 s at 150 s, then the IMU repeating its first reading after the gap for 0.7 s: no second of
    samples before it, so it was used and doubted (its warning once said "in the stream's first 1 s" at 155 s). Now
    judged by the second after it, as in the stream's first second: refused, said to be right after an IMU gap."""
    config, recs = records
    nav, _, said = _run(config, _stalled(_lost(recs, 5.0, 150.0), 155.0, 0.7))
    told = [w for w in said if "the reading at t = 155.000 s repeated" in w]
    assert len(told) == 1 and "right after an IMU gap" in told[0] and "first 1 s" not in told[0], said
    assert "69 imu sample(s) refused" in told[0] and "imu" not in nav.doubted


def test_a_first_record_days_ahead_of_the_stream_after_it_is_not_trusted_over_it(records):
    """The first record stamped on Unix time (1.7e9 s), every later one from 0 (seconds since boot): no stamp was
    refused, and the run ended with "IMU data cover 200.0 s of the 300 s needed" (on 400 s of data, 401 estimates
    without a word). A stamp days behind
    the stream is as far off its clock as one days ahead: the samples after it are refused as such until a second of
    IMU samples confirmed the clock went back, then the stream starts over on it, the first record refused, as a
    first record days behind the rest is: 200 of the clean run's 201 estimates, metres from them."""
    config, recs = records
    late = [dict(recs[0], t=recs[0]["t"] + 1.7e9)] + recs[1:]
    _, clean, _ = _run(config, recs)
    nav, out, said = _run(config, late)
    assert any("the clock jumped 1.7e+09 s back at t = 1700000000.000 s, first on the dvl stream" in w
               and "after only 1 depth sample(s): those are refused" in w and "starts over on that clock" in w
               for w in said), said
    assert any("imu sample at t = 0.000000 s refused, field 't': stamp jumps 1.7e+09 s behind the stream" in w
               for w in said), said
    assert nav.refused == {"depth": {"t": 10}, "dvl": {"t": 1}, "imu": {"t": 100}}, nav.refused
    at = {round(e.t, 3): e for e in clean}
    assert len(out) == 200 and out[0].t >= 1.0
    assert max(np.linalg.norm(e.p_n[:2] - at[round(e.t, 3)].p_n[:2]) for e in out) < 5.0


@pytest.mark.parametrize("stream, count", [("imu", 3), ("dvl", 1)])
def test_first_samples_stamped_0_among_unix_stamps_are_refused_one_by_one(records, stream, count):
    """Every record on Unix time but the first ``count`` of one stream, stamped 0 (a driver that stamped before its
    clock was set) after the other streams' first records: the IMU's first was taken and the two after it refused as
    a "duplicate stamp", the DVL's ping was taken without a word. Each is now refused alone as days behind the
    stream, named and counted, and the run navigates on the rest: every estimate of the clean run, metres from it."""
    config, recs = records
    t0 = 1.7e9
    late = [dict(r, t=r["t"] + t0) for r in recs]
    first = [i for i, r in enumerate(late) if r["type"] == stream][:count]
    for i in first:
        late[i] = dict(late[i], t=0.0)
    assert min(first) > 0
    _, clean, _ = _run(config, recs)
    nav, out, said = _run(config, late)
    assert any(f"{stream} sample at t = 0.000000 s refused, field 't': stamp jumps 1.7e+09 s behind the stream" in w
               for w in said), said
    assert nav.refused == {stream: {"t": count}}, nav.refused
    assert not any("gap" in w for w in said), said
    at = {round(e.t): e for e in clean}     # the IMU's first three lost, its keyframes come 0.03 s later
    assert len(out) == len(clean)
    assert max(np.linalg.norm(e.p_n[:2] - at[round(e.t - t0)].p_n[:2]) for e in out) < 5.0


def test_a_clock_step_of_days_back_is_refused_naming_the_jump_as_one_ahead_is(records):
    """Every stream stepped 2 days back at 140 s: the 6001 IMU samples after it were refused as "out of order"
    (older than what had left the reorder buffer), and the run ended with the 140 estimates before it and no error.
    Now the step is named as a forward one is, which way it went, once the IMU has been 1 s past it."""
    config, recs = records
    with pytest.raises(DataError) as err:
        _run(config, _stepped(recs, -2 * 86400.0))
    text = str(err.value)
    assert "the clock jumped 172800 s back at t = 139.990 s, first on the depth stream" in text, text
    assert "100 of 14100 imu samples refused after it" in text and "split the stream there" in text


def _imu_on_boot_clock(recs, until_s: float, t0: float = 1.7e9):
    """Every record on Unix time (``t0`` on) but the IMU's before ``until_s``, stamped from 0 (an IMU driver stamping
    from its boot before the clock the other streams share reached it)."""
    return [r if r["type"] == "imu" and r["t"] < until_s else dict(r, t=r["t"] + t0) for r in recs]


def test_an_imu_stamped_from_its_boot_for_its_first_seconds_is_refused_alone(records):
    """The IMU's first 3 s stamped from 0 among streams on Unix time: a second of its samples days behind the
    others' was taken for the clock stepping back, three times: the stream started over on the IMU's clock with the
    depth and DVL samples before refused ("the clock jumped 1.7e+09 s back ... starts over on that clock", 30 depth
    and 3 DVL samples lost). The other streams went on on their clock: the IMU's 300 samples alone are refused."""
    config, recs = records
    nav, out, said = _run(config, _imu_on_boot_clock(recs, 3.0))
    assert not any("starts over" in w for w in said), said
    assert nav.refused == {"imu": {"t": 300}}, nav.refused
    assert len(out) >= 198 and out[0].t >= 1.7e9 + 3.0


def test_an_imu_on_its_own_clock_is_named_not_the_stream_the_start_overs_refused(records):
    """The IMU stamped from its boot throughout, the depth and DVL on Unix time: the stream started over on the
    IMU's clock every second (a warning each time) and ended naming the depth stream: "200 of 200 depth samples
    refused (t: 200): more than 50% of the stream; check units and sensor ranges". Now the IMU is named as on
    its own clock."""
    config, recs = records
    with pytest.raises(DataError) as err:
        _run(config, _imu_on_boot_clock([r for r in recs if r["t"] < 20.0], 20.0))
    text = str(err.value)
    assert "2000 of 2000 imu samples are stamped more than 86400 s behind the other streams' (by 1.7e+09 s" in text
    assert "the imu stamps are not on the clock the other streams share" in text and "split" not in text, text


def test_the_imu_alone_stepping_days_back_is_named_as_on_its_own_clock_not_as_a_step_to_split_at(records):
    """The IMU's stamps alone 2 days back from 140 s, the depth and DVL going on: the error said "the clock jumped
    172800 s back ... (every stream shares the clock); split the stream there", which the other streams'
    stamps after it would not follow. Now it names the IMU's stamps as off the clock the others share."""
    config, recs = records
    stepped = [dict(r, t=r["t"] - 2 * 86400.0) if r["type"] == "imu" and r["t"] >= T_STEP else r for r in recs]
    with pytest.raises(DataError) as err:
        _run(config, stepped)
    text = str(err.value)
    assert "100 of 14100 imu samples are stamped more than 86400 s behind the other streams' (by 172800 s" in text
    assert "the imu stamps are not on the clock the other streams share" in text and "split" not in text, text


def test_a_late_ping_stamped_before_a_step_of_every_streams_clock_does_not_make_it_the_imu_alone(records):
    """Every stream stepped 2 days back at 140 s, a DVL ping stamped 0.05 s after the last stamp before the step
    (measured before it) arriving behind 10 IMU samples on the new clock, the other streams silent for 2 s: taken for
    the DVL going on on the old clock,
    the error named the IMU as off the clock the others share ("correct its stamps"). A ping within
    CLOCK_JUMP_LATE_S of the jump is no evidence of that: the step of every stream is named, to split at."""
    config, recs = records
    # the depth and DVL silent for the 2 s after the step, so that nothing but the IMU shows the new clock at first
    quiet = [r for r in recs if r["type"] == "imu" or not T_STEP <= r["t"] < T_STEP + 2.0]
    stepped = _stepped(quiet, -2 * 86400.0)
    after = [i for i, r in enumerate(stepped) if r["type"] == "imu" and r["t"] < 0.0][9]
    ping = next(r for r in recs if r["type"] == "dvl" and r["t"] >= T_STEP - 1.0)
    stepped.insert(after + 1, dict(ping, t=T_STEP + 0.04))
    with pytest.raises(DataError) as err:
        _run(config, stepped)
    text = str(err.value)
    assert "the clock jumped 172800 s back" in text and "split the stream there" in text, text



@pytest.mark.parametrize("configured_hz", [10.0, 4.0])
def test_an_imu_faster_than_configured_sees_its_own_rate_and_a_loss_is_said_as_a_gap(records, configured_hz):
    """A 100 Hz IMU configured at 10 or 4 Hz losing 0.5 s at 100 s: judged against the configured period, each 10 ms
    step was one within a packet, the loss made packets and its samples came restamped about 12 ms apart (251 at
    10 Hz), or (4 Hz) the loss stayed under 2.5 of the configured 0.25 s; no gap was said. Now the live IMU timing
    sees the rate the data show, as the loaders do, warns about the configured one and bridges the loss as a gap."""
    import dataclasses
    config, recs = records
    config = dataclasses.replace(config, imu_rate_hz=configured_hz)
    nav, out, said = _run(config, [r for r in recs if not (r["type"] == "imu" and 100.0 <= r["t"] < 100.5)])
    assert any(f"runs at 100 Hz (from its first 16 steps, 10 ms), not the configured imu_rate_hz {configured_hz:g} Hz"
               in w for w in said), said
    assert any("imu: gap of 0.510 s after t = 99.990 s bridged" in w for w in said), said
    assert nav.info["imu_restamped"] == 0 and len(out) == 201


def test_a_numerical_failure_of_the_smoother_ends_as_a_said_loss_of_track_not_a_traceback(records, monkeypatch):
    """The first-second stall of 20 s used as before it was judged by the second after it (the rule switched off
    here): the smoother's run after the alignment reached 1e111 m/s and its innovation check raised numpy's "Singular
    matrix" at 70 s, a traceback that lost every estimate of the run. Now the Navigator says the loss of track,
    naming the time and the failure, takes no more data, keeps the estimates made, and the run ends diverged."""
    from graphnav.core.screening import ImuStallTest
    monkeypatch.setattr(ImuStallTest, "untold_may_stall", lambda self: False, raising=False)
    config, recs = records
    nav, out, said = _run(config, _stalled(recs, 0.2, 20.0))
    assert nav.lost_track is not None and nav.lost_track[0] == 70.0, nav.lost_track
    assert any("fixed-lag lost track at t = 70.000 s (the DVL innovation covariance cannot be inverted (Singular "
               "matrix; predicted velocity" in w and "the 201 estimate(s) made (to t = 200.000 s) stand" in w
               for w in said), said
    health = nav.backend.monitor.summary()
    assert health["diverged_at_end"] and health["lost_track_at"] == 70.0
    # the run's health says it, and where its estimates end: the catch-up run's through the alignment window stand
    from graphnav.estimators.health import run_health
    assert any(w.startswith("lost track at t = 70.000 s (the DVL innovation covariance cannot be inverted")
               and w.endswith(": no estimate after t = 200.000 s") for w in run_health(health)["why"]), health
    assert len(out) == 201 and out[-1].health == "diverged"


T_TURN = 165.0      # s: seed 1 turns at 4.7 deg/s there


def _yaw_deg(C) -> float:
    return float(np.degrees(np.arctan2(C[1, 0], C[0, 0])))


def _heading_off_at_end(out, clean, lag_s: float = 0.0) -> float:
    """Heading difference, deg, between a run's last estimate and the clean run's at its stamp less ``lag_s``
    (the stamps a clock step put ahead of the vehicle's time)."""
    ref = next(e for e in clean if abs(e.t - (out[-1].t - lag_s)) < 1e-6)
    return abs((_yaw_deg(out[-1].C_b_n) - _yaw_deg(ref.C_b_n) + 180.0) % 360.0 - 180.0)


def test_a_step_of_every_streams_clock_in_a_turn_is_joined_with_no_time_passed(records):
    """Every stream's clock stepped 5 s ahead in a 4.7 deg/s turn (no time passed for the vehicle): bridged as a
    loss, the interpolated rates turned the vehicle 23.7 deg it never turned, 19 m off and "ok". The IMU readings
    join up across the step and do not fit 5 s of the turn: joined with no time passed, said and counted; the
    heading stays within a degree of the clean run's (measured 0.4 deg against the ground truth)."""
    config, recs = records
    _, clean, _ = _run(config, recs)
    nav, out, said = _run(config, _stepped_at(recs, 5.0, T_TURN))
    assert any("no stream has a sample for 5.010 s after t = 164.990 s: taken as a step of the clock they share"
               in w for w in said), said
    assert nav.info["gaps_in_every_stream"] == {"step": 1}
    assert _heading_off_at_end(out, clean, 5.0) < 2.0


def test_a_loss_of_every_sensor_in_a_turn_is_still_bridged_and_said_so(records):
    """5 s of every sensor lost in the same turn: the readings changed across it as the turn does in 5 s, so it is
    bridged as before (the bridge serves a loss: heading within 2 deg of the clean run), now said and counted."""
    config, recs = records
    _, clean, _ = _run(config, recs)
    nav, out, said = _run(config, _lost(recs, 5.0, T_TURN))
    assert any("no stream has a sample for 5.010 s after t = 164.990 s: taken as a loss of every sensor" in w
               for w in said), said
    assert nav.info["gaps_in_every_stream"] == {"loss": 1}
    assert _heading_off_at_end(out, clean) < 2.0


def test_a_gap_in_every_stream_the_imu_cannot_judge_is_bridged_with_the_doubt_said(records):
    """The IMU reading one steady motion for 2 s either side of a 5 s gap on a straight leg (its noise only): a step
    and a loss read the same. Bridged as a loss, as before, but no longer "ok" unsaid: the warning says it cannot be
    told and the estimates after it are degraded, naming the gap."""
    config, recs = records
    rng = np.random.default_rng(0)
    t_gap = 188.0
    steady = next(r for r in recs if r["type"] == "imu" and r["t"] >= t_gap - 2.0)

    def held(r):
        if r["type"] != "imu" or not t_gap - 2.0 <= r["t"] < t_gap + 7.0:
            return r
        return dict(r, f_b=list(np.add(steady["f_b"], rng.normal(0, 1e-3, 3))),
                    omega_b=list(np.add(steady["omega_b"], rng.normal(0, 1e-5, 3))))

    nav, out, said = _run(config, _lost([held(r) for r in recs], 5.0, t_gap))
    assert any("no stream has a sample for 5.010 s after t = 187.990 s: a step of the clock they share cannot be "
               "told from a loss of every sensor" in w for w in said), said
    assert nav.info["gaps_in_every_stream"] == {"undecided": 1}
    after = [e for e in out if e.t > t_gap]
    assert after and all(e.health != "ok" and "may be a step of their clock, not a loss" in e.health_why
                         for e in after)


def test_a_step_of_every_streams_clock_is_judged_on_a_20_hz_imu_too():
    """A 20 Hz IMU has 10 samples in the 0.5 s either side of a gap, under the 20 a fit needs: every gap in every
    stream was "undecided" for "under 0.5 s of IMU samples" (there were 0.5 s), a 5 s step in the turn bridged with
    24.2 deg of turn it never made and the rest of the run degraded. The sides now hold 20 samples (1 s): joined as a
    step, the heading within 2 deg of the clean run's, "ok"."""
    config = SensorConfig(imu_rate_hz=20.0)
    m = simulate_mission(duration_s=200.0, seed=1, config=config, gt_rate_hz=5.0)
    recs = list(mission_records(m, config=False))
    _, clean, _ = _run(m.config, recs)
    nav, out, said = _run(m.config, _stepped_at(recs, 5.0, T_TURN))
    assert nav.info["gaps_in_every_stream"] == {"step": 1}, said
    assert _heading_off_at_end(out, clean, 5.0) < 2.0 and out[-1].health == "ok"


def test_a_second_step_before_the_first_is_judged_is_judged_too(records):
    """Every stream's clock stepped 5 s ahead in the turn and again 0.3 s later, before the 0.5 s that judge the
    first had come: the second was fitted inside the first's window and bridged unjudged, 23.3 deg of turn never
    made, "ok". Each is judged now (the first by the 0.3 s between): both joined, the heading within 2 deg."""
    config, recs = records
    _, clean, _ = _run(config, recs)
    nav, out, said = _run(config, _stepped_at(_stepped_at(recs, 5.0, T_TURN + 0.3), 5.0, T_TURN))
    assert nav.info["gaps_in_every_stream"] == {"step": 2}, said
    assert _heading_off_at_end(out, clean, 10.0) < 2.0


def test_an_array_of_the_wrong_shape_in_the_smoother_is_a_programming_error_not_a_loss_of_track(records, monkeypatch):
    """numpy raises the LinAlgError of a singular matrix also for an array of the wrong shape ("Last 2 dimensions of
    the array must be square"): a bug in the estimator, which was said as a loss of track (the run ended diverged,
    exit 3, with no traceback to find it by). It now ends the run as GTSAM's other RuntimeErrors do."""
    from graphnav.estimators.backends import GraphBackend

    def wrong_shape(self, kf):
        return np.linalg.solve(np.zeros((2, 3)), np.zeros(2))

    monkeypatch.setattr(GraphBackend, "process", wrong_shape)
    config, recs = records
    with pytest.raises(np.linalg.LinAlgError, match="must be square"):
        _run(config, recs)


def test_no_state_is_propagated_after_a_loss_of_track(records, monkeypatch):
    """The smoother lost track at 150 s of a 200 s stream: the estimates stop there, but state_at(199) propagated the
    last one over the 50 s of IMU samples after it as if nothing had happened (a controller steering on it had no
    word of the loss). Now it is refused naming the loss."""
    from graphnav.core.errors import ConfigError
    from graphnav.estimators.backends import GraphBackend
    from graphnav.estimators.health import LostTrack
    process = GraphBackend.process

    def lost_at_150(self, kf):
        if kf.t >= 150.0:
            raise LostTrack(kf.t, "the DVL innovation covariance cannot be inverted")
        return process(self, kf)

    monkeypatch.setattr(GraphBackend, "process", lost_at_150)
    config, recs = records
    nav, out, _ = _run(config, recs)
    assert nav.lost_track[0] == 150.0 and out[-1].t == 149.0
    with pytest.raises(ConfigError, match=r"state_at\(199.000\): the fixed-lag estimator lost track at t = 150.000 s "
                       r"\(the DVL innovation covariance cannot be inverted\); no state after its last estimate "
                       r"\(t = 149.000 s\)"):
        nav.state_at(199.0)


@pytest.mark.parametrize("held", [(5,), (0, 1, 2, 3, 4, 5)])
def test_a_gap_judged_beside_an_imu_channel_reading_one_value_leaves_that_channel_out(held):
    """A 100 Hz IMU in a turn whose rate grows 0.2 deg/s each second, its clock stepped 5 s (no time passed), one
    channel (or all six) reading exactly one value either side (a quantised gyro, a dead axis): that channel's fit had
    no spread, its chi-square term 0/0, every chi-square NaN and the gap "undecided" ("step nan, loss nan"), the turn
    bridged and the rest of the run degraded. The channel is left out: the other five tell the step; six held still
    is undecided with its reason."""
    from graphnav.estimators.clock_steps import judge_gap
    rng = np.random.default_rng(3)

    def samples(t_vehicle, t_stamp):
        x = np.column_stack([0.2 * np.sin(t_vehicle), 0.1 * t_vehicle, -9.8 + 0.05 * t_vehicle ** 2,
                             0.01 * t_vehicle, -0.02 * t_vehicle, np.radians(0.2) * t_vehicle ** 2])
        x = x + rng.normal(0.0, 1e-3, x.shape)
        x[:, list(held)] = 0.0
        return [(float(s), x[k, :3], x[k, 3:]) for k, s in enumerate(t_stamp)]

    t_before = np.arange(100) * 0.01 + 10.0
    t_after = t_before[-1] + 0.01 + np.arange(100) * 0.01
    verdict = judge_gap(samples(t_before, t_before), samples(t_after, t_after + 5.0), 0.01)
    if len(held) == 6:
        assert verdict.kind == "undecided" and "every IMU channel reads one value" in verdict.why
    else:
        assert verdict.kind == "step" and np.isfinite(verdict.chi2_loss), verdict
        assert "chi-square over the 5 (the others read one value either side) IMU channels" in verdict.why


def test_an_all_zero_imu_row_right_after_a_joined_clock_step_is_dropped_as_filler():
    """The first IMU sample after a step of every stream's clock is joined to the one before it (no time passed);
    a logger's all-zero filler row there went in as a sample of zero specific force (about 0.1 m/s of velocity at
    100 Hz), and a keyframer holding no sample yet raised an IndexError. Both now go in as any sample does: the zero
    row dropped and counted, the first sample started on."""
    from graphnav.estimators.keyframes import Keyframer
    k = Keyframer(SensorConfig())
    k.join_step(0.0, (0.0, 0.0, -9.8), (0.0, 0.0, 0.0))          # no sample before it: started on
    k.add_imu(0.01, (0.0, 0.0, -9.8), (0.0, 0.0, 0.0))
    with pytest.warns(RuntimeWarning, match="all-zero IMU row"):
        k.join_step(5.02, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert k.stats.zero_imu_rows == 1 and [s[0] for s in k._samples][-1] == 0.01
