"""Tests of the IMU-aware missing-beam regressor: preintegration, model, completer, shipped weights, history."""
from __future__ import annotations

import shutil
from dataclasses import replace

import numpy as np
import pytest
import torch
from graphnav.nets import ImuBeamRegressor, load_imu_completer, load_imu_model
from graphnav.nets.imu_network import model_inputs
from graphnav.nets.imu_window import ImuFeatures, preintegrate
from graphnav.nets.storage import weights_dir

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry, make_beams
from graphnav.core.errors import ConfigError, DataError
from graphnav.estimators.history import BeamHistory

G = 9.81
#: Recursive steady-leg error allowed against the average estimator's. The shipped networks: 1.13-1.51x (an
#: error level of 0.10-0.115 m/s that hardly grows); the first release 1.1-8.4x, and with the recursive stage
#: and blend alone (correction seeing the attitude) 1.1-6.2x.
STEADY_LEG_MARGIN = 1.6


def _steady_turn(n=2000, rate=100.0, v_b=(1.6, 0.15, 0.05), omega_b=(0.0, 0.0, 0.06), pitch=0.05):
    """IMU window of a vehicle holding body velocity ``v_b`` in a turn about body z, pitched by ``pitch``.

    With the body velocity constant, ``dv_b/dt = 0 = f_b + g_b - omega_b x v_b``, so ``f_b = omega x v - g_b``.
    The turn is about body z and gravity has a body-x component, so g_b rotates in the body frame.
    """
    dt = 1.0 / rate
    w = np.asarray(omega_b, float)
    v = np.asarray(v_b, float)
    t = np.arange(n) * dt
    # body z is the turn axis: gravity in the body frame rotates about z at -w_z
    ang = -w[2] * (t - t[-1])
    g0 = G * np.array([-np.sin(pitch), 0.0, np.cos(pitch)])          # g_b at the last sample
    c, s = np.cos(ang), np.sin(ang)
    g_b = np.stack([c * g0[0] - s * g0[1], s * g0[0] + c * g0[1], np.full(n, g0[2])], axis=1)
    f_b = np.cross(w, v)[None, :] - g_b
    return f_b, np.tile(w, (n, 1)), v


def test_preintegration_propagates_a_held_body_velocity_exactly_in_a_pitched_turn():
    f_b, omega_b, v = _steady_turn()
    feats = preintegrate(f_b, omega_b, n_past=3)
    assert feats.rot.shape == (1, 3, 3, 3) and feats.tail.shape == (1, 3, 3) and feats.summary.shape == (1, 6)
    # rotation j pings ago -> now: a yaw of omega_z * tau
    for j, tau in enumerate((3.0, 2.0, 1.0)):
        a = 0.06 * tau
        expected = np.array([[np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0], [0, 0, 1]])
        np.testing.assert_allclose(feats.rot[0, j], expected, atol=1e-9)
    model = ImuBeamRegressor("2-missing", n_past=3)
    T = DvlGeometry.from_spec(DvlSpec()).T_b
    past = torch.as_tensor(np.tile(v @ T.T, (3, 1))[None], dtype=torch.float32)
    prop, g_dir = model.propagate(past, *model_inputs(feats)[:4])
    np.testing.assert_allclose(prop[0].numpy(), np.tile(v @ T.T, (3, 1)), atol=2e-3)
    np.testing.assert_allclose(g_dir[0].numpy(), [-np.sin(0.05), 0, np.cos(0.05)], atol=1e-3)
    # without the centripetal term (mean inertial acceleration taken as zero) the propagation is off
    g_naive = -feats.f_mean[0]
    v_naive = feats.rot[0, 0] @ v + feats.tail[0, 0] + g_naive * 3.0
    assert np.linalg.norm(v_naive - v) > 0.1


def test_preintegration_batches_like_single_windows():
    f1, w1, _ = _steady_turn(pitch=0.0)
    f2, w2, _ = _steady_turn(omega_b=(0.01, -0.02, 0.03), pitch=0.1)
    both = preintegrate(np.stack([f1, f2]), np.stack([w1, w2]), 5, chunk=1)
    for i, (f, w) in enumerate(((f1, w1), (f2, w2))):
        one = preintegrate(f, w, 5)
        for k in ImuFeatures.FIELDS:
            np.testing.assert_allclose(getattr(both, k)[i], getattr(one, k)[0], atol=1e-12)
    with pytest.raises(DataError, match="shorter than"):
        preintegrate(f1[:200], w1[:200], 3)


