"""The shipped beam-only networks on DVLs they were not trained for (docs/decisions/completers.md, "A network on a
DVL it was not trained for").

The networks were trained for one DVL: the Snapir's, as :class:`graphnav.core.config.DvlSpec` describes it by
default (beams 20 deg from the vertical at azimuths 45, 135, 225, 315 deg, the DVL along the body axes). Here the ten
A-KIT trajectories' recorded DVL velocities are turned into the beams of other DVLs (:func:`graphnav.nets.data.
akit_series` with another spec; beam noise seed ``--seed``) and each scenario's missing beams are completed:

- ``network, unbound``: the network as it completed every mission's beams before a completer was bound to the
  mission's DVL (its training envelope still checked);
- ``network, bound``: bound to the DVL (:mod:`graphnav.nets.dvl_match`), as the estimators now bind it: on a DVL it
  was not trained for every ping is the average estimator's;
- ``average``: the average estimator over the network's past window.

Per ping (true past) and through recursive 30-ping outages (:func:`graphnav.nets.evaluate.outage_rollout`). Printed:
the beam and velocity RMSE (velocity: least squares of the four beams with the DVL's own geometry) over the average
estimator's, and the share of pings the network's training envelope handed to the average. The trajectories are
those the shipped networks were trained on, so the network's numbers on its own DVL are in-sample (better than out
of fold); on the other DVLs that makes the comparison kinder to the network, not harsher. About 2 min (``--imu``
about 20 s more a DVL)::

    .venv/bin/python experiments/network_on_other_dvl.py
"""
from __future__ import annotations

import argparse
import dataclasses
import sys

import numpy as np

#: short name -> (what the DVL is, the DvlSpec fields that differ from the default: the Snapir's DVL, the one the
#: networks were trained for)
DVLS = {
    "snapir": ("Snapir (trained for)", {}),
    "rdi-convex": ("RDI convex head, 20 deg", {"psi_rad": np.deg2rad([270.0, 90.0, 0.0, 180.0])}),
    "theta25": ("Snapir head, 25 deg beams", {"theta_rad": np.deg2rad(25.0)}),
    "theta30": ("Snapir head, 30 deg beams", {"theta_rad": np.deg2rad(30.0)}),
    "yaw5": ("Snapir head turned 5 deg", {"C_d_b": "yaw 5"}),
    "yaw10": ("Snapir head turned 10 deg", {"C_d_b": "yaw 10"}),
    "yaw20": ("Snapir head turned 20 deg", {"C_d_b": "yaw 20"}),
    "yaw45": ("Snapir head turned 45 deg", {"C_d_b": "yaw 45"}),
}


def spec_of(changes: dict):
    """The :class:`DvlSpec` of a :data:`DVLS` entry's changes (``"yaw D"``: the head turned D deg about the body z
    axis)."""
    from scipy.spatial.transform import Rotation

    from graphnav.core.config import DvlSpec
    fields = dict(changes)
    if isinstance(fields.get("C_d_b"), str):
        fields["C_d_b"] = Rotation.from_euler("z", float(fields["C_d_b"].split()[1]), degrees=True).as_matrix()
    return dataclasses.replace(DvlSpec(), **fields)


def scored_row(dvl: str, scenario: str, mode: str, name: str, completer, complete, geometry, missing,
               bound_to_other_dvl: bool) -> dict:
    """One row: ``complete(completer)`` -> ``(full, sigma, scored)`` completions scored (beam / velocity RMSE, m/s,
    velocity with the DVL's ``geometry``) and the fallbacks the completer counted while it made them."""
    from graphnav.nets.evaluate import completion_metrics

    before = dict(getattr(completer, "fallbacks", {}))
    full, sigma, scored = complete(completer)
    m = completion_metrics(full, sigma, scored, missing, geometry)
    counts = {k: getattr(completer, "fallbacks", {}).get(k, 0) - n for k, n in before.items()}
    return {"dvl": DVLS[dvl][0], "scenario": scenario, "mode": mode, "completer": name,
            "beam_rmse": m["beam_rmse"], "vel_rmse": m["vel_rmse"], "pings": len(full),
            "envelope": counts.get("envelope", 0), "dvl_fallbacks": counts.get("dvl", 0),
            "bound_to_other_dvl": bound_to_other_dvl}


