"""A network completer serves only the DVL it was trained for (:mod:`graphnav.nets.dvl_match`): bound to a mission
whose beams point elsewhere it leaves every ping to the average estimator, counted, and the estimator says so."""
from __future__ import annotations

import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry, make_beams
from graphnav.nets import AverageCompleter, load_completer
from graphnav.nets.dvl_match import beam_direction_mismatch, beam_model_record, trained_beams_b

#: a convex RDI head's beam azimuths (beam 3 forward), the layout most DVLs in the field have
RDI_PSI = np.deg2rad([270.0, 90.0, 0.0, 180.0])


def T_b(**changes) -> np.ndarray:
    return DvlGeometry.from_spec(dataclasses.replace(DvlSpec(), **changes)).T_b


def yawed(deg: float) -> np.ndarray:
    return Rotation.from_euler("z", deg, degrees=True).as_matrix()


def turning_past(n: int = 5, seed: int = 4) -> np.ndarray:
    """Full beam vectors of a vehicle whose sway and heave change from ping to ping (the network departs from the
    average there)."""
    rng = np.random.default_rng(seed)
    v = np.array([1.5, 0.1, 0.05]) + np.cumsum(0.05 * rng.standard_normal((n, 3)), axis=0)
    return make_beams(v, DvlSpec(), seed)


def test_a_beam_more_than_the_tolerance_away_is_another_dvl():
    trained = T_b()
    assert beam_direction_mismatch(trained, trained) is None
    # the head turned about the vertical by D moves each 20 deg beam by about D sin(20 deg)
    assert beam_direction_mismatch(trained, T_b(C_d_b=yawed(5.0))) is None      # 1.7 deg a beam
    off = beam_direction_mismatch(trained, T_b(C_d_b=yawed(10.0)))              # 3.4 deg
    assert off is not None and all(f"beam {i}" in off for i in range(1, 5))
    rdi = beam_direction_mismatch(trained, T_b(psi_rad=RDI_PSI))
    assert "beam 1 36.8 deg" in rdi and "beam 2 15.0 deg" in rdi             # 135 and 45 deg of azimuth at 20 deg
    assert beam_direction_mismatch(trained, T_b(theta_rad=np.deg2rad(25.0))) is not None


def test_a_card_says_which_dvl_its_network_was_trained_for():
    """A card records the spec (``beam_model``); one written before that is the default spec's, which the beam-only
    training made its beams with. The shipped IMU-aware cards record the default spec."""
    np.testing.assert_array_equal(trained_beams_b({}), T_b())
    other = dataclasses.replace(DvlSpec(), psi_rad=RDI_PSI, C_d_b=yawed(10.0))
    np.testing.assert_allclose(trained_beams_b({"data": {"beam_model": beam_model_record(other)}}),
                               DvlGeometry.from_spec(other).T_b)
    from graphnav.nets import load_imu_completer
    np.testing.assert_allclose(load_imu_completer(2).trained_T_b, T_b())
    assert "beam_model" not in load_completer(2).card["data"]       # the shipped beam-only cards predate it


def test_a_network_bound_to_another_dvl_leaves_every_ping_to_the_average():
    net = load_completer("auto")
    past = turning_past()
    two = past[-1] + 0.01
    two[[0, 2]] = np.nan
    assert net.bind_dvl(T_b()) == []
    own, _ = net.complete(past, two)
    average = AverageCompleter(3).complete(past[-3:], two)
    assert not np.allclose(own, average[0])
    before = net.fallbacks["dvl"]
    messages = net.bind_dvl(T_b(psi_rad=RDI_PSI))
    assert len(messages) == 1 and "beam 1" in messages[0]         # both networks, the same DVL: said once
    np.testing.assert_array_equal(net.complete(past, two), average)
    assert net.fallbacks["dvl"] == before + 1
    net.bind_dvl(T_b())                                            # bound again to its own DVL: the network again
    np.testing.assert_array_equal(net.complete(past, two)[0], own)


def test_the_imu_aware_completer_on_another_dvl_is_its_beam_only_route():
    """An IMU-aware network trained for another DVL serves none of its pattern's pings: the beam-only member does
    (route ``pattern``), and its own networks, bound too, leave the ping to the average: counted once."""
    from graphnav.nets import load_fused_beam_only, load_imu_auto_completer
    auto = load_imu_auto_completer(beam_only=load_completer("auto"), fused_beam_only=load_fused_beam_only())
    past = turning_past()
    two = past[-1] + 0.01
    two[[0, 2]] = np.nan
    imu = (np.tile([0.0, 0.0, -9.8], (2000, 1)), np.zeros((2000, 3)))
    assert auto.bind_dvl(T_b(psi_rad=RDI_PSI))
    usage, fallbacks = dict(auto.usage), dict(auto.fallbacks)
    np.testing.assert_array_equal(auto.complete(past, two, imu=imu), AverageCompleter(3).complete(past[-3:], two))
    assert auto.usage["pattern"] == usage["pattern"] + 1 and auto.usage["imu"] == usage["imu"]
    assert auto.fallbacks["dvl"] == fallbacks["dvl"] + 1
    assert auto.bind_dvl(T_b()) == []
    auto.complete(past, two, imu=imu)
    assert auto.usage["imu"] == usage["imu"] + 1


