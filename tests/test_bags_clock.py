"""A bag straight from the drivers: a topic's own header clock stepping (+5 s, or days) or stalling while its
messages keep arriving on the recorder's receive clock, and an IMU losing messages near the bag's start. Short
simulated missions written as bags and rewritten message by message."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from graphnav.core.errors import DataError
from graphnav.io import bag_convert, bag_stamps, bags
from graphnav.sim.simulate import simulate_mission

T0_NS = 1_700_000_000_123_456_789
NS = 1_000_000_000


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    root = tmp_path_factory.mktemp("bags_clock")
    mission = simulate_mission(duration_s=30.0, seed=5)
    path = bags.write_mission_bag(mission, root / "clean", t0_unix_ns=T0_NS)
    return mission, path, root


def _stamp_ns(msg) -> int:
    return msg.header.stamp.sec * NS + msg.header.stamp.nanosec


def _set_stamp(msg, ns: int) -> None:
    msg.header.stamp.sec, msg.header.stamp.nanosec = ns // NS, ns % NS


def _rewritten(clean, path, change):
    """The bag ``clean`` written again to ``path`` with each message through ``change(topic, k, msg, t_ns)`` (``k``:
    its index in the topic), which returns its receive time (ns) or None to drop it."""
    from rosbags.highlevel import AnyReader
    from test_bags import _bag_with
    store = bags.typestore()
    rows, seen = [], {}
    with AnyReader([clean], default_typestore=store) as reader:
        for conn, t_ns, raw in reader.messages():
            k = seen[conn.topic] = seen.get(conn.topic, -1) + 1
            msg = store.deserialize_cdr(raw, conn.msgtype)
            t_ns = change(conn.topic, k, msg, t_ns)
            if t_ns is not None:
                rows.append((conn.topic, conn.msgtype, t_ns, msg))
    return _bag_with(path.parent, path.name, sorted(rows, key=lambda r: r[2]), store)


def _load(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = bags.load_bag(path)
    return m, [str(w.message) for w in caught]


def _latency_ns(rng) -> int:
    """A DVL driver's latency, 0.25-0.35 s (the receive time after the header stamp)."""
    return int((0.25 + 0.1 * rng.random()) * NS)


def _dvl_stall(rng, last: int, resumed: bool = False):
    """A change (:func:`_rewritten`) of the DVL's messages: 11 to ``last`` repeat message 10's header stamp (its clock
    stalled); ``resumed``: the clock then runs on from the value it froze at (the later pings as many seconds early as
    it stalled); every ping received 0.25-0.35 s after its time."""
    held = {}

    def change(t, k, msg, rx):
        if t != "/dvl/data":
            return rx
        if k == 10:
            held["ns"] = _stamp_ns(msg)
        if 10 < k <= last:
            _set_stamp(msg, held["ns"])
        elif resumed and k > last:
            _set_stamp(msg, _stamp_ns(msg) - (last - 10) * NS)
        return rx + _latency_ns(rng)
    return change


STREAMS = {"/dvl/data": "dvl", "/pressure": "depth", "/reference/odometry": "gt"}


@pytest.mark.parametrize("topic", list(STREAMS))
def test_a_topics_own_header_clock_step_is_moved_back_as_the_imus(sim, tmp_path, topic):
    """The DVL's (the pressure's, the reference's) header clock alone steps +5 s or +2 days at 15 s while its messages
    keep arriving on the receive clock and every other topic is fine: the DVL's pings were left 5 s late for the
    second half (its velocities set against the IMU's of 5 s before) and a 2-day step refused the whole bag naming
    field 't' and a "sample". Now the stamps after the step are moved back onto the clock before it, as the IMU's
    are: warned naming the topic, the message, its time and the field, and counted as doubted on its stream."""
    mission, clean_path, _ = sim
    clean, _ = _load(clean_path)
    stream = STREAMS[topic]
    at_ns = T0_NS + 15 * NS
    for step_s in (5.0, 2 * 86400.0):
        first = {}

        def change(t, k, msg, rx):
            if t == topic and rx >= at_ns:
                first.setdefault("k", k)
                _set_stamp(msg, _stamp_ns(msg) + int(step_s * NS))
            return rx
        m, warned = _load(_rewritten(clean_path, tmp_path / f"{stream}{step_s:g}", change))
        np.testing.assert_allclose(getattr(m, stream).t, getattr(clean, stream).t, atol=2e-9)
        np.testing.assert_array_equal(m.imu.t, clean.imu.t)
        n = len(getattr(clean, stream).t)
        assert m.meta["streams"][stream]["doubted"] == {bag_convert.HEADER_CLOCK_STEP: n - first["k"]}
        said = [w for w in warned if "the header clock steps" in w]
        period = 1.0 if stream == "dvl" else 0.1
        assert len(said) == 1 and said[0].startswith(
            f"{tmp_path / f'{stream}{step_s:g}'}: {topic}, message {first['k']} (t = {15.0 + step_s:.3f} s), field "
            f"'header.stamp': the header clock steps {step_s + period:+.3f} s while the messages kept arriving "
            f"(receive time {period:+.3f} s)"), said