def rows_for(dvl: str, scenario: str, akit_dir, seed: int) -> list[dict]:
    """Rows of one DVL and scenario: per completer and mode, beam / velocity RMSE (m/s) and the envelope's share."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets import AverageCompleter, load_completer
    from graphnav.nets import data as beamdata
    from graphnav.nets.evaluate import outage_rollout, predict_completer

    spec = spec_of(DVLS[dvl][1])
    geometry = DvlGeometry.from_spec(spec)
    series = beamdata.akit_series(akit_dir, seed, spec=spec)
    unbound, bound = load_completer(scenario), load_completer(scenario)
    mismatch = bool(bound.bind_dvl(geometry.T_b))
    completers = {"average": AverageCompleter(unbound.n_past), "network, unbound": unbound,
                  "network, bound": bound}
    samples = beamdata.windows(series, unbound.n_past)
    missing = unbound.missing
    modes = {"per ping": lambda comp: (*predict_completer(comp, samples, missing), samples),
             "outage 30 s": lambda comp: outage_rollout(comp, series, missing)}
    return [scored_row(dvl, scenario, mode, name, comp, complete, geometry, missing, mismatch)
            for mode, complete in modes.items() for name, comp in completers.items()]


def imu_rows_for(dvl: str, scenario: str, akit_dir, seed: int) -> list[dict]:
    """The shipped IMU-aware network of ``scenario`` through recursive 30-ping outages (from ping
    :data:`graphnav.nets.imu_evaluate.OUTAGE_SETTLE`, its IMU window full) on one DVL's beams, recorded IMU: unbound,
    bound, and the average estimator it falls back to (rows as :func:`rows_for`'s, mode ``IMU-aware, outage 30 s``)."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets import load_imu_completer
    from graphnav.nets.evaluate import outage_rollout
    from graphnav.nets.imu_data import AKIT_SPLIT, akit_imu_series
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE

    spec = spec_of(DVLS[dvl][1])
    geometry = DvlGeometry.from_spec(spec)
    series = akit_imu_series(sorted(AKIT_SPLIT["train"] + AKIT_SPLIT["val"]), akit_dir, seed, spec=spec)
    unbound, bound = load_imu_completer(scenario), load_imu_completer(scenario)
    mismatch = bool(bound.bind_dvl(geometry.T_b))
    missing = unbound.missing

    def complete(comp):
        return outage_rollout(comp, series, missing, settle=OUTAGE_SETTLE)
    return [scored_row(dvl, scenario, "IMU-aware, outage 30 s", name, comp, complete, geometry, missing, mismatch)
            for name, comp in (("average", unbound.fallback), ("network, unbound", unbound), ("network, bound", bound))]


def write_config(dvl: str, path: str) -> None:
    """A sensor configuration (JSON) whose DVL is the :data:`DVLS` entry ``dvl``: for ``graphnav train-beams --config``
    and ``graphnav eval-beams --folds --config`` (networks trained for that DVL)."""
    import json
    from pathlib import Path
    spec = spec_of(DVLS[dvl][1])
    fields = {k: np.asarray(getattr(spec, k)).tolist() for k in DVLS[dvl][1]}
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps({"dvl": fields}, indent=1) + "\n")


