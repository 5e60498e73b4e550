"""One calibration from several missions: each quantity's missions combined with the spread between them.

A single mission's sigmas (:mod:`graphnav.calibration.calibrate`) are statistical: they say how well that mission's
data fix its own value. Some quantities differ between missions by more than that: on the ten shared Snapir
trajectories the DVL mounting yaw, its scale factor and the accelerometer's position scatter 2.1-4.3 times their
per-mission sigmas (docs/decisions/calibration-spread.md; what moves them is not identified: the reference's heading
error and the water's sound speed change between missions, for example). A configuration applied to the next mission
needs the sigma that covers that scatter.

Each quantity (each component of a vector) is combined by the DerSimonian-Laird random-effects estimator:
missions ``i`` with values ``y_i`` and sigmas ``s_i``; Cochran's ``Q = sum w_i (y_i - y_fixed)^2`` with
``w_i = 1 / s_i^2`` measures the scatter, the between-mission variance is
``tau^2 = max(0, (Q - (k - 1)) / (sum w - sum w^2 / sum w))``, and the combined value is the mean weighted by
``1 / (s_i^2 + tau^2)``, whose sigma is ``1 / sqrt(sum 1 / (s_i^2 + tau^2))``. A next mission's true value is
expected within ``sqrt(tau^2 + sigma^2)`` of it (that mission's own estimate adds its own sigma), and within
``t_{k-2}(0.975) sqrt(tau^2 + sigma^2)`` at 95 % (Higgins, Thompson and Spiegelhalter's prediction interval: with few
missions tau is itself uncertain, and 1.96 of that sigma covers 80-86 % when they differ; none with two missions). The
``p`` of ``Q`` against chi-square with ``k - 1`` degrees of freedom says whether the missions differ beyond their
sigmas.

The time offsets are combined for the report only: a log's clocks are its own.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.stats import chi2
from scipy.stats import t as student_t

from graphnav.calibration.result import PRINTED, CalibrationResult, joined, printed_label
from graphnav.core.config import SensorConfig
from graphnav.core.errors import DataError

#: The CalibrationResult fields combined over missions (the ones a mode does not estimate are None and skipped).
COMBINED_FIELDS = ("lever_arm_b", "dvl_time_offset_s", "gt_time_offset_s", "dvl_yaw_rad", "dvl_scale", "dvl_bias",
                   "imu_position_b")
#: Below this p of Cochran's Q the missions differ beyond their sigmas, and the report says so.
SPREAD_P = 0.05
#: Configuration keys a combined calibration does not write, each mission's own: a log's clock offsets (the ten
#: Snapir trajectories' GT offsets differ by up to a second; a configuration that sets them stops
#: :func:`graphnav.calibration.preparation.prepare` from finding them in each mission) and the mission's place and
#: weather (latitude, gravity, surface pressure, which the loaders take from the data where it has them).
PER_MISSION_KEYS = ("gt_time_offset_s", "dvl_time_offset_s", "lat_rad", "gravity_mps2", "atmospheric_pressure_pa")
#: The combined fields that are a log's clocks: reported, never written, never flagged as differing.
CLOCK_FIELDS = ("dvl_time_offset_s", "gt_time_offset_s")


@dataclass
class RandomEffects:
    """A quantity combined over missions, per component (arrays of the quantity's shape; units its own).

    Attributes:
        value: the random-effects mean.
        sigma: the mean's 1-sigma.
        between_sigma: tau, the spread of the missions' true values around the mean (0 when none is seen).
        next_mission_sigma: ``sqrt(tau^2 + sigma^2)``, where the next mission's true value is expected.
        next_mission_95: the half-width of its 95 % prediction interval, ``t_{k-2}(0.975)`` times
            ``next_mission_sigma`` (NaN with fewer than three missions).
        q_per_dof: Cochran's Q over its k - 1 degrees of freedom (about 1 when the sigmas cover the scatter).
        p: the probability of a Q at least this large were the missions' true values equal.
        n: missions combined (those with a finite value and a positive sigma).
    """

    value: np.ndarray
    sigma: np.ndarray
    between_sigma: np.ndarray
    next_mission_sigma: np.ndarray
    next_mission_95: np.ndarray
    q_per_dof: np.ndarray
    p: np.ndarray
    n: np.ndarray

    def to_dict(self) -> dict:
        return {k: np.asarray(v).tolist() for k, v in self.__dict__.items()}


def usable(values, sigmas) -> np.ndarray:
    """Where a mission's value is finite and its sigma a positive finite number: what :func:`random_effects`
    combines (the same shape as ``values``)."""
    return np.isfinite(values) & np.isfinite(sigmas) & (sigmas > 0)


def random_effects(values, sigmas) -> RandomEffects:
    """DerSimonian-Laird combination of ``values`` (k, ...) with 1-sigmas ``sigmas`` (k, ...), column by column.

    Missions with a non-finite value or a sigma that is not a positive finite number are left out of their
    column. A column with one mission passes it through (no spread can be seen: ``between_sigma``, the next-mission
    numbers, ``q_per_dof`` and ``p`` are NaN); with none, everything is NaN.
    """
    y = np.asarray(values, float)
    s = np.asarray(sigmas, float)
    if y.shape != s.shape or y.ndim < 1:
        raise ValueError(f"values {y.shape} and sigmas {s.shape} must have the same shape, missions first")
    shape = y.shape[1:]
    y, s = y.reshape(len(y), -1), s.reshape(len(s), -1)
    out = {k: np.full(y.shape[1], np.nan) for k in ("value", "sigma", "between_sigma", "next_mission_sigma",
                                                     "next_mission_95", "q_per_dof", "p")}
    n = np.zeros(y.shape[1], int)
    for j in range(y.shape[1]):
        use = usable(y[:, j], s[:, j])
        yj, sj = y[use, j], s[use, j]
        k = n[j] = len(yj)
        if k == 0:
            continue
        if k == 1:
            out["value"][j], out["sigma"][j] = yj[0], sj[0]
            continue
        w = 1.0 / sj ** 2
        fixed = np.sum(w * yj) / np.sum(w)
        q = float(np.sum(w * (yj - fixed) ** 2))
        tau2 = max(0.0, (q - (k - 1)) / (np.sum(w) - np.sum(w ** 2) / np.sum(w)))
        w_re = 1.0 / (sj ** 2 + tau2)
        out["value"][j] = np.sum(w_re * yj) / np.sum(w_re)
        out["sigma"][j] = 1.0 / np.sqrt(np.sum(w_re))
        out["between_sigma"][j] = np.sqrt(tau2)
        out["next_mission_sigma"][j] = np.sqrt(tau2 + out["sigma"][j] ** 2)
        if k >= 3:
            out["next_mission_95"][j] = float(student_t.ppf(0.975, k - 2)) * out["next_mission_sigma"][j]
        out["q_per_dof"][j] = q / (k - 1)
        out["p"][j] = float(chi2.sf(q, k - 1))
    return RandomEffects(**{k: v.reshape(shape) for k, v in out.items()}, n=n.reshape(shape))


@dataclass
class CombinedCalibration:
    """Several missions' calibrations combined (:func:`combine`).

    Attributes:
        names: the missions, in order.
        results: each mission's :class:`CalibrationResult`.
        quantities: field name -> :class:`RandomEffects` (the fields of :data:`COMBINED_FIELDS` every mission
            estimated).
        units: field name -> unit.
        config: the first mission's calibrated configuration with the combined values written in (lever arm,
            mounting yaw, scale factor; the noise densities as the RMS over the missions). Its time offsets are the
            first mission's; :meth:`config_dict`, what ``graphnav calibrate`` writes, leaves them out with the
            mission's place (:data:`PER_MISSION_KEYS`).
        notes: what the combination left out or took from the first mission.
    """

    names: list[str]
    results: list[CalibrationResult]
    quantities: dict[str, RandomEffects]
    units: dict[str, str]
    config: SensorConfig
    notes: list[str] = field(default_factory=list)

    def config_dict(self) -> dict:
        """The combined configuration as a configuration file holds it, without :data:`PER_MISSION_KEYS`."""
        return {k: v for k, v in self.config.to_dict().items() if k not in PER_MISSION_KEYS}

    def differing(self) -> list[str]:
        """The instrument fields whose missions differ beyond their sigmas (p of Q below :data:`SPREAD_P` in a
        component); the clocks (:data:`CLOCK_FIELDS`) are each log's own and never listed."""
        return [name for name, q in self.quantities.items()
                if name not in CLOCK_FIELDS and np.any(np.asarray(q.p) < SPREAD_P)]

    def to_dict(self) -> dict:
        return {"missions": [{"name": n, **r.to_dict()} for n, r in zip(self.names, self.results)],
                "combined": {name: {**q.to_dict(), "unit": self.units[name]} for name, q in self.quantities.items()},
                "differing": self.differing(), "notes": list(self.notes), "spread_p": SPREAD_P}

    def report(self) -> str:
        def cells(x, scale, digits, sign="+"):
            return joined([f"{a:{sign}.{digits}f}" if np.isfinite(a) else "-" for a in np.atleast_1d(x) * scale])

        def line(name, q, next_mission=True):
            _, scale, unit, digits = PRINTED[name]
            flag = "  MISSIONS DIFFER beyond their sigmas" if name in self.differing() else ""
            nxt = (f"next mission +- {cells(q.next_mission_sigma, scale, digits, '')} (95 %: +- "
                   f"{cells(q.next_mission_95, scale, digits, '')}); ") if next_mission else ""
            return (f"  {printed_label(name, self.results[0]):<26}: {cells(q.value, scale, digits)} +- "
                    f"{cells(q.sigma, scale, digits, '')} "
                    f"{unit or self.units[name]}; {nxt}scatter/sigma {cells(np.sqrt(q.q_per_dof), 1.0, 1, '')}{flag}")

        lines = [f"combined over {len(self.names)} missions (random effects): the value +- its sigma; where the next "
                 "mission's true value is expected, 1 sigma and 95 % (its own estimate adds its own sigma; no 95 % "
                 "with two missions); the scatter over the per-mission sigmas (about 1 when they cover it):"]
        lines += [line(name, q) for name, q in self.quantities.items() if name not in CLOCK_FIELDS]
        if self.differing():
            lines.append("  (a single mission's sigma does not cover another mission for these; use the next-mission "
                         "sigma)")
        lever, accelerometer = (self.quantities.get(k) for k in ("lever_arm_b", "imu_position_b"))
        if lever is not None:
            lines += self.results[0].point_note(lever.value, None if accelerometer is None else accelerometer.value)
        clocks = [name for name in CLOCK_FIELDS if name in self.quantities]
        if clocks:
            lines.append("  each log's own clocks (not written: each mission's preparation finds its own):")
            lines += [line(name, self.quantities[name], next_mission=False) for name in clocks]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