def test_a_dvl_clock_jumping_days_with_the_receive_clock_is_refused_naming_the_topic_and_message(sim, tmp_path):
    """The DVL's header stamps and their receive time both jump two days at 15 s (the recorder's clock stepped with
    the DVL's): no clock in the bag says what time passed. Refused naming the topic, the message and the header
    stamp field, saying the receive time jumped with it (it named field 't' and "sample 15 of the stream")."""
    _, clean_path, _ = sim
    at_ns = T0_NS + 15 * NS

    def change(t, k, msg, rx):
        if t == "/dvl/data" and rx >= at_ns:
            _set_stamp(msg, _stamp_ns(msg) + 2 * 86400 * NS)
            return rx + 2 * 86400 * NS
        return rx
    with pytest.raises(DataError, match=r"message 15 \(t = 172815\.000 s\): time stamp jumps by 172801 s") as err:
        _load(_rewritten(clean_path, tmp_path / "both", change))
    assert (err.value.source, err.value.field) == (f"{tmp_path / 'both'}:/dvl/data", "header.stamp")
    assert str(err.value).endswith("the receive time jumps +172801 s with it: the recorder's clock stepped too, so no "
                                   "clock in the bag says what time passed: split the bag there")


def test_an_imu_losing_half_a_second_at_its_20th_message_is_warned_as_a_gap(sim, tmp_path):
    """Half a second of IMU messages lost from the 20th on (header and receive time both gap): a loss later is warned
    as a gap the run bridges, this one was not (the step test wants 50 stamps either side, and the bag's start has 20).
    Now a gap near either end is judged on the 10 or more stamps there are on its short side: warned naming the
    message and counted as doubted, as any gap; a clean start says nothing."""
    from graphnav.core.imu_timing import stamp_steps
    from graphnav.core.screening import IMU_GAP
    _, clean_path, _ = sim
    for first in (20, 2930):
        lost = _rewritten(clean_path, tmp_path / f"loss{first}",
                          lambda t, k, msg, rx: None if t == "/imu/data" and first <= k < first + 50 else rx)
        m, warned = _load(lost)
        gaps = [w for w in warned if "a gap of 0.5 s in the stamps" in w]
        assert len(gaps) == 1 and f"/imu/data, message {first} (t = " in gaps[0], gaps
        assert m.meta["streams"]["imu"]["doubted"] == {IMU_GAP: 1}
    t = np.delete(np.arange(3000) * 0.01, np.arange(5, 55))
    assert stamp_steps(t, 0.01)[0].size == 0            # 5 stamps before it: too few to judge
    t = np.arange(3000) * 0.01 + np.random.default_rng(1).normal(0.0, 0.002, 3000)
    assert stamp_steps(np.sort(t), 0.01)[0].size == 0   # jitter alone: nothing at the ends
    _, warned = _load(clean_path)
    assert not [w for w in warned if "a gap of" in w]


