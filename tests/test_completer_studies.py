"""The arithmetic of the completer studies checked against numbers worked out by hand: the run-error study's
whitened differences and Gauss-Markov fit (``experiments/run_error_model.py``), the recent-error mixture's outage
windows and weights (``experiments/recent_error_mixture.py``), the placement study's windows and the fadings' rule
(``experiments/outage_placement.py``), and the gate and the bound on the fused completer's departure from the average
(``experiments/departure_gate.py``, ``experiments/departure_clip.py``), the stress and report of runs whose number
of measured beams changes (``experiments/count_change_runs.py``), the screening against the graph without
completions (``experiments/oracle_completions.py --anchored``) and the fold networks that study runs in total
outages. The studies themselves run for minutes on the shared data and are not run here."""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _study(name: str):
    if str(ROOT / "experiments") not in sys.path:
        sys.path.insert(0, str(ROOT / "experiments"))       # the studies import their siblings
    spec = importlib.util.spec_from_file_location(f"_study_{name}", ROOT / "experiments" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _gauss_markov(rng, n_windows: int, pings: int, beams: int, tau_pings: float, std: float) -> list[np.ndarray]:
    """Stationary first-order Gauss-Markov errors, one independent series per window and beam."""
    phi = np.exp(-1.0 / tau_pings)
    out = []
    for _ in range(n_windows):
        e = np.empty((pings, beams))
        e[0] = std * rng.standard_normal(beams)
        for k in range(1, pings):
            e[k] = phi * e[k - 1] + std * np.sqrt(1.0 - phi ** 2) * rng.standard_normal(beams)
        out.append(e)
    return out


def _random_walk_beams(seed: int, pings: int, step: float = 0.05):
    """(beams (pings, 4), a one-series list of :class:`graphnav.nets.data.BeamSeries`): beams that random-walk by
    ``step`` m/s per ping, the velocity solved from them exactly."""
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.data import BeamSeries
    beams = np.cumsum(step * np.random.default_rng(seed).standard_normal((pings, 4)), axis=0)
    return beams, [BeamSeries("s", DvlGeometry.from_spec(DvlSpec()).velocity_from_beams(beams), beams)]


def test_whitened_differences_have_nees_one_at_the_true_correlation_time():
    study = _study("run_error_model")
    rng = np.random.default_rng(3)
    errors = _gauss_markov(rng, n_windows=300, pings=120, beams=3, tau_pings=20.0, std=0.1)
    windows = [(e, np.full_like(e, 0.1)) for e in errors]
    rms, nees = study.difference_check(windows, tau=20.0)
    assert nees == pytest.approx(1.0, abs=0.03)
    assert rms == pytest.approx(0.1 * np.sqrt(1 - np.exp(-2 / 20)), rel=0.03)
    # a shorter model time: var(e_k - phi e_k-1) = s^2 (1 + phi^2 - 2 phi phi_T) over (1 - phi^2) s^2
    phi, phi_true = np.exp(-1 / 3), np.exp(-1 / 20)
    expected = (1 + phi ** 2 - 2 * phi * phi_true) / (1 - phi ** 2)
    assert study.difference_check(windows, tau=3.0)[1] == pytest.approx(expected, rel=0.05)


def test_whitened_difference_variance_takes_the_growing_sigma_where_it_is_larger():
    study = _study("run_error_model")
    phi = np.exp(-1.0 / 10.0)
    e = np.array([[0.1], [0.3], [0.2]])
    s = np.array([[0.1], [0.3], [0.3]])
    # ping 1: sigma grew, s1^2 - phi^2 s0^2 beats (1 - phi^2) s1^2; ping 2: steady, the stationary branch
    v1 = 0.3 ** 2 - phi ** 2 * 0.1 ** 2
    v2 = (1 - phi ** 2) * 0.3 ** 2
    assert v1 > (1 - phi ** 2) * 0.3 ** 2
    d1, d2 = 0.3 - phi * 0.1, 0.2 - phi * 0.3
    rms, nees = study.difference_check([(e, s)], tau=10.0)
    assert nees == pytest.approx((d1 ** 2 / v1 + d2 ** 2 / v2) / 2)
    assert rms == pytest.approx(np.sqrt((d1 ** 2 + d2 ** 2) / 2))


def test_gauss_markov_fit_finds_the_correlation_time_and_the_white_share():
    study = _study("run_error_model")
    rng = np.random.default_rng(4)
    slow = _gauss_markov(rng, n_windows=400, pings=120, beams=3, tau_pings=15.0, std=0.1)
    acf = {k: study.autocorrelation(slow, k) for k in range(1, 31)}
    a, t = study.gauss_markov_fit(acf)
    assert a > 0.9 and 11.0 <= t <= 19.0
    # a white share of 0.3 of the variance lowers a by that much and leaves the time
    mixed = [np.sqrt(0.7) * e + np.sqrt(0.3) * 0.1 * rng.standard_normal(e.shape) for e in slow]
    a_mixed, t_mixed = study.gauss_markov_fit({k: study.autocorrelation(mixed, k) for k in range(1, 31)})
    assert a_mixed == pytest.approx(0.7, abs=0.06) and 11.0 <= t_mixed <= 19.0


def test_runs_of_splits_windows_and_skips_records_that_are_not_whole(tmp_path, capsys):
    study = _study("run_error_model")
    pings = 5
    e = np.arange(2 * pings * 3, dtype=float)          # two windows, three regressed beams per ping
    runs = [[["Trajectory1", "mems", float(pings), "Graph-HNI (fold)"],
             {"errors": e.tolist(), "stated_sigma": (e + 1).tolist()}],
            [["Trajectory2", "mems", float(pings), "Graph-HNI (fold)"],
             {"errors": e[:-1].tolist(), "stated_sigma": e[:-1].tolist()}],
            [["Trajectory1", "mems", float(pings), "another"], {"errors": e.tolist(), "stated_sigma": e.tolist()}]]
    path = tmp_path / "runs.json"
    path.write_text(json.dumps({"settings": {"scenario": "3-missing"}, "runs": runs}))
    scenario, windows = study.runs_of(path, "Graph-HNI (fold)")
    assert scenario == "3-missing" and len(windows) == 2
    np.testing.assert_array_equal(windows[1][0][0], [15.0, 16.0, 17.0])     # ping 0 of window 2, beams in order
    np.testing.assert_array_equal(windows[0][1], windows[0][0] + 1)
    assert "Trajectory2" in capsys.readouterr().err                         # 29 errors: not whole windows


def test_outage_starts_are_the_rollout_windows_and_mixing_weights_as_stated():
    from graphnav.nets.average import AverageCompleter
    from graphnav.nets.data import BeamSeries
    from graphnav.nets.evaluate import outage_rollout
    study = _study("recent_error_mixture")
    rng = np.random.default_rng(5)
    series = [BeamSeries(f"s{i}", np.zeros((n, 3)), rng.standard_normal((n, 4))) for i, n in enumerate((200, 131))]
    average = AverageCompleter(3)
    _, _, samples = outage_rollout(average, series, [0, 1], window=study.WINDOW, gap=study.GAP, settle=25)
    starts = study.outage_starts(series, average.n_past, 25)
    assert starts == [(0, 25), (0, 115), (1, 25)]         # 200 pings: 25 and 115 (205 > 200 - 30); 131: 25 only
    assert len(starts) * study.WINDOW == len(samples.beams)
    for w, (si, start) in enumerate(starts):
        np.testing.assert_array_equal(samples.beams[w * study.WINDOW], series[si].beams[start])

    fused, average_b = np.full((3, 4), 1.0), np.full((3, 4), 3.0)
    errors = {0: (0.01, 0.03), 1: (0.04, 0.01)}             # row 2 has none: it keeps the fused completion
    np.testing.assert_allclose(study.mixed(fused, average_b, errors, "select")[:, 0], [1.0, 3.0, 1.0])
    # inverse mean squared error: w = e_A / (e_F + e_A) on the fused completion
    np.testing.assert_allclose(study.mixed(fused, average_b, errors, "inverse")[:, 0], [1.5, 2.6, 1.0], atol=1e-9)


def test_oracle_draws_table_counts_fold_cells_over_the_bound_per_draw():
    from graphnav.nets.crossval import AKIT_FOLDS
    study = _study("oracle_completions")
    names = [f"Trajectory{k}" for pair in AKIT_FOLDS for k in pair]
    reference = {(n, "mems", 60.0, "Graph-TC"): [1.0, 1.0] for n in names}
    runs = {}
    for n in names:
        runs[n, "mems", 60.0, "serial 0.1"] = {"vrmse": [0.9, 0.9]}
        runs[n, "mems", 60.0, "serial 0.1 draw 2"] = {"vrmse": [0.9, 0.9]}
    pair = [f"Trajectory{k}" for k in AKIT_FOLDS[3]]
    for n in pair:                                    # draw 2 makes fold 3 1.1x Graph-TC
        runs[n, "mems", 60.0, "serial 0.1 draw 2"] = {"vrmse": [1.1, 1.1]}
    text = study.draws_table(runs, reference, ["mems"], [60.0], ["serial 0.1"], 2)
    assert "| serial 0.1 | mems | 60 | 0.90-0.94 | 0.90-1.10 |" in text
    assert "serial 0.1: fold cells over 1.02x per draw: 0, 1 (of 5)" in text


def test_rehearsal_is_the_outage_rollout_of_the_pings_before_and_reads_nothing_after():
    from graphnav.nets.average import AverageCompleter
    from graphnav.nets.data import BeamSeries
    from graphnav.nets.evaluate import outage_rollout
    study = _study("recent_error_mixture")
    rng = np.random.default_rng(6)
    beams = np.cumsum(0.02 * rng.standard_normal((120, 4)), axis=0)
    series = BeamSeries("s", np.zeros((120, 3)), beams)
    average, start, k = AverageCompleter(3), 70, 20
    (mse,) = study.rehearsal_errors((average,), series, [0, 1], start, k)
    full, _, samples = outage_rollout(average, series, [0, 1], window=k, gap=1000, settle=start - k)
    assert len(full) == k and np.array_equal(samples.beams[0], beams[start - k])
    assert mse == pytest.approx(np.sum((full[:, :2] - samples.beams[:, :2]) ** 2) / k)
    damaged = BeamSeries("s", series.v_b, beams.copy())
    damaged.beams[start:] = np.nan                      # the outage and after: never read
    assert study.rehearsal_errors((average,), damaged, [0, 1], start, k) == (mse,)
    damaged.beams[start - 1, 0] = np.nan                # a bad beam it would read: no rehearsal, not a NaN weight
    assert study.rehearsal_errors((average,), damaged, [0, 1], start, k) is None
    assert study.rehearsal_errors((average,), series, [0, 1], 30, k) is None      # before the IMU window is full


def test_row_index_lays_out_the_usable_pings_from_n_past_on_series_after_series():
    study = _study("recent_error_mixture")

    class Usable:
        def __init__(self, mask):
            self.mask = np.asarray(mask, bool)

        def usable(self, n_past, n_imu):
            return self.mask.copy()

    rows = study.row_index([Usable([1, 1, 1, 0, 1]), Usable([0, 1, 1, 1])], n_past=2, n_imu=10)
    assert rows == {(0, 2): 0, (0, 4): 1, (1, 2): 2, (1, 3): 3}


def test_oracle_first_draw_keeps_the_stored_runs_seed():
    import zlib
    study = _study("oracle_completions")
    key = ("Trajectory6", "mems", "3-missing", 60.0, "serial 0.1")
    stored = zlib.crc32(repr(key).encode())
    assert study.oracle_seed(*key) == stored == study.oracle_seed(*key, draw="1")
    assert len({study.oracle_seed(*key, draw=str(k)) for k in range(1, 6)}) == 5


def test_every_placement_holds_the_studies_windows_at_placement_zero_and_blocks_of_ninety_pings():
    import sys
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.average import AverageCompleter
    from graphnav.nets.data import BeamSeries
    from graphnav.nets.evaluate import outage_rollout
    sys.path.insert(0, str(ROOT / "experiments"))
    study = _study("outage_placement")
    fade = _study("completer_fade_folds")
    rng = np.random.default_rng(7)
    series = []
    for i, n in enumerate((400, 150)):
        beams = np.cumsum(0.03 * rng.standard_normal((n, 4)), axis=0)
        series.append(BeamSeries(f"s{i}", DvlGeometry.from_spec(DvlSpec()).velocity_from_beams(beams)
                                 + 0.01 * rng.standard_normal((n, 3)), beams))
    comps = {"average": AverageCompleter(3), "long": AverageCompleter(12)}
    sq, starts = study.rollout_windows(comps, series, [0, 1], settle=25, stride=10)
    # 400 pings: 25, 35, ..., 365 (35 windows); 150 pings: 25 .. 115 (10)
    assert starts[:2] == [(0, 25), (0, 35)] and starts[34] == (0, 365) and starts[35:] == [(1, 25 + 10 * k)
                                                                                          for k in range(10)]
    place, blocks = study.placement_of(starts, 25, 10), study.block_of(starts, 25)
    assert list(place[:11]) == [0, 1, 2, 3, 4, 5, 6, 7, 8, 0, 1]
    assert blocks[0] == blocks[8] != blocks[9] and blocks[35] != blocks[34]
    # placement 0 is the studies' layout: a window every 90 pings from the settle ping, the same errors
    full, _, samples = outage_rollout(comps["long"], series, [0, 1], window=30, gap=60, settle=25)
    own = fade.window_sq(full, samples, [0, 1], DvlGeometry.from_spec(DvlSpec()))
    for m in (0, 1):
        np.testing.assert_allclose(np.asarray(sq["long"][m])[place == 0], own[m])
    g = study.gain(sq["long"], sq["average"], place == 0)
    assert g[1] == pytest.approx(100 * (1 - np.sqrt(np.sum(own[1]) / np.sum(np.asarray(sq["average"][1])[place == 0]))))
    lo, hi = study.block_interval(sq["long"], sq["average"], blocks)[1]
    assert lo <= study.gain(sq["long"], sq["average"])[1] <= hi
    # blocks that are all alike: no spread to draw
    same = [[1.0] * 9, [2.0] * 9], [[2.0] * 9, [2.0] * 9]
    (blo, bhi), (vlo, vhi) = study.block_interval(*same, np.repeat(np.arange(3), 3))
    assert blo == bhi == pytest.approx(100 * (1 - np.sqrt(0.5))) and vlo == vhi == 0.0


def test_every_placement_solves_velocities_with_the_dvl_the_beams_were_made_for():
    """Fold networks trained for another DVL are scored on that DVL's beams: the windows' velocity errors come from
    its geometry, not the Snapir's (the beam errors do not depend on it)."""
    import dataclasses
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.average import AverageCompleter
    from graphnav.nets.data import BeamSeries
    from graphnav.nets.evaluate import outage_rollout
    study = _study("outage_placement")
    fade = _study("completer_fade_folds")
    rdi = dataclasses.replace(DvlSpec(), psi_rad=np.deg2rad([270.0, 90.0, 0.0, 180.0]))
    rng = np.random.default_rng(3)
    beams = np.cumsum(0.03 * rng.standard_normal((200, 4)), axis=0)
    series = [BeamSeries("s", DvlGeometry.from_spec(rdi).velocity_from_beams(beams), beams)]
    comps = {"average": AverageCompleter(3), "long": AverageCompleter(12)}
    sq_rdi, starts = study.rollout_windows(comps, series, [0, 1], settle=25, stride=10, spec=rdi)
    sq_default, _ = study.rollout_windows(comps, series, [0, 1], settle=25, stride=10)
    full, _, samples = outage_rollout(comps["long"], series, [0, 1], window=30, gap=60, settle=25)
    own = fade.window_sq(full, samples, [0, 1], DvlGeometry.from_spec(rdi))
    place = study.placement_of(starts, 25, 10)
    np.testing.assert_allclose(np.asarray(sq_rdi["long"][1])[place == 0], own[1])
    np.testing.assert_allclose(sq_rdi["long"][0], sq_default["long"][0])
    assert not np.allclose(sq_rdi["long"][1], sq_default["long"][1])


def test_the_fused_studies_score_a_pair_on_the_dvl_both_members_were_trained_for():
    import dataclasses
    import types
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    fused = _study("imu_beam_fused_folds")
    folds = _study("imu_completer_folds")
    rdi = dataclasses.replace(DvlSpec(), psi_rad=np.deg2rad([270.0, 90.0, 0.0, 180.0]))
    noisier = dataclasses.replace(rdi, beam_noise_std=0.1)
    net = types.SimpleNamespace
    assert fused.pair_dvl(net(trained_dvl_spec=rdi), net(trained_dvl_spec=rdi), "x.py") is rdi
    # a pivot member has no card: its beams must be the DVL's
    assert fused.pair_dvl(net(trained_dvl_spec=rdi), net(T_b=DvlGeometry.from_spec(rdi).T_b), "x.py") is rdi
    for second, why in ((net(trained_dvl_spec=DvlSpec()), "45, 135, 225, 315 deg"),
                        (net(trained_dvl_spec=noisier), "the same beams, other errors"),
                        (net(T_b=DvlGeometry.from_spec(DvlSpec()).T_b), "its beams differ")):
        with pytest.raises(SystemExit, match=r"x.py: the IMU-aware fold network was trained for the DVL 20 deg from "
                                             r"the vertical at azimuths 270, 90, 0, 180 deg, .*" + why):
            fused.pair_dvl(net(trained_dvl_spec=rdi), second, "x.py")
    # a report pools the rows of one DVL only; rows without a name were scored on the Snapir's
    assert folds.rows_dvl([{"dvl": "A"}, {"dvl": "A"}], "x.py") == "A"
    assert folds.rows_dvl([{}], "x.py") == folds.rows_dvl([], "x.py") == "20 deg from the vertical at azimuths 45, " \
        "135, 225, 315 deg"
    with pytest.raises(SystemExit, match="x.py: the rows were scored on different DVLs"):
        folds.rows_dvl([{"dvl": "A"}, {}], "x.py")
    # every report of the studies that score pairs refuses them before pooling
    mixed = [{"dvl": "A"}, {"dvl": "B"}]
    for study, report in (("outage_placement", "report"), ("outage_placement", "decay_report"),
                          ("imu_beam_fused_folds", "report"), ("recent_error_mixture", "report")):
        with pytest.raises(SystemExit, match="the rows were scored on different DVLs"):
            getattr(_study(study), report)(mixed)


def test_the_fused_studies_make_the_beams_and_solve_the_velocities_of_the_pairs_dvl(monkeypatch, tmp_path):
    """The studies' own runs, their data and scoring stubbed where they would train or read missions: each fold's
    held-out beams are made for the DVL the pair was trained for, the placement study solves its windows with that
    DVL, the fused and mixture studies score velocities with its geometry, and each row names it."""
    import dataclasses
    import types
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets import evaluate
    from graphnav.nets.average import AverageCompleter
    from graphnav.nets.data import BeamSamples
    from graphnav.nets.dvl_match import dvl_name
    place = _study("outage_placement")
    import imu_beam_fused_folds as fused          # the modules the studies import at run time
    import imu_completer_folds as folds
    rdi = dataclasses.replace(DvlSpec(), psi_rad=np.deg2rad([270.0, 90.0, 0.0, 180.0]))
    made, solved = [], []
    monkeypatch.setattr(folds, "held_out_series", lambda held, akit_dir, grade, spec=None: made.append(spec) or [])

    def member():
        m = AverageCompleter(3)
        m.trained_dvl_spec, m.missing, m.run_decay = rdi, (0, 1), 1.0
        return m
    nets = {f: (member(), member()) for f in range(5)}
    # the placement study
    monkeypatch.setattr(fused, "fold_networks", lambda *args, **kwargs: nets)
    monkeypatch.setattr(place, "envelope_variants", lambda net, akit_dir: lambda enveloped: net)
    monkeypatch.setattr(place, "rollout_windows", lambda comps, series, missing, settle, stride, spec=None:
                        solved.append(spec) or ({}, []))
    rows = place.run("2-missing", "imu", "beam", None, tmp_path / "rows.json", 10, names=("IMU-aware, fading",))
    assert len(made) == len(solved) == 15 and all(s is rdi for s in made + solved)
    assert {r["dvl"] for r in rows} == {dvl_name(rdi)}
    # the fused study's held-out pings
    made.clear()
    monkeypatch.setattr(fused, "per_ping", lambda *args: None)
    fused.held_out_per_ping(nets, "2-missing", None)
    assert len(made) == 15 and all(s is rdi for s in made)
    # the fused study's and the mixture study's metrics: every outage and per-ping completion has errors on beams 1
    # and 2, and the velocity error is the RDI geometry's
    rng = np.random.default_rng(5)
    beams = rng.normal(size=(60, 4))
    samples = BeamSamples(np.zeros((60, 0, 4)), beams, DvlGeometry.from_spec(rdi).velocity_from_beams(beams))
    full, sigma = beams + np.array([0.1, -0.2, 0.0, 0.0]), np.full((60, 4), 0.1)
    monkeypatch.setattr(evaluate, "outage_rollout", lambda comp, series, missing, **kw: (full, sigma, samples))
    pp = {"samples": samples, "imu": (full, sigma), "beam": (full, sigma), "average": (full, sigma)}
    rows = fused.fold_rows(0, (1, 3), "2-missing", "recorded", *nets[0], [], pp, 0.5)
    want, snapir = (evaluate.completion_metrics(full, sigma, samples, [0, 1], DvlGeometry.from_spec(spec))["vel_rmse"]
                    for spec in (rdi, DvlSpec()))
    assert want != pytest.approx(snapir)
    assert {r["dvl"] for r in rows} == {dvl_name(rdi)}
    assert all(r["vel_rmse"] == pytest.approx(want) for r in rows)
    # the outage windows' errors (the 90 % intervals) too
    assert all(sum(r["window_sq"][1]) == pytest.approx(60 * want ** 2) for r in rows if "window_sq" in r)
    # a pair trained for two DVLs stops before any pings are made or scored
    made.clear()
    other = member()
    other.trained_dvl_spec = DvlSpec()
    with pytest.raises(SystemExit, match="imu_beam_fused_folds.py: the IMU-aware fold network was trained for"):
        fused.held_out_per_ping({0: (nets[0][0], other)}, "2-missing", None)
    assert made == []
    mixture = _study("recent_error_mixture")
    monkeypatch.setattr(mixture, "row_index", lambda series, n_past, n_imu: {(0, i): i for i in range(60)})
    monkeypatch.setattr(mixture, "outage_starts", lambda series, n_past, settle: [(0, 0), (0, 30)])
    monkeypatch.setattr(mixture, "rehearsal_errors", lambda *args: None)
    for m in nets[0]:
        m.imu_samples = 0
    mixed = mixture.fold_rows(0, "recorded", "2-missing", nets[0], ["s"], pp, 0.5)
    assert {r["dvl"] for r in mixed} == {dvl_name(rdi)}
    for r in mixed:
        assert r["sq"]["fused"][1] == pytest.approx(60 * want ** 2)


def test_decay_choice_over_every_placement_counts_worse_folds_first_and_scores_each_fold_out_of_fold():
    study = _study("outage_placement")

    def row(fold, pair, ratio, draw="nets"):
        # two windows a fold; the completer's squared errors are ratio^2 the average's in both metrics
        avg = [[1.0, 3.0], [2.0, 2.0]]
        return {"scenario": "2-missing", "fold": fold, "grade": "mems", "settle": 10, "stride": 10,
                "starts": [[0, 10], [0, 110]], "nets": {"IMU-aware": draw, "beam-only": "beams"},
                "run_decay": {"IMU-aware": pair[0], "beam-only": pair[1]},
                "sq": {"average": avg, "fused, envelope": [[ratio ** 2 * x for x in m] for m in avg]}}
    safe, bold = (0.95, 0.9), (0.98, 0.95)
    rows = [row(f, safe, 0.9) for f in range(3)] + [row(f, bold, r) for f, r in enumerate((0.5, 0.6, 1.2))]
    by_pair = {safe: rows[:3], bold: rows[3:]}
    pooled, per_fold = study.decay_gains(by_pair[bold], "fused, envelope", [0, 1])
    assert pooled["nets", "mems", 1] == pytest.approx(100 * (1 - np.sqrt((0.25 * 4 + 0.36 * 4) / 8)))
    assert per_fold["nets", 1, "mems", 0] == pytest.approx(40.0)
    # on all three folds the bold pair leaves fold 2 worse: the safe one wins although its pooled gain is smaller
    assert study.choose_decays(by_pair, "fused, envelope", [0, 1, 2]) == safe
    # without fold 2 nothing is worse and the bold pair's larger gain decides; fold 2 then pays for it out of fold
    assert study.choose_decays(by_pair, "fused, envelope", [0, 1]) == bold
    # the windows are placements 0 and 1 (of nine; the others hold none): fold 2 is worse in both, with the bold
    # pair only
    assert study.placements_worse(by_pair[bold], "fused, envelope") == (2, 6)
    assert study.placements_worse(by_pair[safe], "fused, envelope")[0] == 0
    text = study.decay_report(rows)
    bold_pooled = 100 * (1 - np.sqrt((0.25 + 0.36 + 1.44) / 3))
    assert f"| 0.98 / 0.95 | 1 | {bold_pooled:+.1f} / {bold_pooled:+.1f} | -20.0 (fold 2, mems, beam) | 2 | 2 of 6 |" in text
    assert "Chosen on all folds: 0.95 / 0.9." in text
    assert "- fold 2: 0.98 / 0.95 -> draw 1 mems -20.0 / -20.0" in text
    assert "- fold 0: 0.95 / 0.9 -> draw 1 mems +10.0 / +10.0" in text
    oof = 100 * (1 - np.sqrt((0.81 * 4 + 0.81 * 4 + 1.44 * 4) / 12))
    assert f"Out of fold, pooled: draw 1 mems {oof:+.1f} / {oof:+.1f}; fold cells worse: 2" in text
    # a second training draw in which the bold pair is worse in fold 0 too: on both draws it loses even without
    # fold 2, and a pair missing from the second draw is left out
    second = [row(f, safe, 0.9, "nets2") for f in range(3)] + [row(f, bold, r, "nets2") for f, r in enumerate((1.1, 0.6, 0.6))]
    both = rows + second + [row(f, (1.0, 1.0), 0.1) for f in range(3)]
    assert study.choose_decays({safe: rows[:3] + second[:3], bold: rows[3:] + second[3:]}, "fused, envelope",
                               [0, 1]) == safe
    text = study.decay_report(both)
    assert "1 = nets, 2 = nets2" in text and "| 1 / 1 |" not in text
    assert "- fold 2: 0.95 / 0.9 -> draw 1 mems +10.0 / +10.0; draw 2 mems +10.0 / +10.0" in text
    # rows of two window layouts are not pooled into one choice, nor rows that do not say their networks
    with pytest.raises(ValueError, match="place their windows differently"):
        study.decay_report(rows + [{**row(0, (0.9, 0.9), 1.0), "stride": 90}])
    with pytest.raises(ValueError, match="no rows"):
        study.decay_report([])
    with pytest.raises(ValueError, match="no run_decay pair"):
        study.decay_report(rows, "fused")
    with pytest.raises(ValueError, match="without 'nets'"):
        study.decay_report([{k: v for k, v in r.items() if k != "nets"} for r in rows])
    with pytest.raises(ValueError, match="without 'run_decay'"):
        study.decay_report([{k: v for k, v in r.items() if k != "run_decay"} for r in rows])
    with pytest.raises(ValueError, match="given twice"):
        study.decay_report(rows + rows[:1])
    # a draw is its networks' folder however it was spelt
    assert study.decay_report(rows + [{**r, "nets": {**r["nets"], "IMU-aware": "nets2/"}} for r in second]) \
        == study.decay_report(rows + second)
    # tied pairs: the faster fading wins, whatever the order of the rows
    twin = [{**r, "run_decay": {"IMU-aware": 1.0, "beam-only": 1.0}} for r in rows[:3]]
    assert study.choose_decays({(1.0, 1.0): twin, safe: rows[:3]}, "fused, envelope", [0, 1, 2]) == safe


def test_choose_decays_on_the_command_line_refuses_what_it_cannot_compare(tmp_path, capsys):
    study = _study("outage_placement")
    empty = tmp_path / "rows.json"
    empty.write_text("[]")
    for argv, says in ((["--choose-decays"], "give them with --report"),
                       (["--report", str(empty), "--choose-decays"], "no rows to choose run_decay from"),
                       (["--report", str(empty), "--imu-decay", "1"], "--report reads the decays")):
        with pytest.raises(SystemExit) as stop:
            study.main(argv)
        assert stop.value.code == 2 and says in capsys.readouterr().err


def test_departure_gate_measures_the_first_ping_and_hands_gated_windows_to_the_average():
    import sys

    from graphnav.nets.average import AverageCompleter
    sys.path.insert(0, str(ROOT / "experiments"))
    study = _study("departure_gate")
    beams, series = _random_walk_beams(3, 80)
    # a slow average stands in for the fused completer: z0 is its first completion's departure from the
    # paper's average (3 pings) in that average's sigma, from the true pings before the window
    slow, fast = AverageCompleter(12), AverageCompleter(3)
    z0 = study.first_ping_departure(slow, fast, series, [(0, 20), (0, 50)], [1, 2])
    for (_, start), z in zip([(0, 20), (0, 50)], z0):
        b_slow, b_fast = beams[start - 12:start].mean(axis=0), beams[start - 3:start].mean(axis=0)
        s_fast = np.sqrt(0.042 ** 2 * (1 + 1 / 3) + beams[start - 3:start].var(axis=0))
        assert z == pytest.approx(np.max(np.abs(b_slow - b_fast)[[1, 2]] / s_fast[[1, 2]]))

    def row(fold, avg_sq, net_sq, z):
        return {"scenario": "2-missing", "fold": fold, "grade": "mems", "settle": 10, "stride": 10,
                "starts": [[0, 10 + 10 * k] for k in range(len(z))], "nets": {"IMU-aware": "nets"},
                "sq": {"average": [avg_sq] * 2, "fused, envelope": [net_sq] * 2}, "z0": z}
    # fold 0: the completer better everywhere, never far from the average; fold 1: two windows that start far from
    # the average (z0 1.5 and 5) and go badly, enough to make the fold worse than the average ungated
    rows = [row(0, [4.0] * 4, [2.0] * 4, [0.2] * 4), row(1, [1.0] * 4, [0.5, 0.5, 1.5, 3.0], [0.2, 0.2, 1.5, 5.0])]
    gated, average = study.gated_sq(rows[1], 1.5)
    assert list(gated[1]) == [0.5, 0.5, 1.5, 1.0] and list(average[1]) == [1.0] * 4    # 1.5 is not above 1.5
    assert list(study.gated_sq(rows[1], 1.0)[0][1]) == [0.5, 0.5, 1.0, 1.0]
    assert list(study.gated_sq(rows[1], 6.0)[0][1]) == [0.5, 0.5, 1.5, 3.0]
    pooled, per_fold, share = study.gate_gains(rows, 1.0, [0, 1])
    assert per_fold["nets", 1, "mems", 1] == pytest.approx(100 * (1 - np.sqrt(3.0 / 4.0))) and share == 0.25
    # pooled over the windows, not the mean of the folds' gains
    assert pooled["nets", "mems", 1] == pytest.approx(100 * (1 - np.sqrt(11.0 / 20.0)))
    assert study.gate_gains(rows, float("inf"), [0, 1])[1]["nets", 1, "mems", 1] < 0
    # placement 0 holds only the first window of each fold (its windows start 10 pings apart)
    assert study.gate_gains(rows, 1.0, [0, 1], placement=0)[0]["nets", "mems", 1] == pytest.approx(
        100 * (1 - np.sqrt(2.5 / 5.0)))
    # every threshold up to 4 leaves no fold worse; then the larger smallest pooled gain: 0.5 and 1 gate both bad
    # windows, and of the two the tie goes to less gating
    assert study.choose_threshold(rows, [0, 1]) == 1.0
    # without fold 1 no gating shows any use, so fold 1 left out gets none
    assert study.choose_threshold(rows, [0]) == float("inf")
    assert "Chosen on all folds: Z = 1." in study.report(rows)


def test_departure_gate_names_the_file_it_cannot_use(tmp_path, capsys):
    study = _study("departure_gate")
    placement_rows = tmp_path / "rows.json"
    placement_rows.write_text(json.dumps([{"scenario": "2-missing", "fold": 0, "grade": "mems", "starts": [[0, 10]],
                                           "settle": 10, "stride": 10, "sq": {}, "nets": {}, "run_decay": {}}]))
    for argv, said in ((["--report", str(placement_rows)], "rows without 'z0' (run --rows ... --out first)"),
                       (["--report", str(tmp_path / "absent.json")], "absent.json: cannot read rows"),
                       (["--rows", str(placement_rows)], "--rows and --out are needed")):
        with pytest.raises(SystemExit):
            study.main(argv)
        assert said in capsys.readouterr().err
    # the hint to run the study first is for rows without z0 only
    no_nets = tmp_path / "gated.json"
    no_nets.write_text(json.dumps([{k: v for k, v in json.loads(placement_rows.read_text())[0].items() if k != "nets"}
                                   | {"z0": [0.1]}]))
    with pytest.raises(SystemExit):
        study.main(["--report", str(no_nets)])
    err = capsys.readouterr().err
    assert "rows without 'nets'" in err and "run --rows" not in err


def test_departure_clip_bounds_the_completion_around_the_average_s_own_recursion():
    import sys

    from graphnav.nets.average import AverageCompleter
    from graphnav.nets.evaluate import outage_rollout
    sys.path.insert(0, str(ROOT / "experiments"))
    study = _study("departure_clip")
    beams, series = _random_walk_beams(5, 200)
    missing = [1, 2]

    def rollout(c):
        return outage_rollout(c, series, missing, window=30, gap=0, settle=20)[0]
    # a slow average stands in for the fused completer; the paper's 3-ping average is the anchor
    slow, fast = AverageCompleter(12), AverageCompleter(3)
    # Z = 0 is the average estimator's own recursion, Z = inf the inner completer, to the last bit
    np.testing.assert_array_equal(rollout(study.DepartureClip(slow, 3, 0.0)), rollout(fast))
    np.testing.assert_array_equal(rollout(study.DepartureClip(slow, 3, float("inf"))), rollout(slow))
    # in between, by hand: the inner 12-ping average over a history of the clipped outputs, the anchor's own 3-ping
    # recursion and its sigma from the true past, both restarted at every window
    z = 0.7
    clipped, anchor, free = (rollout(c) for c in (study.DepartureClip(slow, 3, z), fast, slow))
    for w, start in enumerate(range(20, 200 - 30 + 1, 30)):
        history, own = list(beams[start - 12:start]), list(beams[start - 3:start])
        s0 = np.sqrt(0.042 ** 2 * (1 + 1 / 3) + beams[start - 3:start].var(axis=0))
        for k in range(30):
            inner, mean3 = np.mean(history[-12:], axis=0), np.mean(own[-3:], axis=0)
            bound = z * np.sqrt(s0 ** 2 + k * study.GROWTH ** 2)
            want, anchor_k = beams[start + k].copy(), beams[start + k].copy()
            want[missing] = (mean3 + np.clip(inner - mean3, -bound, bound))[missing]
            anchor_k[missing] = mean3[missing]
            np.testing.assert_allclose(clipped[30 * w + k], want, rtol=0, atol=1e-12)
            history.append(want)
            own.append(anchor_k)
    # the bound binds somewhere, and not everywhere: the clip is neither completer
    assert not np.array_equal(clipped, anchor) and not np.array_equal(clipped, free)
    with pytest.raises(ValueError, match="z must be >= 0"):
        study.DepartureClip(slow, 3, -1.0)


def test_departure_clip_cuts_the_placement_rows_and_chooses_by_the_fadings_rule(tmp_path, capsys):
    import sys
    sys.path.insert(0, str(ROOT / "experiments"))
    study = _study("departure_clip")
    # nine windows 10 pings apart: placements 0..8; a 30-ping layout keeps placements 0, 3 and 6
    row = {"scenario": "2-missing", "fold": 0, "grade": "mems", "settle": 10, "stride": 10, "nets": {"IMU-aware": "n"},
           "starts": [[0, 10 + 10 * k] for k in range(9)], "sq": {"average": [list(range(9)), list(range(9, 18))]}}
    cut = study.placement_rows([row], 30)[0]
    assert cut["starts"] == [[0, 10], [0, 40], [0, 70]] and cut["stride"] == 30
    assert [list(m) for m in cut["sq"]["average"]] == [[0, 3, 6], [9, 12, 15]]
    with pytest.raises(ValueError, match="not a multiple"):
        study.placement_rows([row], 25)

    def clipped(fold, ratios):
        # three windows a fold (placements 0, 1, 2 of a 30-ping layout); each Z's squared errors are the given
        # (beam, velocity) ratios squared, window by window, times the average's
        avg = [1.0, 2.0, 3.0]
        return {"scenario": "2-missing", "fold": fold, "grade": "mems", "settle": 10, "stride": 30,
                "starts": [[0, 10], [0, 40], [0, 70]], "nets": {"IMU-aware": "n"},
                "sq": {"average": [avg, avg]} | {f"Z={z}": [[r ** 2 * a for r, a in zip(m, avg)] for m in rs]
                                                for z, rs in ratios.items()}}
    # fold 0: the unbounded completer far better; fold 1: it loses its p = 0 window badly (velocity ratio 1.5),
    # enough to make the fold worse in velocity; Z = 1 and 2 hold every fold alike (a tie: the larger wins); Z = 1.5
    # holds them with the largest mean but the smallest least pooled gain (beam); Z = 3 has the largest least pooled
    # gain of the bounds but leaves fold 1 worse in beam; Z = 0.5 gains little
    same = {z: ([r] * 3, [r] * 3) for z, r in (("0.5", 0.95), ("1", 0.8), ("2", 0.8))}
    rows = [clipped(0, same | {"1.5": ([0.97] * 3, [0.6] * 3), "3": ([0.5] * 3, [0.5] * 3),
                               "inf": ([0.3] * 3, [0.3] * 3)}),
            clipped(1, {"0.5": ([0.95] * 3, [0.95] * 3), "1": ([0.95] * 3, [0.9] * 3), "2": ([0.95] * 3, [0.9] * 3),
                        "1.5": ([0.97] * 3, [0.6] * 3), "3": ([1.05] * 3, [0.6] * 3),
                        "inf": ([0.9] * 3, [1.5, 0.9, 0.9])})]
    names = study.clip_names(rows)
    assert names == ["Z=0.5", "Z=1", "Z=1.5", "Z=2", "Z=3", "Z=inf"]
    assert min(study.clip_gains(rows, "Z=3", [0, 1])[0].values()) > min(study.clip_gains(rows, "Z=2", [0, 1])[0].values())
    pooled, per_fold = study.clip_gains(rows, "Z=inf", [0, 1])
    assert pooled["n", "mems", 1] == pytest.approx(100 * (1 - np.sqrt((0.09 * 6 + 2.25 + 0.81 * 5) / 12)))
    assert pooled["n", "mems", 1] > study.clip_gains(rows, "Z=1", [0, 1])[0]["n", "mems", 1]
    assert per_fold["n", 1, "mems", 1] == pytest.approx(100 * (1 - np.sqrt((2.25 + 0.81 * 5) / 6)))
    assert per_fold["n", 1, "mems", 0] == pytest.approx(10.0)
    # p = 0 is the first window alone
    p0 = study.clip_gains(rows, "Z=inf", [0, 1], placement=0)[1]
    assert p0["n", 1, "mems", 1] == pytest.approx(-50.0) and p0["n", 0, "mems", 1] == pytest.approx(70.0)
    # the first key (beam cells counted too) keeps the unbounded completer and Z = 3 out; then the least pooled gain,
    # not the mean, and a tie to the larger Z
    assert study.choose(rows, [0, 1], names) == "Z=2"
    # without fold 1 nothing is worse and the larger pooled gain decides: fold 1 then pays for it
    assert study.choose(rows, [0], names) == "Z=inf"
    text = study.report(rows)
    fold1 = 100 * (1 - np.sqrt((2.25 + 0.81 * 5) / 6))
    assert "Chosen on all folds: Z = 2." in text and f"- fold 1: Z = inf -> {fold1:+.1f}; -50.0" in text
    # the command line names what it cannot use
    path = tmp_path / "rows.json"
    path.write_text(json.dumps([{k: v for k, v in row.items() if k != "nets"}]))
    for argv, said in ((["--report", str(path)], "rows without 'nets'"),
                       (["--report", str(tmp_path / "absent.json")], "absent.json: cannot read rows"),
                       (["--rows", str(path)], "--rows and --out are needed"),
                       (["--rows", str(path), "--out", str(tmp_path / "o.json"), "--z", "-1"], "bounds must be >= 0")):
        with pytest.raises(SystemExit):
            study.main(argv)
        assert said in capsys.readouterr().err


def test_run_setting_choice_over_draws_counts_a_fold_over_the_bound_in_any_draw(tmp_path, capsys):
    import sys
    from graphnav.nets.crossval import AKIT_FOLDS
    sys.path.insert(0, str(ROOT / "experiments"))
    study = _study("oracle_completions")
    from hybrid_imu_folds import save_runs
    names = [f"Trajectory{k}" for pair in AKIT_FOLDS for k in pair]
    first, each = f"{study.RECORDED}{study.TAU}3", study.RECORDED

    def write(path, scenario, ratios):
        """Runs whose window VRMSE is ``ratios[variant]`` (per trajectory) times Graph-TC's 1.0."""
        runs = {(n, "mems", 60.0, v): {"vrmse": [r(n)] * 2} for v, r in ratios.items() for n in names}
        save_runs(path, {"scenario": scenario, "max_windows": 2, "oracle_tau_pings": study.SERIAL_TAU_PINGS}, runs)
        return str(path)

    fold1 = set(f"Trajectory{k}" for k in AKIT_FOLDS[1])
    fold2 = set(f"Trajectory{k}" for k in AKIT_FOLDS[2])
    ref = tmp_path / "ref.json"
    save_runs(ref, {"scenario": "2-missing", "max_windows": 2},
              {(n, "mems", 60.0, m): [1.0, 1.0] for n in names for m in ("Graph-TC", "all beams", "Graph-HN")})
    # draw 1: screening once is better everywhere; draw 2: it puts fold 1 at 1.05x Graph-TC and fold 2 at the bound
    d1 = write(tmp_path / "d1.json", "2-missing", {first: lambda n: 0.8, each: lambda n: 0.9})
    d2 = write(tmp_path / "d2.json", "2-missing", {first: lambda n: 1.05 if n in fold1 else 1.02 if n in fold2 else 0.8,
                                                   each: lambda n: 0.9})
    one = study.choice_over_draws([[d1]], [str(ref)], [3.0], ["mems"], [60.0])
    assert "chosen on all folds: screen-first, tau 3 s" in one
    both = study.choice_over_draws([[d1], [d2]], [str(ref)], [3.0], ["mems"], [60.0])
    # 1 fold cell over 1.02x (draw 2, fold 1; fold 2 at 1.02x is not over) against none; the means
    # (0.8 + 0.894) / 2 and 0.9 are not read
    assert "screen-each: 0, 0.900; screen-first, tau 3 s: 1, 0.847" in both
    assert "chosen on all folds: screen-each" in both
    assert both.endswith("fold cells over 1.02x per draw: screen-each: 0, 0; screen-first, tau 3 s: 0, 1")
    # each setting's worst fold cell in each draw, and where it is (fold 0 on a tie: every fold at 0.9 or 0.8)
    assert ("worst fold cell per draw (ratio to Graph-TC, scenario, IMU, window, fold): screen-each: 0.900 (2-missing, mems, "
            "60 s, fold 0), 0.900 (2-missing, mems, 60 s, fold 0); screen-first, tau 3 s: 0.800 (2-missing, mems, "
            "60 s, fold 0), 1.050 (2-missing, mems, 60 s, fold 1)") in both
    # left out, fold 1 is chosen for by the other folds, where screening once never fails: it gets screen-first
    assert "fold 1: screen-first, tau 3 s" in both and "fold 0: screen-each" in both
    # out of fold: fold 1 at 1.05x, the other eight trajectories screened at each ping (0.9)
    assert "| 2-missing, draw 2 | mems | 60 | 0.93 (1.05) | 0.90, 1.05, 0.90, 0.90, 0.90 |" in both
    # with two scenarios the worst cell is looked for in both and named by its scenario
    ref3 = tmp_path / "ref3.json"
    save_runs(ref3, {"scenario": "3-missing", "max_windows": 2},
              {(n, "mems", 60.0, m): [1.0, 1.0] for n in names for m in ("Graph-TC", "all beams", "Graph-HN")})
    d1_3 = write(tmp_path / "d1_3.json", "3-missing", {first: lambda n: 1.04 if n in fold2 else 0.8,
                                                      each: lambda n: 0.9})
    two = study.choice_over_draws([[d1, d1_3]], [str(ref), str(ref3)], [3.0], ["mems"], [60.0])
    assert "screen-first, tau 3 s: 1.040 (3-missing, mems, 60 s, fold 2)" in two
    assert two.endswith("fold cells over 1.02x per draw: screen-each: 0; screen-first, tau 3 s: 1")
    # the same fold cell known only as a count of a draw whose runs were not kept
    counted = study.choice_over_draws([[d1]], [str(ref)], [3.0], ["mems"], [60.0], recorded=["3@1"])
    assert "screen-each: 0, 0.900; screen-first, tau 3 s: 1, 0.800" in counted
    assert "chosen on all folds: screen-each" in counted and "fold 1: screen-first, tau 3 s" in counted
    assert counted.endswith("screen-first, tau 3 s: 0 (recorded: folds 1)")
    for bad in (["3@7"], ["4@1"], ["3"]):
        with pytest.raises(SystemExit, match="SETTING@FOLD"):
            study.choice_over_draws([[d1]], [str(ref)], [3.0], ["mems"], [60.0], recorded=bad)
    with pytest.raises(SystemExit, match="a second 2-missing file in draw 1"):
        study.choice_over_draws([[d1, d2]], [str(ref)], [3.0], ["mems"], [60.0])
    with pytest.raises(SystemExit):                      # the command needs the settings to choose from
        study.main(["--over-draws", d1, "--references", str(ref)])
    with pytest.raises(SystemExit, match="runs the choice reads are not there"):     # a study not finished
        study.choice_over_draws([[d1]], [str(ref)], [3.0, 10.0], ["mems"], [60.0])
    with pytest.raises(SystemExit, match="no --references file for scenario 3-missing"):
        study.choice_over_draws([[write(tmp_path / "d3.json", "3-missing", {each: lambda n: 1.0})]], [str(ref)],
                                [3.0], ["mems"], [60.0])
    # the anchored screening as a further candidate: read only when asked for, and missing runs named
    anchored = f"{study.RECORDED}{study.ANCHORED}"
    d1_a = write(tmp_path / "d1a.json", "2-missing", {first: lambda n: 0.8, each: lambda n: 0.9,
                                                      anchored: lambda n: 1.03 if n in fold1 else 0.85})
    assert "anchored" not in study.choice_over_draws([[d1_a]], [str(ref)], [3.0], ["mems"], [60.0])
    with_anchored = study.choice_over_draws([[d1_a]], [str(ref)], [3.0], ["mems"], [60.0], anchored=True)
    assert with_anchored.endswith("screen-first, tau 3 s: 0; screen-each, anchored: 1")
    assert "screen-each, anchored: 1, 0.886" in with_anchored      # (8 x 0.85 + 2 x 1.03) / 10 pooled
    counted = study.choice_over_draws([[d1_a]], [str(ref)], [3.0], ["mems"], [60.0], recorded=["anchored@2"],
                                      anchored=True)
    assert counted.endswith("screen-each, anchored: 1 (recorded: folds 2)")
    assert "screen-each, anchored: 2, 0.886" in counted
    with pytest.raises(SystemExit, match="SETTING@FOLD"):           # not a candidate unless asked for
        study.choice_over_draws([[d1_a]], [str(ref)], [3.0], ["mems"], [60.0], recorded=["anchored@2"])
    with pytest.raises(SystemExit, match="--anchored"):
        study.choice_over_draws([[d1]], [str(ref)], [3.0], ["mems"], [60.0], anchored=True)
    with pytest.raises(SystemExit):                      # a total outage: the prediction also steers the motion prior
        study.main(["--scenario", "0-beams", "--anchored", "--reference", str(ref), "--out", str(tmp_path / "o.json")])
    assert "--anchored with a total outage" in capsys.readouterr().err and not (tmp_path / "o.json").exists()
    (tmp_path / "notes.json").write_text('{"rows": []}')
    with pytest.raises(SystemExit, match="notes.json is not a results file"):
        study.choice_over_draws([[d1]], [str(tmp_path / "notes.json")], [3.0], ["mems"], [60.0])


def test_count_change_stress_keeps_the_pair_out_and_flickers_the_fourth_beam_the_same_way_each_run():
    study = _study("count_change_runs")
    t = np.arange(0.0, 400.0, 1.0)
    starts = [60.0, 240.0]
    mask = study.stress_mask(t, starts, 120.0, "Trajectory6")
    inside = ((t >= 60) & (t < 180)) | ((t >= 240) & (t < 360))
    assert mask[inside][:, [0, 2]].all() and not mask[inside][:, 1].any()
    assert not mask[~inside].any()
    measured = 4 - mask[inside].sum(axis=1)
    # both counts occur, beam 4 out about half the time (p_drop = p_recover), in runs of several pings
    assert set(measured) == {1, 2} and 0.3 < np.mean(measured == 1) < 0.7
    flips = np.count_nonzero(np.diff(mask[(t >= 60) & (t < 180), 3].astype(int)))
    assert 3 <= flips <= 40
    # seeded by the trajectory and the window: every run the same pattern, each trajectory and window its own
    assert np.array_equal(mask, study.stress_mask(t, starts, 120.0, "Trajectory6"))
    other = study.stress_mask(t, starts, 120.0, "Trajectory13")
    assert np.array_equal(other[:, [0, 1, 2]], mask[:, [0, 1, 2]]) and not np.array_equal(other[:, 3], mask[:, 3])
    assert not np.array_equal(mask[60:180, 3], mask[240:360, 3])
    assert study.variant_options("HNI shipped") is None and study.variant_options("HNI restart") is None
    assert study.variant_options("HNI tau 10") == {"regressed_error_tau_s": 10.0}
    assert study.variant_options("HNI independent") == {"regressed_error_tau_s": None}
    assert study.variant_options("HNI each ping") == {"regressed_runs": "screen-each", "regressed_error_tau_s": None}
    with pytest.raises(ValueError, match="unknown variant"):
        study.variant_options("HNI sometimes")


def test_count_change_report_counts_fold_cells_over_the_bound_in_each_draw(tmp_path):
    import sys
    from graphnav.nets.crossval import AKIT_FOLDS
    sys.path.insert(0, str(ROOT / "experiments"))
    study = _study("count_change_runs")
    from hybrid_imu_folds import save_runs
    names = [f"Trajectory{k}" for pair in AKIT_FOLDS for k in pair]
    fold3 = {f"Trajectory{k}" for k in AKIT_FOLDS[3]}

    def runs(hni_in_fold3):
        out = {(n, "mems", 120.0, "Graph-TC"): {"vrmse": [0.2, 0.2]} for n in names}
        out.update({(n, "mems", 120.0, "HNI shipped"): {"vrmse": [0.2 * (hni_in_fold3 if n in fold3 else 0.5)] * 2,
                                                          "continued_pings": 3, "changes_in_runs": 1,
                                                          "one_measured": 0.5} for n in names})
        return out
    first, second = runs(0.9), runs(1.03)
    table = study.report(first, ["mems"], [120.0], ["Graph-TC", "HNI shipped"])
    # pooled: (8 x 0.5 + 2 x 0.9) / 10 = 0.58; worst fold 0.90
    assert "| mems | 120 | 0.200 | 0.58 (0.90) |" in table
    assert "fold cells over 1.02x Graph-TC (of 5): HNI shipped: 0" in table
    assert table.endswith("pings with one measured beam inside the windows: 0.50\n"
                          "HNI shipped: pings continuing a run 30, of them after a change of measured beams 10")
    paths = []
    for k, r in enumerate((first, second)):
        paths.append(str(tmp_path / f"d{k}.json"))
        save_runs(Path(paths[-1]), {"max_windows": 2}, r)
    summary = study.over_draws(paths, ["mems"], [120.0])
    assert "| HNI shipped | 0, 1 | 0.900, 1.030 | 0.58-0.61 |" in summary


def test_count_change_stress_puts_the_pivot_completer_in_the_beam_only_networks_place(tmp_path):
    """``--beam-nets pivot pivot``: the fold's IMU-aware networks of both patterns fused with one pivot completer
    fitted online for the mission's sensors, with the correlation measured for that pair; half a pivot refused."""
    import shutil
    import sys

    from graphnav.core.config import SensorConfig
    from graphnav.nets.pivot import PivotCompleter
    sys.path.insert(0, str(ROOT / "experiments"))
    study = _study("count_change_runs")
    from hybrid_imu_folds import IMU_PIVOT_ERROR_CORRELATION
    dirs = []
    for scenario in ("2-missing", "3-missing"):
        dirs.append(tmp_path / scenario)
        (dirs[-1] / "fold1").mkdir(parents=True)
        for suffix in ("pt", "json"):
            shutil.copy(ROOT / "nets" / "weights" / f"imu-{scenario}.{suffix}", dirs[-1] / "fold1")
    config = SensorConfig()
    pair = study.fold_completer(dirs, ("pivot", "pivot"), 1, config)
    assert sorted(len(missing) for missing in pair.networks) == [2, 3]
    assert isinstance(pair.fused_beam_only, PivotCompleter) and pair.fused_beam_only.pivot_m is None
    assert pair.beam_correlation == IMU_PIVOT_ERROR_CORRELATION
    assert pair.fused_beam_only.axes == ("yaw",)                          # as Graph-HNP runs it
    from graphnav.nets.pivot import DEFAULT_AXES, DEFAULT_N_PAST
    pitch_pair = study.fold_completer(dirs, ("pivot-pitch", "pivot-pitch"), 1, config)
    assert pitch_pair.fused_beam_only.axes == DEFAULT_AXES and pitch_pair.fused_beam_only.pivot_m is None
    assert pitch_pair.fused_beam_only.n_past == DEFAULT_N_PAST["2-missing"]
    for half in (("pivot", str(tmp_path)), ("pivot", "pivot-pitch"), (str(tmp_path), "pivot-pitch")):
        with pytest.raises(SystemExit, match="for both patterns or none"):
            study.fold_completer(dirs, half, 1, config)
    with pytest.raises(SystemExit) as refused:       # refused before any run starts
        study.main(["--imu-nets", *map(str, dirs), "--beam-nets", "pivot", str(tmp_path), "--variants", "Graph-TC",
                    "HNI shipped", "--out", str(tmp_path / "c.json")])
    assert refused.value.code == 2 and not (tmp_path / "c.json").exists()


def test_run_counter_counts_continued_pings_after_a_change_and_restart_ends_the_runs():
    from types import SimpleNamespace
    study = _study("count_change_runs")

    def original(kf, builder, m, sel, omega_b, use_d):
        """continue_regressed_runs reduced to its bookkeeping: a regressed row continues if its beam has a link."""
        chained = np.array([int(i) in builder.regressed_links for i in sel], dtype=bool)
        builder.regressed_links = {int(i): "link" for i in sel}
        return sel[~chained], sel[chained], [], {}

    def run(restart):
        counter, builder = study.RunCounter(original, restart), SimpleNamespace(regressed_links={})
        left = []
        # pings: two beams regressed with two measured, then with one measured (beam 3 lost), then two again
        for regressed in ([1, 0, 1, 0], [1, 0, 1, 0], [1, 0, 1, 1], [1, 0, 1, 1], [1, 0, 1, 0]):
            m = SimpleNamespace(regressed=np.array(regressed, dtype=bool))
            left.append(len(counter(None, builder, m, np.flatnonzero(m.regressed), None, False)[0]))
        return counter.counts, left
    counts, left = run(restart=False)
    # continued at pings 2-5; pings 3 and 5 follow a change of the measured count (2 -> 1, 1 -> 2)
    assert counts == {"continued_pings": 4, "changes_in_runs": 2}
    assert left == [2, 0, 1, 0, 0]                     # ping 3: only the newly lost beam meets the screening
    counts, left = run(restart=True)
    # a change ends every run: pings 3 and 5 screen all their regressed beams, nothing continues across a change
    assert counts == {"continued_pings": 2, "changes_in_runs": 0}
    assert left == [2, 0, 3, 0, 2]


class _TrueBeams:
    """A completer that fills missing beams with the true beams plus a constant offset (m/s), stated sigma
    ``sigma``: the graph keeps its completions, so its own prediction through an outage is pulled by them."""

    drift_std = 0.0

    def __init__(self, mission, offset=0.05, sigma=0.03):
        from graphnav.core.dvl import DvlGeometry
        self.n_past, self.sigma = 3, sigma
        state = mission.meta["trajectory"].state(mission.dvl.t)
        truth = DvlGeometry.from_spec(mission.config.dvl).beams_from_velocity(state.v_b, state.omega_nb_b) + offset
        self._by_measured = {tuple(np.round(b[v], 12)): tr for b, v, tr in zip(mission.dvl.beams, mission.dvl.valid,
                                                                                truth)}

    def complete(self, past, measured):
        valid = np.isfinite(measured)
        return (np.where(valid, measured, self._by_measured[tuple(np.round(measured[valid], 12))]),
                np.where(valid, 0.0, self.sigma))


def test_anchored_screening_hands_the_hybrid_the_prediction_of_the_graph_without_completions():
    """``oracle_completions.py --anchored``: the twin (Graph-TC on the same run) predicts every keyframe after the
    first; through an outage whose completions the hybrid keeps, the hybrid's own prediction is sharper than the
    twin's (the completions pulled it), and screening against the twin changes the run. Handed its own predictions
    instead, the hybrid runs to the bit as without the context, which counts the keyframes it served."""
    from graphnav.core.scenarios import scenario_outage
    from graphnav.estimators.graph import incremental
    from graphnav.evaluation.methods import run_method
    from graphnav.sim.simulate import simulate_mission
    study = _study("oracle_completions")
    m = simulate_mission(90, imu_grade="tactical", seed=3).with_outage(scenario_outage("2-missing", 30.0, 50.0))
    comp = _TrueBeams(m)
    twin = study.twin_predictions(m, "2-missing")
    n_keyframes = len(m.dvl.t)
    assert len(twin) >= n_keyframes - 2 and all(p.cov_v_n.shape == (3, 3) for p in twin.values())

    own: dict = {}
    original = incremental._IncrementalGraph._prediction

    def record(self, kf, v_n_pred, bias):
        prediction = original(self, kf, v_n_pred, bias)
        if prediction is not None:
            own[kf.t] = prediction
        return prediction
    incremental._IncrementalGraph._prediction = record
    try:
        plain = run_method(m, "Graph-HN", "2-missing", completer=comp)
    finally:
        incremental._IncrementalGraph._prediction = original
    kept = plain.info["regressed_screening"]["entered"]
    assert kept > 10                                   # the completions are good: the screening keeps them
    late = [t for t in own if 70.0 < t < 80.0]
    assert late and all(np.trace(own[t].cov_v_n) < 0.8 * np.trace(twin[t].cov_v_n) for t in late)

    with study.screened_against(None) as count:
        same = run_method(m, "Graph-HN", "2-missing", completer=comp)
    np.testing.assert_array_equal(same.v_n, plain.v_n)
    assert count == [0]
    with study.screened_against(own) as count:
        mirrored = run_method(m, "Graph-HN", "2-missing", completer=comp)
    np.testing.assert_array_equal(mirrored.v_n, plain.v_n)
    assert count[0] == len(own)                       # every screened keyframe was served from the dict
    with study.screened_against(twin) as count:
        anchored = run_method(m, "Graph-HN", "2-missing", completer=comp)
    assert count[0] == len(own)
    assert np.abs(anchored.v_n - plain.v_n).max() > 1e-4
    assert incremental.keyframe_factors.__module__ == "graphnav.estimators.graph.builder"   # the context undone


def test_a_fold_network_for_total_outages_is_found_loaded_and_serves_pings_without_a_measured_beam(tmp_path, akit_dir):
    """``oracle_completions.py --record DIR`` in a total outage: a fold whose folder holds a network for pings without
    a measured beam (``imu_completer_folds.py --missing 0-beams --save-nets``) runs it, the others keep the average
    fallback. A network trained for one epoch on one trajectory is saved, found in its fold only, loaded back from
    its card, and completes a ping with no beam measured through the IMU-aware route (no fallback)."""
    from dataclasses import replace

    from graphnav.nets.imu_recipes import IMU_RECIPES
    from graphnav.nets.imu_training import train_imu
    from graphnav.nets.training import save
    study = _study("oracle_completions")
    folds = _study("hybrid_imu_folds")
    opt = replace(IMU_RECIPES["graded"], epochs=1, rollout_epochs=1, draws=1, sigma_epochs=1, imu_grades=())
    result = train_imu("0-beams", opt, akit_dir, progress=False, evaluate=False, trajectories=(2,))
    save(result, tmp_path / "fold1")
    assert study.total_outage_network(tmp_path, 1) and not study.total_outage_network(tmp_path, 0)

    comp = folds.completer("HNI fold", "0-beams", str(tmp_path), 1, None, 0.04)
    net = comp.networks[(0, 1, 2, 3)]
    rng = np.random.default_rng(0)
    past = np.tile([1.1, 0.3, -0.9, 0.2], (comp.n_past, 1)) + 0.01 * rng.standard_normal((comp.n_past, 4))
    imu = (np.tile([0.0, 0.0, -9.81], (net.imu_samples, 1)), np.zeros((net.imu_samples, 3)))
    beams, sigma = comp.complete(past, np.full(4, np.nan), imu=imu)
    assert comp.usage == {"imu": 1, "no_imu": 0, "pattern": 0}
    assert beams.shape == sigma.shape == (4,) and np.all(np.isfinite(beams)) and np.all(sigma > 0)
    # a vehicle at rest in the IMU window with its past beams steady: the completion stays near them
    np.testing.assert_allclose(beams, past[-1], atol=0.3)



def test_the_position_study_reads_the_error_during_and_after_the_outage_less_the_start():
    """A track 2 m north of the truth before an outage over [10, 40] s, 0.1 m/s more through it, 1 m more after."""
    import types
    study = _study("outage_position_drift")
    t = np.arange(0.0, 100.0, 0.5)
    north = 2.0 + np.where(t < 10.0, 0.0, np.where(t <= 40.0, 0.1 * (t - 10.0), 1.0))
    sol = types.SimpleNamespace(t=t, p_n=np.stack([north, np.zeros_like(t), np.zeros_like(t)], axis=-1))
    gt = types.SimpleNamespace(t=t, at=lambda s: (np.zeros((len(np.atleast_1d(s)), 3)),) * 2 + (None,))
    np.testing.assert_allclose(study.horizontal_error(sol, gt, np.array([5.0, 40.0])), [[2.0, 0.0], [5.0, 0.0]])
    got = study.position_metrics(sol, gt, 10.0, 30.0)
    last = 0.1 * np.arange(20.0, 30.0 + 1e-9, 0.5)          # the outage's last 10 s, less the start's 2 m
    assert got["end 10 s"] == pytest.approx(float(np.sqrt(np.mean(last ** 2))))
    assert got["after 20-40 s"] == pytest.approx(1.0)


def test_the_position_study_names_its_runs_and_chooses_on_both_readings():
    """Run labels resolve to the registry method and its options (the retirement suffixes outermost); the choice
    counts fold cells over 1.02x Graph-TC in the velocity and in the position after the outage, picks on all folds
    and with each fold left out, and refuses to choose with a fold cell missing."""
    study = _study("outage_position_drift")
    assert study.variant_run("Graph-HNP tau 0 kept") == ("Graph-HNP", {"regressed_runs": "screen-first",
                                                                       "regressed_error_tau_s": None,
                                                                       "retire_completions": False})
    assert study.variant_run("Graph-HNI each ping retired") == ("Graph-HNI", {"regressed_runs": "screen-each",
                                                                               "regressed_error_tau_s": None,
                                                                               "retire_completions": True})
    assert study.variant_run("Graph-TC relinearised 20") == ("Graph-TC", {"relin_window_s": 20.0,
                                                                          "relinearize_skip": 1})
    assert study.variant_run("Graph-HNP prior 0.01") == ("Graph-HNP", None)      # a completer setting, no graph one
    assert study.variant_run("Graph-HNP measured-sigma 1.5 kept") == ("Graph-HNP", {"retire_completions": False})
    assert study.variant_run("Graph-HN measured-sigma") == ("Graph-HN", None)
    assert study.variant_run("Graph-HNP measured-both 0.5") == ("Graph-HNP", {"measured_both_margin": 0.5})
    assert study.variant_run("Graph-HNP measured-both 2 kept") == ("Graph-HNP", {"measured_both_margin": 2.0,
                                                                                 "retire_completions": False})
    # both errors read against the outage's: the smaller read is the smaller actual one in 2 of the 3 windows
    both = [{"s graph": g, "act graph": ag, "s comp": c, "act comp": ac, "kept": k}
            for g, ag, c, ac, k in ((0.02, 0.01, 0.06, 0.07, 0.0), (0.05, 0.04, 0.03, 0.02, 1.0),
                                    (0.08, 0.09, 0.06, 0.10, 0.5))]
    runs = {(f"Trajectory{k}", "mems", "2-missing", 60.0): {"Graph-HNP measured-both 1": [{"both": b}]}
            for k, b in zip((1, 2, 3), both)}
    table = study.both_errors_report(runs, ["Graph-TC", "Graph-HNP measured-both 1"], [(1, 2), (3, 4)])
    assert "| Graph-HNP measured-both 1 | all | 3 | 0.99 | 0.93 | 67% | 50% |" in table
    assert study.variant_run("Graph-HNP tau 10 rehearsed 0.5") == ("Graph-HNP", {"regressed_runs": "screen-first",
                                                                                 "regressed_error_tau_s": 10.0,
                                                                                 "rehearsed_outages": 0.5})
    assert study.pivot_prior("Graph-HNP prior 0.01") == 0.01 and study.pivot_prior("Graph-HNP tau 3") is None
    assert study.variant_run("Graph-HNP rehearsed 1 twin correlated") == ("Graph-HNP", {
        "rehearsed_outages": 1.0, "rehearsal_graph": "twin", "rehearsal_fusion": "correlated"})
    # the rehearsals' choice scored against the outage: right when the smaller rehearsed error was the smaller one
    window = {"predicted": [{"pred comp": 0.1, "pred graph": 0.2, "act comp": 0.05, "act graph": 0.04,
                             "beam sigma": 0.0}, {"pred comp": 0.3, "pred graph": 0.2, "act comp": 0.1,
                                                  "act graph": 0.2, "beam sigma": 0.0}]}
    table = study.predictiveness_report({("Trajectory1", "mems", "0-beams", 60.0): {"Graph-HNP rehearsed 1": [window]}},
                                        ["Graph-HNP rehearsed 1"], [(1, 2)])
    assert "| Graph-HNP rehearsed 1 | mems | 0-beams | 2 | 0% | 0% | 50% / 50% | 2.50 (2.50) | 3.00 (3.00) |" in table
    # with the other suffixes, on either side of them
    assert study.variant_run("Graph-HNP prior 0.01 kept") == ("Graph-HNP", {"retire_completions": False})
    assert study.pivot_prior("Graph-HNP prior 1e-2 kept") == 0.01
    assert study.variant_run("Graph-HNP prior 0.3 tau 3") == study.variant_run("Graph-HNP tau 3 prior 0.3")
    assert study.pivot_prior("Graph-HNP tau 3 prior 0.3") == study.pivot_prior("Graph-HNP prior 0.3 tau 3") == 0.3
    assert study.other_retirement("Graph-HNP prior 0.01") == "Graph-HNP prior 0.01 kept"
    study.check_pivot_setting("Graph-HNP prior 0.01 kept")
    with pytest.raises(ValueError, match="Graph-HNI does not run"):
        study.check_pivot_setting("Graph-HNI prior 0.1")
    # the pivot completer's turn axes: a completer setting too, beside the others
    assert study.variant_run("Graph-HNP axes yaw+pitch kept") == ("Graph-HNP", {"retire_completions": False})
    assert study.pivot_axes("Graph-HNP axes yaw+pitch") == ("yaw", "pitch")
    assert study.pivot_axes("Graph-HNP axes yaw") == ("yaw",) and study.pivot_axes("Graph-HNP prior 0.1") is None
    assert study.pivot_axes("Graph-HNP prior 0.3 axes yaw+pitch") == ("yaw", "pitch")
    assert study.pivot_prior("Graph-HNP prior 0.3 axes yaw+pitch") == 0.3
    assert study.pivot_setting("Graph-HNP axes yaw") and not study.pivot_setting("Graph-HNP tau 3")
    with pytest.raises(ValueError, match="axes is a setting of the pivot completer, which Graph-HN does not"):
        study.check_pivot_setting("Graph-HN axes yaw+pitch")
    from graphnav.core.errors import ConfigError
    with pytest.raises(ConfigError, match="axes"):
        study.pivot_axes("Graph-HNP axes pitch")
    assert study.other_retirement("Graph-HN") == "Graph-HN kept"
    assert study.other_retirement("Graph-HN kept") == "Graph-HN kept retired"
    assert study.other_retirement("Graph-TC") is None
    assert study.resolved_options("Graph-HN")["retire_completions"] is True
    assert study.resolved_options("Graph-HN kept")["retire_completions"] is False
    folds = [(1, 3), (2, 5), (4, 10), (6, 13), (8, 11)]

    def window(v, after):
        return {"vrmse": v, "after 20-40 s": after, "end 10 s": 1.0, "bench": 1.0}
    runs = {}
    for pair in folds:
        for k in pair:
            for cell in (("mems", "3-missing", 120.0), ("tactical", "3-missing", 120.0)):
                worse = 1.10 if pair == (6, 13) and cell[0] == "mems" else 1.0
                runs[(f"Trajectory{k}", *cell)] = {"Graph-TC": [window(1.0, 5.0)], "A": [window(0.9, 5.0 * worse)],
                                                   "B": [window(0.95, 5.0)]}
    text = study.choice(runs, ["A", "B"], folds)
    assert "| A | 0 / 1 of 10 |" in text and "| B | 0 / 0 of 10 |" in text and "chosen on all folds: B" in text
    # against another reference (a batch against Graph-TC-batch): A's harmed fold over B in the position after, where
    # pooled over the five folds A is (4 * 5 + 5.5) / 25 = 1.02x B
    table = study.against_reference(runs, ["A"], "B", folds)
    assert "| A | vrmse | 0 of 10 | 0.947-0.947 | 0.947-0.947 |" in table
    assert "| A | after 20-40 s | 1 of 10 | 1.000-1.100 | 1.000-1.020 |" in table
    # with the fold that harms A left out, the other four prefer A's lower mean ratio
    assert "fold 3 left out: A; its worst cell 0.900x in velocity, 1.100x in the position after" in text
    del runs[("Trajectory13", "mems", "3-missing", 120.0)]
    del runs[("Trajectory6", "mems", "3-missing", 120.0)]
    assert study.choice(runs, ["A", "B"], folds).startswith("not chosen")


def test_the_position_study_runs_the_imu_aware_methods_on_each_trajectorys_own_fold_networks(tmp_path, capsys):
    """``Graph-HNI`` (any run of it) needs fold networks wherever a beam is measured, not in a total outage nor for
    another method; with them a trajectory gets its fold's IMU-aware network fused with its fold's beam-only one, and
    without them for a scenario that needs them the study refuses to start; networks whose cards do not say the
    trajectory was held out are refused; the beam-only network's methods run the fold's beam-only ensemble. ``--over-draws`` keeps the draws' cells apart and refuses draws of other runs or
    settings, or of the same networks."""
    import shutil
    import sys
    import types

    from graphnav.core.config import SensorConfig
    from graphnav.core.errors import ConfigError
    study = _study("outage_position_drift")
    sys.path.insert(0, str(ROOT / "experiments"))      # the studies import their siblings
    assert study.needs_fold_nets("Graph-HNI retired", "3-missing")
    assert study.needs_fold_nets("Graph-HNI-batch", "2-missing")
    assert not study.needs_fold_nets("Graph-HNI", "0-beams")
    assert not study.needs_fold_nets("Graph-HN", "3-missing")
    assert study.needs_fold_nets("Graph-HN-net", "2-missing")               # the beam-only network too
    imu_dir, beam_dir = tmp_path / "imu", tmp_path / "beam"
    for folder, prefix in ((imu_dir, "imu-"), (beam_dir, "")):
        (folder / "fold2").mkdir(parents=True)
        for suffix in ("pt", "json"):
            shutil.copy(ROOT / "nets" / "weights" / f"{prefix}3-missing.{suffix}", folder / "fold2")
    mission = types.SimpleNamespace(config=SensorConfig())
    fold_nets = {"3-missing": [str(imu_dir), str(beam_dir)]}
    # the shipped networks were trained on every trajectory: their cards refuse to score trajectory 4 (fold 2)
    with pytest.raises(SystemExit, match=r"beam/fold2 \(3-missing\): the card names neither"):
        study.fold_completer("Graph-HNI", "3-missing", fold_nets, 2, mission, 4)
    beam_card = beam_dir / "fold2" / "3-missing.json"
    beam_card.write_text(json.dumps({**json.loads(beam_card.read_text()), "data": {"held_out": [4, 10]}}))
    with pytest.raises(SystemExit, match=r"imu/fold2 \(3-missing\): trained on trajectory 4"):
        study.fold_completer("Graph-HNI", "3-missing", fold_nets, 2, mission, 4)
    imu_card = imu_dir / "fold2" / "imu-3-missing.json"
    imu_card.write_text(json.dumps({**json.loads(imu_card.read_text()),
                                    "split": {"train_trajectories": [1, 2, 3, 5, 6, 8, 11, 13]}}))
    with pytest.raises(SystemExit, match="trained on trajectory 6"):
        study.fold_completer("Graph-HNI", "3-missing", fold_nets, 2, mission, 6)
    comp = study.fold_completer("Graph-HNI kept", "3-missing", fold_nets, 2, mission, 4)
    assert [len(missing) for missing in comp.networks] == [3]             # the 3-missing network
    assert comp.fused_beam_only is not None and comp.beam_only is not comp.fused_beam_only
    # one pattern per fold completer: its outages can be rehearsed (--hni-rehearsed), its one beam measured
    assert callable(comp.rehearse) and comp.rehearsal_measured.sum() == 1
    assert study.fold_completer("Graph-HNI", "0-beams", fold_nets, 2, mission, 4) is None
    assert study.fold_completer("Graph-HN", "3-missing", fold_nets, 2, mission, 4) is None
    with pytest.raises(ConfigError, match="fold1"):                      # fold 1 has no networks here
        study.fold_completer("Graph-HNI", "3-missing", fold_nets, 1, mission, 2)
    beam_only = study.fold_completer("Graph-HN-net", "3-missing", fold_nets, 2, mission, 10)
    assert beam_only.n_past and not hasattr(beam_only, "networks")          # the fold's beam-only ensemble alone
    # the pivot completer in the beam-only networks' place: nothing trained to check on it, the network still checked
    from graphnav.nets.pivot import PivotCompleter
    pivot_nets = {"3-missing": [str(imu_dir), "pivot"]}
    pair = study.fold_completer("Graph-HNI", "3-missing", pivot_nets, 2, mission, 4)
    assert isinstance(pair.fused_beam_only, PivotCompleter) and pair.fused_beam_only.pivot_m is None
    with pytest.raises(SystemExit, match="trained on trajectory 6"):
        study.fold_completer("Graph-HNI", "3-missing", pivot_nets, 2, mission, 6)
    with pytest.raises(SystemExit, match="fused pair only"):
        study.fold_completer("Graph-HN-net", "3-missing", pivot_nets, 2, mission, 4)
    # 'pivot' is the pivot completer as Graph-HNP runs it (the yaw alone), 'pivot-pitch' with its own defaults
    from graphnav.nets.pivot import DEFAULT_AXES, DEFAULT_N_PAST
    assert pair.fused_beam_only.axes == ("yaw",)
    for scenario in ("3-missing", "0-beams"):
        pitch_pair = study.fold_completer("Graph-HNI", scenario, {scenario: [str(imu_dir), "pivot-pitch"]}, 2, mission,
                                          4)
        assert pitch_pair.fused_beam_only.axes == DEFAULT_AXES and pitch_pair.fused_beam_only.pivot_m is None
        assert pitch_pair.fused_beam_only.n_past == DEFAULT_N_PAST[scenario]
    with pytest.raises(SystemExit, match="'pivot-pitch' stands in for the beam-only networks of the fused pair only"):
        study.fold_completer("Graph-HN-net", "3-missing", {"3-missing": [str(imu_dir), "pivot-pitch"]}, 2, mission, 4)
    # refused before any run starts: the pivot for a beam-only network's method, a prior for a method without it
    for argv, refusal in ((["--methods", "Graph-TC", "Graph-HN-net", "--fold-nets", "3-missing", str(imu_dir), "pivot"],
                           "fused pair only"),
                          (["--methods", "Graph-TC", "Graph-HNI prior 0.1", "--fold-nets", "3-missing", str(imu_dir),
                            "pivot"], "Graph-HNI does not run")):
        with pytest.raises(SystemExit) as refused:
            study.main(argv + ["--scenarios", "3-missing", "--out", str(tmp_path / "p.json")])
        assert refused.value.code == 2 and refusal in capsys.readouterr().err
    assert not (tmp_path / "p.json").exists()
    # in a total outage the pair runs too (its pivot member serves, with that outage's past pings)
    total = study.fold_completer("Graph-HNI", "0-beams", {"0-beams": [str(imu_dir), "pivot"]}, 2, mission, 4)
    assert isinstance(total.beam_only, PivotCompleter) and total.beam_only.n_past == 5
    assert study.fold_completer("Graph-HNP", "0-beams", {"0-beams": [str(imu_dir), "pivot"]}, 2, mission, 4) is None
    with pytest.raises(SystemExit) as refused:
        study.main(["--methods", "Graph-TC", "Graph-HNI", "--scenarios", "3-missing", "--out", str(tmp_path / "o.json")])
    assert refused.value.code == 2 and "--fold-nets 3-missing" in capsys.readouterr().err
    # every trajectory runs the networks of the fold that holds it out
    options = types.SimpleNamespace(grades=["mems"], scenarios=["3-missing"], window_s=[120.0], max_windows=2,
                                    methods=["Graph-TC", "Graph-HNI"], backend="isam2", predictiveness=False)
    folds = [(1, 3), (2, 5), (4, 10), (6, 13), (8, 11)]
    sources = {f"Trajectory{k}": k for pair in folds for k in pair}
    items = study.study_items(sources, options, fold_nets, {("Trajectory5", "mems", "3-missing", 120.0): {}}, folds)
    assert {item[0]: item[-1] for item in items} == {1: 0, 3: 0, 2: 1, 4: 2, 10: 2, 6: 3, 13: 3, 8: 4, 11: 4}

    # two training draws' files: the second draw's cells are told apart, so the rule counts the fold cells of both
    from hybrid_imu_folds import save_runs
    key = ("Trajectory6", "mems", "3-missing", 120.0)
    window = {"vrmse": 1.0, "after 20-40 s": 2.0, "end 10 s": 1.0, "bench": 1.0}
    both = ["Graph-TC", "Graph-HNI"]
    for name, methods, backend, nets in (("a", both, "isam2", "n1"), ("b", both, "isam2", "n2"),
                                         ("c", ["Graph-TC"], "isam2", "n3"), ("d", both, "fixed-lag", "n4"),
                                         ("e", both, "isam2", "n1")):
        save_runs(tmp_path / f"{name}.json", {"methods": methods, "backend": backend, "fold_nets": nets},
                  {key: {m: [window] for m in methods}})
    runs, methods = study.runs_over_draws([tmp_path / "a.json", tmp_path / "b.json"])
    assert methods == both
    assert sorted(runs) == [key, ("Trajectory6", "mems", "3-missing@1", 120.0)]
    with pytest.raises(SystemExit, match="methods"):
        study.runs_over_draws([tmp_path / "a.json", tmp_path / "c.json"])
    with pytest.raises(SystemExit, match="backend"):
        study.runs_over_draws([tmp_path / "a.json", tmp_path / "d.json"])
    with pytest.raises(SystemExit, match="same fold networks"):
        study.runs_over_draws([tmp_path / "a.json", tmp_path / "e.json"])


def test_the_pivot_completer_stands_in_for_the_beam_only_networks_in_the_fused_studies(tmp_path):
    """``--beam-nets pivot``: per ping the pivot completer is run from each usable ping's true past with the IMU
    window ending at the ping (the pings the IMU-aware network is scored on), the rows name it ``pivot``, and the
    regime study's ``HNI fold fused`` fuses the fold's IMU-aware network with a pivot completer fitted online that
    also serves the pings the network cannot, with the correlation measured for that pair."""
    import shutil

    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.imu_data import ImuBeamSeries, imu_windows
    from graphnav.nets.pivot import PivotCompleter
    fused = _study("imu_beam_fused_folds")
    assert fused.member_label("pivot") == "pivot" and fused.member_label("out/ens2/x") == "beam-only, fading"
    assert fused.member_label("pivot-pitch") == "pivot-pitch"
    assert fused.variants("pivot")[1] == "pivot" and fused.variants("beam-only, fading") == fused.VARIANTS
    assert fused.row_variants([{"variant": "IMU mems, pivot"}, {"variant": "IMU mems, fused, rho 0"},
                               {"variant": "IMU recorded, pivot"}]) == ["pivot", "fused, rho 0"]

    rng = np.random.default_rng(3)
    geometry = DvlGeometry.from_spec(DvlSpec())
    n, per_ping = 16, 100
    v_b = np.array([1.5, 0.0, 0.1]) + 0.05 * rng.standard_normal((n, 3))
    omega = np.zeros((n * per_ping, 3))
    omega[:, 2] = 0.1 * np.sin(np.arange(n * per_ping) / 300.0)         # turning to and fro
    series = [ImuBeamSeries("s", np.arange(n, dtype=float), v_b, v_b @ geometry.T_b.T,
                            np.tile([0.0, 0.0, -9.8], (n * per_ping, 1)), omega,
                            np.arange(n) * per_ping + per_ping - 1)]
    pivot = PivotCompleter(geometry.T_b, geometry.lever_arm_b, 3.6, n_past=3)
    n_imu = 800                                                          # longer than the pivot's own 400
    full, sigma = fused.predict_with_imu(pivot, series, 5, n_imu, (0, 2))
    samples = imu_windows(series, 5, n_imu)
    assert full.shape == sigma.shape == samples.beams.shape
    ks = np.flatnonzero(series[0].usable(5, n_imu))
    k = ks[-1]
    measured = series[0].beams[k].copy()
    measured[[0, 2]] = np.nan
    expect = pivot.complete(series[0].beams[k - 3:k], measured, imu=series[0].imu_window(k, pivot.imu_samples))
    np.testing.assert_array_equal(full[-1], expect[0])
    np.testing.assert_array_equal(full[:, [1, 3]], samples.beams[:, [1, 3]])   # the measured beams pass through

    hybrid = _study("hybrid_imu_folds")
    import sys
    sys.path.insert(0, str(ROOT / "experiments"))      # the studies import their siblings
    (tmp_path / "fold0").mkdir()
    for suffix in ("pt", "json"):
        shutil.copy(ROOT / "nets" / "weights" / f"imu-2-missing.{suffix}", tmp_path / "fold0")
    comp = hybrid.completer("HNI fold fused", "2-missing", (str(tmp_path), "pivot"), 0, None, 0.042)
    assert isinstance(comp.fused_beam_only, PivotCompleter) and comp.beam_only is comp.fused_beam_only
    assert comp.fused_beam_only.pivot_m is None                          # fitted online, as Graph-HNP's
    assert comp.beam_correlation == {"2-missing": hybrid.IMU_PIVOT_ERROR_CORRELATION["2-missing"]}


def test_the_pitch_aware_pivot_member_has_the_completers_own_defaults_with_its_lengths_from_the_other_folds(
        monkeypatch):
    """``--beam-nets pivot-pitch``: each fold's pivot completer takes the yaw and pitch lengths fitted on the other
    folds and holds the completer's own past pings; ``pivot`` keeps the yaw alone and the average's hold."""
    import sys
    sys.path.insert(0, str(ROOT / "experiments"))
    fused = _study("imu_beam_fused_folds")

    import graphnav.evaluation.bench as bench
    import graphnav.evaluation.pivot_folds as pivot_folds
    import graphnav.io.paths as paths
    from graphnav.nets.average import AVERAGE_N_PAST
    from graphnav.nets.pivot import DEFAULT_N_PAST
    asked = []

    def lengths(sources, folds, axes=("yaw",)):
        asked.append(tuple(axes))
        return [(3.0 + f, 2.0 + f) if len(axes) == 2 else 3.5 + f for f in range(len(folds))]
    monkeypatch.setattr(pivot_folds, "fold_pivot_lengths", lengths)
    monkeypatch.setattr(paths, "akit_trajectories", lambda d=None: [Path("/nowhere/Trajectory1")])
    monkeypatch.setattr(bench, "find_trajectories", lambda folder: [])
    for scenario in ("2-missing", "3-missing"):
        pitch = fused.fold_pivot_completers(scenario, pitch=True)
        yaw = fused.fold_pivot_completers(scenario)
        assert [c.lengths_m for c in pitch] == [(3.0 + f, 2.0 + f) for f in range(5)]
        assert [c.lengths_m for c in yaw] == [(3.5 + f, 0.0) for f in range(5)]
        assert {c.n_past for c in pitch} == {DEFAULT_N_PAST[scenario]}
        assert {c.n_past for c in yaw} == {AVERAGE_N_PAST[scenario]}
    assert DEFAULT_N_PAST["2-missing"] != AVERAGE_N_PAST["2-missing"]        # the two holds are told apart above
    assert asked == [("yaw", "pitch"), ("yaw",)] * 2


def test_the_placement_report_keeps_the_pivot_pair_and_each_draw_apart_and_chooses_no_fading_for_it():
    """Rows with the pivot completer as the second member are another pair than the beam-only networks' at the same
    decays, and rows of two training draws are two groups; --choose-decays refuses pivot rows (the pivot does not
    fade); rows of before rows named their networks still report."""
    import sys
    study = _study("outage_placement")
    sys.path.insert(0, str(ROOT / "experiments"))
    starts = [[0, study.PERIOD * k + 10] for k in range(2)]
    sq = {"average": [[2.0, 2.0], [2.0, 2.0]], "fused": [[1.0, 1.0], [1.0, 1.0]]}

    def row(nets, second, fold=0):
        return {"scenario": "2-missing", "fold": fold, "grade": "recorded", "settle": 10, "stride": 90,
                "starts": starts, "sq": sq, "run_decay": {"IMU-aware": 1.0, "beam-only": 1.0},
                "nets": {"IMU-aware": nets, "beam-only": second}}
    rows = [row("a/nets2", "pivot"), row("a/nets2", "ens2/x"), row("a/nets2s100", "pivot"),
            row("a/nets2", "pivot-pitch")]
    assert [study.pivot_member(r) for r in rows] == ["pivot", None, "pivot", "pivot-pitch"]
    headers = [line for line in study.report(rows).splitlines() if line.startswith("###")]
    assert len(headers) == 4 and sum("pivot completer" in h for h in headers) == 3
    assert sum("(pivot-pitch)" in h for h in headers) == 1
    assert any("nets2s100" in h for h in headers)
    with pytest.raises(ValueError, match="pivot completer"):
        study.decay_report(rows)
    old = {k: v for k, v in row("a/nets2", "ens2/x").items() if k not in ("nets", "run_decay")}
    assert "the cards'" in study.report([old])


def test_the_pivot_completers_hold_is_chosen_per_scenario_counting_worse_folds_first(tmp_path):
    """``pivot_completer_folds.py --choose-n-past``: per scenario the hold with the fewest fold cells worse than the
    average, then the largest smallest pooled gain; each fold left out gets the hold the others choose; a file run
    with the completer's own holds is refused by name."""
    study = _study("pivot_completer_folds")
    folds = [(1, 3), (2, 5), (4, 10), (6, 13), (8, 11)]
    member = "online+pitch 0.1"

    def results(errors):
        """Per trajectory the completer's squared errors against the average's 1.0: ``errors(scenario, fold)``."""
        out = {}
        for f, pair in enumerate(folds):
            for k in pair:
                rows = {}
                for scenario in study.SCENARIOS:
                    for kind in ("per ping", "outage"):
                        rows[f"{scenario}|{kind}|average"] = [1.0, 1.0, 10]
                        e = errors(scenario, f)
                        rows[f"{scenario}|{kind}|{member}"] = [e, e, 10]
                out[f"Trajectory{k}"] = {"as-recorded": rows}
        return out
    files = []
    # hold 3: better pooled in 2-missing, but fold 3 worse than the average there; hold 4 a little better everywhere
    for n, errors in ((3, lambda sc, f: 1.2 if (sc, f) == ("2-missing", 3) else 0.5),
                      (4, lambda sc, f: 0.8)):
        path = tmp_path / f"n{n}.json"
        path.write_text(json.dumps({"pivot_n_past": n, "results": results(errors)}))
        files.append(str(path))
    text = study.choose_n_past(files, member)
    assert text.splitlines()[1] == "2-missing: N 3: 4, +20.0 %; N 4: 0, +10.6 % -> N 4"
    assert text.splitlines()[7] == "3-missing: N 3: 0, +29.3 %; N 4: 0, +10.6 % -> N 3"
    # left out, fold 3 gets the others' choice (3, whose other folds are all better) and is then worse
    assert "without fold 3: N 3; fold 3 with it: smallest gain -9.5 %, 4 cells worse" in text
    default = tmp_path / "default.json"
    default.write_text(json.dumps({"pivot_n_past": "default", "results": results(lambda sc, f: 0.8)}))
    with pytest.raises(SystemExit, match="default.json"):
        study.choose_n_past([*files, str(default)], member)
    # a file without a hold holds the average's N: 3 with 2 missing beams, the same as n3.json
    average = tmp_path / "average.json"
    average.write_text(json.dumps({"results": results(lambda sc, f: 0.8)}))
    with pytest.raises(SystemExit, match="two files hold 3 past pings with 2-missing"):
        study.choose_n_past([*files, str(average)], member)
    # files that differ in more than the hold are not compared
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"pivot_n_past": 5, "stride": 90, "results": results(lambda sc, f: 0.8)}))
    with pytest.raises(SystemExit, match="stride 90 against None"):
        study.choose_n_past([*files, str(other)], member)