def test_model_shapes_and_architecture_checks():
    model = ImuBeamRegressor("3-missing", n_past=3, imu_window_s=20.0)
    assert model.imu_samples == 2000 and model.kept == (1,)
    f_b, omega_b, v = _steady_turn()
    feats = preintegrate(np.stack([f_b] * 4), np.stack([omega_b] * 4), 3)
    beams, sigma = model(torch.randn(4, 3, 4), torch.randn(4, 1), *model_inputs(feats))
    assert beams.shape == sigma.shape == (4, 3) and torch.all(sigma > 0)
    with pytest.raises(ConfigError):
        ImuBeamRegressor("2-missing", n_past=5, imu_window_s=3.0)


def test_a_few_training_steps_are_deterministic():
    from graphnav.nets.imu_training import _mse
    from graphnav.nets.training import _run_stage

    f_b, omega_b, v = _steady_turn()
    one = preintegrate(f_b, omega_b, 3)
    feats = ImuFeatures(*(np.repeat(getattr(one, k), 32, axis=0) for k in ImuFeatures.FIELDS))
    rng = np.random.default_rng(0)
    past = torch.as_tensor(rng.normal(0, 0.5, (32, 3, 4)), dtype=torch.float32)
    target = past[:, -1, [0, 2]] + 0.05
    data = (past, past[:, -1, [1, 3]], *model_inputs(feats), target)

    def run():
        torch.manual_seed(0)
        model = ImuBeamRegressor("2-missing", n_past=3)
        _, g_dir = model.propagate(past, *data[2:6])
        model.set_normalisation(past.flatten(0, 1), data[6], g_dir)
        hist = _run_stage(model, model.mean_parameters(), data, data, _mse, "mse", 3, 8, torch.optim.Adam, 1e-2,
                          None, 1.0, None, 0, False)
        return model, hist

    (m1, h1), (m2, _) = run(), run()
    assert h1[-1]["train"] < h1[0]["train"]
    for a, b in zip(m1.state_dict().values(), m2.state_dict().values()):
        assert torch.equal(a, b)


def test_recursive_training_feeds_the_completions_back_and_is_deterministic():
    from graphnav.nets.imu_training import _rollout_loss, rollout
    from graphnav.nets.training import _run_stage

    f_b, omega_b, v = _steady_turn()
    feats = model_inputs(preintegrate(f_b, omega_b, 3))         # one IMU row, used by every ping
    T = torch.as_tensor(DvlGeometry.from_spec(DvlSpec()).T_b, dtype=torch.float32)
    rng = np.random.default_rng(1)
    v_b = torch.as_tensor(rng.normal(0, 0.5, (16, 3)), dtype=torch.float32)
    beams = (v_b @ T.T)[:, None, :].repeat(1, 9, 1)             # (16, 3 past + 6 pings, 4): held velocity
    past0, measured, target = beams[:, :3], beams[:, 3:, [1, 3]], beams[:, 3:, [0, 2]]
    fidx = torch.zeros(16, 6, dtype=torch.long)

    def run():
        torch.manual_seed(0)
        model = ImuBeamRegressor("2-missing", n_past=3, blend=True)
        hist = _run_stage(model, model.mean_parameters(), (past0, measured, fidx, target),
                          (past0, measured, fidx, target), _rollout_loss(feats), "rollout", 3, 8,
                          torch.optim.Adam, 1e-2, None, 1.0, None, 0, False)
        return model, hist

    (m1, h1), (m2, _) = run(), run()
    for a, b in zip(m1.state_dict().values(), m2.state_dict().values()):
        assert torch.equal(a, b)
    assert np.isfinite(h1[-1]["val"])
    # the rollout feeds each completion back: ping 2 sees ping 1's completion in its past window
    with torch.no_grad():
        out = rollout(m1, past0[:2], measured[:2, :2], [f[fidx[:2, :2]] for f in feats])
        full1 = beams[:2, 3].clone()
        full1[:, [0, 2]] = out[:, 0]
        step2, _ = m1(torch.cat([past0[:2, 1:], full1[:, None]], 1), measured[:2, 1], *(f[[0, 0]] for f in feats))
    torch.testing.assert_close(out[:, 1], step2)


