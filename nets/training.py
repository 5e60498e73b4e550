"""Training of the missing-beam regressor, its sigma head, and the model card.

Stage 1 is the paper's recipe: MSE on normalised beams, RMSprop, batch 4, learning rate 1e-3 decayed x0.1
every 35 epochs, at most 100 epochs; the weights of the epoch with the lowest validation MSE are kept.
With ``patience`` (30 epochs by default) training stops early; the weights are then the same as after
all 100 epochs whenever the best epoch comes more than ``patience`` epochs before the end, as it did for
both networks shipped with this recipe (best epochs 6 and 22 of 100). Stage 2 freezes that network and fits the sigma
head with the Gaussian negative log-likelihood (Adam), again keeping the best validation epoch.
Everything is seeded; with one thread (the default) a rerun gives the same weights bit for bit.
"""
from __future__ import annotations

import copy
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from tqdm.auto import tqdm

import graphnav
from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry

from . import data as beamdata
from .dvl_match import beam_model_record
from .evaluate import network_metrics
from .model import BeamRegressor, normalize_missing, scenario_name
from .storage import card_format_version, file_sha256, weights_dir


@dataclass
class TrainOptions:
    """Hyper-parameters (paper defaults for stage 1)."""

    epochs: int = 100
    batch_size: int = 4
    lr: float = 1e-3
    lr_step_epochs: int = 35
    lr_gamma: float = 0.1
    patience: int | None = 30            # stop after this many epochs without validation improvement
    sigma_epochs: int = 30
    sigma_batch_size: int = 64
    sigma_lr: float = 3e-3
    seed: int = 0                        # weights init and shuffling
    velocity_weight: float = 0.0         # weight of the velocity term of the mean loss (mean_loss)
    beam_seed: int = 0                   # noise of the beams made from velocities
    align_yaw_deg: float = beamdata.BEAMSNET_YAW_DEG   # BeamsNet files -> body frame (0: as published)
    threads: int = 1


@dataclass
class TrainResult:
    model: BeamRegressor
    card: dict
    history: list[dict] = field(default_factory=list)


def _tensors(model: BeamRegressor, samples: beamdata.BeamSamples):
    past = torch.as_tensor(samples.past[:, -model.n_past:], dtype=torch.float32)
    meas = torch.as_tensor(samples.beams[:, list(model.kept)], dtype=torch.float32)
    target = torch.as_tensor(samples.beams[:, list(model.missing)], dtype=torch.float32)
    return past, meas, target


def _normalised_errors(model, past, meas, target):
    pred, _ = model(past, meas)
    return (pred - target) / model.beam_std[list(model.missing)]


def _normalised_mse(model, past, meas, target):
    return torch.mean(_normalised_errors(model, past, meas, target) ** 2)


def velocity_of_missing(missing, spec: DvlSpec | None = None) -> np.ndarray:
    """(3, n_missing): the body-frame least-squares velocity error (m/s) per m/s of error in each missing beam,
    the ``missing`` columns of ``C_d_b (T_d^T T_d)^-1 T_d^T``
    (:meth:`~graphnav.core.dvl.DvlGeometry.velocity_from_beams` on four beams). For the Janus geometry at 20 deg a
    beam's error enters the horizontal velocity 1.46x, the vertical 0.27x."""
    geometry = DvlGeometry.from_spec(spec or DvlSpec())
    T = geometry.T_d
    return (geometry.C_d_b @ np.linalg.solve(T.T @ T, T.T))[:, list(normalize_missing(missing))]


def mean_loss(velocity_weight: float, missing, spec: DvlSpec | None = None):
    """The mean network's loss: normalised beam MSE plus, with ``velocity_weight`` w > 0, w times the squared
    velocity error the normalised beam errors make through least squares on four beams (:func:`velocity_of_missing`).

    Beam MSE weighs the sum and the difference of two opposite beams' errors alike, but the difference moves
    the horizontal velocity about 30x more in squared error (1.46x per beam horizontally, 0.27x vertically), so
    a network can cut the beam RMSE a quarter and the velocity RMSE a tenth; the velocity term weighs the errors
    as the velocity feels them. ``spec``: the DVL whose beams the network completes (default :class:`DvlSpec`)."""
    if not velocity_weight:
        return _normalised_mse
    L = torch.as_tensor(velocity_of_missing(missing, spec), dtype=torch.float32)

    def loss(model, past, meas, target):
        err = _normalised_errors(model, past, meas, target)
        return torch.mean(err ** 2) + velocity_weight * torch.mean(torch.sum((err @ L.T) ** 2, dim=1))
    return loss