def combine(results: list[CalibrationResult], names: list[str]) -> CombinedCalibration:
    """Combine several missions' calibrations of one vehicle (same sensors, same starting configuration).

    Raises :class:`DataError` naming the first mission that cannot be combined with the first one
    (:func:`incompatibility`).
    """
    if len(results) != len(names) or not results:
        raise ValueError("one name per calibration result, at least one")
    for name, r in zip(names[1:], results[1:]):
        problem = incompatibility(results[0], r)
        if problem is not None:
            raise DataError(f"{problem} ({names[0]}'s)", name, field=problem.split(":", 1)[0])
    quantities, units, notes = {}, {}, []
    for name in COMBINED_FIELDS:
        got = [getattr(r, name) for r in results]
        if any(q is None for q in got):
            if any(q is not None for q in got):
                notes.append(f"{name}: not estimated for every mission, not combined")
            continue
        values = np.array([q.value for q in got], float)
        sigmas = np.array([q.sigma for q in got], float)
        for i in np.flatnonzero(~usable(values, sigmas).reshape(len(got), -1).all(axis=1)):
            msg = f"{names[i]}: {name} left out of the combination (value or sigma not usable)"
            warnings.warn(msg, stacklevel=2)
            notes.append(msg)
        quantities[name], units[name] = random_effects(values, sigmas), got[0].unit
    return CombinedCalibration(list(names), list(results), quantities, units,
                               _combined_config(results, quantities, notes), notes)


