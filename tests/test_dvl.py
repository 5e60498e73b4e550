"""DVL beam geometry, least-squares velocity and the beam error model."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphnav.core.config import DEG, DvlSpec
from graphnav.core.dvl import DvlErrorModel, DvlGeometry, beam_matrix, make_beams
from graphnav.core.errors import ConfigError, GeometryError


@pytest.fixture
def geometry():
    spec = DvlSpec(C_d_b=Rotation.from_euler("z", 45.0, degrees=True).as_matrix(),
                   lever_arm_b=np.array([-1.86, -0.04, 0.2]))
    return DvlGeometry.from_spec(spec)


def test_beam_matrix_rows_are_unit_vectors_at_theta_from_the_axis():
    theta = 20.0 * DEG
    psi = np.deg2rad([45.0, 135.0, 225.0, 315.0])
    T = beam_matrix(theta, psi)
    assert T.shape == (4, 3)
    np.testing.assert_allclose(np.linalg.norm(T, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.arccos(T[:, 2]), theta, atol=1e-12)        # angle to the DVL z axis
    np.testing.assert_allclose(np.arctan2(T[:, 1], T[:, 0]) % (2 * np.pi), psi, atol=1e-12)
    # Janus configuration: opposite beams cancel horizontally, so T^T T is diagonal.
    gram = T.T @ T
    np.testing.assert_allclose(gram, np.diag([2 * np.sin(theta) ** 2, 2 * np.sin(theta) ** 2,
                                              4 * np.cos(theta) ** 2]), atol=1e-14)


def test_body_beam_matrix_includes_the_mounting_rotation(geometry):
    v_b = np.array([1.5, -0.2, 0.1])
    v_d = geometry.C_d_b.T @ v_b
    np.testing.assert_allclose(geometry.beams_from_velocity(v_b), geometry.T_d @ v_d, atol=1e-15)


def test_least_squares_recovers_the_velocity_from_4_and_from_3_beams(geometry):
    rng = np.random.default_rng(0)
    v_b = rng.normal(0.0, 1.0, (50, 3))
    omega_b = rng.normal(0.0, 0.1, (50, 3))
    beams = geometry.beams_from_velocity(v_b, omega_b)
    head = v_b + np.cross(omega_b, geometry.lever_arm_b)
    np.testing.assert_allclose(geometry.velocity_from_beams(beams), head, atol=1e-12)
    for missing in range(4):
        valid = np.ones((50, 4), bool)
        valid[:, missing] = False
        np.testing.assert_allclose(geometry.velocity_from_beams(beams, valid), head, atol=1e-12)
    # one epoch (4,) in, (3,) out; NaN beams count as missing
    one = beams[0].copy()
    one[2] = np.nan
    np.testing.assert_allclose(geometry.velocity_from_beams(one), head[0], atol=1e-12)


def test_fewer_than_three_beams_is_an_error_naming_the_epoch(geometry):
    beams = geometry.beams_from_velocity(np.array([[1.0, 0.0, 0.0]] * 3))
    valid = np.ones((3, 4), bool)
    valid[1, [0, 2]] = False
    with pytest.raises(GeometryError, match=r"epoch 1: 2 valid beams"):
        geometry.velocity_from_beams(beams, valid)
    out = geometry.velocity_from_beams(beams, valid, allow_missing=True)
    assert np.isnan(out[1]).all() and np.isfinite(out[[0, 2]]).all()


def test_error_model_statistics(geometry):
    model = DvlErrorModel(scale_factor=np.array([0.01, -0.02, 0.005]),
                          beam_bias=np.array([0.01, -0.02, 0.0, 0.03]), noise_std=0.042)
    n = 20000
    v = np.tile([1.8, 0.1, 0.05], (n, 1))
    beams = model.beams(geometry, v, np.random.default_rng(3))
    clean = ((v @ geometry.C_d_b) * (1 + model.scale_factor)) @ geometry.T_d.T
    residual = beams - clean
    # per beam: mean = bias within 4 sigma/sqrt(n), std within 3 % of the noise
    np.testing.assert_allclose(residual.mean(axis=0), model.beam_bias, atol=4 * 0.042 / np.sqrt(n))
    np.testing.assert_allclose(residual.std(axis=0), 0.042, rtol=0.03)
    # the noise of different beams is independent
    corr = np.corrcoef(residual.T)
    assert np.abs(corr[~np.eye(4, dtype=bool)]).max() < 0.05


def test_make_beams_is_seeded_and_uses_the_spec():
    spec = DvlSpec(beam_noise_std=0.0, beam_bias=np.zeros(4), scale_factor=np.zeros(3))
    v = np.array([[1.0, 0.2, -0.1], [2.0, 0.0, 0.0]])
    np.testing.assert_allclose(make_beams(v, spec), DvlGeometry.from_spec(spec).beams_from_velocity(v),
                               atol=1e-15)
    noisy = DvlSpec()
    np.testing.assert_array_equal(make_beams(v, noisy, seed=4), make_beams(v, noisy, seed=4))
    assert not np.array_equal(make_beams(v, noisy, seed=4), make_beams(v, noisy, seed=5))


def test_spec_rejects_a_non_rotation():
    with pytest.raises(ConfigError):
        DvlSpec(C_d_b=np.diag([1.0, 1.0, 2.0]))


def test_spec_rejects_a_reflection_and_beams_off_plus_z():
    # Orthogonal but det -1: the DVL frame mirrored (e.g. an instrument's z flipped alone).
    with pytest.raises(ConfigError, match="determinant -1"):
        DvlSpec(C_d_b=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ConfigError, match="determinant -1"):
        DvlSpec(C_d_b=np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    DvlSpec(C_d_b=np.diag([1.0, -1.0, -1.0]))               # a 180 deg roll is a rotation
    with pytest.raises(ConfigError, match="inclination"):
        DvlSpec(theta_rad=np.deg2rad(160.0))
