"""The public face: every public name imports, ``import graphnav`` stays light, the README lists
``graphnav.__all__``, subpackages export only their API, one method registry, command modules import each
other's helpers only through ``commands.common``."""
from __future__ import annotations

import ast
import importlib
import re
import runpy
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import graphnav

ROOT = Path(__file__).parents[1]
SUBPACKAGES = ("core", "io", "sim", "estimators", "calibration", "evaluation", "commands")


def test_every_public_name_imports_and_dir_lists_it():
    assert len(graphnav.__all__) == len(set(graphnav.__all__)) <= 15
    for name in graphnav.__all__:
        assert getattr(graphnav, name) is not None, name
        assert name in dir(graphnav)
    assert graphnav.Navigator is importlib.import_module("graphnav.estimators.navigator").Navigator
    with pytest.raises(AttributeError, match="no attribute 'StackedBeams'"):
        graphnav.StackedBeams  # noqa: B018


@pytest.mark.parametrize("sub", SUBPACKAGES)
def test_subpackages_export_their_own_api(sub):
    package = importlib.import_module(f"graphnav.{sub}")
    for name in package.__all__:
        value = getattr(package, name)
        assert name in dir(package)
        # defined in the subpackage itself (no re-export of another layer's names), and not a submodule
        assert getattr(value, "__module__", package.__name__).startswith(package.__name__), (sub, name)
        assert not isinstance(value, type(sys)), (sub, name)
    assert not any(name.startswith("_") for name in package.__all__)


def test_import_graphnav_is_light():
    code = ("import sys, graphnav; graphnav.__version__; "
            "print(sorted(m for m in ('numpy', 'gtsam', 'torch', 'scipy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_command_line_parser_does_not_import_torch():
    """Every ``graphnav`` call builds the whole parser; torch (about 2 s to import) is for the commands that run a
    network, not for parsing (the IMU-aware recipes' defaults the help prints live in a torch-free module)."""
    code = ("import sys; from graphnav.cli import build_parser; build_parser(); "
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_readme_lists_the_public_names():
    line = next(ln for ln in (ROOT / "README.md").read_text().splitlines()
                if ln.startswith("Public names (`graphnav.__all__`):"))
    listed = re.findall(r"`([A-Za-z_]+)`", line.split(":", 1)[1])
    assert listed == graphnav.__all__


def test_one_method_registry():
    from graphnav.evaluation import methods
    assert list(graphnav.METHODS) == ["LC", "TC", "Average-LC", "Average-TC", "HNLC", "HNTC", "Graph-TC",
                                      "Graph-HN", "Graph-HN-batch", "Graph-TC-batch", "Graph-MP", "Graph-HN-net",
                                      "Graph-HN-net-batch", "HNTC-IMU",
                                      "Graph-HNI", "Graph-HNI-batch", "Graph-HNP", "LC-12", "TC-12", "Average-LC-12",
                                      "Average-TC-12", "HNLC-12", "HNTC-12"]
    m = graphnav.METHODS["Graph-HN-batch"]
    assert (m.family, m.tight, m.completer, m.batch) == ("graph", True, "average", True)
    m = graphnav.METHODS["Graph-HN-net-batch"]
    assert (m.family, m.tight, m.completer, m.batch, m.experimental) == ("graph", True, "network", True, True)
    assert dict(graphnav.METHODS["Graph-MP"].defaults) == dict(methods.GRAPH_MP_OPTIONS)
    assert graphnav.METHODS["HNLC"].baseline == "LC" and graphnav.METHODS["Graph-HN"].average == "Average-TC"
    m = graphnav.METHODS["Graph-HNP"]
    assert (m.family, m.tight, m.completer, m.batch, m.experimental) == ("graph", True, "pivot", False, False)
    # the paper's 12-state EKF (no position or DVL error states): the method's own defaults plus the paper's,
    # compared within its family
    hn12 = graphnav.METHODS["HNTC-12"]
    assert dict(hn12.defaults) == {**methods.EKF_HYBRID_OPTIONS, "position_states": False, "dvl_error_states": False}
    assert (hn12.baseline, hn12.average, hn12.reproduction) == ("TC-12", "Average-TC-12", True)
    assert "TC-12" not in methods.BENCH_METHODS and "TC" in methods.BENCH_METHODS
    assert methods.estimator_options("LC-12").position_states is False
    assert methods.estimator_options("LC").position_states is True
    assert methods.estimator_options("TC").dvl_error_states and not methods.estimator_options("TC-12").dvl_error_states
    assert all(rec.description for rec in graphnav.METHODS.values())
    with pytest.raises(graphnav.ConfigError, match="unknown method 'EKF-TC'"):
        methods.get_method("EKF-TC")
    # no other module keeps a list of method names: only the two selections below, of registry names
    selections = {}
    for path in [*(ROOT / "graphnav").rglob("*.py"),
                 *(p for d in ("scripts", "experiments", "benchmarks") for p in (ROOT / d).glob("*.py"))]:
        for node in ast.walk(ast.parse(path.read_text())):
            target = node.target if isinstance(node, ast.AnnAssign) else (
                node.targets[0] if isinstance(node, ast.Assign) else None)
            if isinstance(target, ast.Name) and target.id.endswith("METHODS") and isinstance(node.value, ast.Tuple):
                # registry constants (methods.GRAPH_TC ...) or literals
                selections[target.id] = [getattr(methods, e.id) if isinstance(e, ast.Name) else ast.literal_eval(e)
                                         for e in node.value.elts]
    assert set(selections) == {"FAULT_METHODS", "REGIME_METHODS"}, selections
    assert all(set(names) <= set(graphnav.METHODS) for names in selections.values())


def test_commands_import_shared_helpers_from_common_only():
    for path in (ROOT / "graphnav" / "commands").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("graphnav.commands."):
                assert node.module == "graphnav.commands.common", (path.name, node.module)


@pytest.mark.parametrize("example, args", [("streaming_loop.py", ["--duration", "330"]),
                                           ("compare_methods.py", ["--duration", "90", "--methods", "TC", "Graph-TC"])])
def test_the_examples_run(example, args):
    example = ROOT / "examples" / example
    argv = sys.argv
    sys.argv = [str(example), *args]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            runpy.run_path(str(example), run_name="__main__")
    finally:
        sys.argv = argv