def test_a_dvl_header_clock_stalling_restamps_those_pings_alone(sim, tmp_path):
    """The DVL's header clock stalls: messages 11 to 14 repeat message 10's stamp while they keep arriving every
    second, 0.25-0.35 s after their time (the driver's latency). The whole topic went onto the receive time, every
    ping 0.25-0.35 s late; now the stalled pings alone are stamped from their receive time less the latency of the
    pings around them, the others keep their header stamps: warned naming the message and the field, counted as
    doubted. Repeats on over a quarter of the messages (a driver stamping bursts) still go onto the receive time."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    rng = np.random.default_rng(2)

    def stalled(last):
        return _dvl_stall(rng, last)
    m, warned = _load(_rewritten(clean_path, tmp_path / "stall", stalled(14)))
    dt = m.dvl.t - clean.dvl.t
    assert np.all(np.abs(np.delete(dt, np.arange(11, 15))) < 2e-9)
    assert np.all(np.abs(dt[11:15]) < 0.06), dt[11:15]
    assert m.meta["clock"]["stamps"]["dvl"] == "header"
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_STALL: 4}
    said = [w for w in warned if "the header clock stalls" in w]
    assert len(said) == 1 and said[0].startswith(f"{tmp_path / 'stall'}:/dvl/data: message 11, field 'header.stamp': "
                                                 "the header clock stalls: 4 message(s) repeat"), said
    m, _ = _load(_rewritten(clean_path, tmp_path / "two", stalled(12)))
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_STALL: 2}
    m, _ = _load(_rewritten(clean_path, tmp_path / "burst", stalled(13 + 10)))
    assert m.meta["clock"]["stamps"]["dvl"] == "receive"


def test_a_dvl_losing_pings_as_its_latency_drops_keeps_its_header_stamps(tmp_path):
    """A 5 Hz DVL whose recorder latency is 1.5 s (a backlog) loses 2 s of pings at 15 s as the backlog is flushed
    (latency 0.05 s after): the header stamps gap 2.2 s, the receive time 0.75 s, header minus receive time steps
    +1.45 s. That read as the DVL's clock stepping: the 70 pings after the loss were moved 1.4 s early, warned as "no
    messages lost". The receive time gapping too (3 pings' worth) as header minus receive time comes nearer 0 says
    the latency dropped as messages were lost: the stamps are kept. A +5 s step of the DVL's clock as as many pings are
    lost (header minus receive time away from 0) is still moved back."""
    import dataclasses

    from graphnav.core.config import SensorConfig
    cfg = SensorConfig()
    cfg = dataclasses.replace(cfg, dvl=dataclasses.replace(cfg.dvl, rate_hz=5.0))
    mission = simulate_mission(duration_s=30.0, seed=5, config=cfg)
    clean_path = bags.write_mission_bag(mission, tmp_path / "clean", t0_unix_ns=T0_NS)
    clean, _ = _load(clean_path)
    lost_from, lost_to = T0_NS + 15 * NS, T0_NS + 17 * NS

    def change(topic, k, msg, rx):
        if topic != "/dvl/data":
            return rx
        if lost_from <= rx < lost_to:
            return None
        return rx + int((1.5 if rx < lost_from else 0.05) * NS) + k % 3 * 1_000_000

    m, warned = _load(_rewritten(clean_path, tmp_path / "flushed", change))
    t_mission = clean.dvl.t + mission.imu.t[0]          # the pings' receive time in the clean bag, s from T0_NS
    kept = (t_mission < 15.0 - 1e-6) | (t_mission >= 17.0 - 1e-6)
    assert kept.sum() == clean.dvl.t.size - 10 == m.dvl.t.size
    np.testing.assert_allclose(m.dvl.t, clean.dvl.t[kept], atol=2e-9)
    assert not [w for w in warned if "the header clock steps" in w]
    assert "doubted" not in m.meta["streams"]["dvl"]
    # the DVL's clock stepping +5 s as the same pings are lost (a driver restarted) is still moved back

    def stepped(topic, k, msg, rx):
        if topic == "/dvl/data" and rx >= lost_from:
            _set_stamp(msg, _stamp_ns(msg) + 5 * NS)
        return None if topic == "/dvl/data" and lost_from <= rx < lost_to else rx + int(0.05 * NS) + k % 3 * 1_000_000

    m, warned = _load(_rewritten(clean_path, tmp_path / "restarted", stepped))
    np.testing.assert_allclose(m.dvl.t, clean.dvl.t[kept], atol=2e-9)
    said = ("/dvl/data, message 75 (t = 22.000 s), field 'header.stamp': the header clock steps +7.200 s while the "
            "receive time steps +2.")
    assert len([w for w in warned if said in w and "s: 10 messages lost by it, the rest the clock's step" in w]) == 1


def test_a_dvl_header_clock_resuming_from_its_stall_or_stepping_back_is_repaired_not_dropped(sim, tmp_path):
    """The DVL's header clock stalls at message 10 for four pings and resumes from the value it froze at (message 15
    is stamped one second after message 10: every later ping 4 s early), or steps back 5 s at 15 s, while its pings
    keep arriving every second 0.25-0.35 s after their time. The whole topic went onto the receive time (every ping
    0.25-0.35 s late, "4 duplicated" / "1 non-monotonic"); now the pings after the step are moved forward onto the
    clock before it (the stalled ones stamped from their receive time as before), warned naming the message and the
    field and counted as doubted; the other pings keep their header stamps exactly."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    n = clean.dvl.t.size
    rng = np.random.default_rng(3)
    resumed = _dvl_stall(rng, 14, resumed=True)

    def back(t, k, msg, rx):
        if t == "/dvl/data" and rx >= T0_NS + 15 * NS:
            _set_stamp(msg, _stamp_ns(msg) - 5 * NS)
        return rx + _latency_ns(rng) if t == "/dvl/data" else rx
    for name, change, stalled, said in (
            ("resumed", resumed, np.arange(11, 15), "its stamp +1.000 s after message 10's, received +5."),
            ("back", back, np.zeros(0, int), "its stamp -4.000 s after message 14's, received +1.")):
        m, warned = _load(_rewritten(clean_path, tmp_path / name, change))
        assert m.meta["clock"]["stamps"]["dvl"] == "header"
        dt = m.dvl.t - clean.dvl.t
        assert np.all(np.abs(np.delete(dt, stalled)) < 2e-9), dt
        assert np.all(np.abs(dt[stalled]) < 0.06), dt[stalled]
        doubted = {bag_stamps.HEADER_CLOCK_STEP_BACK: n - 15, **({bag_stamps.HEADER_CLOCK_STALL: 4} if stalled.size
                                                                  else {})}
        assert m.meta["streams"]["dvl"]["doubted"] == doubted
        steps = [w for w in warned if "the header clock steps back" in w]
        assert len(steps) == 1 and steps[0].startswith(
            f"{tmp_path / name}:/dvl/data: message 15, field 'header.stamp': the header clock steps back "
            f"({said}"), steps
        assert steps[0].endswith("the stamps from this message on are moved forward by 4.000 s onto the clock before "
                                 "the step" if stalled.size else "moved forward by 5.000 s onto the clock before the "
                                 "step")
        assert not [w for w in warned if "receive time is used" in w]


