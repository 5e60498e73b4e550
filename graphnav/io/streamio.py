"""The JSON-lines measurement stream of ``graphnav online --stream`` and ``graphnav simulate --stream``.

One JSON object per line, in time order (samples late by less than the Navigator's reorder window are
fine). Units SI, frames as everywhere in graphnav (body FRD, NED: the fixed tangent frame at the origin of
:class:`graphnav.core.earth.EarthModel`), stamps in seconds on the IMU clock:

====================  ===========================================================================
``type``              fields
====================  ===========================================================================
``config``            optional, first line only: ``config`` = a :class:`~graphnav.core.config.SensorConfig` as JSON
                      (what ``SensorConfig.to_dict`` writes, or only some of its keys; checked like a
                      ``--config`` file); keys ``--config`` sets win
``imu``               ``t``, ``f_b`` [3] specific force m/s^2, ``omega_b`` [3] angular rate rad/s: the
                      increments over ``[t, t_next]`` divided by the interval, stamped at its **start**
                      (:mod:`graphnav.core.imu_stamps`; convert increments that end at their stamp with
                      ``increments_to_samples``, ROS ``sensor_msgs/Imu`` instant rates with
                      ``rates_to_samples``)
``dvl``               ``t``, ``beams`` [4] along-beam velocity m/s (``null`` where invalid), ``valid`` [4] bool
                      (optional: default = the beams that are numbers)
``dvl_velocity``      ``t``, ``v_d`` [3] velocity of the DVL head in the DVL frame measured by the instrument, m/s
                      (a velocity-only DVL, a 3-beam solution); ``sigma`` [3] one-sigma per DVL axis, m/s
                      (optional: default ``DvlSpec.velocity_noise_std``). A ping with a ``dvl`` record of >= 3
                      valid beams at the same ``t`` uses the beams instead
``depth``             ``t``, ``depth_m`` (m, positive down)
``fix``               ``t``, ``lat``, ``lon`` (rad), ``sigma_m`` (m, 1-sigma per horizontal axis)
``heading``           ``t``, ``yaw`` (rad), ``sigma`` (rad)
``units``             optional, before the samples it applies to: the units the following records are in
                      (``time`` s/ms/us/ns, ``accel`` m/s^2/g, ``gyro`` rad/s/deg/s, ``velocity``
                      m/s/cm/s/mm/s); each sample is converted to SI as it is read
====================  ===========================================================================

A stream is read one sample at a time, so units cannot be detected from its statistics as the loaders do
(:mod:`graphnav.io.units`): they are declared (a ``units`` record, or ``StreamReader(units=...)``), and a
sample that cannot be in SI is refused, counted and warned about like a bad line, naming the unit to declare:
a stamp beyond :data:`MAX_STAMP_S` (not seconds), ``|omega_b|`` above :data:`MAX_RATE_RADPS`, ``|f_b|``
below :data:`MIN_ACCEL_MPS2` or above :data:`MAX_ACCEL_MPS2` (the accelerometer always sees gravity; g
reads ~1, and swapped IMU blocks put ~0 in ``f_b``).

Example lines::

    {"type": "imu", "t": 12.34, "f_b": [0.01, -0.02, -9.79], "omega_b": [0.0, 0.001, -0.002]}
    {"type": "dvl", "t": 12.5, "beams": [0.71, null, -0.65, 0.12], "valid": [true, false, true, true]}
    {"type": "dvl_velocity", "t": 13.5, "v_d": [1.02, -0.05, 0.01], "sigma": [0.02, 0.02, 0.01]}

The estimates ``graphnav online --stream`` writes back are JSON lines of ``type`` ``estimate`` (see
:func:`estimate_record`). A line that is not valid JSON or lacks a field is skipped with a warning naming
its line number, and counted; the Navigator refuses bad values itself. A ``config`` line anywhere but first,
or one with a bad key, stops the stream with a :class:`~graphnav.core.errors.ConfigError` naming the line (the
estimator is built from the configuration before the first measurement).

While the Navigator aligns, ``graphnav online --stream`` also writes ``status`` lines (:func:`status_record`).
``graphnav online --schema`` prints this table and the configuration keys.
"""
from __future__ import annotations

