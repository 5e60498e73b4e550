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

A completer whose ``run_sigma`` attribute is ``"measured-change"`` (experimental; Graph-HN's and Graph-HNP's completers,
which can :meth:`rehearse`) has the sigma of its missing beams judged by the beams still measured instead of grown:
through the run the history keeps the completer's own completion of all four beams from the run's held past (what it
would give each beam had that beam been missing since the run started; for these completers exactly what it gives
the missing ones). A measured beam's change from that, ``r_j`` (m/s), is the completer's error in that beam's
direction plus the beam noise; its mean square over the measured beams, smoothed over :data:`MEASURED_CHANGE_PINGS`
pings, less the noise variance, is the sigma's square, floored by the completer's own sigma, times the completer's
``run_sigma_scale`` (1 when it has none). A steady run keeps the completer's sigma; a manoeuvre the measured beams see
widens it. A ping without a measured beam grows the sigma as
above (docs/decisions/completers.md, "The completions judged by the beams still measured").
"""
from __future__ import annotations

from collections import deque

import numpy as np

from graphnav.core.errors import ConfigError

#: How the sigma of a run of regressed pings is set: by the fixed growth (``"growth"``, the default) or by the change
#: the beams still measured show (``"measured-change"``), read from a completer's ``run_sigma`` (module docstring).
RUN_SIGMAS = ("growth", "measured-change")
#: Pings over which the measured-change sigma smooths the measured beams' squared change (exponentially; the running
#: mean over a run's first pings). Set by judgement, not fitted.
MEASURED_CHANGE_PINGS = 5


class SmoothedSquare:
    """A mean square ((m/s)^2) smoothed over :data:`MEASURED_CHANGE_PINGS` pings: the running mean over a run's first
    pings, then exponential. The measured-change sigma's and the graph's side of ``GraphOptions.measured_both_margin``
    (:mod:`graphnav.estimators.graph.regressed`), so that the two errors are read alike."""

    def __init__(self):
        self.value, self.pings = 0.0, 0

    def add(self, square: float) -> None:
        self.pings += 1
        self.value += (square - self.value) / min(self.pings, MEASURED_CHANGE_PINGS)

    def less_noise(self, noise_std: float) -> float:
        """The smoothed mean square less the noise's variance (``noise_std``, m/s), at least 0."""
        return max(self.value - noise_std ** 2, 0.0)


def run_sigma_of(completer) -> tuple[str, float]:
    """The run sigma (:data:`RUN_SIGMAS`) a completer asks for with its ``run_sigma`` attribute (absent or None:
    ``"growth"``) and its ``run_sigma_scale`` (1 when it has none), checked: ``"measured-change"`` needs a completer
    that can ``rehearse`` a ping without beams."""
    mode = getattr(completer, "run_sigma", None) or "growth"
    if mode not in RUN_SIGMAS:
        raise ConfigError(f"{type(completer).__name__}.run_sigma = {mode!r}: expected one of {RUN_SIGMAS}")
    if mode == "measured-change" and not callable(getattr(completer, "rehearse", None)):
        raise ConfigError(f"{type(completer).__name__}.run_sigma = 'measured-change' needs a completer that can "
                          "rehearse a ping without beams (the average estimator, the pivot completer)")
    scale = getattr(completer, "run_sigma_scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0 < scale < float("inf"):
        raise ConfigError(f"{type(completer).__name__}.run_sigma_scale = {scale!r} is not a factor > 0")
    return mode, float(scale)


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
        self._held: np.ndarray | None = None   # the completer's all-beam completions through the run, (n_past, 4)
        self._change2 = SmoothedSquare()   # the measured beams' squared change from the held completions

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
        self._end_run()

    def _end_run(self) -> None:
        self._run_sigma[:] = 0.0
        self._run_steps[:] = 0
        self._held, self._change2 = None, SmoothedSquare()

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
            self._end_run()
            return np.asarray(beams, dtype=float), np.zeros(4)
        if not self.ready:
            self._end_run()
            return None
        measured = np.where(valid, beams, np.nan)
        full, sigma = complete_with(completer, self.past(), measured, imu=imu, run_steps=self._run_steps.copy(),
                                    past_dt_s=self.past_dt(t))
        regressed = ~valid
        continuing = regressed & (self._run_sigma > 0)
        drift_std = getattr(completer, "drift_std", None)
        if drift_std is None:
            drift_std = self.drift_std
        # the held completions advance at every ping of the run, a total outage's too
        mode, scale = run_sigma_of(completer)
        change = self._measured_change(completer, beams, valid, imu) if mode == "measured-change" else None
        if change is not None and valid.any():
            sigma = np.where(regressed, scale * np.maximum(sigma, change), sigma)
        else:
            grown = np.sqrt(np.maximum(sigma, self._run_sigma) ** 2 + drift_std ** 2)
            sigma = np.where(continuing, grown, sigma)
        self._run_sigma = np.where(regressed, sigma, 0.0)
        self._run_steps = np.where(regressed, self._run_steps + 1, 0)
        self.push(full, t)
        return full, sigma

    def _measured_change(self, completer, beams: np.ndarray, valid: np.ndarray, imu) -> float:
        """The completion error scale (m/s) the measured beams show at this ping (module docstring), after holding
        the completer's all-beam completion one ping further; the last scale where no beam is measured."""
        if self._held is None:
            self._held = self.past()
        held = completer.rehearse(self._held[-completer.n_past:], imu)
        self._held = np.vstack([self._held[1:], held])
        if valid.any():
            self._change2.add(float(np.mean((np.asarray(beams, float)[valid] - held[valid]) ** 2)))
        return float(np.sqrt(self._change2.less_noise(getattr(completer, "noise_std", 0.0))))
