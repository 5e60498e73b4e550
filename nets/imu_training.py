"""Training of the IMU-aware missing-beam regressor on the A-KIT trajectories, and its model card.

Split by trajectory (:data:`graphnav.nets.imu_data.AKIT_SPLIT`): the training trajectories give the training
pings (their first ``1 - select_fraction``) and the selection pings (the rest; the best epoch and the sigma
gain are chosen on them); the validation trajectories are only used for the card's metrics, with another
beam-noise draw (seed 1000, as ``graphnav eval-beams``). Training beams come in ``draws`` noise draws of the
DVL error model (the IMU features are shared), which multiplies the 2 600 training pings.

Stage 1: MSE on normalised beams, Adam, step decay, early stopping on the selection pings. Stage 2
(recursive): the mean network is trained on its own fed-back completions, as an estimator uses it through an
outage: rollouts of ``rollout_window`` pings with the missing beams removed, each completion pushed into the
past window of the next ping, loss = normalised MSE of the first ping (completed from the true past) plus
the mean over all pings of the rollout, back-propagated through the whole rollout; the best epoch is chosen
on rollouts in the selection pings. Trained one step ahead only, the network's small per-ping bias compounds
through an outage (30-100 % worse than the average on the steady legs of A-KIT trajectory 6). Stage 3: the
sigma head with the Gaussian NLL while the mean network is frozen; then ``sigma_gain`` makes the RMS of
error/sigma 1 on the selection pings. Seeded; with one thread a rerun gives the same weights bit for bit.

The beams are made for one DVL (``spec``; default the Snapir's, :class:`~graphnav.core.config.DvlSpec`) from the
recorded body-frame velocities, one a ping 1 s apart (:func:`graphnav.nets.data.training_spec`); the network holds
that DVL's beam directions (``ImuBeamRegressor.T_b``) and its card records it (``data["beam_model"]``), which the
estimators bind it to (:mod:`graphnav.nets.dvl_match`).
"""
from __future__ import annotations

import time
from dataclasses import asdict, replace

import numpy as np
import torch

from graphnav.core.dvl import DvlGeometry, make_beams
from graphnav.io.loaders import akit_files

from . import imu_data
from .data import _data_dir, training_spec
from .dvl_match import beam_model_record, trained_dvl_spec
from .imu_model import DEFAULT_IMU_N_PAST, ImuBeamRegressor
from .imu_network import ImuNetworkCompleter, imu_weights_name, model_inputs
from .imu_recipes import ImuTrainOptions
from .imu_window import preintegrate
from .model import normalize_missing, scenario_name
from .storage import file_sha256
from .training import TrainResult, _run_stage, card_header, training_envelope


def _tensors(model: ImuBeamRegressor, samples: imu_data.ImuBeamSamples):
    past = torch.as_tensor(samples.past[:, -model.n_past:], dtype=torch.float32)
    meas = torch.as_tensor(samples.beams[:, list(model.kept)], dtype=torch.float32)
    target = torch.as_tensor(samples.beams[:, list(model.missing)], dtype=torch.float32)
    return (past, meas, *model_inputs(samples.imu), target)


def _mse(model, *tensors):
    pred, _ = model(*tensors[:-1])
    return torch.mean(((pred - tensors[-1]) / model.beam_std[list(model.missing)]) ** 2)


def _nll(model, *tensors):
    pred, sigma = model(*tensors[:-1])
    return torch.nn.functional.gaussian_nll_loss(pred.detach(), tensors[-1], sigma ** 2, full=True)


