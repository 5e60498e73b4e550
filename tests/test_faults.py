"""Fault injection: every fault either completes within its stated bound or stops with an error naming the
file/stream, line/index and field (table: :data:`graphnav.evaluation.faults.EXPECTED`); robust estimators against beam
spikes; the solver's indeterminant-system recovery; no lost work when online/bench runs are interrupted.

Everything runs on the 200 s simulated mission of :func:`graphnav.evaluation.faults.fault_mission` (each estimator
~0.2 s), seeded. A SIGALRM guard fails any test that hangs.
"""
from __future__ import annotations

import json
import signal
import warnings

import numpy as np
import pytest

from graphnav.cli import main
from graphnav.core.errors import DataError
from graphnav.core.mission import (
    IMU_GAP_ACCEL_SIGMA,
    MAX_DVL_SPEED_MPS,
    DvlData,
    ImuData,
    gap_variances,
)
from graphnav.estimators.ekf import EkfOptions
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.runs import run_ekf, run_graph
from graphnav.evaluation import faults
from graphnav.evaluation.faults import EXPECTED, FAULT_METHODS, FAULTS
from graphnav.evaluation.metrics import vrmse

HANG_LIMIT_S = 120


@pytest.fixture(autouse=True)
def no_hang():
    """Fail (instead of hanging the suite) when one test runs longer than HANG_LIMIT_S."""
    def alarm(signum, frame):
        raise TimeoutError(f"test still running after {HANG_LIMIT_S} s: hang?")
    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(HANG_LIMIT_S)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="module")
def mission():
    return faults.fault_mission()


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("faults")


@pytest.fixture(scope="module")
def baselines(mission, workdir):
    """VRMSE per estimator on the fault-free mission, in memory and through the A-KIT files."""
    return {name: {o.estimator: o.vrmse for o in faults.run_fault(name, FAULT_METHODS, mission, workdir)}
            for name in ("none", "none csv")}


def test_every_fault_has_an_expected_outcome():
    assert set(FAULTS) == set(EXPECTED)


def _first_changed_row(a: np.ndarray, b: np.ndarray) -> int:
    changed = ~((a == b) | (np.isnan(a) & np.isnan(b)))
    return int(np.flatnonzero(changed.any(axis=1))[0])


@pytest.mark.parametrize("fault", [f for f in FAULTS if not f.startswith("none")])
def test_fault_outcome(fault, mission, workdir, baselines):
    expected = EXPECTED[fault]
    outcomes = faults.run_fault(fault, FAULT_METHODS, mission, workdir)
    assert [o.estimator for o in outcomes] == list(FAULT_METHODS)
    if expected.stop:
        err = outcomes[0].error
        assert outcomes[0].stopped and isinstance(err, DataError), f"{fault} was not refused"
        assert str(err.source).endswith(expected.source)
        assert err.field == expected.field
        line = expected.line
        if line is None:    # the first ping the injector changed
            injected = {"nan-beams raw": faults.nan_beams, "rdi-invalid raw": faults.rdi_invalid_beams}[fault]
            line = _first_changed_row(injected(mission.dvl).beams, mission.dvl.beams)
        assert err.line == line
        # the message names the place, so a user can go to the record
        assert expected.source in str(err) and str(line) in str(err) and expected.field in str(err)
        return
    for o in outcomes:
        assert not o.stopped
        t = o.solution.t
        assert np.all(np.isfinite(o.solution.v_n)) and np.all(np.diff(t) > 0)
        assert t[0] >= mission.imu.t[0] and t[-1] <= mission.imu.t[-1]
        bound = expected.factor * baselines[expected.baseline][o.estimator]
        assert o.vrmse <= bound, f"{fault} / {o.estimator}: VRMSE {o.vrmse:.4f} > bound {bound:.4f} m/s"
        if expected.warning is not None:
            assert any(expected.warning in w for w in o.warnings), (fault, o.warnings)


def test_fault_free_runs_are_accurate(baselines):
    # the bounds above are relative: the references themselves are at the cm/s level
    for name in ("none", "none csv"):
        assert max(baselines[name].values()) < 0.08, baselines[name]