import json
import math
import warnings
from typing import IO, Iterator

import numpy as np

from graphnav.core.config import ConfigOverrides
from graphnav.core.errors import ConfigError
from graphnav.core.screening import ACCEL_ZERO, IMU_FILLER
from graphnav.io.units import DECLARED_UNITS

#: Fields each record type needs (besides ``type``).
FIELDS = {"imu": ("t", "f_b", "omega_b"), "dvl": ("t", "beams"), "dvl_velocity": ("t", "v_d"),
          "depth": ("t", "depth_m"),
          "fix": ("t", "lat", "lon", "sigma_m"), "heading": ("t", "yaw", "sigma"), "config": ("config",),
          "units": ()}
#: Unit names a ``units`` record may declare, with their factor to SI (the same as a CSV column map's).
UNITS = DECLARED_UNITS
#: Per-sample plausibility in SI (module docstring): stamps up to the year ~2286 in Unix seconds; an AUV never
#: turns at 10 rad/s (570 deg/s); the accelerometer reads gravity, 9.8 m/s^2, within a few m/s^2.
MAX_STAMP_S = 1e10
MAX_RATE_RADPS = 10.0
MIN_ACCEL_MPS2 = 3.0
MAX_ACCEL_MPS2 = 50.0


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

    def __init__(self, lines, source: str = "<stream>", units: dict | None = None):
        self.lines = lines
        self.source = source
        self.n_bad = 0
        self.n_records = 0
        self.config: ConfigOverrides | None = None
        self._first_line: int | None = None
        self._config_line: int | None = None
        self.refused: dict[str, int] = {}
        self.scale = {k: 1.0 for k in UNITS}
        if units:
            problem = self._set_units(units)
            if problem:
                from graphnav.core.errors import ConfigError
                raise ConfigError(f"{source}: {problem}")

    def _set_units(self, rec: dict) -> str | None:
        """Apply a units declaration; returns what is wrong with it, or None."""
        for key, name in rec.items():
            if key in ("type", "_line"):
                continue
            if key not in UNITS or name not in UNITS[key]:
                return (f"unknown unit {key}={name!r} (choose "
                        + "; ".join(f"{k}: {', '.join(v)}" for k, v in UNITS.items()) + ")")
        for key, name in rec.items():
            if key in UNITS:
                self.scale[key] = UNITS[key][name]
        return None

    def _to_si(self, rec: dict) -> str | None:
        """Convert a sample to SI in place by the declared units; returns why it cannot be SI, or None."""
        try:
            rec["t"] = float(rec["t"]) * self.scale["time"]
            if rec["type"] == "imu":
                rec["f_b"] = [float(x) * self.scale["accel"] for x in rec["f_b"]]
                rec["omega_b"] = [float(x) * self.scale["gyro"] for x in rec["omega_b"]]
            elif rec["type"] == "dvl" and isinstance(rec["beams"], list):
                rec["beams"] = [None if b is None else float(b) * self.scale["velocity"] for b in rec["beams"]]
            elif rec["type"] == "dvl_velocity" and isinstance(rec["v_d"], list):
                rec["v_d"] = [None if v is None else float(v) * self.scale["velocity"] for v in rec["v_d"]]
                if isinstance(rec.get("sigma"), list):
                    rec["sigma"] = [None if v is None else float(v) * self.scale["velocity"] for v in rec["sigma"]]
        except (TypeError, ValueError):
            return None                      # malformed values: the Navigator refuses them itself
        if abs(rec["t"]) > MAX_STAMP_S:
            return f"stamp {rec['t']:.6g} s is not seconds (declare the time unit in a units record)"
        if rec["type"] == "imu":
            if not any(rec["f_b"]) and not any(rec["omega_b"]):
                # six zeros are so in any unit: a logger's filler, not g or swapped sensors (the advice below)
                return f"{IMU_FILLER}; the gap it leaves is bridged as any IMU gap"
            w = math.sqrt(sum(x * x for x in rec["omega_b"]))
            f = math.sqrt(sum(x * x for x in rec["f_b"]))
            if w > MAX_RATE_RADPS:
                return f"|omega_b| {w:.4g} rad/s is beyond any AUV's turn rate (deg/s? declare gyro in a units record)"
            if f == 0.0:         # no unit makes gravity read 0: a dead accelerometer, not a unit to declare
                return ACCEL_ZERO
            if not MIN_ACCEL_MPS2 <= f <= MAX_ACCEL_MPS2:
                return (f"|f_b| {f:.4g} m/s^2 is not gravity plus vehicle accelerations (g? declare accel in a units "
                        "record; ~0 with |omega_b| ~9.8: accelerometer and gyro swapped)")
        return None

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
            if kind == "units":
                problem = self._set_units(rec)
                if problem:
                    self._bad(line_no, problem)
                continue
            if kind in ("imu", "dvl", "dvl_velocity", "depth", "fix", "heading"):
                problem = self._to_si(rec)
                if problem:
                    self.refused[kind] = self.refused.get(kind, 0) + 1
                    self._bad(line_no, f"{kind} sample refused: {problem}")
                    continue
            if kind == "config":
                self.config = self._config(rec["config"], line_no)
                continue
            self._first_line = self._first_line or line_no
            self.n_records += 1
            rec["_line"] = line_no
            yield rec


    def _config(self, data, line_no: int) -> ConfigOverrides:
        """The keys of a ``config`` record, accepted on the first record line only."""
        where = f"{self.source}, line {line_no}"
        if self._first_line is not None or self.config is not None:
            why = (f"a config was already given at line {self._config_line}" if self.config is not None else
                   f"measurements start at line {self._first_line}")
            raise ConfigError(f"{where}: a config record is accepted only as the first line of the stream ({why}); "
                              "put it first or give the configuration with --config")
        self._config_line = line_no
        return ConfigOverrides.parse(data, where)


