"""Write a :class:`~graphnav.core.mission.Mission` in the published A-KIT CSV layout.

``<folder>/TrajectoryN/{IMU,DVL,GT}_trajectoryN.csv`` with exactly the published column headers, so
:mod:`graphnav.io.loaders` reads a simulated mission like a recorded one. Differences from the published
files, on purpose:

* the stamps are the streams' own (the published ones are ``linspace(0, 400, N)``, which the reader
  rescales; a folder written here it reads with its stamps as written);
* the IMU is written in the body frame FRD as it is (the published files have a flipped y axis);
* the ground truth is at the IMU point (the published one is the INS's point, about 1.9 m from it);
* the DVL file holds the DVL-head velocity (least squares of the valid beams) of every ping with >= 3
  valid beams, in the frame the reader expects (the configuration's ``C_d_b`` and
  ``velocity_scale_correction`` undone; the body frame with the defaults); pings with fewer are left out (the
  published files have no gaps to encode);
* two extra files: ``beams_trajectoryN.csv`` (the four along-beam velocities, empty where a beam is
  invalid) and ``config_trajectoryN.json`` (the :class:`SensorConfig`, with the axis signs and time offsets
  the files need: none). :func:`graphnav.io.loaders.read_mission` reads such a folder as it was written: with
  that configuration, the GT at the IMU point, and the written beams of the pings whose DVL velocity they
  give (``graphnav simulate --out DIR`` then ``graphnav smooth --data DIR/Trajectory1`` round trips).

Ground truth: geodetic position from the NED origin ``gt.origin_lla`` (``Altitude`` negative below the
surface), NED velocity, roll/pitch/yaw with ``C_b_n = Rz(yaw) Ry(pitch) Rx(roll)``.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from graphnav.core.errors import DataError
from graphnav.core.mission import Mission
from graphnav.core.rotations import C_b_n_to_euler
from graphnav.io.loaders import AKIT_COLUMNS, WRITTEN_BEAM_COLUMNS


def _write_csv(path: Path, columns: tuple[str, ...], data: np.ndarray) -> None:
    # 15 significant digits: round trips to ~1e-15 relative, far below any sensor resolution.
    np.savetxt(path, data, delimiter=",", header=",".join(columns), comments="", fmt="%.15g")


def write_akit(mission: Mission, folder: str | Path, number: int = 1) -> dict[str, Path]:
    """Write ``mission`` as ``folder/Trajectory<number>/`` in the A-KIT layout; returns the written paths. The
    files hold the mission's data as it is (prepared: axis signs and time offsets applied, the reference at the IMU
    point), and the configuration written beside them says so (``imu_axis_signs`` (1, 1, 1), time offsets 0 s), so
    that reading the folder gives the mission back."""
    if mission.gt is None or mission.gt.origin_lla is None:
        raise DataError("the A-KIT layout needs ground truth with a known geodetic origin",
                        mission.name, field="gt.origin_lla")
    out = Path(folder) / f"Trajectory{number}"
    out.mkdir(parents=True, exist_ok=True)
    paths = {kind: out / f"{kind}_trajectory{number}.csv" for kind in ("IMU", "DVL", "GT", "beams")}
    paths["config"] = out / f"config_trajectory{number}.json"

    imu = mission.imu
    _write_csv(paths["IMU"], AKIT_COLUMNS["IMU"], np.column_stack([imu.t, imu.f_b, imu.omega_b]))

    dvl = mission.dvl
    v_b = dvl.v_b if dvl.v_b is not None else np.full((len(dvl.t), 3), np.nan)
    ok = np.isfinite(v_b).all(axis=1)
    # the reader takes the DVL file for the instrument's own velocity and turns it to the body with the
    # configuration's C_d_b and scale correction: write what it turns back into v_b. A ping without a velocity
    # (fewer than three beams) keeps its row, NaN, so that its beams in the beams file come back with it.
    spec = mission.config.dvl
    v_file = np.full_like(v_b, np.nan)
    v_file[ok] = (v_b[ok] * (1.0 + spec.velocity_scale_correction)) @ spec.C_d_b
    _write_csv(paths["DVL"], AKIT_COLUMNS["DVL"], np.column_stack([dvl.t, v_file]))
    beams = np.where(dvl.valid, dvl.beams, np.nan)
    _write_csv(paths["beams"], WRITTEN_BEAM_COLUMNS, np.column_stack([dvl.t, beams]))
    text = paths["beams"].read_text().replace("nan", "")
    paths["beams"].write_text(text)

    gt = mission.gt
    lla = gt.lla
    euler = C_b_n_to_euler(gt.C_b_n)
    _write_csv(paths["GT"], AKIT_COLUMNS["GT"],
               np.column_stack([gt.t, lla[:, 1], lla[:, 0], lla[:, 2], gt.v_n, euler]))
    # the GT is written where the mission holds it, at the IMU point: no reference point to move it from; the files
    # hold the prepared data, its axis signs and time offsets applied, so the next read has none left to apply
    dataclasses.replace(mission.config, reference_position_b=None, imu_axis_signs=(1.0, 1.0, 1.0),
                        gt_time_offset_s=0.0, dvl_time_offset_s=0.0).save(paths["config"])
    return paths
