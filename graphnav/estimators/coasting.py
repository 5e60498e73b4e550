"""Pure-inertial coasting: the one check, shared by the EKF and the graph, live in the Navigator's stream and
in the replay runners, that an estimator says so when it has navigated on the IMU alone for longer than it
should.

Through a total DVL outage nothing bounds the velocity error but the IMU: a navigation-grade INS drifts by
centimetres per second over two minutes, a tactical or MEMS unit by metres per second. No bound on the
error can then hold; what must hold is that the estimator says so while it happens and that its covariance
covers the error (velocity NEES, ``graphnav faults --estimators``).

:class:`CoastingMonitor` is fed one output epoch at a time (:class:`graphnav.estimators.navigator.Navigator`
feeds it every estimate it makes, with the backend's word on whether a DVL update with a measured beam or velocity
entered). Beams a completer regresses at a ping without any measured beam are no aiding: a total outage is pure
inertial whether its pings are in the log with no valid beam (NaN, flagged invalid, no bottom lock) or missing from
it, and the warning says where the velocity then comes from: a hybrid method's completed beams (those its screening
let in: offered ones it took out are none), or the IMU alone. A stretch of epochs without aiding runs from the last
aided epoch before it (or the first epoch). When a stretch becomes longer than the limit the monitor warns once, at that
epoch ("pure inertial for X s since t0"); when aiding resumes after such a stretch it warns again ("aiding resumed ...
after X s pure inertial") with the predicted velocity sigma at the stretch's last un-aided epoch.
:meth:`CoastingMonitor.summary` goes into ``info``. :func:`check_pure_inertial` runs the same monitor over a finished
solution's arrays.

Time alone says little: a MEMS IMU is off by 1 m/s after 60 s without aiding, a navigation-grade one by
centimetres per second. :class:`SigmaMonitor` judges what the estimator itself predicts: an estimate whose claimed
horizontal velocity sigma exceeds ``HealthOptions.max_sigma_v_fraction`` of its horizontal speed (at least
``min_sigma_v_bound_mps``) is degraded, and ok again once aiding has brought the sigma below
:data:`SIGMA_RECOVER_FRACTION` of that bound. It sees what the NIS test cannot (an error no measurement
observes) and acts in partial outages too (one or two beams leave a direction unobserved). The 60 s rule stays:
a stretch without any measurement rests on the IMU's noise model alone, which nothing checks, whatever sigma it
claims.
"""
from __future__ import annotations

import warnings

import numpy as np

#: A degraded estimate is ok again when its claimed sigma is below this fraction of the bound: a sigma near the
#: bound (a speed that varies in a partial outage) does not flip the state at every ping.
SIGMA_RECOVER_FRACTION = 0.8

#: Longest pure-inertial stretch (s) an estimator accepts without a warning (``EkfOptions`` /
#: ``GraphOptions.max_pure_inertial_s``). Above the paper's 30 s beam-outage windows (LC coasts through
#: them by design) and well below the 120 s total outage of the fault suite.
MAX_PURE_INERTIAL_S = 60.0


def _sigma(cov_v_n) -> float:
    """sqrt of the velocity covariance trace, m/s (NaN without covariance)."""
    if cov_v_n is None:
        return float("nan")
    return float(np.sqrt(np.trace(np.asarray(cov_v_n, float))))


def _sigma_text(sigma: float, at: str = "") -> str:
    """The predicted velocity sigma for a message, or what stands in for it (a run without covariance)."""
    if not np.isfinite(sigma):
        return "no velocity covariance to predict its error with"
    return f"predicted velocity sigma{at} {sigma:.3f} m/s"