# --- the data model: what is a measurement --------------------------------------------------------------
def test_dvl_sanitizer_marks_flags_and_impossible_values_invalid():
    t = np.arange(4.0)
    beams = np.array([[0.5, 0.4, -0.3, 0.2],
                      [-32768.0, 0.4, -0.3, 0.2],
                      [0.5, -32.768, np.nan, 0.2],
                      [0.5, 0.4, MAX_DVL_SPEED_MPS + 1, 9.9]])
    dvl = DvlData(t, beams, np.ones((4, 4), bool))
    with pytest.raises(DataError) as err:
        dvl.validate()
    assert err.value.line == 2 and err.value.field == "beams" and "not finite" in str(err.value)
    with pytest.raises(DataError) as err:
        DvlData(t, np.nan_to_num(beams), np.ones((4, 4), bool)).validate()
    assert err.value.line == 1 and err.value.field == "beams" and "-32768" in str(err.value)
    with pytest.warns(RuntimeWarning, match="RDI bad-velocity flag.*2 seen"):
        clean = dvl.sanitized()
    clean.validate()
    assert clean.valid.tolist() == [[True] * 4, [False, True, True, True], [True, False, False, True],
                                    [True, True, False, True]]
    assert np.isnan(clean.beams[~clean.valid]).all() and clean.beams[3, 3] == 9.9
    with pytest.warns(RuntimeWarning):
        assert dvl.sanitized() is not dvl
    assert clean.sanitized() is clean      # nothing left to mark: same object, no warning


def test_dvl_sanitizer_drops_ping_whose_reported_velocity_is_flagged():
    beams = np.full((2, 4), 0.3)
    v_b = np.array([[1.0, 0.0, 0.1], [-32.768, -32.768, -32.768]])
    dvl = DvlData(np.arange(2.0), beams, np.ones((2, 4), bool), v_b)
    with pytest.raises(DataError, match="v_b"):
        dvl.validate()
    with pytest.warns(RuntimeWarning, match="1 ping"):
        clean = dvl.sanitized()
    clean.validate()
    assert clean.valid[0].all() and not clean.valid[1].any() and np.isnan(clean.v_b[1]).all()


def test_loader_marks_rdi_flagged_rows_invalid(mission, workdir):
    with pytest.warns(RuntimeWarning, match="3 ping.*first at line 20"):
        loaded = faults.make_faulty("rdi-invalid csv", mission, workdir)
    # lines 20, 40, 60 are data rows 18, 38, 58 (every ping has four valid beams in the written file)
    assert np.flatnonzero(~loaded.dvl.valid.any(axis=1)).tolist() == [18, 38, 58]


def test_imu_gap_is_bridged_at_the_nominal_rate_with_linear_values():
    t = np.r_[np.arange(0, 1.0, 0.01), np.arange(3.0, 4.0, 0.01)]
    f = np.column_stack([t, np.zeros_like(t), np.full_like(t, -9.8)])
    imu = ImuData(t, f, np.zeros_like(f))
    with pytest.warns(RuntimeWarning, match=r"1 IMU gap.*2\.010 s after index 99"):
        bridged, gaps = imu.bridge_gaps(100.0)
    assert len(gaps) == 1 and gaps[0].index == 99
    bridged.validate()
    assert np.max(np.diff(bridged.t)) <= 0.0101
    np.testing.assert_allclose(bridged.f_b[:, 0], bridged.t, atol=1e-12)   # linear in t across the gap
    var_v, var_att = gap_variances(gaps, 0.0, 10.0)
    assert var_v == pytest.approx((IMU_GAP_ACCEL_SIGMA * 2.01) ** 2)
    assert gap_variances(gaps, 0.0, 0.5) == (0.0, 0.0)


def test_imu_gap_inflates_estimator_covariance(mission):
    gap = faults.imu_gap(mission, 80.0, 2.0)
    with pytest.warns(RuntimeWarning, match="bridged"):
        sol = run_ekf(gap)
    clean = run_ekf(mission)
    assert sol.info["imu_gaps"] == 1 and clean.info["imu_gaps"] == 0
    k = int(np.searchsorted(sol.t, 82.0))     # first ping after the gap
    assert np.trace(sol.cov_v_n[k]) > 1.5 * np.trace(clean.cov_v_n[k])
    from graphnav.estimators.graph.builder import GraphContext, mission_keyframes
    with pytest.warns(RuntimeWarning, match="bridged"):
        kfs = list(mission_keyframes(gap, GraphOptions()))
    t = np.array([kf.t for kf in kfs])

    def velocity_variance(k):        # preintegrated covariance order: [rot, pos, vel, ...]
        return np.trace(kfs[k].pim.preintMeasCov()[6:9, 6:9])
    over_gap, clean_k = int(np.searchsorted(t, 82.0)), int(np.searchsorted(t, 11.0))
    assert velocity_variance(over_gap) > 100 * velocity_variance(clean_k)
    ctx = GraphContext(gap.config, GraphOptions())
    # without a gap the settings are the context's, in an object of their own (a keyframe's gravity is its own)
    plain = ctx.gap_params(0.0, 0.0, 1.0)
    assert plain is not ctx.params
    assert np.array_equal(plain.getAccelerometerCovariance(), ctx.params.getAccelerometerCovariance())