@pytest.mark.parametrize("missing, pattern", [(2, (0, 2)), (3, (0, 2, 3))])
def test_shipped_imu_weights_load_and_predict_deterministically(missing, pattern):
    comp = load_imu_completer(missing)
    assert comp.needs_imu and comp.missing == pattern and comp.imu_samples == 2000
    assert comp.n_past == {2: 5, 3: 3}[missing]
    # chosen out of fold, then trained on every A-KIT trajectory: the card says so
    assert "cross-validation" in comp.card["selected_by"] and comp.card["split"]["val_trajectories"] == []
    assert comp.card["split"]["train_trajectories"] == [1, 2, 3, 4, 5, 6, 8, 10, 11, 13]
    assert comp.card["training"]["imu_grades"] == ["tactical", "mems"]
    f_b, omega_b, v = _steady_turn()
    T = DvlGeometry.from_spec(DvlSpec()).T_b
    beams = v @ T.T
    measured = beams.copy()
    measured[list(pattern)] = np.nan
    out1, sig1 = comp.complete(np.tile(beams, (comp.n_past, 1)), measured, imu=(f_b, omega_b))
    out2, sig2 = comp.complete(np.tile(beams, (comp.n_past, 1)), measured, imu=(f_b, omega_b))
    np.testing.assert_array_equal(out1, out2)
    np.testing.assert_array_equal(sig1, sig2)
    kept = [b for b in range(4) if b not in pattern]
    np.testing.assert_array_equal(out1[kept], beams[kept])
    assert np.all(sig1[list(pattern)] > 0) and np.all(sig1[kept] == 0)
    # a vehicle holding its velocity: the completion stays close to the true beams
    assert np.max(np.abs(out1 - beams)) < 0.1


def _steady_leg_outage_errors(comp, missing, pitch, roll, v_b, seeds=range(4), window=30):
    """Velocity errors (m/s, RMS over the pings and seeds) of ``comp`` through a recursive outage of its
    missing beams on a synthetic steady leg (level or tilted, constant body velocity, exact IMU)."""
    g_b = G * np.array([-np.sin(pitch), np.cos(pitch) * np.sin(roll), np.cos(pitch) * np.cos(roll)])
    imu = (np.tile(-g_b, (2000, 1)), np.zeros((2000, 3)))
    T_pinv = np.linalg.pinv(DvlGeometry.from_spec(DvlSpec()).T_b)
    valid = np.ones(4, bool)
    valid[list(missing)] = False
    err = []
    for seed in seeds:
        beams = make_beams(np.tile(v_b, (10 + window, 1)), DvlSpec(), seed)
        hist = BeamHistory(comp.n_past)
        for k in range(10 - comp.n_past, 10):
            hist.push(beams[k])
        for k in range(10, 10 + window):
            full, _ = hist.complete(comp, beams[k], valid, imu=imu)
            err.append(T_pinv @ full - v_b)
    return float(np.sqrt(np.mean(np.sum(np.square(err), axis=1))))


@pytest.mark.parametrize("missing", [2, 3])
def test_shipped_imu_weights_do_not_drift_through_a_recursive_outage_on_a_steady_leg(missing):
    """Fed its own completions for 30 pings on a steady leg (level and tilted, exact IMU), the IMU-aware
    completer stays near the average estimator's error (which is right there: the velocity is held) instead
    of drifting. The first release (trained one step ahead, correction seeing the attitude) reached 0.1-0.6 m/s
    RMS over the outage here, against 0.07-0.09 for the average."""
    from graphnav.nets import AverageCompleter
    from graphnav.nets.average import AVERAGE_N_PAST

    comp = load_imu_completer(missing)
    avg = AverageCompleter(AVERAGE_N_PAST[f"{missing}-missing"])
    for pitch, roll, v_b in ((0.0, 0.0, (2.05, 0.0, 0.0)), (0.03, -0.02, (2.05, 0.1, 0.05)),
                             (-0.05, 0.03, (1.0, -0.1, 0.1))):
        net_err = _steady_leg_outage_errors(comp, comp.missing, pitch, roll, np.array(v_b))
        avg_err = _steady_leg_outage_errors(avg, comp.missing, pitch, roll, np.array(v_b))
        assert net_err <= STEADY_LEG_MARGIN * avg_err, (pitch, roll, v_b, net_err, avg_err)


