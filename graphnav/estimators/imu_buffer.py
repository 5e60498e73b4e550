"""The IMU window an IMU-aware beam completer sees, kept sample by sample as the estimator is fed.

An IMU-aware completer (``needs_imu``, :mod:`graphnav.nets.imu_network`) wants the last ``n_samples`` IMU
samples up to the ping (the last one at or before the ping stamp, oldest first) at its training rate
``rate_hz``. :class:`ImuWindowBuffer` keeps them as they stream in, so the window equals
``graphnav.nets.imu_window.imu_window_at(mission.imu, t_ping, n_samples)`` on the recorded stream.
It says why there is no usable window instead of handing one on that the completer would misread:

- ``"not_full"``: fewer than ``n_samples`` samples at or before the ping (the first ``n_samples / rate_hz``
  seconds of a mission, or after a restart);
- ``"rate"``: the median step differs from ``1 / rate_hz`` by more than ``rate_tol`` (relative): an IMU at
  another rate would stretch every preintegrated interval;
- ``"gap"``: the window holds samples the keyframer made up to bridge an IMU gap, or a step longer than 1.5
  periods (a dropped sample);
- ``"late"``: the ping is older than the samples still kept (``extra_s``);
- ``"ping_dt"`` (given by the keyframer, not the buffer): the past pings the completer propagates are not one
  DVL period (its ``ping_dt``) apart -- a missed ping or a DVL at another rate.
"""
from __future__ import annotations

import bisect
from collections import deque
from itertools import islice

import numpy as np

from graphnav.core.errors import ConfigError

#: Reasons :meth:`ImuWindowBuffer.window` gives for a ping without a usable IMU window.
NO_WINDOW_REASONS = ("not_full", "rate", "gap", "late", "ping_dt")


class ImuWindowBuffer:
    """Ring buffer of the newest IMU samples (t s, f_b m/s^2, omega_b rad/s, body frame).

    Args:
        n_samples: window length (the completer's ``imu_samples``).
        rate_hz: the rate the completer assumes (its ``imu_rate_hz``).
        rate_tol: relative tolerance on the window's mean sample step.
        extra_s: how long after a ping its samples are still kept (a ping is completed when the IMU has
            passed its stamp, usually by one sample; 10 s covers pings closed late).
    """

    def __init__(self, n_samples: int, rate_hz: float, rate_tol: float = 0.02, extra_s: float = 10.0):
        if n_samples < 2 or not rate_hz > 0:
            raise ConfigError(f"IMU window needs n_samples >= 2 and rate_hz > 0, got {n_samples}, {rate_hz}")
        self.n_samples = int(n_samples)
        self.period = 1.0 / float(rate_hz)
        self.rate_tol = float(rate_tol)
        size = self.n_samples + int(np.ceil(extra_s * rate_hz))
        self._t: deque[float] = deque(maxlen=size)
        self._f: deque = deque(maxlen=size)
        self._w: deque = deque(maxlen=size)
        self._bridged: deque[bool] = deque(maxlen=size)

    def push(self, t: float, f_b, omega_b, bridged: bool = False) -> None:
        """Append one sample in time order; ``bridged``: made up by interpolation over an IMU gap."""
        self._t.append(float(t))
        self._f.append(f_b)
        self._w.append(omega_b)
        self._bridged.append(bool(bridged))

    def check_length(self, n: int | None, what: str) -> None:
        """Refuse a window of ``n`` samples (None: the buffer's own) that this buffer cannot serve: fewer than 2 or
        more than its ``n_samples``; ``what`` names it in the error."""
        if n is not None and not 2 <= n <= self.n_samples:
            raise ConfigError(f"{what} = {n}: the windows of this IMU buffer are 2 to {self.n_samples} samples")

    def window(self, t: float, n_samples: int | None = None
               ) -> tuple[tuple[np.ndarray, np.ndarray] | None, str | None]:
        """``((f_b, omega_b), None)``, each (n, 3), for a ping at ``t`` (s), or ``(None, reason)`` with a reason
        of :data:`NO_WINDOW_REASONS`; ``n`` is ``n_samples`` (no more than the buffer's), by default the buffer's
        window length (a member of the completer may read a shorter window of its own)."""
        n = self.n_samples if n_samples is None else int(n_samples)
        self.check_length(n, "IMU window")
        end = bisect.bisect_right(self._t, t)
        if end < n:
            # a full ring has dropped samples: the ping's window is gone, not still to come
            return None, "late" if len(self._t) == self._t.maxlen else "not_full"
        start = end - n
        steps = np.diff(np.fromiter(islice(self._t, start, end), float, n))
        if abs(np.median(steps) - self.period) > self.rate_tol * self.period:
            return None, "rate"
        if any(islice(self._bridged, start, end)) or steps.max() > 1.5 * self.period:
            return None, "gap"
        f_b = np.array(list(islice(self._f, start, end)), dtype=float)
        omega_b = np.array(list(islice(self._w, start, end)), dtype=float)
        return (f_b, omega_b), None
