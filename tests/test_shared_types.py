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