def ping_rate_rows(rates, duration_s: float = 1200.0, seed: int = 2) -> list[str]:
    """The DVL's ping period. The shipped beam-only networks per ping (true past) on simulated missions
    (``graphnav.simulate_mission``, navigation-grade IMU, seed ``seed``) whose DVL pings at each of ``rates`` Hz, their
    past window of N pings spanning N / rate s: beam / velocity RMSE over the average estimator's (same N), as table
    rows, unbound (no stamps: as the networks completed every ping before the ping period was checked) and bound (the
    pings' stamps handed on as the estimators' history hands them), with the share of pings the bound network left to
    the average estimator for their period."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets import AverageCompleter, load_completer
    from graphnav.sim.simulate import default_config, simulate_mission

    lines = []
    for rate in rates:
        config = default_config()
        config.dvl = dataclasses.replace(config.dvl, rate_hz=float(rate))
        mission = simulate_mission(duration_s, "navigation", seed=seed, config=config)
        t, beams, ok = mission.dvl.t, mission.dvl.beams, mission.dvl.valid.all(axis=1)
        T_pinv = np.linalg.pinv(DvlGeometry.from_spec(config.dvl).T_d)
        for scenario in ("2-missing", "3-missing"):
            net = load_completer(scenario)
            n, missing = net.n_past, list(net.missing)
            average = AverageCompleter(n)
            err = {"average": [], "unbound": [], "bound": []}
            before = net.fallbacks["period"]
            for k in range(n, len(beams)):
                if not ok[k - n:k + 1].all():
                    continue
                measured = beams[k].copy()
                measured[missing] = np.nan
                past, past_dt_s = beams[k - n:k], np.diff(t[k - n:k + 1])
                err["average"].append(average.complete(past, measured)[0] - beams[k])
                err["unbound"].append(net.complete(past, measured)[0] - beams[k])
                err["bound"].append(net.complete(past, measured, past_dt_s=past_dt_s)[0] - beams[k])
            e = {k: np.array(v) for k, v in err.items()}
            cells = []
            for mode in ("unbound", "bound"):
                beam = np.sqrt(np.mean(e[mode][:, missing] ** 2) / np.mean(e["average"][:, missing] ** 2))
                vel = np.sqrt(np.mean(np.sum((e[mode] @ T_pinv.T) ** 2, axis=1))
                              / np.mean(np.sum((e["average"] @ T_pinv.T) ** 2, axis=1)))
                cells.append(f"{beam:.2f} / {vel:.2f}")
            refused = (net.fallbacks["period"] - before) / len(e["average"])
            lines.append(f"| simulated, {rate:g} Hz | {scenario} | {len(e['average'])} | {cells[0]} | {cells[1]} | "
                         f"{100 * refused:.0f} % | - |")
    return lines


def ratios(net, samples, geometry) -> list[float]:
    """Beam and velocity RMSE of the network ``net`` over the average estimator's (same N), per ping on ``samples``
    (true past), velocity with the DVL's ``geometry``."""
    from graphnav.nets import AverageCompleter
    from graphnav.nets.evaluate import completion_metrics, predict_completer

    m = {k: completion_metrics(*predict_completer(c, samples, net.missing), samples, net.missing, geometry)
         for k, c in (("network", net), ("average", AverageCompleter(net.n_past)))}
    return [m["network"][k] / m["average"][k] for k in ("beam_rmse", "vel_rmse")]


def decimated_rows(steps, akit_dir, seed: int) -> list[str]:
    """A slower DVL (or missed pings) on real motion: the beams of the A-KIT trajectories and of ``V_test.npy`` (the
    BeamsNet recordings no network was trained on; noise seed ``seed``) keeping every ``step``-th ping, each of
    ``steps`` (every phase, pooled), so that the networks' past pings are ``step`` s apart. The shipped beam-only
    networks per ping: beam / velocity RMSE over the average estimator's (same N), unbound and bound (the average's,
    1.00 / 1.00, where the spacing is refused), and the worst recording's velocity ratio unbound, as table rows.
    A-KIT is in sample: the networks were trained on those trajectories at 1 Hz. A data set that is absent is left
    out."""
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.core.errors import DataError
    from graphnav.nets import load_completer
    from graphnav.nets.data import BeamSeries, akit_series, beamsnet_series, windows

    geometry = DvlGeometry.from_spec(DvlSpec())
    lines = []
    for scenario in ("2-missing", "3-missing"):
        net = load_completer(scenario)
        data = {}
        try:
            data["A-KIT (in sample)"] = akit_series(akit_dir, seed)
        except DataError:
            pass
        try:
            yaw = net.card.get("data", {}).get("align_yaw_deg", 0.0)    # the frame the network was trained in
            data["V_test (never trained on)"] = [beamsnet_series("test", None, seed, align_yaw_deg=yaw)]
        except DataError:
            pass
        for name, series in data.items():
            for step in steps:
                slow = [BeamSeries(f"{s.name}/{step}:{phase}", s.v_b[phase::step], s.beams[phase::step])
                        for s in series for phase in range(step)]
                slow = [s for s in slow if len(s.beams) > net.n_past]
                ratio = ratios(net, windows(slow, net.n_past), geometry)
                # each recording alone (a trajectory's parts and phases together): the worst velocity ratio
                groups = {s.name.split("/")[0].split("#")[0] for s in slow}
                worst = max(ratios(net, windows([s for s in slow if s.name.split("/")[0].split("#")[0] == g],
                                                net.n_past), geometry)[1] for g in groups)
                pings = sum(len(s.beams) - net.n_past for s in slow)
                cell = f"{ratio[0]:.2f} / {ratio[1]:.2f}"
                refused = net.period_mismatch(np.full(net.n_past, float(step)))     # every past spaced alike
                lines.append(f"| {name}, pings {step} s apart | {scenario} | {pings} | {cell} | "
                             f"{'1.00 / 1.00' if refused else cell} | {100 if refused else 0} % | {worst:.2f} |")
    return lines


