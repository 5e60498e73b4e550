"""Pure-inertial coasting: the one check, shared by the EKF and the graph, that an estimator says so when it
has navigated on the IMU alone for longer than it should.

Through a total DVL outage nothing bounds the velocity error but the IMU: a navigation-grade INS drifts by
centimetres per second over two minutes, a tactical or MEMS unit by metres per second. No bound on the
error can then hold; what must hold is that the estimator says so and that its covariance covers the error
(velocity NEES, ``scripts/fault_report.py``). :func:`check_pure_inertial` finds every run of output epochs
without a DVL update that lasts longer than the limit, warns once per run with its length and the
predicted velocity sigma at its end, and returns the spans for the solution's ``info``.
"""
from __future__ import annotations

import warnings

import numpy as np

#: Longest pure-inertial stretch (s) an estimator accepts without a warning (``EkfOptions`` /
#: ``GraphOptions.max_pure_inertial_s``). Above the paper's 30 s beam-outage windows (LC coasts through
#: them by design) and well below the 120 s total outage of the fault suite.
MAX_PURE_INERTIAL_S = 60.0


def check_pure_inertial(name: str, t: np.ndarray, aided: np.ndarray, cov_v_n: np.ndarray | None,
                        max_s: float = MAX_PURE_INERTIAL_S) -> dict:
    """Warn about every pure-inertial stretch longer than ``max_s``.

    Args:
        name: estimator/method name for the message.
        t: (K,) output epochs, s. aided: (K,) True where a DVL update (measured or completed beams) entered
            at that epoch. cov_v_n: (K,3,3) velocity covariance, m^2/s^2, or None.
        max_s: limit, s.

    A stretch runs from the last aided epoch before it (or the first epoch) to its last un-aided epoch.

    Returns:
        ``{"pure_inertial_max_s": longest stretch, "pure_inertial_spans": [[start_s, end_s, sigma_v_end],
        ...]}`` for the stretches above ``max_s`` (sigma: sqrt of the velocity covariance trace, m/s, NaN
        without covariance).
    """
    t = np.asarray(t, float)
    aided = np.asarray(aided, bool)
    spans, longest = [], 0.0
    k, K = 0, len(t)
    while k < K:
        if aided[k]:
            k += 1
            continue
        end = k
        while end + 1 < K and not aided[end + 1]:
            end += 1
        start_t = t[k - 1] if k > 0 else t[0]
        length = float(t[end] - start_t)
        longest = max(longest, length)
        if length > max_s:
            sigma = float(np.sqrt(np.trace(cov_v_n[end]))) if cov_v_n is not None else float("nan")
            spans.append([float(start_t), float(t[end]), sigma])
            warnings.warn(f"{name}: pure inertial for {length:.0f} s ({start_t:.1f}-{t[end]:.1f} s, no DVL update), "
                          f"longer than max_pure_inertial_s={max_s:g}: the velocity is bounded by the IMU "
                          f"alone; predicted velocity sigma {sigma:.3f} m/s at the end", RuntimeWarning,
                          stacklevel=3)
        k = end + 1
    return {"pure_inertial_max_s": longest, "pure_inertial_spans": spans}