def test_a_total_outage_network_rolls_out_with_no_beam_measured_and_starts_from_the_held_body_velocity():
    """A network for pings without a measured beam (``0-beams``): its correction starts at zero, so before training
    it is its IMU-propagated prior, which holds a body velocity exactly through a pitched turn; fed its own
    completions through a 6-ping outage it must stay on the true beams, and one step of the recursion must be
    the model called on the past it built."""
    from graphnav.nets.imu_training import rollout
    from graphnav.nets.model import normalize_missing

    assert normalize_missing("0-beams") == normalize_missing((3, 2, 1, 0)) == (0, 1, 2, 3)
    with pytest.raises(ConfigError, match="1 to 4"):
        normalize_missing((0, 4))
    f_b, omega_b, v = _steady_turn()
    feats = model_inputs(preintegrate(f_b, omega_b, 3))
    T = DvlGeometry.from_spec(DvlSpec()).T_b
    truth = torch.as_tensor(v @ T.T, dtype=torch.float32)
    model = ImuBeamRegressor("0-beams", blend=True)
    assert model.kept == () and model.n_past == 3
    past0 = truth.repeat(2, 3, 1)
    no_beams = torch.zeros(2, 6, 0)
    fidx = torch.zeros(2, 6, dtype=torch.long)
    with torch.no_grad():
        out = rollout(model, past0, no_beams, [f[fidx] for f in feats])
        assert out.shape == (2, 6, 4)
        np.testing.assert_allclose(out.numpy(), np.broadcast_to(truth.numpy(), (2, 6, 4)), atol=5e-3)
        step2, sigma = model(torch.cat([past0[:, 1:], out[:, :1]], 1), no_beams[:, 1], *(f[[0, 0]] for f in feats))
    torch.testing.assert_close(out[:, 1], step2)
    assert torch.all(sigma > 0)


def test_bad_inputs_give_clear_errors():
    comp = load_imu_completer(2)
    f_b, omega_b, v = _steady_turn()
    past = np.ones((comp.n_past, 4))
    measured = np.array([np.nan, 1.0, np.nan, 1.0])
    with pytest.raises(DataError, match="needs the IMU window"):
        comp.complete(past, measured)
    with pytest.raises(DataError, match="imu.f_b"):
        comp.complete(past, measured, imu=(f_b[:-1], omega_b))
    with pytest.raises(DataError, match="imu.omega_b"):
        comp.complete(past, measured, imu=(f_b, omega_b[:, :2]))
    bad = omega_b.copy()
    bad[17, 1] = np.nan
    with pytest.raises(DataError, match="index 17.*imu.omega_b"):
        comp.complete(past, measured, imu=(f_b, bad))
    with pytest.raises(DataError, match="pair"):
        comp.complete(past, measured, imu=f_b)
    with pytest.raises(DataError, match="past"):
        comp.complete(np.ones((2, 4)), measured, imu=(f_b, omega_b))
    with pytest.raises(DataError, match="do not match"):
        comp.complete(past, np.array([np.nan, 1.0, 1.0, 1.0]), imu=(f_b, omega_b))


def test_weights_checksum_and_missing_files(tmp_path):
    for ext in ("pt", "json"):
        shutil.copy(weights_dir() / f"imu-2-missing.{ext}", tmp_path / f"imu-2-missing.{ext}")
    load_imu_model("2-missing", tmp_path)
    pt = tmp_path / "imu-2-missing.pt"
    pt.write_bytes(pt.read_bytes()[:-1] + bytes([pt.read_bytes()[-1] ^ 1]))
    with pytest.raises(ConfigError, match="checksum"):
        load_imu_model("2-missing", tmp_path)
    with pytest.raises(ConfigError, match="train-beams --imu"):
        load_imu_model("3-missing", tmp_path)