class Unbound:
    """A completer as it ran before completers were bound to the mission's DVL: everything but ``bind_dvl``."""

    def __init__(self, completer):
        completer.bind_dvl(completer.trained_T_b if hasattr(completer, "trained_T_b") else
                           next(iter(completer.networks.values())).trained_T_b)      # clear an earlier binding
        self._completer = completer

    def __getattr__(self, name):
        if name == "bind_dvl":
            raise AttributeError(name)
        return getattr(self._completer, name)


#: The methods of each estimator family the estimator check runs: the one without a completer (the ratios' base), the
#: one with the average estimator, the one with the beam-only network, the one with the IMU-aware completer.
FAMILIES = {"ekf": ("TC", "Average-TC", "HNTC", "HNTC-IMU"),
            "graph": ("Graph-TC", "Graph-HN", "Graph-HN-net", "Graph-HNI")}


def estimator_rows(dvl: str, scenario: str, akit_dir, window_s: float = 30.0, grade: str = "as-recorded",
                   fold_nets=None, fold_imu_nets=None, family: str = "ekf") -> list[dict]:
    """An estimator family (:data:`FAMILIES`: the paper's hybrid EKF, or the graph) on each A-KIT trajectory with
    ``dvl``'s beams, through the bench's outage windows of ``window_s`` (``graphnav.evaluation.bench.case_windows``)
    with IMU ``grade`` (the bench's errors and seed): window VRMSE (m/s) of the method without a completer (``TC`` /
    ``Graph-TC``), the one with the average estimator, and the one with the beam-only network unbound and as it runs
    now (bound: on another DVL it is the average's). ``fold_nets``: a folder of networks trained for this DVL out of
    fold (``graphnav eval-beams --folds --config ... --save-nets``: ``fold<k>`` folders whose cards name the
    trajectories they held out); each trajectory is then also run with the one that held it out ("<method>, trained for
    it"). ``fold_imu_nets`` (with ``fold_nets``): a folder of IMU-aware networks trained for this DVL out of fold
    (``experiments/imu_completer_folds.py --config ... --save-nets``); then also the IMU-aware method (``HNTC-IMU`` /
    ``Graph-HNI``) as it runs now (bound) and with the fold networks that held each trajectory out
    (:func:`held_out_imu_completer`)."""
    import warnings
    import zlib

    from graphnav.core.config import SensorConfig
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation import vrmse
    from graphnav.evaluation.bench import case_windows
    from graphnav.evaluation.bench.cases import degrade_imu
    from graphnav.evaluation.methods import network_completer, run_method
    from graphnav.io.paths import akit_trajectories
    from graphnav.missions import load_akit

    base, average, network, imu = FAMILIES[family]
    config = SensorConfig(dvl=spec_of(DVLS[dvl][1]))
    out = []
    for traj in akit_trajectories(akit_dir):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mission = load_akit(traj, config=config)
            if grade != "as-recorded":         # the bench's IMU errors and seed (prepared_mission)
                mission = degrade_imu(mission, grade, seed=zlib.crc32(traj.name.encode()) % 2**31)
            starts = case_windows(mission, window_s)
            run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
            sols = {base: run_method(run, base, scenario), average: run_method(run, average, scenario),
                    f"{network}, unbound": run_method(run, network, scenario,
                                                      completer=Unbound(network_completer(scenario)[0])),
                    network: run_method(run, network, scenario)}
            if fold_nets is not None:
                sols[f"{network}, trained for it"] = run_method(
                    run, network, scenario, completer=held_out_network(fold_nets, scenario, traj.name))
            if fold_imu_nets is not None:
                sols[imu] = run_method(run, imu, scenario)
                sols[f"{imu}, trained for it"] = run_method(
                    run, imu, scenario, completer=held_out_imu_completer(fold_imu_nets, fold_nets, scenario, traj.name))
        for s in starts:
            out.append({"dvl": DVLS[dvl][0], "scenario": scenario, "trajectory": traj.name, "start_s": s,
                        "family": family,
                        **{name: vrmse(sol, mission.gt, s, s + window_s) for name, sol in sols.items()}})
    return out


