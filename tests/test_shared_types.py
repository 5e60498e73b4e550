"""Each type and helper name means one thing: the estimators' shared types live in one module, no two classes
share a name, and the EKF does not reach into the factor graph's modules."""
from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("graphnav", "factors", "nets")


def top_level_definitions() -> dict[str, list[str]]:
    """Public top-level class and function name -> the files that define it."""
    found = defaultdict(list)
    for top in SOURCES:
        for path in sorted((ROOT / top).rglob("*.py")):
            for node in ast.parse(path.read_text(), str(path)).body:
                if isinstance(node, (ast.ClassDef, ast.FunctionDef)) and not node.name.startswith("_"):
                    found[node.name].append(str(path.relative_to(ROOT)))
    return found


def test_no_two_classes_share_a_name():
    classes = defaultdict(list)
    for top in SOURCES:
        for path in sorted((ROOT / top).rglob("*.py")):
            for node in ast.parse(path.read_text(), str(path)).body:
                if isinstance(node, ast.ClassDef):
                    classes[node.name].append(str(path.relative_to(ROOT)))
    assert {name: files for name, files in classes.items() if len(files) > 1} == {}


@pytest.mark.parametrize("name, home", [
    ("InitialState", "graphnav/estimators/types.py"),
    ("EpochEstimate", "graphnav/estimators/types.py"),
    ("Keyframe", "graphnav/estimators/types.py"),
    ("Ping", "graphnav/estimators/types.py"),
    ("ImuSegments", "graphnav/estimators/types.py"),
    ("PositionFix", "graphnav/estimators/types.py"),
    ("GraphKeyframe", "graphnav/estimators/graph/builder.py"),
    ("BeamPrediction", "graphnav/core/beam_model.py"),
    ("euler_to_C_b_n", "graphnav/core/rotations.py"),
    ("euler_to_C_b_n_closed_form", "graphnav/core/rotations.py"),
    ("mission_reference", "graphnav/calibration/reference.py"),
    ("scoring_reference", "graphnav/evaluation/consistency.py"),
    ("screen_against_prediction", "graphnav/estimators/regressed_screening.py"),
])
def test_each_shared_name_is_defined_once(name, home):
    assert top_level_definitions()[name] == [home]


def test_the_ekf_does_not_import_the_graph():
    tree = ast.parse((ROOT / "graphnav/estimators/ekf.py").read_text())
    modules = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    modules |= {a.name for node in ast.walk(tree) if isinstance(node, ast.Import) for a in node.names}
    assert not [m for m in modules if m and m.startswith("graphnav.estimators.graph")]


def test_the_public_paths_give_the_shared_types():
    import graphnav.estimators as est
    import graphnav.estimators.graph as graph
    from graphnav.estimators import types
    assert est.InitialState is graph.InitialState is types.InitialState
    assert est.EpochEstimate is graph.EpochEstimate is types.EpochEstimate


def test_a_graph_backend_without_kept_factors_says_so():
    import gtsam

    from graphnav.core.config import SensorConfig
    from graphnav.core.errors import ConfigError
    from graphnav.estimators.backends import make_backend
    from graphnav.estimators.types import InitialState
    initial = InitialState(gtsam.Pose3(), np.zeros(3))
    kept = make_backend("isam2", SensorConfig(), initial, keep_keyframe_graphs=True)
    assert kept.keyframe_graphs() == []
    with pytest.raises(ConfigError, match="keep_keyframe_graphs"):
        make_backend("isam2", SensorConfig(), initial).keyframe_graphs()


def test_a_ping_is_made_once_and_reaches_the_backend_as_that_ping():
    """The Ping the Navigator makes in add_dvl is the one the keyframer hands on (a copy with its gyro rate), and
    the graph keyframe keeps it; a velocity ping likewise."""
    import gtsam

    from graphnav.core.config import SensorConfig
    from graphnav.core.errors import ConfigError
    from graphnav.estimators.graph.builder import GraphContext, graph_keyframe
    from graphnav.estimators.graph.options import GraphOptions
    from graphnav.estimators.navigator import Navigator
    from graphnav.estimators.types import InitialState, Ping
    ping = Ping.from_beams(1.0, [0.5, np.nan, 0.3, -32.768], [True, True, True, False])
    np.testing.assert_array_equal(ping.measured, [True, False, True, False])
    assert np.isnan(ping.beams[[1, 3]]).all() and not ping.has_regressed and ping.omega_b is None
    velocity = Ping.from_velocity(2.0, [1.0, 0.0, 0.1], [np.nan, 0.02, 0.02])
    assert velocity.is_velocity and velocity.n_measured == 0

    config = SensorConfig()
    nav = Navigator(config, "isam2", initial=InitialState(gtsam.Pose3(), np.zeros(3), t=0.0),
                    keep_keyframe_graphs=True)
    seen = []
    nav.backend.process = lambda kf, process=nav.backend.process: seen.append(kf) or process(kf)
    beams = [0.1, 0.2, 0.3, 0.4]
    for k in range(301):
        nav.add_imu(0.01 * k, (0.0, 0.0, -config.gravity_mps2), (0.0, 0.0, 0.01))
        if k == 100:
            nav.add_dvl(1.0, beams, [True] * 4)
        if k == 200:
            nav.add_dvl_velocity(2.0, [1.0, 0.0, 0.1], [np.nan, 0.02, 0.02])
    nav.finish()
    pings = [kf.ping for kf in seen if kf.ping is not None]
    assert [p.t for p in pings] == [1.0, 2.0]
    np.testing.assert_array_equal(pings[0].beams, beams)
    np.testing.assert_allclose(pings[0].omega_b, [0.0, 0.0, 0.01])
    assert pings[1].is_velocity and pings[1].omega_b is not None
    gkf = graph_keyframe(next(kf for kf in seen if kf.ping is pings[0]), GraphContext(config, GraphOptions()))
    assert gkf.ping is pings[0] and gkf.n_measured == 4 and gkf.n_regressed == 0
    assert len(nav.keyframe_graphs()) == len(seen)
    with pytest.raises(ConfigError, match="not a graph backend"):
        Navigator(config, "ekf", initial=InitialState(gtsam.Pose3(), np.zeros(3), t=0.0)).keyframe_graphs()