def test_beam_history_forwards_the_imu_window():
    comp = load_imu_completer(2)
    f_b, omega_b, v = _steady_turn()
    beams = v @ DvlGeometry.from_spec(DvlSpec()).T_b.T
    hist = BeamHistory(comp.n_past)
    for _ in range(comp.n_past):
        hist.complete(comp, beams, np.ones(4, bool))
    valid = np.array([0, 1, 0, 1], bool)
    with pytest.raises(DataError, match="needs the IMU window"):
        hist.complete(comp, beams, valid)
    full, sigma = hist.complete(comp, beams, valid, imu=(f_b, omega_b))
    assert np.all(np.isfinite(full)) and sigma[0] > 0
    np.testing.assert_allclose(hist.past()[-1], full)


def test_imu_window_at_takes_the_samples_up_to_the_ping():
    from graphnav.nets.imu_window import imu_window_at

    from graphnav.core.mission import ImuData

    t = np.arange(500) * 0.01
    imu = ImuData(t, np.tile(t[:, None], (1, 3)), -np.tile(t[:, None], (1, 3)))
    assert imu_window_at(imu, 1.0, 200) is None                  # 101 samples so far
    f_b, omega_b = imu_window_at(imu, 3.005, 200)
    assert f_b.shape == omega_b.shape == (200, 3)
    assert f_b[-1, 0] == pytest.approx(3.0) and f_b[0, 0] == pytest.approx(1.01)


@pytest.mark.realdata
def test_shipped_imu_network_beats_the_average_on_real_motion(akit_dir):
    """A sanity check on real motion, not a held-out score: the shipped weights were trained on every A-KIT
    trajectory (other beam draws than seed 7); their out-of-fold numbers are in docs/decisions/completers.md."""
    from graphnav.nets import AverageCompleter
    from graphnav.nets.evaluate import completion_metrics, predict_completer
    from graphnav.nets.imu_data import akit_imu_series, imu_windows
    from graphnav.nets.imu_evaluate import predict_imu_network

    series = akit_imu_series((5,), akit_dir, beam_seed=7)
    comp = load_imu_completer(2)
    samples = imu_windows(series, comp.n_past, comp.imu_samples, pings=slice(0, 200))
    net = completion_metrics(*predict_imu_network(comp.model, samples), samples, comp.missing)
    avg = completion_metrics(*predict_completer(AverageCompleter(3), samples, comp.missing), samples,
                             comp.missing)
    assert net["beam_rmse"] < 0.85 * avg["beam_rmse"]
    assert 0.55 < net["within_1sigma"] < 0.8 and 0.9 < net["within_2sigma"] < 0.99


def test_cli_parsers_imu():
    from graphnav.cli import build_parser
    args = build_parser().parse_args(["train-beams", "--imu", "--scenario", "2-missing", "--imu-epochs", "3"])
    assert args.imu and args.imu_epochs == 3
    args = build_parser().parse_args(["eval-beams", "--imu", "--trajectories", "3,5"])
    assert args.imu and args.trajectories == "3,5"


def test_train_beams_refuses_recipes_it_does_not_know_before_training(tmp_path):
    from graphnav.cli import build_parser
    from graphnav.commands import train_beams
    from graphnav.core.errors import ConfigError
    from graphnav.nets.imu_recipes import IMU_RECIPES

    assert IMU_RECIPES["graded"].imu_grades == ("tactical", "mems")
    # the shipped recipe: the same training, only the fading through an outage differs
    assert IMU_RECIPES["graded-fade"] == replace(IMU_RECIPES["graded"], run_decay=0.95)
    with pytest.raises(ConfigError, match="ImuTrainOptions: run_decay 0"):
        replace(IMU_RECIPES["graded"], run_decay=0.0)
    parse = build_parser().parse_args
    out = str(tmp_path / "out")
    with pytest.raises(ConfigError,
                       match="--imu --recipe 'akit-residual-aug' unknown; choose from \\['graded', 'graded-fade'\\]"):
        train_beams.run(parse(["train-beams", "--imu", "--recipe", "akit-residual-aug", "--out", out]))
    with pytest.raises(ConfigError, match="--out-of-fold goes with a beam-only --recipe"):
        train_beams.run(parse(["train-beams", "--imu", "--recipe", "graded", "--out-of-fold", "cv.json", "--out", out]))
    with pytest.raises(ConfigError, match="--out-of-fold goes with a beam-only --recipe"):
        train_beams.run(parse(["train-beams", "--out-of-fold", "cv.json", "--out", out]))
    with pytest.raises(ConfigError, match="sets its own schedule"):
        train_beams.run(parse(["train-beams", "--imu", "--recipe", "graded", "--imu-epochs", "3", "--out", out]))
    assert not (tmp_path / "out").exists()