def test_an_estimator_on_another_dvl_completes_with_the_average_and_says_so():
    """HNTC (the paper's hybrid EKF, network completer) on a simulated MEMS mission whose DVL has 30 deg beams, where
    the network's envelope lets every ping through and the completions reach the filter: unbound (as it ran before)
    it is not Average-TC; bound, it counts every regressed ping in ``completer_fallbacks["dvl"]``, warns, and is
    Average-TC to the bit (the same average, window, noise and screening). On the trained DVL the keyframer binds
    without a warning."""
    from graphnav.estimators.keyframes import Keyframer
    from graphnav.evaluation import faults
    from graphnav.evaluation.methods import network_completer, run_method
    from graphnav.sim.simulate import default_config, simulate_mission
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    from network_on_other_dvl import Unbound
    config = default_config()
    config = dataclasses.replace(config, dvl=dataclasses.replace(config.dvl, theta_rad=np.deg2rad(30.0)))
    mission = simulate_mission(200.0, "mems", seed=1, config=config)
    run = mission.with_outage(*[faults.Outage(s, 30.0, (0, 2, 3)) for s in (60.0, 150.0)])
    average = run_method(run, "Average-TC", "3-missing")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        unbound = run_method(run, "HNTC", "3-missing", completer=Unbound(network_completer("3-missing")[0]))
    assert unbound.info["completer_fallbacks"] == {"envelope": 0, "pattern": 0, "dvl": 0, "period": 0}
    assert np.abs(unbound.v_n - average.v_n).max() > 1e-3
    with pytest.warns(RuntimeWarning, match="do not serve this DVL: .*30 deg from the vertical"):
        hybrid = run_method(run, "HNTC", "3-missing")
    # two 30 s outages, 1 Hz
    assert hybrid.info["completer_fallbacks"] == {"envelope": 0, "pattern": 0, "dvl": 60, "period": 0}
    np.testing.assert_array_equal(hybrid.v_n, average.v_n)
    rdi = dataclasses.replace(config, dvl=dataclasses.replace(config.dvl, theta_rad=np.deg2rad(20.0), psi_rad=RDI_PSI))
    with pytest.warns(RuntimeWarning, match="azimuths 270, 90, 0, 180 deg .*beam 1 36.8 deg"):
        Keyframer(rdi, completer=load_completer("auto"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Keyframer(default_config(), completer=load_completer("auto"))


def test_the_same_beams_numbered_differently_are_named_so():
    """An RDI head turned 45 deg has the trained beams in another order: refused (the networks take the beams by
    number), and the message says which is which."""
    turned = T_b(psi_rad=RDI_PSI, C_d_b=yawed(45.0))
    off = beam_direction_mismatch(T_b(), turned)
    assert "numbered differently (the mission's beams 1, 3, 4 are the trained DVL's 4, 1, 3)" in off
    np.testing.assert_allclose(T_b()[[3, 1, 0, 2]], turned, atol=1e-12)


def test_the_other_dvl_study_reports_the_network_over_the_average():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    import network_on_other_dvl as study
    np.testing.assert_allclose(study.spec_of(study.DVLS["yaw45"][1]).C_d_b, yawed(45.0))
    rows = [{"dvl": "X", "scenario": "2-missing", "mode": "per ping", "completer": name, "beam_rmse": b,
             "vel_rmse": v, "pings": 10, "envelope": e, "dvl_fallbacks": 0, "bound_to_other_dvl": True}
            for name, b, v, e in (("average", 0.1, 0.2, 0), ("network, unbound", 0.25, 0.3, 6),
                                  ("network, bound", 0.1, 0.2, 0))]
    assert "| X | 2-missing | per ping | 2.50 / 1.50 | 60% | 1.00 / 1.00 | yes |" in study.report(rows)


def test_the_other_dvl_study_finds_the_fold_network_that_held_a_trajectory_out(tmp_path):
    """Beam-only fold cards name their held-out trajectories, IMU-aware ones their training trajectories; the study runs
    each trajectory with the fold that did not train on it, and says so when none did."""
    import json
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    import network_on_other_dvl as study
    for fold, held in enumerate(((1, 3), (2, 5))):
        beam = tmp_path / "beam" / "recipe" / f"fold{fold}"
        imu = tmp_path / "imu" / f"fold{fold}"
        beam.mkdir(parents=True)
        imu.mkdir(parents=True)
        (beam / "3-missing.json").write_text(json.dumps({"data": {"held_out": list(held)}}))
        train = [t for t in (1, 2, 3, 5) if t not in held]
        (imu / "imu-3-missing.json").write_text(json.dumps({"data": {}, "split": {"train_trajectories": train}}))
    assert study.held_out_folder(tmp_path / "beam", "3-missing", "Trajectory5").name == "fold1"
    assert study.held_out_folder(tmp_path / "imu", "imu-3-missing", "Trajectory3").name == "fold0"
    assert study.held_out_folder(tmp_path / "imu", "imu-3-missing", "Trajectory2").name == "fold1"
    for kind, name in (("beam", "3-missing"), ("imu", "imu-3-missing")):      # a trajectory no fold had
        with pytest.raises(FileNotFoundError, match=f"no {name} fold network held out Trajectory7"):
            study.held_out_folder(tmp_path / kind, name, "Trajectory7")


def test_the_other_dvl_study_reports_each_estimator_family_over_its_method_without_a_completer():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    import network_on_other_dvl as study
    rows = [{"dvl": "X", "scenario": "3-missing", "trajectory": "T", "start_s": s, "family": "graph",
             "Graph-TC": 1.0, "Graph-HN": 0.8, "Graph-HNI": 0.75, "Graph-HNI, trained for it": hni}
            for s, hni in ((0, 0.7), (9, 0.9))]
    rows += [{"dvl": "X", "scenario": "3-missing", "trajectory": "T", "start_s": 0, "TC": 2.0, "Average-TC": 1.0,
              "HNTC": 1.5}]
    text = study.estimator_report(rows).splitlines()
    assert text[0] == ("| DVL | scenario | windows | Graph-HN / Graph-TC | Graph-HNI / Graph-TC | Graph-HNI, trained "
                       "for it / Graph-TC | windows > 1.02x Graph-HN: Graph-HNI; Graph-HNI, trained for it | "
                       "windows Graph-HNI, trained for it > 1.02x Graph-HNI |")
    assert text[2] == "| X | 3-missing | 2 | 0.800 | 0.750 | 0.800 | 0; 1 | 1 |"    # 0.9 > 1.02 * 0.8 in one window
    assert text[-1] == "| X | 3-missing | 1 | 0.500 | 0.750 | 1 |"       # the EKF rows (no family: the EKF's)


def test_the_studies_made_for_the_default_dvl_stop_on_fold_networks_trained_for_another():
    import types
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    from imu_completer_folds import default_dvl_only
    rdi = dataclasses.replace(DvlSpec(), psi_rad=RDI_PSI)
    default_dvl_only(types.SimpleNamespace(trained_T_b=T_b(), trained_dvl_spec=DvlSpec()), "x.py")
    with pytest.raises(SystemExit, match=r"x.py: its fold networks were trained for another DVL \(20 deg from the "
                                         r"vertical at azimuths 270, 90, 0, 180 deg\)"):
        default_dvl_only(types.SimpleNamespace(trained_T_b=DvlGeometry.from_spec(rdi).T_b, trained_dvl_spec=rdi),
                         "x.py")


def test_a_card_says_its_recipe_was_chosen_on_the_default_dvl_when_trained_for_another():
    from graphnav.nets.dvl_match import chosen_for_note
    assert chosen_for_note(None, "x") == "" and chosen_for_note(DvlSpec(), "x") == ""
    rdi = dataclasses.replace(DvlSpec(), psi_rad=RDI_PSI)
    note = chosen_for_note(rdi, "experiments/imu_completer_folds.py --config")
    assert "chosen on the default DVL's beams (20 deg from the vertical at azimuths 45, 135, 225, 315 deg)" in note
    assert "(20 deg from the vertical at azimuths 270, 90, 0, 180 deg)" in note
    assert note.endswith("come from experiments/imu_completer_folds.py --config")


def test_the_commands_say_how_many_pings_the_network_left_to_the_average(tmp_path, capsys):
    """`graphnav smooth` and `graphnav online` with a configuration whose DVL is an RDI head: the summary counts the
    pings under ``completer_fallbacks["dvl"]`` and prints them."""
    import json

    from graphnav.cli import main
    from graphnav.evaluation.methods import completer_fallbacks_line
    config = tmp_path / "rdi.json"
    config.write_text(json.dumps({"dvl": {"psi_rad": RDI_PSI.tolist()}}))
    for command in ("smooth", "online"):
        out = tmp_path / command
        with pytest.warns(RuntimeWarning, match="do not serve this DVL"):
            assert main([command, "--duration", "200", "--config", str(config), "--scenario", "3-missing",
                         "--method", "HNTC", "--out", str(out), "--no-plots"]) == 0
        counts = json.loads((out / "summary.json").read_text())["completer_fallbacks"]
        assert counts == {"envelope": 0, "pattern": 0, "dvl": 60, "period": 0}     # this run's, not the process's
        assert completer_fallbacks_line(counts) in capsys.readouterr().out
    assert completer_fallbacks_line({"envelope": 0, "dvl": 0}) == ""
    assert "2 for inputs outside its training envelope" in completer_fallbacks_line({"envelope": 2, "dvl": 0})
