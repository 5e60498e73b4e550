"""Writers for what the command-line uses produce: trajectory CSV, TUM file, JSON summary, per-epoch CSV.

* Trajectory CSV (:func:`write_trajectory_csv`): one row per output epoch, columns :data:`CSV_COLUMNS`
  (SI units and frames in the names; attitude as aerospace roll/pitch/yaw, ``C_b_n = Rz Ry Rx``; ``sigma_*``
  are 1-sigma from the estimator's velocity, position and attitude covariances -- velocity and position NED,
  m/s and m; roll, pitch and yaw (heading) in rad like the angles -- empty cells when it has none, e.g. no
  position sigma from the paper's 12-state EKF), then the ``health`` column:
  ``ok``, ``degraded`` or ``diverged`` (:func:`graphnav.estimators.health.epoch_health`; empty when the
  solution does not say).
* TUM file (:func:`write_tum`): ``timestamp tx ty tz qx qy qz qw`` per line, position in local NED (m) and
  the body-to-NED rotation as a unit quaternion, the format the ``evo`` tools read; beside it
  :func:`write_pose_covariance_csv` (``trajectory_cov.csv``) holds each line's position covariance (NED, m^2),
  attitude covariance (body axes, rad^2) and velocity covariance (NED, m^2/s^2), which TUM has no place for;
  :func:`write_reference_tum` writes the ground truth at the estimate's stamps (``graphnav smooth``: carried there
  by the IMU) and in the estimate's frame, so that ``evo_ape tum groundtruth.tum trajectory.tum`` pairs every
  epoch at its defaults and compares positions in one frame.
* Every position written follows :data:`graphnav.core.mission.NED_ORIGIN_CONVENTION`: NED from the sea
  surface above the first fix, down = absolute depth; where that origin is on Earth (or that it is unknown, for a
  run started without its position) is the summary's ``position_frame``
  (:func:`graphnav.core.solution.position_frame`), which ``graphnav evaluate`` reads beside the file.
* JSON summary (:func:`write_json`): plain JSON (NaN written as ``null``), indented;
  :func:`uncertainty_summary` is what a summary says about the run's own uncertainty.
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
from graphnav.core.rotations import (
    C_b_n_to_euler,
    euler_covariance,
    euler_jacobian,
    euler_to_C_b_n,
    heading_variance,
)
from graphnav.core.solution import NavSolution
from graphnav.core.timeseries import finite_rows

#: The columns every trajectory CSV graphnav wrote has (files from before the position and attitude sigmas
#: were written still read and resume).
BASE_COLUMNS: tuple[str, ...] = (
    "t_s",
    "p_north_m", "p_east_m", "p_down_m",
    "v_north_mps", "v_east_mps", "v_down_mps",
    "roll_rad", "pitch_rad", "yaw_rad",
    "sigma_v_north_mps", "sigma_v_east_mps", "sigma_v_down_mps",
    "bias_acc_x_mps2", "bias_acc_y_mps2", "bias_acc_z_mps2",
    "bias_gyro_x_radps", "bias_gyro_y_radps", "bias_gyro_z_radps",
)
#: 1-sigma of the position (NED, m) and of roll, pitch and yaw (heading) (rad), from the estimator's own
#: position covariance and attitude covariance (:func:`graphnav.core.rotations.euler_covariance`); empty cells
#: when it has none (the paper's 12-state EKF has no position uncertainty).
SIGMA_COLUMNS: tuple[str, ...] = (
    "sigma_p_north_m", "sigma_p_east_m", "sigma_p_down_m",
    "sigma_roll_rad", "sigma_pitch_rad", "sigma_yaw_rad",
)
#: Columns of the trajectory CSV and of the per-epoch CSV (same layout).
CSV_COLUMNS: tuple[str, ...] = BASE_COLUMNS + SIGMA_COLUMNS


#: The last column of the trajectory and per-epoch CSVs: how far to trust the row (ok / degraded / diverged).
HEALTH_COLUMN = "health"
#: The full header of the trajectory and per-epoch CSVs.
TRAJECTORY_COLUMNS: tuple[str, ...] = CSV_COLUMNS + (HEALTH_COLUMN,)
#: Headers of per-epoch CSVs ``--resume`` continues: today's and the earlier layouts (without the position and
#: attitude sigmas, without the health column).
RESUMABLE_HEADERS: tuple[tuple[str, ...], ...] = (TRAJECTORY_COLUMNS, CSV_COLUMNS, BASE_COLUMNS + (HEALTH_COLUMN,),
                                                  BASE_COLUMNS)


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


def _sigmas(cov, k: int) -> np.ndarray:
    """(k,3) square roots of the diagonals of (k,3,3) covariances; NaN when there are none."""
    if cov is None:
        return np.full((k, 3), np.nan)
    return np.sqrt(np.clip(np.diagonal(np.asarray(cov, float).reshape(k, 3, 3), axis1=1, axis2=2), 0, None))


def _rows(t, p_n, v_n, C_b_n, cov_v_n=None, bias_acc=None, bias_gyro=None, cov_p_n=None,
          cov_rot_b=None) -> np.ndarray:
    """(K, len(CSV_COLUMNS)) rows of K epochs (arrays with a leading K axis; None = not available: NaN)."""
    C_b_n = np.asarray(C_b_n, float).reshape(-1, 3, 3)
    k = len(C_b_n)
    nan3 = np.full((k, 3), np.nan)
    att = None if cov_rot_b is None else euler_covariance(C_b_n, np.asarray(cov_rot_b, float).reshape(k, 3, 3))
    return np.column_stack([
        np.asarray(t, float).reshape(k), np.asarray(p_n, float).reshape(k, 3), np.asarray(v_n, float).reshape(k, 3),
        C_b_n_to_euler(C_b_n).reshape(k, 3), _sigmas(cov_v_n, k),
        nan3 if bias_acc is None else np.asarray(bias_acc, float).reshape(k, 3),
        nan3 if bias_gyro is None else np.asarray(bias_gyro, float).reshape(k, 3),
        _sigmas(cov_p_n, k), _sigmas(att, k),
    ])


def solution_rows(sol: NavSolution) -> np.ndarray:
    """(K, len(CSV_COLUMNS)) float array of a solution in CSV column order (NaN where not available)."""
    return _rows(sol.t, sol.p_n, sol.v_n, sol.C_b_n, sol.cov_v_n, sol.bias_acc, sol.bias_gyro, sol.cov_p_n,
                 sol.cov_rot_b)


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
    # stamps to the microsecond, as the CSV files hold them: a trajectory.csv scored against a TUM reference then
    # meets it at the same first stamp (at the nanosecond the first epoch fell 0.2 microseconds outside)
    np.savetxt(path, data, fmt=["%.6f"] + ["%.9f"] * 7, delimiter=" ")
    return path


#: Columns of the covariance file written beside a TUM trajectory (:func:`write_pose_covariance_csv`): the
#: stamp, the upper triangle of the position covariance (NED, m^2), of the attitude covariance (GTSAM's right
#: perturbation ``C_b_n = C_hat Exp(theta)``, theta in body axes, rad^2) and of the velocity covariance (NED,
#: m^2/s^2; the trajectory CSV keeps only its diagonal's square roots).
POSE_COV_COLUMNS: tuple[str, ...] = (
    "t_s",
    "p_nn_m2", "p_ne_m2", "p_nd_m2", "p_ee_m2", "p_ed_m2", "p_dd_m2",
    "rot_b_xx_rad2", "rot_b_xy_rad2", "rot_b_xz_rad2", "rot_b_yy_rad2", "rot_b_yz_rad2", "rot_b_zz_rad2",
    "v_nn_m2_s2", "v_ne_m2_s2", "v_nd_m2_s2", "v_ee_m2_s2", "v_ed_m2_s2", "v_dd_m2_s2",
)
#: The header of a covariance file written before the velocity block, which still reads (no velocity covariance).
POSE_COV_COLUMNS_WITHOUT_VELOCITY = POSE_COV_COLUMNS[:13]
_UPPER = np.triu_indices(3)


def write_pose_covariance_csv(path: str | Path, sol: NavSolution) -> Path:
    """Write the position, attitude and velocity covariances of every epoch of ``sol``, one row per line of the TUM
    file :func:`write_tum` writes (same stamps): columns :data:`POSE_COV_COLUMNS`. The estimators carry them as
    separate marginals (no cross-covariance between them), so the three 3x3 blocks are written, not a 9x9 with
    made-up zero cross blocks. A block the estimator does not provide (e.g. the position of the paper's 12-state
    EKF) is written as empty cells. Returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    k = len(sol.t)
    nan6 = np.full((k, 6), np.nan)
    blocks = [nan6 if c is None else np.asarray(c, float).reshape(k, 3, 3)[:, _UPPER[0], _UPPER[1]]
              for c in (sol.cov_p_n, sol.cov_rot_b, sol.cov_v_n)]
    with path.open("w", newline="") as fh:
        fh.write(",".join(POSE_COV_COLUMNS) + "\n")
        for t, row in zip(sol.t, np.hstack(blocks)):
            fh.write(f"{t:.9f}," + ",".join(_fmt(float(x)) for x in row) + "\n")
    return path


