"""DVL dead reckoning: a track from a DVL log on its own (no IMU), for a first look at a log.

This is *not* graphnav's IMU/DVL estimator: it integrates the instrument's own velocity over ground in NED
(``DvlLog.v_n``, which the instrument made with its own compass and tilt sensors; else ``v_d`` turned with the
stored ``attitude_deg``). Its position error grows with the compass error times the distance run (1 deg of
heading is 1.7 % of the distance sideways) and it has nothing to bridge a lost bottom lock with.

Integration is trapezoidal over the pings, the velocity being linear between two pings that measured it:

* a ping without a velocity (no bottom lock, a 3-beam ping the instrument refused, ...) takes the velocity
  interpolated between its valid neighbours, and is counted;
* a *gap* (consecutive measured pings further apart than :data:`GAP_PERIODS` median ping periods, the
  instrument silent or unlocked) is bridged the same way, with epochs filled in at the median period so that
  the written track has no position jump; each gap is counted and warned about, since what the vehicle did
  inside it is unknown. A gap longer than :data:`~graphnav.io.dvl_files.BRIDGE_MAX_S` (an hour) is not bridged:
  the log is refused, naming the gap and where to cut it (an hour without a velocity over ground is a vehicle
  recovered and put in again, or a clock set on, not a pause within one dive; a bridge across 3 days "travelled"
  366 km).

The vertical position is the log's depth where it has one (a pressure sensor), else the integrated
``v_down``. The attitude written is the instrument's (heading, pitch, roll as yaw, pitch, roll of ``C_b_n``:
the instrument frame taken as the body frame), identity when the log has none.
"""
from __future__ import annotations

import warnings

import numpy as np

from graphnav.core.dvl_log import DvlLog
from graphnav.core.errors import DataError
from graphnav.core.rotations import euler_to_C_b_n
from graphnav.core.solution import NavSolution
from graphnav.io.dvl_files import long_gaps_said

#: A break between two measured pings longer than this many median ping periods is a gap (warned, counted):
#: the same threshold as the IMU's (:data:`graphnav.core.mission.IMU_GAP_PERIODS`), a missed ping or two is
#: not a gap, a silent instrument is.
GAP_PERIODS = 2.5


def attitude_C_d_n(attitude_deg: np.ndarray) -> np.ndarray:
    """(M,3,3) DVL-frame-to-NED rotations from (M,3) heading, pitch, roll in degrees, taken as the yaw,
    pitch, roll of a Z-Y-X (aerospace) rotation; NaN rows give NaN matrices."""
    a = np.deg2rad(np.asarray(attitude_deg, float).reshape(-1, 3))
    return euler_to_C_b_n(a[:, 2], a[:, 1], a[:, 0]).reshape(-1, 3, 3)


def velocity_over_ground_n(log: DvlLog) -> tuple[np.ndarray, str]:
    """(M,3) head velocity over the seabed in NED (m/s, NaN where not measured) and where it came from
    (``"v_n"``: the log's own; ``"v_d+attitude"``: ``v_d`` turned with ``attitude_deg``).

    Raises:
        DataError: the log has neither ``v_n`` nor an attitude to turn ``v_d`` with.
    """
    if log.v_n is not None:
        return np.asarray(log.v_n, float), "v_n"
    if log.attitude_deg is None:
        raise DataError("the log has no velocity over ground in NED (v_n) and no attitude to turn its "
                        f"{log.frame}-frame velocity with: it cannot be dead-reckoned without an IMU or compass",
                        log.source, field="attitude_deg")
    v_d = np.where(np.asarray(log.v_d_valid, bool)[:, None], np.asarray(log.v_d, float), np.nan)
    return np.einsum("kij,kj->ki", attitude_C_d_n(log.attitude_deg), v_d), "v_d+attitude"


def _epochs(t_ok: np.ndarray, t_all: np.ndarray, period: float, gap_periods: float
            ) -> tuple[np.ndarray, list[dict]]:
    """Output stamps: every ping inside the measured span, plus fill-in stamps at ``period`` inside gaps."""
    inside = t_all[(t_all >= t_ok[0]) & (t_all <= t_ok[-1])]
    step = np.diff(t_ok)
    gaps = []
    fill = []
    for i in np.flatnonzero(step > gap_periods * period):
        t0, t1 = float(t_ok[i]), float(t_ok[i + 1])
        gaps.append({"t_start": t0, "t_end": t1, "length_s": t1 - t0})
        n = int(np.ceil((t1 - t0) / period)) - 1
        fill.append(t0 + (t1 - t0) * np.arange(1, n + 1) / (n + 1))
    return np.unique(np.concatenate([inside, *fill])), gaps


