"""The streaming Navigator: replay equality with the whole-mission estimators it replaced, reordering,
refusals, no look-ahead, IMU-rate state, aiding factors."""
from __future__ import annotations

import dataclasses
import math
import re
import warnings
from pathlib import Path

import gtsam
import numpy as np
import pytest
from graphnav.nets import AverageCompleter

from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import scenario_outage
from graphnav.estimators.ekf import EkfOptions
from graphnav.estimators.graph import GraphOptions, InitialState
from graphnav.estimators.navigator import Navigator, NavigatorOptions
from graphnav.estimators.replay import first_ping_time, replay
from graphnav.estimators.runs import run_ekf, run_graph
from graphnav.evaluation.methods import METHODS, run_method
from graphnav.evaluation.metrics import vrmse
from graphnav.sim.simulate import simulate_mission

REFERENCE = Path(__file__).parent / "data" / "replay_reference.npz"


@pytest.fixture(scope="module")
def mission():
    return simulate_mission(duration_s=200.0, seed=3)


@pytest.fixture(scope="module")
def reference():
    """Solutions of the whole-mission estimators before the Navigator (KeyframeBuilder with
    look-ahead keyframes, run_ekf over the whole IMU timeline), on the same simulated missions; refreshed by
    ``experiments/make_replay_reference.py`` after deliberate changes (one gyro-at-ping rule for every
    estimator, which moved the stored velocities by up to 3.5e-4 m/s; the Earth model, which moved them by up to
    1.3e-4 m/s and the positions by 1e-2 m: the simulator's gravity now depends on the position; the script
    prints the changes)."""
    return np.load(REFERENCE)


def _missions(m):
    gap = dataclasses.replace(m, dvl=m.dvl.take((m.dvl.t < 100.0) | (m.dvl.t > 109.5)))
    return {"clean": m, "outage": m.with_outage(scenario_outage("3-missing", 80.0, 30.0)), "gap": gap}


CASES = [("clean", "Graph-TC", "isam2", "3-missing"), ("clean", "Graph-TC", "fixed-lag", "3-missing"),
         ("outage", "Graph-HN", "isam2", "3-missing"), ("outage", "Graph-HN-batch", "fixed-lag", "3-missing"),
         ("clean", "TC", None, "3-missing"), ("outage", "LC", None, "3-missing"),
         ("outage", "HNTC", None, "3-missing"), ("gap", "Graph-TC", "isam2", "none"), ("gap", "TC", None, "none")]


@pytest.mark.parametrize("tag, method, backend, scenario", CASES)
def test_sample_by_sample_replay_reproduces_the_whole_mission_estimators(mission, reference, tag, method, backend,
                                                                        scenario):
    """Tolerance: the graph methods reproduce the old results to 1e-9 m/s and 1e-8 m (identical keyframes and
    factors);
    the EKF to 1e-5 m/s, 1e-4 m: IMU-only keyframes in a DVL gap split its prediction into more calls, and the
    strapdown's Coriolis approximation is per call (measured: 1.0e-6 m/s, 1.9e-5 m)."""
    m = _missions(mission)[tag]
    completer = AverageCompleter(5) if "HN" in method else None
    # the initial states the old estimators took from the GT (before GroundTruth.at replaced their
    # interpolations), so that the comparison isolates the streaming code path
    graph = method.startswith("Graph")
    a = reference[f"initial/{'graph' if graph else 'ekf'}/{'gap' if tag == 'gap' else 'clean'}"]
    initial = InitialState(gtsam.Pose3(gtsam.Rot3(a[1:10].reshape(3, 3)), a[13:16]), a[10:13], t=float(a[0]))
    if graph:
        sol = run_graph(m, completer=completer, batch=METHODS[method].batch, backend=backend, initial=initial)
    else:   # the stored EKF solutions are the paper's 12-state filter (no depth), whose results did not change
        sol = run_ekf(m, tight=METHODS[method].tight, completer=completer, initial=initial,
                      options=EkfOptions(position_states=False, dvl_error_states=False))
    key = f"{tag}/{method}/{backend}"
    np.testing.assert_array_equal(sol.t, reference[key + "/t"])
    # graph positions to 1e-8 m: on another CPU (the same GTSAM wheel) the stored graph positions differ by
    # 2.1-2.8e-9 m after 400 s (1e-11 relative), rounding of the vectorised linear algebra, not of our code
    v_tol, p_tol = (1e-9, 1e-8) if method.startswith("Graph") else (1e-5, 1e-4)
    np.testing.assert_allclose(sol.v_n, reference[key + "/v_n"], rtol=0, atol=v_tol)
    np.testing.assert_allclose(sol.p_n, reference[key + "/p_n"], rtol=0, atol=p_tol)
    if key + "/cov_v_n" in reference:
        np.testing.assert_allclose(sol.cov_v_n, reference[key + "/cov_v_n"], rtol=1e-6, atol=1e-10)


