"""The IMU-aware completer wired into the estimators: the keyframer's streaming IMU window, the beam-only
fallback and its counters, the routing of :class:`graphnav.nets.ImuAutoCompleter`, the registry's methods."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry, make_beams
from graphnav.core.errors import ConfigError
from graphnav.core.mission import ImuData
from graphnav.core.scenarios import scenario_outage
from graphnav.estimators.imu_buffer import ImuWindowBuffer
from graphnav.estimators.keyframes import Keyframer
from graphnav.estimators.replay import replay
from graphnav.nets import AverageCompleter
from graphnav.nets.imu_window import imu_window_at
from graphnav.sim.simulate import simulate_mission

GAP = (30.0, 30.5)        # IMU samples strictly inside are dropped


class SpyImuCompleter:
    """Stands in for an IMU-aware completer: records the window it is given, completes beam-only."""

    needs_imu = True
    imu_samples = 2000
    imu_rate_hz = 100.0

    def __init__(self):
        self.beam_only = AverageCompleter(3)
        self.n_past = 3
        self.windows = []

    def complete(self, past, measured, imu=None):
        self.windows.append(imu)
        return self.beam_only.complete(past, measured)


@pytest.fixture(scope="module")
def gapped_mission():
    """60 s simulated mission, 2 beams missing from 6 s on (after the 5 full pings a history needs), the IMU
    silent over GAP."""
    m = simulate_mission(60.0, "navigation", 1)
    keep = ~((m.imu.t > GAP[0]) & (m.imu.t < GAP[1]))
    imu = ImuData(m.imu.t[keep], m.imu.f_b[keep], m.imu.omega_b[keep])
    return dataclasses.replace(m, imu=imu).with_outage(scenario_outage("2-missing", 6.0, 53.0))


def test_window_buffer_serves_a_shorter_window_and_refuses_a_longer_one():
    buf = ImuWindowBuffer(200, 100.0)
    for k in range(260):
        buf.push(0.01 * k, (k, 0.0, 9.8), (0.0, 0.0, -k))
    (f_b, _), reason = buf.window(2.305, 60)                     # samples 171..230, the last 60 of the full window
    assert reason is None and f_b.shape == (60, 3) and f_b[0, 0] == 171 and f_b[-1, 0] == 230
    assert buf.window(0.7, 60)[1] is None and buf.window(0.7)[1] == "not_full"     # 71 samples so far
    for n in (1, 201):
        with pytest.raises(ConfigError, match="samples"):
            buf.window(2.305, n)


def test_keyframer_refuses_a_member_window_longer_than_the_completers(gapped_mission):
    spy = SpyMemberCompleter()
    spy.member_imu_samples = 2400
    with pytest.raises(ConfigError, match="member_imu_samples = 2400"):
        Keyframer(gapped_mission.config, completer=spy)


def test_window_buffer_reasons():
    buf = ImuWindowBuffer(200, 100.0)
    for k in range(199):
        buf.push(0.01 * k, (k, 0.0, 9.8), (0.0, 0.0, -k))
    assert buf.window(5.0) == (None, "not_full")
    for k in range(199, 260):
        buf.push(0.01 * k, (k, 0.0, 9.8), (0.0, 0.0, -k))
    (f_b, omega_b), reason = buf.window(2.305)                    # samples 31..230: later ones are left out
    assert reason is None and f_b.shape == omega_b.shape == (200, 3)
    assert f_b[0, 0] == 31 and f_b[-1, 0] == 230 and omega_b[-1, 2] == -230

    slow = ImuWindowBuffer(200, 100.0)                            # a 95 Hz IMU for a 100 Hz completer
    for k in range(300):
        slow.push(k / 95.0, (0.0, 0.0, 9.8), (0.0, 0.0, 0.0))
    assert slow.window(3.0) == (None, "rate")
    half = ImuWindowBuffer(200, 100.0)                            # 50 Hz: every step is 2 periods, a rate
    for k in range(300):
        half.push(k / 50.0, (0.0, 0.0, 9.8), (0.0, 0.0, 0.0))
    assert half.window(5.9) == (None, "rate")
    late = ImuWindowBuffer(200, 100.0, extra_s=1.0)               # keeps 300 samples: 2.0 s is long gone
    for k in range(1000):
        late.push(0.01 * k, (0.0, 0.0, 9.8), (0.0, 0.0, 0.0))
    assert late.window(2.0) == (None, "late") and late.window(9.99)[1] is None

    dropped = ImuWindowBuffer(200, 100.0)                         # one sample missing: a 2-period step
    for k in range(300):
        if k != 250:
            dropped.push(0.01 * k, (0.0, 0.0, 9.8), (0.0, 0.0, 0.0))
    assert dropped.window(2.6) == (None, "gap")
    assert dropped.window(2.49)[1] is None                        # before the dropped sample: a clean window

    bridged = ImuWindowBuffer(200, 100.0)
    for k in range(340):
        bridged.push(0.01 * k, (0.0, 0.0, 9.8), (0.0, 0.0, 0.0), bridged=(k == 120))
    assert bridged.window(2.9) == (None, "gap") and bridged.window(3.3)[1] is None    # 3.3: samples 131..330


def without_ping(mission, t: float):
    """(``mission`` with the DVL ping nearest ``t`` (s) left out, that ping's stamp): a missed ping."""
    m = mission
    drop = int(np.argmin(np.abs(m.dvl.t - t)))
    keep = np.arange(len(m.dvl.t)) != drop
    dvl = dataclasses.replace(m.dvl, t=m.dvl.t[keep], beams=m.dvl.beams[keep], valid=m.dvl.valid[keep],
                              v_b=None if m.dvl.v_b is None else m.dvl.v_b[keep])
    return dataclasses.replace(m, dvl=dvl), float(m.dvl.t[drop])


def run_keyframer(mission, completer, gap: bool = True):
    """(the keyframer, its keyframes) after replaying ``mission`` without depth through a keyframer with
    ``completer``; with ``gap`` the mission's bridged IMU gap warns."""
    import contextlib
    kfr = Keyframer(mission.config, completer=completer)
    kfr.start(float(mission.imu.t[0]))
    keyframes = []
    with pytest.warns(RuntimeWarning, match="gap") if gap else contextlib.nullcontext():
        for kind, t, payload in replay(mission, depth=False):
            keyframes += getattr(kfr, "add_" + kind)(t, *payload)
        keyframes += kfr.finish()
    return kfr, keyframes


def test_keyframer_streams_exactly_the_last_imu_window_and_counts_the_fallbacks(gapped_mission):
    m = gapped_mission
    spy = SpyImuCompleter()
    kfr, keyframes = run_keyframer(m, spy)
    completed = [kf.ping.t for kf in keyframes if kf.ping is not None and kf.ping.has_regressed]
    assert len(completed) == len(spy.windows) > 40
    expected = {"not_full": 0, "rate": 0, "gap": 0, "late": 0, "ping_dt": 0}
    n_used = 0
    for t, got in zip(completed, spy.windows):
        want = imu_window_at(m.imu, t, 2000)
        if want is None:
            expected["not_full"] += 1
            assert got is None
        elif t > GAP[0] and t - 2000 * 0.01 < GAP[1]:             # the window reaches into the bridged gap
            expected["gap"] += 1
            assert got is None
        else:
            n_used += 1
            assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1]), t
    assert kfr.stats.imu_window_missing == expected
    assert expected["not_full"] >= 10 and expected["gap"] >= 15 and n_used >= 15
    assert kfr.stats.regressed_pings == len(completed) and kfr.stats.regressed_beams == 2 * len(completed)


