"""Writers for what the command-line uses produce: trajectory CSV, TUM file, JSON summary, per-epoch CSV.

* Trajectory CSV (:func:`write_trajectory_csv`): one row per output epoch, columns :data:`CSV_COLUMNS`
  (SI units and frames in the names; attitude as aerospace roll/pitch/yaw, ``C_b_n = Rz Ry Rx``; ``sigma_*``
  are 1-sigma from the estimator's velocity covariance, empty when it has none), then the ``health`` column:
  ``ok``, ``degraded`` or ``diverged`` (:func:`graphnav.estimators.health.epoch_health`; empty when the
  solution does not say).
* TUM file (:func:`write_tum`): ``timestamp tx ty tz qx qy qz qw`` per line, position in local NED (m) and
  the body-to-NED rotation as a unit quaternion, the format the ``evo`` tools read;
  :func:`write_reference_tum` writes the ground truth at the estimate's stamps, so that
  ``evo_ape tum groundtruth.tum trajectory.tum`` pairs every epoch at its defaults.
* Every position written follows :data:`graphnav.core.mission.NED_ORIGIN_CONVENTION`: NED from the sea
  surface above the first fix, down = absolute depth.
* JSON summary (:func:`write_json`): plain JSON (NaN written as ``null``), indented.
* :class:`EpochCsvWriter`: the online mode's output, one row appended *and flushed* per epoch so a crash or
  Ctrl-C keeps every estimate produced so far; it reopens an existing file for ``--resume`` and reports the
  last epoch written (a torn last line from a crash is cut off first).
"""
from __future__ import annotations

import csv
import json
import math
import os
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from graphnav.core.errors import DataError
from graphnav.core.mission import GroundTruth
from graphnav.core.rotations import C_b_n_to_euler, euler_to_C_b_n
from graphnav.core.solution import NavSolution

#: Columns of the trajectory CSV and of the per-epoch CSV (same layout).
CSV_COLUMNS: tuple[str, ...] = (
    "t_s",
    "p_north_m", "p_east_m", "p_down_m",
    "v_north_mps", "v_east_mps", "v_down_mps",
    "roll_rad", "pitch_rad", "yaw_rad",
    "sigma_v_north_mps", "sigma_v_east_mps", "sigma_v_down_mps",
    "bias_acc_x_mps2", "bias_acc_y_mps2", "bias_acc_z_mps2",
    "bias_gyro_x_radps", "bias_gyro_y_radps", "bias_gyro_z_radps",
)


#: The last column of the trajectory and per-epoch CSVs: how far to trust the row (ok / degraded / diverged).
HEALTH_COLUMN = "health"
#: The full header of the trajectory and per-epoch CSVs.
TRAJECTORY_COLUMNS: tuple[str, ...] = CSV_COLUMNS + (HEALTH_COLUMN,)


def _fmt(x: float) -> str:
    # Empty cell for "not available"; 10 significant digits keeps mm over km and nrad/s.
    return "" if x is None or not math.isfinite(x) else f"{x:.10g}"


def _fmt_t(x: float) -> str:
    # Stamps to the microsecond whatever their size: 10 significant digits would cut a Unix stamp to 1 s.
    return "" if x is None or not math.isfinite(x) else (f"{x:.6f}".rstrip("0").rstrip(".") or "0")


def _fmt_row(row) -> str:
    return ",".join([_fmt_t(float(row[0]))] + [_fmt(float(x)) for x in row[1:]])


def written_stamp(t: float) -> float:
    """A stamp as the CSV writers hold it (to the microsecond): what a reader of the file gets back."""
    return float(_fmt_t(float(t)))


def solution_rows(sol: NavSolution) -> np.ndarray:
    """(K, len(CSV_COLUMNS)) float array of a solution in CSV column order (NaN where not available)."""
    k = len(sol.t)
    nan3 = np.full((k, 3), np.nan)
    sigma = nan3 if sol.cov_v_n is None else np.sqrt(np.clip(np.diagonal(sol.cov_v_n, axis1=1, axis2=2), 0, None))
    return np.column_stack([
        sol.t, sol.p_n, sol.v_n, C_b_n_to_euler(sol.C_b_n).reshape(k, 3), sigma,
        nan3 if sol.bias_acc is None else sol.bias_acc,
        nan3 if sol.bias_gyro is None else sol.bias_gyro,
    ])