def rollout(model: ImuBeamRegressor, past0, measured, imu_seq):
    """Complete ``W`` pings recursively: each completion joins the past window of the next ping.

    Args:
        past0: (B, N, 4) full past beam vectors before the first ping, m/s.
        measured: (B, W, n_kept) beams measured at each ping, m/s.
        imu_seq: the IMU tensors of :func:`model_inputs`, each with a (B, W) leading shape.

    Returns:
        completed missing beams (B, W, n_missing), m/s.
    """
    kept = torch.as_tensor(model.kept, dtype=torch.long)     # empty in a total outage
    miss = torch.as_tensor(model.missing, dtype=torch.long)
    past, out = past0, []
    for k in range(measured.shape[1]):
        pred, _ = model(past, measured[:, k], *(f[:, k] for f in imu_seq))
        full = torch.zeros(len(past), 4).index_copy(1, kept, measured[:, k]).index_copy(1, miss, pred)
        past = torch.cat([past[:, 1:], full[:, None]], dim=1)
        out.append(pred)
    return torch.stack(out, dim=1)


def _rollout_loss(feats):
    """Loss of the recursive stage over rollouts whose IMU features are rows ``fidx`` of ``feats``."""
    def loss(model, past0, measured, fidx, target):
        pred = rollout(model, past0, measured, [f[fidx] for f in feats])
        err = ((pred - target) / model.beam_std[list(model.missing)]) ** 2      # (B, W, n_missing)
        return err[:, 0].mean() + err.mean()
    return loss


def _imu_rows(model, base, opt: ImuTrainOptions):
    """IMU tensors of every ping with a full window of the series ``base`` (shared by the noise draws), and
    per series the row of each ping in them (-1: no full window)."""
    n_imu = imu_data.n_imu_samples(opt.imu_window_s)
    N = model.n_past
    feats, rows, offset = [], [], 0
    for s in base:
        k = np.flatnonzero(s.imu_end + 1 >= n_imu)
        idx = (s.imu_end[k] + 1)[:, None] - n_imu + np.arange(n_imu)
        feats.append(preintegrate(s.f_b[idx], s.omega_b[idx], N, s.imu_rate_hz, model.ping_dt))
        row = np.full(len(s.beams), -1)
        row[k] = offset + np.arange(len(k))
        rows.append(row)
        offset += len(k)
    return model_inputs(imu_data.ImuFeatures.concatenate(feats)), rows


def _rollouts(model, series_draws, rows, opt: ImuTrainOptions, part: str):
    """Rollout tensors (past0, measured, fidx, target) of the ``part`` pings (``rows``: :func:`_imu_rows`)."""
    N, W = model.n_past, opt.rollout_window
    past0, meas, fidx, target = [], [], [], []
    for draw in series_draws:
        for s, row in zip(draw, rows):
            cut = int(round((1.0 - opt.select_fraction) * len(s.beams)))
            lo, hi = (0, cut) if part == "train" else (cut, len(s.beams))
            finite = np.all(np.isfinite(s.beams), axis=1)
            stride = opt.rollout_stride if part == "train" else 1
            for k0 in range(lo + N, hi - W + 1, stride):
                if not (finite[k0 - N:k0 + W].all() and (row[k0:k0 + W] >= 0).all()):
                    continue
                past0.append(s.beams[k0 - N:k0])
                meas.append(s.beams[k0:k0 + W][:, list(model.kept)])
                target.append(s.beams[k0:k0 + W][:, list(model.missing)])
                fidx.append(row[k0:k0 + W])
    as_t = lambda a: torch.as_tensor(np.array(a), dtype=torch.float32)   # noqa: E731
    return as_t(past0), as_t(meas), torch.as_tensor(np.array(fidx), dtype=torch.long), as_t(target)


def _samples(series, opt: ImuTrainOptions, part: str):
    n_imu = imu_data.n_imu_samples(opt.imu_window_s)
    out = []
    for s in series:
        cut = int(round((1.0 - opt.select_fraction) * len(s.beams)))
        pings = slice(0, cut) if part == "train" else slice(cut + opt.n_past, None)
        out.append(imu_data.imu_windows(s, opt.n_past, n_imu, pings=pings))
    return imu_data.ImuBeamSamples.concatenate(out)


