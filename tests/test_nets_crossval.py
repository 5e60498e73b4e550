"""Tests of the leave-trajectories-out cross-validation of the beam completers (graphnav.nets.crossval)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch
from graphnav.nets import AverageCompleter, BeamRegressor, NetworkCompleter
from graphnav.nets import crossval as cv
from graphnav.nets import data as beamdata
from graphnav.nets.evaluate import predict_completer

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import make_beams
from graphnav.core.errors import ConfigError


def _series(name, n=160, seed=0, phase=0.0):
    """Smooth synthetic DVL velocity (forward ~1.5 m/s, sway, heave) and beams made from it."""
    t = np.arange(n, dtype=float) + phase
    v = np.stack([1.5 + 0.3 * np.sin(t / 15), 0.2 * np.sin(t / 7), 0.05 * np.cos(t / 11)], axis=1)
    return beamdata.BeamSeries(name, v, make_beams(v, DvlSpec(), seed))


def test_akit_folds_hold_out_every_trajectory_exactly_once():
    folds = cv.check_folds(cv.AKIT_FOLDS)
    flat = [t for f in folds for t in f]
    assert sorted(flat) == [1, 2, 3, 4, 5, 6, 8, 10, 11, 13]
    assert len(folds) == 5 and all(len(f) == 2 for f in folds)
    with pytest.raises(ConfigError, match="trajectory 3 is in folds 0 and 1"):
        cv.check_folds([(1, 3), (3, 4)])
    with pytest.raises(ConfigError, match="fold 1 holds no trajectory"):
        cv.check_folds([(1,), ()])


def test_fold_split_never_trains_on_a_held_out_recording():
    akit = {t: [_series(f"Trajectory{t}", seed=t)] for t in (1, 2, 3, 4)}
    bn = [[_series("V[0:160]", seed=10)], [_series("V[160:320]", seed=11)]]
    data = cv.FoldData(akit, bn, [_series("V_test", seed=12)], cv.check_folds([(1, 3), (2, 4)]))
    for i in range(2):
        train, held = data.split(i)
        train_names = {s.name for ss in train.values() for s in ss}
        held_names = {s.name for ss in held.values() for s in ss}
        assert not train_names & held_names
        assert {s.name for s in held["A-KIT"]} == {f"Trajectory{t}" for t in data.folds[i]}
        assert "V_test" in held_names and "V_test" not in train_names
        assert train_names | held_names == {f"Trajectory{t}" for t in akit} | {"V[0:160]", "V[160:320]", "V_test"}


def test_beamsnet_missions_are_found_at_velocity_jumps_and_blocks_are_contiguous():
    rng = np.random.default_rng(0)
    parts = [np.full((n, 3), lvl) + 0.05 * rng.standard_normal((n, 3)) for n, lvl in
             ((300, 0.0), (200, 2.0), (500, 0.2))]
    v = np.concatenate(parts)
    missions = cv.beamsnet_missions(v)
    assert [(m.start, m.stop) for m in missions] == [(0, 300), (300, 500), (500, 1000)]
    blocks = cv.beamsnet_blocks(missions, 2)
    flat = [p for b in blocks for p in b]
    assert flat[0].start == 0 and flat[-1].stop == 1000
    assert all(a.stop == b.start for a, b in zip(flat[:-1], flat[1:]))       # contiguous, no ping twice
    assert blocks[0][-1].stop == 500             # the equal cut (500) is a mission boundary: kept whole


def test_untrained_residual_network_is_the_average_estimator():
    torch.manual_seed(0)
    model = BeamRegressor("3-missing", residual=True)
    model.set_normalisation(torch.as_tensor(_series("a").beams, dtype=torch.float32))
    samples = beamdata.windows(_series("b", seed=3), model.n_past)
    net = NetworkCompleter(model)
    full_net, _ = cv.predict_batch(net, samples, model.missing)
    full_avg, _ = cv.predict_batch(AverageCompleter(5), samples, model.missing)
    np.testing.assert_allclose(full_net, full_avg, atol=1e-5)
    assert BeamRegressor(**model.architecture()).residual


@pytest.mark.parametrize("missing", ["2-missing", "3-missing"])
def test_batch_prediction_matches_complete_ping_by_ping(missing):
    torch.manual_seed(1)
    model = BeamRegressor(missing)
    train = _series("train", seed=1)
    model.set_normalisation(torch.as_tensor(train.beams, dtype=torch.float32))
    from graphnav.nets.training import training_envelope
    env = training_envelope(train)
    env["beam_max"][1] -= 0.15                   # some pings fall outside: filled by the average fallback
    net = NetworkCompleter(model, card={"envelope": env})
    samples = beamdata.windows(_series("eval", seed=2, phase=40.0), model.n_past)
    for comp in (net, AverageCompleter(model.n_past)):
        a = cv.predict_batch(comp, samples, model.missing)
        b = predict_completer(comp, samples, model.missing)
        np.testing.assert_allclose(a[0], b[0], atol=1e-6)
        np.testing.assert_allclose(a[1], b[1], atol=1e-6)
    assert 0 < net.fallbacks["envelope"] < len(samples)


def test_protocol_on_tiny_synthetic_folds(tmp_path):
    akit = {t: [_series(f"Trajectory{t}", seed=t, phase=13.0 * t)] for t in (1, 2, 3, 4)}
    data = cv.FoldData(akit, [], [], cv.check_folds([(1, 2), (3, 4)]))
    variant = cv.Variant("tiny", akit=True, residual=True, epochs=2, patience=1, sigma_epochs=1, batch_size=64)
    rows = cv.crossval(data, "2-missing", variant, save_dir=tmp_path / "nets")
    # each fold's network is kept, loadable, and completes the held-out pings as it was scored
    from graphnav.nets import load_completer
    from graphnav.nets.evaluate import completion_metrics, predict_network
    fold1 = load_completer(2, directory=tmp_path / "nets" / "fold1")
    assert fold1.card["data"]["held_out"] == [3, 4] and fold1.model.residual
    held = beamdata.windows([akit[t][0] for t in (3, 4)], fold1.n_past)
    scored = next(r for r in rows if (r["fold"], r["mode"], r["method"]) == (1, "per ping", "network"))
    assert completion_metrics(*predict_network(fold1.model, held), held, (0, 2))["beam_rmse"] == pytest.approx(
        scored["beam_rmse"], rel=1e-6)
    assert {(r["fold"], r["mode"], r["method"]) for r in rows} == {
        (f, m, k) for f in (0, 1) for m in ("per ping", "outage 30 s") for k in ("network", "average")}
    # the average's per-ping numbers, computed here independently
    for f, held in ((0, (1, 2)), (1, (3, 4))):
        s = beamdata.windows([akit[t][0] for t in held], 3)
        err = s.past.mean(axis=1)[:, [0, 2]] - s.beams[:, [0, 2]]
        row = next(r for r in rows if (r["fold"], r["mode"], r["method"]) == (f, "per ping", "average"))
        assert row["beam_rmse"] == pytest.approx(np.sqrt(np.mean(err ** 2)))
        assert row["n"] == len(s)
    summary = cv.summarise(rows)
    per_ping = next(r for r in summary if r["mode"] == "per ping")
    avg = [r for r in rows if r["mode"] == "per ping" and r["method"] == "average"]
    pooled = np.sqrt(sum(r["beam_rmse"] ** 2 * r["n"] for r in avg) / sum(r["n"] for r in avg))
    assert per_ping["beam_rmse_average"] == pytest.approx(pooled)
    assert per_ping["beam_rmse_gain"] == pytest.approx(1 - per_ping["beam_rmse_network"] / pooled)
    assert per_ping["beam_rmse_worst_gain"] <= per_ping["beam_rmse_gain"] + 1e-12
    table = cv.format_summary(summary)
    assert "| tiny | A-KIT | 2-missing | per ping |" in table
    gains = cv.format_fold_gains(rows).splitlines()
    assert len(gains) == 2 + 2 and gains[2].startswith("| tiny | 0 (1, 2) |")
    net0 = next(r for r in rows if (r["fold"], r["mode"], r["method"]) == (0, "per ping", "network"))
    avg0 = next(r for r in rows if (r["fold"], r["mode"], r["method"]) == (0, "per ping", "average"))
    assert f"{100 * (1 - net0['beam_rmse'] / avg0['beam_rmse']):+.1f} %" in gains[2]

    # the rows that chose a recipe go into its model card (train-beams --recipe --out-of-fold)
    import json

    from graphnav.commands.train_beams import out_of_fold_summary
    from graphnav.core.errors import ConfigError
    other = [{**r, "variant": "other", "beam_rmse": 1.0} for r in rows]
    folds_json = tmp_path / "cv.json"
    folds_json.write_text(json.dumps(rows + other))
    assert out_of_fold_summary([str(folds_json)], "tiny", ["2-missing"]) == summary
    with pytest.raises(ConfigError, match="no rows of recipe 'tiny' for 3-missing"):
        out_of_fold_summary([str(folds_json)], "tiny", ["2-missing", "3-missing"])
    with pytest.raises(ConfigError, match="a fold's rows appear twice"):
        out_of_fold_summary([str(folds_json), str(folds_json)], "tiny", ["2-missing"])
    unfinished = tmp_path / "unfinished.json"
    unfinished.write_text(json.dumps([r for r in rows if not (r["fold"] == 1 and r["mode"] == "per ping")]))
    with pytest.raises(ConfigError, match="not every scenario and mode has the same folds"):
        out_of_fold_summary([str(unfinished)], "tiny", ["2-missing"])
    (tmp_path / "bench.json").write_text(json.dumps({"runs": []}))
    with pytest.raises(ConfigError, match="bench.json: not the fold rows"):
        out_of_fold_summary([str(tmp_path / "bench.json")], "tiny", ["2-missing"])


def test_ensemble_is_the_mixture_of_its_members_and_round_trips_through_a_card(tmp_path):
    """A two-member recipe: member 0 is the one network of the same seed, the completion is the members' mean
    and its variance the mixture's (mean variance + spread of the means), and the saved ensemble loads back."""
    akit = {t: [_series(f"Trajectory{t}", seed=t, phase=13.0 * t)] for t in (1, 2, 3)}
    train = {"akit": [s for ss in akit.values() for s in ss], "beamsnet": []}
    single = cv.Variant("one", akit=True, residual=True, copies=1, epochs=2, patience=1, sigma_epochs=1, batch_size=64)
    pair = cv.Variant("two", akit=True, residual=True, copies=1, epochs=2, patience=1, sigma_epochs=1, batch_size=64,
                      members=2)
    one = cv.train_network(train, "3-missing", single, seed=4)
    ens = cv.train_network(train, "3-missing", pair, seed=4)
    assert ens.model.architecture() == {**one.model.architecture(), "members": 2}
    for a, b in zip(ens.model.members[0].state_dict().values(), one.model.state_dict().values()):
        assert torch.equal(a, b)
    samples = beamdata.windows(_series("held", seed=9, phase=5.0), 5)
    past = torch.as_tensor(samples.past, dtype=torch.float32)
    meas = torch.as_tensor(samples.beams[:, [1]], dtype=torch.float32)
    with torch.no_grad():
        (m0, s0), (m1, s1) = (m(past, meas) for m in ens.model.members)
        mean, sigma = ens.model(past, meas)
    assert not torch.allclose(m0, m1)                       # another seed and augmentation draw
    np.testing.assert_allclose(mean, (m0 + m1) / 2, atol=1e-6)
    np.testing.assert_allclose(sigma ** 2, (s0 ** 2 + s1 ** 2) / 2 + ((m0 - m1) / 2) ** 2, rtol=1e-5)
    # the envelope covers both members' training data (each draws its own augmented copies)
    env, env0 = ens.card["envelope"], one.card["envelope"]
    assert np.all(np.array(env["beam_min"]) <= env0["beam_min"])
    assert np.all(np.array(env["beam_max"]) >= env0["beam_max"])
    assert env["samples"] > env0["samples"]
    with pytest.raises(ConfigError, match="members must be >= 1"):
        cv.Variant("none", members=0)
    from graphnav.nets import load_completer
    from graphnav.nets.model import BeamEnsemble
    from graphnav.nets.training import TrainResult, save
    save(TrainResult(ens.model, cv.network_card(ens, pair, 4, data={"source": "test"})), tmp_path)
    loaded = load_completer(3, directory=tmp_path)
    assert isinstance(loaded.model, BeamEnsemble) and len(loaded.model.members) == 2
    # an ensemble card is format version 2 (a version-1 reader could not build it); one network stays version 1
    assert loaded.card["format_version"] == 2
    assert cv.network_card(one, single, 4, data={})["format_version"] == 1
    np.testing.assert_allclose(cv.predict_batch(loaded, samples, (0, 2, 3))[0],
                               cv.predict_batch(ens, samples, (0, 2, 3))[0], atol=1e-6)
    with pytest.raises(ConfigError, match="at least 2 members"):
        BeamEnsemble(1, missing="3-missing")