def held_out_folder(folder, name: str, trajectory: str):
    """The folder under ``folder`` (``fold<k>`` subfolders of ``eval-beams --folds --save-nets`` or
    ``imu_completer_folds.py --save-nets``, any depth) whose model card ``<name>.json`` held out ``trajectory``
    (``TrajectoryN``): its ``data["held_out"]``, or, for a card that lists only its training trajectories, one that
    was not trained on it while another fold was."""
    import json
    from pathlib import Path

    number = int(trajectory.removeprefix("Trajectory"))
    cards = {f.parent: json.loads(f.read_text()) for f in sorted(Path(folder).rglob(f"{name}.json"))}
    trained = {t for card in cards.values() for t in card.get("split", {}).get("train_trajectories", [])}
    for where, card in cards.items():
        held = card["data"].get("held_out")
        if number in held if held is not None else (number in trained
                                                    and number not in card["split"]["train_trajectories"]):
            return where
    raise FileNotFoundError(f"{folder}: no {name} fold network held out {trajectory}")


def held_out_network(folder, scenario: str, trajectory: str):
    """The beam-only network of ``folder`` (:func:`held_out_folder`) whose fold held out ``trajectory``."""
    from graphnav.nets import load_completer
    return load_completer(scenario, directory=held_out_folder(folder, scenario, trajectory))


def held_out_imu_completer(imu_folder, beam_folder, scenario: str, trajectory: str):
    """``HNTC-IMU``'s completer built as the shipped one (:func:`graphnav.nets.imu_auto.load_imu_auto_completer`) from
    the fold networks that held out ``trajectory``: the IMU-aware network of ``imu_folder`` fused with the beam-only
    network of ``beam_folder``, which also serves the pings the IMU-aware one cannot."""
    from graphnav.nets import load_completer
    from graphnav.nets.imu_auto import FUSED_RUN_DECAY, load_imu_auto_completer
    from graphnav.nets.imu_network import imu_weights_name
    beam_dirs = {scenario: held_out_folder(beam_folder, scenario, trajectory)}
    return load_imu_auto_completer({scenario: held_out_folder(imu_folder, imu_weights_name(scenario), trajectory)},
                                   load_completer("auto", directory=beam_dirs),
                                   fused_beam_only=load_completer("auto", directory=beam_dirs,
                                                                  run_decay=FUSED_RUN_DECAY[scenario]["beam-only"]),
                                   patterns=(scenario,))


