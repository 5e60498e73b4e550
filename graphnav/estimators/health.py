"""Estimator health: one normalised-innovation-squared (NIS) monitor for every estimator.

Each DVL measurement an estimator processes gives an innovation ``nu`` (measured minus predicted, at the
state *before* the measurement is used) and its predicted covariance ``S = H P H^T + R``; its NIS
``nu^T S^-1 nu`` is chi-square with ``dim(nu)`` degrees of freedom when the estimator is consistent.
:class:`NisMonitor` turns that stream into three things:

- **Consistency** (statistical): the NIS of consecutive, non-overlapping blocks of ``window`` measurements the
  estimator used is summed and compared with the two-sided chi-square band of the block's total dof at
  ``band_prob`` (scipy's ``chi2.ppf``). A block above the band means the estimator's covariance is too small
  for its errors (overconfident), below it too large. Counted; the first block above the band warns.
  Measurements the estimator's gate rejected are counted (``n_rejected``), not put into the blocks: the
  gate has already said they do not fit.
- **Divergence** (the estimator has lost track): a *sustained* excess, the median NIS per dof of the last
  ``window`` measurements above ``divergence_ratio`` (at least half of them with errors of ``sqrt(ratio)``
  sigma, far outside any plausible tuning error), or ``lockout_rejections`` measurements in a row rejected
  by the estimator's gate. The median, not the mean: an isolated outlier (a 1 m/s single-ping spike, NIS
  in the thousands) moves a 20-ping mean past any threshold but not the median, and the estimator that
  rejected it (gate) or down-weighted it (the graph's Huber kernel) has not lost track; an estimator
  that has lost track misfits every ping. Entering and leaving the diverged state are warned and kept as
  time intervals (``divergence_intervals``), so a caller can tell whether a given time window was
  affected.
- **Loss of track on a number**: an estimator whose state or innovation covariance is no longer finite, or whose
  linear algebra fails (a singular matrix), raises :class:`LostTrack`; its caller reports it with
  :meth:`NisMonitor.lost`, which enters the diverged state for good (nothing it computes after can be trusted),
  names the time and the failure, and keeps what was estimated before it.
- **Re-acquisitions**: an estimator that recovers from a lockout (the EKF re-initialises its velocity
  from the beams or inflates its covariance) reports it with :meth:`NisMonitor.reacquired`, which warns,
  counts and restarts the window.

**How much to trust an estimate** (:func:`epoch_health` per estimate, :func:`run_health` per run): one word,
``"ok"``, ``"degraded"`` or ``"diverged"``, and why. Diverged: the monitor is in the diverged state (per
estimate), or was at the end of the run (per run; a command then exits with :data:`EXIT_DIVERGED`).
Degraded: a claimed horizontal velocity sigma above ``max_sigma_v_fraction`` of the speed (at least
``min_sigma_v_bound_mps``), pure inertial longer than ``max_pure_inertial_s``, recovering from a divergence, or (per
run) a divergence that recovered, most NIS blocks above their band, or more than :data:`REFUSED_DEGRADED_FRACTION` of
an input stream refused. Every output carries it: the stream's JSON lines, the trajectory CSV's ``health``
column, ``summary.json`` and the bag's Odometry covariance.

Warnings are ``RuntimeWarning`` and name the estimator, the time (s) and what happened; after
``max_warnings`` per run further events are only counted. :meth:`NisMonitor.summary` is the plain dict that
goes into ``NavSolution.info["health"]``.
"""
from __future__ import annotations

import math
import warnings
from collections import deque
from dataclasses import dataclass

import numpy as np


class LostTrack(ArithmeticError):
    """An estimator's numbers failed at ``t`` (s): ``why`` (a singular innovation covariance, a state no longer
    finite). The caller stops the estimator there (:meth:`NisMonitor.lost`) rather than letting a traceback end the
    run and lose what it had estimated."""

    def __init__(self, t: float, why: str):
        super().__init__(f"t = {t:.3f} s: {why}")
        self.t, self.why = float(t), why