# --- robustness in the estimators ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def spiky(mission):
    return faults.beam_spikes(mission)


def test_ekf_gating_rejects_exactly_the_spikes(mission, spiky):
    n_spikes = len(spiky.meta["spike_rows"])
    gated = run_ekf(spiky, options=EkfOptions(gating=True))
    plain = run_ekf(spiky, options=EkfOptions(gating=False))
    clean = run_ekf(mission, options=EkfOptions(gating=True))
    assert n_spikes == 18 and gated.info["n_gated"] == n_spikes and clean.info["n_gated"] == 0
    # a spike the gate rejects is not divergence, nor an inconsistency of the filter
    h = gated.info["health"]
    assert not h["diverged"] and h["n_rejected"] == n_spikes and h["n_blocks_above_band"] == 0
    assert vrmse(gated, mission.gt) < 1.2 * vrmse(clean, mission.gt) < vrmse(plain, mission.gt) / 2
    assert EkfOptions().gating     # on by default


def test_graph_huber_on_measured_beams_helps_the_spike_case(mission, spiky):
    assert GraphOptions().huber_measured_k == 3.0
    robust_sol = run_graph(spiky)
    assert not robust_sol.info["health"]["diverged"]     # the down-weighted spikes are not divergence
    robust = vrmse(robust_sol, mission.gt)
    gaussian = vrmse(run_graph(spiky, options=GraphOptions(huber_measured_k=None)), mission.gt)
    clean_robust = vrmse(run_graph(mission), mission.gt)
    clean_gaussian = vrmse(run_graph(mission, options=GraphOptions(huber_measured_k=None)), mission.gt)
    assert gaussian > 2 * robust and robust < 1.15 * clean_gaussian
    assert clean_robust < 1.01 * clean_gaussian     # free on clean data


def test_indeterminant_system_recovers_with_a_warning(mission, monkeypatch):
    """GTSAM's IndeterminantLinearSystem at keyframe 60: the solver restarts (QR, priors from the last
    estimate) with a warning, and the run completes as accurately as without the failure."""
    from graphnav.estimators.graph.incremental import OnlineGraph
    original = OnlineGraph._solve
    calls = {"n": 0}

    def failing(self, factors, values, kf, first_key=None, remove=()):
        if kf.index == 60 and first_key is None and calls["n"] == 0:
            calls["n"] += 1
            raise RuntimeError("Indeterminant linear system detected while working near variable x60")
        return original(self, factors, values, kf, first_key, remove)

    monkeypatch.setattr(OnlineGraph, "_solve", failing)
    with pytest.warns(RuntimeWarning, match="indeterminant linear system at keyframe 60"):
        sol = run_graph(mission)
    monkeypatch.undo()
    reference = run_graph(mission)
    assert sol.info["recovered"] == 1 and len(sol.t) == len(reference.t)
    assert vrmse(sol, mission.gt) < 1.2 * vrmse(reference, mission.gt)


@pytest.mark.parametrize("backend", ["isam2", "fixed-lag"])
def test_indeterminant_system_from_a_tiny_integration_sigma_recovers(mission, backend):
    """The real thing: Cholesky with an integration sigma of 1e-4 (covariance 1e-8) is indeterminant at
    keyframe 1 (2 with the DVL error states); the solver restarts with QR and the run is as accurate as with
    the default sigma."""
    with pytest.warns(RuntimeWarning, match="indeterminant linear system at keyframe [12] "):
        sol = run_graph(mission, options=GraphOptions(integration_sigma=1e-4, factorization="CHOLESKY"),
                        backend=backend)
    reference = run_graph(mission, backend=backend)
    assert sol.info["recovered"] == 1
    assert vrmse(sol, mission.gt) < 1.05 * vrmse(reference, mission.gt)


