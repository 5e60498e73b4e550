"""Earth model for local-area navigation in a NED frame (WGS84).

The navigation frame n is a local-level NED frame. For AUV missions (a few km), transport rate is
neglected; Earth rotation and normal gravity at the mission latitude are kept, as in GTSAM's
``NavState`` Coriolis handling.
"""
from __future__ import annotations

import numpy as np

WGS84_A = 6378137.0                 # semi-major axis, m
WGS84_E2 = 6.69437999014e-3         # first eccentricity squared
EARTH_RATE = 7.292115e-5            # rad/s
GAMMA_E = 9.7803253359              # normal gravity at equator, m/s^2
SOMIGLIANA_K = 1.931852652458e-3


def gravity_magnitude(lat_rad: float, depth_m: float = 0.0) -> float:
    """WGS84 normal gravity (Somigliana) at latitude ``lat_rad`` and ``depth_m`` below the ellipsoid, m/s^2.

    The free-air gradient (3.086e-6 s^-2) is applied with the sign of height (depth is negative height);
    inside water the true gradient differs slightly, which is far below IMU bias levels here.
    """
    s2 = np.sin(lat_rad) ** 2
    g0 = GAMMA_E * (1 + SOMIGLIANA_K * s2) / np.sqrt(1 - WGS84_E2 * s2)
    return float(g0 + 3.086e-6 * depth_m)


def gravity_n(lat_rad: float, depth_m: float = 0.0) -> np.ndarray:
    """Gravity vector in NED (positive down), m/s^2."""
    return np.array([0.0, 0.0, gravity_magnitude(lat_rad, depth_m)])


def earth_rate_n(lat_rad: float) -> np.ndarray:
    """Earth rotation rate expressed in NED, rad/s."""
    return EARTH_RATE * np.array([np.cos(lat_rad), 0.0, -np.sin(lat_rad)])


def radii_of_curvature(lat_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Meridian (R_M) and prime-vertical (R_N) radii of curvature, m."""
    s2 = np.sin(lat_rad) ** 2
    r_n = WGS84_A / np.sqrt(1 - WGS84_E2 * s2)
    r_m = WGS84_A * (1 - WGS84_E2) / (1 - WGS84_E2 * s2) ** 1.5
    return r_m, r_n


def lla_to_ned(lat_rad: np.ndarray, lon_rad: np.ndarray, alt_m: np.ndarray,
               origin: tuple[float, float, float]) -> np.ndarray:
    """Local NED position (N,3) in m of geodetic points relative to ``origin = (lat, lon, alt)``.

    Uses the curvature radii at the origin (accurate to mm over the few-km extent of a mission).
    """
    lat0, lon0, alt0 = origin
    r_m, r_n = radii_of_curvature(lat0)
    north = (np.asarray(lat_rad) - lat0) * (r_m + alt0)
    east = (np.asarray(lon_rad) - lon0) * (r_n + alt0) * np.cos(lat0)
    down = -(np.asarray(alt_m) - alt0)
    return np.stack([north, east, down], axis=-1)


def ned_to_lla(p_n: np.ndarray, origin: tuple[float, float, float]) -> np.ndarray:
    """Inverse of :func:`lla_to_ned`: (N,3) NED in m to (N,3) [lat rad, lon rad, alt m]."""
    lat0, lon0, alt0 = origin
    r_m, r_n = radii_of_curvature(lat0)
    p_n = np.asarray(p_n, dtype=float)
    lat = lat0 + p_n[..., 0] / (r_m + alt0)
    lon = lon0 + p_n[..., 1] / ((r_n + alt0) * np.cos(lat0))
    alt = alt0 - p_n[..., 2]
    return np.stack([lat, lon, alt], axis=-1)
