"""The average estimator of the paper: a missing beam is the mean of its N past values."""
from __future__ import annotations

import numpy as np

from .completer import check_drift_std, check_inputs

#: Past pings the average estimator uses per beam-outage scenario (the paper's N: 3 for 2 missing beams, 5 for
#: 3; 5 for the others), as the estimators and the network evaluation use it.
AVERAGE_N_PAST: dict[str, int] = {"2-missing": 3, "3-missing": 5, "none": 5, "0-beams": 5, "markov": 5}


class AverageCompleter:
    """Fill missing beams with the mean of the past ``n_past`` values of the same beam.

    Sigma of a regressed beam (m/s): ``sqrt(noise_std^2 (1 + 1/N) + var_past)``, the beam noise of the mean
    and of the new ping plus the spread of the past values (a proxy for how fast the beam is changing).
    Pass ``sigma`` to use fixed per-beam values instead (e.g. calibrated on validation data). ``drift_std``
    (m/s per ping) is the growth :class:`graphnav.estimators.history.BeamHistory` gives the sigma through a run
    of pings with regressed beams; None leaves the history's default (docs/decisions/completers.md).
    """

    #: sigma growth per ping with regressed beams, m/s (None: BeamHistory's default)
    drift_std: float | None = None

    def __init__(self, n_past: int = 3, noise_std: float = 0.042, sigma: np.ndarray | float | None = None,
                 drift_std: float | None = None):
        if n_past < 1:
            raise ValueError(f"n_past must be >= 1, got {n_past}")
        if drift_std is not None:
            self.drift_std = check_drift_std("AverageCompleter", drift_std)
        self.n_past = n_past
        self.noise_std = noise_std
        self.sigma = None if sigma is None else np.broadcast_to(np.asarray(sigma, float), (4,)).copy()

    def complete(self, past: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        past, measured = check_inputs(past, measured, self.n_past)
        missing = ~np.isfinite(measured)
        beams = np.where(missing, past.mean(axis=0), measured)
        if self.sigma is not None:
            spread = self.sigma
        else:
            spread = np.sqrt(self.noise_std ** 2 * (1.0 + 1.0 / self.n_past) + past.var(axis=0))
        return beams, np.where(missing, spread, 0.0)

    def rehearse(self, past: np.ndarray, imu=None) -> np.ndarray:
        """The four beams (m/s) :meth:`complete` would give a ping whose beams are all missing
        (:mod:`graphnav.estimators.rehearsal`); ``imu`` is not read."""
        return np.asarray(past, float).mean(axis=0)