@dataclass
class HealthOptions:
    """Settings of :class:`NisMonitor` (and of the EKF's re-acquisition trigger).

    Attributes:
        window: measurements (DVL pings) per consistency block and in the sliding divergence window.
        band_prob: two-sided probability of the chi-square band of a block's summed NIS.
        divergence_ratio: median NIS per dof over the sliding window above which the estimator is declared
            diverged. 25 (5-sigma errors for at least half the window): in ``graphnav start-sweep`` on the
            shared A-KIT trajectories no run tripped the same threshold on the window *mean* (9180 runs; the
            highest run-mean NIS per dof is 2.86, HNLC in a 2-missing outage; 17 runs trip the lockout rule
            instead, and re-acquire), while a filter that has lost track shows 1e2-1e4 on every ping (EKF
            locked out after a 2-10 deg attitude error, ``experiments/lockout_demo.py``: NIS 344-7929 on 3 dof;
            graph with the IMU y axis of the wrong sign: 5.7e3 per dof).
        lockout_rejections: consecutive gated (rejected) measurements that count as a lockout: the
            estimator is declared diverged and (EKF) re-acquires. 5 pings = 5 s at 1 Hz.
        recover_after: measurements after a re-acquisition (or a divergence) with no rejection and a median
            NIS per dof below ``divergence_ratio`` after which the estimator is healthy again.
        max_warnings: warnings per run; later events are counted only.
        max_sigma_v_fraction: an estimate whose claimed horizontal velocity sigma (m/s) exceeds this fraction of
            its horizontal speed is degraded (:class:`graphnav.estimators.coasting.SigmaMonitor`): 0.1, a
            position error growing by 10 % of the distance travelled at one sigma, ten times what a DVL-aided
            INS is specified for (0.1-1 % of distance travelled).
        min_sigma_v_bound_mps: the bound on the claimed horizontal velocity sigma is at least this, m/s, so that
            a slow or hovering vehicle is not degraded by the DVL's own noise: 0.1, about twice the horizontal
            sigma one ping of a 4-beam DVL with 0.04 m/s beam noise gives.
    """

    window: int = 20
    band_prob: float = 0.999
    divergence_ratio: float = 25.0
    lockout_rejections: int = 5
    recover_after: int = 5
    max_warnings: int = 5
    max_sigma_v_fraction: float = 0.1
    min_sigma_v_bound_mps: float = 0.1