def estimator_report(rows: list[dict]) -> str:
    """Per estimator family, DVL and scenario: the mean over the windows of each method's window VRMSE over the
    method without a completer's (``TC`` / ``Graph-TC``); how many windows each made worse than the method with the
    average estimator (``Average-TC`` / ``Graph-HN``) by more than 2 %; and how many windows each method with networks
    trained for the DVL made worse by more than 2 % than the same method as it runs now (bound to the DVL, which
    leaves the shipped networks' pings to the average)."""
    lines = []
    for family in dict.fromkeys(r.get("family", "ekf") for r in rows):
        base, average = FAMILIES[family][:2]
        ours = [r for r in rows if r.get("family", "ekf") == family]
        names = [k for k in ours[0] if k not in ("dvl", "scenario", "trajectory", "start_s", "family", base)]
        trained = [k for k in names if k.endswith(", trained for it") and k.removesuffix(", trained for it") in names]
        lines += ["", "| DVL | scenario | windows | " + " | ".join(f"{k} / {base}" for k in names)
                  + f" | windows > 1.02x {average}: " + "; ".join(k for k in names if k != average) + " |"
                  + ("".join(f" windows {k} > 1.02x {k.removesuffix(', trained for it')} |" for k in trained)),
                  "| --- | --- | --- | " + "--- | " * (len(names) + len(trained)) + "--- |"]
        for key in dict.fromkeys((r["dvl"], r["scenario"]) for r in ours):
            sel = [r for r in ours if (r["dvl"], r["scenario"]) == key]
            ratio = {k: np.mean([r[k] / r[base] for r in sel]) for k in names}
            worse = [str(sum(r[k] > 1.02 * r[average] for r in sel)) for k in names if k != average]
            own = [sum(r[k] > 1.02 * r[k.removesuffix(", trained for it")] for r in sel) for k in trained]
            lines.append(f"| {key[0]} | {key[1]} | {len(sel)} | " + " | ".join(f"{ratio[k]:.3f}" for k in names)
                         + f" | {'; '.join(worse)} |" + "".join(f" {n} |" for n in own))
    return "\n".join(lines[1:])