def _feed(nav, events):
    out = []
    for kind, t, payload in events:
        out += getattr(nav, "add_" + kind)(t, *payload)
    return out + nav.finish()


def _navigator(m, backend="fixed-lag", **kw):
    return Navigator(m.config, backend, initial=InitialState.from_ground_truth(m, first_ping_time(m)), **kw)


@pytest.mark.parametrize("backend", ["fixed-lag", "ekf"])
def test_dvl_late_within_the_reorder_window_changes_nothing(mission, backend):
    """The DVL reports each ping 0.15 s after its stamp (its processing time): with a 0.2 s window the
    estimates equal those of the time-ordered stream."""
    m = mission.slice(0, 60)
    events = list(replay(m))
    late = sorted(events, key=lambda e: e[1] + (0.15 if e[0] == "dvl" else 0.0))
    assert [e[0] for e in late] != [e[0] for e in events]
    a = _feed(_navigator(m, backend), events)
    b = _feed(_navigator(m, backend), late)
    assert len(a) == len(b) > 50
    for x, y in zip(a, b):
        assert x.t == y.t
        np.testing.assert_array_equal(x.v_n, y.v_n)


def test_bad_samples_are_refused_with_a_warning_and_change_nothing(mission):
    m = mission.slice(0, 40)
    events = list(replay(m))
    clean = _feed(_navigator(m), events)
    nav = _navigator(m)
    bad = list(events)
    i = next(k for k, e in enumerate(bad) if e[0] == "imu" and e[1] > 20.0)
    t_imu = bad[i][1]
    f_b, omega_b = bad[i][2]
    # a duplicate stamp with other values (one repeating every value is a row written again, refused as a copy)
    bad.insert(i + 1, ("imu", t_imu, (np.asarray(f_b) + 0.01, omega_b)))
    bad.insert(i + 2, ("imu", t_imu + 0.001, ([math.nan, 0, -9.8], [0, 0, 0])))    # non-finite value
    bad.insert(i + 300, ("dvl", t_imu - 0.5, ([0.1] * 4, [True] * 4)))             # 3 s late: too old
    bad.insert(i + 400, ("dvl", t_imu + 4.3, ([0.1, math.nan, 0.1, 0.1], [True] * 4)))  # NaN on a valid beam
    with pytest.warns(RuntimeWarning) as record:
        out = _feed(nav, bad)
    text = "\n".join(str(w.message) for w in record)
    assert "imu sample at t = %.6f s refused, field 't': duplicate stamp" % t_imu in text
    assert "field 'f_b'" in text and "field 'beams'" in text and "out of order" in text
    assert nav.info["n_refused"] == 4
    assert nav.info["refused"] == {"imu": {"t": 1, "f_b": 1}, "dvl": {"t": 1, "beams": 1}}
    assert [e.t for e in out] == [e.t for e in clean]
    for x, y in zip(out, clean):
        np.testing.assert_array_equal(x.v_n, y.v_n)