class NisMonitor:
    """Windowed NIS statistics, divergence flag, counters and warnings for one estimator run.

    Args:
        estimator: name used in warnings and the summary (e.g. ``"EKF TC"``, ``"Graph-TC"``).
        options: :class:`HealthOptions`.
    """

    def __init__(self, estimator: str, options: HealthOptions | None = None):
        self.estimator = estimator
        self.options = o = options or HealthOptions()
        self._recent: deque = deque(maxlen=o.window)       # (nis, dof) of the sliding divergence window
        self._block_nis = 0.0
        self._block_dof = 0
        self._block_n = 0
        self.n_nis = 0
        self.sum_nis = 0.0
        self.sum_dof = 0
        self.n_blocks = 0
        self.n_blocks_high = 0
        self.n_blocks_low = 0
        self.n_rejected = 0
        self.rejection_run = 0
        self.max_rejection_run = 0
        self.n_divergences = 0
        self.n_reacquired = 0
        self.diverged = False
        self.intervals: list[list] = []          # [t_enter, t_leave or None, reason]
        self.reacquisitions: list[list] = []     # [t, how]
        self._since_reset = 0                    # measurements since the last re-acquisition/divergence
        self.n_warnings = 0
        self.first_event: str | None = None
        self.lost_at: float | None = None        # the time (s) the estimator lost track on a number (:meth:`lost`)
        self.lost_why = ""                       # and the failure
        self.lost_last_estimate: float | None = None    # the time (s) of the last estimate made before it

    # --- input ------------------------------------------------------------------------------------
    def record(self, t: float, nis: float, dof: int, accepted: bool = True) -> None:
        """One measurement at time t (s): its NIS, degrees of freedom and whether the estimator used it."""
        o = self.options
        if not math.isfinite(nis):
            nis = math.inf
        self.n_nis += 1
        self.sum_nis += nis
        self.sum_dof += dof
        self._recent.append((nis, dof))
        self._since_reset += 1
        if accepted:
            self.rejection_run = 0
        else:
            self.n_rejected += 1
            self.rejection_run += 1
            self.max_rejection_run = max(self.max_rejection_run, self.rejection_run)
        # consistency: non-overlapping blocks of used measurements against the chi-square band of their dof
        if accepted:
            self._block_nis += nis
            self._block_dof += dof
            self._block_n += 1
        if self._block_n == o.window:
            from scipy.stats import chi2    # here, not at import: scipy.stats takes ~1 s to import (CLI start-up)
            lo, hi = chi2.ppf([(1 - o.band_prob) / 2, (1 + o.band_prob) / 2], self._block_dof)
            self.n_blocks += 1
            if self._block_nis > hi:
                self.n_blocks_high += 1
                if self.n_blocks_high == 1 and not self.diverged:
                    self._warn(t, f"NIS of the last {o.window} measurements {self._block_nis:.3g} is above its "
                                  f"{o.band_prob:g} chi-square band [{lo:.3g}, {hi:.3g}] ({self._block_dof} dof): "
                                  "the estimator's covariance is too small for its errors, or the measurements hold outliers "
                                  "(counted from now on)")
            elif self._block_nis < lo:
                self.n_blocks_low += 1
            self._block_nis, self._block_dof, self._block_n = 0.0, 0, 0
        # divergence
        ratio = self.window_ratio()
        if not self.diverged:
            if self.rejection_run >= o.lockout_rejections:
                self._enter(t, f"{self.rejection_run} measurements in a row rejected by the gate (lockout)")
            elif len(self._recent) == o.window and ratio > o.divergence_ratio:
                self._enter(t, f"median NIS per dof {ratio:.3g} over the last {o.window} measurements exceeds "
                               f"{o.divergence_ratio:g}")
        elif (self.lost_at is None and self._since_reset >= o.recover_after and self.rejection_run == 0
              and self._ratio_since_reset() <= o.divergence_ratio):
            self.diverged = False
            self.intervals[-1][1] = float(t)
            self._warn(t, f"recovered: the last {self._since_reset} measurements are consistent again "
                          f"(median NIS per dof {self._ratio_since_reset():.3g})")

    def reacquired(self, t: float, how: str) -> None:
        """The estimator re-acquired at time t (s) after a lockout; ``how`` says what it did."""
        self.n_reacquired += 1
        if len(self.reacquisitions) < 50:
            self.reacquisitions.append([float(t), how])
        self.rejection_run = 0
        self._recent.clear()
        self._since_reset = 0
        self._warn(t, f"re-acquired after a lockout: {how}")

    def lost(self, t: float, why: str, last_estimate: float | None = None) -> None:
        """The estimator lost track at time t (s) on a number (``why``: :class:`LostTrack`): diverged from then on,
        for good, warned. ``last_estimate``: the time (s) of the last estimate that stands, none after it."""
        self.lost_at, self.lost_why, self.lost_last_estimate = float(t), why, last_estimate
        if self.diverged:       # the interval keeps why it began (its start is not the loss's time)
            self.intervals[-1][2] = f"{self.intervals[-1][2]}; lost track at t = {t:.3f} s: {why}"
            self._warn(t, f"lost track: {why}")
        else:
            self._enter(t, f"lost track: {why}")

    # --- state ------------------------------------------------------------------------------------
    def window_ratio(self) -> float:
        """Median NIS per dof of the measurements in the sliding window (NaN when empty)."""
        return _median_ratio(self._recent)

    def _ratio_since_reset(self) -> float:
        return _median_ratio(list(self._recent)[-self._since_reset:] if self._since_reset else [])

    def _enter(self, t: float, reason: str) -> None:
        self.diverged = True
        self.n_divergences += 1
        self._since_reset = 0
        self.intervals.append([float(t), None, reason])
        self._warn(t, f"DIVERGED: {reason}")

    def _warn(self, t: float, what: str) -> None:
        message = f"{self.estimator}: t={t:.2f} s: {what}"
        if self.first_event is None:
            self.first_event = message
        self.n_warnings += 1
        if self.n_warnings <= self.options.max_warnings:
            warnings.warn(message, RuntimeWarning, stacklevel=3)
        elif self.n_warnings == self.options.max_warnings + 1:
            warnings.warn(f"{self.estimator}: t={t:.2f} s: more health events; further ones are counted only "
                          "(NavSolution.info['health'])", RuntimeWarning, stacklevel=3)

    def summary(self) -> dict:
        """Plain (JSON-ready) health record of the run."""
        o = self.options
        mean = self.sum_nis / self.sum_dof if self.sum_dof else float("nan")
        return {
            "estimator": self.estimator,
            "ok": not self.n_divergences,
            "diverged": self.n_divergences > 0,
            "diverged_at_end": self.diverged,
            "n_divergences": self.n_divergences,
            "divergence_intervals": [list(i) for i in self.intervals],
            "n_reacquired": self.n_reacquired,
            "reacquisitions": [list(r) for r in self.reacquisitions],
            "n_measurements": self.n_nis,
            "n_rejected": self.n_rejected,
            "max_rejection_run": self.max_rejection_run,
            "nis_mean_per_dof": mean if math.isfinite(mean) else None,
            "n_blocks": self.n_blocks, "n_blocks_above_band": self.n_blocks_high,
            "n_blocks_below_band": self.n_blocks_low,
            "window": o.window, "band_prob": o.band_prob, "divergence_ratio": o.divergence_ratio,
            "first_event": self.first_event,
            **({"lost_track_at": self.lost_at, "lost_track": self.lost_why,
                "last_estimate_before_lost_track": self.lost_last_estimate} if self.lost_at is not None else {}),
        }


