"""Two completers' regressed beams combined by their own sigmas.

For a missing beam with completions ``b1``, ``b2``, sigmas ``s1``, ``s2`` and error correlation ``rho``, the best
linear unbiased combination is ``b = w1 b1 + (1 - w1) b2`` with::

    w1 = (s2^2 - rho s1 s2) / (s1^2 + s2^2 - 2 rho s1 s2)
    sigma^2 = w1^2 s1^2 + w2^2 s2^2 + 2 w1 w2 rho s1 s2          (w2 = 1 - w1)

With ``rho = 0`` that is the inverse-variance weighting. Both completions are made from the same past beams, so
their errors are correlated (``docs/decisions/completers.md`` measures it); ``rho`` is then a fitted number and
must come from data the scored trajectories are not in.

Through a run of regressed pings each member's errors compound at their own rate: with ``growth = (d1, d2)``
(m/s per ping) member ``i``'s sigma at the ``k``-th regressed ping of the run is ``sqrt(s_i^2 + k d_i^2)`` before
the weights are made, so the fusion leans on the member whose errors grow more slowly as the outage lengthens.
Such a completer takes ``run_steps`` from :class:`graphnav.estimators.history.BeamHistory` and has
``drift_std = 0``: the growth is already in the sigma it hands on. The history still keeps that sigma from falling
within a run (``max(sigma, previous)``), so a fused sigma that drops when the weights move to the other member is
handed on at its earlier value.
"""
from __future__ import annotations

import numpy as np

from graphnav.estimators.history import complete_with

from .completer import summed_fallbacks
from .dvl_match import bind_members


def check_correlation(name: str, value: float) -> None:
    """A :class:`ValueError` naming ``name`` unless ``value`` is an error correlation in (-1, 1)."""
    if not -1.0 < value < 1.0:
        raise ValueError(f"{name} must be in (-1, 1), got {value}")


