"""Two completers' regressed beams combined by their own sigmas (inverse-variance weights).

For a missing beam with completions ``b1``, ``b2`` and sigmas ``s1``, ``s2``::

    b = (b1 / s1^2 + b2 / s2^2) / (1 / s1^2 + 1 / s2^2),    sigma = (1 / s1^2 + 1 / s2^2) ** -0.5

the best linear combination when the two errors are independent and the sigmas are right. It has no fitted
parameter, so it needs no fold of its own: it leans on the completer that says it is surer, ping by ping. The two
completions are made from the same past beams, so their errors are correlated in practice and the combined sigma
is a lower bound (``docs/decisions/completers.md`` reports its coverage).
"""
from __future__ import annotations

import numpy as np


def fuse(b1: np.ndarray, s1: np.ndarray, b2: np.ndarray, s2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse-variance combination of two completions (arrays of any equal shape, m/s) where both sigmas are
    > 0; elsewhere (measured beams, sigma 0) the first completion with sigma 0."""
    b1, s1, b2, s2 = (np.asarray(x, float) for x in (b1, s1, b2, s2))
    regressed = (s1 > 0) & (s2 > 0)
    # weights where both are regressed; 1 elsewhere only to keep the arithmetic finite (those entries are replaced)
    w1 = np.where(regressed, s1, 1.0) ** -2
    w2 = np.where(regressed, s2, 1.0) ** -2
    beams = np.where(regressed, (w1 * b1 + w2 * b2) / (w1 + w2), b1)
    sigma = np.where(regressed, (w1 + w2) ** -0.5, 0.0)
    return beams, sigma


class FusedCompleter:
    """A completer (``complete(past, measured[, imu])``, ``n_past``) that asks ``first`` and ``second`` and
    combines their regressed beams with :func:`fuse`. ``needs_imu`` (and ``imu_samples``, ``ping_dt``) follow an
    IMU-aware member, which alone is handed the IMU window."""

    def __init__(self, first, second):
        self.first, self.second = first, second
        self.n_past = max(first.n_past, second.n_past)
        imu_member = next((c for c in (first, second) if getattr(c, "needs_imu", False)), None)
        self.needs_imu = imu_member is not None
        if imu_member is not None:
            self.imu_samples, self.ping_dt = imu_member.imu_samples, imu_member.ping_dt

    def complete(self, past: np.ndarray, measured: np.ndarray, imu=None) -> tuple[np.ndarray, np.ndarray]:
        """(beams (4,), sigma (4,)) from the past full beam vectors ``past`` (N >= ``n_past``, 4), oldest first,
        and the ``measured`` beams (4,) with NaN where missing, m/s."""
        past = np.asarray(past, float)
        outs = []
        for c in (self.first, self.second):
            own = past[-c.n_past:]
            outs.append(c.complete(own, measured, imu=imu) if getattr(c, "needs_imu", False)
                        else c.complete(own, measured))
        (b1, s1), (b2, s2) = outs
        return fuse(b1, s1, b2, s2)