def test_no_look_ahead(mission):
    """Every estimate an add_* call returns is for a keyframe at or before that call's stamp, and DVL-gap
    keyframes are decided from the past only."""
    m = _missions(mission)["gap"].slice(0, 130)
    nav = _navigator(m, options=NavigatorOptions(reorder_window_s=0.0))
    for kind, t, payload in replay(m):
        for est in getattr(nav, "add_" + kind)(t, *payload):
            assert est.t <= t + 1e-12
    kinds = [(e.t, e.kind) for e in [nav.estimate()]]
    assert kinds


def test_state_at_propagates_the_latest_estimate_at_the_imu_rate():
    """On a noiseless mission the IMU-rate state between keyframes follows the truth (velocity 1e-3 m/s,
    attitude 1e-3 deg), and it meets the next keyframe's prediction."""
    m = simulate_mission(duration_s=40.0, seed=2, noiseless=True)
    nav = _navigator(m, "isam2", options=NavigatorOptions(reorder_window_s=0.0))
    traj = m.meta["trajectory"]
    checked = 0
    for kind, t, payload in replay(m):
        nav.add_imu(t, *payload) if kind == "imu" else getattr(nav, "add_" + kind)(t, *payload)
        if kind == "imu" and nav.initialised and t > 5.0 and round(t * 100) % 7 == 0:
            s = nav.state_at(t + 0.004)
            truth = traj.state(np.array([t + 0.004]))
            assert np.abs(s.v_n - truth.v_n[0]).max() < 1e-3
            err = gtsam.Rot3(truth.C_b_n[0]).between(gtsam.Rot3(s.C_b_n)).axisAngle()[1]
            assert np.degrees(abs(err)) < 1e-3
            checked += 1
    assert checked > 100
    with pytest.raises(Exception, match="before the latest estimate"):
        nav.state_at(nav.estimate().t - 1.0)


def test_heading_and_position_fix_constrain_the_graph(mission):
    """A heading sensor bounds the yaw error; a position fix pins the position (fixes every 10 s, 1 m)."""
    m = mission.slice(0, 120)
    gt = m.gt
    yaw = np.unwrap(np.arctan2(gt.C_b_n[:, 1, 0], gt.C_b_n[:, 0, 0]))
    rng = np.random.default_rng(0)
    origin = (math.radians(32.8), math.radians(34.9), 0.0)
    from graphnav.core.earth import ned_to_lla
    lla = ned_to_lla(gt.p_n, origin)
    initial = dataclasses.replace(InitialState.from_ground_truth(m, first_ping_time(m)), origin_lla=origin)
    # a 3 deg initial heading error that only the heading sensor can correct (the DVL barely sees yaw)
    pose = initial.pose
    initial = dataclasses.replace(initial, pose=gtsam.Pose3(gtsam.Rot3.Yaw(math.radians(3.0)).compose(pose.rotation()),
                                                              pose.translation() + np.array([20.0, -15.0, 0.0])),
                                  cov_pose=np.diag([1e-4, 1e-4, math.radians(5) ** 2, 30.0 ** 2, 30.0 ** 2, 1.0]))
    events = list(replay(m))
    aids = [("heading", float(t), (float(y + rng.normal(0, math.radians(0.5))), math.radians(0.5)))
            for t, y in zip(gt.t[::5], yaw[::5]) if t > 2.0]
    aids += [("position_fix", float(t), (float(p[0]), float(p[1]), 1.0)) for t, p in zip(gt.t[::100], lla[::100])
             if t > 2.0]
    events = sorted(events + aids, key=lambda e: (e[1], 0 if e[0] in ("heading", "position_fix") else 1))
    for backend in ("isam2", "ekf"):
        nav = Navigator(m.config, backend, initial=initial)
        out = _feed(nav, events)
        C = np.array([e.C_b_n for e in out])
        yaw_est = np.arctan2(C[:, 1, 0], C[:, 0, 0])
        yaw_gt = np.interp([e.t for e in out], gt.t, yaw)
        late = np.array([e.t for e in out]) > 60
        err = np.degrees(np.abs(np.remainder(yaw_est - yaw_gt + np.pi, 2 * np.pi) - np.pi))[late]
        assert err.max() < 1.0, (backend, err.max())
        assert nav.info["n_fixes"] >= 10
        # both correct the 20 m / 15 m initial offset from the fixes (the EKF's 15-state filter as updates)
        p = np.array([e.p_n for e in out])[late]
        p_gt = np.array([np.interp([e.t for e in out], gt.t, gt.p_n[:, i]) for i in range(3)]).T[late]
        assert np.abs(p[:, :2] - p_gt[:, :2]).max() < 3.0, backend
        if backend == "ekf":
            assert nav.backend.info["aiding"]["fix"]["used"] >= 10
            sigma = np.sqrt(np.array([np.diag(e.cov_p_n) for e in out])[late, :2])
            assert sigma.max() < 3.0 and sigma.min() > 0.1