def _with_imu_grades(base, opt: ImuTrainOptions):
    """``base`` followed by one copy of it per grade of ``opt.imu_grades`` (same beams, IMU errors added)."""
    from graphnav.core.config import imu_grade
    out = list(base)
    for c, grade in enumerate(opt.imu_grades, start=1):
        imu_grade(grade)      # a grade preset ("recorded" is not one: it would only copy the recorded IMU)
        out += imu_data.graded_series(base, grade, opt.imu_seed + 100 * c)
    return out


def card_envelope(card: dict, data_dir=None) -> dict:
    """The input envelope of a trained IMU-aware network (:func:`graphnav.nets.training.training_envelope` of the
    beams it was trained on), rebuilt from its card: the card's training trajectories and beam seed, read from
    ``data_dir`` (default: the shared A-KIT data). For cards written before :func:`train_imu` stored one.

    Raises:
        DataError: a trajectory's DVL file is not the one the card was trained on (sha256).
    """
    from graphnav.core.errors import DataError
    d = _data_dir(data_dir, "akit")
    numbers = card["split"]["train_trajectories"]
    for k in numbers:
        path = akit_files(d / f"Trajectory{k}", require_gt=False)["DVL"]
        expected = card["data"]["DVL_sha256"].get(f"Trajectory{k}")
        if expected is not None and file_sha256(path) != expected:
            raise DataError(f"{path}: not the DVL file the network was trained on (sha256 differs from its card)",
                            "akit")
    return training_envelope(imu_data.akit_imu_series(numbers, d, card["data"]["beam_seed"],
                                                      spec=trained_dvl_spec(card)))