def read_pose_covariance_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None,
                                                         np.ndarray | None]:
    """Read :func:`write_pose_covariance_csv`'s file: (t (K,), cov_p_n (K,3,3), cov_rot_b (K,3,3), cov_v_n
    (K,3,3)); None for a block whose cells are all empty, and for the velocity of a file written before it
    (:data:`POSE_COV_COLUMNS_WITHOUT_VELOCITY`).

    Raises:
        DataError: another header or a malformed row, naming file, line and column.
    """
    path = Path(path)
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None or tuple(header) not in (POSE_COV_COLUMNS, POSE_COV_COLUMNS_WITHOUT_VELOCITY):
            raise DataError("header is not graphnav's pose covariance header", str(path), 1)
        rows = []
        for line_no, row in enumerate(reader, start=2):
            if len(row) != len(header):
                raise DataError(f"{len(row)} cells, expected {len(header)}", str(path), line_no)
            bad = next((i for i, c in enumerate(row) if c != "" and not _is_float(c)), None)
            if bad is not None:
                raise DataError(f"not a number: {row[bad]!r}", str(path), line_no, header[bad])
            rows.append([float(c) if c != "" else np.nan for c in row])
    data = np.array(rows, dtype=float).reshape(-1, len(header))

    def symmetric(upper: np.ndarray) -> np.ndarray | None:
        if np.all(np.isnan(upper)):
            return None
        cov = np.empty((len(upper), 3, 3))
        cov[:, _UPPER[0], _UPPER[1]] = upper
        cov[:, _UPPER[1], _UPPER[0]] = upper
        return cov

    velocity = symmetric(data[:, 13:19]) if data.shape[1] > 13 else None
    return data[:, 0], symmetric(data[:, 1:7]), symmetric(data[:, 7:13]), velocity


