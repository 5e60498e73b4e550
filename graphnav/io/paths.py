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