@pytest.mark.parametrize("off_s", [-5.0, 5.0])
def test_a_dvl_header_clock_set_right_mid_bag_moves_the_pings_before_onto_it(sim, tmp_path, off_s):
    """The DVL's header clock runs 5 s behind (or ahead of) the receive clock for the first 15 pings and is set right
    at message 15 (an RTC synchronised mid-dive) while its pings keep arriving 0.25-0.35 s after their time. The
    forward step moved the 15 pings after it back onto the wrong clock (every ping of the second half 5 s early) and
    the step back put the whole topic on the receive time; now the 15 pings before it are moved onto the clock after
    it, as a step's pings are (the same rule), warned naming the message and counted as doubted."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    rng = np.random.default_rng(4)

    def change(t, k, msg, rx):
        if t != "/dvl/data":
            return rx
        if k < 15:
            _set_stamp(msg, _stamp_ns(msg) + int(off_s * NS))
        return rx + _latency_ns(rng)
    path = _rewritten(clean_path, tmp_path / f"set{off_s:+g}", change)
    m, warned = _load(path)
    np.testing.assert_allclose(m.dvl.t, clean.dvl.t, atol=2e-9)
    np.testing.assert_array_equal(m.imu.t, clean.imu.t)
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_SET_RIGHT: 15}
    said = [w for w in warned if "set right" in w]
    assert len(said) == 1 and "message 15" in said[0] and f"{-off_s:+.3f} s onto the clock after" in said[0], said


def test_an_imu_losing_samples_as_its_latency_drops_is_told_from_a_clock_step_by_its_sample_grid(sim, tmp_path):
    """The IMU loses 5 samples at message 1500 as the recorder's latency drops from 60 to 2 ms: the header stamps gap
    60 ms, the receive time 2 ms, header minus receive time steps +58 ms, as if the header clock stepped. The 1495
    samples after the loss were moved 50 ms early ("no messages lost"). The header stamps stay on their sample grid
    across the gap: messages lost, kept as stamped and warned, the gap bridged as any. The header clock stepping
    +1.5 ms (off the grid) as they are lost is still moved back, the warning saying how many were lost cannot be told;
    on stamps too uneven (2-3 ms jitter
    on 10 ms) to tell, the step is moved and the warning says it cannot be told."""
    from graphnav.core.screening import IMU_GAP
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    lost = np.arange(1500, 1505)

    def dropped(t, k, msg, rx):
        if t != "/imu/data":
            return rx
        return None if k in lost else rx + (60 if k < 1500 else 2) * 1_000_000
    m, warned = _load(_rewritten(clean_path, tmp_path / "dropped", dropped))
    np.testing.assert_allclose(m.imu.t, np.delete(clean.imu.t, lost), atol=2e-9)
    assert m.meta["streams"]["imu"]["doubted"] == {IMU_GAP: 1}
    said = [w for w in warned if "stay on their sample grid" in w]
    assert len(said) == 1 and said[0].startswith(
        f"{tmp_path / 'dropped'}: /imu/data, message 1500 (t = 15.050 s), field 'header.stamp': the header stamps gap "
        "+0.060 s while the receive time steps +0.002 s, yet stay on their sample grid: 5 message(s) lost"), said
    assert not [w for w in warned if "the header clock steps" in w]

    def stepped(t, k, msg, rx):
        if t != "/imu/data":
            return rx
        if k >= 1500:
            _set_stamp(msg, _stamp_ns(msg) + 1_500_000)
        return None if k in lost else rx + (60 if k < 1500 else 4) * 1_000_000
    m, warned = _load(_rewritten(clean_path, tmp_path / "stepped", stepped))
    said = [w for w in warned if "message 1500 (t = 15.052 s), field 'header.stamp': the header clock steps +0.06" in w]
    assert len(said) == 1 and "the stamps leave their sample grid, so the header clock stepped" in said[0], said
    assert m.meta["streams"]["imu"]["doubted"] == {bag_convert.HEADER_CLOCK_STEP: 1496}
    rng = np.random.default_rng(6)
    jitter = {}

    def uneven(t, k, msg, rx):
        if t != "/imu/data":
            return rx
        jitter[k] = int(rng.uniform(-3e6, 3e6))
        _set_stamp(msg, _stamp_ns(msg) + jitter[k])
        return None if k in lost else rx + (60 if k < 1500 else 2) * 1_000_000
    m, warned = _load(_rewritten(clean_path, tmp_path / "uneven", uneven))
    said = [w for w in warned if "cannot be told from 5 message(s) lost as the recorder's latency dropped" in w]
    assert len(said) == 1 and "the header clock steps" in said[0], said


@pytest.mark.parametrize("recorder_s, step_s", [(3.0, 3.0), (-3.0, -3.0)])
def test_a_dvl_clock_step_is_judged_against_the_imu_clock_when_the_recorder_clock_is_off(sim, tmp_path, recorder_s,
                                                                                          step_s):
    """The recording computer's clock is 3 s off the vehicle's (every message received 3 s after, or before, its
    stamp: the IMU's header minus receive time -3 s or +3 s) and the DVL's header clock steps by as much at message 15,
    onto the recorder's clock. Judged against the receive clock alone, that read as the DVL's clock set right: the 15
    pings before it were moved onto the clock after (every ping of the topic 3 s off the IMU). Judged against the
    IMU's clock, it is the DVL's clock stepping: the pings after it are moved back onto the IMU's, as with a recorder
    on time."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    n = clean.dvl.t.size

    def change(t, k, msg, rx):
        if t == "/dvl/data" and k >= 15:
            _set_stamp(msg, _stamp_ns(msg) + int(step_s * NS))
        return rx + int(recorder_s * NS) + (50_000_000 if t == "/dvl/data" else 0)
    m, warned = _load(_rewritten(clean_path, tmp_path / f"rec{recorder_s:+g}", change))
    np.testing.assert_allclose(m.dvl.t, clean.dvl.t, atol=2e-9)
    reason = bag_stamps.HEADER_CLOCK_STEP if step_s > 0 else bag_stamps.HEADER_CLOCK_STEP_BACK
    assert m.meta["streams"]["dvl"]["doubted"] == {reason: n - 15}
    assert not [w for w in warned if "set right" in w]


@pytest.mark.parametrize("back_s", [5.0, 0.8])
def test_a_dvl_header_clock_stalling_and_stepping_back_elsewhere_keeps_its_header_stamps(sim, tmp_path, back_s):
    """The DVL's header clock stalls for messages 11-12 (they repeat message 10's stamp, as the driver bag's do) and
    steps back at message 20, its pings received 0.05 s after their time. Stepping back 5 s, the whole topic went onto
    the receive time (the stall was not restamped with a step back in the topic: every ping 0.05 s late); now the stall
    is restamped and the step repaired. Stepping back 0.8 s (under a period: stamps still increasing), the step in the
    window of message 13, the first after the stall, was taken for its own: the 7 pings from it to the step moved 1 s
    late ("steps back ... moved forward by 1.000 s"); then the step was left (the 11 pings after it 0.8 s early); now
    the stall is restamped and the step repaired at message 20 alone, as the longer one."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    n = clean.dvl.t.size
    held = {}

    def change(t, k, msg, rx):
        if t != "/dvl/data":
            return rx
        held.setdefault("ns", _stamp_ns(msg)) if k == 10 else None
        if k in (11, 12):
            _set_stamp(msg, held["ns"])
        elif k >= 20:
            _set_stamp(msg, _stamp_ns(msg) - int(back_s * NS))
        return rx + 50_000_000
    m, warned = _load(_rewritten(clean_path, tmp_path / f"back{back_s:g}", change))
    assert m.meta["clock"]["stamps"]["dvl"] == "header"
    dt = m.dvl.t - clean.dvl.t
    np.testing.assert_allclose(dt[:11], 0.0, atol=2e-9)
    np.testing.assert_allclose(dt[11:13], 0.0, atol=1e-3)
    np.testing.assert_allclose(dt[13:], 0.0, atol=2e-9)
    doubted = {bag_stamps.HEADER_CLOCK_STALL: 2, bag_stamps.HEADER_CLOCK_STEP_BACK: n - 20}
    said = m.meta["streams"]["dvl"]["doubted"]
    assert {k: v for k, v in said.items() if k.startswith(("stamped after", "stamped while"))} == doubted, said
    steps = [w for w in warned if "the header clock steps back" in w]
    assert len(steps) == 1 and "message 20," in steps[0], steps


def _dvl_latency(rng, change=None):
    """A change (:func:`_rewritten`) of the DVL's messages: each through ``change(k, msg)`` (its header stamp), received
    0.25-0.35 s after its time."""
    def rewrite(t, k, msg, rx):
        if t != "/dvl/data":
            return rx
        if change is not None:
            change(k, msg)
        return rx + _latency_ns(rng)
    return rewrite


def test_a_dvl_header_clock_off_for_ten_pings_is_repaired_not_put_on_the_receive_time(sim, tmp_path):
    """The DVL's header clock runs 5 s ahead for pings 10-19 alone (a glitch of its RTC), its pings received 0.25-0.35 s
    after their time. The step back at ping 20 was judged over a window holding the glitch itself (no step seen): the
    whole topic went onto the receive time, every ping 0.25-0.35 s late ("1 non-monotonic"). Now each step is judged
    between the jumps either side of it: the ten pings are moved onto the clock around them, warned once naming the
    first and the last, counted as ten."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)

    def ahead(k, msg):
        if 10 <= k < 20:
            _set_stamp(msg, _stamp_ns(msg) + 5 * NS)
    m, warned = _load(_rewritten(clean_path, tmp_path / "glitch", _dvl_latency(np.random.default_rng(6), ahead)))
    assert m.meta["clock"]["stamps"]["dvl"] == "header"
    np.testing.assert_allclose(m.dvl.t, clean.dvl.t, atol=2e-9)
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_SET_RIGHT: 10}
    said = [w for w in warned if "set right" in w]
    assert len(said) == 1 and said[0].startswith(f"{tmp_path / 'glitch'}:/dvl/data: message 20, field 'header.stamp'"
                                                 ": the header clock is set right (its stamp -4.000 s after message "
                                                 "19's"), said
    assert ("the 10 stamp(s) from message 10 (where the clock stepped off by as much) to it are moved by -5.000 s "
            "onto the clock after") in said[0]
    assert not [w for w in warned if "receive time is used" in w]


