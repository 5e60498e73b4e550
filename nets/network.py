"""Loading the shipped regressors as beam completers (``complete(past, measured) -> (beams, sigma)``).

``load_completer(2)`` / ``load_completer(3)`` give the network of the paper's scenario (beams 1 and 3
missing / only beam 2 kept). Real dropouts have other patterns, so ``load_completer("auto")`` returns a
dispatcher: the network when the missing pattern is one a network was trained for, the average estimator
otherwise (and when nothing is missing, the measured beams pass through).
"""
from __future__ import annotations

import json
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import torch

import graphnav
from graphnav.core.errors import ConfigError, DataError
from graphnav.estimators.history import complete_with

from .average import AverageCompleter
from .completer import FALLBACK_KINDS, check_inputs, check_run_decay, fade_to_average, new_fallbacks, summed_fallbacks
from .dvl_match import TrainedForOneDvl, bind_members
from .model import NO_BEAM_ONLY_TOTAL_OUTAGE, BeamEnsemble, BeamRegressor, beam_model, normalize_missing, scenario_name
from .storage import READABLE_VERSIONS, file_sha256, weights_dir

#: Margin (m/s) around the training envelope: about two beam-noise sigmas (0.042 m/s), so that noise on a
#: ping at the edge of the training data does not switch completers.
ENVELOPE_MARGIN_MPS = 0.1


class InputEnvelope:
    """The inputs a network was trained on: per-beam range and largest ping-to-ping change, m/s.

    From the model card's ``"envelope"`` (:func:`graphnav.nets.training.training_envelope`); a card without
    one gives the normalisation's mean +- 4 std per beam and no step limit.
    """

    def __init__(self, beam_min, beam_max, max_step=None, margin: float = ENVELOPE_MARGIN_MPS):
        self.lo = np.asarray(beam_min, float) - margin
        self.hi = np.asarray(beam_max, float) + margin
        self.max_step = None if max_step is None else np.asarray(max_step, float) + margin

    @classmethod
    def from_card(cls, card: dict) -> "InputEnvelope | None":
        if "envelope" in card:
            env = card["envelope"]
            return cls(env["beam_min"], env["beam_max"], env.get("max_step"))
        if "normalisation" in card:
            mean, std = (np.asarray(card["normalisation"][k], float) for k in ("beam_mean", "beam_std"))
            return cls(mean - 4 * std, mean + 4 * std)
        return None

    def contains(self, past: np.ndarray, measured: np.ndarray, kept) -> bool:
        """Whether every past beam, the kept measured beams and (with a step limit) every ping-to-ping
        change of them lie inside the envelope."""
        kept = list(kept)
        if np.any((past < self.lo) | (past > self.hi)):
            return False
        if np.any((measured[kept] < self.lo[kept]) | (measured[kept] > self.hi[kept])):
            return False
        if self.max_step is None:
            return True
        return bool(np.all(np.abs(np.diff(past, axis=0)) <= self.max_step)
                    and np.all(np.abs(measured[kept] - past[-1, kept]) <= self.max_step[kept]))