def test_heading_factor_jacobian_matches_numerical():
    from graphnav.factors import heading_factor
    rng = np.random.default_rng(4)
    for _ in range(5):
        pose = gtsam.Pose3(gtsam.Rot3.Expmap(rng.normal(0, 0.6, 3)), rng.normal(0, 5, 3))
        f = heading_factor(gtsam.symbol("x", 0), 0.3, 0.01)
        values = gtsam.Values()
        values.insert(gtsam.symbol("x", 0), pose)
        H = f.linearize(values).jacobian()[0]
        eps = 1e-6
        num = np.zeros(6)
        for i in range(6):
            d = np.zeros(6)
            d[i] = eps
            vp, vm = gtsam.Values(), gtsam.Values()
            vp.insert(gtsam.symbol("x", 0), pose.retract(d))
            vm.insert(gtsam.symbol("x", 0), pose.retract(-d))
            num[i] = (f.unwhitenedError(vp)[0] - f.unwhitenedError(vm)[0]) / (2 * eps)
        np.testing.assert_allclose(H.reshape(-1) * 0.01, num, atol=1e-6)


# --- without ground truth ------------------------------------------------------------------------------
class _Tripwire:
    """Stands in for a mission's ground truth: any use of it fails the test."""

    def __getattr__(self, name):
        raise AssertionError(f"an estimator read the ground truth ('{name}')")


@pytest.mark.parametrize("method", ["Graph-TC", "TC"])
def test_estimators_started_from_the_sensors_never_read_the_ground_truth(method):
    m = simulate_mission(duration_s=200.0, seed=5)
    truth = m.gt
    object.__setattr__(m, "gt", _Tripwire())
    sol = run_graph(m, init="sensors") if method.startswith("Graph") else run_ekf(m, init="sensors")
    object.__setattr__(m, "gt", truth)
    assert sol.info["alignment"]["heading_source"] == "gyrocompass"
    assert sol.t[0] >= sol.info["alignment"]["t"] - 1e-9
    # started from the sensors, the estimate converges to the truth (navigation-grade IMU, all beams)
    assert vrmse(sol, truth, t_start=sol.t[0] + 30.0) < 0.1


