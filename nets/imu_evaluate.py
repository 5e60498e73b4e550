"""The IMU-aware completer against the average estimator and the beam-only network, on A-KIT trajectories.

Per ping: every ping completed from the true past. Recursive outage: 30-ping outages of the missing beams,
each completer fed its own completions through :class:`graphnav.estimators.history.BeamHistory` (as the estimators do),
windows every 90 pings from ping :data:`OUTAGE_SETTLE` (the IMU window must be full). Every method is
scored on the same pings. Beam RMSE is over the filled beams against the beams the DVL would have reported;
velocity RMSE is least squares on the four completed beams against the recorded DVL velocity. The beams are made
for the DVL the IMU-aware network was trained for (its card's ``data["beam_model"]``), and the velocities solved
with its geometry.
"""
from __future__ import annotations

import numpy as np

from .average import AverageCompleter
from .evaluate import metrics_with_floor, outage_rollout, predict_completer, predict_network
from .imu_data import AKIT_SPLIT, ImuBeamSamples, akit_imu_series, graded_series, imu_windows
from .imu_network import ImuNetworkCompleter, load_imu_completer, model_inputs
from .imu_window import IMU_WINDOW_S

#: First ping of the recursive outage windows (after the IMU window has filled), pings.
OUTAGE_SETTLE = int(IMU_WINDOW_S) + 5


def predict_imu_network(model, samples: ImuBeamSamples, batch: int = 4096):
    """Completed beams (S, 4) and sigma (S, 4) (0 for measured beams) of the IMU-aware network."""
    return predict_network(model, samples, batch, extra=lambda sl: model_inputs(samples.imu, sl))


def evaluate_imu(scenarios=("2-missing", "3-missing"), trajectories=AKIT_SPLIT["val"], directory=None,
                 akit_dir=None, beam_seed: int = 1000, outage: bool = True, completers=None,
                 tail_fraction: float | None = None, imu_grade: str | None = None,
                 imu_seed: int = 5000, fused: bool = False) -> list[dict]:
    """Rows of metrics: per scenario, mode (per ping / outage 30 s) and method.

    Methods: ``imu-network`` (the IMU-aware network), ``average`` (N = 3 for 2 missing beams, 5 for 3, as
    the estimators use it, :data:`graphnav.nets.average.AVERAGE_N_PAST`) and
    ``network`` (the shipped beam-only network; none in a total outage, ``0-beams``). ``completers`` maps a scenario to an
    :class:`ImuNetworkCompleter` to evaluate instead of the shipped one (used while training).
    ``tail_fraction``: only the last part of each trajectory (the selection pings of the training
    trajectories, :class:`~graphnav.nets.imu_recipes.ImuTrainOptions` ``select_fraction``); the outage windows
    then follow one another from the first ping with a full past.
    ``imu_grade``: add that grade's IMU errors to each trajectory's recorded IMU (seed ``imu_seed`` +
    trajectory number; :meth:`~graphnav.nets.imu_data.ImuBeamSeries.with_imu_grade`).
    ``fused``: also ``imu+average``, the IMU-aware network and the average combined by their sigmas
    (:class:`graphnav.nets.fused.FusedCompleter`).
    Each scenario's beams are made for the DVL its IMU-aware network was trained for (:meth:`ImuNetworkCompleter.
    trained_dvl_spec`); the shipped beam-only network is compared only when it was trained for that DVL too.
    """
    from graphnav.core.dvl import DvlGeometry

    from .fused import FusedCompleter, fuse
    from .average import AVERAGE_N_PAST
    from .network import load_completer

    rows = []
    for scen in scenarios:
        imu_net = (completers or {}).get(scen) or load_imu_completer(scen, directory)
        spec = imu_net.trained_dvl_spec
        geometry = DvlGeometry.from_spec(spec)
        series = graded_series(akit_imu_series(trajectories, akit_dir, beam_seed, spec=spec), imu_grade, imu_seed)
        settle, gap = OUTAGE_SETTLE, 60
        if tail_fraction is not None:
            series = [s.tail(tail_fraction) for s in series]
            settle, gap = 5, 0
        methods = {"imu-network": imu_net, "average": AverageCompleter(AVERAGE_N_PAST[scen])}
        if len(imu_net.missing) < 4:        # no beam-only network completes a ping without a measured beam
            beam_only = load_completer(scen)
            if not beam_only.bind_dvl(geometry.T_b):
                methods["network"] = beam_only
        n_past = max(c.n_past for c in methods.values())
        samples = imu_windows(series, n_past, imu_net.imu_samples, imu_net.ping_dt)
        made = {}
        for name, comp in methods.items():
            if isinstance(comp, ImuNetworkCompleter):
                # the same pings: those with the longest past window (the IMU window is full from ping n_past
                # on in a tail, after any past window otherwise)
                own = imu_windows(series, comp.n_past, comp.imu_samples, comp.ping_dt, pings=slice(n_past, None))
                if not np.array_equal(own.beams, samples.beams):
                    raise RuntimeError("IMU network samples are not the pings of the other methods")
                full, sigma = predict_imu_network(comp.model, own)
            else:
                full, sigma = predict_completer(comp, samples, imu_net.missing)
            made[name] = full, sigma
        if fused:
            made["imu+average"] = fuse(*made["imu-network"], *made["average"])
            methods["imu+average"] = FusedCompleter(imu_net, methods["average"])
        for name, (full, sigma) in made.items():
            rows.append({"scenario": scen, "mode": "per ping", "method": name,
                         **metrics_with_floor(full, sigma, samples, imu_net.missing, geometry)})
        if outage:
            for name, comp in methods.items():
                rows.append({"scenario": scen, "mode": "outage 30 s", "method": name,
                             **metrics_with_floor(*outage_rollout(comp, series, imu_net.missing, gap=gap,
                                                                  settle=settle), imu_net.missing, geometry)})
    for r in rows:
        avg = next(a for a in rows if a["scenario"] == r["scenario"] and a["mode"] == r["mode"]
                   and a["method"] == "average")
        r["beam_gain_pct"] = 100.0 * (1.0 - r["beam_rmse"] / avg["beam_rmse"])
        r["vel_gain_pct"] = 100.0 * (1.0 - r["vel_rmse"] / avg["vel_rmse"])
    return rows