def test_a_pressure_header_clock_off_for_a_third_of_the_bag_counts_the_messages_moved(sim, tmp_path):
    """The pressure's header clock runs 5 s ahead for messages 100-199 of 301 (received on time): the stamps were
    repaired exactly but every message counted as doubted (the step back at 200 moved all 200 before it, the step at
    100 then the 100 before that back again: 300 where 100 were off). Now the 100 are moved and counted."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)

    def change(t, k, msg, rx):
        if t == "/pressure" and 100 <= k < 200:
            _set_stamp(msg, _stamp_ns(msg) + 5 * NS)
        return rx
    m, warned = _load(_rewritten(clean_path, tmp_path / "pressure", change))
    np.testing.assert_allclose(m.depth.t, clean.depth.t, atol=2e-9)
    assert m.meta["streams"]["depth"]["doubted"] == {bag_stamps.HEADER_CLOCK_SET_RIGHT: 100}
    assert len([w for w in warned if "set right" in w]) == 1


def test_a_dvl_header_clock_stepping_back_under_a_period_is_repaired(sim, tmp_path):
    """The DVL's header clock steps back 0.5 s at ping 15 (half its period: its stamps still increase), its pings
    received 0.25-0.35 s after their time. The 16 pings from it on were left 0.5 s early, without a word. The step
    leaves the sample grid and header minus receive time drops by it: the pings are moved forward onto the clock
    before the step, warned and counted."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    n = clean.dvl.t.size

    def back(k, msg):
        if k >= 15:
            _set_stamp(msg, _stamp_ns(msg) - NS // 2)
    m, warned = _load(_rewritten(clean_path, tmp_path / "back", _dvl_latency(np.random.default_rng(7), back)))
    np.testing.assert_allclose(m.dvl.t, clean.dvl.t, atol=2e-9)
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_STEP_BACK: n - 15}
    said = [w for w in warned if "the header clock steps back" in w]
    assert len(said) == 1 and "message 15, field 'header.stamp'" in said[0] and said[0].endswith(
        "the stamps from this message on are moved forward by 0.500 s onto the clock before the step"), said