def test_keyframer_withholds_the_window_when_a_ping_is_missing(gapped_mission):
    """The completer propagates each past ping over exactly ping_dt: after a missed ping its lags are wrong,
    so the keyframer hands no window (reason "ping_dt") until the history is one period apart again."""
    spy = SpyImuCompleter()
    spy.ping_dt = 1.0
    kfr, _ = run_keyframer(without_ping(gapped_mission, 54.0)[0], spy)     # well after the IMU gap's 20 s shadow
    assert kfr.stats.imu_window_missing["ping_dt"] == spy.n_past       # the 3 pings whose history spans it
    assert spy.windows[-1] is not None                                 # one period apart again


class SpyMemberCompleter(SpyImuCompleter):
    """The spy with a member that needs the IMU itself and reads a 6 s window of its own (as the pivot completer
    inside :class:`graphnav.nets.ImuAutoCompleter`), and learns from the fully measured pings."""

    member_imu_samples = 600
    observe_imu_samples = 600

    def __init__(self):
        super().__init__()
        self.observed = []

    def observe(self, t, beams, imu=None):
        self.observed.append((t, imu))


def test_keyframer_hands_the_members_their_own_shorter_window_where_the_networks_have_none(gapped_mission):
    """Where the networks' 20 s window is missing (the mission's first 20 s, a bridged IMU gap in it) a completer
    whose members read a shorter window is handed that one, exactly the last samples, where it is clean; the
    counters still say where the networks had none. Its learning members see every fully measured ping with their
    own window, not only those with 20 s behind them."""
    m = gapped_mission
    spy = SpyMemberCompleter()
    kfr, keyframes = run_keyframer(m, spy)
    completed = [kf.ping.t for kf in keyframes if kf.ping is not None and kf.ping.has_regressed]
    assert len(completed) == len(spy.windows)
    routes = {"networks": 0, "member": 0, "none": 0}
    for t, got in zip(completed, spy.windows):
        clean = {n: imu_window_at(m.imu, t, n) is not None and not (t > GAP[0] and t - n * 0.01 < GAP[1])
                 for n in (2000, 600)}
        n = 2000 if clean[2000] else 600 if clean[600] else None
        if n is None:
            routes["none"] += 1
            assert got is None, t
            continue
        routes["networks" if n == 2000 else "member"] += 1
        want = imu_window_at(m.imu, t, n)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1]), t
    assert routes["member"] >= 15 and routes["networks"] >= 15 and routes["none"] >= 5
    missing = kfr.stats.imu_window_missing
    assert missing["not_full"] >= 10 and missing["gap"] >= 15
    assert sum(missing.values()) == len(completed) - routes["networks"]

    # a missed ping inside the first 20 s: the member's window is withheld too while the history spans it (its
    # rates per ping would be cut wrongly), counted under the networks' own reason
    dropped, t_drop = without_ping(m, 12.0)
    spy = SpyMemberCompleter()
    spy.ping_dt = 1.0
    kfr, keyframes = run_keyframer(dropped, spy)
    completed = [kf.ping.t for kf in keyframes if kf.ping is not None and kf.ping.has_regressed]
    after = [got for t, got in zip(completed, spy.windows) if t_drop < t < 20.0]
    assert [got is None for got in after[:spy.n_past + 1]] == [True] * spy.n_past + [False]
    assert kfr.stats.imu_window_missing["ping_dt"] == 0          # the networks had no window there anyway

    straight = simulate_mission(30.0, "navigation", 2)           # every ping fully measured, no IMU gap
    spy = SpyMemberCompleter()
    run_keyframer(straight, spy, gap=False)
    seen = [t for t, imu in spy.observed if imu is not None]
    assert all(len(imu[1]) == 600 for _, imu in spy.observed if imu is not None)
    assert len(seen) == sum(imu_window_at(straight.imu, t, 600) is not None for t, _ in spy.observed)
    assert len(seen) > sum(imu_window_at(straight.imu, t, 2000) is not None for t, _ in spy.observed) + 10