def test_imu_completer_serves_other_patterns_with_a_window_average():
    """A network for a pattern without the paper's N (one missing beam) still builds; its fading averages its own
    window."""
    from graphnav.nets.imu_network import ImuNetworkCompleter
    comp = ImuNetworkCompleter(ImuBeamRegressor((1,), n_past=3), {}, run_decay=0.9)
    assert comp.fallback.n_past == 3 and comp.takes_run_steps


def test_imu_completer_fades_to_the_average_through_a_run(tmp_path):
    """``run_decay`` on the IMU-aware completer: the k-th regressed ping of a run is ``gamma^k`` network + the rest
    the average over the last ``min(n_past, N)`` pings (beams and sigma); a first ping is the network's; the IMU-aware
    auto completer hands the run on; the card's value is the default and a damaged one is refused naming the file."""
    from graphnav.nets import AverageCompleter, ImuAutoCompleter
    from graphnav.nets.average import AVERAGE_N_PAST
    f_b, omega_b, v = _steady_turn()
    T = DvlGeometry.from_spec(DvlSpec()).T_b
    rng = np.random.default_rng(11)
    for missing, pattern in ((2, [0, 2]), (3, [0, 2, 3])):
        net, fade = load_imu_completer(missing, run_decay=1.0), load_imu_completer(missing, run_decay=0.9)
        assert fade.takes_run_steps and not net.takes_run_steps
        past = (v + 0.05 * rng.standard_normal((net.n_past, 3))) @ T.T
        measured = v @ T.T
        measured[pattern] = np.nan
        b_net, s_net = net.complete(past, measured, imu=(f_b, omega_b))
        n_avg = min(net.n_past, AVERAGE_N_PAST[f"{missing}-missing"])
        b_avg, s_avg = AverageCompleter(n_avg).complete(past[-n_avg:], measured)
        assert not np.allclose(b_net, b_avg)
        np.testing.assert_array_equal(fade.complete(past, measured, imu=(f_b, omega_b),
                                                    run_steps=np.zeros(4, int))[0], b_net)
        steps = np.where(np.isfinite(measured), 0, 4)
        b, s = fade.complete(past, measured, imu=(f_b, omega_b), run_steps=steps)
        w = 0.9 ** 4
        np.testing.assert_allclose(b, w * b_net + (1 - w) * b_avg, rtol=1e-12)
        np.testing.assert_allclose(s, w * s_net + (1 - w) * s_avg, rtol=1e-12)
        auto = ImuAutoCompleter([fade], AverageCompleter(AVERAGE_N_PAST[f"{missing}-missing"]))
        assert auto.takes_run_steps
        full_past = np.vstack([np.tile(past[:1], (auto.n_past - net.n_past, 1)), past])
        np.testing.assert_array_equal(auto.complete(full_past, measured, imu=(f_b, omega_b), run_steps=steps)[0], b)
    # the shipped cards fade (recipe graded-fade), and an explicit run_decay overrides the card
    assert load_imu_completer(2).run_decay == load_imu_completer(3).run_decay == 0.95
    shutil.copytree(weights_dir(), tmp_path / "w")
    card = tmp_path / "w" / "imu-2-missing.json"
    import json
    import re
    card.write_text(json.dumps({**json.loads(card.read_text()), "run_decay": 1.5}))
    with pytest.raises(ConfigError, match=re.escape(f"{tmp_path / 'w' / 'imu-2-missing.json'}: run_decay 1.5")):
        load_imu_completer(2, tmp_path / "w")
    assert load_imu_completer(2, tmp_path / "w", run_decay=0.95).run_decay == 0.95