def _gaussian_nll(model, past, meas, target):
    pred, sigma = model(past, meas)
    return torch.nn.functional.gaussian_nll_loss(pred.detach(), target, sigma ** 2, full=True)


def fit(model: BeamRegressor, train_samples: beamdata.BeamSamples, val_samples: beamdata.BeamSamples,
        options: TrainOptions | None = None, progress: bool = True, spec: DvlSpec | None = None) -> list[dict]:
    """Train ``model`` in place (both stages); returns the per-epoch history.

    The normalisation is set from the training beams. Validation samples select the best epoch. ``spec``: the DVL
    whose beams the samples are (default :class:`DvlSpec`; the velocity term of the loss projects with it).
    """
    opt = options or TrainOptions()
    prev_threads = torch.get_num_threads()
    torch.set_num_threads(opt.threads)
    try:
        torch.manual_seed(opt.seed)
        model.set_normalisation(torch.as_tensor(train_samples.beams, dtype=torch.float32))
        tr, va = _tensors(model, train_samples), _tensors(model, val_samples)
        history = _run_stage(model, model.mean_parameters(), tr, va,
                             mean_loss(opt.velocity_weight, model.missing, spec), "mse", opt.epochs, opt.batch_size,
                             torch.optim.RMSprop, opt.lr, opt.lr_step_epochs, opt.lr_gamma, opt.patience, opt.seed,
                             progress)
        history += _run_stage(model, list(model.sigma_head.parameters()), tr, va, _gaussian_nll, "nll",
                              opt.sigma_epochs, opt.sigma_batch_size, torch.optim.Adam, opt.sigma_lr,
                              None, 1.0, None, opt.seed + 1, progress)
    finally:
        torch.set_num_threads(prev_threads)
    model.eval()
    return history


def _run_stage(model, params, tr, va, loss_fn, name, epochs, batch_size, optim_cls, lr, step, gamma,
               patience, seed, progress):
    """One training stage over ``params`` only; restores the best-validation weights.

    ``tr`` and ``va`` are tuples of tensors with the samples on axis 0 (inputs, then the target);
    ``loss_fn(model, *tensors)`` gives the mean loss of a batch.
    """
    for p in model.parameters():
        p.requires_grad_(False)
    for p in params:
        p.requires_grad_(True)
    optim = optim_cls(params, lr=lr)
    sched = torch.optim.lr_scheduler.StepLR(optim, step, gamma) if step else None
    gen = torch.Generator().manual_seed(seed)
    n = len(tr[0])
    best, best_state, since_best, history = np.inf, None, 0, []
    bar = tqdm(range(epochs), desc=f"{scenario_name(model.missing)} {name}", disable=not progress,
               leave=False)
    for epoch in bar:
        model.train()
        order = torch.randperm(n, generator=gen)
        total = 0.0
        for i in range(0, n, batch_size):
            idx = order[i:i + batch_size]
            loss = loss_fn(model, *(t[idx] for t in tr))
            optim.zero_grad(set_to_none=True)
            loss.backward()
            optim.step()
            total += loss.item() * len(idx)
        if sched is not None:
            sched.step()
        model.eval()
        with torch.no_grad():
            val = loss_fn(model, *va).item()
        history.append({"stage": name, "epoch": epoch + 1, "train": total / n, "val": val})
        bar.set_postfix(train=f"{total / n:.4g}", val=f"{val:.4g}")
        if val < best:
            best, best_state, since_best = val, copy.deepcopy(model.state_dict()), 0
        else:
            since_best += 1
            if patience is not None and since_best >= patience:
                break
    if best_state is None:
        raise FloatingPointError(f"{name} stage diverged: validation loss was never finite")
    model.load_state_dict(best_state)
    for p in model.parameters():
        p.requires_grad_(True)
    return history