def test_keyframer_refuses_an_imu_completer_without_a_beam_only_fallback(gapped_mission):
    spy = SpyImuCompleter()
    spy.beam_only = None
    with pytest.raises(ConfigError, match="ImuAutoCompleter"):
        Keyframer(gapped_mission.config, completer=spy)


def test_imu_auto_completer_routes_and_counts():
    from graphnav.nets import ImuAutoCompleter, load_imu_completer
    nets = [load_imu_completer(2), load_imu_completer(3)]
    auto = ImuAutoCompleter(nets, AverageCompleter(3))
    assert auto.n_past == 5 and auto.imu_samples == 2000 and auto.needs_imu
    rng = np.random.default_rng(0)
    past = 1.0 + 0.01 * rng.standard_normal((5, 4))
    imu = (np.tile([0.0, 0.0, -9.8], (2000, 1)), np.zeros((2000, 3)))
    two = np.array([np.nan, 1.0, np.nan, 1.0])
    full, sigma = auto.complete(past, two, imu=imu)
    np.testing.assert_array_equal(full, nets[0].complete(past, two, imu=imu)[0])
    beam_only = auto.complete(past, two)                          # no window: the average over its 3 pings
    np.testing.assert_array_equal(beam_only[0], AverageCompleter(3).complete(past[-3:], two)[0])
    auto.complete(past, np.full(4, np.nan), imu=imu)              # no beam measured: beam-only
    auto.complete(past, np.ones(4), imu=imu)                      # nothing to complete: not counted
    assert auto.usage == {"imu": 1, "no_imu": 1, "pattern": 1}
    with pytest.raises(ConfigError):
        ImuAutoCompleter(nets, nets[0])