class CoastingMonitor:
    """Live pure-inertial check of one estimator run (see the module docstring).

    Args:
        name: estimator/method name for the messages.
        max_s: limit, s (``max_pure_inertial_s``).

    Attributes:
        spans: ``[start_s, end_s, sigma_v_end]`` per stretch longer than ``max_s``; the last one's end and sigma
            follow the stretch while it lasts (sigma: sqrt of the velocity covariance trace at its last
            un-aided epoch, m/s, NaN without covariance).
        longest_s: the longest stretch so far (also one still running), s.
        coasting_since: start (s) of the stretch under way, None while aided.
    """

    def __init__(self, name: str, max_s: float = MAX_PURE_INERTIAL_S):
        self.name = name
        self.max_s = float(max_s)
        self.spans: list[list[float]] = []
        self.longest_s = 0.0
        self.coasting_since: float | None = None
        self._last_t: float | None = None
        self._warned = False            # the stretch under way has passed max_s (and was warned)
        self._completed = False         # regressed beams entered in the stretch under way

    def update(self, t: float, aided: bool, cov_v_n=None, completed: bool = False) -> None:
        """One output epoch at t (s): whether a DVL update with a measured beam or velocity entered there (regressed
        beams alone do not count), the velocity covariance (3,3) m^2/s^2 after it (or None), and whether beams a
        completer regressed entered there, past the screening (a hybrid method's, at a ping with no measured beam: the
        warning then says the velocity comes from them, not from the IMU alone)."""
        t = float(t)
        if aided:
            if self._warned:
                start, end, sigma = self.spans[-1]
                warnings.warn(f"{self.name}: t={t:.2f} s: DVL aiding resumed after {end - start:.0f} s pure inertial "
                              f"({start:.1f}-{end:.1f} s); {_sigma_text(sigma, ' at its end')}",
                              RuntimeWarning, stacklevel=3)
            self.coasting_since, self._warned, self._completed = None, False, False
            self._last_t = t
            return
        if self.coasting_since is None:
            self.coasting_since = self._last_t if self._last_t is not None else t
        self._last_t = t
        self._completed |= bool(completed)
        length = t - self.coasting_since
        self.longest_s = max(self.longest_s, length)
        if length > self.max_s:
            if not self._warned:
                self._warned = True
                self.spans.append([self.coasting_since, t, _sigma(cov_v_n)])
                bound = ("its velocity comes from completed beams, not measured ones" if self._completed
                         else "the velocity is bounded by the IMU alone")
                warnings.warn(f"{self.name}: t={t:.2f} s: pure inertial for {length:.0f} s (since "
                              f"{self.coasting_since:.1f} s, no measured DVL beam), longer than max_pure_inertial_s="
                              f"{self.max_s:g}: {bound}; {_sigma_text(_sigma(cov_v_n))}",
                              RuntimeWarning, stacklevel=3)
            else:
                self.spans[-1][1:] = [t, _sigma(cov_v_n)]

    @property
    def coasting(self) -> bool:
        """The estimator is in a stretch longer than the limit now."""
        return self._warned

    def summary(self) -> dict:
        """``{"pure_inertial_max_s": longest stretch, "pure_inertial_spans": [[start_s, end_s, sigma_v_end],
        ...], "n_pure_inertial": number of spans, "pure_inertial_now": coasting at the last epoch}``."""
        return {"pure_inertial_max_s": self.longest_s, "pure_inertial_spans": [list(s) for s in self.spans],
                "n_pure_inertial": len(self.spans), "pure_inertial_now": self.coasting}


def check_pure_inertial(name: str, t: np.ndarray, aided: np.ndarray, cov_v_n: np.ndarray | None,
                        max_s: float = MAX_PURE_INERTIAL_S, completed: np.ndarray | None = None) -> dict:
    """:class:`CoastingMonitor` over a finished run: ``t`` (K,) epochs, s; ``aided`` (K,) True where a DVL update
    with a measured beam or velocity entered; ``cov_v_n`` (K,3,3) velocity covariance, m^2/s^2, or None;
    ``completed`` (K,) True where regressed beams entered (None: nowhere). Returns its summary."""
    monitor = CoastingMonitor(name, max_s)
    for k in range(len(t)):
        monitor.update(t[k], bool(aided[k]), None if cov_v_n is None else cov_v_n[k],
                       completed is not None and bool(completed[k]))
    return monitor.summary()


def horizontal_sigma(cov_v_n) -> float:
    """sqrt of the north + east velocity variances, m/s (NaN without covariance)."""
    if cov_v_n is None:
        return float("nan")
    cov = np.asarray(cov_v_n, float)
    return float(np.sqrt(cov[0, 0] + cov[1, 1]))


