"""Fitting a completer's outage sigma growth and two completers' error correlation from held-out errors.

The numbers here are fitted, so the errors they are fitted on must come from trajectories other than the ones
they are then scored on (``experiments/imu_completer_folds.py --calibrate`` takes them from the other folds).

Arrays of one recursive-outage rollout are ``(windows, pings, beams)``: each window a run of regressed pings
(:func:`graphnav.nets.evaluate.outage_rollout`), ``raw`` the sigma the completer itself returned at each ping
(before any growth) and ``err`` the completion minus the beam the DVL would have reported, m/s.
"""
from __future__ import annotations

import numpy as np

#: Fraction of a Gaussian within 1 sigma: the coverage target of :func:`fit_drift` ``target="coverage"``.
GAUSSIAN_1SIGMA = 0.6827


def history_sigma(raw: np.ndarray, drift_std: float) -> np.ndarray:
    """The sigma :class:`graphnav.estimators.history.BeamHistory` hands on through each window for a completer
    with this ``drift_std`` (m/s per ping): ``sigma_0 = raw_0``, ``sigma_k = sqrt(max(raw_k, sigma_{k-1})^2 +
    drift_std^2)``."""
    raw = np.asarray(raw, float)
    out = np.empty_like(raw)
    out[:, 0] = raw[:, 0]
    for k in range(1, raw.shape[1]):
        out[:, k] = np.sqrt(np.maximum(raw[:, k], out[:, k - 1]) ** 2 + drift_std ** 2)
    return out


def member_sigma(raw: np.ndarray, drift_std: float) -> np.ndarray:
    """A fused member's grown sigma (:class:`graphnav.nets.fused.FusedCompleter`): ``sqrt(raw_k^2 + k
    drift_std^2)`` at the ``k``-th regressed ping of the window (k from 0)."""
    raw = np.asarray(raw, float)
    k = np.arange(raw.shape[1], dtype=float).reshape((1, -1) + (1,) * (raw.ndim - 2))
    return np.sqrt(raw ** 2 + k * drift_std ** 2)


def fit_drift(err: np.ndarray, raw: np.ndarray, grow=history_sigma, target: str = "coverage",
              upper: float = 1.0) -> float:
    """The growth ``drift_std`` (m/s per ping, in [0, ``upper``]) that calibrates ``grow(raw, drift_std)`` on the
    errors ``err``: ``target="coverage"`` puts :data:`GAUSSIAN_1SIGMA` of the errors within 1 sigma (what a
    reported 68 % band needs), ``"variance"`` makes the RMS of error / sigma 1 (what least-squares weights
    need); the two differ when the tails are heavier than Gaussian. 0 when the errors are already inside
    without growth; ``upper`` when even that is not enough."""
    err = np.abs(np.asarray(err, float))
    if target == "coverage":
        def short(d):  # True while the sigma is too small
            return np.mean(err <= grow(raw, d)) < GAUSSIAN_1SIGMA
    elif target == "variance":
        def short(d):
            return np.mean((err / grow(raw, d)) ** 2) > 1.0
    else:
        raise ValueError(f"target must be 'coverage' or 'variance', got {target!r}")
    if not short(0.0):
        return 0.0
    if short(upper):
        return float(upper)
    lo, hi = 0.0, float(upper)
    for _ in range(40):  # bisection to 1e-12 of upper: the coverage is a step function of drift_std
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if short(mid) else (lo, mid)
    return hi


def error_correlation(err1: np.ndarray, sigma1: np.ndarray, err2: np.ndarray, sigma2: np.ndarray) -> float:
    """Correlation of two completers' errors on the same beams, each normalised by its own sigma:
    ``sum(z1 z2) / sqrt(sum(z1^2) sum(z2^2))`` (no mean removed: a shared bias is part of the error)."""
    z1 = np.asarray(err1, float) / np.asarray(sigma1, float)
    z2 = np.asarray(err2, float) / np.asarray(sigma2, float)
    return float(np.sum(z1 * z2) / np.sqrt(np.sum(z1 ** 2) * np.sum(z2 ** 2)))


def integrated_autocorrelation(sequences, max_lag: int = 60) -> float:
    """Integrated autocorrelation time (pings) of normalised completion errors ``z`` (error / sigma), one
    sequence per beam and outage run: ``tau = 1 + 2 sum_k r_k`` with ``r_k = sum_t z_t z_t+k / sum_t z_t^2`` pooled
    over the sequences (no mean removed: an error that stays off for a whole window is what it measures), summed
    from lag 1 while ``r_k > 0`` and ``k <= max_lag`` (the initial positive sequence). n pings of such errors carry
    about n / tau independent pings' worth of information; white errors give 1."""
    seqs = [np.asarray(z, float) for z in sequences]
    den = sum(float(np.sum(z * z)) for z in seqs)
    if not den > 0:
        raise ValueError("no non-zero errors to fit the autocorrelation on")
    tau = 1.0
    for k in range(1, max_lag + 1):
        r = sum(float(np.sum(z[:-k] * z[k:])) for z in seqs if len(z) > k) / den
        if r <= 0:
            break
        tau += 2.0 * r
    return tau