def feed(nav, rec: dict) -> list:
    """Give one stream record to a :class:`~graphnav.estimators.navigator.Navigator`; returns the estimates it made."""
    kind, t = rec["type"], rec["t"]
    if kind == "imu":
        return nav.add_imu(t, rec["f_b"], rec["omega_b"])
    if kind == "dvl":
        beams = [math.nan if b is None else b for b in rec["beams"]] if isinstance(rec["beams"], list) else rec["beams"]
        return nav.add_dvl(t, beams, rec.get("valid"))
    if kind == "dvl_velocity":
        return nav.add_dvl_velocity(t, rec["v_d"], rec.get("sigma"))
    if kind == "depth":
        return nav.add_depth(t, rec["depth_m"])
    if kind == "fix":
        return nav.add_position_fix(t, rec["lat"], rec["lon"], rec["sigma_m"])
    return nav.add_heading(t, rec["yaw"], rec["sigma"])


def _matrix(cov):
    return None if cov is None else np.asarray(cov, float).tolist()


def _sigma(cov):
    return None if cov is None else np.sqrt(np.clip(np.diagonal(np.asarray(cov, float)), 0, None)).tolist()


def estimate_record(est) -> dict:
    """An estimate as a JSON-lines record: ``t`` s, ``kind``, ``p_n`` m, ``v_n`` m/s, ``rpy`` rad (roll,
    pitch, yaw of ``C_b_n``), ``bias_acc`` m/s^2, ``bias_gyro`` rad/s, the estimator's covariances --
    ``cov_p_n`` (3x3 NED, m^2), ``cov_v_n`` (3x3 NED, (m/s)^2), ``cov_rot_b`` (3x3 attitude, rad^2, GTSAM's right
    perturbation ``C_b_n = C_hat Exp(theta)``, theta in body axes), ``cov_bias`` (6x6 [acc, gyro]) -- and their
    1-sigma ``sigma_p_n`` [3] m, ``sigma_v_n`` [3] m/s, ``sigma_rpy`` [3] rad (roll, pitch, yaw), each null when
    the estimator has none (the paper's 12-state EKF: no position), and ``health`` (``ok`` / ``degraded`` /
    ``diverged``: how far to trust it) with ``health_why`` (empty when ok)."""
    from graphnav.core.rotations import C_b_n_to_euler, euler_covariance
    C = np.asarray(est.C_b_n, float)
    roll, pitch, yaw = np.asarray(C_b_n_to_euler(C[None])).reshape(-1)[:3]
    cov_p, cov_rot = getattr(est, "cov_p_n", None), getattr(est, "cov_rot_b", None)
    return {"type": "estimate", "t": est.t, "kind": est.kind, "p_n": np.asarray(est.p_n).tolist(),
            "v_n": np.asarray(est.v_n).tolist(), "rpy": [float(roll), float(pitch), float(yaw)],
            "cov_v_n": _matrix(est.cov_v_n),
            "bias_acc": np.asarray(est.bias.accelerometer()).tolist(),
            "bias_gyro": np.asarray(est.bias.gyroscope()).tolist(),
            "cov_p_n": _matrix(cov_p), "cov_rot_b": _matrix(cov_rot), "cov_bias": _matrix(getattr(est, "cov_bias", None)),
            "sigma_p_n": _sigma(cov_p), "sigma_v_n": _sigma(est.cov_v_n),
            "sigma_rpy": None if cov_rot is None else _sigma(euler_covariance(C, cov_rot)),
            "health": getattr(est, "health", None) or "ok", "health_why": getattr(est, "health_why", "")}