@pytest.mark.parametrize("solver", ["vectorized", "lm"])
def test_indeterminant_batch_is_solved_again_with_qr(mission, solver):
    from graphnav.nets.average import AverageCompleter
    with pytest.warns(RuntimeWarning, match="solving again with QR elimination"):
        sol = run_graph(mission, completer=AverageCompleter(5), batch=True,
                        options=GraphOptions(integration_sigma=1e-4, batch_solver=solver))
    reference = run_graph(mission, completer=AverageCompleter(5), batch=True, options=GraphOptions(batch_solver=solver))
    assert sol.info["batch_qr_retry"] and "batch_failed" not in sol.info
    assert vrmse(sol, mission.gt) < 1.05 * vrmse(reference, mission.gt)
    # the QR marginals agree with the Cholesky ones where both work
    qr = run_graph(mission, completer=AverageCompleter(5), batch=True,
                   options=GraphOptions(batch_factorization="QR", batch_solver=solver))
    np.testing.assert_allclose(qr.cov_v_n, reference.cov_v_n, rtol=1e-6, atol=1e-12)


def test_batch_that_cannot_be_solved_returns_the_filtered_estimates(mission, monkeypatch):
    from graphnav.nets.average import AverageCompleter

    from graphnav.estimators import runs as graph_run

    def indeterminant(*args, **kwargs):
        raise RuntimeError("Indeterminate linear system detected while working near variable x5")
    monkeypatch.setattr(graph_run, "batch_smooth", indeterminant)
    with pytest.warns(RuntimeWarning, match="returning the filtered"):
        sol = run_graph(mission, completer=AverageCompleter(5), batch=True)
    filtered = run_graph(mission, completer=AverageCompleter(5))
    assert "Indeterminate" in sol.info["batch_failed"] and sol.cov_v_n is None
    np.testing.assert_allclose(sol.v_n, filtered.v_n, atol=1e-9)


def test_other_solver_errors_are_not_swallowed(mission, monkeypatch):
    from graphnav.estimators.graph.incremental import OnlineGraph

    def broken(self, *args, **kwargs):
        raise RuntimeError("something else")
    monkeypatch.setattr(OnlineGraph, "_solve", broken)
    with pytest.raises(RuntimeError, match="something else"):
        run_graph(mission)


# --- every entry point names the bad record -------------------------------------------------------------
@pytest.mark.parametrize("command", ["smooth", "online"])
def test_cli_reports_a_truncated_line(command, mission, tmp_path, capsys):
    from graphnav.io.export import write_akit
    paths = write_akit(mission, tmp_path)
    faults.truncate_csv_line(paths["DVL"], 7)
    rc = main([command, "--data", str(paths["DVL"].parent), "--out", str(tmp_path / "out"), "--no-plots"])
    err = capsys.readouterr().err
    assert rc == 1
    assert "DVL_trajectory1.csv, line 7, field 'DVL X [m/s]'" in err and "truncated line" in err


# --- no lost work ----------------------------------------------------------------------------------------
def _online(out, *extra):
    return main(["online", "--duration", "150", "--scenario", "2-missing", "--method", "Graph-TC", "--out",
                 str(out), "--no-progress", "--no-plots", *extra])


def test_online_interrupted_keeps_epochs_and_resumes_identically(tmp_path, monkeypatch):
    full = tmp_path / "full"
    assert _online(full) == 0
    reference = (full / "online.csv").read_text()

    from graphnav.io.outputs import EpochCsvWriter
    original = EpochCsvWriter.write
    stop_after = 40

    def interrupting(self, *args, **kwargs):
        if self.n_written == stop_after:
            raise KeyboardInterrupt
        return original(self, *args, **kwargs)

    part = tmp_path / "part"
    monkeypatch.setattr(EpochCsvWriter, "write", interrupting)
    assert _online(part) == 130          # Ctrl-C: exit code 130, the file keeps what was written
    monkeypatch.undo()
    kept = (part / "online.csv").read_text()
    assert len(kept.splitlines()) == stop_after + 1 and reference.startswith(kept)

    assert _online(part, "--resume") == 0
    assert (part / "online.csv").read_text() == reference
    summary = json.loads((part / "summary.json").read_text())
    assert summary["epochs_replayed"] == stop_after and summary["resumed_after_s"] is not None