@pytest.mark.parametrize("jitter_s", [0.1, 1.0])
def test_a_dvl_header_clock_running_slow_is_warned_and_taken_out_when_clear(sim, tmp_path, jitter_s):
    """The DVL's own clock runs 1 % slow against the IMU's and the recorder's, its pings received 0.25 s plus up to
    0.1 s (1 s) after their time: its stamps fell 0.3 s behind by the end of the 30 s bag without a word. Now header
    minus receive time drifting off the IMU's is warned about naming the topic and counted on every ping; 0.3 s against
    the 0.1 s jitter is taken out (the pings within 0.02 s of their time), against 1 s of jitter it is not clear
    (under ten times the spread about the line) and is kept as stamped, the warning saying so."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    rng = np.random.default_rng(8)
    t0 = {}

    def change(t, k, msg, rx):
        if t != "/dvl/data":
            return rx
        t0.setdefault("ns", _stamp_ns(msg))
        _set_stamp(msg, t0["ns"] + round((_stamp_ns(msg) - t0["ns"]) * 0.99))
        return rx + int((0.25 + jitter_s * rng.random()) * NS)
    path = _rewritten(clean_path, tmp_path / f"slow{jitter_s:g}", change)
    m, warned = _load(path)
    n = clean.dvl.t.size
    said = [w for w in warned if "the header clock runs" in w]
    assert len(said) == 1 and said[0].startswith(f"{path}: /dvl/data, field 'header.stamp': the header clock runs "
                                                 ) and "% slow against the IMU's" in said[0], said
    assert jitter_s > 0.5 or "runs 0.9" in said[0] or "runs 1.0" in said[0], said
    dt = m.dvl.t - clean.dvl.t
    if jitter_s < 0.5:
        assert np.abs(dt).max() < 0.02, dt
        assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_DRIFT: n}
    else:
        assert dt[-1] == pytest.approx(-0.3, abs=1e-6)
        assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_DRIFT_UNTOLD: n}
        assert said[0].endswith("too spread to take the drift out: the header stamps are kept")


def _imu_packets(t, k, rx):
    """The IMU's samples delivered in packets of 10 (received with the packet's last): header minus receive time a
    sawtooth of 0-0.09 s, every message's a jump of more than a quarter period."""
    return rx + (9 - k % 10) * NS // 100 if t == "/imu/data" else rx


def test_an_imu_delivered_in_packets_is_no_reason_to_move_the_other_topics_off_a_drifting_recorder_clock(sim,
                                                                                                        tmp_path):
    """The recorder's clock runs 1 % fast against the vehicle's (every receive time), the IMU's samples arrive in
    packets of 10. Every header clock is right. The packets' sawtooth was taken out as jumps, leaving the IMU no drift
    against the recorder: the DVL, the pressure and the reference read as drifting 0.3 s against it and were moved
    0.3 s off their true time ("the header clock runs ... slow against the IMU's"). Now a latency jumping on most
    messages is the recorder's delivery, not a clock's steps: every topic keeps its header stamps, no drift is said."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)

    def change(t, k, msg, rx):
        return T0_NS + round((_imu_packets(t, k, rx) - T0_NS) * 1.01)
    m, warned = _load(_rewritten(clean_path, tmp_path / "packets", change))
    for s in ("dvl", "depth", "gt"):
        np.testing.assert_allclose(getattr(m, s).t, getattr(clean, s).t, atol=2e-9, err_msg=s)
    assert not [w for w in warned if "the header clock runs" in w], warned


@pytest.mark.parametrize("topic, off_s", [("/imu/data", 5.0), ("/imu/data", 0.5), ("/pressure", 0.5)])
def test_a_header_clock_glitch_under_a_latency_counts_only_the_messages_it_moved(sim, tmp_path, topic, off_s):
    """The IMU's (the pressure's) header clock runs 5 s or 0.5 s ahead for messages 1000-1099 (100-149) alone, the
    IMU delivered in packets of 10. Everything after the step back was moved forward, then everything after the step
    back: 3902 of the IMU's 3001 samples counted doubted (the pressure's 0.5 s: 352 of 301), each warning saying
    "the stamps from this message on"; in packets (every message a jump of header minus receive time) the IMU's
    last 1901 samples were left 0.09 s late. Now the stretch between the step and the step back by as much is moved
    onto the clock around it and counted alone, once."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    stream, ks = ("imu", range(1000, 1100)) if topic == "/imu/data" else ("depth", range(100, 150))

    def change(t, k, msg, rx):
        if t == topic and k in ks:
            _set_stamp(msg, _stamp_ns(msg) + round(off_s * NS))
        return _imu_packets(t, k, rx)
    m, warned = _load(_rewritten(clean_path, tmp_path / f"glitch{stream}{off_s:g}", change))
    np.testing.assert_allclose(getattr(m, stream).t, getattr(clean, stream).t, atol=2e-9)
    assert m.meta["streams"][stream]["doubted"] == {bag_stamps.HEADER_CLOCK_SET_RIGHT: len(ks)}
    said = [w for w in warned if "the header clock" in w]
    assert len(said) == 1 and f"message {ks[-1] + 1}, field 'header.stamp'" in said[0] and (
        f"the {len(ks)} stamp(s) from message {ks[0]} (where the clock stepped off by as much) to it are moved by "
        f"{-off_s:+.3f} s onto the clock after") in said[0], said
    assert not [w for w in warned if "a gap of" in w], warned