def report(rows: list[dict]) -> str:
    """The network's RMSE over the average's, per DVL, scenario and mode."""
    lines = ["| DVL | scenario | mode | network unbound: beam / velocity x average | envelope caught | "
             "network bound: beam / velocity x average | bound to another DVL |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    keys = dict.fromkeys((r["dvl"], r["scenario"], r["mode"]) for r in rows)
    for key in keys:
        by = {r["completer"]: r for r in rows if (r["dvl"], r["scenario"], r["mode"]) == key}
        avg, unb, bnd = by["average"], by["network, unbound"], by["network, bound"]
        lines.append(f"| {key[0]} | {key[1]} | {key[2]} | {unb['beam_rmse'] / avg['beam_rmse']:.2f} / "
                     f"{unb['vel_rmse'] / avg['vel_rmse']:.2f} | {unb['envelope'] / unb['pings']:.0%} | "
                     f"{bnd['beam_rmse'] / avg['beam_rmse']:.2f} / {bnd['vel_rmse'] / avg['vel_rmse']:.2f} | "
                     f"{'yes' if bnd['bound_to_other_dvl'] else 'no'} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--seed", type=int, default=1000, help="beam noise seed (default 1000: not a training draw)")
    p.add_argument("--dvls", nargs="+", choices=list(DVLS), default=list(DVLS), help="DVLs to score (default all): "
                   + "; ".join(f"{k}: {label}" for k, (label, _) in DVLS.items()))
    p.add_argument("--estimator", action="store_true", help="also HNTC through the bench's outage windows of every "
                   "trajectory (about 2 min a DVL at 120 s; the DVLs with the head along the body axes: the loader "
                   "refuses a turned head's velocities, which are the recorded ones)")
    p.add_argument("--fold-nets", metavar="PREFIX", help="--estimator: also HNTC with networks trained for the DVL out "
                   "of fold, from PREFIX_<scenario> (graphnav eval-beams --folds --config C --scenario S --save-nets "
                   "PREFIX_S); each trajectory with the fold network that held it out")
    p.add_argument("--fold-imu-nets", metavar="PREFIX", help="with --fold-nets: also HNTC-IMU, as it runs now and with "
                   "IMU-aware networks trained for the DVL out of fold, from PREFIX_<scenario> (experiments/"
                   "imu_completer_folds.py --config C --missing S --save-nets PREFIX_S), fused with --fold-nets' "
                   "networks as the shipped ones are; each trajectory with the fold networks that held it out")
    p.add_argument("--graph", action="store_true", help="--estimator: the graph's methods (Graph-TC, Graph-HN, "
                   "Graph-HN-net, Graph-HNI) instead of the paper's EKF's (TC, Average-TC, HNTC, HNTC-IMU)")
    p.add_argument("--window-s", type=float, default=30.0, help="--estimator: outage length, s (default 30)")
    p.add_argument("--json", metavar="FILE", help="--estimator: also write the window rows (VRMSE per method) here")
    p.add_argument("--grade", default="as-recorded", choices=["as-recorded", "tactical", "mems"],
                   help="--estimator: IMU grade (default as-recorded)")
    p.add_argument("--ping-rates", nargs="+", type=float, metavar="HZ", help="instead: the beam-only networks on "
                   "simulated missions whose DVL pings at these rates (Hz, dividing the IMU's 100 Hz; the networks "
                   "were trained at 1 Hz), unbound and bound to the ping period, and on A-KIT and V_test with every "
                   "2nd, 3rd, 5th and 10th ping kept")
    p.add_argument("--imu", action="store_true", help="also the IMU-aware networks through outages (about 20 s "
                   "more a DVL)")
    p.add_argument("--write-config", nargs=2, metavar=("DVL", "FILE"), help="instead: write a sensor configuration "
                   "whose DVL is DVL (one of --dvls' names) to FILE, for graphnav train-beams / eval-beams --config")
    a = p.parse_args(argv)
    if a.write_config and a.write_config[0] not in DVLS:
        p.error(f"--write-config: no DVL {a.write_config[0]!r}; choose from {', '.join(DVLS)}")
    if a.fold_nets and not (a.estimator and len(a.dvls) == 1):
        p.error("--fold-nets goes with --estimator and the one DVL its networks were trained for (--dvls NAME)")
    if a.fold_imu_nets and not a.fold_nets:
        p.error("--fold-imu-nets goes with --fold-nets: the IMU-aware networks are fused with beam-only ones")
    if a.write_config:
        write_config(*a.write_config)
        return 0
    if a.ping_rates:
        print("| DVL pings | scenario | pings | network unbound: beam / velocity x average, per ping | bound | "
              "pings left to the average (period) | unbound velocity, worst recording |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
        print("\n".join(ping_rate_rows(a.ping_rates)))
        from graphnav.core.errors import ConfigError
        try:
            print("\n".join(decimated_rows((1, 2, 3, 5, 10), a.data, a.seed)))
        except ConfigError as exc:
            print(f"A-KIT rows skipped: {exc}", file=sys.stderr)
        return 0
    from graphnav.core.errors import ConfigError
    from graphnav.io.paths import akit_trajectories
    try:
        akit_trajectories(a.data)
    except ConfigError as exc:
        print(f"skipped: {exc}", file=sys.stderr)
        return 0
    rows, est = [], []
    for dvl in a.dvls:
        for scenario in ("2-missing", "3-missing"):
            rows += rows_for(dvl, scenario, a.data, a.seed)
            if a.imu:
                rows += imu_rows_for(dvl, scenario, a.data, a.seed)
            # a turned head's recorded velocities would be turned as well, and the loader refuses them (rightly)
            if a.estimator and "C_d_b" not in DVLS[dvl][1]:
                est += estimator_rows(dvl, scenario, a.data, a.window_s, a.grade,
                                      f"{a.fold_nets}_{scenario}" if a.fold_nets else None,
                                      f"{a.fold_imu_nets}_{scenario}" if a.fold_imu_nets else None,
                                      "graph" if a.graph else "ekf")
    print(report(rows))
    if est:
        print(f"\nIn the estimator ({a.window_s:g} s outages, IMU {a.grade}), window VRMSE over the method without a "
              "completer's (mean over the windows):\n")
        print(estimator_report(est))
        if a.json:
            import json
            with open(a.json, "w") as fh:
                json.dump(est, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