def test_cli_pipes_a_simulated_stream_into_online(tmp_path):
    """`graphnav simulate --stream - | graphnav online --stream -`: estimates come back as JSON lines."""
    import json
    import subprocess
    import sys
    exe = Path(sys.executable).parent / "graphnav"
    cmd = (f"'{exe}' simulate --duration 200 --seed 4 --stream - | "
           f"'{exe}' online --stream - --out '{tmp_path / 'on'}' --no-plots")
    run = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    records = [json.loads(x) for x in run.stdout.splitlines()]
    lines = [r for r in records if r["type"] != "status"]
    assert len(lines) > 50 and all(r["type"] == "estimate" for r in lines)
    # while it aligned (gyrocompassing, 300 s of data needed from a 200 s stream) it said so; on a loaded machine
    # the simulator may start later than the first status is due, which then says it waits for data (a later status
    # may say so too, while the stream's end is awaited)
    leading = next(i for i, r in enumerate(records) if not (r["type"] == "status" and r["state"] == "waiting for data"))
    first = records[leading]
    assert leading <= 5 and first["type"] == "status" and first["state"] == "aligning"
    assert all(len(r["v_n"]) == 3 and len(r["cov_v_n"]) == 3 for r in lines)
    assert all(len(r["sigma_p_n"]) == 3 and len(r["sigma_rpy"]) == 3 and len(r["cov_bias"]) == 6 for r in lines)
    assert all(r["health"] in ("ok", "degraded", "diverged") for r in lines) and lines[-1]["health"] == "ok"
    summary = json.loads((tmp_path / "on" / "summary.json").read_text())
    assert summary["epochs"] == len(lines) and summary["stream"]["bad_lines"] == 0
    assert summary["initialisation"]["heading_source"] == "gyrocompass"
    assert "(fixed-lag)" in run.stderr


def test_fixed_lag_restart_from_the_joint_marginal_changes_nothing(mission):
    """The fixed-lag smoother is restarted every reanchor_interval_s (its cost grows over hours otherwise):
    from the joint marginal of the last state the estimates stay within 5e-4 m/s (about 1 % of the beam noise;
    measured 2.6e-4 just after a restart, where the window's older keyframes can no longer be relinearised) of
    an unrestarted run."""
    m = mission.slice(0, 120)
    a = run_graph(m, backend="fixed-lag", options=GraphOptions(reanchor_interval_s=None))
    b = run_graph(m, backend="fixed-lag", options=GraphOptions(reanchor_interval_s=20.0))
    assert b.info["reanchored"] == 6 and a.info["reanchored"] == 0      # at 20, 40, ..., 120 s
    np.testing.assert_allclose(b.v_n, a.v_n, atol=5e-4)
    np.testing.assert_allclose(b.cov_v_n, a.cov_v_n, rtol=0.05, atol=1e-7)   # diagonal ~4e-4..2e-3


@pytest.mark.parametrize("backend", ["fixed-lag", "ekf"])
def test_pure_inertial_warning_is_live_in_the_stream(mission, backend):
    """A 70 s total DVL outage: the Navigator warns from the add_* call at which the stretch passes
    max_pure_inertial_s (not after the run), once, counts it in info, and says when aiding resumes."""
    t_out = 60.0
    m = mission.slice(0, 150).with_outage(scenario_outage("0-beams", t_out, 70.0))
    nav = _navigator(m, backend)
    events, checked = [], False
    for kind, t, payload in replay(m):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            getattr(nav, "add_" + kind)(t, *payload)
        events += [(t, str(w.message)) for w in caught if "pure inertial" in str(w.message)]
        if t >= 100.0 and not checked:     # 40 s into the outage: coasting, but no warning yet
            assert nav.coasting.coasting_since is not None and not nav.info["pure_inertial_now"] and not events
            checked = True
    nav.finish()
    assert len(events) == 2, events
    (t_warn, first), (t_resume, second) = events
    # the last aided ping is at most 1 s before the outage; the warning comes with the first keyframe past
    # 60 s of coasting, from the stream call that closes it (at most a keyframe interval and the reorder
    # window later)
    assert t_out + 59.0 < t_warn < t_out + 62.5 and "pure inertial for 6" in first
    assert t_out + 70.0 <= t_resume < t_out + 72.5 and "DVL aiding resumed after 7" in second
    info = nav.info
    assert info["n_pure_inertial"] == 1 and not info["pure_inertial_now"]
    start, end, sigma = info["pure_inertial_spans"][0]
    assert t_out - 1.01 <= start < t_out and t_out + 69.0 <= end < t_out + 70.0 and sigma > 0