@pytest.mark.parametrize("topic", ["/dvl/data", "/reference/odometry"])
def test_a_topic_received_at_another_pace_than_stamped_keeps_its_header_stamps(sim, tmp_path, topic):
    """The DVL's pings received at 1.25 times their pace (a replay), or the reference written into the bag after the
    run (received 1 ms apart), every header stamp right. Header minus receive time running 25 % off the IMU's was
    read as the DVL's clock drifting: its pings moved onto the receive time's pace, the last 6 s early (the
    reference's kept without a word, only as its every message read as a jump). No clock drifts that far: now either
    is warned as received at another pace, counted, and the header stamps are kept."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    stream = STREAMS[topic]

    def change(t, k, msg, rx):
        if t != topic:
            return rx
        return T0_NS + round(0.8 * (rx - T0_NS)) if topic == "/dvl/data" else T0_NS + 31 * NS + k * NS // 1000
    m, warned = _load(_rewritten(clean_path, tmp_path / "pace", change))
    np.testing.assert_allclose(getattr(m, stream).t, getattr(clean, stream).t, atol=2e-9)
    n = getattr(clean, stream).t.size
    assert m.meta["streams"][stream]["doubted"] == {bag_stamps.RECEIVED_OFF_PACE: n}
    said = [w for w in warned if "received at another pace than it was stamped" in w]
    assert len(said) == 1 and f"{topic}, field 'receive time'" in said[0], said
    assert not [w for w in warned if "the header clock runs" in w], warned


def _dvl_received_later(latency_s, slow=0.0):
    """A change (:func:`_rewritten`) of the DVL's messages: each received ``latency_s(t)`` s after its time ``t`` (s
    into the bag); ``slow``: its header clock running that much slow against every other clock."""
    t0 = {}

    def change(t, k, msg, rx):
        if t != "/dvl/data":
            return rx
        t0.setdefault("ns", _stamp_ns(msg))
        _set_stamp(msg, t0["ns"] + round((_stamp_ns(msg) - t0["ns"]) * (1.0 - slow)))
        return rx + round(latency_s((rx - T0_NS) / NS) * NS)
    return change


def test_a_dvl_received_ever_later_keeps_its_right_header_stamps(sim, tmp_path):
    """The DVL's pings received 0.05 s after their time at the start, 0.35 s at the end (a recorder's queue filling),
    every header stamp right. Header minus receive time drifting 0.3 s was read as the DVL's clock running 1 % slow:
    its right stamps were moved, the last 0.3 s late. A clock running slow puts the header stamps off the pings' round
    rate; a queue filling leaves them on it and puts the receive time off it: now the header stamps are kept, warned
    as the latency growing and counted; the same DVL on a clock 1 % slow (received on time) is still taken out."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    n = clean.dvl.t.size
    m, warned = _load(_rewritten(clean_path, tmp_path / "queue", _dvl_received_later(lambda t: 0.05 + 0.01 * t)))
    np.testing.assert_array_equal(m.dvl.t, clean.dvl.t)
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_LATENCY_GROWS: n}
    said = [w for w in warned if "/dvl/data, field 'header.stamp'" in w]
    assert len(said) == 1 and "its period 1.000000 s on the header clock, 1.010000 s on the IMU's as received" in \
        said[0] and said[0].endswith("the recorder's latency grows (a queue filling), not the header clock: the "
                                     "header stamps are kept"), said
    m, warned = _load(_rewritten(clean_path, tmp_path / "slow", _dvl_received_later(lambda t: 0.05, slow=0.01)))
    assert np.abs(m.dvl.t - clean.dvl.t).max() < 1e-6
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_DRIFT: n}


def test_a_dvl_clock_running_slow_and_stepping_has_its_step_measured_off_the_drift(tmp_path):
    """The DVL's clock runs 1 % slow and steps +5 s at ping 75 of a 150 s bag, its pings received 0.25-0.35 s after
    their time. The step was measured between medians of header minus receive time some 100 s apart, a second of
    drift between them: read as +4 s and one ping lost, the stamps moved back 4.010 s, the later pings left 0.997 s
    late once the drift was taken out. Now the step is measured with the drift taken out: moved back 5.000 s, the
    drift then taken out leaves every ping within 0.02 s."""
    clean_path = bags.write_mission_bag(simulate_mission(duration_s=150.0, seed=5), tmp_path / "clean",
                                        t0_unix_ns=T0_NS)
    clean, _ = _load(clean_path)
    rng = np.random.default_rng(8)
    slow = _dvl_received_later(lambda t: 0.25 + 0.1 * rng.random(), slow=0.01)

    def change(t, k, msg, rx):
        rx = slow(t, k, msg, rx)
        if t == "/dvl/data" and k >= 75:
            _set_stamp(msg, _stamp_ns(msg) + 5 * NS)
        return rx
    m, warned = _load(_rewritten(clean_path, tmp_path / "slowstep", change))
    said = [w for w in warned if "message 75 (t = " in w]
    assert len(said) == 1 and said[0].endswith("moved back by 5.000 s onto the clock before the step"), said
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_STEP: clean.dvl.t.size - 75,
                                                   bag_stamps.HEADER_CLOCK_DRIFT: clean.dvl.t.size}
    assert np.abs(m.dvl.t - clean.dvl.t).max() < 0.02


@pytest.mark.parametrize("topic, off_ms", [("/dvl/data", 500), ("/imu/data", -5), ("/imu/data", 5),
                                           ("/dvl/data", 1500), ("/imu/data", 15)])
