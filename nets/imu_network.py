"""The IMU-aware regressor behind the completer interface, and loading its shipped weights.

Interface (what an estimator passes), in addition to the beam-only completers' ``complete(past, measured)``::

    completer = load_imu_completer(2)              # or 3, "2-missing", "3-missing"
    completer.needs_imu                            # True
    completer.n_past                               # N past full beam vectors (5 for 2 missing, 3 for 3)
    completer.imu_samples, completer.imu_rate_hz   # 2000 samples at 100 Hz: the last 20 s of IMU
    beams, sigma = completer.complete(past, measured, imu=(f_b, omega_b))

- ``past`` (N, 4) m/s: the last N full beam vectors, oldest first, one DVL period (``ping_dt``, 1 s) apart,
  completions included (:class:`graphnav.estimators.history.BeamHistory` keeps them);
- ``measured`` (4,) m/s: this ping's beams, NaN exactly at the network's missing beams;
- ``f_b`` and ``omega_b`` (imu_samples, 3): specific force (m/s^2) and angular rate (rad/s) in the body frame
  (FRD), the last ``imu_samples`` IMU samples at ``imu_rate_hz`` whose last one is the sample at (or just
  before) the ping time, oldest first, on the DVL's clock. ``BeamHistory.complete(completer, beams, valid,
  imu=(f_b, omega_b))`` forwards it; :func:`graphnav.nets.imu_window.imu_window_at` cuts it from an
  ``ImuData`` stream (None during the first 20 s).

Returns ``(beams (4,), sigma (4,))`` m/s as every completer (measured beams passed through, sigma 0).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from graphnav.core.dvl import PING_PERIOD_TOLERANCE
from graphnav.core.errors import ConfigError, DataError

from .average import AVERAGE_N_PAST, AverageCompleter
from .completer import check_inputs, check_run_decay, fade_to_average, new_fallbacks
from .dvl_match import TrainedForOneDvl, describe_beams
from .imu_model import ImuBeamRegressor
from .imu_window import check_imu, preintegrate
from .model import normalize_missing, scenario_name
from .network import InputEnvelope, card_run_decay, load_weights


def imu_weights_name(missing) -> str:
    """File stem of the IMU-aware weights for ``missing``: ``imu-2-missing``, ``imu-3-missing``, ..."""
    return "imu-" + scenario_name(missing)


def model_inputs(features, idx=None) -> list[torch.Tensor]:
    """The IMU tensors of the model's ``forward`` from :class:`~graphnav.nets.imu_window.ImuFeatures`."""
    fields = [getattr(features, k) for k in features.FIELDS]
    if idx is not None:
        fields = [f[idx] for f in fields]
    return [torch.as_tensor(f, dtype=torch.float32) for f in fields]