@pytest.mark.parametrize("run", [run_graph, run_ekf])
def test_a_clean_run_started_from_the_sensors_ends_healthy(run):
    # The estimator that counts the alignment's data once runs the window again from a wide prior (0.5 m/s): its
    # sigma there put a clean run "degraded" (70 s, 0.60 m/s) though every estimate published said ok
    m = simulate_mission(duration_s=400.0, seed=2)
    sol = run(m, init="sensors")
    assert sol.info["sigma_v_spans"] == [] and sol.info["health"]["ok"]


def test_the_ekf_going_on_after_a_catch_up_claims_a_heading_sigma_that_covers_its_error():
    """The EKF that goes on after the catch-up runs through the alignment's data again from a wide heading prior.
    From 30 deg its first pings' noise moved the heading tens of degrees (seed 14, whose DVL drew a 3.3-sigma
    scale factor and a 3.4-sigma beam bias) and, linearised there, it settled off by several claimed sigmas
    (here, a 150 s alignment: 2.6 deg against 0.62 deg, 4.2 sigmas). With the prior at
    ``EkfOptions.catch_up_heading_sigma_factor`` times the alignment's sigma its heading error after the window
    stays within 3 claimed sigmas."""
    from graphnav.core.rotations import heading_variance
    from graphnav.estimators.align import AlignOptions
    from graphnav.evaluation.metrics import heading_errors

    m = simulate_mission(duration_s=170.0, imu_grade="navigation", seed=14, dvl_errors="drawn")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = run_ekf(m, init="sensors", navigator_options=NavigatorOptions(align=AlignOptions(duration_s=150.0)))
    after = sol.t > sol.info["alignment"]["completed_t"]
    t, d_psi = heading_errors(sol, m.gt, float(sol.t[after][0]))
    sigma = np.sqrt(heading_variance(sol.C_b_n[after], sol.cov_rot_b[after]))
    assert len(t) == after.sum() > 10
    assert np.max(np.abs(d_psi) / sigma) < 3.0


def test_a_catch_up_heading_sigma_factor_under_one_or_not_finite_is_refused():
    """A factor under 1 (a heading prior narrower than the alignment knows, 1e-9 was taken) or not finite (inf) is
    refused naming the option; 1 and None (the 30 deg prior) are taken."""
    for bad in (0.0, -1.0, float("nan"), 1e-9, 0.5, float("inf")):
        with pytest.raises(ConfigError, match="catch_up_heading_sigma_factor"):
            EkfOptions(catch_up_heading_sigma_factor=bad)
    assert EkfOptions(catch_up_heading_sigma_factor=1.0).catch_up_heading_sigma_factor == 1.0
    assert EkfOptions(catch_up_heading_sigma_factor=None).catch_up_heading_sigma_factor is None


