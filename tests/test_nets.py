"""Tests of the missing-beam regressor, its training, the shipped weights and the completers."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import torch
from graphnav.nets import (
    AutoCompleter,
    AverageCompleter,
    BeamRegressor,
    NetworkCompleter,
    TrainOptions,
    fit,
    load_completer,
    load_model,
)
from graphnav.nets import data as beamdata
from graphnav.nets.evaluate import (
    completion_metrics,
    predict_completer,
    predict_network,
)
from graphnav.nets.storage import weights_dir

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import make_beams
from graphnav.core.errors import ConfigError, DataError


def _series(n=200, seed=0):
    """A smooth synthetic DVL velocity (forward ~1.5 m/s with slow sway) and beams made from it."""
    t = np.arange(n, dtype=float)
    v = np.stack([1.5 + 0.3 * np.sin(t / 15), 0.2 * np.sin(t / 7), 0.05 * np.cos(t / 11)], axis=1)
    return beamdata.BeamSeries("synthetic", v, make_beams(v, DvlSpec(), seed))


@pytest.mark.parametrize("missing, n_past, feat", [((0, 2), 3, 12), ((0, 2, 3), 5, 20)])
def test_architecture_sizes_match_the_paper(missing, n_past, feat):
    model = BeamRegressor(missing)
    n_miss = len(missing)
    assert model.n_past == n_past
    assert (model.conv.in_channels, model.conv.out_channels) == (n_past, 2 * n_past)
    assert model.conv.kernel_size == (2,) and model.conv.stride == (2,)
    assert (model.fc1.in_features, model.fc1.out_features) == (feat, 16)
    assert (model.fc2.in_features, model.fc2.out_features) == (16, n_miss)
    assert (model.out.in_features, model.out.out_features) == (8, n_miss)
    beams, sigma = model(torch.randn(7, n_past, 4), torch.randn(7, 4 - n_miss))
    assert beams.shape == sigma.shape == (7, n_miss)
    assert torch.all(sigma > 0)


def test_residual_path_adds_the_past_beams():
    torch.manual_seed(0)
    model = BeamRegressor("2-missing")
    past = torch.randn(5, 3, 4)
    with torch.no_grad():
        model.conv.weight.zero_()
        model.conv.bias.zero_()          # tanh(conv) = 0: Y must be exactly the normalised X
        y, _, m = model.features(past, torch.randn(5, 2))
        assert torch.allclose(y, ((past - model.beam_mean) / model.beam_std).flatten(1))
        assert torch.allclose(m, past.mean(1))
        model.conv.bias.fill_(0.5)        # conv output shows up on top of X
        y2, _, _ = model.features(past, torch.randn(5, 2))
        assert torch.allclose(y2 - y, torch.full_like(y, np.tanh(0.5)), atol=1e-6)


def test_output_is_linear_and_can_be_negative():
    model = BeamRegressor("3-missing")
    with torch.no_grad():
        model.out.bias.fill_(-50.0)
        beams, _ = model(torch.zeros(2, 5, 4), torch.zeros(2, 1))
    assert torch.all(beams < 0)


def test_missing_sets_and_errors():
    assert BeamRegressor("3-missing").missing == (0, 2, 3)
    assert BeamRegressor([3, 1]).kept == (0, 2)
    with pytest.raises(ConfigError):
        BeamRegressor("none")
    with pytest.raises(ConfigError):
        BeamRegressor((0, 4))
    with pytest.raises(ConfigError, match="needs a measured beam"):
        BeamRegressor("0-beams")
    with pytest.raises(ConfigError, match="needs a measured beam"):
        load_completer((0, 1, 2, 3))


def test_windows_stay_inside_each_series():
    a, b = _series(20), _series(30, seed=1)
    s = beamdata.windows([a, b], 3)
    assert len(s) == (20 - 3) + (30 - 3)
    np.testing.assert_array_equal(s.past[17], b.beams[0:3])       # first window of the second series
    np.testing.assert_array_equal(s.beams[17], b.beams[3])


def test_tiny_training_overfits_a_few_batches_and_is_deterministic():
    t = np.arange(27.0)
    v = np.stack([1.5 + 0.3 * np.sin(t / 5), 0.4 * np.sin(t / 3), 0.1 * np.cos(t / 4)], axis=1)
    noise_free = beamdata.BeamSeries("noise-free", v, make_beams(v, DvlSpec(beam_noise_std=0.0), 0))
    samples = beamdata.windows(noise_free, 3)      # 24 samples = 6 batches of 4
    opt = TrainOptions(epochs=100, lr=3e-3, lr_step_epochs=1000, sigma_epochs=3, seed=3)
    models = []
    for _ in range(2):
        torch.manual_seed(3)
        model = BeamRegressor("2-missing")
        hist = fit(model, samples, samples, opt, progress=False)
        models.append(model)
    mse = [h["train"] for h in hist if h["stage"] == "mse"]
    assert mse[-1] < 0.02 * mse[0], (mse[0], mse[-1])
    for (k, v1), v2 in zip(models[0].state_dict().items(), models[1].state_dict().values()):
        assert torch.equal(v1, v2), k


@pytest.mark.parametrize("missing, pattern", [(2, (0, 2)), (3, (0, 2, 3))])
def test_shipped_weights_load_and_predict_deterministically(missing, pattern):
    comp = load_completer(missing)
    assert isinstance(comp, NetworkCompleter) and comp.missing == pattern
    rng = np.random.default_rng(1)
    past = make_beams(np.array([1.8, 0.2, 0.05]) + 0.05 * rng.standard_normal((comp.n_past, 3)), DvlSpec(), 2)
    measured = make_beams(np.array([[1.8, 0.2, 0.05]]), DvlSpec(), 3)[0]
    measured[list(pattern)] = np.nan
    beams, sigma = comp.complete(past, measured)
    beams2, sigma2 = load_completer(missing).complete(past, measured)
    np.testing.assert_array_equal(beams, beams2)
    np.testing.assert_array_equal(sigma, sigma2)
    kept = [b for b in range(4) if b not in pattern]
    np.testing.assert_array_equal(beams[kept], measured[kept])
    assert np.all(sigma[kept] == 0)
    assert np.all(np.isfinite(sigma[list(pattern)])) and np.all(sigma[list(pattern)] > 0)
    assert np.all(sigma[list(pattern)] < 1.0)
    # A sensible prediction: the true beams of that velocity, within a few sigma.
    truth = make_beams(np.array([[1.8, 0.2, 0.05]]), DvlSpec(), 3)[0]
    assert np.all(np.abs(beams - truth)[list(pattern)] < 0.3)
    card = comp.card
    assert card["n_past"] == comp.n_past and card["metrics"]["val"]["beam_rmse"] > 0
    const = load_completer(missing, sigma="constant").complete(past, measured)[1]
    np.testing.assert_allclose(const[list(pattern)], card["constant_sigma"])
    scaled = load_completer(missing, sigma_scale=1.5).complete(past, measured)[1]
    np.testing.assert_allclose(scaled, 1.5 * sigma, rtol=1e-12)


def test_bad_inputs_give_clear_errors():
    comp = load_completer(2)
    past = np.ones((3, 4))
    measured = np.array([np.nan, 0.5, np.nan, -0.5])
    bad = past.copy()
    bad[1, 2] = np.nan
    with pytest.raises(DataError, match="past"):
        comp.complete(bad, measured)
    with pytest.raises(DataError, match=r"expected \(3, 4\)"):
        comp.complete(np.ones((5, 4)), measured)
    with pytest.raises(DataError, match="auto"):
        comp.complete(past, np.array([np.nan, 0.5, 0.2, -0.5]))
    with pytest.raises(ConfigError):
        load_completer(4)
    with pytest.raises(ConfigError):
        load_completer(2, sigma="large")


def test_loading_checks_versions_and_shapes(tmp_path):
    for name in ("2-missing.pt", "2-missing.json"):
        shutil.copy(weights_dir() / name, tmp_path / name)
    card = json.loads((tmp_path / "2-missing.json").read_text())
    load_model("2-missing", tmp_path)                                  # unchanged copy loads
    (tmp_path / "2-missing.json").write_text(json.dumps({**card, "format_version": 99}))
    with pytest.raises(ConfigError, match="format version"):
        load_model("2-missing", tmp_path)
    arch = {**card["architecture"], "hidden": 8}
    (tmp_path / "2-missing.json").write_text(json.dumps({**card, "architecture": arch}))
    with pytest.raises(ConfigError, match="fc1.weight"):
        load_model("2-missing", tmp_path)
    (tmp_path / "2-missing.json").write_text(json.dumps({**card, "weights_sha256": "0" * 64}))
    with pytest.raises(ConfigError, match="checksum"):
        load_model("2-missing", tmp_path)
    for bad in (1.5, "0.9", None):       # a damaged fading factor names the card and the field
        (tmp_path / "2-missing.json").write_text(json.dumps({**card, "run_decay": bad}))
        with pytest.raises(ConfigError, match=r"2-missing\.json: run_decay"):
            load_completer(2, directory=tmp_path)
    with pytest.raises(ConfigError, match="train-beams"):
        load_model("3-missing", tmp_path)


def test_auto_completer_dispatches_by_pattern():
    auto = load_completer("auto")
    assert isinstance(auto, AutoCompleter) and auto.n_past == 5
    rng = np.random.default_rng(4)
    past = make_beams(np.array([1.5, 0.1, 0.0]) + 0.05 * rng.standard_normal((5, 3)), DvlSpec(), 5)
    full = make_beams(np.array([[1.5, 0.1, 0.0]]), DvlSpec(), 6)[0]
    two = full.copy()
    two[[0, 2]] = np.nan
    np.testing.assert_array_equal(auto.complete(past, two)[0], load_completer(2).complete(past[-3:], two)[0])
    one = full.copy()
    one[1] = np.nan                                                    # no network: average of last 3
    beams, sigma = auto.complete(past, one)
    assert beams[1] == pytest.approx(past[-3:, 1].mean())
    assert sigma[1] > 0 and np.all(sigma[[0, 2, 3]] == 0)
    beams, sigma = auto.complete(past, full)
    np.testing.assert_array_equal(beams, full)
    assert np.all(sigma == 0)


def test_auto_completer_from_a_folder_per_scenario_holds_those_networks_only(tmp_path):
    """Out-of-fold networks live one scenario to a folder: ``load_completer("auto", directory={scenario: folder})``
    holds the networks of those folders, fading as asked, and sends every other pattern to its average estimator;
    a scenario without a network, a folder without weights and a folder map for one network are refused."""
    folder = tmp_path / "fold0"
    folder.mkdir()
    for suffix in (".pt", ".json"):
        shutil.copy(weights_dir() / f"3-missing{suffix}", folder)
    auto = load_completer("auto", directory={"3-missing": folder}, run_decay=0.5)
    three = load_completer(3, run_decay=0.5)
    assert list(auto.networks) == [tuple(three.missing)] and auto.networks[tuple(three.missing)].run_decay == 0.5
    rng = np.random.default_rng(4)
    past = make_beams(np.array([1.5, 0.1, 0.0]) + 0.05 * rng.standard_normal((5, 3)), DvlSpec(), 5)
    full = make_beams(np.array([[1.5, 0.1, 0.0]]), DvlSpec(), 6)[0]
    only_one = full.copy()
    only_one[list(three.missing)] = np.nan
    np.testing.assert_array_equal(auto.complete(past, only_one)[0], three.complete(past, only_one)[0])
    two = full.copy()
    two[[0, 2]] = np.nan                                               # no network here: average of last 3
    assert auto.complete(past, two)[0][0] == pytest.approx(past[-3:, 0].mean())
    with pytest.raises(ConfigError, match="'0-beams'"):
        load_completer("auto", directory={"0-beams": folder})
    with pytest.raises(ConfigError, match="fold1"):
        load_completer("auto", directory={"3-missing": tmp_path / "fold1"})
    with pytest.raises(ConfigError, match="run_decay names \\['2-missing'\\]"):
        load_completer("auto", directory={"3-missing": folder}, run_decay={"2-missing": 0.5})
    with pytest.raises(ConfigError, match="for missing='auto'"):
        load_completer(3, directory={"3-missing": folder})


def test_metrics_and_average_baseline_on_synthetic_data():
    samples = beamdata.windows(_series(60), 3)
    full, sigma = predict_completer(AverageCompleter(3), samples, (0, 2))
    m = completion_metrics(full, sigma, samples, (0, 2))
    assert 0 < m["beam_rmse"] < 0.3 and 0 <= m["within_1sigma"] <= m["within_2sigma"] <= 1
    net_full, net_sigma = predict_network(load_completer(2).model, samples)
    np.testing.assert_array_equal(net_full[:, [1, 3]], samples.beams[:, [1, 3]])


@pytest.mark.realdata
def test_shipped_network_beats_the_average_on_a_mission_it_never_saw(beamsnet_dir):
    """V_test (another date, a slow mission moving forward and backward) was never trained on; the sigma is
    known to be somewhat small there (the model card), not far off."""
    for missing in (2, 3):
        comp = load_completer(missing)
        samples = beamdata.windows(beamdata.beamsnet_series("test", beamsnet_dir, seed=7), comp.n_past)
        net = completion_metrics(*predict_network(comp.model, samples), samples, comp.missing)
        avg = completion_metrics(*predict_completer(AverageCompleter(comp.n_past), samples, comp.missing),
                                 samples, comp.missing)
        assert net["beam_rmse"] < 0.8 * avg["beam_rmse"] and net["vel_rmse"] < avg["vel_rmse"]
        assert 0.5 < net["within_1sigma"] < 0.8 and 0.85 < net["within_2sigma"] < 0.99


@pytest.mark.realdata
def test_beamsnet_split_has_no_window_across_the_cut(beamsnet_dir):
    tr = beamdata.beamsnet_series("train", beamsnet_dir)
    va = beamdata.beamsnet_series("val", beamsnet_dir)
    full = beamdata.beamsnet_series("all", beamsnet_dir)
    assert len(tr.beams) + len(va.beams) == len(full.beams) == 13886
    np.testing.assert_array_equal(np.concatenate([tr.beams, va.beams]), full.beams)
    heading = np.degrees(np.arctan2(full.v_b[:, 1], full.v_b[:, 0]))
    assert abs(np.median(heading[np.hypot(full.v_b[:, 0], full.v_b[:, 1]) > 0.5])) < 5  # body frame


def test_cli_parsers():
    from graphnav.cli import build_parser
    args = build_parser().parse_args(["train-beams", "--scenario", "3-missing", "--epochs", "2"])
    assert args.scenario == ["3-missing"] and args.epochs == 2
    args = build_parser().parse_args(["eval-beams", "--no-outage"])
    assert args.no_outage


def test_outage_rollout_feeds_completions_back():
    from graphnav.nets.evaluate import outage_rollout
    s = _series(200)
    full, sigma, samples = outage_rollout(AverageCompleter(3), s, (0, 2), window=30, gap=60, settle=10)
    assert full.shape == (60, 4) and len(samples) == 60              # windows at pings 10 and 100
    np.testing.assert_array_equal(samples.beams[:30], s.beams[10:40])
    np.testing.assert_array_equal(full[:, [1, 3]], samples.beams[:, [1, 3]])
    # From the 4th outage ping on the history holds only earlier completions.
    assert full[3, 0] == pytest.approx(np.mean(full[:3, 0]))
    assert np.all(sigma[:, [0, 2]] > 0) and np.all(sigma[:, [1, 3]] == 0)


def test_akit_series_splits_at_invalid_pings(tmp_path):
    from graphnav.io.loaders import AKIT_COLUMNS
    folder = tmp_path / "Trajectory7"
    folder.mkdir()
    for kind in ("IMU", "GT"):
        (folder / f"{kind}_trajectory7.csv").write_text(",".join(AKIT_COLUMNS[kind]) + "\n")
    rows = [f"{k:.1f},{1.5 + 0.01 * k},0.1,0.0" for k in range(12)]
    rows[5] = "5.0,NaN,NaN,NaN"
    (folder / "DVL_trajectory7.csv").write_text(",".join(AKIT_COLUMNS["DVL"]) + "\n" + "\n".join(rows) + "\n")
    series = beamdata.akit_series(tmp_path, seed=0)
    assert [s.name for s in series] == ["Trajectory7", "Trajectory7#1"]
    assert [len(s.beams) for s in series] == [5, 6]
    assert all(np.all(np.isfinite(s.beams)) for s in series)
    assert len(beamdata.windows(series, 3)) == (5 - 3) + (6 - 3)


def test_run_decay_fades_the_network_to_the_average_through_a_run():
    """With ``run_decay`` gamma the k-th regressed ping of a run is ``gamma^k`` network + the rest average (beams
    and sigma); the first one (k = 0, or no ``run_steps``) is the network's; measured beams pass through."""
    net, fade, avg = load_completer(2, run_decay=1.0), load_completer(2, run_decay=0.9), AverageCompleter(3)
    assert fade.takes_run_steps and not net.takes_run_steps
    assert load_completer(2).run_decay == load_completer(2).card.get("run_decay", 1.0)   # the card's, by default
    rng = np.random.default_rng(7)
    past = make_beams(np.array([1.6, 0.1, 0.02]) + 0.05 * rng.standard_normal((3, 3)), DvlSpec(), 8)
    measured = make_beams(np.array([[1.6, 0.1, 0.02]]), DvlSpec(), 9)[0]
    measured[[0, 2]] = np.nan
    b_net, s_net = net.complete(past, measured)
    b_avg, s_avg = avg.complete(past, measured)
    assert not np.allclose(b_net, b_avg)                        # the ping is inside the network's envelope
    for steps in (None, np.zeros(4, int)):
        np.testing.assert_array_equal(fade.complete(past, measured, run_steps=steps)[0], b_net)
    w = 0.9 ** 5
    b, s = fade.complete(past, measured, run_steps=np.array([5, 0, 5, 0]))
    np.testing.assert_allclose(b, w * b_net + (1 - w) * b_avg, rtol=1e-12)
    np.testing.assert_allclose(s, w * s_net + (1 - w) * s_avg, rtol=1e-12)
    np.testing.assert_array_equal(b[[1, 3]], measured[[1, 3]])
    assert np.all(s[[1, 3]] == 0)
    # the auto completer hands the run on to the network it dispatches to
    auto = load_completer("auto", run_decay=0.9)
    assert auto.takes_run_steps
    full_past = np.vstack([past[:2], past])
    np.testing.assert_array_equal(auto.complete(full_past, measured, run_steps=np.array([5, 0, 5, 0]))[0], b)
    # through an outage the history counts the run: with a tiny gamma every ping after the first is the average's
    from graphnav.nets.evaluate import outage_rollout
    s = _series(120)
    full, _, _ = outage_rollout(load_completer(2, run_decay=1e-12), s, (0, 2), window=20, gap=60, settle=10)
    first, _ = net.complete(s.beams[7:10], np.where([False, True, False, True], s.beams[10], np.nan))
    np.testing.assert_allclose(full[0], first)
    for k in range(1, 20):
        hist = np.vstack([s.beams[7:10], full[:k]])[-3:]
        np.testing.assert_allclose(full[k, [0, 2]], hist[:, [0, 2]].mean(axis=0), atol=1e-9)
    for bad in (0.0, 1.5):
        with pytest.raises(ConfigError, match="run_decay"):
            load_completer(2, run_decay=bad)