def train(missing="2-missing", n_past: int | None = None, options: TrainOptions | None = None,
          data_dir: str | Path | None = None, progress: bool = True, spec: DvlSpec | None = None) -> TrainResult:
    """Train the regressor for ``missing`` on the BeamsNet ``V.npy`` data and build its model card.

    Beams are made from ``V.npy`` with the DVL ``spec`` (default :class:`~graphnav.core.config.DvlSpec`: the
    Snapir's; the card records it, and the estimators bind the network to it) and ``options.beam_seed``; the first
    75 % of the pings train, the last 25 % validate (no window crosses the cut); metrics on ``V_test.npy`` are added to
    the card.
    """
    opt = options or TrainOptions()
    missing = normalize_missing(missing)
    spec = beamdata.training_spec(spec)
    torch.manual_seed(opt.seed)
    model = BeamRegressor(missing, n_past)
    d = beamdata._data_dir(data_dir, "beamsnet")
    series = {s: beamdata.beamsnet_series(s, d, opt.beam_seed, spec, align_yaw_deg=opt.align_yaw_deg)
              for s in ("train", "val", "test")}
    samples = {s: beamdata.windows(v, model.n_past) for s, v in series.items()}
    t0 = time.perf_counter()
    history = fit(model, samples["train"], samples["val"], opt, progress, spec)
    train_time = time.perf_counter() - t0
    geometry = DvlGeometry.from_spec(spec)
    metrics = {split: network_metrics(model, samples[split], missing, geometry) for split in ("val", "test")}
    # The minimum calibrated alternative to the head: one sigma per beam, the validation residual RMS.
    constant_sigma = metrics["val"]["beam_rmse_per_beam"]
    mse_hist = [h for h in history if h["stage"] == "mse"]
    nll_hist = [h for h in history if h["stage"] == "nll"]
    card = {
        **card_header(model),
        "data": {
            "source": "snapir-2021-beamsnet (ansfl/BeamsNet, May 2021), V.npy; test V_test.npy",
            "V_sha256": file_sha256(d / "V.npy"),
            "beam_model": beam_model_record(spec),
            "beam_seed": opt.beam_seed,
            "align_yaw_deg": opt.align_yaw_deg,
        },
        "split": {"train_fraction": beamdata.TRAIN_FRACTION, "order": "mission order as published",
                  "train_samples": len(samples["train"]), "val_samples": len(samples["val"]),
                  "test_samples": len(samples["test"])},
        "training": {**asdict(opt), "epochs_run": len(mse_hist),
                     "best_epoch": int(np.argmin([h["val"] for h in mse_hist])) + 1,
                     "sigma_epochs_run": len(nll_hist),
                     "time_s": round(train_time, 1)},
        "normalisation": {"beam_mean": model.beam_mean.tolist(), "beam_std": model.beam_std.tolist()},
        "envelope": training_envelope(series["train"]),
        "constant_sigma": constant_sigma,
        "metrics": metrics,
    }
    return TrainResult(model, card, history)


def training_envelope(series) -> dict:
    """The input envelope of a network, from its training beams (list of :class:`BeamSeries`, or one):
    per-beam min and max (m/s) and the largest ping-to-ping change of each beam (m/s). Stored in the model
    card (``"envelope"``); :class:`graphnav.nets.network.NetworkCompleter` falls back to the average
    estimator for inputs outside it."""
    series = [series] if isinstance(series, beamdata.BeamSeries) else list(series)
    beams = np.concatenate([s.beams for s in series])
    steps = np.concatenate([np.abs(np.diff(s.beams, axis=0)) for s in series if len(s.beams) > 1])
    # pings without a beam (NaN) bound nothing: a NaN bound would let every input in, or none
    return {"beam_min": np.nanmin(beams, axis=0).tolist(), "beam_max": np.nanmax(beams, axis=0).tolist(),
            "max_step": np.nanmax(steps, axis=0).tolist(), "source": "training split beams", "samples": int(len(beams))}


def card_header(model) -> dict:
    """Model-card fields every trained regressor shares: versions, scenario, beams, architecture, shapes."""
    return {
        "format_version": card_format_version(model.architecture()),
        "graphnav_version": graphnav.__version__,
        "torch_version": torch.__version__,
        "scenario": scenario_name(model.missing),
        "missing": list(model.missing),
        "kept": list(model.kept),
        "n_past": model.n_past,
        "architecture": model.architecture(),
        "state_dict_shapes": {k: list(v.shape) for k, v in model.state_dict().items()},
    }


def save(result: TrainResult, directory: str | Path | None = None) -> tuple[Path, Path]:
    """Write ``<scenario>.pt`` (state dict) and ``<scenario>.json`` (model card) to ``directory``."""
    import json
    directory = Path(directory) if directory is not None else weights_dir()
    directory.mkdir(parents=True, exist_ok=True)
    name = result.card.get("name", result.card["scenario"])
    pt, js = directory / f"{name}.pt", directory / f"{name}.json"
    torch.save(result.model.state_dict(), pt)
    result.card["weights_sha256"] = file_sha256(pt)
    js.write_text(json.dumps(result.card, indent=2) + "\n")
    return pt, js
