"""Metrics of beam completers on windowed samples: beam RMSE, velocity RMSE, sigma calibration.

Errors of a filled beam are taken against the beam the DVL would have reported (made with the error
model, noise included), as in the paper; the velocity error is the least-squares velocity of the
completed four beams against the true (recorded) DVL velocity.
"""
from __future__ import annotations

import numpy as np
import torch

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry

from .average import AverageCompleter
from .data import BeamSamples
from .model import BeamRegressor


def predict_network(model: BeamRegressor, samples: BeamSamples, batch: int = 4096, extra=None):
    """Completed beams (S, 4) and sigma (S, 4) (0 for measured beams) of the network on all samples.

    ``extra(slice)`` gives further input tensors of a batch after the past and measured beams (the IMU
    features of :class:`~graphnav.nets.imu_model.ImuBeamRegressor`).
    """
    miss, kept = list(model.missing), list(model.kept)
    past = torch.as_tensor(samples.past[:, -model.n_past:], dtype=torch.float32)
    meas = torch.as_tensor(samples.beams[:, kept], dtype=torch.float32)
    out, sig = [], []
    model.eval()
    with torch.no_grad():
        for i in range(0, len(samples), batch):
            sl = slice(i, i + batch)
            b, s = model(past[sl], meas[sl], *(extra(sl) if extra is not None else ()))
            out.append(b.double().numpy())
            sig.append(s.double().numpy())
    full = samples.beams.copy()
    sigma = np.zeros_like(full)
    full[:, miss] = np.concatenate(out)
    sigma[:, miss] = np.concatenate(sig)
    return full, sigma


def predict_completer(completer, samples: BeamSamples, missing) -> tuple[np.ndarray, np.ndarray]:
    """Completed beams and sigma of any completer (``complete(past, measured)``), one ping at a time."""
    missing = list(missing)
    full, sigma = np.empty_like(samples.beams), np.empty_like(samples.beams)
    for i in range(len(samples)):
        measured = samples.beams[i].copy()
        measured[missing] = np.nan
        full[i], sigma[i] = completer.complete(samples.past[i, -completer.n_past:], measured)
    return full, sigma


def completion_metrics(full: np.ndarray, sigma: np.ndarray, samples: BeamSamples, missing,
                       geometry: DvlGeometry | None = None) -> dict:
    """Metrics of completed beams ``full`` (S, 4) with ``sigma`` (S, 4) for the ``missing`` beams.

    Returns a dict: ``beam_rmse`` (m/s, over all filled beams), ``beam_rmse_per_beam`` (list, order of
    ``missing``), ``vel_rmse`` (m/s, ``sqrt(mean |v_ls - v_true|^2)``), ``within_1sigma`` and
    ``within_2sigma`` (fractions of filled-beam errors inside 1 and 2 sigma; Gaussian: 0.683, 0.954),
    ``z_rms`` (RMS of error/sigma, 1 when calibrated) and ``n`` (samples).
    """
    geometry = geometry or DvlGeometry.from_spec(DvlSpec())
    missing = list(missing)
    err = full[:, missing] - samples.beams[:, missing]
    z = np.abs(err) / sigma[:, missing]
    v = geometry.velocity_from_beams(full)
    return {
        "beam_rmse": float(np.sqrt(np.mean(err ** 2))),
        "beam_rmse_per_beam": np.sqrt(np.mean(err ** 2, axis=0)).tolist(),
        "vel_rmse": float(np.sqrt(np.mean(np.sum((v - samples.v_b) ** 2, axis=1)))),
        "within_1sigma": float(np.mean(z <= 1.0)),
        "within_2sigma": float(np.mean(z <= 2.0)),
        "z_rms": float(np.sqrt(np.mean(z ** 2))),
        "n": int(len(samples)),
    }


def full_beam_vel_rmse(samples: BeamSamples, geometry: DvlGeometry | None = None) -> float:
    """Velocity RMSE (m/s) of least squares on all four made beams: the floor any completer is judged by."""
    geometry = geometry or DvlGeometry.from_spec(DvlSpec())
    v = geometry.velocity_from_beams(samples.beams)
    return float(np.sqrt(np.mean(np.sum((v - samples.v_b) ** 2, axis=1))))


def outage_window_starts(n_pings: int, n_past: int, window: int = 30, gap: int = 60, settle: int = 10) -> list[int]:
    """First pings of the outage windows :func:`outage_rollout` makes in a series of ``n_pings`` pings: from ping
    ``settle`` (at least ``n_past``), every ``window + gap`` pings, while a whole window fits."""
    return list(range(max(settle, n_past), n_pings - window + 1, window + gap))