def test_imu_auto_completer_fuses_with_the_beam_only_completion():
    """With beam_correlation the IMU-aware completion is fused with the beam-only one of the same ping (inverse
    variance, sigma with the correlation); a ping without an IMU window is the beam-only one alone, not fused with
    itself. The shipped completer fuses with the measured correlations; fused=False is the network alone."""
    from graphnav.nets import ImuAutoCompleter, load_completer, load_imu_auto_completer, load_imu_completer
    from graphnav.nets.fused import fuse
    from graphnav.nets.imu_auto import IMU_BEAM_ERROR_CORRELATION
    net, beam = load_imu_completer(2), load_completer(2)
    auto = ImuAutoCompleter([net], beam, {"2-missing": 0.8})
    rng = np.random.default_rng(0)
    past = make_beams(np.array([1.5, 0.1, 0.05]) + 0.05 * rng.standard_normal((5, 3)), DvlSpec(), 4)
    imu = (np.tile([0.0, 0.0, -9.8], (2000, 1)), np.zeros((2000, 3)))
    two = past[-1] + 0.01
    two[[0, 2]] = np.nan
    b_imu, s_imu = net.complete(past, two, imu=imu)
    b_beam, s_beam = beam.complete(past[-3:], two)
    assert not np.allclose(b_imu, b_beam)
    full, sigma = auto.complete(past, two, imu=imu)
    expect = fuse(b_imu, s_imu, b_beam, s_beam, 0.0, 0.8)
    np.testing.assert_array_equal(full, expect[0])
    np.testing.assert_array_equal(sigma, expect[1])
    assert np.all(sigma[[0, 2]] > fuse(b_imu, s_imu, b_beam, s_beam)[1][[0, 2]])   # wider than if independent
    np.testing.assert_array_equal(auto.complete(past, two), (b_beam, s_beam))     # no window: beam-only alone
    assert auto.usage == {"imu": 1, "no_imu": 1, "pattern": 0}
    assert load_imu_auto_completer().beam_correlation == IMU_BEAM_ERROR_CORRELATION
    assert load_imu_auto_completer(fused=False).beam_correlation == {}
    with pytest.raises(ConfigError, match="3-missing"):
        ImuAutoCompleter([net], beam, {"3-missing": 0.7})
    with pytest.raises(ConfigError, match="not in"):
        ImuAutoCompleter([net], beam, {"2-missing": 1.0})