def test_bench_interrupted_keeps_finished_cases(tmp_path, monkeypatch):
    from graphnav.evaluation import bench
    source = bench.TrajectorySource("sim-fault", None, 1, 200.0, None)
    cases = bench.make_cases([source], scenarios=("2-missing",), grades=("navigation",),
                             methods=("TC", "Graph-TC", "LC"), window_s=30.0, max_windows=1)
    original = bench.runner.run_method
    calls = []

    def interrupting(mission, method, *args, **kwargs):
        calls.append(method)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return original(mission, method, *args, **kwargs)

    bench.prepared_mission.cache_clear()
    monkeypatch.setattr(bench.runner, "run_method", interrupting)
    with pytest.raises(KeyboardInterrupt):
        bench.run_bench(cases, tmp_path, progress=False)
    kept = json.loads((tmp_path / "results.json").read_text())
    assert [r["method"] for r in kept] == ["TC"] and kept[0]["vrmse_window"] < 0.1

    calls.clear()
    monkeypatch.setattr(bench.runner, "run_method", lambda m, method, *a, **k: calls.append(method) or original(m, method, *a, **k))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        records = bench.run_bench(cases, tmp_path, resume=True, progress=False)
    bench.prepared_mission.cache_clear()
    assert calls == ["Graph-TC", "LC"]          # the finished case is not run again
    assert [r["method"] for r in records] == ["TC", "Graph-TC", "LC"]
    assert records[0] == kept[0] and not any(r.get("error") for r in records)


# --- every IMU grade -------------------------------------------------------------------------------------
#: The faults run on the tactical and MEMS missions in the suite (the whole table: graphnav faults --estimators).
GRADE_FAULTS = ("none", "dvl-outage 120 s", "dvl-glitches screened", "beam-spikes 1 m/s")


@pytest.mark.parametrize("grade", ["tactical", "mems"])
def test_fault_subset_on_lower_grade_imus(grade, tmp_path):
    """Within the bound, or (a total outage: no bound can hold for a tactical/MEMS INS) the estimator warned
    that it ran pure inertial and its covariance covers the error."""
    mission = faults.fault_mission(grade)
    base = {o.estimator: o.vrmse for o in faults.run_fault("none", FAULT_METHODS, mission, tmp_path)}
    for fault in GRADE_FAULTS[1:]:
        for o in faults.run_fault(fault, FAULT_METHODS, mission, tmp_path):
            verdict = faults.judge(EXPECTED[fault], o, base[o.estimator])
            assert verdict != "FAIL", (grade, fault, o.estimator, o.vrmse, o.nees, o.warnings)
            if fault.startswith("dvl-outage") and o.estimator in ("Graph-TC", "TC"):
                assert o.warned_pure_inertial and o.pure_inertial_s >= 119.0
                assert o.nees <= faults.NEES_COVER_MAX, (grade, o.estimator, o.nees)


def test_pure_inertial_check_warns_when_it_happens_and_when_aiding_resumes():
    from graphnav.estimators.coasting import check_pure_inertial
    t = np.arange(200.0)
    aided = (t < 40) | (t >= 160)
    cov = np.repeat(np.eye(3)[None], 200, axis=0) * 0.01
    cov[159] *= 4.0
    with pytest.warns(RuntimeWarning) as record:
        info = check_pure_inertial("EKF-TC", t, aided, cov, max_s=60.0)
    text = [str(w.message) for w in record]
    assert len(text) == 2
    # once, at the first epoch past the limit (39 s was the last aided epoch), with the sigma there
    assert text[0].startswith("EKF-TC: t=100.00 s: pure inertial for 61 s (since 39.0 s") and "sigma 0.173" in text[0]
    # and when aiding resumes, with the whole span and the sigma at its last un-aided epoch
    assert text[1].startswith("EKF-TC: t=160.00 s: DVL aiding resumed after 120 s pure inertial (39.0-159.0 s)")
    assert "sigma at its end 0.346 m/s" in text[1]
    assert info["pure_inertial_max_s"] == 120.0 and info["n_pure_inertial"] == 1
    assert info["pure_inertial_spans"] == [[39.0, 159.0, pytest.approx(0.3464, abs=1e-4)]]
    # a run without covariance says so, not "sigma nan"
    with pytest.warns(RuntimeWarning) as record:
        check_pure_inertial("Graph-TC", t, aided, None, max_s=60.0)
    assert [str(w.message).endswith("no velocity covariance to predict its error with") for w in record] == [True] * 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_pure_inertial("x", t, aided, None, max_s=130.0)["pure_inertial_spans"] == []
        assert check_pure_inertial("x", t, np.ones(200, bool), cov)["pure_inertial_max_s"] == 0.0
