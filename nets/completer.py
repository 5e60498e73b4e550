"""The beam-completer interface and input checks shared by every completer.

A completer fills the missing beams of one ping:
``complete(past, measured) -> (beams, sigma)`` where ``past`` is (n_past, 4) m/s (oldest first),
``measured`` (4,) m/s with NaN for missing beams, ``beams`` (4,) with measured beams passed through and
``sigma`` (4,) m/s, 0 for measured beams: the 1-sigma error of each filled beam, used by the estimators
as the inflated measurement noise (EKF) or the weak factor's noise (graph).

A completer that also needs the IMU sets ``needs_imu = True`` and takes it as a keyword,
``complete(past, measured, imu=(f_b, omega_b))`` with ``f_b``/``omega_b`` the last ``imu_samples`` IMU samples
up to the ping (``graphnav.nets.imu_network``); :meth:`graphnav.estimators.history.BeamHistory.complete` forwards it.

A completer with a network trained for one DVL has ``bind_dvl(T_b) -> list[str]``: the estimators' keyframer hands it
the mission's beam directions (body frame) before any ping, and a network trained for other beams then leaves its
pings to the average estimator (:mod:`graphnav.nets.dvl_match`). A completer that wraps one hands it on.

A completer whose network was trained for one DVL ping period sets ``takes_past_dt = True``: it is also handed
``past_dt_s`` (n_past,) s, the interval from each past ping to the next one (the newest past ping's to this ping),
oldest first, when the stamps are known (:class:`graphnav.estimators.history.BeamHistory` keeps them), and leaves a
ping whose past is not spaced as in training to the average estimator (:mod:`graphnav.nets.dvl_match`).
"""
from __future__ import annotations

from typing import Protocol

import numpy as np

from graphnav.core.errors import ConfigError, DataError


#: Why a network completer left a ping to the average estimator (its ``fallbacks`` counters): inputs outside its
#: training envelope, a missing-beam pattern it was not trained for, a DVL whose beams are not those it was trained
#: for, past pings not spaced as in training (closer together than the trained DVL period, or a long gap).
FALLBACK_KINDS = ("envelope", "pattern", "dvl", "period")


def new_fallbacks() -> dict[str, int]:
    """A network completer's ``fallbacks`` counters, all 0 (:data:`FALLBACK_KINDS`)."""
    return dict.fromkeys(FALLBACK_KINDS, 0)


class BeamCompleter(Protocol):
    n_past: int

    def complete(self, past: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ...


def check_drift_std(owner: str, drift_std) -> float | None:
    """A completer's ``drift_std`` (m/s per ping, the growth :class:`graphnav.estimators.history.BeamHistory` gives
    its sigma through a run of regressed pings) as a float, or None (the history's own); :class:`ConfigError`
    naming ``owner`` unless it is a finite number >= 0."""
    if drift_std is None:
        return None
    if isinstance(drift_std, bool) or not isinstance(drift_std, (int, float)) or not 0.0 <= drift_std < float("inf"):
        raise ConfigError(f"{owner}: drift_std = {drift_std!r} is not a growth >= 0 m/s per ping (or None)")
    return float(drift_std)


def check_inputs(past: np.ndarray, measured: np.ndarray, n_past: int) -> tuple[np.ndarray, np.ndarray]:
    """Validate and convert completer inputs; raise :class:`DataError` naming the bad field."""
    past = np.asarray(past, dtype=float)
    measured = np.asarray(measured, dtype=float)
    if past.shape != (n_past, 4):
        raise DataError(f"shape {past.shape}, expected ({n_past}, 4)", "completer", field="past")
    bad = np.argwhere(~np.isfinite(past))
    if bad.size:
        raise DataError("past beam is not finite", "completer", int(bad[0][0]), "past")
    if measured.shape != (4,):
        raise DataError(f"shape {measured.shape}, expected (4,)", "completer", field="measured")
    return past, measured


def summed_fallbacks(completers) -> dict[str, int]:
    """The ``fallbacks`` counters of ``completers`` (pings a network left to the average estimator, by kind:
    :data:`FALLBACK_KINDS`) summed by kind; a completer without counters adds nothing. How a
    completer that wraps others (IMU-aware auto, fused) reports its members'. A completer listed twice (one object
    serving two routes) is counted once."""
    counts: dict[str, int] = {}
    for c in {id(c): c for c in completers}.values():
        for kind, n in getattr(c, "fallbacks", {}).items():
            counts[kind] = counts.get(kind, 0) + n
    return counts


def fade_to_average(beams: np.ndarray, sigma: np.ndarray, measured: np.ndarray, run_steps, run_decay: float,
                    average) -> tuple[np.ndarray, np.ndarray]:
    """A network's completion ``(beams, sigma)`` faded to the average estimator's through a run of regressed pings:
    ``w b_net + (1 - w) b_avg`` and ``w s_net + (1 - w) s_avg`` per missing beam with ``w = run_decay^k`` at its
    k-th regressed ping of the run (``run_steps``, k = 0 after a measured past); measured beams pass through. The
    sigma is the blend's if the two errors were fully correlated, a bound. ``average()`` returns the average's
    ``(beams, sigma)``; it is called only when there is something to fade (``run_decay`` < 1 and ``run_steps``
    given: None is a first regressed ping)."""
    if run_decay >= 1.0 or run_steps is None:
        return beams, sigma
    b_avg, s_avg = average()
    w = np.where(np.isfinite(measured), 1.0, run_decay ** np.asarray(run_steps, float))
    return w * beams + (1.0 - w) * b_avg, w * sigma + (1.0 - w) * s_avg


def check_run_decay(value, source: str) -> float:
    """``value`` as a fading factor ``run_decay`` in (0, 1] (:class:`graphnav.nets.network.NetworkCompleter`);
    otherwise a :class:`ConfigError` naming ``source`` (a model card, a recipe, the argument)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < value <= 1.0:
        raise ConfigError(f"{source}: run_decay {value!r} is not a number in (0, 1]")
    return float(value)