def incompatibility(first: CalibrationResult, other: CalibrationResult) -> str | None:
    """Why ``other`` cannot be combined with ``first`` (its field first, then the reason), or None: another
    calibration mode, other IMU axis signs (not one vehicle's IMU mounting, or an axis check that failed), or another
    starting DVL mounting or scale correction (not calibrated from one configuration, so their fitted yaw and scale
    are relative to different starts)."""
    if other.mode != first.mode:
        return f"mode: calibrated in mode {other.mode}, not {first.mode} (give --mode)"
    if not _same_point(other.gt_point_b, first.gt_point_b):
        return (f"gt_point_b: lever arm measured from the point {_point(other)}, not {_point(first)}: "
                "read the missions alike")
    if not np.array_equal(other.config.imu_axis_signs, first.config.imu_axis_signs):
        return (f"imu_axis_signs: {other.config.imu_axis_signs.tolist()}, not {first.config.imu_axis_signs.tolist()}: "
                "not one vehicle's IMU mounting")
    if not np.allclose(_start_mounting(other), _start_mounting(first), atol=1e-9):
        return "dvl.C_d_b: another starting DVL mounting (before the fitted yaw): calibrate from one configuration"
    if not np.isclose(_start_scale(other), _start_scale(first), rtol=0, atol=1e-12):
        return ("dvl.velocity_scale_correction: another starting scale correction (before the fitted scale): "
                "calibrate from one configuration")
    return None