def _median_ratio(measurements) -> float:
    """Median of NIS/dof over (nis, dof) pairs (NaN when empty)."""
    ratios = [n / d for n, d in measurements if d]
    return float(np.median(ratios)) if ratios else float("nan")


def diverged_during(health: dict | None, t_start: float, t_end: float) -> bool:
    """Whether a run's health record (:meth:`NisMonitor.summary`) has a divergence interval overlapping
    ``[t_start, t_end]`` (s); an interval still open at the end of the run extends to infinity."""
    if not health:
        return False
    for t0, t1, _reason in health.get("divergence_intervals", []):
        if t0 <= t_end and (t1 is None or t1 >= t_start):
            return True
    return False


def health_line(health: dict | None) -> str | None:
    """One line for command output: ``"health: ok ..."`` or what went wrong."""
    if not health:
        return None
    mean = health.get("nis_mean_per_dof")
    stats = (f"NIS/dof {mean:.2f}" if mean is not None else "no NIS") + \
        (f", {health['n_blocks_above_band']}/{health['n_blocks']} blocks above the chi-square band"
         if health.get("n_blocks") else "") + \
        (f", {health['n_rejected']} rejected" if health.get("n_rejected") else "")
    if health.get("diverged"):
        state = ("DIVERGED (not recovered at the end)" if health.get("diverged_at_end")
                 else f"diverged {health['n_divergences']} time(s), recovered")
        extra = f", re-acquired {health['n_reacquired']} time(s)" if health.get("n_reacquired") else ""
        if health.get("lost_track_at") is not None:
            extra += f", {_lost_track(health)}"
        return f"health: {state}{extra}; {stats}; first: {health.get('first_event')}"
    if health.get("state") in ("degraded", "diverged"):
        return f"health: {health['state']} ({'; '.join(health.get('why') or [])}); {stats}"
    return f"health: ok; {stats}"


#: Health states, from best to worst.
HEALTH_STATES = ("ok", "degraded", "diverged")
#: Exit code of ``graphnav smooth`` / ``graphnav online`` when the estimator had diverged at the end of the run.
EXIT_DIVERGED = 3
#: A run that had to refuse more than this fraction of an input stream is at best degraded.
REFUSED_DEGRADED_FRACTION = 0.05


