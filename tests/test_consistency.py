"""Consistency tools (NEES band, reference covariance, report section, NEES plot) and noise identification."""
from __future__ import annotations

import numpy as np
import pytest

from graphnav.calibration.noise import allan_deviation, identify, white_density
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.runs import run_graph
from graphnav.evaluation.bench import mission_nees, nees_section
from graphnav.evaluation.consistency import (
    chi2_band,
    n_independent,
    nees_time_series,
    nees_with_reference,
)
from graphnav.evaluation.metrics import nees_velocity
from graphnav.evaluation.plots import plot_nees
from graphnav.sim.simulate import simulate_mission


@pytest.fixture(scope="module")
def mission_and_solution():
    m = simulate_mission(120, seed=5)
    sol = run_graph(m, options=GraphOptions(dvl_error_states=True))
    return m, sol


def test_chi2_band():
    lo, hi = chi2_band(1)
    assert lo == pytest.approx(0.2158, abs=1e-3) and hi == pytest.approx(9.348, abs=1e-3)
    lo, hi = chi2_band(1000)
    assert 2.8 < lo < 3.0 < hi < 3.2
    assert n_independent(np.arange(0, 100.0)) == 10


def test_reference_covariance_lowers_nees(mission_and_solution):
    m, sol = mission_and_solution
    plain = nees_velocity(sol, m.gt, 30.0)
    np.testing.assert_allclose(nees_with_reference(sol, m.gt, np.zeros((3, 3)), 30.0), plain)
    assert np.mean(nees_with_reference(sol, m.gt, np.eye(3) * 0.01 ** 2, 30.0)) < np.mean(plain)
    t, nees = nees_time_series(sol, m.gt, 30.0)
    assert len(t) == len(nees) == len(plain) and t[0] >= 30.0


def test_nees_section_and_plot(mission_and_solution, tmp_path):
    m, sol = mission_and_solution
    m.meta["gt_velocity_sigma_n"] = [0.005, 0.005, 0.005]
    scores = mission_nees(sol, m)
    assert scores["nees_mission_gt"] < scores["nees_mission"]
    records = [{"trajectory": f"t{i}", "scenario": "none", "imu_grade": "as-recorded", "method": "Graph-TC",
                "nees_window": 3.0 + i, **scores} for i in range(2)]
    text = "\n".join(nees_section(records, ["as-recorded"], ["none"], ["Graph-TC"]))
    assert "### NEES: as-recorded, none" in text and "| Graph-TC |" in text and "%" in text
    path = plot_nees(m, [sol], [], tmp_path / "nees.png", "test")
    assert path.exists() and path.stat().st_size > 1000


def test_allan_white_density():
    rng = np.random.default_rng(0)
    density, rate = 2e-3, 100.0
    x = rng.normal(0, density * np.sqrt(rate), (60000, 3))
    adev = allan_deviation(x, rate, [1, 10, 100])
    np.testing.assert_allclose(adev[:, 0] * np.sqrt([0.01, 0.1, 1.0]), density, rtol=0.1)
    assert white_density(x, rate) == pytest.approx(density, rel=0.05)


def test_identify_beam_noise_and_exact_gt(mission_and_solution):
    """On a simulated mission the beam noise comes back within 10 % and the (exact) GT gets a small error."""
    m, _ = mission_and_solution
    est = identify(m)
    assert est.beam_noise_std == pytest.approx(m.config.dvl.beam_noise_std, rel=0.1)
    assert max(est.gt_velocity_sigma_n) < 0.01
    assert est.accel_noise_density > 0 and est.gyro_noise_density > 0


def test_imu_carried_reference_between_sparse_samples(mission_and_solution):
    """A 1 Hz GT carried to off-sample stamps by the IMU matches the full-rate GT there far better than its
    linear interpolation does, and is exact at its own samples; the bench's NEES is scored against it."""
    import dataclasses

    from graphnav.evaluation.consistency import imu_carried_reference, mission_reference
    m, sol = mission_and_solution
    gt = m.gt
    step = int(round(1.0 / np.median(np.diff(gt.t))))
    sparse = dataclasses.replace(m, gt=gt.take(np.arange(0, len(gt.t), step)))
    t = sparse.gt.t[5:-5] + 0.37
    v_true = gt.at(t)[1]
    ref = imu_carried_reference(t, sparse)
    np.testing.assert_array_equal(ref.t, t)
    err_carried = np.sqrt(np.mean(np.sum((ref.v_n - v_true) ** 2, axis=1)))
    err_linear = np.sqrt(np.mean(np.sum((sparse.gt.at(t)[1] - v_true) ** 2, axis=1)))
    assert err_carried < 0.005 and err_carried < 0.5 * err_linear
    on_samples = imu_carried_reference(sparse.gt.t[3:9], sparse)
    np.testing.assert_allclose(on_samples.v_n, sparse.gt.v_n[3:9], atol=1e-9)
    own = mission_reference(sol, sparse)
    inside = (sol.t >= sparse.gt.t[0]) & (sol.t <= sparse.gt.t[-1])
    np.testing.assert_array_equal(own.t, sol.t[inside])