def test_imu_completer_leaves_pings_outside_its_training_envelope_to_the_average():
    """A card's ``envelope`` (the training beams' range and steps): a ping inside is the network's, one outside (a
    vehicle slower than any it was trained on) the average over the same past, counted; the fused and auto
    completers add the count to their own ``fallbacks``; a card without one checks nothing."""
    from graphnav.nets import AverageCompleter, ImuAutoCompleter
    from graphnav.nets.average import AVERAGE_N_PAST
    from graphnav.nets.fused import FusedCompleter
    from graphnav.nets.imu_network import ImuNetworkCompleter
    f_b, omega_b, v = _steady_turn()
    T = DvlGeometry.from_spec(DvlSpec()).T_b
    shipped = load_imu_completer(2)
    beams = v @ T.T
    envelope = {"beam_min": (beams - 0.05).tolist(), "beam_max": (beams + 0.05).tolist(), "max_step": [0.05] * 4}
    assert shipped.envelope is not None               # the shipped cards carry their training envelope
    card = {k: v for k, v in shipped.card.items() if k != "envelope"}
    plain = ImuNetworkCompleter(shipped.model, card, run_decay=1.0)
    bounded = ImuNetworkCompleter(shipped.model, {**card, "envelope": envelope}, run_decay=1.0)
    assert plain.envelope is None
    measured = beams.copy()
    measured[[0, 2]] = np.nan
    past = np.tile(beams, (shipped.n_past, 1))
    np.testing.assert_array_equal(bounded.complete(past, measured, imu=(f_b, omega_b))[0],
                                  plain.complete(past, measured, imu=(f_b, omega_b))[0])
    assert bounded.fallbacks == {"envelope": 0, "pattern": 0, "dvl": 0, "period": 0}
    slow = 0.5 * beams                                  # 0.8 m/s instead of 1.6: outside the trained range
    measured = slow.copy()
    measured[[0, 2]] = np.nan
    past = np.tile(slow, (shipped.n_past, 1))
    n_avg = min(shipped.n_past, AVERAGE_N_PAST["2-missing"])
    average = AverageCompleter(n_avg).complete(past[-n_avg:], measured)
    got = bounded.complete(past, measured, imu=(f_b, omega_b))
    np.testing.assert_array_equal(got[0], average[0])
    np.testing.assert_array_equal(got[1], average[1])
    assert not np.allclose(plain.complete(past, measured, imu=(f_b, omega_b))[0], average[0])
    assert bounded.fallbacks["envelope"] == 1 and plain.fallbacks["envelope"] == 0
    fused = FusedCompleter(bounded, AverageCompleter(AVERAGE_N_PAST["2-missing"]))
    fused.complete(past, measured, imu=(f_b, omega_b))
    assert fused.fallbacks == {"envelope": 2, "pattern": 0, "dvl": 0, "period": 0}
    auto = ImuAutoCompleter([bounded], AverageCompleter(AVERAGE_N_PAST["2-missing"]))
    auto.complete(np.tile(slow, (auto.n_past, 1)), measured, imu=(f_b, omega_b))
    assert auto.fallbacks["envelope"] == 3


def test_card_envelope_rebuilds_the_training_beams_range_and_checks_the_files(akit_dir):
    from graphnav.nets.imu_data import akit_imu_series
    from graphnav.nets.imu_training import card_envelope
    from graphnav.nets.storage import file_sha256
    from graphnav.nets.training import training_envelope
    dvl = akit_dir / "Trajectory2" / "DVL_trajectory2.csv"
    card = {"split": {"train_trajectories": [2]}, "data": {"beam_seed": 0, "DVL_sha256": {"Trajectory2": file_sha256(dvl)}}}
    envelope = card_envelope(card, akit_dir)
    assert envelope == training_envelope(akit_imu_series((2,), akit_dir, 0))
    assert np.all(np.isfinite(envelope["beam_min"])) and np.all(np.array(envelope["max_step"]) > 0)
    series = akit_imu_series((2,), akit_dir, 0)
    series[0].beams[10, 1] = np.nan                     # a ping without beam 1 bounds nothing
    assert training_envelope(series) == envelope
    card["data"]["DVL_sha256"]["Trajectory2"] = "0" * 64
    with pytest.raises(DataError, match="DVL_trajectory2.csv: not the DVL file the network was trained on"):
        card_envelope(card, akit_dir)