def epoch_health(monitor: NisMonitor | None, coasting=None, sigma=None) -> tuple[str, str]:
    """(state, why) of the estimate just made, from the live NIS monitor, the live pure-inertial check
    (:class:`~graphnav.estimators.coasting.CoastingMonitor`) and the check of the claimed velocity sigma
    (:class:`~graphnav.estimators.coasting.SigmaMonitor`)."""
    if monitor is not None and monitor.diverged:
        reason = monitor.intervals[-1][2] if monitor.intervals else "diverged"
        return "diverged", reason
    why = []
    if coasting is not None and coasting.coasting:
        why.append(f"pure inertial since t={coasting.coasting_since:.1f} s (longer than "
                   f"max_pure_inertial_s={coasting.max_s:g})")
    if sigma is not None and sigma.degraded:
        why.append(sigma.reason)
    if why:
        return "degraded", "; ".join(why)
    if monitor is not None and monitor.n_divergences and monitor._since_reset < 2 * monitor.options.window:
        return "degraded", "recovering from a divergence"
    return "ok", ""


def _lost_track(health: dict) -> str:
    """What a run whose estimator lost track on a number (:meth:`NisMonitor.lost`) says of it: when, why, and where
    its estimates end (it took no data after it)."""
    last = health.get("last_estimate_before_lost_track")
    return (f"lost track at t = {health['lost_track_at']:.3f} s ({health.get('lost_track') or 'a numerical failure'})"
            + (f": no estimate after t = {last:.3f} s" if last is not None else ": no estimate"))


def run_health(health: dict | None, info: dict | None = None, streams: dict | None = None) -> dict:
    """``{"state": ok|degraded|diverged, "why": [...]}`` of a whole run, from the NIS monitor's summary
    (``health``), the run's info (pure-inertial spans, the Navigator's ``received`` / ``samples_refused``) and
    the loader's ``Mission.meta["streams"]`` (refusals, DVL outages)."""
    info = info or {}
    state, why = "ok", []

    def worse(s: str, reason: str) -> None:
        nonlocal state
        if HEALTH_STATES.index(s) > HEALTH_STATES.index(state):
            state = s
        why.append(reason)

    if health:
        if health.get("diverged_at_end"):
            worse("diverged", f"diverged, not recovered at the end ({health.get('first_event')})")
        elif health.get("diverged"):
            worse("degraded", f"diverged {health.get('n_divergences')} time(s), recovered "
                              f"({health.get('first_event')})")
        if health.get("lost_track_at") is not None:
            worse("diverged", _lost_track(health))
        n_blocks, high = health.get("n_blocks") or 0, health.get("n_blocks_above_band") or 0
        if n_blocks and high > 0.5 * n_blocks:
            worse("degraded", f"NIS above its chi-square band in {high} of {n_blocks} blocks (covariance too small "
                              "for the errors)")
    if info.get("estimates") == 0:
        worse("degraded", "no estimate: the estimator never started (alignment not completed, or no usable data)")
    spans = info.get("pure_inertial_spans") or []
    if spans:
        worse("degraded", f"{len(spans)} pure-inertial stretch(es), longest {info.get('pure_inertial_max_s', 0):.0f} s")
    sigma_spans = info.get("sigma_v_spans") or []
    if sigma_spans:
        longest = max(end - start for start, end, _ in sigma_spans)
        worse("degraded", f"{len(sigma_spans)} stretch(es) with the claimed horizontal velocity sigma above its "
                          f"bound, longest {longest:.0f} s, largest sigma {max(s for *_, s in sigma_spans):.2f} m/s")
    received, refused = info.get("received") or {}, info.get("samples_refused") or {}
    for stream, n in received.items():
        if n and refused.get(stream, 0) > REFUSED_DEGRADED_FRACTION * n:
            worse("degraded", f"{refused[stream]} of {n} {stream} samples refused on the stream")
    for stream, entry in (streams or {}).items():
        n, bad = entry.get("read", 0), sum(entry.get("refused", {}).values())
        if n and bad > REFUSED_DEGRADED_FRACTION * n:
            worse("degraded", f"{bad} of {n} {stream} samples refused at load ({entry['refused']})")
    return {"state": state, "why": why}

