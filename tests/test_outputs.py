"""Output writers: trajectory CSV and TUM formats, JSON, and the flushed per-epoch CSV with resume."""
from __future__ import annotations

import json

import numpy as np
import pytest

from graphnav.core.errors import DataError
from graphnav.core.rotations import euler_to_C_b_n
from graphnav.core.solution import NavSolution
from graphnav.io.outputs import (
    CSV_COLUMNS,
    EpochCsvWriter,
    read_trajectory_csv,
    read_tum,
    write_json,
    write_trajectory_csv,
    write_tum,
)


def make_solution(k: int = 50, seed: int = 0, cov: bool = True) -> NavSolution:
    rng = np.random.default_rng(seed)
    t = 10.0 + np.arange(k) * 0.5
    rpy = rng.uniform([-0.3, -0.3, -3.0], [0.3, 0.3, 3.0], (k, 3))
    sig = rng.uniform(0.01, 0.2, (k, 3))
    return NavSolution(
        method="fake", t=t, p_n=rng.normal(0, 300, (k, 3)), v_n=rng.normal(0, 2, (k, 3)),
        C_b_n=euler_to_C_b_n(rpy[:, 0], rpy[:, 1], rpy[:, 2]),
        cov_v_n=np.einsum("ki,ij->kij", sig ** 2, np.eye(3)) if cov else None,
        bias_acc=rng.normal(0, 1e-3, (k, 3)), bias_gyro=None)


def test_trajectory_csv_round_trip(tmp_path):
    sol = make_solution()
    path = write_trajectory_csv(tmp_path / "traj.csv", sol)
    lines = path.read_text().splitlines()
    assert lines[0].split(",") == list(CSV_COLUMNS) + ["health"]
    assert len(lines) == len(sol.t) + 1
    # Missing gyro bias is written as empty cells, not "nan" (and no health: the solution does not say).
    assert lines[1].endswith(",,,,") and "nan" not in path.read_text()
    back = read_trajectory_csv(path)
    np.testing.assert_allclose(back.t, sol.t)
    np.testing.assert_allclose(back.p_n, sol.p_n, atol=1e-6)
    np.testing.assert_allclose(back.v_n, sol.v_n, atol=1e-8)
    np.testing.assert_allclose(back.C_b_n, sol.C_b_n, atol=1e-8)
    np.testing.assert_allclose(back.cov_v_n, sol.cov_v_n, rtol=1e-8)
    np.testing.assert_allclose(back.bias_acc, sol.bias_acc, atol=1e-12)
    assert back.bias_gyro is None


def test_trajectory_csv_health_column(tmp_path):
    sol = make_solution()
    states = ["ok"] * (len(sol.t) - 2) + ["degraded", "diverged"]
    sol.info["health_state"] = states
    lines = write_trajectory_csv(tmp_path / "traj.csv", sol).read_text().splitlines()
    assert [x.rsplit(",", 1)[1] for x in lines[1:]] == states
    np.testing.assert_allclose(read_trajectory_csv(tmp_path / "traj.csv").t, sol.t)


def test_csv_reader_names_bad_cell(tmp_path):
    path = write_trajectory_csv(tmp_path / "traj.csv", make_solution(5))
    lines = path.read_text().splitlines()
    cells = lines[3].split(",")
    cells[4] = "abc"
    lines[3] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError) as err:
        read_trajectory_csv(path)
    assert err.value.line == 4 and err.value.field == CSV_COLUMNS[4]


def test_tum_format(tmp_path):
    sol = make_solution(cov=False)
    path = write_tum(tmp_path / "traj.tum", sol)
    rows = [line.split(" ") for line in path.read_text().splitlines()]
    assert all(len(r) == 8 for r in rows) and len(rows) == len(sol.t)
    q = np.array([[float(x) for x in r[4:8]] for r in rows])  # qx qy qz qw
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-8)
    assert np.all(q[:, 3] >= 0)
    t, p, C = read_tum(path)
    np.testing.assert_allclose(t, sol.t, atol=1e-9)
    np.testing.assert_allclose(p, sol.p_n, atol=1e-8)
    np.testing.assert_allclose(C, sol.C_b_n, atol=1e-7)
    # The quaternion is the body-to-NED rotation: rotating body x gives the first column of C_b_n.
    from scipy.spatial.transform import Rotation
    np.testing.assert_allclose(Rotation.from_quat(q).apply([1, 0, 0]), sol.C_b_n[:, :, 0], atol=1e-7)


def test_write_json_nan_is_null(tmp_path):
    path = write_json(tmp_path / "s.json", {"a": float("nan"), "b": np.float32(1.5), "c": np.arange(3)})
    assert json.loads(path.read_text()) == {"a": None, "b": 1.5, "c": [0, 1, 2]}
    assert not (tmp_path / "s.json.tmp").exists()


def _write_epochs(writer, sol, idx):
    for k in idx:
        writer.write(sol.t[k], sol.p_n[k], sol.v_n[k], sol.C_b_n[k], sol.cov_v_n[k], sol.bias_acc[k], None)


def test_epoch_writer_flushes_each_epoch(tmp_path):
    sol = make_solution(10)
    path = tmp_path / "online.csv"
    writer = EpochCsvWriter(path)
    for k in range(3):
        _write_epochs(writer, sol, [k])
        # Another reader sees the row while the writer is still open: nothing waits in a buffer.
        assert len(path.read_text().splitlines()) == k + 2
    writer.close()
    back = read_trajectory_csv(path)
    np.testing.assert_allclose(back.v_n, sol.v_n[:3], atol=1e-8)


def test_epoch_writer_resume_after_torn_line(tmp_path):
    sol = make_solution(10)
    path = tmp_path / "online.csv"
    with EpochCsvWriter(path) as w:
        _write_epochs(w, sol, range(6))
    # A crash mid-write leaves half a line.
    text = path.read_text()
    path.write_text(text + "13.5,1.0,2.")
    with EpochCsvWriter(path, resume=True) as w:
        assert w.n_written == 6 and w.last_t == pytest.approx(sol.t[5])
        _write_epochs(w, sol, [k for k in range(10) if sol.t[k] > w.last_t])
    back = read_trajectory_csv(path)
    np.testing.assert_allclose(back.t, sol.t)
    np.testing.assert_allclose(back.p_n, sol.p_n, atol=1e-6)


def test_epoch_writer_fresh_start_and_bad_resume(tmp_path):
    sol = make_solution(4)
    path = tmp_path / "online.csv"
    with EpochCsvWriter(path) as w:
        _write_epochs(w, sol, range(4))
    with EpochCsvWriter(path) as w:  # no resume: starts over
        assert w.last_t is None
    assert len(path.read_text().splitlines()) == 1
    with EpochCsvWriter(path, resume=True) as w:  # header only: nothing to skip
        assert w.last_t is None and w.n_written == 0
    other = tmp_path / "other.csv"
    other.write_text("time,x\n1,2\n")
    with pytest.raises(DataError, match="header"):
        EpochCsvWriter(other, resume=True)