class ImuNetworkCompleter(TrainedForOneDvl):
    """A trained :class:`ImuBeamRegressor` as a beam completer that needs the IMU window (module docstring).

    Args:
        model: the trained network; it serves its ``missing`` pattern only.
        card: its model card.
        sigma_scale: factor on the returned sigma (1: calibrated per ping on held-out pings).
        run_decay: ``gamma`` in (0, 1]: through a run of regressed pings the completion fades to the mean of the
            last ``min(n_past, AVERAGE_N_PAST[scenario])`` pings of the past window (3 for 2 and 3 missing beams;
            the average estimator's N = 5 of 3 missing beams does not fit the network's 3-ping window), with
            ``gamma^k`` the network's weight at the k-th regressed ping of the run, as
            :class:`graphnav.nets.network.NetworkCompleter` fades; 1 (default): no fading.
            :func:`load_imu_completer` takes it from the model card.

    No ``drift_std`` of its own: :class:`graphnav.estimators.history.BeamHistory` grows the sigma through a run of regressed
    pings by its default (0.03 m/s per ping), conservative for this network (model card, outage coverage).

    A ping whose beams leave the card's ``"envelope"`` (the training beams' per-beam range and largest
    ping-to-ping change, :class:`graphnav.nets.network.InputEnvelope`) is completed by the average estimator over
    the same past and counted in ``fallbacks["envelope"]``, as the beam-only network does: out of fold, a
    trajectory slower than any the network was trained on (under 1 m/s, near the surface) made its outage
    completions several times worse than the average's (``docs/decisions/completers.md``, "Where the outages
    fall"). A card without an envelope (weights saved before it) checks nothing. Bound to a mission's DVL whose beams
    are not those it was trained for (:meth:`bind_dvl`, :mod:`graphnav.nets.dvl_match`), it leaves every ping to the
    average estimator, counted in ``fallbacks["dvl"]``, and so a ping whose past pings are not ``ping_dt`` apart
    (``past_dt_s``), counted in ``fallbacks["period"]`` (in the estimators the keyframer has already sent such a ping
    to the beam-only route, without the IMU window).
    """

    needs_imu = True
    #: it propagates each past ping over exactly one period (``ping_dt``): no longer interval passes
    longest_past_interval = 1.0 + PING_PERIOD_TOLERANCE

    def __init__(self, model: ImuBeamRegressor, card: dict | None = None, sigma_scale: float = 1.0,
                 run_decay: float = 1.0):
        if not sigma_scale > 0:
            raise ConfigError(f"sigma_scale must be > 0, got {sigma_scale}")
        self.run_decay = check_run_decay(run_decay, "ImuNetworkCompleter")
        self.takes_run_steps = self.run_decay < 1.0
        self.model = model.eval()
        self.missing = model.missing
        self.n_past = model.n_past
        self.imu_samples = model.imu_samples
        self.imu_rate_hz = model.imu_rate_hz
        self.ping_dt = model.ping_dt
        self.sigma_scale = float(sigma_scale)
        self.card = card or {}
        # the card's DVL (the default one for a card without a record) is what evaluations make beams for
        held, recorded = self.trained_T_b, super().trained_T_b
        if not np.allclose(held, recorded, atol=1e-5):
            raise ConfigError(f"IMU-aware network {self.card.get('name', '')}: its weights hold beams "
                              f"{describe_beams(held)}, its model card's DVL has {describe_beams(recorded)}")
        # the paper's N where the pattern has one (2 or 3 missing beams), else the network's window
        n_average = AVERAGE_N_PAST.get(scenario_name(self.missing), self.n_past)
        self.fallback = AverageCompleter(min(self.n_past, n_average))
        self.envelope = InputEnvelope.from_card(self.card) if "envelope" in self.card else None
        self.fallbacks = new_fallbacks()
        self._last_window = None      # (f_b, omega_b, features): _window_features'

    @property
    def trained_ping_period_s(self) -> float:
        """The ping period (s) the network propagates its past pings over: its model's ``ping_dt``."""
        return float(self.ping_dt)

    @property
    def trained_T_b(self) -> np.ndarray:
        """(4, 3) body-frame beam directions the network computes with: its model's ``T_b`` (the card's DVL, which
        the constructor checks against them)."""
        return self.model.T_b.detach().cpu().numpy().astype(float)

    def _window_features(self, f_b: np.ndarray, omega_b: np.ndarray):
        """:func:`preintegrate`'s features of the IMU window (m/s^2, rad/s, body frame), the last window's kept:
        rehearsed outages (:mod:`graphnav.estimators.rehearsal`) complete many pasts on one window."""
        last = self._last_window
        if last is None or not (np.array_equal(last[0], f_b) and np.array_equal(last[1], omega_b)):
            last = self._last_window = (np.array(f_b), np.array(omega_b),
                                        preintegrate(f_b, omega_b, self.n_past, self.imu_rate_hz, self.ping_dt))
        return last[2]

    def complete(self, past: np.ndarray, measured: np.ndarray, imu=None, run_steps=None, past_dt_s=None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Fill the missing beams of one ping (module docstring for the inputs; ``run_steps`` (4,): regressed
        pings of each beam earlier in the current run, for ``run_decay``; ``past_dt_s`` (n_past,) s: the intervals
        of the past pings, the newest one's to this ping, checked against ``ping_dt`` (None: not checked)).

        Raises:
            DataError: wrong shape or non-finite past/IMU, no IMU window, or a missing pattern the network
                was not trained for.
        """
        past, measured = check_inputs(past, measured, self.n_past)
        f_b, omega_b = check_imu(imu, self.imu_samples)
        pattern = tuple(int(b) for b in np.flatnonzero(~np.isfinite(measured)))
        if pattern != self.missing:
            raise DataError(f"missing beams {list(pattern)} (0-based) do not match the network's "
                            f"{list(self.missing)}", "completer", field="measured")
        reason = self.refusal(past, measured, past_dt_s)
        if reason is not None:
            self.fallbacks[reason] += 1
            return self.fallback.complete(past[-self.fallback.n_past:], measured)
        feats = self._window_features(f_b, omega_b)
        with torch.no_grad():
            out, sig = self.model(torch.as_tensor(past, dtype=torch.float32)[None],
                                  torch.as_tensor(measured[list(self.model.kept)], dtype=torch.float32)[None],
                                  *model_inputs(feats))
        beams, sigma = measured.copy(), np.zeros(4)
        beams[list(self.missing)] = out[0].double().numpy()
        sigma[list(self.missing)] = self.sigma_scale * sig[0].double().numpy()
        return fade_to_average(beams, sigma, measured, run_steps, self.run_decay,
                               lambda: self.fallback.complete(past[-self.fallback.n_past:], measured))


def load_imu_model(missing, directory: str | Path | None = None) -> tuple[ImuBeamRegressor, dict]:
    """Load the IMU-aware weights and model card of ``missing`` (default folder: the shipped weights).

    Raises:
        ConfigError: files missing, format version, kind or scenario mismatch, tensor shapes that do not match
            the architecture in the card, or weights that are not the ones the card describes (sha256).
    """
    missing = normalize_missing(missing)
    return load_weights(ImuBeamRegressor, imu_weights_name(missing), missing, directory, kind="imu",
                        train_hint=f"graphnav train-beams --imu --scenario {scenario_name(missing)}")


def load_imu_completer(missing=2, directory: str | Path | None = None, sigma_scale: float = 1.0,
                       run_decay: float | None = None):
    """The IMU-aware completer for ``missing`` (2 / 3 / scenario name / 0-based indices with weights);
    ``run_decay`` None: the model card's ``"run_decay"`` (1, no fading, when the card has none)."""
    if isinstance(missing, (int, np.integer)) and not isinstance(missing, bool):
        if missing not in (2, 3):
            raise ConfigError(f"missing={missing}: IMU-aware networks are shipped for 2 and 3 missing beams")
        missing = f"{missing}-missing"
    model, card = load_imu_model(missing, directory)
    if run_decay is None:
        run_decay = card_run_decay(card, imu_weights_name(missing), directory)
    return ImuNetworkCompleter(model, card, sigma_scale, run_decay)