def write_trajectory_csv(path: str | Path, sol: NavSolution) -> Path:
    """Write a whole solution as a CSV with header :data:`CSV_COLUMNS`; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    health = sol.info.get("health_state") if sol.info else None
    if health is None or len(health) != len(sol.t):
        health = [""] * len(sol.t)
    with path.open("w", newline="") as fh:
        fh.write(",".join(TRAJECTORY_COLUMNS) + "\n")
        for row, state in zip(solution_rows(sol), health):
            fh.write(_fmt_row(row) + "," + (state or "") + "\n")
    return path


def write_tum(path: str | Path, sol: NavSolution) -> Path:
    """Write ``timestamp tx ty tz qx qy qz qw`` lines (TUM format for evo): NED position, body-to-NED quaternion."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    quat_xyzw = Rotation.from_matrix(sol.C_b_n).as_quat()
    # One sign convention (qw >= 0) so diffs between runs are meaningful.
    quat_xyzw *= np.where(quat_xyzw[:, 3:4] < 0, -1.0, 1.0)
    data = np.column_stack([sol.t, sol.p_n, quat_xyzw])
    np.savetxt(path, data, fmt="%.9f", delimiter=" ")
    return path


def write_reference_tum(path: str | Path, sol: NavSolution, gt: GroundTruth) -> Path | None:
    """Write the reference ``gt`` at the estimate's stamps (TUM, as :func:`write_tum`), so that evo's tools at
    their defaults (``evo_ape tum groundtruth.tum trajectory.tum``: stamps matched within 0.01 s) pair every
    epoch: :meth:`GroundTruth.at` (the one GT interpolator) at each of ``sol.t`` inside the GT span (never
    extrapolated; epochs outside are left out). Positions in both files follow
    :data:`graphnav.core.mission.NED_ORIGIN_CONVENTION` (down = absolute depth). Returns the path, or None
    (with a RuntimeWarning, nothing written) when no estimate epoch lies inside the GT span."""
    inside = (sol.t >= gt.t[0]) & (sol.t <= gt.t[-1])
    if not inside.any():
        warnings.warn(f"{path}: not written: no estimate epoch inside the ground truth span "
                      f"[{gt.t[0]:.3f}, {gt.t[-1]:.3f}] s", RuntimeWarning, stacklevel=2)
        return None
    t = sol.t[inside]
    p, v, C = gt.at(t)
    return write_tum(path, NavSolution("GT", t, p, v, C))