@pytest.mark.parametrize("missing", ["2-missing", "3-missing"])
def test_velocity_loss_weighs_beam_errors_as_least_squares_does(missing):
    """The velocity term of the mean loss is the velocity error least squares on the four beams makes of the
    missing beams' errors (checked against DvlGeometry.velocity_from_beams), added to the beam MSE."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.training import _normalised_mse, mean_loss, velocity_of_missing
    geometry = DvlGeometry.from_spec(DvlSpec())
    model = BeamRegressor(missing)
    L = velocity_of_missing(missing)
    rng = np.random.default_rng(3)
    beams = rng.normal(0.0, 1.0, 4)
    err = rng.normal(0.0, 0.1, len(model.missing))
    damaged = beams.copy()
    damaged[list(model.missing)] += err
    np.testing.assert_allclose(geometry.velocity_from_beams(damaged) - geometry.velocity_from_beams(beams), L @ err,
                               atol=1e-12)
    torch.manual_seed(0)
    past, meas = torch.randn(8, model.n_past, 4), torch.randn(8, len(model.kept))
    target = torch.randn(8, len(model.missing))
    assert mean_loss(0.0, missing) is _normalised_mse
    with torch.no_grad():
        pred, _ = model(past, meas)
        e = ((pred - target) / model.beam_std[list(model.missing)]).double().numpy()
        expected = np.mean(e ** 2) + 0.5 * np.mean(np.sum((e @ L.T) ** 2, axis=1))
        assert mean_loss(0.5, missing)(model, past, meas, target).item() == pytest.approx(expected, rel=1e-5)


def test_augmented_copies_keep_speed_within_the_scale_and_draw_new_noise():
    s = _series("a")
    variant = cv.Variant("aug", copies=2, yaw_deg=10.0, speed_scale=0.1)
    out = cv.augment([s], variant, seed=0)
    assert len(out) == 3 and out[0] is s
    for c in out[1:]:
        ratio = np.linalg.norm(c.v_b, axis=1) / np.linalg.norm(s.v_b, axis=1)
        assert np.ptp(ratio) < 1e-9 and 0.9 <= ratio[0] <= 1.1
        assert not np.allclose(c.beams, s.beams)


def beamsnet_series_test(beamsnet_dir):
    return beamdata.beamsnet_series("test", beamsnet_dir).beams


def test_real_folds_and_final_training_round_trip(akit_dir, beamsnet_dir, tmp_path):
    """On the shared data: the folds hold every A-KIT trajectory once and every V.npy ping once; a recipe
    trained on everything saves a card that loads as a completer and says which protocol chose it."""
    from graphnav.nets import load_completer
    from graphnav.nets.training import save

    data = cv.load_fold_data(akit_dir, beamsnet_dir)
    assert sorted(data.akit) == [1, 2, 3, 4, 5, 6, 8, 10, 11, 13]
    pings = [s.name for block in data.beamsnet for s in block]
    edges = [tuple(int(x) for x in n.removeprefix("V[").removesuffix("]").split(":")) for n in pings]
    assert edges[0][0] == 0 and all(a[1] == b[0] for a, b in zip(edges[:-1], edges[1:]))
    assert edges[-1][1] == sum(len(s.beams) for block in data.beamsnet for s in block)
    tiny = cv.Variant("tiny", akit=True, residual=True, epochs=1, patience=1, sigma_epochs=1, batch_size=256)
    result = cv.train_final("2-missing", tiny, akit_dir, beamsnet_dir)
    save(result, tmp_path)
    completer = load_completer(2, directory=tmp_path)
    assert completer.model.residual and "cross-validation" in completer.card["selected_by"]
    assert completer.card["training"]["name"] == "tiny"
    # its metrics: the selection part of the recordings and V_test (never trained on); one sigma per beam
    metrics = completer.card["metrics"]
    test_beams = beamsnet_series_test(beamsnet_dir)
    assert metrics["test"]["n"] == len(test_beams) - completer.n_past
    assert 0 < metrics["val"]["beam_rmse"] < 1 and 0 < metrics["test"]["beam_rmse"] < 1
    constant = load_completer(2, directory=tmp_path, sigma="constant")
    past, measured = test_beams[100:103], test_beams[103].copy()
    measured[[0, 2]] = np.nan
    np.testing.assert_allclose(constant.complete(past, measured)[1][[0, 2]], completer.card["constant_sigma"])


def test_fading_recipe_reaches_the_completer_and_its_card(tmp_path):
    """A recipe's ``run_decay`` changes no training: the fold network completes outages with it, its card records
    it, and a completer loaded from that card fades alike (an explicit ``run_decay`` overrides the card)."""
    train = {"akit": [_series(f"Trajectory{t}", seed=t, phase=13.0 * t) for t in (1, 2)], "beamsnet": []}
    plain = cv.Variant("plain", akit=True, residual=True, epochs=1, patience=1, sigma_epochs=1, batch_size=64)
    fading = replace(plain, name="fading", run_decay=(("3-missing", 0.9),))
    assert fading.decay("3-missing") == 0.9 and fading.decay("2-missing") == 1.0 and plain.decay((0, 2, 3)) == 1.0
    a, b = (cv.train_network(train, "3-missing", v, seed=2) for v in (plain, fading))
    for x, y in zip(a.model.state_dict().values(), b.model.state_dict().values()):
        assert torch.equal(x, y)
    assert (a.run_decay, a.takes_run_steps, b.run_decay, b.takes_run_steps) == (1.0, False, 0.9, True)
    assert "run_decay" not in cv.network_card(a, plain, 2, data={})
    from graphnav.nets import load_completer
    from graphnav.nets.training import TrainResult, save
    save(TrainResult(b.model, cv.network_card(b, fading, 2, data={"source": "test"})), tmp_path)
    assert load_completer(3, directory=tmp_path).run_decay == 0.9
    assert load_completer(3, directory=tmp_path, run_decay=1.0).takes_run_steps is False
    with pytest.raises(ConfigError, match="run_decay"):
        cv.Variant("bad", run_decay=(("2-missing", 0.0),))


def test_a_recipe_trained_for_another_dvl_is_bound_to_that_dvl(monkeypatch):
    """``train_network(..., spec=)`` (what ``graphnav train-beams --recipe NAME --config JSON`` runs): its augmented
    copies are that DVL's beams, its card records that DVL at the recordings' 1 Hz whatever the configuration's rate,
    so an estimator on that DVL lets it complete and one on the Snapir's DVL does not."""
    from graphnav.core.dvl import DvlGeometry
    rdi = replace(DvlSpec(), psi_rad=np.deg2rad([270.0, 90.0, 0.0, 180.0]), rate_hz=4.0)
    T_rdi, T_default = DvlGeometry.from_spec(rdi).T_b, DvlGeometry.from_spec(DvlSpec()).T_b

    def rdi_series(name, seed, phase):
        s = _series(name, seed=seed, phase=phase)
        return beamdata.BeamSeries(name, s.v_b, make_beams(s.v_b, rdi, seed))
    train = {"akit": [rdi_series(f"Trajectory{t}", t, 13.0 * t) for t in (1, 2)], "beamsnet": []}
    tiny = cv.Variant("tiny", akit=True, residual=True, copies=1, epochs=1, patience=1, sigma_epochs=1,
                      batch_size=64)
    copy = cv.augment(train["akit"][:1], tiny, seed=0, spec=rdi)[1]
    # the copy's beams are the RDI head's (the default spec's noise 0.042 m/s and bias 0.01 m/s), not the Snapir head's
    assert np.abs(copy.beams - copy.v_b @ T_rdi.T).max() < 0.25
    assert np.abs(copy.beams - copy.v_b @ T_default.T).max() > 0.5
    made_for = []                                           # the DVLs the training's augmented copies were made for
    monkeypatch.setattr(cv, "make_beams", lambda v, spec, rng: made_for.append(spec) or make_beams(v, spec, rng))
    net = cv.train_network(train, "3-missing", tiny, seed=1, spec=rdi)
    assert made_for and all(np.allclose(DvlGeometry.from_spec(m).T_b, T_rdi) for m in made_for)
    np.testing.assert_allclose(net.trained_T_b, T_rdi)
    assert net.bind_dvl(T_rdi) == []
    assert "azimuths 45, 135, 225, 315 deg" in net.bind_dvl(T_default)[0]
    assert net.trained_ping_period_s == 1.0                  # the recordings' rate, not the configuration's 4 Hz
    default = cv.train_network({"akit": [_series("Trajectory1", seed=1)], "beamsnet": []}, "3-missing", tiny, seed=1)
    assert default.bind_dvl(T_default) == []