def uncertainty_summary(sol: NavSolution) -> dict:
    """What a run's summary says about its own uncertainty: the 1-sigma position (N, E, D, m) at the last
    epoch, the horizontal position sigma ``sqrt(P_nn + P_ee)`` (m) at the end and its largest value over the
    run, the heading sigma (deg) at the end and its largest value, and the velocity sigma at the end (NED, m/s).
    A quantity the estimator does not provide is None, and ``not_estimated`` names it (e.g. ``"position"`` for
    the paper's 12-state EKF)."""
    out: dict = {"not_estimated": [name for name, cov in (("position", sol.cov_p_n), ("attitude", sol.cov_rot_b),
                                                          ("velocity", sol.cov_v_n)) if cov is None]}
    if not len(sol.t):
        return out
    horizontal = heading = None
    if sol.cov_p_n is not None:
        horizontal = np.sqrt(np.clip(sol.cov_p_n[:, 0, 0] + sol.cov_p_n[:, 1, 1], 0, None))
    if sol.cov_rot_b is not None:
        heading = np.rad2deg(np.sqrt(np.clip(heading_variance(sol.C_b_n, sol.cov_rot_b), 0, None)))
    out.update({
        "final_position_sigma_ned_m": None if sol.cov_p_n is None else _sigmas(sol.cov_p_n[-1:], 1)[0],
        "final_horizontal_position_sigma_m": None if horizontal is None else float(horizontal[-1]),
        "max_horizontal_position_sigma_m": None if horizontal is None else float(np.nanmax(horizontal)),
        "final_heading_sigma_deg": None if heading is None else float(heading[-1]),
        "max_heading_sigma_deg": None if heading is None else float(np.nanmax(heading)),
        "final_velocity_sigma_ned_mps": None if sol.cov_v_n is None else _sigmas(sol.cov_v_n[-1:], 1)[0],
    })
    return out