def read_tum(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a TUM file: (t (K,), p_n (K,3), C_b_n (K,3,3))."""
    data = np.atleast_2d(np.loadtxt(path))
    return data[:, 0], data[:, 1:4], Rotation.from_quat(data[:, 4:8]).as_matrix()


def read_trajectory_csv(path: str | Path, method: str = "") -> NavSolution:
    """Read a trajectory or per-epoch CSV back into a :class:`NavSolution` (covariance diagonal only).

    Raises:
        DataError: missing column or malformed row, naming file, line and column.
    """
    path = Path(path)
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            raise DataError("file is empty", str(path), 1)
        missing = [c for c in CSV_COLUMNS if c not in header]
        if missing:
            raise DataError("column missing from header", str(path), 1, missing[0])
        idx = [header.index(c) for c in CSV_COLUMNS]
        rows = []
        for line_no, row in enumerate(reader, start=2):
            if len(row) != len(header):
                raise DataError(f"{len(row)} cells, expected {len(header)}", str(path), line_no)
            try:
                rows.append([float(row[i]) if row[i] != "" else np.nan for i in idx])
            except ValueError:
                bad = next(i for i in idx if row[i] != "" and not _is_float(row[i]))
                raise DataError(f"not a number: {row[bad]!r}", str(path), line_no, header[bad]) from None
    data = np.array(rows, dtype=float).reshape(-1, len(CSV_COLUMNS))
    sigma = data[:, 10:13]
    cov = None if np.all(np.isnan(sigma)) else np.einsum("ki,ij->kij", sigma ** 2, np.eye(3))
    return NavSolution(
        method=method, t=data[:, 0], p_n=data[:, 1:4], v_n=data[:, 4:7],
        C_b_n=euler_to_C_b_n(data[:, 7], data[:, 8], data[:, 9]).reshape(-1, 3, 3), cov_v_n=cov,
        bias_acc=None if np.all(np.isnan(data[:, 13:16])) else data[:, 13:16],
        bias_gyro=None if np.all(np.isnan(data[:, 16:19])) else data[:, 16:19])


def _is_float(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def to_jsonable(obj):
    """Plain JSON types: numpy scalars/arrays to Python, NaN/inf to None, paths to str."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: str | Path, data) -> Path:
    """Write ``data`` as indented JSON atomically (temporary file then rename), so a reader never sees half a file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(to_jsonable(data), indent=2) + "\n")
    os.replace(tmp, path)
    return path


class EpochCsvWriter:
    """Append one estimate per epoch to a CSV and flush it at once (online mode).

    Args:
        path: output CSV.
        resume: keep an existing file and append to it (``--resume``); otherwise the file is started anew.
        fsync: also ask the OS to write to disk every epoch (survives a power loss, costs ~ms per epoch).

    Attributes:
        last_t: stamp (s) of the last epoch in the file (None when empty); on resume the caller skips
            epochs with ``t <= last_t``.
        n_written: rows in the file.
    """

    def __init__(self, path: str | Path, resume: bool = False, fsync: bool = False):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fsync = fsync
        self.last_t: float | None = None
        self.n_written = 0
        self._health = True          # the file has the health column (files written before it did not)
        if resume and self.path.exists() and self.path.stat().st_size > 0:
            self._recover()
            self._fh = self.path.open("a", newline="")
        else:
            self._fh = self.path.open("w", newline="")
            self._fh.write(",".join(TRAJECTORY_COLUMNS) + "\n")
            self._fh.flush()

    def _recover(self) -> None:
        """Cut a torn last line (crash mid-write), check the header, find the last stamp."""
        raw = self.path.read_bytes()
        cut = raw.rfind(b"\n") + 1
        if cut < len(raw):
            with self.path.open("r+b") as fh:
                fh.truncate(cut)
            raw = raw[:cut]
        lines = raw.decode().splitlines()
        header = lines[0].split(",") if lines else []
        self._health = header == list(TRAJECTORY_COLUMNS)
        if not self._health and header != list(CSV_COLUMNS):
            raise DataError("cannot resume: header is not graphnav's per-epoch CSV header", str(self.path), 1)
        self.n_written = len(lines) - 1
        if self.n_written:
            try:
                self.last_t = float(lines[-1].split(",", 1)[0])
            except ValueError:
                raise DataError("cannot resume: last row has no time stamp", str(self.path),
                                len(lines), CSV_COLUMNS[0]) from None

    def write(self, t: float, p_n, v_n, C_b_n, cov_v_n=None, bias_acc=None, bias_gyro=None,
              health: str | None = None) -> None:
        """Append one epoch (units as in :data:`CSV_COLUMNS`, then ``health``) and flush."""
        nan3 = (np.nan,) * 3
        sigma = nan3 if cov_v_n is None else np.sqrt(np.clip(np.diagonal(np.asarray(cov_v_n)), 0, None))
        row = [t, *np.asarray(p_n, float), *np.asarray(v_n, float), *C_b_n_to_euler(np.asarray(C_b_n, float)),
               *sigma, *(nan3 if bias_acc is None else bias_acc), *(nan3 if bias_gyro is None else bias_gyro)]
        self._fh.write(_fmt_row(row) + ("," + (health or "") if self._health else "") + "\n")
        self._fh.flush()
        if self.fsync:
            os.fsync(self._fh.fileno())
        self.last_t = float(t)
        self.n_written += 1

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.close()

    def __enter__(self) -> "EpochCsvWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
