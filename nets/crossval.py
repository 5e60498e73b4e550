"""Leave-trajectories-out cross-validation of the missing-beam completers: numbers that predict unseen motion.

A fold holds out whole recordings: two A-KIT trajectories (:data:`AKIT_FOLDS`, fixed) and one contiguous block
of BeamsNet missions (:func:`beamsnet_missions`, :func:`beamsnet_blocks`). In each fold a network is trained
on everything else (the training recipe is a :class:`Variant`; its early stopping uses the last
:data:`INNER_VAL_FRACTION` of each training recording, never a held-out one) and compared with the average
estimator on the held-out recordings, per ping (true past) and through recursive 30-ping outages
(:func:`graphnav.nets.evaluate.outage_rollout`). ``V_test.npy`` (another date) is never trained on; every
fold's network is scored on it. Pooled numbers weight each fold by its samples; "worst fold" is the fold
with the largest network/average ratio.

Every choice between recipes (:data:`VARIANTS`) is made on these out-of-fold numbers only.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry, make_beams
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.folds import check_folds as core_check_folds

from . import data as beamdata
from .average import AVERAGE_N_PAST, AverageCompleter
from .completer import check_run_decay
from .dvl_match import beam_model_record, chosen_for_note, dvl_name
from .evaluate import completion_metrics, outage_rollout, predict_completer
from .model import normalize_missing, scenario_name

#: The five fixed A-KIT folds (trajectory numbers held out together). Each pairs a steady trajectory with
#: one that changes depth, speed or heading, so that no fold holds only easy or only hard motion:
#: steady 2, 3, 10, 13; depth/speed 1, 4, 6, 8; turns 5; slow, from the surface 11.
AKIT_FOLDS: tuple[tuple[int, ...], ...] = ((1, 3), (2, 5), (4, 10), (6, 13), (8, 11))

#: A ping-to-ping change of the BeamsNet velocity above this (m/s) is a mission boundary: within a mission
#: the 99.9th percentile of the change is 0.82 m/s; the five changes above 1.2 m/s (at pings 1339, 2566,
#: 3028, 3897, 4483 of ``V.npy``) are where one recording ends and the next begins (2-2.2 m/s at 2565-4482).
#: The other boundaries of the nine missions are not visible in the data; the long last part is cut into
#: contiguous blocks by :func:`beamsnet_blocks`.
BEAMSNET_JUMP_MPS = 1.2

#: Share of each training recording (its end) that selects the epoch; never a held-out recording.
INNER_VAL_FRACTION = 0.2


@dataclass(frozen=True)
class Variant:
    """One training recipe of the beam-only network, compared out of fold.

    Attributes:
        name: short label in tables.
        akit: also train on the fold's A-KIT training trajectories (else BeamsNet only, as the paper).
        residual: the network regresses the change from the average of the past window
            (:class:`~graphnav.nets.model.BeamRegressor` ``residual``).
        copies: augmented copies of every training recording (0: none); each copy turns the velocity by a
            yaw drawn in +-``yaw_deg`` about body z, scales it by a factor drawn in 1 +- ``speed_scale``, and
            draws new beam noise.
        epochs, batch_size, lr, patience, sigma_epochs: the schedule (RMSprop, lr x0.1 every 35 epochs).
        rollout: after the one-step training, fine-tune the mean network on its own completions fed back
            through ``rollout``-ping outages (0: no such stage; :func:`fine_tune_recursive`).
        velocity_weight: weight of the velocity error in the mean network's loss
            (:func:`graphnav.nets.training.mean_loss`; 0: beam MSE only, as the paper).
        members: networks trained alike from different seeds (and augmentation draws) and averaged
            (:class:`~graphnav.nets.model.BeamEnsemble`); 1: one network. Member 0 is the one network.
        run_decay: ``(scenario, gamma)`` pairs: the completer's fading from the network to the average through a
            run of regressed pings (:class:`~graphnav.nets.network.NetworkCompleter` ``run_decay``); it changes
            no training, only how the trained network completes an outage (absent scenario: 1, no fading).
    """

    name: str
    akit: bool = False
    residual: bool = False
    copies: int = 0
    yaw_deg: float = 15.0
    speed_scale: float = 0.2
    epochs: int = 25
    batch_size: int = 32
    lr: float = 1e-3
    patience: int = 5
    sigma_epochs: int = 8
    rollout: int = 0
    rollout_epochs: int = 6
    velocity_weight: float = 0.0
    members: int = 1
    run_decay: tuple[tuple[str, float], ...] = ()

    def __post_init__(self):
        if self.members < 1 or self.velocity_weight < 0:
            raise ConfigError(f"recipe {self.name!r}: members must be >= 1 and velocity_weight >= 0, got "
                              f"{self.members} and {self.velocity_weight}")
        for _, gamma in self.run_decay:
            check_run_decay(gamma, f"recipe {self.name!r}")

    def decay(self, missing) -> float:
        """The ``run_decay`` of scenario ``missing`` (1 when the recipe names none)."""
        return dict(self.run_decay).get(scenario_name(missing), 1.0)


#: The recipes the out-of-fold table can compare (``graphnav eval-beams --folds --variant NAME``); the default
#: run is :data:`DEFAULT_VARIANTS`.
VARIANTS: dict[str, Variant] = {v.name: v for v in (
    Variant("paper-recipe"),                                     # BeamsNet only, values (the paper's networks)
    Variant("akit", akit=True),                                  # + A-KIT training folds
    Variant("akit-residual", akit=True, residual=True),          # + change from the average
    Variant("akit-residual-aug", akit=True, residual=True, copies=2),   # + yaw/speed/noise augmentation
    Variant("akit-residual-recursive", akit=True, residual=True, rollout=15),  # + trained on its own completions
    Variant("akit-residual-aug-ens5", akit=True, residual=True, copies=2, members=5),   # + mean of 5 seeds
    Variant("akit-residual-aug-vel", akit=True, residual=True, copies=2, velocity_weight=1.0),  # + velocity loss
    # + fading to the average through an outage; gamma chosen out of fold by experiments/completer_fade_folds.py
    Variant("akit-residual-aug-ens5-fade", akit=True, residual=True, copies=2, members=5,
            run_decay=(("2-missing", 0.9), ("3-missing", 0.98))),
)}
#: The recipes ``graphnav eval-beams --folds`` runs without ``--variant``: the recursive stage is left out (its
#: rollouts cost about 8 min of one core per fold on the shared machine, 15x the one-step recipe).
DEFAULT_VARIANTS: tuple[str, ...] = ("paper-recipe", "akit", "akit-residual", "akit-residual-aug")


def check_folds(folds) -> tuple[tuple[int, ...], ...]:
    """``folds`` as tuples of trajectory numbers, checked by :func:`graphnav.core.folds.check_folds` (no empty
    fold, no trajectory in two)."""
    folds = tuple(tuple(int(t) for t in f) for f in folds)
    core_check_folds(folds)
    return folds


def beamsnet_missions(v: np.ndarray, jump_mps: float = BEAMSNET_JUMP_MPS) -> list[slice]:
    """Recordings of a concatenated velocity file (K, 3) m/s: cut where the velocity jumps by more than
    ``jump_mps`` from one ping to the next (one mission ends, the next begins)."""
    step = np.linalg.norm(np.diff(v, axis=0), axis=1)
    cuts = [0, *(np.flatnonzero(step > jump_mps) + 1).tolist(), len(v)]
    return [slice(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def beamsnet_blocks(missions: list[slice], n_blocks: int) -> list[list[slice]]:
    """``n_blocks`` contiguous blocks of about equal length; a block's edge is a mission boundary when one is
    within 5 % of the total of the equal cut, else the mission is cut there (said in the fold table)."""
    total = missions[-1].stop
    bounds = np.array([m.start for m in missions[1:]])
    edges = [0]
    for k in range(1, n_blocks):
        target = round(k * total / n_blocks)
        near = bounds[np.abs(bounds - target) <= 0.05 * total] if bounds.size else bounds
        edge = int(near[np.argmin(np.abs(near - target))]) if near.size else target
        edges.append(max(edge, edges[-1] + 1))
    edges.append(total)
    blocks = []
    for a, b in zip(edges[:-1], edges[1:]):
        parts = [slice(max(m.start, a), min(m.stop, b)) for m in missions if m.start < b and m.stop > a]
        blocks.append(parts)
    return blocks


@dataclass
class FoldData:
    """Recordings of the protocol, by fold.

    Attributes:
        akit: trajectory number -> its :class:`~graphnav.nets.data.BeamSeries` (split at invalid pings).
        beamsnet: per fold, the BeamsNet recordings it holds out (empty lists without BeamsNet data).
        test: recordings never trained on (``V_test.npy``), scored by every fold's network.
        folds: the A-KIT trajectory numbers held out per fold.
        spec: the DVL whose beams the recordings are (made from the recorded velocities with it), which the
            networks are trained for and scored with.
    """

    akit: dict[int, list[beamdata.BeamSeries]]
    beamsnet: list[list[beamdata.BeamSeries]]
    test: list[beamdata.BeamSeries]
    folds: tuple[tuple[int, ...], ...]
    spec: DvlSpec = field(default_factory=DvlSpec)

    def split(self, i: int) -> tuple[dict[str, list], dict[str, list]]:
        """(training recordings, held-out recordings by data set) of fold ``i``."""
        held = set(self.folds[i])
        train = {"akit": [s for t, ss in self.akit.items() if t not in held for s in ss],
                 "beamsnet": [s for j, ss in enumerate(self.beamsnet) if j != i for s in ss]}
        out = {"A-KIT": [s for t in self.folds[i] for s in self.akit.get(t, [])]}
        if self.beamsnet and self.beamsnet[i]:
            out["BeamsNet"] = self.beamsnet[i]
        if self.test:
            out["V_test"] = self.test
        return train, out


def load_fold_data(akit_dir=None, beamsnet_dir=None, beam_seed: int = 1000,
                   folds=AKIT_FOLDS, spec: DvlSpec | None = None) -> FoldData:
    """The ten A-KIT trajectories and the BeamsNet missions, beams made with ``beam_seed`` for the DVL ``spec``
    (default :class:`DvlSpec`: the Snapir's, the one the recordings were made with), in ``folds``.

    BeamsNet data are optional (absent folder: A-KIT only); A-KIT data are required.

    Raises:
        DataError: no A-KIT folder, or a fold names a trajectory that is not there.
    """
    folds = check_folds(folds)
    spec = beamdata.training_spec(spec)
    akit: dict[int, list[beamdata.BeamSeries]] = {}
    for s in beamdata.akit_series(akit_dir, beam_seed, spec):
        akit.setdefault(int(s.name.split("#")[0].removeprefix("Trajectory")), []).append(s)
    absent = sorted(t for f in folds for t in f if t not in akit)
    if absent:
        raise DataError(f"fold trajectories {absent} not found (have {sorted(akit)})", "A-KIT", field="folds")
    beamsnet, test = [], []
    try:
        whole = beamdata.beamsnet_series("all", beamsnet_dir, beam_seed, spec)
        test = [beamdata.beamsnet_series("test", beamsnet_dir, beam_seed, spec)]
    except DataError:
        whole = None
    if whole is not None:
        for j, block in enumerate(beamsnet_blocks(beamsnet_missions(whole.v_b), len(folds))):
            beamsnet.append([beamdata.BeamSeries(f"V[{p.start}:{p.stop}]", whole.v_b[p], whole.beams[p])
                             for p in block])
    return FoldData(akit, beamsnet, test, folds, spec)


def augment(series: list[beamdata.BeamSeries], variant: Variant, seed: int,
            spec: DvlSpec | None = None) -> list[beamdata.BeamSeries]:
    """``series`` plus ``variant.copies`` augmented copies of each (turned about z, speed-scaled, new noise)."""
    spec = spec or DvlSpec()
    rng = np.random.default_rng(seed)
    out = list(series)
    for c in range(variant.copies):
        for s in series:
            yaw = rng.uniform(-variant.yaw_deg, variant.yaw_deg)
            scale = 1.0 + rng.uniform(-variant.speed_scale, variant.speed_scale)
            v = scale * s.v_b @ beamdata.yaw_rotation(yaw).T
            out.append(beamdata.BeamSeries(f"{s.name}~{c}", v, make_beams(v, spec, rng)))
    return out


def inner_split(series: list[beamdata.BeamSeries], fraction: float = INNER_VAL_FRACTION):
    """(fit, select) recordings: the last ``fraction`` of each recording selects the epoch."""
    fit, select = [], []
    for s in series:
        cut = int(round((1 - fraction) * len(s.beams)))
        fit.append(beamdata.BeamSeries(s.name, s.v_b[:cut], s.beams[:cut]))
        select.append(beamdata.BeamSeries(s.name + "/sel", s.v_b[cut:], s.beams[cut:]))
    return fit, select


def train_network(train: dict[str, list], missing, variant: Variant, seed: int = 0, progress: bool = False,
                  spec: DvlSpec | None = None):
    """A :class:`~graphnav.nets.network.NetworkCompleter` trained on one fold's recordings with ``variant``: one
    network, or with ``variant.members`` > 1 the ensemble of networks trained with seeds ``seed + MEMBER_SEED_STEP
    * j`` (member 0 is the one network of ``seed``). ``spec``: the DVL of the recordings' beams (default
    :class:`DvlSpec`), which its augmented copies are made for and its card records. Its input envelope is the union
    of the members' training data (each draws its own augmented copies). Out of fold, the range common to all members
    sent more unseen pings to the average estimator and was worse (docs/decisions/completers.md, "Five seeds
    averaged")."""
    from .model import BeamEnsemble
    from .network import NetworkCompleter
    from .training import training_envelope

    spec = beamdata.training_spec(spec)
    recordings = train["beamsnet"] + (train["akit"] if variant.akit else [])
    if not recordings:
        raise DataError("no training recordings in this fold", "crossval")
    fit_s, select_s = inner_split(recordings)
    models, seen = [], list(fit_s)
    for j in range(variant.members):
        model, member_fit = _train_member(fit_s, select_s, missing, variant, seed + MEMBER_SEED_STEP * j, progress,
                                          spec)
        models.append(model)
        seen += member_fit[len(fit_s):]      # its augmented copies (the recordings themselves are in already)
    model = models[0] if len(models) == 1 else BeamEnsemble.of(models)
    card = {"envelope": training_envelope(seen), "data": {"beam_model": beam_model_record(spec)}}
    return NetworkCompleter(model, card=card, run_decay=variant.decay(missing))


#: Seed offset between ensemble members (larger than any fold index, so no member repeats another fold's seed).
MEMBER_SEED_STEP = 1000


def _train_member(fit_s, select_s, missing, variant: Variant, seed: int, progress: bool, spec: DvlSpec | None = None):
    """One network of ``variant`` trained on ``fit_s`` (augmented with ``seed``, beams of the DVL ``spec``), its
    epoch chosen on ``select_s``; returns (model, the recordings it was fitted on)."""
    import torch

    from .model import BeamRegressor
    from .training import TrainOptions, fit

    fit_s = augment(fit_s, variant, seed, spec)
    torch.manual_seed(seed)
    model = BeamRegressor(missing, residual=variant.residual)
    n = model.n_past
    opt = TrainOptions(epochs=variant.epochs, batch_size=variant.batch_size, lr=variant.lr,
                       patience=variant.patience, sigma_epochs=variant.sigma_epochs, seed=seed, threads=1,
                       velocity_weight=variant.velocity_weight)
    fit_w = beamdata.windows([s for s in fit_s if len(s.beams) > n], n)
    select_w = beamdata.windows([s for s in select_s if len(s.beams) > n], n)
    fit(model, fit_w, select_w, opt, progress, spec)
    if variant.rollout:
        fine_tune_recursive(model, fit_s, select_s, variant, seed)
        from .training import _gaussian_nll, _run_stage, _tensors
        _run_stage(model, list(model.sigma_head.parameters()), _tensors(model, fit_w), _tensors(model, select_w),
                   _gaussian_nll, "nll", variant.sigma_epochs, 64, torch.optim.Adam, 3e-3, None, 1.0, None,
                   seed + 1, progress)
        model.eval()
    return model, fit_s


def rollout_sequences(series: list[beamdata.BeamSeries], n_past: int, length: int, stride: int = 3) -> np.ndarray:
    """Beam sequences (S, n_past + length, 4) m/s, one starting every ``stride`` pings inside each recording."""
    out = []
    for s in series:
        span = n_past + length
        for k in range(0, len(s.beams) - span + 1, stride):
            out.append(s.beams[k:k + span])
    if not out:
        raise DataError(f"no recording is longer than {n_past + length} pings", "crossval")
    return np.asarray(out)


def rollout_loss(model, seq):
    """Normalised MSE of the missing beams through an outage of ``seq.shape[1] - n_past`` pings in which the
    network's completions are fed back as its past (differentiable through the whole outage)."""
    import torch

    n, miss, kept = model.n_past, list(model.missing), list(model.kept)
    scale = model.beam_std[miss]
    hist = seq[:, :n]
    losses = []
    for k in range(n, seq.shape[1]):
        pred, _ = model(hist[:, -n:], seq[:, k, kept])
        losses.append(torch.mean(((pred - seq[:, k, miss]) / scale) ** 2))
        full = seq[:, k].clone()
        full[:, miss] = pred
        hist = torch.cat([hist[:, 1:], full[:, None]], dim=1)
    return torch.stack(losses).mean()


def fine_tune_recursive(model, fit_s, select_s, variant: Variant, seed: int) -> None:
    """Fine-tune the mean network on rollouts of ``variant.rollout`` pings (Adam 3e-4, batch 64); the epoch
    with the lowest rollout loss on the selection recordings is kept (the one-step weights if none is lower)."""
    import copy

    import torch

    tr = torch.as_tensor(rollout_sequences(fit_s, model.n_past, variant.rollout), dtype=torch.float32)
    va = torch.as_tensor(rollout_sequences(select_s, model.n_past, variant.rollout), dtype=torch.float32)
    params = model.mean_parameters()
    optim = torch.optim.Adam(params, lr=3e-4)
    gen = torch.Generator().manual_seed(seed)
    model.eval()
    with torch.no_grad():
        best, best_state = rollout_loss(model, va).item(), copy.deepcopy(model.state_dict())
    for _ in range(variant.rollout_epochs):
        model.train()
        order = torch.randperm(len(tr), generator=gen)
        for i in range(0, len(tr), 64):
            loss = rollout_loss(model, tr[order[i:i + 64]])
            optim.zero_grad(set_to_none=True)
            loss.backward()
            optim.step()
        model.eval()
        with torch.no_grad():
            val = rollout_loss(model, va).item()
        if val < best:
            best, best_state = val, copy.deepcopy(model.state_dict())
    model.load_state_dict(best_state)


def predict_batch(completer, samples: beamdata.BeamSamples, missing) -> tuple[np.ndarray, np.ndarray]:
    """What ``completer.complete`` gives on every sample, computed in one batch for the average estimator and
    the beam-only network (pings outside the network's envelope regressed by its average fallback, as
    :meth:`~graphnav.nets.network.NetworkCompleter.complete` does); other completers one ping at a time."""
    from .network import NetworkCompleter

    missing = list(missing)
    if isinstance(completer, AverageCompleter):
        past = samples.past[:, -completer.n_past:]
        spread = (np.sqrt(completer.noise_std ** 2 * (1 + 1 / completer.n_past) + past.var(axis=1))
                  if completer.sigma is None else np.broadcast_to(completer.sigma, samples.beams.shape))
        full, sigma = samples.beams.copy(), np.zeros_like(samples.beams)
        full[:, missing] = past.mean(axis=1)[:, missing]
        sigma[:, missing] = spread[:, missing]
        return full, sigma
    if not isinstance(completer, NetworkCompleter) or completer.sigma_mode != "head":
        return predict_completer(completer, samples, missing)
    from .evaluate import predict_network
    full, sigma = predict_network(completer.model, samples)
    sigma *= completer.sigma_scale
    env = completer.envelope
    if env is not None:
        kept = list(completer.model.kept)
        past = samples.past[:, -completer.n_past:]
        inside = np.all((past >= env.lo) & (past <= env.hi), axis=(1, 2))
        inside &= np.all((samples.beams[:, kept] >= env.lo[kept]) & (samples.beams[:, kept] <= env.hi[kept]), axis=1)
        if env.max_step is not None:
            inside &= np.all(np.abs(np.diff(past, axis=1)) <= env.max_step, axis=(1, 2))
            inside &= np.all(np.abs(samples.beams[:, kept] - past[:, -1, kept]) <= env.max_step[kept], axis=1)
        if not inside.all():
            f_full, f_sigma = predict_batch(completer.fallback, samples, missing)
            full[~inside], sigma[~inside] = f_full[~inside], f_sigma[~inside]
    return full, sigma


def _score(completer, series, missing, mode: str, geometry=None) -> dict:
    """Metrics of one completer through its ``complete`` (as an estimator calls it, envelope fallback included);
    velocities with the DVL ``geometry`` (default :class:`DvlSpec`'s)."""
    if mode == "per ping":
        samples = beamdata.windows(series, completer.n_past)
        full, sigma = predict_batch(completer, samples, missing)
    else:
        full, sigma, samples = outage_rollout(completer, series, missing)
    return completion_metrics(full, sigma, samples, missing, geometry)


def _windowable(series, n: int):
    return [s for s in series if len(s.beams) > n]


def crossval(data: FoldData, missing, variant: Variant | str = "paper-recipe", seed: int = 0,
             outage: bool = True, progress: bool = False, log=None, save_dir=None) -> list[dict]:
    """Network (trained per fold with ``variant``) vs average estimator on each fold's held-out recordings.

    Per-ping samples need the network's past window (N = 3 for 2 missing, 5 for 3 missing, as the average's),
    so both completers are scored on the same pings. Outage windows start at ping 10 of a recording.
    ``save_dir``: also save fold i's network (weights and card, loadable by
    :func:`graphnav.nets.load_completer` with ``directory``) to ``save_dir/fold<i>``, for studies that run it on
    fold i's held-out trajectories only.

    Returns:
        rows: fold (index), held_out (names), dataset, scenario, mode, method, variant and the
        :func:`~graphnav.nets.evaluate.completion_metrics` keys.
    """
    variant = VARIANTS[variant] if isinstance(variant, str) else variant
    missing = normalize_missing(missing)
    scen = scenario_name(missing)
    geometry = DvlGeometry.from_spec(data.spec)
    dvl = dvl_name(data.spec)
    rows = []
    for i in range(len(data.folds)):
        t0 = time.perf_counter()
        train, held = data.split(i)
        net = train_network(train, missing, variant, seed + i, progress, data.spec)
        if save_dir is not None:
            from pathlib import Path

            from .training import TrainResult, save
            card = network_card(net, variant, seed + i, data={"source": "crossval fold",
                                                               "held_out": list(data.folds[i]),
                                                               "beam_model": beam_model_record(data.spec)})
            save(TrainResult(net.model, card), Path(save_dir) / f"fold{i}")
        avg = AverageCompleter(AVERAGE_N_PAST.get(scen, net.n_past))
        for dname, series in held.items():
            series = _windowable(series, max(net.n_past, avg.n_past) + 1)
            if not series:
                continue
            for mode in ("per ping", "outage 30 s") if outage else ("per ping",):
                for mname, comp in (("network", net), ("average", avg)):
                    rows.append({"fold": i, "held_out": list(data.folds[i]) if dname == "A-KIT" else
                                 [s.name for s in series], "dataset": dname, "scenario": scen, "mode": mode,
                                 "method": mname, "variant": variant.name, "dvl": dvl,
                                 **_score(comp, series, missing, mode, geometry)})
        if log is not None:
            log(f"{scen} {variant.name} fold {i} {list(data.folds[i])}: {time.perf_counter() - t0:.0f} s")
    return rows


def summarise(rows: list[dict]) -> list[dict]:
    """Pooled (sample-weighted) RMSE per dataset, scenario, mode and method, the ratio network/average pooled
    and in the worst fold, and the gain ``1 - ratio`` (positive: the network is better)."""
    out = []
    keys = sorted({(r["variant"], r["dataset"], r["scenario"], r["mode"]) for r in rows})
    for var, ds, sc, mode in keys:
        sel = [r for r in rows if (r["variant"], r["dataset"], r["scenario"], r["mode"]) == (var, ds, sc, mode)]
        row = {"variant": var, "dataset": ds, "scenario": sc, "mode": mode}
        for metric in ("beam_rmse", "vel_rmse"):
            pooled = {}
            for m in ("network", "average"):
                rs = [r for r in sel if r["method"] == m]
                pooled[m] = float(np.sqrt(sum(r[metric] ** 2 * r["n"] for r in rs) / sum(r["n"] for r in rs)))
            ratios = []
            for f in sorted({r["fold"] for r in sel}):
                net = next(r for r in sel if r["fold"] == f and r["method"] == "network")
                avg = next(r for r in sel if r["fold"] == f and r["method"] == "average")
                ratios.append((net[metric] / avg[metric], f))
            worst, wf = max(ratios)
            row.update({f"{metric}_network": pooled["network"], f"{metric}_average": pooled["average"],
                        f"{metric}_gain": 1.0 - pooled["network"] / pooled["average"],
                        f"{metric}_worst_gain": 1.0 - worst, f"{metric}_worst_fold": wf})
        out.append(row)
    return out


def format_summary(summary: list[dict]) -> str:
    """Markdown table of :func:`summarise`: RMSE m/s network / average, gain pooled and in the worst fold."""
    lines = ["| variant | data | scenario | mode | beam RMSE net / avg | gain | worst fold | "
             "vel RMSE net / avg | gain | worst fold |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in summary:
        cells = []
        for m in ("beam_rmse", "vel_rmse"):
            cells.append(f"{r[m + '_network']:.4f} / {r[m + '_average']:.4f} | {100 * r[m + '_gain']:+.1f} % | "
                         f"{100 * r[m + '_worst_gain']:+.1f} % ({r[m + '_worst_fold']})")
        lines.append(f"| {r['variant']} | {r['dataset']} | {r['scenario']} | {r['mode']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def format_fold_rows(rows: list[dict]) -> str:
    """Markdown table of :func:`crossval` rows: one line per fold, data set, scenario, mode and method."""
    lines = ["| variant | fold | data | scenario | mode | method | beam RMSE | vel RMSE | in 1s / 2s | n |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['variant']} | {r['fold']} | {r['dataset']} | {r['scenario']} | {r['mode']} | "
                     f"{r['method']} | {r['beam_rmse']:.4f} | {r['vel_rmse']:.4f} | "
                     f"{r['within_1sigma']:.2f} / {r['within_2sigma']:.2f} | {r['n']} |")
    return "\n".join(lines)


def format_fold_gains(rows: list[dict], dataset: str = "A-KIT") -> str:
    """Markdown table of the network's gain against the average (``1 - network/average``, beam / velocity RMSE)
    per recipe and fold on ``dataset``, one column per scenario and mode."""
    cols = sorted({(r["scenario"], r["mode"]) for r in rows if r["dataset"] == dataset},
                  key=lambda c: (c[0], c[1] != "per ping"))
    lines = ["| recipe | fold (held out) | " + " | ".join(f"{sc} {mode}" for sc, mode in cols) + " |",
             "| --- | --- | " + " | ".join("---" for _ in cols) + " |"]
    for var in dict.fromkeys(r["variant"] for r in rows):
        for f in sorted({r["fold"] for r in rows if r["variant"] == var}):
            cells, held = [], ""
            for sc, mode in cols:
                sel = {r["method"]: r for r in rows if (r["variant"], r["fold"], r["dataset"], r["scenario"], r["mode"])
                       == (var, f, dataset, sc, mode)}
                if "network" not in sel or "average" not in sel:
                    cells.append("-")
                    continue
                held = ", ".join(map(str, sel["network"]["held_out"])) if dataset == "A-KIT" else ""
                cells.append(" / ".join(f"{100 * (1 - sel['network'][m] / sel['average'][m]):+.1f} %"
                                        for m in ("beam_rmse", "vel_rmse")))
            lines.append(f"| {var} | {f} ({held}) | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def fold_table(data: FoldData) -> str:
    """What each fold holds out (A-KIT trajectories, BeamsNet pings), for the decision page."""
    lines = ["| fold | A-KIT trajectories | BeamsNet V.npy pings |", "| --- | --- | --- |"]
    for i, f in enumerate(data.folds):
        bn = ", ".join(s.name.removeprefix("V") for s in data.beamsnet[i]) if data.beamsnet else "-"
        lines.append(f"| {i} | {', '.join(map(str, f))} | {bn} |")
    return "\n".join(lines)


def variant_dict(variant: Variant) -> dict:
    """The recipe as a dict (model card)."""
    return asdict(variant)


def with_epochs(variant: Variant, epochs: int) -> Variant:
    """``variant`` with another epoch budget (tests, quick runs)."""
    return replace(variant, epochs=epochs)


def network_card(net, variant: Variant, seed: int, data: dict, time_s: float | None = None) -> dict:
    """The model card of a network trained with ``variant`` (what :func:`graphnav.nets.load_completer` reads):
    header, ``data`` (what it was trained on), training recipe and seed, normalisation and input envelope."""
    from .training import card_header

    training = {**variant_dict(variant), "seed": seed}
    if time_s is not None:
        training["time_s"] = round(time_s, 1)
    card = {**card_header(net.model), "data": data, "training": training,
            "normalisation": {"beam_mean": net.model.beam_mean.tolist(), "beam_std": net.model.beam_std.tolist()},
            "envelope": net.card["envelope"]}
    if net.run_decay < 1.0:     # absent: no fading (cards written before it existed read the same)
        card["run_decay"] = net.run_decay
    return card


def final_metrics(net, train: dict[str, list], variant: Variant, beamsnet_dir, beam_seed: int,
                  spec: DvlSpec | None = None) -> dict:
    """Completion metrics of a network trained on everything (:func:`train_final`): ``val`` on the selection part
    of its recordings (the last :data:`INNER_VAL_FRACTION` of each, which chose the epoch and was never a gradient
    step), ``test`` on BeamsNet ``V_test.npy`` when the BeamsNet data are there (never trained on); beams and
    velocities of the DVL ``spec`` (default :class:`DvlSpec`)."""
    from .evaluate import network_metrics

    n = net.model.n_past
    _, select_s = inner_split(train["beamsnet"] + (train["akit"] if variant.akit else []))
    splits = {"val": beamdata.windows([s for s in select_s if len(s.beams) > n], n)}
    if train["beamsnet"]:
        splits["test"] = beamdata.windows(beamdata.beamsnet_series("test", beamsnet_dir, beam_seed, spec), n)
    geometry = DvlGeometry.from_spec(spec or DvlSpec())
    return {split: network_metrics(net.model, samples, net.missing, geometry) for split, samples in splits.items()}


def train_final(missing, variant: Variant | str, akit_dir=None, beamsnet_dir=None, beam_seed: int = 0,
                seed: int = 0, summary: list[dict] | None = None, progress: bool = False,
                spec: DvlSpec | None = None):
    """Train ``variant`` on every recording (all ten A-KIT trajectories and all of ``V.npy``; ``V_test`` stays
    out) after the recipe was chosen out of fold; returns a :class:`~graphnav.nets.training.TrainResult` whose
    model card says which protocol chose the recipe and, given ``summary`` (:func:`summarise` rows), its
    out-of-fold numbers. Save it with :func:`graphnav.nets.training.save`. ``spec``: the DVL the network is trained
    for, its beams made from the recorded velocities (default :class:`DvlSpec`, the Snapir's); the card records it
    and the estimators bind the network to it (:mod:`graphnav.nets.dvl_match`)."""
    from .storage import file_sha256
    from .training import TrainResult

    variant = VARIANTS[variant] if isinstance(variant, str) else variant
    missing = normalize_missing(missing)
    data = load_fold_data(akit_dir, beamsnet_dir, beam_seed, spec=spec)
    train = {"akit": [s for ss in data.akit.values() for s in ss],
             "beamsnet": [s for block in data.beamsnet for s in block]}
    t0 = time.perf_counter()
    net = train_network(train, missing, variant, seed, progress, data.spec)
    train_time = time.perf_counter() - t0
    metrics = final_metrics(net, train, variant, beamsnet_dir, beam_seed, data.spec)
    scen = scenario_name(missing)
    card = network_card(net, variant, seed, time_s=train_time, data={
        "source": "A-KIT trajectories " + ", ".join(map(str, sorted(data.akit)))
                  + (" and snapir-2021-beamsnet V.npy (all)" if data.beamsnet else ""),
        "beam_model": beam_model_record(data.spec), "beam_seed": beam_seed, "align_yaw_deg": beamdata.BEAMSNET_YAW_DEG,
        "V_sha256": file_sha256(beamdata._data_dir(beamsnet_dir, "beamsnet") / "V.npy") if data.beamsnet else None})
    card = {
        **card,
        "split": {"selection": f"last {INNER_VAL_FRACTION:.0%} of every recording (epoch only)"},
        # one sigma per beam, the selection part's residual RMS (``load_completer(sigma="constant")``)
        "constant_sigma": metrics["val"]["beam_rmse_per_beam"],
        "metrics": metrics,
        "selected_by": "leave-trajectories-out cross-validation, graphnav.nets.crossval (graphnav eval-beams "
                       f"--folds): A-KIT folds {[list(f) for f in AKIT_FOLDS]} with BeamsNet mission blocks"
                       + ("; run_decay chosen on the same folds' networks by experiments/completer_fade_folds.py"
                          if variant.decay(scen) < 1.0 else "")
                       + chosen_for_note(spec, "graphnav eval-beams --folds --config"),
        "out_of_fold": [r for r in (summary or []) if r["variant"] == variant.name and r["scenario"] == scen],
    }
    return TrainResult(net.model, card)