def test_a_header_clock_stepping_under_a_gap_is_repaired(sim, tmp_path, topic, off_ms):
    """The DVL's header clock steps +0.5 s at ping 15 (a 1.5 s step: under the two periods a gap is judged from), the
    IMU's -5 ms or +5 ms at sample 1500 (half its period: its stamps still increase), every message received as before
    (the DVL 0.25-0.35 s after its time, the IMU 1-1.5 ms). The DVL's later pings were left 0.5 s late without a word,
    the IMU's 5 ms off (warned as a step off its period, the samples keeping their stamps). Now header minus receive
    time stepping where the stamps leave their grid is the header clock's step, taken out either way as a step back of
    a DVL is: the stamps from it on moved onto the clock before it, warned and counted. A step of +1.5 s (+15 ms: 2.5
    periods between stamps, a step of 1.5 periods) fell between the two rules, too long for this one and too short for
    a gap's (a step of 2 periods or more): the later pings were left 1.5 s late (the IMU's samples 15 ms), now moved."""
    _, clean_path, _ = sim
    clean, _ = _load(clean_path)
    rng = np.random.default_rng(12)
    stream, at = ("dvl", 15) if topic == "/dvl/data" else ("imu", 1500)

    def change(t, k, msg, rx):
        if t == topic and k >= at:
            _set_stamp(msg, _stamp_ns(msg) + off_ms * NS // 1000)
        if t == "/imu/data":
            return rx + round((0.001 + 0.0005 * rng.random()) * NS)
        return rx + _latency_ns(rng) if t == "/dvl/data" else rx
    m, warned = _load(_rewritten(clean_path, tmp_path / f"step{stream}{off_ms}", change))
    n = getattr(clean, stream).t.size
    np.testing.assert_allclose(getattr(m, stream).t, getattr(clean, stream).t, atol=2e-9)
    reason = bag_stamps.HEADER_CLOCK_STEP if off_ms > 0 else bag_stamps.HEADER_CLOCK_STEP_BACK
    assert m.meta["streams"][stream]["doubted"] == {reason: n - at}
    said = [w for w in warned if f"message {at}, field 'header.stamp': the header clock steps" in w]
    way = ("forward", "back") if off_ms > 0 else ("back", "forward")
    assert len(said) == 1 and f"the header clock steps {way[0]} (" in said[0] and said[0].endswith(
        f"the stamps from this message on are moved {way[1]} by {abs(off_ms) / 1000:.3f} s onto the clock before the "
        "step"), said


def test_a_topics_exact_copies_are_looked_for_once_beside_an_imus_filler(sim, tmp_path, monkeypatch):
    """The IMU's messages 700-709 written whole as zeros, their stamps too (a logger's filler): the messages published
    twice were looked for on the IMU's other messages to judge their stamps, then again on the same messages to drop
    them. Once now, the filler refused as before."""
    _, clean_path, _ = sim
    calls = []
    copies = bag_convert._copies
    monkeypatch.setattr(bag_convert, "_copies", lambda stream, *a: calls.append(stream) or copies(stream, *a))

    def change(t, k, msg, rx):
        if t == "/imu/data" and 700 <= k < 710:
            _set_stamp(msg, 0)
            for v in (msg.linear_acceleration, msg.angular_velocity):
                v.x = v.y = v.z = 0.0
        return rx
    m, _ = _load(_rewritten(clean_path, tmp_path / "filler", change))
    assert m.meta["streams"]["imu"]["refused"] == {
        "all-zero IMU row (a logger's filler: zero specific force is impossible under gravity)": 10}
    assert calls.count("imu") == 1, calls


def _dvl_pinging_every(period_s, header_s, latency_s, every=1):
    """A change (:func:`_rewritten`) of the DVL's messages: every ``every``-th kept, its ping at ``period_s`` (s) steps
    on the IMU's clock (a DVL triggered by the vehicle), stamped ``header_s(t)`` and received ``latency_s(t)`` s after
    its time ``t`` (s into the bag); the others left out."""
    n = {"k": 0}

    def change(t, k, msg, rx):
        if t != "/dvl/data":
            return rx
        if k % every:
            return None
        at = 0.5 + n["k"] * period_s
        n["k"] += 1
        _set_stamp(msg, T0_NS + round(header_s(at) * NS))
        return T0_NS + round((at + latency_s(at)) * NS)
    return change


@pytest.mark.parametrize("period_s, every", [(3.0, 3), (0.6, 1)])
def test_a_dvl_clock_running_slow_at_a_round_ping_period_is_taken_out(tmp_path, period_s, every):
    """A DVL triggered every 3 s (every 0.6 s: periods a DVL is set to, rates of 0.333 Hz and 1.667 Hz) whose clock
    runs 1 % slow, its pings received 0.25-0.35 s after their time. Neither rate is round, so the drift was said not
    to be told from a queue filling and kept: the last ping 1.5 s (0.9 s) early. A round period shows the clock that
    keeps the pings' schedule as well as a round rate: the drift is taken out again, every ping within 0.02 s."""
    clean_path = bags.write_mission_bag(simulate_mission(duration_s=150.0, seed=5), tmp_path / "clean",
                                        t0_unix_ns=T0_NS)
    rng = np.random.default_rng(8)
    right, _ = _load(_rewritten(clean_path, tmp_path / "right",
                                _dvl_pinging_every(period_s, lambda t: t, lambda t: 0.3, every)))
    m, warned = _load(_rewritten(clean_path, tmp_path / "slow", _dvl_pinging_every(
        period_s, lambda t: 0.5 + (t - 0.5) * 0.99, lambda t: 0.25 + 0.1 * rng.random(), every)))
    assert np.abs(m.dvl.t - right.dvl.t).max() < 0.02
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_DRIFT: right.dvl.t.size}


def test_a_dvl_drift_not_told_from_a_queue_filling_is_counted_as_such(sim, tmp_path):
    """The DVL pinging every 0.7 s (1.43 Hz: neither a round rate nor a round period), received 0.05 s after its time
    at the start and 0.35 s at the end. Which clock keeps the schedule cannot be told: the header stamps are kept as
    before, but were counted as kept for a latency "too spread to tell" (0.000 s spread about the line). Now counted
    as not told from the recorder's latency growing."""
    _, clean_path, _ = sim
    m, warned = _load(_rewritten(clean_path, tmp_path / "queue07", _dvl_pinging_every(
        0.7, lambda t: t, lambda t: 0.05 + 0.3 * t / 21.0)))
    n = m.dvl.t.size
    np.testing.assert_allclose(m.dvl.t - m.dvl.t[0], 0.7 * np.arange(n), atol=2e-9)
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_stamps.HEADER_CLOCK_DRIFT_NOT_TOLD: n}
    said = [w for w in warned if "/dvl/data, field 'header.stamp'" in w]
    assert len(said) == 1 and said[0].endswith("cannot be told from the recorder's latency growing: the header "
                                               "stamps are kept"), said
