"""Where the real data sets live.

The data are never copied into the repository. ``GRAPHNAV_DATA`` names the folder that holds
``snapir-2022-akit/`` and ``snapir-2021-beamsnet/``; without it, ``../shared/data`` next to the checkout
(or next to the current directory) is used.
"""
from __future__ import annotations

import os
from pathlib import Path

AKIT_DIRNAME = "snapir-2022-akit"
BEAMSNET_DIRNAME = "snapir-2021-beamsnet"


def data_root() -> Path | None:
    """The data folder, or None if it cannot be found."""
    env = os.environ.get("GRAPHNAV_DATA")
    if env:
        return Path(env)
    candidates = [Path(__file__).resolve().parents[1].parent / "shared" / "data",
                  Path.cwd().parent / "shared" / "data", Path.cwd() / "shared" / "data"]
    for cand in candidates:
        if cand.is_dir():
            return cand
    return None


def akit_dir() -> Path | None:
    """``<data>/snapir-2022-akit`` if present."""
    root = data_root()
    return root / AKIT_DIRNAME if root is not None and (root / AKIT_DIRNAME).is_dir() else None


def beamsnet_dir() -> Path | None:
    """``<data>/snapir-2021-beamsnet`` if present."""
    root = data_root()
    return root / BEAMSNET_DIRNAME if root is not None and (root / BEAMSNET_DIRNAME).is_dir() else None


REAL_FORMATS_DIRNAME = "real-formats"


def real_formats_dir() -> Path | None:
    """``<data>/real-formats`` (real vendor files: ``pd0/`` RDI ensembles, ...) if present."""
    root = data_root()
    return root / REAL_FORMATS_DIRNAME if root is not None and (root / REAL_FORMATS_DIRNAME).is_dir() else None


# --- for studies and benchmarks: the data they need, or a clear error ------------------------------------------
def _missing(what: str, option: str | None) -> "ConfigError":
    from graphnav.core.errors import ConfigError
    where = f"give {option} or " if option else ""
    return ConfigError(f"{what} not found: {where}set GRAPHNAV_DATA to the folder holding {what} (see "
                       "graphnav.io.paths)")


def akit_trajectories(root: str | Path | None = None, names=None, option: str | None = "--data") -> list[Path]:
    """The A-KIT ``TrajectoryN`` folders (sorted by N) under ``root`` (default: :func:`akit_dir`), only those in
    ``names`` when given (``"Trajectory5"``, ``"5"`` or 5).

    Raises:
        ConfigError: no A-KIT folder, no trajectory in it, or a name that is not there (naming ``option``, the
        command-line option that sets ``root``).
    """
    from graphnav.core.errors import ConfigError
    from graphnav.io.loaders import list_akit
    folder = Path(root) if root is not None else akit_dir()
    if folder is None:
        raise _missing(f"the A-KIT data ({AKIT_DIRNAME})", option)
    found = list_akit(folder)
    if not found:
        raise ConfigError(f"{option + ' ' if option else ''}{folder}: no TrajectoryN folders with their IMU, DVL "
                          "and GT files")
    if names:
        wanted = [str(n) if str(n).startswith("Trajectory") else f"Trajectory{n}" for n in names]
        unknown = sorted(set(wanted) - {f.name for f in found})
        if unknown:
            raise ConfigError(f"{', '.join(unknown)}: not under {folder} (it holds "
                              f"{', '.join(f.name for f in found)})")
        found = [f for f in found if f.name in wanted]
    return found


def real_formats_file(*parts: str, option: str | None = None) -> Path:
    """A file of the real vendor files, ``<data>/real-formats/<parts...>``.

    Raises:
        ConfigError: the real-formats folder or the file is not there.
    """
    from graphnav.core.errors import ConfigError
    root = real_formats_dir()
    if root is None:
        raise _missing(f"the real vendor files ({REAL_FORMATS_DIRNAME})", option)
    path = root.joinpath(*parts)
    if not path.exists():
        raise ConfigError(f"{path}: not found in the real vendor files")
    return path
