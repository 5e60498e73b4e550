"""Option groups both estimators compose (the factor graph's :class:`~graphnav.estimators.graph.GraphOptions`
and the EKF's :class:`~graphnav.estimators.ekf.EkfOptions`): one name per quantity, whichever estimator reads it.

- :class:`PriorOptions` (``options.priors``): the initial uncertainty of the state (the graph's first-keyframe
  priors, the EKF's initial covariance).
- :class:`RegressedScreeningOptions` (``options.screening``): the screening of regressed beams against the
  estimator's own predicted beam (:mod:`graphnav.estimators.regressed_screening`).
- :class:`graphnav.estimators.health.HealthOptions` (``options.health``): the NIS monitor.
- ``dvl_error_states`` and ``max_pure_inertial_s`` are plain fields of the same name in both (their defaults:
  :data:`DVL_ERROR_STATES`, :data:`graphnav.estimators.coasting.MAX_PURE_INERTIAL_S`).

Options can also be given by name (a dict of the method registry, ``--graph-base NAME=VALUE`` of an
experiment): :func:`build_options` reads ``"group.field"`` names (``"priors.velocity_sigma"``) and, for one
release, the names of before the groups (:data:`RENAMED`) with a :class:`DeprecationWarning` naming the new one.
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from graphnav.core.errors import ConfigError

#: Estimate the DVL scale factor (per DVL axis) and beam biases in both estimators by default (measured:
#: ``GraphOptions`` and ``EkfOptions`` docstrings, docs/decisions/consistency.md, ekf-position-states.md).
DVL_ERROR_STATES = True

#: Initial attitude sigma per axis (rad) when ``PriorOptions.attitude_sigma`` is None, per estimator. The two
#: estimators' defaults were set and measured separately (graph 0.05 deg on its first-keyframe pose, EKF 0.1 deg
#: per NED axis of its misalignment state) and every stored result of each was measured with its own; one value
#: for both would change the results of one of them, which needs its own measurement first.
DEFAULT_ATTITUDE_SIGMA_RAD: Mapping[str, float | np.ndarray] = {
    "graph": np.deg2rad(0.05),
    "ekf": np.deg2rad([0.1, 0.1, 0.1]),
}
#: Floor of the DVL error-state prior sigmas when they come from the configuration (scale unitless, bias m/s).
DVL_ERROR_PRIOR_FLOOR = 0.005


@dataclass
class PriorOptions:
    """Initial uncertainty of the state, SI units: the graph's first-keyframe priors and the EKF's initial
    covariance. None = resolved from one place for each estimator (the methods below).

    Attributes:
        position_sigma: position sigma per NED axis, m (scalar or (3,)); the EKF uses it with its position
            states only.
        velocity_sigma: velocity sigma per NED axis, m/s (the run starts on the ground truth or an
            alignment; this covers its error and the time offsets of real data).
        attitude_sigma: attitude sigma per axis, rad (scalar or (3,)): the graph's first pose (body-frame
            rotation), the EKF's misalignment per NED axis; None = :data:`DEFAULT_ATTITUDE_SIGMA_RAD` of the
            estimator (:meth:`attitude_sigma_for`).
        acc_bias_sigma: accelerometer bias sigma, m/s^2; None = ``config.imu.accel_bias_sigma`` (turn-on).
        gyro_bias_sigma: gyro bias sigma, rad/s; None = ``config.imu.gyro_bias_sigma``.
        dvl_scale_sigma: sigma of each DVL scale-factor state, unitless; None =
            ``max(|config.dvl.scale_factor|, 0.005)``.
        dvl_bias_sigma: sigma of each beam-bias state, m/s; None = ``max(|config.dvl.beam_bias|, 0.005)``.
    """

    position_sigma: float | np.ndarray = 1.0
    velocity_sigma: float = 0.05
    attitude_sigma: float | np.ndarray | None = None
    acc_bias_sigma: float | None = None
    gyro_bias_sigma: float | None = None
    dvl_scale_sigma: float | None = None
    dvl_bias_sigma: float | None = None

    def attitude_sigma_for(self, estimator: str) -> float | np.ndarray:
        """The attitude sigma (rad) ``estimator`` (``"graph"`` or ``"ekf"``) starts with."""
        if self.attitude_sigma is not None:
            return self.attitude_sigma
        if estimator not in DEFAULT_ATTITUDE_SIGMA_RAD:
            raise ConfigError(f"estimator must be one of {tuple(DEFAULT_ATTITUDE_SIGMA_RAD)}, got {estimator!r}")
        return DEFAULT_ATTITUDE_SIGMA_RAD[estimator]

    def bias_sigmas(self, imu) -> tuple[float, float]:
        """(accelerometer m/s^2, gyro rad/s) bias sigmas, from the IMU spec ``imu`` where None."""
        acc = imu.accel_bias_sigma if self.acc_bias_sigma is None else self.acc_bias_sigma
        gyro = imu.gyro_bias_sigma if self.gyro_bias_sigma is None else self.gyro_bias_sigma
        return acc, gyro

    def dvl_error_sigmas(self, dvl) -> tuple[float, float]:
        """(scale unitless, beam bias m/s) prior sigmas of the DVL error states, from the DVL configuration
        ``dvl`` where None (its largest |value|, floored at :data:`DVL_ERROR_PRIOR_FLOOR`: a perfect
        configuration must not make the states certain)."""
        scale = (max(float(np.max(np.abs(dvl.scale_factor))), DVL_ERROR_PRIOR_FLOOR) if self.dvl_scale_sigma is None
                 else self.dvl_scale_sigma)
        bias = (max(float(np.max(np.abs(dvl.beam_bias))), DVL_ERROR_PRIOR_FLOOR) if self.dvl_bias_sigma is None
                else self.dvl_bias_sigma)
        return scale, bias


@dataclass
class RegressedScreeningOptions:
    """Screening of regressed beams (a beam the DVL did not measure, regressed by a completer) against the
    estimator's own predicted beam with their joint covariance; the rules and the measurements behind them
    are in :mod:`graphnav.estimators.graph.regressed`. All off by default (the registry's hybrid methods
    switch it on).

    Attributes:
        correlation: assumed correlation (0..1) between a regressed beam's error and the estimator's
            prediction error (both come from the same past pings); 0 = independent.
        adaptive: raise a regressed beam's variance to its innovation's excess over the prediction variance.
        gate_k: joint-covariance gate in sigmas; None = no gate.
        prediction_var_scale: factor (> 0) on the estimator's predicted beam variance (the graph's marginal
            is over-confident on real data).
        completion_var_scale: factor (> 0) on the completer's variance after the correlation rule (which
            decides what is kept, on the unscaled variance) and before the adaptive rule and the gate. A
            completer's errors through one outage are serially correlated (off for many pings together), which
            the per-ping factors do not model; n completions then hold about n / tau pings' worth of
            information, tau the errors' integrated autocorrelation time (pings;
            :func:`graphnav.nets.outage_calibration.integrated_autocorrelation`). 1: the errors taken as
            independent from ping to ping.
        prediction_var_table: experimental, the factor graph only (None: off). Per number of beams the ping
            measured, ``((t_0 = 0, scale_0), (t_1, scale_1), ...)`` (s, unitless > 0, times ascending): the
            predicted beam variance is multiplied by the scale of the last ``t_i`` at or before the time since
            the run of pings with regressed beams started, on top of ``prediction_var_scale``; a number of
            measured beams the table does not name: 1. Fitted out of fold on the graph's actual errors of the
            missing beams (``experiments/claim_calibration.py``; docs/decisions/completers.md, "The graph's
            claimed variance calibrated out of fold").
    """

    correlation: float = 0.0
    adaptive: bool = False
    gate_k: float | None = None
    prediction_var_scale: float = 1.0
    completion_var_scale: float = 1.0
    prediction_var_table: Mapping[int, tuple[tuple[float, float], ...]] | None = None

    def __post_init__(self):
        for name in ("prediction_var_scale", "completion_var_scale"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"screening.{name} must be > 0, got {getattr(self, name)}")
        if not 0.0 <= self.correlation < 1.0:
            raise ConfigError(f"screening.correlation must be in [0, 1), got {self.correlation}")
        if self.prediction_var_table is not None:
            self.prediction_var_table = dict(check_scale_steps(n, steps)
                                             for n, steps in dict(self.prediction_var_table).items())

    def table_scale(self, n_measured: int, run_s: float) -> float:
        """The factor of ``prediction_var_table`` (1 without it) at a ping measuring ``n_measured`` beams,
        ``run_s`` s into its run of pings with regressed beams."""
        steps = (self.prediction_var_table or {}).get(int(n_measured))
        if not steps:
            return 1.0
        return next(scale for t, scale in reversed(steps) if t <= max(run_s, 0.0))

    @property
    def active(self) -> bool:
        """Whether any rule is on (else regressed beams enter at the completer's sigma unscreened)."""
        return self.gate_k is not None or self.adaptive or self.correlation > 0 or self.completion_var_scale != 1.0


def check_scale_steps(n_measured, steps) -> tuple[int, tuple[tuple[float, float], ...]]:
    """The entry ``n_measured: ((t_0 = 0, scale_0), ...)`` of ``screening.prediction_var_table`` as (int, floats),
    checked: a number of measured beams 0-4, times from 0 ascending (s), scales finite and > 0 (else
    :class:`ConfigError` naming the entry)."""
    name = f"screening.prediction_var_table[{n_measured}]"
    try:
        steps = tuple((float(t), float(scale)) for t, scale in steps)
        measured = int(n_measured)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be ((time s, scale), ...) per number of measured beams, got "
                          f"{steps!r}") from None
    if not 0 <= measured <= 4 or not steps or steps[0][0] != 0.0:
        raise ConfigError(f"{name}: a number of measured beams 0-4 with steps starting at 0 s, got {steps!r}")
    times, scales = np.array([t for t, _ in steps]), np.array([s for _, s in steps])
    if np.any(np.diff(times) <= 0) or not np.all(np.isfinite(scales) & (scales > 0)):
        raise ConfigError(f"{name}: times must ascend and scales be finite and > 0, got {steps!r}")
    return measured, steps


#: Option names of before the groups -> their name now (``group.field``), accepted by :func:`build_options`
#: for one release with a DeprecationWarning. The graph and the EKF had different names for one quantity.
RENAMED: Mapping[str, str] = {
    "prior_pos_sigma": "priors.position_sigma", "sigma_p0": "priors.position_sigma",
    "prior_vel_sigma": "priors.velocity_sigma", "sigma_v0": "priors.velocity_sigma",
    "prior_rot_sigma": "priors.attitude_sigma", "sigma_att0_rad": "priors.attitude_sigma",
    "prior_acc_bias_sigma": "priors.acc_bias_sigma", "sigma_ba0": "priors.acc_bias_sigma",
    "prior_gyro_bias_sigma": "priors.gyro_bias_sigma", "sigma_bg0": "priors.gyro_bias_sigma",
    "prior_dvl_scale_sigma": "priors.dvl_scale_sigma", "sigma_dvl_scale0": "priors.dvl_scale_sigma",
    "prior_dvl_bias_sigma": "priors.dvl_bias_sigma", "sigma_beam_bias0": "priors.dvl_bias_sigma",
    "regressed_correlation": "screening.correlation", "regressed_adaptive": "screening.adaptive",
    "regressed_gate_k": "screening.gate_k", "regressed_prediction_var_scale": "screening.prediction_var_scale",
}


def current_name(name: str, stacklevel: int = 3) -> str:
    """``name`` as it is called now: a name of :data:`RENAMED` is mapped with a DeprecationWarning."""
    if name in RENAMED:
        warnings.warn(f"option '{name}' is now '{RENAMED[name]}'; the old name will be refused in the next "
                      f"release", DeprecationWarning, stacklevel=stacklevel)
        return RENAMED[name]
    return name


def build_options(cls, values: Mapping | None = None):
    """An options object of dataclass ``cls`` (``GraphOptions``, ``EkfOptions``) from option names: a field
    (``"lag_s"``), a whole group (``"priors": PriorOptions(...)``) or a field of a group
    (``"priors.velocity_sigma"``); old names (:data:`RENAMED`) with a DeprecationWarning. A group's fields
    given by name go on top of the group given whole (or its default). Raises :class:`ConfigError` naming an
    unknown option."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    top, nested = {}, {}
    for name, value in (values or {}).items():
        name = current_name(name)
        group, dot, field_name = name.partition(".")
        if group not in fields:
            raise ConfigError(f"unknown {cls.__name__} option '{name}'; choose from {', '.join(fields)}")
        if dot:
            nested.setdefault(group, {})[field_name] = value
        else:
            top[group] = value
    for group, changes in nested.items():
        base = top.get(group)
        if base is None:
            if fields[group].default_factory is dataclasses.MISSING:
                raise ConfigError(f"{cls.__name__} option '{group}' is not a group of options")
            base = fields[group].default_factory()
        known = {f.name for f in dataclasses.fields(base)}
        unknown = sorted(set(changes) - known)
        if unknown:
            raise ConfigError(f"unknown {cls.__name__} option '{group}.{unknown[0]}'; {group} has "
                              f"{', '.join(sorted(known))}")
        top[group] = dataclasses.replace(base, **changes)
    return cls(**top)
