"""The beam history every hybrid estimator keeps for its completer.

The completer sees the N most recent *full* beam vectors. Epochs with all four beams valid push the
measurement; epochs with missing beams push the measured beams plus the regressed ones,
so during an outage earlier completions stand in for missing beams, as in the paper.

Completers are calibrated one ping ahead from a measured past. Once the past holds their own completions,
errors compound: the regressed beam of a 30 s outage is off by 1.2-2x its one-step sigma (``nets/weights/
README.md``, recursive outages), and the average estimator's spread collapses to zero on a constant
history. The history therefore keeps, per beam, the sigma it handed on in the current run of pings with regressed beams
and makes it non-decreasing through the run, growing like a random walk:
``sigma_k = sqrt(max(sigma_completer, sigma_{k-1})^2 + drift_std^2)`` (first regressed ping: the completer's
sigma). ``drift_std`` (m/s per ping) is the completer's attribute of that name when it has one that is not
None (a completer whose errors do not compound sets 0), else the history's, 0.03 by default: on recursive 30-ping outages of
the A-KIT DVL data it makes the RMS of (regressed-beam error / sigma) 0.91-1.00 for the network and the average
estimator, 2 and 3 missing beams, the variance a least-squares weight needs (the error tails are heavier
than Gaussian: 75-79 % within 1 sigma). Measured with ``experiments/calibrate_drift.py``; on the ten shared
trajectories it lowers every hybrid method's window VRMSE against 0.02 (HNTC 0.204 -> 0.141 m/s, Graph-HN
0.124 -> 0.105 m/s with 2 missing beams).

A completer that changes through the run (:class:`graphnav.nets.fused.FusedCompleter` with outage growth, a
:class:`graphnav.nets.network.NetworkCompleter` or :class:`graphnav.nets.imu_network.ImuNetworkCompleter` fading to
the average with ``run_decay``, and the completers that wrap one) sets ``takes_run_steps = True``: it is then also
handed ``run_steps`` (4,), the pings each beam has been regressed before this one in the current run (0 on its first
regressed ping).

The history also keeps each ping's stamp when it is given one (``t``, s): a completer trained for one DVL ping period
(``takes_past_dt``: the network completers, :mod:`graphnav.nets.dvl_match`) is handed ``past_dt_s``, the interval
from each past ping to the next and from the newest to the ping it completes, and leaves a ping whose past is not
spaced as in training to the average estimator.
"""
from __future__ import annotations

from collections import deque

import numpy as np


def complete_with(completer, past: np.ndarray, measured: np.ndarray, imu=None, run_steps=None, past_dt_s=None):
    """``completer.complete(past[-completer.n_past:], measured)``, handing the IMU window to a completer with
    ``needs_imu``, the run steps (:class:`BeamHistory`) to one with ``takes_run_steps``
    and the past pings' intervals (``past_dt_s``, as long as ``past``; cut to the completer's window) to one with
    ``takes_past_dt``: how :class:`BeamHistory` and a completer that wraps others (:mod:`graphnav.nets`: auto,
    IMU-aware auto, fused) call a completer, so that no argument is dropped on the way."""
    kwargs = {}
    if getattr(completer, "needs_imu", False):
        kwargs["imu"] = imu
    if getattr(completer, "takes_run_steps", False):
        kwargs["run_steps"] = run_steps
    if getattr(completer, "takes_past_dt", False):
        kwargs["past_dt_s"] = None if past_dt_s is None else np.asarray(past_dt_s, float)[-completer.n_past:]
    return completer.complete(np.asarray(past)[-completer.n_past:], measured, **kwargs)