def write_reference_tum(path: str | Path, sol: NavSolution, gt: GroundTruth,
                        shift_n: np.ndarray | None = None) -> Path | None:
    """Write the reference ``gt`` at the estimate's stamps (TUM, as :func:`write_tum`), so that evo's tools at
    their defaults (``evo_ape tum groundtruth.tum trajectory.tum``: stamps matched within 0.01 s) pair every
    epoch: :meth:`GroundTruth.at` (the one GT interpolator) at each of ``sol.t`` inside the GT span (never
    extrapolated; epochs outside are left out). ``graphnav smooth`` passes the reference already carried to the
    estimate's stamps by the IMU (:func:`graphnav.evaluation.consistency.scoring_reference`), which it returns
    unchanged. ``shift_n`` (K,3) m, one row per estimate epoch, carries the reference into the estimate's frame
    (:func:`graphnav.evaluation.metrics.frame_shift`, the summary's ``position_frame``), so that evo compares like
    with like for a run placed by an initial latitude/longitude or a fix, or started without its position; None:
    written as it is; an epoch whose shift is not finite (the frame unknown there) is left out, warned with the
    count. Positions in both files follow
    :data:`graphnav.core.mission.NED_ORIGIN_CONVENTION` (down = absolute depth). Returns the path, or None
    (with a RuntimeWarning, nothing written) when no estimate epoch lies inside the GT span."""
    inside = (sol.t >= gt.t[0]) & (sol.t <= gt.t[-1])
    if not inside.any():
        warnings.warn(f"{path}: not written: no estimate epoch inside the ground truth span "
                      f"[{gt.t[0]:.3f}, {gt.t[-1]:.3f}] s", RuntimeWarning, stacklevel=2)
        return None
    if shift_n is not None:
        unknown = inside & ~finite_rows(np.asarray(shift_n, float))
        if unknown.any():
            warnings.warn(f"{path}: {int(unknown.sum())} epoch(s) left out (t = {sol.t[unknown][0]:.3f} s first): "
                          "the estimate's frame is not known there (no finite estimate on their side of the fix "
                          "that placed it)", RuntimeWarning, stacklevel=2)
            inside &= ~unknown
            if not inside.any():
                return None
    t = sol.t[inside]
    p, v, C = gt.at(t)
    if shift_n is not None:
        p = p + np.asarray(shift_n, float)[inside]
    return write_tum(path, NavSolution("GT", t, p, v, C))