def train_imu(missing="2-missing", options: ImuTrainOptions | None = None, data_dir=None,
              progress: bool = True, evaluate: bool = True, trajectories=None, spec=None) -> TrainResult:
    """Train the IMU-aware network for ``missing`` and build its model card (module docstring).

    ``spec``: the DVL (:class:`~graphnav.core.config.DvlSpec`) whose beams the network is trained on and bound to
    (default: the Snapir's, the ``DvlSpec`` default); its ping rate is the recordings' 1 Hz whatever ``spec`` says.

    ``trajectories``: the A-KIT trajectory numbers trained on (default ``AKIT_SPLIT["train"]``); with
    ``options.imu_grades`` every training trajectory also comes with each grade's IMU errors (its training,
    selection and rollout pings), so that the network sees IMU errors the recorded IMU does not have.
    """
    missing = normalize_missing(missing)
    spec = training_spec(spec)
    opt = replace(options or ImuTrainOptions())
    if opt.n_past is None:
        opt.n_past = DEFAULT_IMU_N_PAST[len(missing)]
    d = _data_dir(data_dir, "akit")
    prev_threads = torch.get_num_threads()
    torch.set_num_threads(opt.threads)
    try:
        torch.manual_seed(opt.seed)
        model = ImuBeamRegressor(missing, opt.n_past, opt.hidden, opt.sigma_hidden, imu_window_s=opt.imu_window_s,
                                 blend=opt.blend, relative=opt.relative,
                                 correction_sees_imu=opt.correction_sees_imu,
                                 T_b=DvlGeometry.from_spec(spec).T_b)
        train_numbers = tuple(trajectories) if trajectories is not None else imu_data.AKIT_SPLIT["train"]
        recorded = imu_data.akit_imu_series(train_numbers, d, opt.beam_seed, spec=spec)
        base = _with_imu_grades(recorded, opt)
        train_parts, select, draws = [], _samples(base, opt, "select"), []
        for draw in range(opt.draws):
            series = base if draw == 0 else [
                s.with_beams(np.where(np.isfinite(s.beams), make_beams(np.nan_to_num(s.v_b), spec,
                             opt.beam_seed + 100 * draw + int(s.name.removeprefix("Trajectory"))), np.nan))
                for s in base]
            draws.append(series)
            train_parts.append(_samples(series, opt, "train"))
        train = imu_data.ImuBeamSamples.concatenate(train_parts)
        tr, se = _tensors(model, train), _tensors(model, select)
        with torch.no_grad():
            _, g_dir = model.propagate(*tr[0:1], *tr[2:6])
        model.set_normalisation(tr[0].flatten(0, 1), tr[6], g_dir)
        model.set_input_normalisation(*tr[:-1])
        t0 = time.perf_counter()
        history = _run_stage(model, model.mean_parameters(), tr, se, _mse, "mse", opt.epochs, opt.batch_size,
                             torch.optim.Adam, opt.lr, opt.lr_step_epochs, opt.lr_gamma, opt.patience, opt.seed,
                             progress)
        n_rollouts = (0, 0)
        if opt.rollout_epochs > 0:
            feats, rows = _imu_rows(model, base, opt)
            r_tr, r_se = _rollouts(model, draws, rows, opt, "train"), _rollouts(model, [base], rows, opt, "select")
            n_rollouts = (len(r_tr[0]), len(r_se[0]))
            history += _run_stage(model, model.mean_parameters(), r_tr, r_se, _rollout_loss(feats), "rollout",
                                  opt.rollout_epochs, opt.rollout_batch_size, torch.optim.Adam, opt.rollout_lr,
                                  None, 1.0, None, opt.seed + 2, progress)
        history += _run_stage(model, list(model.sigma_head.parameters()), tr, se, _nll, "nll", opt.sigma_epochs,
                              opt.sigma_batch_size, torch.optim.Adam, opt.sigma_lr, None, 1.0, None, opt.seed + 1,
                              progress)
        with torch.no_grad():       # calibrate on held-out pings: RMS of error/sigma = 1
            pred, sigma = model(*se[:-1])
            model.sigma_gain.mul_(torch.sqrt(torch.mean(((pred - se[-1]) / sigma) ** 2)))
        train_time = time.perf_counter() - t0
    finally:
        torch.set_num_threads(prev_threads)
    model.eval()
    mse_hist = [h for h in history if h["stage"] == "mse"]
    card = {
        **card_header(model),
        "kind": "imu",
        "name": imu_weights_name(missing),
        "imu_samples": model.imu_samples,
        "n_parameters": int(sum(p.numel() for p in model.parameters())),
        "data": {
            "source": "snapir-2022-akit (ansfl/A-KIT, June 2022), TrajectoryN/{IMU,DVL,GT}_trajectoryN.csv "
                      "via graphnav.missions.load_akit",
            "DVL_sha256": {s.name: file_sha256(akit_files(d / s.name, require_gt=False)["DVL"]) for s in recorded},
            "beam_model": beam_model_record(spec),
            "beam_seed": opt.beam_seed, "draws": opt.draws,
        },
        "split": {"train_trajectories": list(train_numbers),
                  "val_trajectories": list(imu_data.AKIT_SPLIT["val"]) if trajectories is None else [],
                  "selection": f"last {opt.select_fraction:.0%} of each training trajectory (best epoch, "
                               "sigma gain)",
                  "train_samples": len(train), "selection_samples": len(select),
                  "train_rollouts": n_rollouts[0], "selection_rollouts": n_rollouts[1]},
        "training": {**asdict(opt), "epochs_run": len(mse_hist),
                     "best_epoch": int(np.argmin([h["val"] for h in mse_hist])) + 1,
                     "rollout_val": [round(h["val"], 5) for h in history if h["stage"] == "rollout"],
                     "time_s": round(train_time, 1)},
        "lag_weights": torch.softmax(model.lag_logits.detach(), 0).tolist(),
        "sigma_gain": float(model.sigma_gain),
        "run_decay": opt.run_decay,
        "envelope": training_envelope(recorded),
    }
    if evaluate:
        from .imu_evaluate import evaluate_imu
        name = scenario_name(missing)
        if name in ("2-missing", "3-missing"):
            card["metrics_val"] = evaluate_imu((name,), directory=None, akit_dir=d,
                                               completers={name: ImuNetworkCompleter(model, card,
                                                                                      run_decay=opt.run_decay)})
    return TrainResult(model, card, history)
