"""The JSON-lines measurement stream of ``graphnav online --stream`` and ``graphnav simulate --stream``.

One JSON object per line, in time order (samples late by less than the Navigator's reorder window are
fine). Units SI, frames as everywhere in graphnav (body FRD, NED: the fixed tangent frame at the origin of
:class:`graphnav.core.earth.EarthModel`), stamps in seconds on the IMU clock:

====================  ===========================================================================
``type``              fields
====================  ===========================================================================
``config``            optional first line: ``config`` = a :class:`~graphnav.core.config.SensorConfig` as JSON
                      (what ``SensorConfig.to_dict`` writes); ``--config`` on the command line wins
``imu``               ``t``, ``f_b`` [3] specific force m/s^2, ``omega_b`` [3] angular rate rad/s: the
                      increments over ``[t, t_next]`` divided by the interval, stamped at its **start**
                      (:mod:`graphnav.core.imu_stamps`; convert increments that end at their stamp with
                      ``increments_to_samples``, ROS ``sensor_msgs/Imu`` instant rates with
                      ``rates_to_samples``)
``dvl``               ``t``, ``beams`` [4] along-beam velocity m/s (``null`` where invalid), ``valid`` [4] bool
                      (optional: default = the beams that are numbers)
``depth``             ``t``, ``depth_m`` (m, positive down)
``fix``               ``t``, ``lat``, ``lon`` (rad), ``sigma_m`` (m, 1-sigma per horizontal axis)
``heading``           ``t``, ``yaw`` (rad), ``sigma`` (rad)
====================  ===========================================================================

Example lines::

    {"type": "imu", "t": 12.34, "f_b": [0.01, -0.02, -9.79], "omega_b": [0.0, 0.001, -0.002]}
    {"type": "dvl", "t": 12.5, "beams": [0.71, null, -0.65, 0.12], "valid": [true, false, true, true]}

The estimates ``graphnav online --stream`` writes back are JSON lines of ``type`` ``estimate`` (see
:func:`estimate_record`). A line that is not valid JSON or lacks a field is skipped with a warning naming
its line number, and counted; the Navigator refuses bad values itself.
"""
from __future__ import annotations

import json
import math
import warnings
from typing import IO, Iterator

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.estimators.replay import replay

#: Fields each record type needs (besides ``type``).
FIELDS = {"imu": ("t", "f_b", "omega_b"), "dvl": ("t", "beams"), "depth": ("t", "depth_m"),
          "fix": ("t", "lat", "lon", "sigma_m"), "heading": ("t", "yaw", "sigma"), "config": ("config",)}


def _num(x: float):
    return None if x is None or not math.isfinite(x) else x


def mission_records(mission, config: bool = True) -> Iterator[dict]:
    """A recorded mission as stream records (a config line first, then its samples; never its ground
    truth)."""
    if config:
        yield {"type": "config", "config": mission.config.to_dict()}
    for kind, t, payload in replay(mission):
        if kind == "imu":
            yield {"type": "imu", "t": t, "f_b": list(payload[0]), "omega_b": list(payload[1])}
        elif kind == "dvl":
            yield {"type": "dvl", "t": t, "beams": [_num(b) for b in payload[0]], "valid": list(payload[1])}
        else:
            yield {"type": "depth", "t": t, "depth_m": payload[0]}


def write_records(records, out: IO[str]) -> int:
    """Write records as JSON lines (flushed at the end); returns how many."""
    n = 0
    for rec in records:
        out.write(json.dumps(rec, separators=(",", ":")) + "\n")
        n += 1
    out.flush()
    return n


class StreamReader:
    """Parse JSON lines into records; bad lines are skipped with a warning and counted in ``n_bad``.

    Args:
        lines: an iterable of text lines (a file, ``sys.stdin``).
        source: name for messages (e.g. ``"<stdin>"``).
    """

    def __init__(self, lines, source: str = "<stream>"):
        self.lines = lines
        self.source = source
        self.n_bad = 0
        self.n_records = 0
        self.config: SensorConfig | None = None

    def _bad(self, line_no: int, why: str) -> None:
        self.n_bad += 1
        if self.n_bad <= 5:
            warnings.warn(f"{self.source}, line {line_no}: {why}; line skipped"
                          + ("; further bad lines are only counted" if self.n_bad == 5 else ""),
                          RuntimeWarning, stacklevel=3)

    def __iter__(self) -> Iterator[dict]:
        for line_no, line in enumerate(self.lines, start=1):
            line = line.strip()
            if not line:
                continue
            try:
                rec = json.loads(line)
            except json.JSONDecodeError as exc:
                self._bad(line_no, f"not JSON ({exc.msg})")
                continue
            kind = rec.get("type") if isinstance(rec, dict) else None
            if kind not in FIELDS:
                self._bad(line_no, f"unknown record type {kind!r} (one of {', '.join(FIELDS)})")
                continue
            missing = [f for f in FIELDS[kind] if f not in rec]
            if missing:
                self._bad(line_no, f"{kind} record without field '{missing[0]}'")
                continue
            if kind == "config":
                try:
                    self.config = SensorConfig.from_dict(rec["config"], source=f"{self.source}, line {line_no}")
                except Exception as exc:       # noqa: BLE001 -- any malformed config is reported the same way
                    self._bad(line_no, f"bad config ({exc})")
                continue
            self.n_records += 1
            rec["_line"] = line_no
            yield rec


def feed(nav, rec: dict) -> list:
    """Give one stream record to a :class:`~graphnav.estimators.navigator.Navigator`; returns the estimates it made."""
    kind, t = rec["type"], rec["t"]
    if kind == "imu":
        return nav.add_imu(t, rec["f_b"], rec["omega_b"])
    if kind == "dvl":
        beams = [math.nan if b is None else b for b in rec["beams"]] if isinstance(rec["beams"], list) else rec["beams"]
        return nav.add_dvl(t, beams, rec.get("valid"))
    if kind == "depth":
        return nav.add_depth(t, rec["depth_m"])
    if kind == "fix":
        return nav.add_position_fix(t, rec["lat"], rec["lon"], rec["sigma_m"])
    return nav.add_heading(t, rec["yaw"], rec["sigma"])


def estimate_record(est) -> dict:
    """An estimate as a JSON-lines record: ``t`` s, ``kind``, ``p_n`` m, ``v_n`` m/s, ``rpy`` rad (roll,
    pitch, yaw of ``C_b_n``), ``cov_v_n`` (3x3, (m/s)^2, or null), ``bias_acc`` m/s^2, ``bias_gyro`` rad/s."""
    from graphnav.core.rotations import C_b_n_to_euler
    roll, pitch, yaw = np.asarray(C_b_n_to_euler(np.asarray(est.C_b_n)[None])).reshape(-1)[:3]
    return {"type": "estimate", "t": est.t, "kind": est.kind, "p_n": np.asarray(est.p_n).tolist(),
            "v_n": np.asarray(est.v_n).tolist(), "rpy": [float(roll), float(pitch), float(yaw)],
            "cov_v_n": None if est.cov_v_n is None else np.asarray(est.cov_v_n).tolist(),
            "bias_acc": np.asarray(est.bias.accelerometer()).tolist(),
            "bias_gyro": np.asarray(est.bias.gyroscope()).tolist()}