class SigmaMonitor:
    """Live check of the claimed horizontal velocity sigma of one estimator run (see the module docstring).

    Args:
        name: estimator/method name for the messages.
        options: :class:`graphnav.estimators.health.HealthOptions` (``max_sigma_v_fraction``,
            ``min_sigma_v_bound_mps``, ``max_warnings``).

    Attributes:
        spans: ``[start_s, end_s, largest_sigma_mps]`` per stretch of degraded estimates; the last one follows
            the stretch while it lasts.
        degraded: the last estimate's sigma is (still) above its bound.
        reason: why, for the estimate's ``health_why``.
    """

    def __init__(self, name: str, options):
        self.name = name
        self.fraction = float(options.max_sigma_v_fraction)
        self.floor = float(options.min_sigma_v_bound_mps)
        self.max_warnings = options.max_warnings
        self.spans: list[list[float]] = []
        self.degraded = False
        self.reason = ""
        self.n_warnings = 0

    def bound(self, v_n) -> float:
        """The largest acceptable horizontal velocity sigma at velocity ``v_n`` (3,) NED m/s, m/s."""
        return max(self.fraction * float(np.hypot(v_n[0], v_n[1])), self.floor)

    def update(self, t: float, v_n, cov_v_n) -> None:
        """One estimate at t (s): its NED velocity (3,) m/s and velocity covariance (3,3) m^2/s^2 (None: no
        claim to judge, the state is kept)."""
        sigma = horizontal_sigma(cov_v_n)
        if not np.isfinite(sigma):
            return
        bound = self.bound(v_n)
        if not self.degraded and sigma > bound:
            self.degraded = True
            self.spans.append([float(t), float(t), sigma])
            self._warn(t, f"claimed horizontal velocity sigma {sigma:.3f} m/s is above {bound:.3f} m/s "
                          f"({self._rule()}): the estimate is degraded until aiding brings it down")
        elif self.degraded and sigma < SIGMA_RECOVER_FRACTION * bound:
            self.degraded = False
            start, end, largest = self.spans[-1]
            self._warn(t, f"claimed horizontal velocity sigma back to {sigma:.3f} m/s after {t - start:.0f} s "
                          f"above its bound (largest {largest:.3f} m/s)")
        if self.degraded:
            span = self.spans[-1]
            span[1:] = [float(t), max(span[2], sigma)]
            self.reason = (f"claimed horizontal velocity sigma {sigma:.3f} m/s above {bound:.3f} m/s "
                           f"({self._rule()}) since t={span[0]:.1f} s")

    def _rule(self) -> str:
        return (f"max_sigma_v_fraction={self.fraction:g} of the horizontal speed, at least "
                f"min_sigma_v_bound_mps={self.floor:g}")

    def _warn(self, t: float, what: str) -> None:
        self.n_warnings += 1
        if self.n_warnings <= self.max_warnings:
            warnings.warn(f"{self.name}: t={t:.2f} s: {what}", RuntimeWarning, stacklevel=4)
        elif self.n_warnings == self.max_warnings + 1:
            warnings.warn(f"{self.name}: t={t:.2f} s: more velocity sigma events; further ones are counted only "
                          "(info['sigma_v_spans'])", RuntimeWarning, stacklevel=4)

    def summary(self) -> dict:
        """``{"sigma_v_spans": [[start_s, end_s, largest_sigma_mps], ...], "n_sigma_v_spans": number of spans,
        "sigma_v_degraded_now": degraded at the last estimate}``."""
        return {"sigma_v_spans": [list(s) for s in self.spans], "n_sigma_v_spans": len(self.spans),
                "sigma_v_degraded_now": self.degraded}


def check_sigma(name: str, t: np.ndarray, v_n: np.ndarray, cov_v_n: np.ndarray,
                options) -> tuple[SigmaMonitor, list[tuple[bool, str]]]:
    """:class:`SigmaMonitor` over a finished run: ``t`` (K,) s, ``v_n`` (K,3) NED m/s, ``cov_v_n`` (K,3,3)
    m^2/s^2. Returns the monitor (its ``summary()``) and per epoch (``degraded``, ``reason``)."""
    monitor = SigmaMonitor(name, options)
    states = []
    for k in range(len(t)):
        monitor.update(t[k], v_n[k], cov_v_n[k])
        states.append((monitor.degraded, monitor.reason))
    return monitor, states