class NetworkCompleter(TrainedForOneDvl):
    """A trained :class:`BeamRegressor` (or :class:`~graphnav.nets.model.BeamEnsemble`) behind the completer
    interface.

    Args:
        model: the trained network (its ``missing`` pattern is the only one it serves).
        sigma: ``"head"`` for the per-ping sigma of the heteroscedastic head, or ``"constant"`` for the
            per-beam RMS residual on the validation split (``constant_sigma``, m/s).
        constant_sigma: per-missing-beam sigma (m/s) for ``sigma="constant"``.
        sigma_scale: factor on every returned sigma (default 1: per ping the sigma is calibrated).
            Through recursive 30 s outages the RMS of error/sigma is 1.2-2.0 (model card); the growth
            that :class:`graphnav.estimators.history.BeamHistory` adds over a run of filled pings covers that.
        run_decay: ``gamma`` in (0, 1]: through a run of pings with regressed beams the completion fades from the
            network's to the average estimator's over the same past, ``w b_net + (1 - w) b_avg`` with
            ``w = gamma^k`` at the k-th regressed ping of the run (k from 0: a ping after a measured past is the
            network's alone), and the sigma likewise ``w s_net + (1 - w) s_avg`` (the sigma of the blend if the
            two errors were fully correlated, a bound). Fed its own completions, the network can walk away from
            motion it was not trained on, where the average holds the last beams; 1 (default): no fading. The
            estimators hand over ``k`` (``takes_run_steps``, :class:`graphnav.estimators.history.BeamHistory`); a
            call without ``run_steps`` is a first regressed ping. Chosen out of fold
            (``experiments/completer_fade_folds.py``, docs/decisions/completers.md).

    A network extrapolates badly outside the data it was trained on (no-bottom-lock samples in its past
    window put its beams 0.1-0.3 m/s off, where the average estimator stays bounded): a ping whose inputs
    leave the card's :class:`InputEnvelope` is filled by the average estimator over the same window, and
    counted in ``fallbacks["envelope"]`` (:func:`graphnav.evaluation.methods.run_method` puts the counts of a run in
    ``info["completer_fallbacks"]``). Bound to a mission's DVL whose beams are not those it was trained for
    (:meth:`bind_dvl`, :mod:`graphnav.nets.dvl_match`), it leaves every ping to the average estimator, counted in
    ``fallbacks["dvl"]``; a ping whose past pings are closer together than the trained DVL period allows (a DVL
    pinging faster) or further apart than a few periods (a long gap; ``past_dt_s``,
    :meth:`~graphnav.nets.dvl_match.TrainedForOneDvl.period_mismatch`), counted in ``fallbacks["period"]``.
    """

    def __init__(self, model: BeamRegressor | BeamEnsemble, sigma: str = "head", constant_sigma=None,
                 card: dict | None = None, sigma_scale: float = 1.0, run_decay: float = 1.0):
        if sigma not in ("head", "constant"):
            raise ConfigError(f"sigma must be 'head' or 'constant', got '{sigma}'")
        if sigma == "constant" and constant_sigma is None:
            raise ConfigError("sigma='constant' needs constant_sigma (the model card's validation RMS)")
        self.model = model.eval()
        self.n_past = model.n_past
        self.missing = model.missing
        self.sigma_mode = sigma
        self.constant_sigma = None if constant_sigma is None else np.asarray(constant_sigma, float)
        if not sigma_scale > 0:
            raise ConfigError(f"sigma_scale must be > 0, got {sigma_scale}")
        self.sigma_scale = float(sigma_scale)
        self.run_decay = check_run_decay(run_decay, "NetworkCompleter")
        self.takes_run_steps = self.run_decay < 1.0
        self.card = card or {}
        self.envelope = InputEnvelope.from_card(self.card)
        self.fallback = AverageCompleter(self.n_past)
        self.fallbacks = new_fallbacks()

    def complete(self, past: np.ndarray, measured: np.ndarray, run_steps=None, past_dt_s=None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Fill the missing beams of one ping.

        Args:
            past: (n_past, 4) the last full beam vectors, oldest first, m/s.
            measured: (4,) beams of this ping, NaN exactly at the network's missing beams, m/s.
            run_steps: (4,) regressed pings of each beam earlier in the current run (``run_decay``; None: 0).
            past_dt_s: (n_past,) s, the interval from each past ping to the next (the newest one's to this ping);
                None: stamps unknown, not checked.

        Returns:
            (beams (4,), sigma (4,)) m/s; measured beams passed through with sigma 0.

        A ping that lacks more beams than the network's pattern (one of its inputs is missing too), of a DVL the
        network is bound to and was not trained for (:meth:`bind_dvl`), whose past pings are not spaced as in
        training (:meth:`period_mismatch`), or whose inputs lie outside its envelope, is filled by the average
        estimator over the same past (counted in ``fallbacks["pattern"]`` / ``["dvl"]`` / ``["period"]`` /
        ``["envelope"]``).

        Raises:
            DataError: wrong shape, non-finite past, or a missing pattern that is neither the network's nor
                a superset of it.
        """
        past, measured = check_inputs(past, measured, self.n_past)
        pattern = tuple(int(b) for b in np.flatnonzero(~np.isfinite(measured)))
        if pattern != self.missing:
            if not set(self.missing) < set(pattern):
                raise DataError(f"missing beams {list(pattern)} (0-based) do not match the network's "
                                f"{list(self.missing)}; use load_completer('auto') for any pattern",
                                "completer", field="measured")
            # a ping that also lost a beam the network takes as input (e.g. marked invalid by the loader
            # inside an outage window): the network cannot serve it, the average estimator can
            self.fallbacks["pattern"] += 1
            return self.fallback.complete(past, measured)
        reason = self.refusal(past, measured, past_dt_s)
        if reason is not None:
            self.fallbacks[reason] += 1
            return self.fallback.complete(past, measured)
        with torch.no_grad():
            out, sig = self.model(torch.as_tensor(past, dtype=torch.float32)[None],
                                  torch.as_tensor(measured[list(self.model.kept)], dtype=torch.float32)[None])
        beams, sigma = measured.copy(), np.zeros(4)
        beams[list(self.missing)] = out[0].double().numpy()
        sigma[list(self.missing)] = self.sigma_scale * (self.constant_sigma if self.sigma_mode == "constant"
                                                        else sig[0].double().numpy())
        return fade_to_average(beams, sigma, measured, run_steps, self.run_decay,
                               lambda: self.fallback.complete(past, measured))


class AutoCompleter:
    """Serve any missing pattern: a network when one was trained for it, else the average estimator.

    ``n_past`` is the longest window of its completers (5 with the shipped networks); each completer sees
    the most recent ``n_past`` of its own. With no beam missing the measured beams pass through.
    """

    def __init__(self, networks: list[NetworkCompleter], fallback: AverageCompleter):
        self.networks = {net.missing: net for net in networks}
        self.fallback = fallback
        self.n_past = max([net.n_past for net in networks] + [fallback.n_past])
        self.takes_run_steps = any(net.takes_run_steps for net in networks)
        self.takes_past_dt = any(getattr(net, "takes_past_dt", False) for net in networks)

    @property
    def fallbacks(self) -> dict[str, int]:
        """Pings the networks handed to the average estimator (inputs outside their envelope, a DVL they were not
        trained for, past pings not spaced as they were trained for); patterns without a network go to the average
        estimator by design and are not counted."""
        counts = summed_fallbacks(self.networks.values())
        return {kind: 0 if kind == "pattern" else counts.get(kind, 0) for kind in FALLBACK_KINDS}

    def bind_dvl(self, T_b: np.ndarray) -> list[str]:
        """Bind every network to a mission's DVL (``T_b``: (4, 3) beam unit vectors, body frame;
        :meth:`NetworkCompleter.bind_dvl`)."""
        return bind_members(T_b, self.networks.values())

    def completer_for(self, measured: np.ndarray):
        """The completer that serves the missing pattern (NaN) of ``measured``."""
        pattern = tuple(int(b) for b in np.flatnonzero(~np.isfinite(np.asarray(measured, float))))
        return self.networks.get(pattern, self.fallback)

    def complete(self, past: np.ndarray, measured: np.ndarray, run_steps=None, past_dt_s=None
                 ) -> tuple[np.ndarray, np.ndarray]:
        past, measured = check_inputs(past, measured, self.n_past)
        if np.all(np.isfinite(measured)):
            return measured.copy(), np.zeros(4)
        return complete_with(self.completer_for(measured), past, measured, run_steps=run_steps, past_dt_s=past_dt_s)


def card_run_decay(card: dict, name: str, directory: str | Path | None = None) -> float:
    """The model card's ``"run_decay"`` (1 when it has none), checked; an error names the card file
    ``directory/<name>.json`` (default folder: the shipped weights)."""
    card_file = Path(directory or weights_dir()) / f"{name}.json"
    return check_run_decay(card.get("run_decay", 1.0), str(card_file))


def load_weights(model_cls, name: str, missing: tuple, directory: str | Path | None = None,
                 kind: str | None = None, train_hint: str = "graphnav train-beams"):
    """Load ``<name>.pt`` and its card ``<name>.json`` from ``directory`` (default: the shipped weights).

    The card must have a format version of :data:`~graphnav.nets.storage.READABLE_VERSIONS`, the ``kind`` (None for
    the beam-only networks), the ``missing`` beams and the sha256 of the ``.pt``; the tensors must match
    ``model_cls(**card["architecture"])``.

    Raises:
        ConfigError: naming the file and what does not match (``train_hint`` says how to make the files).
    """
    directory = Path(directory) if directory is not None else weights_dir()
    pt, js = directory / f"{name}.pt", directory / f"{name}.json"
    if not pt.is_file() or not js.is_file():
        raise ConfigError(f"no trained weights for '{name}' in {directory} (need {pt.name} and {js.name}); "
                          f"train them with: {train_hint}")
    card = json.loads(js.read_text())
    if card.get("format_version") not in READABLE_VERSIONS or card.get("kind") != kind:
        raise ConfigError(f"{js}: weights format version {card.get('format_version')} of kind "
                          f"{card.get('kind')!r}, this graphnav reads versions {list(READABLE_VERSIONS)} of kind "
                          f"{kind!r}; retrain with {train_hint}")
    if tuple(card.get("missing", ())) != missing:
        raise ConfigError(f"{js}: card is for missing beams {card.get('missing')}, expected {list(missing)}")
    if card.get("graphnav_version") != graphnav.__version__:
        warnings.warn(f"{js}: trained with graphnav {card.get('graphnav_version')}, running "
                      f"{graphnav.__version__}", stacklevel=3)
    if ("weights_sha256" in card or kind is not None) and card.get("weights_sha256") != file_sha256(pt):
        raise ConfigError(f"{pt}: file does not match the checksum in its model card {js.name}")
    model = model_cls(**card["architecture"])
    state = torch.load(pt, map_location="cpu", weights_only=True)
    expected = {k: list(v.shape) for k, v in model.state_dict().items()}
    found = {k: list(v.shape) for k, v in state.items()}
    if found != expected or card.get("state_dict_shapes", expected) != expected:
        diff = sorted(k for k in set(expected) | set(found) if expected.get(k) != found.get(k))
        raise ConfigError(f"{pt}: tensors do not match the architecture {card['architecture']}: "
                          + ", ".join(f"{k} {found.get(k)} (expected {expected.get(k)})" for k in diff))
    model.load_state_dict(state)
    return model.eval(), card


def load_model(missing, directory: str | Path | None = None) -> tuple[BeamRegressor | BeamEnsemble, dict]:
    """Load the weights and model card of scenario ``missing`` from ``directory`` (default: shipped ones): one
    :class:`BeamRegressor`, or a :class:`~graphnav.nets.model.BeamEnsemble` when the card's architecture has
    ``members``.

    Raises:
        ConfigError: files missing, format version or scenario mismatch, tensor shapes that do not match
            the architecture in the card, or weights that are not the ones the card describes.
    """
    missing = normalize_missing(missing)
    if len(missing) == 4:
        raise ConfigError(NO_BEAM_ONLY_TOTAL_OUTAGE)
    return load_weights(beam_model, scenario_name(missing), missing, directory,
                        train_hint=f"graphnav train-beams --missing {','.join(map(str, missing))}")


def load_completer(missing=2, sigma: str = "head", directory: str | Path | None = None,
                   fallback_n_past: int = 3, sigma_scale: float = 1.0,
                   run_decay: float | dict[str, float] | None = None):
    """A beam completer with the shipped (or ``directory``'s) weights.

    Args:
        missing: ``2`` / ``"2-missing"`` (beams 1 and 3 missing, N = 3), ``3`` / ``"3-missing"`` (only beam
            2 kept, N = 5), a tuple of 0-based missing beams with trained weights, or ``"auto"`` for an
            :class:`AutoCompleter` that serves every pattern (network where trained, average otherwise).
        sigma: ``"head"`` (per-ping heteroscedastic sigma) or ``"constant"`` (validation RMS per beam).
        fallback_n_past: window of the average estimator used by ``"auto"`` for untrained patterns.
        sigma_scale: factor on the network's sigma (see :class:`NetworkCompleter`).
        run_decay: fading to the average through a run of regressed pings (see :class:`NetworkCompleter`);
            None: the model card's ``"run_decay"`` (1, no fading, when the card has none). With ``"auto"`` also
            a mapping scenario ("2-missing", "3-missing") -> run_decay (a scenario it lacks: the card's).
        directory: the weights' folder; with ``"auto"`` also a mapping scenario -> folder, whose scenarios are the
            networks the completer holds (out-of-fold networks live one scenario to a folder; the other patterns go
            to the average estimator).
    """
    if missing == "auto":
        folders = (dict(directory) if isinstance(directory, Mapping)
                   else dict.fromkeys(("2-missing", "3-missing"), directory))     # the auto completer's networks
        trained = tuple(folders)
        if not trained or set(trained) - {"2-missing", "3-missing"}:
            raise ConfigError(f"directory names {sorted(trained)}; the auto completer's networks are '2-missing' "
                              "and '3-missing'")
        decays = run_decay if isinstance(run_decay, dict) else dict.fromkeys(trained, run_decay)
        unknown = set(decays) - set(trained)
        if unknown:
            raise ConfigError(f"run_decay names {sorted(unknown)}; the auto completer's networks are "
                              f"{' and '.join(repr(m) for m in trained)}")
        nets = [load_completer(m, sigma, folders[m], sigma_scale=sigma_scale, run_decay=decays.get(m))
                for m in trained]
        return AutoCompleter(nets, AverageCompleter(fallback_n_past))
    if isinstance(directory, Mapping):
        raise ConfigError("a directory per scenario is for missing='auto'; give one network one folder")
    if isinstance(missing, (int, np.integer)) and not isinstance(missing, bool):
        if missing not in (2, 3):
            raise ConfigError(f"missing={missing}: shipped networks exist for 2 and 3 missing beams; "
                              "use 'auto' for other patterns")
        missing = f"{missing}-missing"
    if isinstance(run_decay, dict):
        raise ConfigError("run_decay per scenario is for missing='auto'; give one network one run_decay")
    model, card = load_model(missing, directory)
    if run_decay is None:
        run_decay = card_run_decay(card, scenario_name(normalize_missing(missing)), directory)
    return NetworkCompleter(model, sigma, card.get("constant_sigma"), card, sigma_scale, run_decay)