def fuse(b1: np.ndarray, s1: np.ndarray, b2: np.ndarray, s2: np.ndarray, rho: float = 0.0,
         sigma_rho: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Combination of two completions (arrays of any equal shape, m/s) with error correlation ``rho`` where both
    sigmas are > 0; elsewhere (measured beams, sigma 0) the first completion with sigma 0.

    The weight of each completion is kept in [0, 1]: with ``rho`` above ``min(s1, s2) / max(s1, s2)`` the
    unconstrained weight would extrapolate past the sharper completion, which leans on ``rho`` being exact; the
    clipped weight takes the sharper one alone. The returned sigma is the standard deviation of the combination
    actually made, with the errors correlated by ``sigma_rho`` (default ``rho``): weights made with ``rho = 0``
    (inverse variance) and the sigma with the measured correlation keep a sigma that does not claim the
    independence the weights assumed."""
    sigma_rho = rho if sigma_rho is None else sigma_rho
    check_correlation("rho", rho)
    check_correlation("sigma_rho", sigma_rho)
    b1, s1, b2, s2 = (np.asarray(x, float) for x in (b1, s1, b2, s2))
    regressed = (s1 > 0) & (s2 > 0)
    # 1 where a sigma is 0 only to keep the arithmetic finite (those entries are replaced)
    v1 = np.where(regressed, s1, 1.0) ** 2
    v2 = np.where(regressed, s2, 1.0) ** 2
    c = rho * np.sqrt(v1 * v2)
    w1 = np.clip((v2 - c) / (v1 + v2 - 2.0 * c), 0.0, 1.0)
    w2 = 1.0 - w1
    beams = np.where(regressed, w1 * b1 + w2 * b2, b1)
    var = w1 ** 2 * v1 + w2 ** 2 * v2 + 2.0 * w1 * w2 * sigma_rho * np.sqrt(v1 * v2)
    sigma = np.where(regressed, np.sqrt(var), 0.0)
    return beams, sigma


class FusedCompleter:
    """A completer (``complete(past, measured[, imu][, run_steps])``, ``n_past``) that asks ``first`` and ``second``
    and combines their regressed beams with :func:`fuse`.

    Args:
        first, second: completers; ``needs_imu`` (and ``imu_samples``, ``imu_rate_hz``, ``ping_dt``, ``beam_only``
            and the ``usage`` counters) follow the first IMU-aware member, whose window every member that needs
            the IMU is handed (the pivot completer reads its tail). In an estimator that member must complete a
            ping without one (``imu=None``, e.g. :class:`graphnav.nets.ImuAutoCompleter`).
        rho: correlation of the two members' errors per ping that the weights assume (0: independent, inverse
            variance).
        sigma_rho: the correlation the fused sigma is computed with (default ``rho``; :func:`fuse`).
        growth: (d1, d2), each member's sigma growth per regressed ping of a run, m/s (module docstring); None:
            no growth of its own, and the history grows the fused sigma by its default.
    """

    def __init__(self, first, second, rho: float = 0.0, growth: tuple[float, float] | None = None,
                 sigma_rho: float | None = None):
        check_correlation("rho", rho)
        if sigma_rho is not None:
            check_correlation("sigma_rho", sigma_rho)
        if growth is not None and (len(growth) != 2 or not all(np.isfinite(g) and g >= 0 for g in growth)):
            raise ValueError(f"growth must be two finite values >= 0 (m/s per ping), got {growth}")
        self.first, self.second = first, second
        self.rho = float(rho)
        self.sigma_rho = self.rho if sigma_rho is None else float(sigma_rho)
        self.growth = None if growth is None else (float(growth[0]), float(growth[1]))
        # its own growth, or a member that fades through the run (a beam-only network's run_decay)
        self.takes_run_steps = self.growth is not None or any(getattr(c, "takes_run_steps", False)
                                                              for c in (first, second))
        self.takes_past_dt = any(getattr(c, "takes_past_dt", False) for c in (first, second))
        if self.growth is not None:
            self.drift_std = 0.0
        self.n_past = max(first.n_past, second.n_past)
        imu_member = next((c for c in (first, second) if getattr(c, "needs_imu", False)), None)
        self.needs_imu = imu_member is not None
        self._imu_member = imu_member
        if imu_member is not None:
            self.imu_samples, self.ping_dt = imu_member.imu_samples, imu_member.ping_dt
            self.imu_rate_hz = getattr(imu_member, "imu_rate_hz", None)
            self.beam_only = getattr(imu_member, "beam_only", None)

    def bind_dvl(self, T_b: np.ndarray) -> list[str]:
        """Bind both members to a mission's DVL (``T_b``: (4, 3) beam unit vectors, body frame;
        :mod:`graphnav.nets.dvl_match`)."""
        return bind_members(T_b, (self.first, self.second))

    @property
    def usage(self) -> dict:
        """The IMU-aware member's routes (:class:`graphnav.nets.ImuAutoCompleter`), empty without one."""
        return dict(getattr(self._imu_member, "usage", {}))

    @property
    def fallbacks(self) -> dict:
        """Both members' fallback counters summed by kind (:data:`graphnav.nets.completer.FALLBACK_KINDS`), empty when
        neither counts."""
        return summed_fallbacks((self.first, self.second))

    def members(self, past: np.ndarray, measured: np.ndarray, imu=None, run_steps=None, past_dt_s=None):
        """``(b1, s1, b2, s2)``: both members' completions (4,) and sigmas (4,), the sigmas grown by ``growth``
        over ``run_steps`` (arguments of :meth:`complete`)."""
        past = np.asarray(past, float)
        outs = [complete_with(c, past, measured, imu=imu, run_steps=run_steps, past_dt_s=past_dt_s)
                for c in (self.first, self.second)]
        (b1, s1), (b2, s2) = outs
        if self.growth is not None and run_steps is not None:
            k = np.asarray(run_steps, float)
            s1 = np.where(s1 > 0, np.sqrt(s1 ** 2 + k * self.growth[0] ** 2), 0.0)
            s2 = np.where(s2 > 0, np.sqrt(s2 ** 2 + k * self.growth[1] ** 2), 0.0)
        return b1, s1, b2, s2

    def complete(self, past: np.ndarray, measured: np.ndarray, imu=None, run_steps=None, past_dt_s=None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(beams (4,), sigma (4,)) from the past full beam vectors ``past`` (N >= ``n_past``, 4), oldest first,
        and the ``measured`` beams (4,) with NaN where missing, m/s. ``run_steps`` (4,): regressed pings of each
        beam earlier in the run (0 or None: a first regressed ping); ``past_dt_s`` (N,) s: the past pings'
        intervals, for members trained for one ping period (None: unknown)."""
        return fuse(*self.members(past, measured, imu, run_steps, past_dt_s), self.rho, self.sigma_rho)