def test_the_fused_members_fade_as_chosen_for_the_fusion_and_a_ping_without_imu_as_the_beam_only_card_says():
    """Fused, the IMU-aware networks and the beam-only member fade with FUSED_RUN_DECAY; the pings without an IMU
    window go to the beam-only completer with its own card's run_decay; the fallbacks of both beam-only completers
    are counted."""
    from graphnav.nets import ImuAutoCompleter, load_completer, load_imu_auto_completer, load_imu_completer
    from graphnav.nets.fused import fuse
    from graphnav.nets.imu_auto import FUSED_RUN_DECAY
    shipped = load_imu_auto_completer()
    for m in (2, 3):
        name, pattern = f"{m}-missing", tuple(load_completer(m).missing)
        assert shipped.networks[pattern].run_decay == FUSED_RUN_DECAY[name]["IMU-aware"]
        assert shipped.fused_beam_only.networks[pattern].run_decay == FUSED_RUN_DECAY[name]["beam-only"]
        assert shipped.beam_only.networks[pattern].run_decay == load_completer(m).run_decay
    assert (load_imu_auto_completer(fused=False).networks[tuple(load_completer(2).missing)].run_decay
            == load_imu_completer(2).run_decay)
    # a fused member that fades otherwise than the no-IMU route: each route takes its own
    net, slow, fast = load_imu_completer(2, run_decay=0.98), load_completer(2, run_decay=1.0), load_completer(2, run_decay=0.5)
    auto = ImuAutoCompleter([net], fast, {"2-missing": 0.8}, fused_beam_only=slow)
    assert auto.takes_run_steps and auto.n_past == 5
    rng = np.random.default_rng(1)
    past = make_beams(np.array([1.5, 0.1, 0.05]) + 0.05 * rng.standard_normal((5, 3)), DvlSpec(), 4)
    imu = (np.tile([0.0, 0.0, -9.8], (2000, 1)), np.zeros((2000, 3)))
    two = past[-1] + 0.01
    two[[0, 2]] = np.nan
    steps = np.array([6, 0, 6, 0])
    b_imu, s_imu = net.complete(past, two, imu=imu, run_steps=steps)
    b_slow, s_slow = slow.complete(past[-3:], two, run_steps=steps)
    assert not np.allclose(b_slow, fast.complete(past[-3:], two, run_steps=steps)[0])
    expect = fuse(b_imu, s_imu, b_slow, s_slow, 0.0, 0.8)
    np.testing.assert_array_equal(auto.complete(past, two, imu=imu, run_steps=steps)[0], expect[0])
    np.testing.assert_array_equal(auto.complete(past, two, run_steps=steps)[0],
                                  fast.complete(past[-3:], two, run_steps=steps)[0])
    fast.fallbacks["envelope"], slow.fallbacks["envelope"] = 2, 3
    assert auto.fallbacks["envelope"] == 5 + net.fallbacks["envelope"]
    # one completer serving both routes is counted once
    assert ImuAutoCompleter([net], fast).fallbacks["envelope"] == 2 + net.fallbacks["envelope"]
    with pytest.raises(ConfigError, match="fused_beam_only"):
        ImuAutoCompleter([net], fast, fused_beam_only=net)
    # a beam-only completer of the caller's is not fused with the shipped weights unasked
    with pytest.raises(ConfigError, match="give fused_beam_only too"):
        load_imu_auto_completer(beam_only=fast)
    mine = load_imu_auto_completer(beam_only=fast, fused_beam_only=slow)
    assert mine.beam_only is fast and mine.fused_beam_only is slow