@pytest.mark.parametrize("backend", ["fixed-lag", "ekf"])
def test_an_estimator_started_from_the_sensors_counts_the_alignment_data_once(backend):
    """The aligned heading comes from the first samples, which the estimator then runs through again (catch-up):
    with the alignment's covariance as its prior it held their heading information twice (a heading sigma ~0.7x
    the one the data give). The estimator that goes on must claim what an estimator started at the aligned state
    with only what was known before the data (30 deg heading, 2 deg tilt, 0.5 m/s) claims from the same data;
    the EKF's heading prior is the alignment's sigma times ``EkfOptions.catch_up_heading_sigma_factor``."""
    from graphnav.core.rotations import heading_variance
    from graphnav.estimators.align import AlignOptions
    from graphnav.estimators.navigator import feed_mission

    m = simulate_mission(duration_s=200.0, seed=6)
    options = NavigatorOptions(align=AlignOptions(duration_s=150.0))
    nav = Navigator(m.config, backend, options=options)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        live = [e for e in feed_mission(nav, m) if e.t > nav.alignment_ready_t + 20.0]
    al = nav.alignment
    assert al.heading_source == "gyrocompass" and live
    C = al.C_b_n
    heading_sigma = np.deg2rad(30.0)
    if backend == "ekf":
        factor = EkfOptions().catch_up_heading_sigma_factor
        heading_sigma = min(heading_sigma, factor * math.sqrt((C @ al.cov_rot @ C.T)[2, 2]))
    cov_pose = np.zeros((6, 6))
    cov_pose[:3, :3] = C.T @ np.diag(np.r_[np.deg2rad([2.0, 2.0]), heading_sigma] ** 2) @ C
    cov_pose[3:, 3:] = C.T @ al.cov_p_n @ C
    start = InitialState(gtsam.Pose3(gtsam.Rot3(C), al.p_n), al.v_n, t=al.t, cov_pose=cov_pose,
                         cov_v_n=np.eye(3) * 0.25, origin_lla=al.origin_lla)
    ref_nav = Navigator(m.config, backend, initial=start, options=options)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = {e.t: e for e in feed_mission(ref_nav, m)}

    def heading_sigma(e):
        return math.sqrt(heading_variance(e.pose.rotation().matrix(), e.cov_rot_b))

    for e in live[::20]:
        assert heading_sigma(e) == pytest.approx(heading_sigma(ref[e.t]), rel=0.02)


def test_imu_and_dvl_samples_sent_again_a_moment_later_are_refused_and_change_nothing(mission):
    """An IMU sample and a DVL ping sent again 1 ms later with the same values (a driver publishing one sample twice)
    were taken live as two samples with no word, the ping weighed twice: now each is refused and counted as a log's
    row written twice is (``NUDGED_COPY``), and the estimates are the clean stream's; a ping 1 ms after another with
    other values is still taken."""
    from graphnav.core.screening import NUDGED_COPY
    m = mission.slice(0, 40)
    events = list(replay(m))
    clean = _feed(_navigator(m), events)
    copied = list(events)
    i = next(k for k, e in enumerate(copied) if e[0] == "imu" and e[1] > 20.0)
    j = next(k for k, e in enumerate(copied) if e[0] == "dvl" and e[1] > 25.0)
    copied.insert(j + 1, ("dvl", copied[j][1] + 0.001, copied[j][2]))
    copied.insert(i + 1, ("imu", copied[i][1] + 0.001, copied[i][2]))
    nav = _navigator(m)
    with pytest.warns(RuntimeWarning, match=r"imu sample at t = \d+\.\d+ s refused \(" + re.escape(NUDGED_COPY)):
        out = _feed(nav, copied)
    assert nav.info["refused"] == {"imu": {NUDGED_COPY: 1}, "dvl": {NUDGED_COPY: 1}}
    assert [e.t for e in out] == [e.t for e in clean]
    for x, y in zip(out, clean):
        np.testing.assert_array_equal(x.v_n, y.v_n)
    beams, valid = events[j][2]
    other = list(events)
    other.insert(j + 1, ("dvl", other[j][1] + 0.001, (np.asarray(beams) + 0.02, valid)))
    nav = _navigator(m)
    _feed(nav, other)
    assert nav.info["refused"] == {}


def _pings_in_outage(m, start_s: float, duration_s: float, logged: bool):
    """``m`` with a total DVL outage from ``start_s`` for ``duration_s``: its pings logged with every beam NaN and
    invalid (``logged``), or missing from the log."""
    out = (m.dvl.t >= start_s) & (m.dvl.t < start_s + duration_s)
    if not logged:
        return dataclasses.replace(m, dvl=m.dvl.take(np.flatnonzero(~out)))
    beams = np.where(out[:, None], np.nan, m.dvl.beams)
    return dataclasses.replace(m, dvl=dataclasses.replace(m.dvl, beams=beams, valid=m.dvl.valid & ~out[:, None]))