def test_eval_beams_scores_a_network_on_the_dvl_it_was_trained_for(tmp_path, akit_dir):
    """``graphnav eval-beams --weights DIR`` (``evaluate_all``) with networks trained for an RDI head makes the A-KIT
    beams for that head and solves velocities with its geometry (the average's row is the head's, not the Snapir's)."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.evaluate import completion_metrics, evaluate_all
    from graphnav.nets.training import TrainResult, save
    rdi = replace(DvlSpec(), psi_rad=np.deg2rad([270.0, 90.0, 0.0, 180.0]))
    s = _series("Trajectory1", seed=1)
    train = {"akit": [beamdata.BeamSeries(s.name, s.v_b, make_beams(s.v_b, rdi, 1))], "beamsnet": []}
    tiny = cv.Variant("tiny", akit=True, residual=True, epochs=1, patience=1, sigma_epochs=1, batch_size=64)
    net = cv.train_network(train, "3-missing", tiny, seed=1, spec=rdi)
    from graphnav.nets.dvl_match import beam_model_record
    save(TrainResult(net.model, cv.network_card(net, tiny, 1, {"beam_model": beam_model_record(rdi)})), tmp_path)
    rows = evaluate_all(tmp_path, tmp_path / "no-beamsnet", akit_dir, scenarios=("3-missing",), outage=False)
    assert {r["dataset"] for r in rows} == {"A-KIT"}
    avg = next(r for r in rows if r["method"] == "average")
    for spec, same in ((rdi, True), (DvlSpec(), False)):
        samples = beamdata.windows(beamdata.akit_series(akit_dir, 1000, spec), net.n_past)
        full, sigma = predict_completer(AverageCompleter(net.n_past), samples, (0, 2, 3))
        got = completion_metrics(full, sigma, samples, (0, 2, 3), DvlGeometry.from_spec(spec))
        assert np.isclose(got["beam_rmse"], avg["beam_rmse"]) == same
        assert np.isclose(got["vel_rmse"], avg["vel_rmse"]) == same


def test_folds_for_another_dvl_are_scored_with_its_geometry_and_say_so():
    """``crossval`` on ``FoldData`` made for another DVL scores velocities with that DVL's geometry (least squares of
    its beams) and names the DVL in every row, which ``train-beams --out-of-fold`` checks."""
    from graphnav.commands.train_beams import out_of_fold_summary
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.evaluate import completion_metrics
    rdi = replace(DvlSpec(), psi_rad=np.deg2rad([270.0, 90.0, 0.0, 180.0]))

    def series(name, seed):
        s = _series(name, seed=seed, phase=7.0 * seed)
        return beamdata.BeamSeries(name, s.v_b, make_beams(s.v_b, rdi, seed))
    akit = {t: [series(f"Trajectory{t}", t)] for t in (1, 2, 3, 4)}
    data = cv.FoldData(akit, [], [], cv.check_folds([(1, 3), (2, 4)]), rdi)
    tiny = cv.Variant("tiny", akit=True, residual=True, epochs=1, patience=1, sigma_epochs=1, batch_size=64)
    rows = cv.crossval(data, "2-missing", tiny, outage=False)
    assert {r["dvl"] for r in rows} == {cv.dvl_name(rdi)} and cv.dvl_name(rdi) != cv.dvl_name()
    avg = next(r for r in rows if r["fold"] == 0 and r["method"] == "average")
    samples = beamdata.windows(akit[1] + akit[3], 3)
    full, sigma = predict_completer(AverageCompleter(3), samples, (0, 2))
    for spec, same in ((rdi, True), (DvlSpec(), False)):
        vel = completion_metrics(full, sigma, samples, (0, 2), DvlGeometry.from_spec(spec))["vel_rmse"]
        assert np.isclose(vel, avg["vel_rmse"]) == same
    import json
    import tempfile
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as fh:
        json.dump(rows, fh)
    assert out_of_fold_summary([fh.name], "tiny", ["2-missing"], rdi)
    with pytest.raises(ConfigError, match="rows made for another DVL"):
        out_of_fold_summary([fh.name], "tiny", ["2-missing"])


def test_the_training_commands_take_a_dvl_and_refuse_it_where_they_cannot(tmp_path, capsys, monkeypatch):
    from graphnav.cli import main
    assert main(["train-beams", "--imu", "--config", str(tmp_path / "none.json"), "--out", str(tmp_path / "o")]) != 0
    assert "none.json" in capsys.readouterr().err and not (tmp_path / "o").exists()
    import graphnav.nets.imu_training as imu_training
    seen = []

    def stop(missing, options, data_dir, **kwargs):     # what train-beams --imu hands the training
        seen.append(kwargs.get("spec"))
        raise ConfigError("stop here")
    monkeypatch.setattr(imu_training, "train_imu", stop)
    rdi_json = tmp_path / "rdi.json"
    rdi_json.write_text('{"dvl": {"psi_rad": [4.71238898038469, 1.5707963267948966, 0.0, 3.141592653589793]}}')
    assert main(["train-beams", "--imu", "--recipe", "graded-fade", "--config", str(rdi_json), "--out",
                 str(tmp_path / "o")]) != 0
    assert len(seen) == 1 and np.allclose(seen[0].psi_rad, np.deg2rad([270.0, 90.0, 0.0, 180.0]))
    assert "training for the DVL of" in capsys.readouterr().out
    assert main(["eval-beams", "--config", str(tmp_path / "none.json")]) != 0
    assert "--config goes with --folds" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text('{"dvl": {"psi_rad": [0.0, 1.0]}}')
    assert main(["train-beams", "--recipe", "akit-residual-aug-ens5-fade", "--config", str(bad), "--out",
                 str(tmp_path / "o")]) != 0
    assert "bad.json" in capsys.readouterr().err and not (tmp_path / "o").exists()
    from graphnav.commands.train_beams import warn_off_rate
    with pytest.warns(RuntimeWarning, match="x.json: dvl.rate_hz = 4 Hz.*leave every ping to the average"):
        warn_off_rate(replace(DvlSpec(), rate_hz=4.0), "x.json")
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_off_rate(replace(DvlSpec(), rate_hz=0.5), "x.json")       # pings 2 s apart: the networks serve them
