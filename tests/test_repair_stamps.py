"""A log with a duplicated stamp (two rows with other values): refused with the file, line and the way out;
`--repair-stamps` reads it, drops the later row (warned and counted) and leaves every other row as read."""
from __future__ import annotations

import argparse
import shutil

import numpy as np
import pytest

from graphnav.commands.common import add_mission_arguments, recorded_mission
from graphnav.core.errors import DataError
from graphnav.io.loaders import read_mission

pytestmark = pytest.mark.realdata


@pytest.fixture()
def duplicated(akit_dir, tmp_path):
    folder = tmp_path / "Trajectory1"
    shutil.copytree(akit_dir / "Trajectory1", folder)
    imu = folder / "IMU_trajectory1.csv"
    lines = imu.read_text().splitlines()
    # file line 801 (data row 800) written twice, the second time with another gyro z: two samples under one stamp
    # (a row written twice exactly is dropped without --repair-stamps)
    lines.insert(801, lines[800].rsplit(",", 1)[0] + ",0.0123")
    imu.write_text("\n".join(lines) + "\n")
    return folder


def _args(argv):
    parser = argparse.ArgumentParser()
    add_mission_arguments(parser)
    return parser.parse_args(argv)


def test_a_duplicated_stamp_is_refused_with_its_line_and_the_option(duplicated):
    with pytest.raises(DataError, match=r"line 802.*--repair-stamps"):
        read_mission(duplicated)
    with pytest.raises(DataError, match="--repair-stamps"):
        recorded_mission(_args(["--data", str(duplicated)]))


def test_repair_stamps_drops_the_duplicate_and_counts_it(duplicated, akit_dir):
    with pytest.warns(UserWarning, match="1 duplicated"):
        repaired = read_mission(duplicated, repair=True)
    clean = read_mission(akit_dir / "Trajectory1")
    assert repaired.meta["streams"]["imu"]["refused"]["duplicated stamp (repair)"] == 1
    np.testing.assert_array_equal(repaired.imu.t, clean.imu.t)
    np.testing.assert_array_equal(repaired.imu.f_b, clean.imu.f_b)
    with pytest.warns(UserWarning):
        prepared = recorded_mission(_args(["--data", str(duplicated), "--repair-stamps"]))
    assert prepared.meta["prepared"] and len(prepared.imu.t) == len(clean.imu.t)