@pytest.mark.parametrize("run", [pytest.param(lambda m: run_graph(m, completer=AverageCompleter(5), batch=True),
                                              id="Graph-HN-batch"),
                                 pytest.param(lambda m: run_ekf(m, completer=AverageCompleter(5)), id="HNTC")])
def test_a_hybrid_says_a_total_outage_whether_its_pings_are_logged_without_beams_or_missing(mission, run):
    """A 90 s total DVL outage. A hybrid regresses all four beams at each ping logged with no valid beam (NaN rows
    of an A-KIT file, pings without bottom lock); those completions are no DVL measurement, so it warns that it
    ran pure inertial and flags the epochs past max_pure_inertial_s exactly as when the pings are missing."""
    m = mission.slice(0, 150)
    spans = {}
    for logged in (True, False):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = run(_pings_in_outage(m, 40.0, 90.0, logged))
        text = [str(w.message) for w in caught if "pure inertial" in str(w.message)]
        assert len(text) == 2 and "pure inertial for 6" in text[0] and "resumed after 9" in text[1], (logged, text)
        (start, end, _), = spans[logged] = sol.info["pure_inertial_spans"]
        flagged = np.array(sol.info["health_state"]) != "ok"
        # every epoch past max_pure_inertial_s up to the stretch's end, and no other (the EKF writes an epoch
        # per ping only: none inside the outage when the pings are missing)
        np.testing.assert_array_equal(flagged, (sol.t - start > 60.0) & (sol.t <= end))
        assert flagged.sum() >= (25 if logged else 0)
    (start, end, _), = spans[True]
    assert 39.0 <= start < 40.0 and 129.0 <= end < 130.0
    assert [start, end] == pytest.approx(spans[False][0][:2], abs=1.01)       # one ping interval


@pytest.mark.parametrize("run, logged, source", [
    pytest.param(lambda m: run_graph(m, completer=AverageCompleter(5), batch=True), True, "completed beams",
                 id="Graph-HN-batch, pings logged"),
    pytest.param(lambda m: run_ekf(m, completer=AverageCompleter(5)), True, "completed beams", id="HNTC, pings logged"),
    pytest.param(lambda m: run_ekf(m, completer=AverageCompleter(5)), False, "the IMU alone",
                 id="HNTC, pings missing"),
    pytest.param(lambda m: run_ekf(m), True, "the IMU alone", id="TC, pings logged")])
def test_the_coasting_warning_says_where_the_velocity_comes_from(mission, run, logged, source):
    """A 90 s total DVL outage warns as pure inertial in every method, but only one without beams to complete
    navigates on the IMU alone: a hybrid regresses all four beams at each ping logged with no valid beam, and its
    velocity comes from those. It said "bounded by the IMU alone" for every method."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run(_pings_in_outage(mission.slice(0, 150), 40.0, 90.0, logged))
    said, = [str(w.message) for w in caught if "pure inertial for" in str(w.message)]
    completed = source == "completed beams"
    assert ("its velocity comes from completed beams, not measured ones" in said) == completed, said
    assert ("the velocity is bounded by the IMU alone" in said) != completed, said


@pytest.mark.parametrize("method", ["HNTC", "Graph-HN"])
def test_a_hybrid_whose_completions_are_all_screened_out_says_the_imu_alone_bounds_its_velocity(mission, method):
    """The registry's hybrids screen each completion against their own prediction. Through this 90 s total outage
    (pings logged with no valid beam) the screening takes out all 360 of them, so nothing but the IMU carries the
    velocity; the warning said it came from completed beams, counting the beams offered as if they had entered."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = run_method(_pings_in_outage(mission.slice(0, 150), 40.0, 90.0, True), method, "0-beams",
                         backend="fixed-lag")
    said, = [str(w.message) for w in caught if "pure inertial for" in str(w.message)]
    assert sol.info["regressed_screening"]["decorrelated_out"] >= 4 * 85, sol.info["regressed_screening"]
    assert "the velocity is bounded by the IMU alone" in said and "completed beams" not in said, said