def _same_point(a, b) -> bool:
    return (a is None) == (b is None) and (a is None or np.allclose(a, b, rtol=0, atol=1e-9))


def _point(r: CalibrationResult) -> str:
    """The point a result's positions are measured from, for a message."""
    return r.reference_point + ("" if r.gt_point_b is None else f" {np.round(r.gt_point_b, 3).tolist()} m from the GT")


def _start_scale(r: CalibrationResult) -> float:
    """The DVL scale correction the calibration started from: the calibrated one without its fitted scale."""
    fitted = 0.0 if r.dvl_scale is None else float(r.dvl_scale.value)
    return (1 + r.config.dvl.velocity_scale_correction) / (1 + fitted) - 1


def _start_mounting(r: CalibrationResult) -> np.ndarray:
    """The DVL mounting the calibration started from: the calibrated C_d_b without its fitted yaw."""
    yaw = 0.0 if r.dvl_yaw_rad is None else float(r.dvl_yaw_rad.value)
    return Rotation.from_euler("z", -yaw).as_matrix() @ r.config.dvl.C_d_b


def _combined_config(results: list[CalibrationResult], quantities: dict[str, RandomEffects],
                     notes: list[str]) -> SensorConfig:
    first = results[0]
    cfg = SensorConfig.from_dict(first.config.to_dict())
    q = quantities

    def has(name):
        return name in q and np.all(np.isfinite(q[name].value))

    if has("lever_arm_b"):
        cfg.dvl.lever_arm_b = np.asarray(q["lever_arm_b"].value, float).copy()
    if has("dvl_yaw_rad"):
        cfg.dvl.C_d_b = Rotation.from_euler("z", float(q["dvl_yaw_rad"].value)).as_matrix() @ _start_mounting(first)
    if has("dvl_scale"):
        cfg.dvl.velocity_scale_correction = float((1 + _start_scale(first)) * (1 + float(q["dvl_scale"].value)) - 1)
    noises = [r.noise for r in results]
    if all(n is not None for n in noises):
        acc, gyro = np.array([n.estimator_densities() for n in noises]).T
        cfg.imu.accel_noise_density = float(np.sqrt(np.mean(acc ** 2)))
        cfg.imu.gyro_noise_density = float(np.sqrt(np.mean(gyro ** 2)))
        beams = [n.beam_noise_std for n in noises if n.beam_noise_std is not None]
        if beams:
            cfg.dvl.beam_noise_std = float(np.sqrt(np.mean(np.square(beams))))
        beam_range = f"; beam noise {min(beams):.4f}..{max(beams):.4f} m/s" if beams else ""
        notes.append(f"noise densities and beam noise written as their RMS over the {len(noises)} missions: accel "
                     f"{cfg.imu.accel_noise_density:.2e} (per mission {acc.min():.2e}..{acc.max():.2e}), gyro "
                     f"{cfg.imu.gyro_noise_density:.2e} ({gyro.min():.2e}..{gyro.max():.2e}){beam_range}; their spread "
                     "is not tested against a sigma (the identification gives none)")
    elif any(n is not None for n in noises):
        notes.append("noise not identified for every mission: the densities and beam noise written are the first "
                     "mission's")
    return cfg
