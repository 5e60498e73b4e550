"""The option groups both estimators compose (graphnav.estimators.options): one name per quantity, the
per-estimator defaults resolved in one place, names read from dicts and the old names' deprecation path."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from graphnav.core.config import SensorConfig
from graphnav.core.errors import ConfigError
from graphnav.estimators.align import AlignOptions
from graphnav.estimators.ekf import EkfOptions
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.health import HealthOptions
from graphnav.estimators.navigator import Navigator, NavigatorOptions
from graphnav.estimators.options import (
    RENAMED,
    PriorOptions,
    RegressedScreeningOptions,
    build_options,
)
from graphnav.evaluation import crossval
from graphnav.evaluation.methods import estimator_options


def test_both_estimators_compose_the_same_groups():
    for cls in (GraphOptions, EkfOptions):
        o = cls()
        assert isinstance(o.priors, PriorOptions) and isinstance(o.screening, RegressedScreeningOptions)
        assert isinstance(o.health, HealthOptions)
        assert o.dvl_error_states and o.max_pure_inertial_s > 0


def test_defaults_that_differ_per_estimator_resolve_from_one_place():
    priors = PriorOptions()
    assert priors.attitude_sigma_for("graph") == pytest.approx(np.deg2rad(0.05))
    np.testing.assert_allclose(priors.attitude_sigma_for("ekf"), np.deg2rad([0.1, 0.1, 0.1]))
    assert PriorOptions(attitude_sigma=0.01).attitude_sigma_for("ekf") == 0.01
    with pytest.raises(ConfigError):
        priors.attitude_sigma_for("kalman")
    config = SensorConfig()
    assert priors.bias_sigmas(config.imu) == (config.imu.accel_bias_sigma, config.imu.gyro_bias_sigma)
    scale, bias = priors.dvl_error_sigmas(config.dvl)
    assert scale == max(float(np.max(np.abs(config.dvl.scale_factor))), 0.005)
    assert bias == max(float(np.max(np.abs(config.dvl.beam_bias))), 0.005)


def test_named_options_fill_groups_on_top_of_the_method_defaults():
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        o = estimator_options("Graph-HN", {"screening.gate_k": 3.0, "priors.velocity_sigma": 0.1, "lag_s": 5.0})
    assert o.screening == RegressedScreeningOptions(correlation=0.5, adaptive=True, gate_k=3.0)
    assert o.priors.velocity_sigma == 0.1 and o.lag_s == 5.0
    # the fused IMU-aware hybrid screens a run of regressed beams until one is kept and models its errors' correlation;
    # the default hybrid screens each ping
    assert (o.regressed_runs, o.regressed_error_tau_s) == ("screen-each", None)
    for method in ("Graph-HNI", "Graph-HNI-batch"):
        hni = estimator_options(method)
        # by the number of measured beams: a total outage, 3, 2 and 1 missing
        assert hni.regressed_runs == {0: "screen-each", 1: "screen-first", 2: "screen-first", 3: "screen-first"}
        assert hni.regressed_error_tau_s == {0: None, 1: 3.0, 2: 10.0, 3: 10.0}
        assert hni.screening == RegressedScreeningOptions(correlation=0.5, adaptive=True)
        assert hni.retire_completions                   # taken out when the measured beams return
    assert estimator_options("Graph-HNI", {"regressed_error_tau_s": None}).regressed_error_tau_s is None
    whole = build_options(EkfOptions, {"priors": PriorOptions(position_sigma=2.0), "priors.velocity_sigma": 0.2})
    assert whole.priors.position_sigma == 2.0 and whole.priors.velocity_sigma == 0.2


@pytest.mark.parametrize("old, new", sorted(RENAMED.items()))
def test_old_names_are_accepted_with_a_deprecation_warning_naming_the_new_one(old, new):
    family = "TC" if old.startswith("sigma_") else "Graph-TC"
    with pytest.warns(DeprecationWarning, match=f"'{old}' is now '{new}'"):
        o = estimator_options(family, {old: 0.3})
    group, field_name = new.split(".")
    assert getattr(getattr(o, group), field_name) == 0.3


def test_unknown_names_are_refused_by_name():
    with pytest.raises(ConfigError, match="priors.nope"):
        build_options(GraphOptions, {"priors.nope": 1.0})
    with pytest.raises(ConfigError, match="'nope'"):
        build_options(EkfOptions, {"nope": 1.0})
    with pytest.raises(ConfigError, match="not a group"):
        build_options(GraphOptions, {"lag_s.x": 1.0})
    with pytest.raises(ConfigError, match="correlation"):
        RegressedScreeningOptions(correlation=1.0)


def test_crossval_parameter_takes_its_old_name_with_a_warning():
    with pytest.warns(DeprecationWarning, match="priors.dvl_bias_sigma"):
        assert crossval.parameter_name("prior_dvl_bias_sigma") == "priors.dvl_bias_sigma"
    assert crossval.parameter_name("dvl_bias_rw") == "dvl_bias_rw"
    assert "priors.dvl_bias_sigma" in crossval.PARAMETERS


def test_navigator_takes_the_alignment_settings_from_its_options():
    align = AlignOptions(initial_heading_rad=0.3, heading_sigma_rad=0.01, initial_lla=(0.5, 0.1, 0.0))
    nav = Navigator(SensorConfig(), "ekf", options=NavigatorOptions(align=align))
    # the alignment's settings, with the estimator's DVL error priors where they leave them open
    assert dataclasses.replace(nav.aligner.options, dvl_scale_sigma=None, dvl_bias_sigma=None) == align
    assert nav.aligner.initial_heading_rad == 0.3 and nav.aligner.heading_sigma_rad == 0.01
    assert nav.aligner.initial_lla == (0.5, 0.1, 0.0)
    with pytest.raises(ConfigError, match="initial_heading_rad"):
        AlignOptions(initial_heading_rad=float("nan"))