def test_the_shipped_pairing_built_from_one_folder_per_pattern_serves_those_patterns_only(tmp_path):
    """Out-of-fold networks live one pattern to a folder: ``load_imu_auto_completer`` given a folder per pattern and
    ``patterns`` builds the shipped pairing (the fused fading and correlation) from them, for those patterns only;
    a pattern it has no setting or no folder for is refused, naming it."""
    import shutil

    from graphnav.nets import load_completer, load_fused_beam_only, load_imu_auto_completer, load_imu_completer
    from graphnav.nets.imu_auto import FUSED_RUN_DECAY, IMU_BEAM_ERROR_CORRELATION
    from graphnav.nets.imu_network import imu_weights_name
    from graphnav.nets.storage import weights_dir
    folder = tmp_path / "fold0"
    folder.mkdir()
    for suffix in (".pt", ".json"):
        shutil.copy(weights_dir() / f"{imu_weights_name('3-missing')}{suffix}", folder)
    beam = load_completer("auto")
    pair = load_imu_auto_completer({"3-missing": folder}, beam, fused_beam_only=load_fused_beam_only(),
                                   patterns=("3-missing",))
    three = tuple(load_completer(3).missing)
    assert list(pair.networks) == [three]
    assert pair.beam_correlation == {"3-missing": IMU_BEAM_ERROR_CORRELATION["3-missing"]}
    assert pair.networks[three].run_decay == FUSED_RUN_DECAY["3-missing"]["IMU-aware"]
    # not fused, the folder's network keeps its card's fading
    plain = load_imu_auto_completer({"3-missing": folder}, beam, fused=False, patterns=("3-missing",))
    assert plain.beam_correlation == {}
    fading = plain.networks[three].run_decay
    assert fading == load_imu_completer(3).run_decay != FUSED_RUN_DECAY["3-missing"]["IMU-aware"]
    with pytest.raises(ConfigError, match="the patterns are \\['2-missing', '3-missing'\\]"):
        load_imu_auto_completer({"3-missing": folder}, beam, fused_beam_only=beam)
    with pytest.raises(ConfigError, match="no fusion was chosen for \\['0-beams'\\]"):
        load_imu_auto_completer(patterns=("0-beams",))
    # the folder's network is the one loaded: without its files the folder is named
    for fused in (True, False):
        with pytest.raises(ConfigError, match="fold1"):
            load_imu_auto_completer({"3-missing": tmp_path / "fold1"}, beam, fused=fused, fused_beam_only=beam,
                                    patterns=("3-missing",))


def test_the_imu_aware_completion_fuses_with_the_pivot_completer_which_reads_the_tail_of_the_window():
    """A fused member that needs the IMU itself (the pivot completer) is handed the networks' 20 s window and reads
    its own last samples: the fused completion is the networks' and the pivot's on the exact window, fused; the
    keyframer's fully measured pings reach its online fit through the wrapper; a ping without a window is the pivot's
    average; a member that cannot complete without a window, or wants a longer one, is refused."""
    from graphnav.nets import ImuAutoCompleter, load_imu_completer
    from graphnav.nets.fused import fuse
    from graphnav.nets.pivot import PivotCompleter
    geometry = DvlGeometry.from_spec(DvlSpec())
    net = load_imu_completer(2, run_decay=1.0)
    pivot = PivotCompleter(geometry.T_b, geometry.lever_arm_b, 3.6, n_past=3)
    auto = ImuAutoCompleter([net], pivot, {"2-missing": 0.7})
    assert auto.n_past == net.n_past and pivot.imu_samples < net.imu_samples
    rng = np.random.default_rng(2)
    past = make_beams(np.array([1.5, 0.1, 0.05]) + 0.05 * rng.standard_normal((5, 3)), DvlSpec(), 4)
    omega = np.zeros((net.imu_samples, 3))
    omega[-pivot.imu_samples:, 2] = np.repeat(np.linspace(0.0, 0.2, 4), pivot.samples_per_ping)   # a turn starting
    imu = (np.tile([0.0, 0.0, -9.8], (net.imu_samples, 1)), omega)
    tail = (imu[0][-pivot.imu_samples:], imu[1][-pivot.imu_samples:])
    two = past[-1] + 0.01
    two[[0, 2]] = np.nan
    b_piv, s_piv = pivot.complete(past[-3:], two, imu=tail)
    assert not np.allclose(b_piv, AverageCompleter(3).complete(past[-3:], two)[0])    # the turn is in it
    expect = fuse(*net.complete(past, two, imu=imu), b_piv, s_piv, 0.0, 0.7)
    np.testing.assert_array_equal(auto.complete(past, two, imu=imu)[0], expect[0])
    np.testing.assert_array_equal(auto.complete(past, two)[0], AverageCompleter(3).complete(past[-3:], two)[0])
    assert pivot.usage["no_imu"] == 1
    full = make_beams(np.array([1.5, 0.1, 0.05]), DvlSpec(), 4)[0]
    for k in range(8):
        auto.observe(float(k), full, imu)
    assert pivot.fit.pairs > 0
    # where the networks have no window the keyframer hands the member's own shorter one: the pivot completes with it
    assert auto.member_imu_samples == auto.observe_imu_samples == pivot.imu_samples
    used = auto.usage["no_imu"]
    np.testing.assert_array_equal(auto.complete(past, two, imu=tail)[0], b_piv)
    assert auto.usage["no_imu"] == used + 1
    assert ImuAutoCompleter([net], AverageCompleter(3), {"2-missing": 0.7}).member_imu_samples is None
    assert not hasattr(ImuAutoCompleter([net], AverageCompleter(3), {"2-missing": 0.7}), "observe")  # nothing learns
    with pytest.raises(ConfigError, match="without a"):
        ImuAutoCompleter([net], net)
    with pytest.raises(ConfigError, match="IMU samples"):
        ImuAutoCompleter([net], PivotCompleter(geometry.T_b, geometry.lever_arm_b, 3.6, n_past=3, imu_rate_hz=1000.0))
    with pytest.raises(ConfigError, match="s apart"):       # pings 2 s apart: its rates would be cut otherwise
        ImuAutoCompleter([net], PivotCompleter(geometry.T_b, geometry.lever_arm_b, 3.6, n_past=3, ping_dt=2.0))