def status_record(nav, t: float, wall_s: float) -> dict:
    """A ``status`` record of a Navigator: ``t`` (s, stamp of the last record read), ``wall_s`` (s since the
    stream was opened), ``state`` (``aligning`` or ``navigating``) and, while aligning, ``alignment``: the
    aligner's :meth:`~graphnav.estimators.align.Aligner.progress` (``aligned_s`` of ``needed_s`` s of IMU data,
    ``dvl_pings`` with bottom lock of ``dvl_pings_needed``, ``heading`` source, ``waiting_for``, ``imu_gaps``)."""
    rec = {"type": "status", "t": float(t), "wall_s": round(float(wall_s), 3),
           "state": "aligning" if nav.aligner is not None else "navigating"}
    if nav.aligner is not None:
        rec["alignment"] = nav.aligner.progress()
    return rec


def schema_text() -> str:
    """The stream schema for ``graphnav online --schema``: the record table of this module and every key of a
    ``config`` record (:data:`graphnav.core.config.SCHEMA`, meanings from the dataclass docstrings)."""
    from graphnav.core.config import describe
    doc = __doc__.split("====", 1)[0].rstrip()
    table = "=" * 20 + __doc__.split("=" * 20, 1)[1].split("\nExample lines::")[0]
    lines = [doc, "", table.rstrip(), "",
             "Written back by graphnav online --stream (standard output, one JSON object per line):",
             "  estimate  t, kind, p_n [3] m (NED), v_n [3] m/s, rpy [3] rad (roll, pitch, yaw of C_b_n), "
             "bias_acc [3] m/s^2, bias_gyro [3] rad/s; covariances, each null when the estimator has none: "
             "cov_p_n 3x3 m^2 (NED), cov_v_n 3x3 (m/s)^2 (NED), cov_rot_b 3x3 rad^2 (C_b_n = C_hat Exp(theta), theta "
             "in body axes), cov_bias 6x6 [acc, gyro]; their 1-sigma sigma_p_n [3] m, sigma_v_n [3] m/s, sigma_rpy [3] "
             "rad; health (ok | degraded | diverged), health_why",
             "  status    t (last record, s), wall_s, state (aligning | navigating | waiting for data), alignment "
             "{aligned_s, needed_s, dvl_pings, dvl_pings_needed, dvl_pings_ignored, heading, waiting_for [...], "
             "imu_gaps} "
             "while aligning, idle_s and source while no record comes",
             "", "Keys of a config record (and of a --config file; any subset; the others keep their defaults):"]
    import textwrap
    previous = None
    for key, expected, meaning in describe():
        lines.append(f"  {key:32s} {expected}")
        if meaning and meaning != previous:
            lines += textwrap.wrap(meaning, 110, initial_indent=" " * 37, subsequent_indent=" " * 37)
        elif meaning:
            lines.append(" " * 37 + "(as above)")
        previous = meaning
    return "\n".join(lines)