def test_eval_beams_folds_trains_with_the_given_seed(monkeypatch):
    """``eval-beams --folds --seed`` reaches the cross-validation (another training draw of the same table)."""
    from graphnav.cli import build_parser
    from graphnav.nets import crossval
    seen = {}

    def fake_crossval(data, scenario, variant, seed=0, **kwargs):
        seen[scenario, variant] = seed
        return []
    monkeypatch.setattr(crossval, "load_fold_data", lambda *a, **k: None)
    monkeypatch.setattr(crossval, "crossval", fake_crossval)
    for name in ("fold_table", "format_fold_rows", "format_fold_gains", "format_summary"):
        monkeypatch.setattr(crossval, name, lambda *a, **k: "")
    monkeypatch.setattr(crossval, "summarise", lambda rows: [])
    for argv, seed in ((["--seed", "100"], 100), ([], 0)):
        args = build_parser().parse_args(["eval-beams", "--folds", "--variant", "akit", "--scenario", "2-missing", *argv])
        assert args.func(args) == 0
        assert seen[("2-missing", "akit")] == seed


def test_completers_that_wrap_a_fading_network_hand_the_run_on():
    """The IMU-aware auto completer (its beam-only route) and the fused completer pass the run steps to a fading
    beam-only network, so the fading of its model card holds on every route an estimator takes."""
    from graphnav.nets import FusedCompleter, load_imu_auto_completer
    fade = load_completer("auto", run_decay=0.9)
    rng = np.random.default_rng(3)
    past = make_beams(np.array([1.6, 0.1, 0.02]) + 0.05 * rng.standard_normal((5, 3)), DvlSpec(), 4)
    measured = make_beams(np.array([[1.6, 0.1, 0.02]]), DvlSpec(), 5)[0]
    measured[[0, 2]] = np.nan
    steps = np.array([5, 0, 5, 0])
    faded = fade.complete(past, measured, run_steps=steps)[0]
    assert not np.allclose(faded, fade.complete(past, measured)[0])     # the run changes the completion
    imu_auto = load_imu_auto_completer(beam_only=fade, fused_beam_only=fade)
    assert imu_auto.takes_run_steps
    np.testing.assert_array_equal(imu_auto.complete(past, measured, imu=None, run_steps=steps)[0], faded)
    fused = FusedCompleter(fade, AverageCompleter(3))
    assert fused.takes_run_steps
    np.testing.assert_array_equal(fused.members(past, measured, run_steps=steps)[0], faded)
    from graphnav.nets import ImuAutoCompleter, load_imu_completer
    plain = [load_imu_completer(m, run_decay=1.0) for m in (2, 3)]
    assert not ImuAutoCompleter(plain, load_completer("auto", run_decay=1.0)).takes_run_steps
    # alone, the shipped IMU-aware networks fade themselves (their cards' run_decay)
    assert load_imu_auto_completer(beam_only=load_completer("auto", run_decay=1.0), fused=False).takes_run_steps