def test_auto_beam_completer_takes_a_run_decay_per_scenario():
    from graphnav.nets import load_completer
    auto = load_completer("auto", run_decay={"2-missing": 0.97})
    assert auto.networks[tuple(load_completer(2).missing)].run_decay == 0.97
    assert auto.networks[tuple(load_completer(3).missing)].run_decay == load_completer(3).run_decay
    with pytest.raises(ConfigError, match="4-missing"):
        load_completer("auto", run_decay={"4-missing": 0.9})
    with pytest.raises(ConfigError, match="for missing='auto'"):
        load_completer(2, run_decay={"2-missing": 0.9})


def test_imu_auto_completer_sigma_grows_by_its_own_drift_through_an_outage():
    """The history grows a completer's sigma through a run of regressed pings by the completer's drift_std; None
    (the shipped completer's) leaves the history's 0.03. A growth that is negative, NaN or not a number is
    refused."""
    from graphnav.estimators.history import BeamHistory
    from graphnav.nets import ImuAutoCompleter, load_completer, load_imu_auto_completer, load_imu_completer
    net, beam = load_imu_completer(2), load_completer(2)
    rng = np.random.default_rng(1)
    past = make_beams(np.array([1.5, 0.1, 0.05]) + 0.05 * rng.standard_normal((5, 3)), DvlSpec(), 4)
    imu = (np.tile([0.0, 0.0, -9.8], (2000, 1)), np.zeros((2000, 3)))
    two = past[-1] + 0.01
    two[[0, 2]] = np.nan
    valid = np.isfinite(two)

    def run(completer, pings=4):
        history = BeamHistory(completer.n_past)
        for row in past:
            history.push(row)
        handed, own = [], []
        for k in range(pings):     # run steps: the pings each missing beam was regressed before this one
            own.append(completer.complete(history.past(), two, imu=imu, run_steps=np.where(valid, 0, k))[1][[0, 2]])
            handed.append(history.complete(completer, two, valid, imu=imu)[1][[0, 2]])
        return np.array(handed), np.array(own)
    for drift, expected in ((0.004, 0.004), (0.0, 0.0), (None, 0.03)):
        handed, own = run(ImuAutoCompleter([net], beam, {"2-missing": 0.8}, drift_std=drift))
        np.testing.assert_allclose(handed[0], own[0])
        for k in range(1, len(handed)):
            np.testing.assert_allclose(handed[k], np.sqrt(np.maximum(own[k], handed[k - 1]) ** 2 + expected ** 2))
    assert load_imu_auto_completer().drift_std is None and load_imu_auto_completer(fused=False).drift_std is None
    for bad in (-0.01, float("nan"), True, "0.01"):
        with pytest.raises(ConfigError, match="drift_std"):
            ImuAutoCompleter([net], beam, drift_std=bad)