class BeamHistory:
    """Ring buffer of the last ``n_past`` full beam vectors (m/s)."""

    def __init__(self, n_past: int, drift_std: float = 0.03):
        if n_past < 1:
            raise ValueError(f"n_past must be >= 1, got {n_past}")
        self.n_past = n_past
        self.drift_std = drift_std
        self._buf: deque[np.ndarray] = deque(maxlen=n_past)
        self._t: deque[float | None] = deque(maxlen=n_past)        # stamps of the pings in _buf (None: not given)
        self._run_sigma = np.zeros(4)     # sigma handed on for each beam in the current run of regressed pings
        self._run_steps = np.zeros(4, dtype=int)   # regressed pings of each beam in the current run so far

    def __len__(self) -> int:
        return len(self._buf)

    @property
    def ready(self) -> bool:
        """True once ``n_past`` full vectors have been pushed."""
        return len(self._buf) == self.n_past

    def push(self, beams: np.ndarray, t: float | None = None) -> None:
        """Append one full (4,) beam vector (it must be finite) of the ping at ``t`` (s; None: not known)."""
        beams = np.asarray(beams, dtype=float).reshape(4)
        if not np.all(np.isfinite(beams)):
            raise ValueError("BeamHistory.push needs a full finite beam vector")
        self._buf.append(beams.copy())
        self._t.append(None if t is None else float(t))

    def push_measured(self, beams: np.ndarray, t: float | None = None) -> None:
        """Append a measured full (4,) beam vector from outside :meth:`complete` (e.g. the beams a DVL-frame
        velocity implies) of the ping at ``t`` (s): a run of regressed pings ends there."""
        self.push(beams, t)
        self._run_sigma[:] = 0.0
        self._run_steps[:] = 0

    @property
    def run_steps(self) -> np.ndarray:
        """(4,) int: per beam, the regressed pings of its current run, the last completed one included."""
        return self._run_steps.copy()

    def past(self) -> np.ndarray:
        """(n_past, 4) oldest first."""
        return np.array(self._buf)

    def past_dt(self, t: float | None) -> np.ndarray | None:
        """(len,) s: the interval from each past ping to the next, the newest one's to a ping at ``t`` (s), oldest
        first; None when a stamp is not known."""
        if t is None or any(s is None for s in self._t):
            return None
        return np.diff([*self._t, float(t)])

    def complete(self, completer, beams: np.ndarray, valid: np.ndarray, imu=None, t: float | None = None):
        """Complete one ping and update the history.

        Args:
            completer: object with ``complete(past, measured) -> (beams, sigma)`` and ``n_past``; a completer
                with ``needs_imu = True`` (:class:`graphnav.nets.ImuNetworkCompleter`) is called as
                ``complete(past, measured, imu=imu)``.
            beams: (4,) measured beams, m/s.
            valid: (4,) bool validity.
            imu: ``(f_b, omega_b)``, each (``completer.imu_samples``, 3), or shorter (the beam-only member's own,
                ``member_imu_samples``): the last IMU samples up to the ping (oldest first, m/s^2 and rad/s, body
                frame), for completers that need it; ignored otherwise.
            t: the ping's stamp, s (None: not known): kept with the ping, and the past pings' intervals up to it handed
                to a completer with ``takes_past_dt`` as ``past_dt_s``.

        Returns:
            (beams (4,), sigma (4,)): the full vector and the per-beam sigma (0 for measured beams), or
            ``None`` when the ping's missing beams cannot be regressed yet (history not full) -- the caller then
            uses the measured beams alone. Full pings always go into the history.
        """
        valid = np.asarray(valid, dtype=bool)
        self._run_sigma[valid] = 0.0
        self._run_steps[valid] = 0
        if valid.all():
            self.push(beams, t)
            return np.asarray(beams, dtype=float), np.zeros(4)
        if not self.ready:
            self._run_sigma[:] = 0.0
            self._run_steps[:] = 0
            return None
        measured = np.where(valid, beams, np.nan)
        full, sigma = complete_with(completer, self.past(), measured, imu=imu, run_steps=self._run_steps.copy(),
                                    past_dt_s=self.past_dt(t))
        regressed = ~valid
        continuing = regressed & (self._run_sigma > 0)
        drift_std = getattr(completer, "drift_std", None)
        if drift_std is None:
            drift_std = self.drift_std
        grown = np.sqrt(np.maximum(sigma, self._run_sigma) ** 2 + drift_std ** 2)
        sigma = np.where(continuing, grown, sigma)
        self._run_sigma = np.where(regressed, sigma, 0.0)
        self._run_steps = np.where(regressed, self._run_steps + 1, 0)
        self.push(full, t)
        return full, sigma