def read_tum(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a TUM file: (t (K,), p_n (K,3), C_b_n (K,3,3))."""
    data = np.atleast_2d(np.loadtxt(path))
    return data[:, 0], data[:, 1:4], Rotation.from_quat(data[:, 4:8]).as_matrix()


def read_trajectory_csv(path: str | Path, method: str = "") -> NavSolution:
    """Read a trajectory or per-epoch CSV back into a :class:`NavSolution`.

    The covariances are what the file holds, the sigmas: ``cov_v_n`` and ``cov_p_n`` diagonal, and
    ``cov_rot_b`` the body-axes covariance whose roll, pitch and yaw variances are the file's with no
    correlation between them (so :func:`graphnav.core.rotations.heading_variance` gives the written heading
    sigma back). A covariance whose sigma columns are empty (or absent: files from before the position and
    attitude sigmas) is None.

    Raises:
        DataError: missing column or malformed row, naming file, line and column.
    """
    path = Path(path)
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            raise DataError("file is empty", str(path), 1)
        missing = [c for c in BASE_COLUMNS if c not in header]
        if missing:
            raise DataError("column missing from header", str(path), 1, missing[0])
        idx = [header.index(c) if c in header else None for c in CSV_COLUMNS]
        present = [i for i in idx if i is not None]
        rows = []
        for line_no, row in enumerate(reader, start=2):
            if len(row) != len(header):
                raise DataError(f"{len(row)} cells, expected {len(header)}", str(path), line_no)
            try:
                rows.append([float(row[i]) if i is not None and row[i] != "" else np.nan for i in idx])
            except ValueError:
                bad = next(i for i in present if row[i] != "" and not _is_float(row[i]))
                raise DataError(f"not a number: {row[bad]!r}", str(path), line_no, header[bad]) from None
    data = np.array(rows, dtype=float).reshape(-1, len(CSV_COLUMNS))
    col = {name: i for i, name in enumerate(CSV_COLUMNS)}

    def block(first: str) -> np.ndarray:
        return data[:, col[first]:col[first] + 3]

    C_b_n = euler_to_C_b_n(data[:, 7], data[:, 8], data[:, 9]).reshape(-1, 3, 3)
    return NavSolution(
        method=method, t=data[:, 0], p_n=data[:, 1:4], v_n=data[:, 4:7], C_b_n=C_b_n,
        cov_v_n=_diagonal_cov(block("sigma_v_north_mps")),
        bias_acc=None if np.all(np.isnan(block("bias_acc_x_mps2"))) else block("bias_acc_x_mps2"),
        bias_gyro=None if np.all(np.isnan(block("bias_gyro_x_radps"))) else block("bias_gyro_x_radps"),
        cov_p_n=_diagonal_cov(block("sigma_p_north_m")),
        cov_rot_b=_attitude_cov(C_b_n, block("sigma_roll_rad")))


def _diagonal_cov(sigma: np.ndarray) -> np.ndarray | None:
    return None if np.all(np.isnan(sigma)) else np.einsum("ki,ij->kij", sigma ** 2, np.eye(3))


def _attitude_cov(C_b_n: np.ndarray, sigma_rpy: np.ndarray) -> np.ndarray | None:
    """Body-axes attitude covariance whose roll/pitch/yaw covariance is ``diag(sigma_rpy^2)``."""
    cov_euler = _diagonal_cov(sigma_rpy)
    if cov_euler is None:
        return None
    # a row without an attitude (an estimator that lost track) has no covariance either: NaN, not an SVD failure
    out = np.full_like(cov_euler, np.nan)
    ok = finite_rows(C_b_n)
    J_inv = np.linalg.inv(euler_jacobian(C_b_n[ok]))
    out[ok] = J_inv @ cov_euler[ok] @ np.swapaxes(J_inv, -1, -2)
    return out


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
        # the layout of the file: a resumed file keeps the one it was started with (files written before the
        # health column, or before the position and attitude sigmas, had fewer columns)
        self._columns = TRAJECTORY_COLUMNS
        if resume and self.path.exists() and self.path.stat().st_size > 0:
            self._recover()
            self._fh = self.path.open("a", newline="")
        else:
            self._fh = self.path.open("w", newline="")
            self._fh.write(",".join(TRAJECTORY_COLUMNS) + "\n")
            self._fh.flush()
        self._health = self._columns[-1] == HEALTH_COLUMN
        self._take = [CSV_COLUMNS.index(c) for c in self._columns if c != HEALTH_COLUMN]

    def _recover(self) -> None:
        """Cut a torn last line (crash mid-write), check the header, find the last stamp."""
        raw = self.path.read_bytes()
        cut = raw.rfind(b"\n") + 1
        if cut < len(raw):
            with self.path.open("r+b") as fh:
                fh.truncate(cut)
            raw = raw[:cut]
        lines = raw.decode().splitlines()
        header = tuple(lines[0].split(",")) if lines else ()
        if header not in RESUMABLE_HEADERS:
            raise DataError("cannot resume: header is not graphnav's per-epoch CSV header", str(self.path), 1)
        self._columns = header
        self.n_written = len(lines) - 1
        if self.n_written:
            try:
                self.last_t = float(lines[-1].split(",", 1)[0])
            except ValueError:
                raise DataError("cannot resume: last row has no time stamp", str(self.path),
                                len(lines), CSV_COLUMNS[0]) from None

    def write(self, t: float, p_n, v_n, C_b_n, cov_v_n=None, bias_acc=None, bias_gyro=None,
              health: str | None = None, cov_p_n=None, cov_rot_b=None) -> None:
        """Append one epoch (units as in :data:`CSV_COLUMNS`, then ``health``) and flush; the covariances
        (``cov_v_n`` NED (m/s)^2, ``cov_p_n`` NED m^2, ``cov_rot_b`` body-axes right perturbation rad^2) give
        the sigma columns, None = empty cells."""
        row = _rows(t, p_n, v_n, C_b_n, cov_v_n, bias_acc, bias_gyro, cov_p_n, cov_rot_b)[0][self._take]
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
