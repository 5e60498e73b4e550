"""Shared fixtures. Real-data tests read ../shared/data (or $GRAPHNAV_DATA) and skip when it is absent."""
from __future__ import annotations

import pytest

from graphnav.io import paths


@pytest.fixture(scope="session")
def akit_dir():
    d = paths.akit_dir()
    if d is None:
        pytest.skip("real A-KIT data not found: set GRAPHNAV_DATA or place it at ../shared/data/snapir-2022-akit")
    return d


@pytest.fixture(scope="session")
def beamsnet_dir():
    d = paths.beamsnet_dir()
    if d is None:
        pytest.skip("real BeamsNet data not found: set GRAPHNAV_DATA or place it at ../shared/data/snapir-2021-beamsnet")
    return d
