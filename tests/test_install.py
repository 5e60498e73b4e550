"""Packaging: the wheel holds only ``graphnav/...``; ``pip install .`` and ``pip install -e .`` both import
``graphnav``, ``graphnav.factors`` and ``graphnav.nets`` and claim no bare ``factors`` / ``nets``.

Builds run on a copy of the project files in a temporary folder, so the checkout gets no ``build/`` or
``*.egg-info`` litter and concurrent work in the checkout cannot disturb them.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIRS = ("graphnav", "factors", "nets")


def _copy_project(dest: Path) -> Path:
    """The files a build needs: pyproject, README/LICENSE, and the three package folders."""
    dest.mkdir(parents=True, exist_ok=True)
    for name in ("pyproject.toml", "README.md", "LICENSE", "setup.cfg", "MANIFEST.in"):
        if (ROOT / name).exists():
            shutil.copy2(ROOT / name, dest / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for name in PACKAGE_DIRS:
        shutil.copytree(ROOT / name, dest / name, ignore=ignore)
    return dest


def _run(cmd: list[str], cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, f"{' '.join(map(str, cmd))} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


def test_wheel_holds_only_the_graphnav_package(tmp_path):
    src = _copy_project(tmp_path / "src")
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
          str(tmp_path / "dist"), "."], cwd=src)
    (wheel,) = (tmp_path / "dist").glob("graphnav-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    top = {n.split("/")[0] for n in names}
    assert all(t == "graphnav" or (t.startswith("graphnav-") and t.endswith(".dist-info")) for t in top), top
    assert "factors" not in top and "nets" not in top
    for required in ("graphnav/__init__.py", "graphnav/cli.py", "graphnav/factors/__init__.py",
                     "graphnav/nets/__init__.py", "graphnav/nets/completer.py", "graphnav/sim/simulate.py"):
        assert required in names
    # every module of the three source folders is in the wheel under graphnav/
    for folder, prefix in (("graphnav", "graphnav/"), ("factors", "graphnav/factors/"), ("nets", "graphnav/nets/")):
        for py in (ROOT / folder).rglob("*.py"):
            rel = py.relative_to(ROOT / folder).as_posix()
            if "__pycache__" not in rel:
                assert prefix + rel in names, f"{folder}/{rel} missing from the wheel"
    weights = ROOT / "nets" / "weights"
    if weights.is_dir():
        for f in weights.iterdir():
            if f.suffix in (".pt", ".json", ".md"):
                assert f"graphnav/nets/weights/{f.name}" in names, f"nets/weights/{f.name} missing from the wheel"
    entry_points = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    assert "graphnav = graphnav.cli:main" in zipfile.ZipFile(wheel).read(entry_points).decode()


_PROBE = textwrap.dedent("""
    import importlib, json
    out = {}
    for name in ("graphnav", "graphnav.factors", "graphnav.nets"):
        out[name] = importlib.import_module(name).__file__
    for name in ("factors", "nets"):
        try:
            importlib.import_module(name)
            out[name] = "importable"
        except ImportError:
            out[name] = None
    print(json.dumps(out))
""")


def _fresh_venv(path: Path) -> Path:
    """A new venv that sees the outer venv's third-party packages through a ``.pth`` line.

    A path listed in a ``.pth`` file is only appended to ``sys.path``; the ``.pth`` files *inside* it (the
    outer venv's editable-install finder for graphnav) are not run, so the outer graphnav stays invisible.
    """
    # --without-pip: ensurepip would bring an old setuptools that shadows the outer one; the outer pip and
    # setuptools, run by the inner interpreter, install into the inner venv.
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(path)], check=True)
    python = path / "bin" / "python"
    inner_site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                capture_output=True, text=True, check=True).stdout.strip()
    outer_site = sysconfig.get_paths()["purelib"]
    Path(inner_site, "outer_site_packages.pth").write_text(outer_site + "\n")
    return python


@pytest.mark.slow
@pytest.mark.parametrize("editable", [False, True], ids=["install", "editable"])
def test_fresh_venv_install_imports_the_three_packages(tmp_path, editable):
    src = _copy_project(tmp_path / "src")
    python = _fresh_venv(tmp_path / "venv")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    cmd = [str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--no-index"]
    _run(cmd + (["-e", "."] if editable else ["."]), cwd=src, env=env)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = json.loads(_run([str(python), "-c", _PROBE], cwd=elsewhere, env=env).stdout.strip().splitlines()[-1])
    assert out["factors"] is None and out["nets"] is None, out
    files = {name: Path(out[name]).resolve() for name in ("graphnav", "graphnav.factors", "graphnav.nets")}
    if editable:
        # the editable install points at the source folders of the (copied) checkout
        assert files["graphnav"] == (src / "graphnav" / "__init__.py").resolve()
        assert files["graphnav.factors"] == (src / "factors" / "__init__.py").resolve()
        assert files["graphnav.nets"] == (src / "nets" / "__init__.py").resolve()
    else:
        site = (tmp_path / "venv").resolve()
        for name, f in files.items():
            assert site in f.parents, f"{name} imported from {f}, not from the fresh venv"
        assert files["graphnav.factors"].parent.name == "factors" and files["graphnav.factors"].parent.parent.name == "graphnav"
        assert files["graphnav.nets"].parent.parent.name == "graphnav"
    # the console entry point works too
    _run([str(tmp_path / "venv" / "bin" / "graphnav"), "--help"], cwd=elsewhere, env=env)
