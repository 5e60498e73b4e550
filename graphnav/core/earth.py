"""Earth model of graphnav (WGS84): the one place gravity, Earth rate and geodetic conversions live.

The navigation frame n is a **fixed, Earth-fixed tangent frame**: NED axes at the mission origin (latitude
``lat_rad``, height ``alt_m``), which turn with the Earth but not with the vehicle. In this frame the exact
strapdown equations are

- attitude  ``dC_b_n/dt = C_b_n [omega_ib_b]x - [omega_ie_n]x C_b_n``   (no transport rate: the axes are fixed)
- velocity  ``dv_n/dt = C_b_n f_b + g_n(p_n) - 2 omega_ie_n x v_n``
- position  ``dp_n/dt = v_n``

with ``g_n(p_n)`` the plumb-bob gravity (gravitation plus centrifugal, WGS84 normal gravity) at the point
``p_n``, expressed in the origin's axes. It is not constant: away from the origin the local vertical tilts
towards the origin by ``|p_h| / R`` (``-g/R`` ~ 1.5e-6 m/s^2 per metre of horizontal displacement) and its
magnitude grows ~3.1e-6 m/s^2 per metre of depth. A constant ``[0, 0, g]`` makes a pure-inertial solution
drift ~17 m in 400 s on a 2 m/s track; :meth:`EarthModel.gravity_n` is exact (ECEF round trip) over any
distance. Because the frame does not rotate with respect to the Earth, GTSAM's ``omegaCoriolis = omega_ie_n``
treatment is exact for it, and the centrifugal term is inside ``g_n``.

Outputs: attitude and velocity are in the origin's axes; :meth:`EarthModel.local_rotation` turns them to
the local NED at a point (0.27 deg per 30 km). Depth sensors measure depth below the geoid, not the
tangent plane's ``down``: :meth:`EarthModel.depth_of` is the height relation (the tangent plane rises
``|p_h|^2 / 2R`` above the ellipsoid: 0.016 m at 440 m, 7.8 m at 10 km).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

WGS84_A = 6378137.0                 # semi-major axis, m
WGS84_F = 1.0 / 298.257223563       # flattening
WGS84_E2 = 6.69437999014e-3         # first eccentricity squared
WGS84_GM = 3.986004418e14           # m^3/s^2
EARTH_RATE = 7.292115e-5            # rad/s
GAMMA_E = 9.7803253359              # normal gravity at equator, m/s^2
SOMIGLIANA_K = 1.931852652458e-3
_WGS84_M = EARTH_RATE ** 2 * WGS84_A ** 2 * WGS84_A * (1 - WGS84_F) / WGS84_GM


def gravity_magnitude(lat_rad, depth_m=0.0):
    """WGS84 normal gravity at latitude ``lat_rad`` and ``depth_m`` below the ellipsoid, m/s^2.

    Somigliana's closed form on the ellipsoid with the WGS84 second-order height correction
    (``-2 g / a (1 + f + m - 2 f sin^2 lat) h + 3 g h^2 / a^2``, ~3.086e-6 s^-2; depth is negative height).
    Inside water the true gradient differs slightly, far below IMU bias levels. Scalar in, float out;
    arrays broadcast.
    """
    s2 = np.sin(lat_rad) ** 2
    g0 = GAMMA_E * (1 + SOMIGLIANA_K * s2) / np.sqrt(1 - WGS84_E2 * s2)
    h = -np.asarray(depth_m, dtype=float)
    g = g0 * (1 - 2 / WGS84_A * (1 + WGS84_F + _WGS84_M - 2 * WGS84_F * s2) * h + 3 * h ** 2 / WGS84_A ** 2)
    return float(g) if np.ndim(g) == 0 else g


def gravity_n(lat_rad: float, depth_m: float = 0.0) -> np.ndarray:
    """Gravity vector in the local NED at a point (positive down), m/s^2."""
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


def C_n_e(lat_rad, lon_rad) -> np.ndarray:
    """NED-to-ECEF rotation(s) (...,3,3): columns are north, east, down in ECEF."""
    sl, cl = np.sin(lat_rad), np.cos(lat_rad)
    so, co = np.sin(lon_rad), np.cos(lon_rad)
    z = np.zeros_like(np.asarray(sl, dtype=float))
    north = np.stack([-sl * co, -sl * so, cl + z], axis=-1)
    east = np.stack([-so + z, co + z, z], axis=-1)
    down = np.stack([-cl * co, -cl * so, -sl], axis=-1)
    return np.stack([north, east, down], axis=-1)


def lla_to_ecef(lat_rad, lon_rad, alt_m) -> np.ndarray:
    """Geodetic (rad, rad, m) to ECEF (...,3), m."""
    _, r_n = radii_of_curvature(lat_rad)
    cl = np.cos(lat_rad)
    return np.stack([(r_n + alt_m) * cl * np.cos(lon_rad), (r_n + alt_m) * cl * np.sin(lon_rad),
                     (r_n * (1 - WGS84_E2) + alt_m) * np.sin(lat_rad)], axis=-1)


def ecef_to_lla(r_e: np.ndarray) -> np.ndarray:
    """ECEF (...,3), m, to geodetic (...,3) [lat rad, lon rad, alt m] (fixed point on latitude; 1e-12 rad)."""
    r_e = np.asarray(r_e, dtype=float)
    if r_e.shape == (3,):
        return np.array(_ecef_to_lla_one(*r_e.tolist()))
    x, y, z = r_e[..., 0], r_e[..., 1], r_e[..., 2]
    rho = np.hypot(x, y)
    lat = np.arctan2(z, rho * (1 - WGS84_E2))
    for _ in range(6):          # converges ~1e-3 per step near the surface: 6 steps reach rounding
        _, r_n = radii_of_curvature(lat)
        alt = rho / np.cos(lat) - r_n
        lat = np.arctan2(z, rho * (1 - WGS84_E2 * r_n / (r_n + alt)))
    _, r_n = radii_of_curvature(lat)
    alt = rho / np.cos(lat) - r_n
    return np.stack([lat, np.arctan2(y, x), alt], axis=-1)


def _ecef_to_lla_one(x: float, y: float, z: float) -> tuple[float, float, float]:
    """:func:`ecef_to_lla` of one point in Python floats: the same iteration, without numpy's per-call cost on
    0-d arrays (the estimators convert one point per keyframe; ~10x faster, equal to rounding)."""
    rho = math.hypot(x, y)
    lat = math.atan2(z, rho * (1 - WGS84_E2))
    for _ in range(6):
        r_n = WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(lat) ** 2)
        alt = rho / math.cos(lat) - r_n
        lat = math.atan2(z, rho * (1 - WGS84_E2 * r_n / (r_n + alt)))
    r_n = WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(lat) ** 2)
    return lat, math.atan2(y, x), rho / math.cos(lat) - r_n


@dataclass(frozen=True)
class EarthModel:
    """The Earth seen from a fixed NED tangent frame at a mission origin (see the module docstring).

    Attributes:
        lat_rad: origin latitude, rad.
        gravity_mps2: gravity magnitude at the origin, m/s^2 (a measured value may replace the model's; the
            model then adds only its variation with position).
        alt_m: origin height above the ellipsoid, m (depth is negative height).
        earth_rotation: whether the Earth rotates (False: no Earth rate, for idealised tests).
        gravity_variation: whether gravity varies with position (False: the constant ``[0, 0, g]`` of a
            flat-Earth model, kept to measure what the variation is worth).
    """

    lat_rad: float
    gravity_mps2: float
    alt_m: float = 0.0
    earth_rotation: bool = True
    gravity_variation: bool = True

    @classmethod
    def from_config(cls, config) -> "EarthModel":
        """The model of a :class:`graphnav.core.config.SensorConfig` (latitude, gravity at the origin, Earth
        rotation, gravity variation); the origin is on the ellipsoid (heights are relative: only the 1e-12
        s^-2/m curvature of the free-air term depends on it)."""
        return cls(float(config.lat_rad), float(config.gravity_mps2), 0.0, bool(config.earth_rotation),
                   bool(config.gravity_variation))

    @property
    def omega_ie_n(self) -> np.ndarray:
        """Earth rate in the navigation frame, rad/s (zeros without Earth rotation)."""
        return earth_rate_n(self.lat_rad) if self.earth_rotation else np.zeros(3)

    @functools.cached_property
    def _origin(self) -> tuple[np.ndarray, np.ndarray]:
        # computed once per model (the estimators ask at every keyframe; the model is frozen)
        r0, C0 = lla_to_ecef(self.lat_rad, 0.0, self.alt_m), C_n_e(self.lat_rad, 0.0)
        r0.flags.writeable = C0.flags.writeable = False
        return r0, C0

    def to_lla(self, p_n: np.ndarray) -> np.ndarray:
        """Geodetic (...,3) [lat rad, lon rad relative to the origin's meridian, alt m] of tangent-frame
        points ``p_n`` (...,3), m (exact)."""
        r0, C0 = self._origin
        return ecef_to_lla(r0 + np.einsum("ij,...j->...i", C0, np.asarray(p_n, dtype=float)))

    def from_lla(self, lla: np.ndarray) -> np.ndarray:
        """Tangent-frame positions (...,3), m, of geodetic points (...,3) [lat rad, lon rad relative to the
        origin's meridian, alt m] (exact inverse of :meth:`to_lla`)."""
        lla = np.asarray(lla, dtype=float)
        r0, C0 = self._origin
        r = lla_to_ecef(lla[..., 0], lla[..., 1], lla[..., 2])
        return np.einsum("ji,...j->...i", C0, r - r0)

    def depth_of(self, p_n: np.ndarray) -> np.ndarray:
        """Depth below the origin's height (what a pressure sensor zeroed at the origin reads), m, of
        tangent-frame points ``p_n`` (...,3): ``p_down`` plus the curvature drop ``|p_h|^2 / 2R``."""
        return self.alt_m - self.to_lla(p_n)[..., 2]

    def local_rotation(self, p_n: np.ndarray) -> np.ndarray:
        """Rotation(s) (...,3,3) from the origin's NED axes to the local NED axes at ``p_n`` (apply it on the
        left of ``C_b_n`` or ``v_n`` to get the local attitude or velocity)."""
        lla = self.to_lla(p_n)
        _, C0 = self._origin
        return np.swapaxes(C_n_e(lla[..., 0], lla[..., 1]), -1, -2) @ C0

    def gravity_n(self, p_n: np.ndarray) -> np.ndarray:
        """Plumb-bob gravity (...,3), m/s^2, at tangent-frame points ``p_n`` (...,3) m, in the origin's axes.

        ``[0, 0, gravity_mps2]`` at the origin; elsewhere along the local vertical of the point (the ellipsoid
        normal at its latitude, turned into the origin's axes), with the model's change of magnitude from the
        origin added to ``gravity_mps2`` (so a measured value at the origin keeps its offset from the model).
        """
        p_n = np.asarray(p_n, dtype=float)
        if not self.gravity_variation:
            g = np.zeros(p_n.shape)
            g[..., 2] = self.gravity_mps2
            return g
        if p_n.shape == (3,):
            return self._gravity_one(p_n)
        lla = self.to_lla(p_n)
        _, C0 = self._origin
        down = np.einsum("ji,...j->...i", C0, C_n_e(lla[..., 0], lla[..., 1])[..., :, 2])
        mag = self.gravity_mps2 + (gravity_magnitude(lla[..., 0], -lla[..., 2])
                                   - gravity_magnitude(self.lat_rad, -self.alt_m))
        return down * np.asarray(mag)[..., None]

    def _gravity_one(self, p_n: np.ndarray) -> np.ndarray:
        """:meth:`gravity_n` of one point in Python floats (the estimators ask once per keyframe; ~10x faster,
        equal to rounding)."""
        lat, lon, alt = self.to_lla(p_n).tolist()
        cl, sl, co, so = math.cos(lat), math.sin(lat), math.cos(lon), math.sin(lon)
        _, C0 = self._origin
        down = np.einsum("ji,j->i", C0, np.array([-cl * co, -cl * so, -sl]))     # the array path's product
        mag = self.gravity_mps2 + (gravity_magnitude(lat, -alt) - gravity_magnitude(self.lat_rad, -self.alt_m))
        return down * mag

    def gravity_gradient_n(self, p_n: np.ndarray | None = None, step_m: float = 1.0) -> np.ndarray:
        """``d g_n / d p_n`` (3,3), s^-2, at ``p_n`` (default: the origin), by central differences of
        :meth:`gravity_n` (the field is smooth on km scales: 1 m steps are exact to ~1e-13 s^-2).

        About ``diag(-g/R_M, -g/R_N, +2g/R)``: ~-1.5e-6 horizontally (the Schuler coupling), +3.1e-6 in depth.
        """
        p = np.zeros(3) if p_n is None else np.asarray(p_n, dtype=float).reshape(3)
        if not self.gravity_variation:
            return np.zeros((3, 3))
        pts = p + np.concatenate([np.eye(3), -np.eye(3)]) * step_m
        g = self.gravity_n(pts)
        return (g[:3] - g[3:]).T / (2 * step_m)


def lla_to_ned(lat_rad: np.ndarray, lon_rad: np.ndarray, alt_m: np.ndarray,
               origin: tuple[float, float, float]) -> np.ndarray:
    """Tangent-frame NED position (N,3) in m of geodetic points relative to ``origin = (lat, lon, alt)``.

    Exact (through ECEF): the navigation frame is the NED tangent frame at the origin, see
    :class:`EarthModel`. (Its ``down`` differs from ``-(alt - alt0)`` by the curvature drop ``|p_h|^2 / 2R``:
    2 cm at 500 m, 7.8 m at 10 km.)
    """
    lat0, lon0, alt0 = origin
    lla = np.stack(np.broadcast_arrays(np.asarray(lat_rad, float), np.asarray(lon_rad, float) - lon0,
                                       np.asarray(alt_m, float)), axis=-1)
    return EarthModel(float(lat0), gravity_magnitude(lat0, -alt0), float(alt0)).from_lla(lla)


def ned_to_lla(p_n: np.ndarray, origin: tuple[float, float, float]) -> np.ndarray:
    """Inverse of :func:`lla_to_ned`: (N,3) tangent-frame NED in m to (N,3) [lat rad, lon rad, alt m]."""
    lat0, lon0, alt0 = origin
    lla = EarthModel(float(lat0), gravity_magnitude(lat0, -alt0), float(alt0)).to_lla(p_n)
    lla[..., 1] += lon0
    return lla