def format_imu_table(rows: list[dict]) -> str:
    """Markdown table of :func:`evaluate_imu` rows (m/s; gain = reduction against the average, %)."""
    lines = ["| scenario | mode | method | beam RMSE | gain | vel RMSE | gain | 4-beam vel | in 1s | in 2s | n |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['scenario']} | {r['mode']} | {r['method']} | {r['beam_rmse']:.4f} | "
                     f"{r['beam_gain_pct']:+.1f} % | {r['vel_rmse']:.4f} | {r['vel_gain_pct']:+.1f} % | "
                     f"{r['all_beams_vel_rmse']:.4f} | {r['within_1sigma']:.3f} | {r['within_2sigma']:.3f} | "
                     f"{r['n']} |")
    return "\n".join(lines)


def evaluate_imu_per_trajectory(scenarios=("2-missing", "3-missing"), trajectories=AKIT_SPLIT["val"],
                                **kwargs) -> list[dict]:
    """:func:`evaluate_imu` rows of each trajectory alone and of all of them pooled (key ``trajectories``)."""
    groups = [(t,) for t in trajectories] + ([tuple(trajectories)] if len(trajectories) > 1 else [])
    rows = []
    for group in groups:
        for r in evaluate_imu(scenarios, group, **kwargs):
            rows.append({"trajectories": list(group), **r})
    return rows


def format_imu_summary(rows: list[dict]) -> str:
    """Markdown table of the IMU-aware network against the average per trajectory group (rows of
    :func:`evaluate_imu_per_trajectory`): beam and velocity RMSE (m/s), gain (%), sigma coverage."""
    lines = ["| trajectories | scenario | mode | beam RMSE net / avg | gain | vel RMSE net / avg | gain | in 1s / 2s |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        if r["method"] != "imu-network":
            continue
        avg = next(a for a in rows if a["trajectories"] == r["trajectories"] and a["scenario"] == r["scenario"]
                   and a["mode"] == r["mode"] and a["method"] == "average")
        name = ",".join(str(t) for t in r["trajectories"])
        lines.append(f"| {name} | {r['scenario']} | {r['mode']} | {r['beam_rmse']:.4f} / {avg['beam_rmse']:.4f} | "
                     f"{r['beam_gain_pct']:+.1f} % | {r['vel_rmse']:.4f} / {avg['vel_rmse']:.4f} | "
                     f"{r['vel_gain_pct']:+.1f} % | {r['within_1sigma']:.3f} / {r['within_2sigma']:.3f} |")
    return "\n".join(lines)