def outage_rollout(completer, series, missing, window: int = 30, gap: int = 60, settle: int = 10):
    """Complete 30-ping outages recursively, as an estimator does (:class:`graphnav.estimators.history.BeamHistory`).

    In each window the ``missing`` beams are removed; the history is primed with the full pings before the
    window and then holds earlier completions, so errors can grow through the window. Windows start at
    ping ``settle`` (at least ``n_past``) and repeat every ``window + gap`` pings of each series.
    A completer with ``needs_imu`` gets the IMU window of each ping (series with ``imu_window``,
    :class:`graphnav.nets.imu_data.ImuBeamSeries`); give every compared completer the same ``settle``.

    Returns:
        :class:`BeamSamples`-aligned arrays ``(full, sigma, samples)`` over all in-window pings, ready for
        :func:`completion_metrics` (``samples.past`` is empty: the past is the completer's own).
    """
    from graphnav.estimators.history import BeamHistory

    from .data import BeamSeries

    series = [series] if isinstance(series, BeamSeries) else series
    missing = list(missing)
    valid = np.ones(4, dtype=bool)
    valid[missing] = False
    full, sigma, beams, v = [], [], [], []
    for s in series:
        for start in outage_window_starts(len(s.beams), completer.n_past, window, gap, settle):
            hist = BeamHistory(completer.n_past)
            for k in range(start - completer.n_past, start):
                hist.push(s.beams[k])
            for k in range(start, start + window):
                imu = (s.imu_window(k, completer.imu_samples) if getattr(completer, "needs_imu", False)
                       else None)
                b, sg = hist.complete(completer, s.beams[k], valid, imu=imu)
                full.append(b)
                sigma.append(sg)
                beams.append(s.beams[k])
                v.append(s.v_b[k])
    samples = BeamSamples(np.zeros((len(beams), 0, 4)), np.array(beams), np.array(v))
    return np.array(full), np.array(sigma), samples


def evaluate_all(directory=None, beamsnet_dir=None, akit_dir=None, beam_seed: int = 1000,
                 scenarios=("2-missing", "3-missing"), outage: bool = True) -> list[dict]:
    """Network vs average estimator on the validation split, ``V_test.npy`` and the A-KIT DVL velocities.

    Beams are made with ``beam_seed`` (by default another noise draw than training used), for the DVL each network
    was trained for (its card's ``data["beam_model"]``), and velocities solved with its geometry. Per dataset and
    scenario: one-step completion of every ping with the true past ("per ping"), and, with ``outage``,
    recursive 30-ping outages ("outage 30 s"). A dataset whose folder is absent is skipped.

    Returns:
        rows of dicts: dataset, scenario, mode, method, the :func:`completion_metrics` keys and
        ``all_beams_vel_rmse`` (least squares on all four made beams, the floor).
    """
    from graphnav.core.errors import DataError

    from . import data as beamdata
    from .network import load_completer

    rows = []
    for scen in scenarios:
        net = load_completer(scen, directory=directory)
        yaw = net.card.get("data", {}).get("align_yaw_deg", 0.0)   # the frame the network was trained in
        spec = net.trained_dvl_spec
        geometry = DvlGeometry.from_spec(spec)
        datasets = {}
        for name, split in (("val", "val"), ("V_test", "test")):
            try:
                datasets[name] = [beamdata.beamsnet_series(split, beamsnet_dir, beam_seed, spec, align_yaw_deg=yaw)]
            except DataError:
                pass
        try:
            datasets["A-KIT"] = beamdata.akit_series(akit_dir, beam_seed, spec)
        except DataError:
            pass
        methods = {"network": net, "average": AverageCompleter(net.n_past)}
        for dname, series in datasets.items():
            samples = beamdata.windows(series, net.n_past)
            for mname, comp in methods.items():
                made = (predict_network(net.model, samples) if mname == "network"
                        else predict_completer(comp, samples, net.missing))
                rows.append({"dataset": dname, "scenario": scen, "mode": "per ping", "method": mname,
                             **metrics_with_floor(*made, samples, net.missing, geometry)})
                if outage:
                    rows.append({"dataset": dname, "scenario": scen, "mode": "outage 30 s", "method": mname,
                                 **metrics_with_floor(*outage_rollout(comp, series, net.missing), net.missing,
                                                      geometry)})
    return rows


def metrics_with_floor(full: np.ndarray, sigma: np.ndarray, samples: BeamSamples, missing,
                       geometry: DvlGeometry | None = None) -> dict:
    """:func:`completion_metrics` with ``all_beams_vel_rmse``: the velocity RMSE (m/s) of least squares on all four
    beams of ``samples``, the floor a completer is read against. ``geometry``: the DVL of the beams (default
    :class:`DvlSpec`'s)."""
    return {**completion_metrics(full, sigma, samples, missing, geometry),
            "all_beams_vel_rmse": full_beam_vel_rmse(samples, geometry)}


def network_metrics(model: BeamRegressor, samples: BeamSamples, missing, geometry: DvlGeometry | None = None) -> dict:
    """:func:`metrics_with_floor` of ``model``'s completions of ``samples`` (per ping): the metrics of a model card.
    ``geometry``: the DVL of the beams (default :class:`DvlSpec`'s)."""
    return metrics_with_floor(*predict_network(model, samples), samples, missing, geometry)


def format_table(rows: list[dict]) -> str:
    """Markdown table of :func:`evaluate_all` rows (m/s; 'in 1s/2s' = fraction within 1/2 sigma)."""
    head = ("| dataset | scenario | mode | method | beam RMSE | vel RMSE | 4-beam vel RMSE | in 1s | in 2s | n |\n"
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    lines = [head]
    for r in rows:
        lines.append(f"| {r['dataset']} | {r['scenario']} | {r['mode']} | {r['method']} | {r['beam_rmse']:.4f} | "
                     f"{r['vel_rmse']:.4f} | {r['all_beams_vel_rmse']:.4f} | {r['within_1sigma']:.3f} | "
                     f"{r['within_2sigma']:.3f} | {r['n']} |")
    return "\n".join(lines)
