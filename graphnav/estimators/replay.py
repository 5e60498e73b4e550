"""Replay a recorded :class:`~graphnav.core.mission.Mission` as the time-ordered sample stream a vehicle produces.

One stream for every consumer (the :class:`~graphnav.estimators.navigator.Navigator` replay loops of ``run_graph`` and
``run_ekf``, the JSON-lines writer of ``graphnav simulate --stream``, offline keyframe tools): records
``(kind, t, payload)`` sorted by stamp, with ``kind`` and ``payload``:

- ``"imu"``: ``(f_b (3,) m/s^2, omega_b (3,) rad/s)``;
- ``"dvl"``: ``(beams (4,) m/s, NaN where not valid, valid (4,) bool)``;
- ``"dvl_velocity"``: ``(v_d (3,) m/s, sigma (3,) m/s or NaN = the configured one)``: the DVL-frame velocity
  the instrument measured (``DvlData.v_d``), for the pings where ``v_d_valid`` and the beams are not usable
  (fewer than :data:`~graphnav.estimators.keyframes.MIN_BEAMS_OVER_VELOCITY` valid; the keyframer then uses
  the velocity, not those beams; a velocity ping without any valid beam has no ``"dvl"`` record);
- ``"depth"``: ``(depth_m,)``;
- ``"heading"``: ``(yaw rad, sigma rad)`` (an AHRS or heading topic, :class:`~graphnav.core.mission.HeadingData`);
- ``"fix"``: ``(lat rad, lon rad, sigma_m m)``: a horizontal position fix (GNSS at the surface, USBL,
  :class:`~graphnav.core.mission.PositionFixData`), for :meth:`~graphnav.estimators.navigator.Navigator.add_position_fix`.

At equal stamps the aiding samples come first, then the DVL, then the IMU: a keyframe at a stamp then
already holds the depth and the ping of that stamp when the IMU sample that closes it arrives.
"""
from __future__ import annotations

import math
from typing import Iterator

import numpy as np

from graphnav.core.mission import Mission
from graphnav.estimators.keyframes import MIN_BEAMS_OVER_VELOCITY

#: Order of streams at equal stamps.
STREAM_ORDER = {"depth": 0, "heading": 0, "fix": 0, "dvl": 1, "dvl_velocity": 1, "imu": 2}


def first_ping_time(mission: Mission) -> float:
    """Stamp of the first DVL ping inside the IMU span (the IMU start when there is none), s."""
    t = mission.dvl.t
    inside = t[(t >= mission.imu.t[0]) & (t <= mission.imu.t[-1])]
    return float(inside[0]) if len(inside) else float(mission.imu.t[0])


def velocity_pings(dvl) -> np.ndarray:
    """(M,) bool: the pings of ``dvl`` (:class:`~graphnav.core.mission.DvlData`) whose DVL-frame velocity
    ``v_d`` is used: ``v_d_valid`` and fewer than ``MIN_BEAMS_OVER_VELOCITY`` valid beams."""
    if dvl.v_d is None or dvl.v_d_valid is None:
        return np.zeros(len(dvl.t), bool)
    return dvl.v_d_valid & (dvl.n_valid < MIN_BEAMS_OVER_VELOCITY)


def replay(mission: Mission, depth: bool = True, chunk: int = 20000, heading: bool = True, fixes: bool = True
           ) -> Iterator[tuple[str, float, tuple]]:
    """The mission's samples in time order (see the module docstring). Ground truth is never part of it;
    ``depth``, ``heading`` and ``fixes`` = False leave that stream out.

    Converted to Python values ``chunk`` samples at a time, so that replaying a day-long mission needs no
    more memory than its arrays."""
    imu, dvl = mission.imu, mission.dvl
    beams = np.where(dvl.valid, dvl.beams, np.nan)
    velocity = velocity_pings(dvl)
    # a velocity ping without any valid beam has no "dvl" record: its velocity is all there is
    has_beams = ~(velocity & ~dvl.valid.any(axis=1))
    if has_beams.all():
        streams = [("imu", imu.t, (imu.f_b, imu.omega_b)), ("dvl", dvl.t, (beams, dvl.valid))]
    else:
        streams = [("imu", imu.t, (imu.f_b, imu.omega_b)),
                   ("dvl", dvl.t[has_beams], (beams[has_beams], dvl.valid[has_beams]))]
    if velocity.any():
        sigma = (dvl.v_d_sigma[velocity] if dvl.v_d_sigma is not None
                 else np.full((int(velocity.sum()), 3), np.nan))
        streams.append(("dvl_velocity", dvl.t[velocity], (dvl.v_d[velocity], sigma)))
    if depth and mission.depth is not None:
        streams.append(("depth", mission.depth.t, (mission.depth.depth,)))
    if heading and mission.heading is not None:
        streams.append(("heading", mission.heading.t, (mission.heading.yaw, mission.heading.sigma)))
    if fixes and mission.fixes is not None:
        f = mission.fixes
        streams.append(("fix", f.t, (f.lat, f.lon, f.sigma_m)))
    t = np.concatenate([s[1] for s in streams])
    order = np.concatenate([np.full(len(s[1]), STREAM_ORDER[s[0]], dtype=np.int8) for s in streams])
    which = np.concatenate([np.full(len(s[1]), i, dtype=np.int8) for i, s in enumerate(streams)])
    index = np.concatenate([np.arange(len(s[1])) for s in streams])
    sort = np.lexsort((order, t))
    del order
    names = [s[0] for s in streams]
    for start in range(0, len(sort), chunk):
        part = sort[start:start + chunk]
        w_part, j_part = which[part], index[part]
        columns = []
        for i, (_, _, arrays) in enumerate(streams):
            rows = j_part[w_part == i]
            columns.append(iter(list(zip(*(a[rows].tolist() for a in arrays)))))
        for w, stamp in zip(w_part.tolist(), t[part].tolist()):
            yield names[w], stamp, next(columns[w])


def _finite_or_none(x: float):
    return None if x is None or not math.isfinite(x) else x


def mission_records(mission, config: bool = True) -> Iterator[dict]:
    """A recorded mission as the records of the JSON-lines stream (:mod:`graphnav.io.streamio`: a config line
    first, then its samples; never its ground truth)."""
    if config:
        yield {"type": "config", "config": mission.config.to_dict()}
    for kind, t, payload in replay(mission):
        if kind == "imu":
            yield {"type": "imu", "t": t, "f_b": list(payload[0]), "omega_b": list(payload[1])}
        elif kind == "dvl":
            yield {"type": "dvl", "t": t, "beams": [_finite_or_none(b) for b in payload[0]],
                   "valid": list(payload[1])}
        elif kind == "dvl_velocity":
            rec = {"type": "dvl_velocity", "t": t, "v_d": list(payload[0])}
            if all(math.isfinite(x) for x in payload[1]):
                rec["sigma"] = list(payload[1])
            yield rec
        elif kind == "heading":
            yield {"type": "heading", "t": t, "yaw": payload[0], "sigma": payload[1]}
        elif kind == "fix":
            yield {"type": "fix", "t": t, "lat": payload[0], "lon": payload[1], "sigma_m": payload[2]}
        else:
            yield {"type": "depth", "t": t, "depth_m": payload[0]}