def dvl_dead_reckoning(log: DvlLog, *, gap_periods: float = GAP_PERIODS,
                       p0_n: np.ndarray | None = None) -> NavSolution:
    """Dead-reckon the DVL head from a DVL log alone (module docstring).

    Args:
        log: the DVL log (``t`` s, ``v_n`` or ``v_d`` + ``attitude_deg``, optional ``depth_m``).
        gap_periods: measured pings further apart than this many median periods are a gap.
        p0_n: NED position of the first measured ping, m (default: north = east = 0, down = the depth).

    Returns:
        ``NavSolution`` named ``"DVL-DR"`` from the first to the last measured ping: ``t`` as the log's
        (Unix s for a file with a real-time clock), ``p_n`` m, ``v_n`` m/s, ``C_b_n`` the instrument's
        attitude; ``info`` holds the counts (``pings_read``, ``pings_used``, ``pings_interpolated``,
        ``epochs_filled``, ``gaps``), ``velocity`` (its source), ``vertical`` (``"depth"`` or
        ``"integrated"``) and ``distance_m``.

    Raises:
        DataError: fewer than two pings with a velocity over ground, or no way to get one (see
            :func:`velocity_over_ground_n`), or measured pings more than
            :data:`~graphnav.io.dvl_files.BRIDGE_MAX_S` apart (:func:`~graphnav.io.dvl_files.long_gaps_said`).
    """
    t = np.asarray(log.t, float)
    v_n, how = velocity_over_ground_n(log)
    ok = np.all(np.isfinite(v_n), axis=1) & np.isfinite(t)
    if ok.sum() < 2:
        raise DataError(f"{int(ok.sum())} ping(s) with a velocity over ground of {len(t)}: nothing to integrate",
                        log.source, field="v_n")
    t_ok, v_ok = t[ok], v_n[ok]
    period = float(np.median(np.diff(t_ok)))
    if not period > 0:
        raise DataError(f"ping stamps do not increase (median step {period:g} s between the {len(t_ok)} pings with a "
                        "velocity): put the pings in time order, each with a time of its own", log.source, field="t")
    far = long_gaps_said(log, ok)
    if far:
        raise DataError(far, log.source, field="t")
    tt, gaps = _epochs(t_ok, t, period, gap_periods)
    v = np.column_stack([np.interp(tt, t_ok, v_ok[:, j]) for j in range(3)])
    dt = np.diff(tt)[:, None]
    p = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (v[1:] + v[:-1]) * dt, axis=0)])
    vertical = "integrated"
    if log.depth_m is not None:
        d = np.asarray(log.depth_m, float)
        good = np.isfinite(d)
        if good.sum() >= 2:
            p[:, 2] = np.interp(tt, t[good], d[good])
            vertical = "depth"
    if p0_n is not None:
        p = p + np.asarray(p0_n, float).reshape(3) - p[0]
    C_b_n = _attitude(log, t, tt)
    n_interp = int(np.sum(~ok & (t >= t_ok[0]) & (t <= t_ok[-1])))
    n_filled = int(len(tt) - np.sum((t >= t_ok[0]) & (t <= t_ok[-1])))
    if gaps:
        longest = max(gaps, key=lambda g: g["length_s"])
        warnings.warn(f"{log.source}: {len(gaps)} gap(s) without a velocity over ground longer than "
                      f"{gap_periods * period:.3g} s bridged by linear interpolation of the velocity (longest "
                      f"{longest['length_s']:.1f} s from t = {longest['t_start']:.3f} s); the track inside is a "
                      "guess", RuntimeWarning, stacklevel=2)
    info = {"velocity": how, "vertical": vertical, "pings_read": int(len(t)), "pings_used": int(ok.sum()),
            "pings_interpolated": n_interp, "epochs_filled": n_filled, "ping_period_s": period,
            "gaps": gaps, "distance_m": float(np.sum(np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1))),
            "attitude": "instrument" if log.attitude_deg is not None else "none (identity written)"}
    return NavSolution("DVL-DR", tt, p, v, C_b_n, info=info)


def _attitude(log: DvlLog, t: np.ndarray, tt: np.ndarray) -> np.ndarray:
    """The instrument's attitude at the output stamps (nearest stored attitude; identity without one)."""
    if log.attitude_deg is None:
        return np.repeat(np.eye(3)[None], len(tt), axis=0)
    att = np.asarray(log.attitude_deg, float)
    good = np.all(np.isfinite(att), axis=1)
    if not good.any():
        return np.repeat(np.eye(3)[None], len(tt), axis=0)
    # nearest sample: angles are not interpolated across the 0/360 deg heading wrap
    i = np.rint(np.interp(tt, t[good], np.arange(good.sum()))).astype(int)
    return attitude_C_d_n(att[good][i])