@pytest.mark.parametrize("method", ["HNTC-IMU", "Graph-HNI"])
def test_methods_report_where_the_imu_window_was_used(gapped_mission, method):
    from graphnav.evaluation.methods import get_method, run_method
    assert get_method(method).completer == "imu-network"
    with pytest.warns(RuntimeWarning, match="gap"):
        sol = run_method(gapped_mission, method, "2-missing")
    info = sol.info
    usage, missing = info["completer_usage"], info["imu_window_missing"]
    assert info["completer"].startswith("imu-network")
    assert usage["pattern"] == 0 and usage["no_imu"] == sum(missing.values()) and usage["imu"] >= 15
    assert usage["imu"] + usage["no_imu"] == info["regressed_pings"]
    assert missing["not_full"] >= 10 and missing["gap"] >= 15 and missing["rate"] == missing["ping_dt"] == 0
    assert np.all(np.isfinite(sol.v_n))


def test_graph_hni_takes_its_completions_out_when_the_measured_beams_return():
    """Every regressed beam Graph-HNI let into the graph through a 3-missing outage that the measured beams end (a
    run screened once, its later completions entering as correlated differences) leaves the graph at their return,
    and the batch variant then smooths the mission to Graph-TC-batch's estimate, where keeping them does not. On the
    simulated vehicle the screening's correlation takes every completion out before it enters (the graph's own
    prediction already holds what they know), so the test screens them as independent of it."""
    from graphnav.evaluation.methods import run_method
    mission = simulate_mission(90.0, "navigation", 2).with_outage(scenario_outage("3-missing", 50.0, 20.0))
    independent = {"screening.correlation": 0.0}
    sol = run_method(mission, "Graph-HNI", "3-missing", options=independent)
    assert sol.info["completer_usage"]["imu"] == 20
    screening = sol.info["regressed_screening"]
    assert screening["continued"] > 0 and sol.info["completions_retired"] == screening["entered"] > 0
    tc = run_method(mission, "Graph-TC-batch")
    batch = run_method(mission, "Graph-HNI-batch", "3-missing", options=independent)
    assert batch.info["completions_retired"] == screening["entered"]
    np.testing.assert_allclose(batch.v_n, tc.v_n, atol=1e-4)
    kept = run_method(mission, "Graph-HNI-batch", "3-missing", options={**independent, "retire_completions": False})
    assert np.abs(kept.v_n - tc.v_n).max() > 1e-3


def test_fused_imu_completer_runs_in_the_keyframer_with_its_run_lengths(gapped_mission):
    """A FusedCompleter whose IMU-aware member is an ImuAutoCompleter passes the keyframer's check (it inherits
    the member's beam-only route) and, with growth, is handed each beam's run length by the history at every
    regressed ping. With a bare IMU network it is refused."""
    from graphnav.nets import FusedCompleter, ImuAutoCompleter, load_imu_completer
    m = gapped_mission
    auto = ImuAutoCompleter([load_imu_completer(2)], AverageCompleter(3))
    fused = FusedCompleter(auto, AverageCompleter(3), rho=0.5, growth=(0.02, 0.01))
    assert fused.beam_only is auto.beam_only and fused.imu_rate_hz == auto.imu_rate_hz
    seen = []
    orig = fused.complete

    def spy(past, measured, imu=None, run_steps=None, past_dt_s=None):
        seen.append(run_steps)
        assert np.allclose(past_dt_s, 1.0)                       # the pings' stamps are handed on: 1 Hz
        return orig(past, measured, imu=imu, run_steps=run_steps, past_dt_s=past_dt_s)
    fused.complete = spy
    run_keyframer(m, fused)
    assert len(seen) > 40 and all(s is not None for s in seen)
    assert max(int(s.max()) for s in seen) >= 5                 # runs of regressed pings are counted through
    assert fused.usage["imu"] > 0 and fused.usage["no_imu"] > 0
    with pytest.raises(ConfigError, match="ImuAutoCompleter"):
        Keyframer(m.config, completer=FusedCompleter(load_imu_completer(2), AverageCompleter(3)))