def test_an_imu_aware_network_trained_for_another_dvl_computes_with_its_beams_and_binds_to_it(tmp_path, akit_dir):
    """``train_imu(spec=)`` for an RDI convex head (beams at 270, 90, 0, 180 deg): the network holds that head's beams,
    is trained on beams made for it (the envelope is that of the head's beams, not the Snapir's: fails if the spec is
    dropped in training), its card records the head at the recordings' 1 Hz, it loads back, binds to the head and
    refuses the Snapir's, its weights and card must agree, and it is scored on the head's beams without the Snapir's
    beam-only network."""
    from graphnav.nets.dvl_match import trained_dvl_spec
    from graphnav.nets.imu_data import akit_imu_series
    from graphnav.nets.imu_evaluate import evaluate_imu
    from graphnav.nets.imu_network import ImuNetworkCompleter
    from graphnav.nets.imu_recipes import IMU_RECIPES
    from graphnav.nets.imu_training import card_envelope, train_imu
    from graphnav.nets.training import save, training_envelope
    rdi = replace(DvlSpec(), psi_rad=np.deg2rad([270.0, 90.0, 0.0, 180.0]), rate_hz=4.0)
    rdi_T_b, snapir_T_b = DvlGeometry.from_spec(rdi).T_b, DvlGeometry.from_spec(DvlSpec()).T_b
    opt = replace(IMU_RECIPES["graded"], epochs=1, rollout_epochs=1, draws=1, sigma_epochs=1, imu_grades=())
    result = train_imu("2-missing", opt, akit_dir, progress=False, evaluate=False, trajectories=(2,), spec=rdi)
    np.testing.assert_allclose(result.model.T_b.numpy(), rdi_T_b, atol=1e-6)
    rdi_1hz = replace(rdi, rate_hz=1.0)
    assert result.card["envelope"] == training_envelope(akit_imu_series((2,), akit_dir, 0, spec=rdi_1hz))
    assert result.card["envelope"] != training_envelope(akit_imu_series((2,), akit_dir, 0))
    assert trained_dvl_spec(result.card).rate_hz == 1.0
    assert card_envelope(result.card, akit_dir) == result.card["envelope"]

    save(result, tmp_path)
    comp = load_imu_completer("2-missing", tmp_path)
    np.testing.assert_allclose(comp.trained_T_b, rdi_T_b, atol=1e-6)
    assert comp.bind_dvl(rdi_T_b) == [] and comp.dvl_mismatch is None
    assert "beam 1" in comp.bind_dvl(snapir_T_b)[0]
    past = np.tile([1.1, 0.3, -0.9, 0.2], (comp.n_past, 1))
    imu = (np.tile([0.0, 0.0, -9.81], (comp.imu_samples, 1)), np.zeros((comp.imu_samples, 3)))
    beams, _ = comp.complete(past, np.array([np.nan, 0.3, np.nan, 0.2]), imu=imu)
    assert comp.fallbacks["dvl"] == 1
    np.testing.assert_allclose(beams, comp.fallback.complete(past[-comp.fallback.n_past:],
                                                             np.array([np.nan, 0.3, np.nan, 0.2]))[0])

    snapir_card = {**result.card, "data": {**result.card["data"], "beam_model": {}}}
    for card in (snapir_card, {}):          # a card without a record is the default DVL's
        with pytest.raises(ConfigError, match="its weights hold beams .* its model card's DVL has"):
            ImuNetworkCompleter(result.model, card)

    rows = evaluate_imu(("2-missing",), (2,), akit_dir=akit_dir, outage=False,
                        completers={"2-missing": ImuNetworkCompleter(result.model, result.card)})
    assert {r["method"] for r in rows} == {"imu-network", "average"}
    # scored on the head's beams and geometry: the average's beam and velocity RMSE with them, not with the Snapir's
    from graphnav.nets.average import AverageCompleter
    from graphnav.nets.evaluate import completion_metrics, predict_completer
    from graphnav.nets.imu_data import imu_windows
    avg = next(r for r in rows if r["method"] == "average")
    for spec, same in ((rdi_1hz, True), (DvlSpec(), False)):
        samples = imu_windows(akit_imu_series((2,), akit_dir, 1000, spec=spec), 5, comp.imu_samples)
        full, sigma = predict_completer(AverageCompleter(3), samples, (0, 2))
        got = completion_metrics(full, sigma, samples, (0, 2), DvlGeometry.from_spec(spec))
        assert np.isclose(got["beam_rmse"], avg["beam_rmse"]) == same
        assert np.isclose(got["vel_rmse"], avg["vel_rmse"]) == same
