"""Every study in ``experiments/`` and speed measurement in ``benchmarks/`` still imports and answers ``--help``
(the studies themselves take minutes to hours on the shared data: they are not run here), and
``experiments/README.md`` lists each one."""
from __future__ import annotations

import ast
import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FILES = sorted([*(ROOT / "experiments").glob("*.py"), *(ROOT / "benchmarks").glob("*.py")])


def _load(path: Path):
    spec = importlib.util.spec_from_file_location(f"_study_{path.parent.name}_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_help(path, capsys):
    module = _load(path)
    with pytest.raises(SystemExit) as exc:
        module.main(["--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0 and out.startswith("usage:"), out
    assert len(out.splitlines()) > 3                   # a description, not only the usage line


def test_readmes_list_every_file_and_its_command():
    for folder in ("experiments", "benchmarks"):
        text = (ROOT / folder / "README.md").read_text()
        listed = set(re.findall(rf"`{folder}/(\w+\.py)", text))
        present = {p.name for p in (ROOT / folder).glob("*.py")}
        assert present <= listed, f"{folder}/README.md lacks {sorted(present - listed)}"


def test_no_study_keeps_its_own_process_pool_or_data_path():
    for path in FILES:
        src = path.read_text()
        first = ast.parse(src).body[0]           # the module docstring: its usage lines may cite data paths
        code = src.replace(ast.get_source_segment(src, first), "") if isinstance(first, ast.Expr) else src
        assert "ProcessPoolExecutor" not in code and "multiprocessing" not in code, path.name
        for own in ("shared/data", "list_akit(", "data_root(", "akit_dir() /", "real-formats"):
            assert own not in code, f"{path.name} finds its data itself ({own!r}); use graphnav.io.paths"


def test_scripts_keeps_only_the_entry_points():
    kept = {"smooth.py", "online.py", "bench.py", "quickstart.sh", "setup_env.sh", "test.sh", "train_beams.sh"}
    assert {p.name for p in (ROOT / "scripts").iterdir()} <= kept


def test_akit_trajectories_finds_names_and_refuses_clearly(tmp_path, monkeypatch):
    from graphnav.core.errors import ConfigError
    from graphnav.io.paths import akit_trajectories, real_formats_file
    for n in (10, 2, 5):
        d = tmp_path / f"Trajectory{n}"
        d.mkdir()
        for kind in ("IMU", "DVL", "GT"):
            (d / f"{kind}_trajectory{n}.csv").write_text("")
    (tmp_path / "Trajectory7").mkdir()                         # incomplete: not a trajectory
    assert [p.name for p in akit_trajectories(tmp_path)] == ["Trajectory2", "Trajectory5", "Trajectory10"]
    assert [p.name for p in akit_trajectories(tmp_path, names=["10", 2])] == ["Trajectory2", "Trajectory10"]
    with pytest.raises(ConfigError, match="Trajectory7: not under"):
        akit_trajectories(tmp_path, names=["Trajectory7"])
    with pytest.raises(ConfigError, match="--data .*: no TrajectoryN folders"):
        akit_trajectories(tmp_path / "Trajectory7")
    monkeypatch.setenv("GRAPHNAV_DATA", str(tmp_path / "nothing"))
    with pytest.raises(ConfigError, match="A-KIT data .* not found: give --data or set GRAPHNAV_DATA"):
        akit_trajectories()
    with pytest.raises(ConfigError, match="real vendor files .* not found"):
        real_formats_file("pd0", "x.PD0")
