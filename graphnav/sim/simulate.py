"""The embedded default mission: a simulated AUV survey with exact ground truth (no download needed).

The vehicle starts at ~2 m depth, descends nose-down (pitch about -15..-19 deg) to 22-28 m, then flies a
lawnmower survey: straight legs of 100-160 s joined by pairs of 90 deg turns (yaw rate up to ~0.1 rad/s),
a depth change (pitch bump) in most legs, new speeds (1.1-2.3 m/s, smooth changes) at the start
and often late in every leg, and roll/pitch/yaw oscillations of a few degrees (periods 8-20 s) with
small sway and heave. The pattern continues for any duration (tested up to 4 h; 21 h simulated for the
Navigator's long-mission benchmark, ``benchmarks/navigator_speed.py --long-hours 21``).

Kinematics are analytic: roll, pitch, yaw and the body velocity ``v_b = [u, v, w]`` are sums of quintic
smooth steps (C2) and sinusoids, so their values and first derivatives are exact. From them

* ``v_n = C_b_n v_b``, ``omega_nb_b`` from the Euler-angle rates, ``a_n = C_b_n (dv_b/dt + omega_nb_b x v_b)``;
* the true specific force and rate in the fixed tangent frame of :class:`graphnav.core.earth.EarthModel`
  (exact there: no transport rate is needed because the axes do not turn with the vehicle)
  ``f_b = C_b_n^T (a_n + 2 omega_ie_n x v_n - g_n(p_n))``, ``omega_ib_b = omega_nb_b + C_b_n^T omega_ie_n``,
  with the plumb-bob gravity ``g_n(p_n)`` at the vehicle's position (it tilts with the distance from the
  origin and grows with depth);
* the position by Gauss-Legendre quadrature of ``v_n`` between output stamps (error far below 1 mm).

The depth sensor reads the depth below the origin's height, :meth:`EarthModel.depth_of` (the tangent plane's
``down`` plus the curvature drop ``|p_h|^2 / 2R``); ground truth is in the tangent frame (position, and
velocity and attitude in the origin's axes).

IMU sample convention (:mod:`graphnav.core.imu_stamps`): the sample stamped ``t_k`` is the *increment* over
``[t_k, t_k + dt]`` divided by ``dt``, as a strapdown IMU outputs it: ``omega_b[k] = Log(C_ib(t_k)^T
C_ib(t_k+dt)) / dt`` and ``f_b[k] = (1/dt) * integral of C_ib(t_k)^T C_ib(tau) f_b(tau) dtau`` (body axes frozen
in inertial space at ``t_k``). Holding sample k constant from ``t_k`` to ``t_{k+1}`` (GTSAM's preintegration)
then reproduces the truth exactly up to the Earth-rate cross terms (~1e-9 rad per step).
Ground truth, DVL and depth are instantaneous values at their
stamps, all of which are IMU stamps (the DVL's unless ``dvl_stamp_offset_s`` moves them between samples).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from graphnav.core.config import DEG, DVL_ERROR_SOURCES, DvlSpec, ImuSpec, SensorConfig
from graphnav.core.config import imu_grade as _imu_grade
from graphnav.core.dvl import DvlErrorModel, DvlGeometry, as_velocity_only
from graphnav.core.earth import EarthModel, gravity_magnitude
from graphnav.core.errors import ConfigError
from graphnav.core.imu_stamps import SAMPLE_CONVENTION
from graphnav.core.mission import DepthData, DvlData, GroundTruth, ImuData, Mission, PositionFixData
from graphnav.core.rotations import euler_to_C_b_n_closed_form
from graphnav.core.scenarios import markov_dropout
from graphnav.sim.imu_errors import corrupt_imu

#: Default DVL lever arm (body frame, m): the DVL sits ~1.9 m aft of the INS, as on the Snapir AUV.
DEFAULT_LEVER_ARM_B = (-1.86, -0.04, 0.2)
#: Default NED origin of the simulated mission (lat rad, lon rad, alt m): off Haifa, at the sea surface.
DEFAULT_ORIGIN_LLA = (32.85 * DEG, 34.95 * DEG, 0.0)
START_DEPTH_M = 2.0


#: Survey patterns of :func:`plan_trajectory`.
PATTERNS = ("lawnmower", "transit")
#: Longest mission the simulator makes, s (24 h; about 3 GB of memory at 21 h).
MAX_DURATION_S = 24 * 3600.0

# --- smooth profile building blocks ------------------------------------------------------------------

def _smoothstep(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic smooth step S(x) on [0,1] with S', S'' (zero slope and curvature at both ends: C2)."""
    s = x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)
    ds = 30.0 * x * x * (1.0 - x) ** 2
    dds = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x)
    return s, ds, dds


@dataclass
class SmoothSteps:
    """A sum of smooth steps: step i rises by ``delta[i]`` between ``t0[i]`` and ``t0[i] + duration[i]``."""

    t0: list = field(default_factory=list)
    duration: list = field(default_factory=list)
    delta: list = field(default_factory=list)

    def add(self, t0: float, duration: float, delta: float) -> int:
        self.t0.append(float(t0))
        self.duration.append(float(duration))
        self.delta.append(float(delta))
        return len(self.delta) - 1

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Value, first and second time derivative at sorted stamps t (s)."""
        t = np.asarray(t, dtype=float)
        completed = np.zeros(len(t) + 1)  # difference array: +delta from the sample where a step is done
        value = np.zeros(len(t))
        rate = np.zeros(len(t))
        acc = np.zeros(len(t))
        for t0, dur, delta in zip(self.t0, self.duration, self.delta):
            i0, i1 = np.searchsorted(t, [t0, t0 + dur])
            completed[i1] += delta
            if i1 > i0:
                s, ds, dds = _smoothstep((t[i0:i1] - t0) / dur)
                value[i0:i1] += delta * s
                rate[i0:i1] += delta * ds / dur
                acc[i0:i1] += delta * dds / dur ** 2
        return value + np.cumsum(completed)[:-1], rate, acc


@dataclass
class Sines:
    """A sum of sinusoids ``amp * sin(2 pi t / period + phase)``."""

    amp: list = field(default_factory=list)
    period: list = field(default_factory=list)
    phase: list = field(default_factory=list)

    def add(self, amp: float, period: float, phase: float) -> None:
        self.amp.append(float(amp))
        self.period.append(float(period))
        self.phase.append(float(phase))

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Value and first time derivative at stamps t (s)."""
        t = np.asarray(t, dtype=float)
        value = np.zeros(len(t))
        rate = np.zeros(len(t))
        for amp, period, phase in zip(self.amp, self.period, self.phase):
            w = 2.0 * np.pi / period
            value += amp * np.sin(w * t + phase)
            rate += amp * w * np.cos(w * t + phase)
        return value, rate

    def acceleration(self, t: np.ndarray) -> np.ndarray:
        """Second time derivative at stamps t (s)."""
        t = np.asarray(t, dtype=float)
        out = np.zeros(len(t))
        for amp, period, phase in zip(self.amp, self.period, self.phase):
            w = 2.0 * np.pi / period
            out -= amp * w * w * np.sin(w * t + phase)
        return out


@dataclass
class TrueState:
    """Exact kinematics at stamps t (all arrays have leading dimension N).

    Attributes:
        t: (N,) s.
        euler: (N,3) roll, pitch, yaw, rad.
        C_b_n: (N,3,3) body-to-NED.
        v_b: (N,3) body velocity, m/s; dv_b: (N,3) its time derivative (body components), m/s^2.
        v_n: (N,3) NED velocity, m/s; a_n: (N,3) NED acceleration, m/s^2.
        omega_nb_b: (N,3) body rate relative to the (Earth-fixed) NED frame, rad/s.
        omega_ib_b: (N,3) body rate relative to inertial space (what a perfect gyro measures), rad/s.
        f_b: (N,3) specific force (what a perfect accelerometer measures), m/s^2.
    """

    t: np.ndarray
    euler: np.ndarray
    C_b_n: np.ndarray
    v_b: np.ndarray
    dv_b: np.ndarray
    v_n: np.ndarray
    a_n: np.ndarray
    omega_nb_b: np.ndarray
    omega_ib_b: np.ndarray
    f_b: np.ndarray


@dataclass
class SimTrajectory:
    """The analytic trajectory of a simulated mission (kept in ``mission.meta["trajectory"]``).

    Attributes:
        yaw0: initial heading, rad.
        p0_n: initial NED position of the IMU, m.
        yaw, pitch, speed: smooth steps of yaw (rad), pitch (rad), forward speed u (m/s).
        roll_osc, pitch_osc, yaw_osc, u_osc, sway, heave: sinusoids (rad or m/s).
        bank_s: roll in turns = bank_s * yaw rate (s).
        pivot_m: the hull's pivot point ahead of the IMU, m: in the turns (the yaw steps) the sway at the IMU gets
            ``-pivot_m * yaw rate``, the sideslip of a hull turning about a point ahead of it (0: none).
        pitch_pivot_m: the hull's pitch pivot ahead of the IMU, m: the heave at the IMU gets ``pitch_pivot_m *
            pitch rate`` (the steps' and the oscillations'), a hull pitching about a point ahead of it (0: none).
        speed0: forward speed at t=0 before the speed steps, m/s.
        gravity_mps2, omega_ie_n: gravity magnitude at the origin (m/s^2) and Earth rate in NED (rad/s).
        earth: the Earth model of the IMU (position-dependent gravity); None: constant ``[0, 0, gravity_mps2]``
            (the planning phase, before positions are known).
        gravity_track: (stamps (K,) s, positions (K,3) m) at which ``earth``'s gravity is evaluated,
            interpolated linearly in between (gravity changes 1.5e-6 m/s^2 per metre: mm are plenty).
        surface_windows: ``(t_start, t_end)`` s of each stay at the surface (a :class:`SurfacingProfile`).
    """

    yaw0: float
    p0_n: np.ndarray
    speed0: float
    gravity_mps2: float
    omega_ie_n: np.ndarray
    yaw: SmoothSteps = field(default_factory=SmoothSteps)
    pitch: SmoothSteps = field(default_factory=SmoothSteps)
    speed: SmoothSteps = field(default_factory=SmoothSteps)
    roll_osc: Sines = field(default_factory=Sines)
    pitch_osc: Sines = field(default_factory=Sines)
    yaw_osc: Sines = field(default_factory=Sines)
    u_osc: Sines = field(default_factory=Sines)
    sway: Sines = field(default_factory=Sines)
    heave: Sines = field(default_factory=Sines)
    bank_s: float = 0.3
    pivot_m: float = 0.0
    pitch_pivot_m: float = 0.0
    earth: EarthModel | None = None
    gravity_track: tuple | None = None
    surface_windows: list = field(default_factory=list)

    def gravity_n(self, t: np.ndarray) -> np.ndarray:
        """Gravity (N,3), m/s^2, at the vehicle's position at stamps t (s)."""
        t = np.asarray(t, dtype=float)
        if self.earth is None or self.gravity_track is None:
            return np.broadcast_to(np.array([0.0, 0.0, self.gravity_mps2]), (len(t), 3))
        ts, ps = self.gravity_track
        p = np.stack([np.interp(t, ts, ps[:, j]) for j in range(3)], axis=-1)
        return self.earth.gravity_n(p)

    def euler_and_body_velocity(self, t: np.ndarray):
        """(euler (N,3), euler rates (N,3), v_b (N,3), dv_b (N,3)) at sorted stamps t."""
        t = np.asarray(t, dtype=float)
        yaw_s, yaw_rate_s, yaw_acc_s = self.yaw.evaluate(t)
        yaw_o, yaw_rate_o = self.yaw_osc.evaluate(t)
        pitch_s, pitch_rate_s, pitch_acc_s = self.pitch.evaluate(t)
        pitch_o, pitch_rate_o = self.pitch_osc.evaluate(t)
        roll_o, roll_rate_o = self.roll_osc.evaluate(t)
        u_s, u_rate_s, _ = self.speed.evaluate(t)
        u_o, u_rate_o = self.u_osc.evaluate(t)
        v, v_rate = self.sway.evaluate(t)
        w, w_rate = self.heave.evaluate(t)
        roll = roll_o + self.bank_s * yaw_rate_s
        roll_rate = roll_rate_o + self.bank_s * yaw_acc_s
        euler = np.stack([roll, pitch_s + pitch_o, self.yaw0 + yaw_s + yaw_o], axis=-1)
        euler_rate = np.stack([roll_rate, pitch_rate_s + pitch_rate_o, yaw_rate_s + yaw_rate_o], axis=-1)
        v = v - self.pivot_m * yaw_rate_s
        v_rate = v_rate - self.pivot_m * yaw_acc_s
        if self.pitch_pivot_m:
            w = w + self.pitch_pivot_m * (pitch_rate_s + pitch_rate_o)
            w_rate = w_rate + self.pitch_pivot_m * (pitch_acc_s + self.pitch_osc.acceleration(t))
        v_b = np.stack([self.speed0 + u_s + u_o, v, w], axis=-1)
        dv_b = np.stack([u_rate_s + u_rate_o, v_rate, w_rate], axis=-1)
        return euler, euler_rate, v_b, dv_b

    def velocity_n(self, t: np.ndarray) -> np.ndarray:
        """NED velocity (N,3), m/s, at sorted stamps t (s)."""
        euler, _, v_b, _ = self.euler_and_body_velocity(t)
        return np.einsum("nij,nj->ni", euler_to_C_b_n_closed_form(*euler.T), v_b)

    def state(self, t: np.ndarray) -> TrueState:
        """Exact kinematics at sorted stamps t (s)."""
        t = np.asarray(t, dtype=float)
        euler, euler_rate, v_b, dv_b = self.euler_and_body_velocity(t)
        C = euler_to_C_b_n_closed_form(*euler.T)
        roll, pitch = euler[:, 0], euler[:, 1]
        droll, dpitch, dyaw = euler_rate.T
        # Body rate from ZYX Euler-angle rates (C_b_n = Rz(yaw) Ry(pitch) Rx(roll)).
        omega_nb_b = np.stack([
            droll - dyaw * np.sin(pitch),
            dpitch * np.cos(roll) + dyaw * np.sin(roll) * np.cos(pitch),
            -dpitch * np.sin(roll) + dyaw * np.cos(roll) * np.cos(pitch)], axis=-1)
        v_n = np.einsum("nij,nj->ni", C, v_b)
        a_n = np.einsum("nij,nj->ni", C, dv_b + np.cross(omega_nb_b, v_b))
        g_n = self.gravity_n(t)
        f_n = a_n + 2.0 * np.cross(self.omega_ie_n, v_n) - g_n
        f_b = np.einsum("nji,nj->ni", C, f_n)
        omega_ib_b = omega_nb_b + np.einsum("nji,j->ni", C, self.omega_ie_n)
        return TrueState(t, euler, C, v_b, dv_b, v_n, a_n, omega_nb_b, omega_ib_b, f_b)

    def position_n(self, t: np.ndarray, order: int = 6) -> np.ndarray:
        """NED position (N,3), m, at sorted stamps t (s), starting from ``p0_n`` at t=0 (t[0] must be 0)."""
        t = np.asarray(t, dtype=float)
        if abs(t[0]) > 0:
            raise ConfigError("position_n needs the stamps to start at t=0")
        nodes, weights = np.polynomial.legendre.leggauss(order)
        a, b = t[:-1], t[1:]
        half = 0.5 * (b - a)
        steps = np.empty((len(a), 3))
        chunk = 20_000                  # intervals per call: bounded memory for multi-hour missions
        for i in range(0, len(a), chunk):
            sl = slice(i, i + chunk)
            tau = (0.5 * (a[sl] + b[sl]))[:, None] + half[sl, None] * nodes[None, :]
            v = self.velocity_n(tau.ravel()).reshape(-1, order, 3)
            steps[sl] = np.einsum("k,nkj->nj", weights, v) * half[sl, None]
        return self.p0_n + np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])

    def imu_samples(self, t: np.ndarray, dt: float, order: int = 3) -> tuple[np.ndarray, np.ndarray]:
        """Exact increment-type IMU samples (f_b (N,3) m/s^2, omega_b (N,3) rad/s) for stamps t (s).

        Sample k is the increment over ``[t_k, t_k + dt]`` divided by dt (see the module docstring).
        """
        t = np.asarray(t, dtype=float)
        euler_k = self.euler_and_body_velocity(t)[0]
        euler_k1 = self.euler_and_body_velocity(t + dt)[0]
        C_k = euler_to_C_b_n_closed_form(*euler_k.T)
        C_k1 = euler_to_C_b_n_closed_form(*euler_k1.T)
        # Gyro: body rotation relative to inertial space over the interval; the NED frame turns with
        # the Earth by Exp(omega_ie_n dt) (transport rate neglected).
        C_earth = Rotation.from_rotvec(self.omega_ie_n * dt).as_matrix()
        delta = np.swapaxes(C_k, 1, 2) @ (C_earth @ C_k1)
        omega_b = Rotation.from_matrix(delta).as_rotvec() / dt
        # Accelerometer: velocity increment in the body axes frozen in inertial space at t_k (includes
        # sculling exactly); the NED axes turn by Exp(omega_ie_n s) after s seconds.
        nodes, weights = np.polynomial.legendre.leggauss(order)
        f_b = np.zeros((len(t), 3))
        for node, weight in zip(nodes, weights):
            s_k = 0.5 * dt * (1.0 + node)
            state = self.state(t + s_k)
            C_turn = Rotation.from_rotvec(self.omega_ie_n * s_k).as_matrix()
            rel = np.swapaxes(C_k, 1, 2) @ (C_turn @ state.C_b_n)   # C_ib(t_k)^T C_ib(tau)
            f_b += 0.5 * weight * (rel @ state.f_b[:, :, None])[:, :, 0]
        return f_b, omega_b


# --- surfacings ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class SurfacingProfile:
    """Surfacings for GNSS fixes: every ``interval_s`` the vehicle climbs to the surface, stays ``stay_s``
    there receiving fixes, and dives to a new survey depth.

    The climb starts on the first straight leg after each multiple of ``interval_s`` (at the multiple when it
    falls inside a leg, else 30 s into the next leg; that leg is lengthened to hold the climb, the stay and the
    dive before its turn), so consecutive surfacings are ``interval_s`` to about ``interval_s + 130`` s apart.

    Attributes:
        interval_s: time between surfacings, s.
        stay_s: time at the surface (level flight at ``surface_depth_m``), s.
        fix_rate_hz: GNSS fix rate at the surface, Hz.
        fix_sigma_m: (low, high) m: each surfacing's fix 1-sigma per horizontal axis is drawn uniformly from it
            (with the seed); the fixes' errors are white with that sigma, which they also report.
        surface_depth_m: IMU depth at the surface, m (the antenna is above the water; the sea-state heave and
            pitch oscillations move the IMU by about 0.1 m).
        dive_depth_m: (low, high) m (low >= 3 m): the survey depth of the descent and after each dive is drawn
            uniformly from it; None = the
            survey depths of a mission without surfacings (22-28 m after the descent, 15-35 m later).
        pitch_deg: pitch while climbing or diving, deg (the time at that pitch is solved for the depth).
    """

    interval_s: float = 600.0
    stay_s: float = 30.0
    fix_rate_hz: float = 1.0
    fix_sigma_m: tuple[float, float] = (2.0, 3.0)
    surface_depth_m: float = 0.5
    dive_depth_m: tuple[float, float] | None = None
    pitch_deg: float = 15.0

    def __post_init__(self):
        checks = {"interval_s": self.interval_s > 0, "stay_s": self.stay_s > 0, "fix_rate_hz": self.fix_rate_hz > 0,
                  "fix_sigma_m": 0 < self.fix_sigma_m[0] <= self.fix_sigma_m[1],
                  "surface_depth_m": 0 <= self.surface_depth_m < 5.0,
                  "dive_depth_m": self.dive_depth_m is None
                  or max(self.surface_depth_m + 1.0, START_DEPTH_M + 1.0) <= self.dive_depth_m[0]
                  <= self.dive_depth_m[1],
                  "pitch_deg": 1.0 <= self.pitch_deg <= 30.0}
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            raise ConfigError(f"SurfacingProfile: {bad[0]} = {getattr(self, bad[0])!r} is out of range "
                              "(interval, stay and fix rate > 0; 0 < sigma low <= high; surface depth in [0, 5) m; "
                              "dive depths at least 1 m below it and below the 2 m start; pitch 1-30 deg)")


def _pitch_manoeuvre(traj: "SimTrajectory", t_a: float, depth_a: float, target: float, pitch_max: float,
                     rise: float = 10.0) -> float:
    """Add a pitch manoeuvre from ``t_a`` (depth ``depth_a`` m) that ends level at depth ``target`` (m):
    pitch to ``pitch_max`` (rad, nose up to climb, down to dive) over ``rise`` s, hold, pitch back; the hold is
    solved for the depth (for a small change, the hold is 0 and the pitch is solved). Returns its end, s."""
    sign = 1.0 if target < depth_a else -1.0          # nose up (positive pitch) climbs
    i_on = traj.pitch.add(t_a, rise, sign * pitch_max)
    i_off = traj.pitch.add(t_a + rise, rise, -sign * pitch_max)

    def error(hold: float, pitch: float = pitch_max) -> float:
        traj.pitch.delta[i_on], traj.pitch.delta[i_off] = sign * pitch, -sign * pitch
        traj.pitch.t0[i_off] = t_a + rise + hold
        return depth_a + _depth_change(traj, t_a, t_a + 2 * rise + hold) - target

    if sign * error(0.0) > 0:         # the full pitch without a hold does not get there: hold it
        hi = 60.0
        while sign * error(hi) > 0:
            hi *= 2.0
        hold = brentq(error, 0.0, hi, xtol=1e-3)
        error(hold)
        return t_a + 2 * rise + hold
    pitch = brentq(lambda p: error(0.0, p), 0.0, pitch_max, xtol=1e-7)
    error(0.0, pitch)
    return t_a + 2 * rise


def _plan_surfacing(traj: "SimTrajectory", profile: SurfacingProfile, rng: np.random.Generator, t_a: float,
                    depth_a: float) -> tuple[float, float]:
    """Climb from ``t_a`` (depth ``depth_a`` m), stay at the surface, dive to a drawn depth; records the stay
    in ``traj.surface_windows``. Returns (end of the dive s, its depth m)."""
    pitch = profile.pitch_deg * DEG
    t_up = _pitch_manoeuvre(traj, t_a, depth_a, profile.surface_depth_m, pitch)
    t_down = t_up + profile.stay_s
    traj.surface_windows.append((t_up, t_down))
    low, high = profile.dive_depth_m or (15.0, 35.0)
    target = float(rng.uniform(low, high))
    return _pitch_manoeuvre(traj, t_down, profile.surface_depth_m, target, pitch), target


def surface_fixes(traj: "SimTrajectory", profile: SurfacingProfile, rng: np.random.Generator, t_end: float,
                  origin_lla: tuple[float, float, float], noiseless: bool = False) -> PositionFixData | None:
    """GNSS fixes at ``profile.fix_rate_hz`` during the surface stays of ``traj`` up to ``t_end`` s: the true
    IMU position plus white north/east errors of the surfacing's drawn sigma (none when ``noiseless``; the
    sigma the fixes report is the drawn one either way), as latitude/longitude (rad) in the frame of
    ``origin_lla``. None when the mission has no stay at the surface."""
    from graphnav.core.earth import ned_to_lla
    t_all, sigma_all, err_all = [], [], []
    for t0, t1 in traj.surface_windows:
        sigma = float(rng.uniform(*profile.fix_sigma_m))
        n0 = int(np.ceil(t0 * profile.fix_rate_hz - 1e-9))
        t = np.arange(n0, np.floor(min(t1, t_end) * profile.fix_rate_hz + 1e-9) + 1) / profile.fix_rate_hz
        t_all.append(t)
        sigma_all.append(np.full(len(t), sigma))
        err = rng.normal(0.0, sigma, (len(t), 2))
        err_all.append(np.zeros_like(err) if noiseless else err)
    if not t_all or not sum(len(t) for t in t_all):
        return None
    t = np.concatenate(t_all)
    grid = np.union1d(np.arange(0.0, t[-1], 1.0), t)     # its quadrature runs from t = 0 between the stamps
    p = traj.position_n(grid)[np.searchsorted(grid, t)]
    p[:, :2] += np.concatenate(err_all)
    lla = ned_to_lla(p, origin_lla)
    return PositionFixData(t, lla[:, 0], lla[:, 1], np.concatenate(sigma_all), "sim:gnss")


# --- mission plan ------------------------------------------------------------------------------------

def _depth_rate(traj: SimTrajectory, t: np.ndarray) -> np.ndarray:
    euler, _, v_b, _ = traj.euler_and_body_velocity(t)
    roll, pitch = euler[:, 0], euler[:, 1]
    u, v, w = v_b.T
    # Down component of C_b_n v_b (independent of yaw).
    return -np.sin(pitch) * u + np.cos(pitch) * np.sin(roll) * v + np.cos(pitch) * np.cos(roll) * w


def _depth_change(traj: SimTrajectory, ta: float, tb: float) -> float:
    """Depth change (m) over [ta, tb] by Gauss-Legendre on 1 s panels (planning accuracy)."""
    if tb <= ta:
        return 0.0
    n_panels = max(1, int(np.ceil(tb - ta)))
    edges = np.linspace(ta, tb, n_panels + 1)
    nodes, weights = np.polynomial.legendre.leggauss(4)
    half = 0.5 * np.diff(edges)
    tau = (0.5 * (edges[:-1] + edges[1:]))[:, None] + half[:, None] * nodes[None, :]
    rate = _depth_rate(traj, tau.ravel()).reshape(n_panels, 4)
    return float(np.sum(rate @ weights * half))


def plan_trajectory(duration_s: float, rng: np.random.Generator, gravity_mps2: float,
                    omega_ie_n: np.ndarray, surfacing: SurfacingProfile | None = None,
                    rng_surfacing: np.random.Generator | None = None, pattern: str = "lawnmower",
                    pivot_m: float = 0.0, pitch_pivot_m: float = 0.0) -> SimTrajectory:
    """Random (seeded) survey covering at least ``duration_s`` seconds: a lawnmower (legs joined by pairs of
    90 deg turns in the same direction: every other leg flies back) or, ``pattern="transit"``, the same legs
    joined by a 90 deg turn and a turn back (a staircase along the first course: the vehicle keeps going
    away). With ``surfacing``, stays at the surface (their own random stream ``rng_surfacing``: the draws of
    ``rng`` are those of a mission without them up to the first surfacing). ``pivot_m``, ``pitch_pivot_m``: the
    hull's sideslip in turns and heave in pitch (:class:`SimTrajectory`)."""
    if pattern not in PATTERNS:
        raise ConfigError(f"pattern must be one of {PATTERNS}, got {pattern!r}")
    traj = SimTrajectory(yaw0=float(rng.uniform(-np.pi, np.pi)),
                         p0_n=np.array([0.0, 0.0, START_DEPTH_M]), speed0=1.3,
                         gravity_mps2=gravity_mps2, omega_ie_n=np.asarray(omega_ie_n, float), pivot_m=float(pivot_m),
                         pitch_pivot_m=float(pitch_pivot_m))
    # Sea-state and control oscillations: a few degrees, periods 8-20 s.
    for _ in range(2):
        traj.roll_osc.add(rng.uniform(1.0, 2.0) * DEG, rng.uniform(8.0, 20.0), rng.uniform(0, 2 * np.pi))
        traj.pitch_osc.add(rng.uniform(0.5, 1.5) * DEG, rng.uniform(8.0, 20.0), rng.uniform(0, 2 * np.pi))
    traj.yaw_osc.add(rng.uniform(0.2, 0.5) * DEG, rng.uniform(10.0, 20.0), rng.uniform(0, 2 * np.pi))
    traj.u_osc.add(rng.uniform(0.01, 0.04), rng.uniform(15.0, 30.0), rng.uniform(0, 2 * np.pi))
    traj.sway.add(rng.uniform(0.02, 0.06), rng.uniform(10.0, 25.0), rng.uniform(0, 2 * np.pi))
    traj.heave.add(rng.uniform(0.01, 0.03), rng.uniform(8.0, 15.0), rng.uniform(0, 2 * np.pi))

    # Descent: pitch down at t=3 s, hold long enough to reach the survey depth, pitch back up.
    target = float(rng.uniform(22.0, 28.0))
    if surfacing is not None and surfacing.dive_depth_m is not None:
        target = float(rng_surfacing.uniform(*surfacing.dive_depth_m))
    pitch_down = -float(rng.uniform(15.0, 19.0)) * DEG
    ramp = 8.0
    traj.speed.add(2.0, 15.0, float(rng.uniform(1.4, 2.3)) - traj.speed0)
    down = traj.pitch.add(3.0, ramp, pitch_down)
    up = traj.pitch.add(3.0 + ramp, ramp, -pitch_down)

    def descent_error(hold: float) -> float:
        traj.pitch.t0[up] = 3.0 + ramp + hold
        return START_DEPTH_M + _depth_change(traj, 0.0, 3.0 + 2 * ramp + hold) - target

    if descent_error(0.0) > 0:
        # a survey depth shallower than the full pitch reaches (surfacing profiles only): no hold, less pitch
        def pitch_error(pitch: float) -> float:
            traj.pitch.delta[down], traj.pitch.delta[up] = pitch, -pitch
            return descent_error(0.0)

        pitch_error(brentq(pitch_error, pitch_down, 0.0, xtol=1e-7))
        hold = 0.0
    else:
        hold = brentq(descent_error, 0.0, 400.0, xtol=1e-3)
        descent_error(hold)
    t_known, depth_known = 0.0, START_DEPTH_M

    cursor, leg, turn_sign = 0.0, 0, 1.0
    next_surfacing = surfacing.interval_s if surfacing is not None else np.inf
    while cursor < duration_s + 1.0:
        leg_start = cursor
        leg_len = float(rng.uniform(100.0, 160.0))
        if leg == 0:
            leg_len = max(leg_len, 3.0 + 2 * ramp + hold + 40.0)
        else:
            speed_now = traj.speed0 + sum(traj.speed.delta)
            traj.speed.add(leg_start + 2.0, 20.0, float(rng.uniform(1.1, 2.3)) - speed_now)
        surfaces = next_surfacing < leg_start + leg_len
        if surfaces:
            # after the descent or the leg's speed change; no depth bump or late speed change in this leg
            t_free = 3.0 + 2 * ramp + hold + 10.0 if leg == 0 else leg_start + 30.0
            while next_surfacing < leg_start + leg_len and next_surfacing < duration_s + 1.0:
                t_a = max(next_surfacing, t_free)
                depth_known += _depth_change(traj, t_known, t_a)
                t_free, depth_known = _plan_surfacing(traj, surfacing, rng_surfacing, t_a, depth_known)
                t_known = t_free
                leg_len = max(leg_len, t_free + 20.0 - leg_start)
                while next_surfacing < t_free:
                    next_surfacing += surfacing.interval_s
        elif leg > 0:
            if rng.random() < 0.75:
                # Depth change by a pitch bump; its amplitude is solved so the bump ends at the target.
                t_a, rise, hold_b = leg_start + 30.0, 10.0, float(rng.uniform(5.0, 20.0))
                t_b = t_a + 2 * rise + hold_b
                depth_known += _depth_change(traj, t_known, t_a)
                t_known = t_a
                target = float(np.clip(25.0 + rng.uniform(-6.0, 6.0), 15.0, 35.0))
                if surfacing is not None and surfacing.dive_depth_m is not None:
                    target = float(rng_surfacing.uniform(*surfacing.dive_depth_m))
                i_dn = traj.pitch.add(t_a, rise, 0.0)
                i_up = traj.pitch.add(t_a + rise + hold_b, rise, 0.0)

                def bump_error(theta: float) -> float:
                    traj.pitch.delta[i_dn], traj.pitch.delta[i_up] = theta, -theta
                    return depth_known + _depth_change(traj, t_a, t_b) - target

                lo, hi = -20.0 * DEG, 20.0 * DEG
                if bump_error(lo) * bump_error(hi) < 0:
                    bump_error(brentq(bump_error, lo, hi, xtol=1e-6))
                else:
                    bump_error(lo if abs(bump_error(lo)) < abs(bump_error(hi)) else hi)
        if leg > 0 and not surfaces and rng.random() < 0.5:
            # A second speed change late in the leg (after any depth change), before the turn.
            speed_now = traj.speed0 + sum(traj.speed.delta)
            traj.speed.add(leg_start + 75.0, 15.0, float(rng.uniform(1.1, 2.3)) - speed_now)
        # Lawnmower turn: 90 deg, short cross leg, 90 deg in the same direction; alternate direction.
        t_turn = leg_start + leg_len
        turn1, cross, turn2 = (float(rng.uniform(30.0, 40.0)), float(rng.uniform(10.0, 25.0)),
                               float(rng.uniform(30.0, 40.0)))
        traj.yaw.add(t_turn, turn1, turn_sign * np.pi / 2)
        # a transit turns back onto its course (a staircase); a lawnmower reverses it
        traj.yaw.add(t_turn + turn1 + cross, turn2, (-turn_sign if pattern == "transit" else turn_sign) * np.pi / 2)
        cursor = t_turn + turn1 + cross + turn2
        turn_sign = -turn_sign
        leg += 1
    return traj


# --- the mission -------------------------------------------------------------------------------------

def default_config() -> SensorConfig:
    """The configuration the default mission is simulated with (a configuration file's keys override it)."""
    return _default_config(DEFAULT_LEVER_ARM_B)


def _default_config(lever_arm_b) -> SensorConfig:
    lat = DEFAULT_ORIGIN_LLA[0]
    return SensorConfig(dvl=DvlSpec(lever_arm_b=np.asarray(lever_arm_b, float)), lat_rad=lat,
                        gravity_mps2=gravity_magnitude(lat))


def _distance(value, name: str) -> float:
    """``value`` as a finite distance in m, or a :class:`ConfigError` naming ``name``."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value):
        raise ConfigError(f"{name} must be a finite distance in m")
    return value


def simulate_mission(duration_s: float = 400.0, imu_grade: str | ImuSpec = "navigation", seed: int = 0, *,
                     lever_arm_b=None, dropout: bool = False, config: SensorConfig | None = None,
                     gt_rate_hz: float = 10.0, noiseless: bool = False,
                     dvl_stamp_offset_s: float = 0.0, dvl_output: str = "beams", start_ne_m=(0.0, 0.0),
                     surfacing: SurfacingProfile | None = None, pattern: str = "lawnmower",
                     pivot_m: float = 0.0, pitch_pivot_m: float = 0.0, dvl_errors: str = "spec") -> Mission:
    """Simulate a realistic AUV survey mission with exact ground truth.

    Args:
        duration_s: mission length, s (1 s .. :data:`MAX_DURATION_S`, 24 h: the Snapir AUV's endurance is 21 h).
        imu_grade: ``navigation``, ``tactical``, ``mems`` (see :data:`graphnav.core.config.IMU_GRADES`) or an
            :class:`ImuSpec`. The IMU errors are drawn from it and ``mission.config.imu`` is set to it.
        seed: seed of everything random (trajectory, IMU errors, DVL errors, dropouts, depth noise); each
            has its own stream, so e.g. ``noiseless=True`` keeps the same trajectory.
        lever_arm_b: DVL lever arm in the body frame, m; default ``config.dvl.lever_arm_b`` when a config
            is given, else :data:`DEFAULT_LEVER_ARM_B`.
        dropout: bottom-lock dropouts from :func:`graphnav.core.scenarios.markov_dropout` (invalid beams NaN).
        config: sensor configuration to simulate (latitude, gravity, Earth rotation, IMU rate, DVL geometry
            incl. C_d_b and error model, depth noise); default: lat 32.85 deg, WGS84 gravity, 100 Hz IMU,
            1 Hz DVL with the paper's error model. Its time offsets and IMU axis signs are reset (the
            simulated streams are on the IMU clock, in FRD).
        gt_rate_hz: ground-truth rate, Hz (must divide the IMU rate).
        noiseless: no IMU, DVL or depth errors (exact measurements).
        dvl_stamp_offset_s: DVL pings at ``k / dvl_rate + offset`` (s, ``0 <= offset < 1 / dvl_rate``);
            an offset that is not a multiple of the IMU period puts every ping between two IMU samples,
            as on real data. Default 0: pings on IMU stamps.
        dvl_output: ``"beams"`` (default): the four beams; ``"velocity"``: a velocity-only DVL, which reports
            only the DVL-frame velocity ``v_d`` of its own least-squares solution of the same simulated beams
            (true head velocity plus the beams' noise, bias and scale through the geometry; ``v_d_valid``
            where >= 3 beams were valid, no per-ping sigma) and no beams (all invalid).
        start_ne_m: (north, east) of the start from the NED origin, m, on the sea surface's curve (its depth
            is the usual start depth: the tangent plane's ``down`` is less by the curvature drop). A start
            tens of km away puts the whole mission where gravity is tilted and the tangent plane has risen.
        surfacing: a :class:`SurfacingProfile`: the vehicle surfaces every ``interval_s`` for GNSS fixes
            (``mission.fixes``, 1 Hz at the surface with a 2-3 m sigma by default). None (default): no
            surfacing and no fixes; the mission is then the same as before the option existed (same seed, same
            numbers).
        pattern: ``"lawnmower"`` (default: every other leg flies back, so a DVL scale error largely cancels
            over a few legs) or ``"transit"`` (a staircase that keeps going away: the scale error accumulates).
        pivot_m: the hull's pivot point ahead of the IMU, m: in turns the vehicle slides sideways at the IMU by
            ``-pivot_m`` times the turn's yaw rate, as a real hull does (the A-KIT Snapir about 3.6 m). Default 0:
            no sideslip in turns (the small sway oscillation stays), the same mission as before the option existed.
        pitch_pivot_m: the hull's pitch pivot ahead of the IMU, m: the vehicle heaves at the IMU by ``pitch_pivot_m``
            times its pitch rate (the A-KIT Snapir about 3 m). Default 0: no heave in pitch, the same mission as
            before the option existed.
        dvl_errors: the beams' bias and scale factor: ``"spec"`` (default): the configuration's
            (``config.dvl.beam_bias``, ``scale_factor``; by default the paper's, the same in every seed: four equal
            biases, a vertical velocity error only); ``"drawn"``: drawn per seed from zero-mean normals whose
            sigmas are the configuration's largest values, the estimators' prior sigmas
            (:class:`graphnav.estimators.options.PriorOptions`), as a Monte Carlo consistency check needs. The
            mission's configuration keeps the given values either way (the estimators' priors come from them);
            ``meta["dvl_errors"]`` holds those the beams were made with (None with ``noiseless``: nothing drawn).

    Returns:
        A validated :class:`Mission`. ``meta`` holds ``seed``, ``imu_grade``, ``noiseless``, ``dropout``,
        ``imu_errors`` (:class:`graphnav.sim.imu_errors.ImuErrorTruth` with the true biases, None if noiseless),
        ``dvl_errors`` (dict of the true beam bias, scale factor and noise std), ``trajectory``
        (:class:`SimTrajectory`, exact kinematics at any time), ``pivot_m``, ``pitch_pivot_m`` and, with
        ``surfacing``, ``surfacing`` (the profile) and ``surface_windows`` (``(t_start, t_end)`` s of each stay at
        the surface).
    """
    if not 1.0 <= duration_s <= MAX_DURATION_S:
        raise ConfigError(f"duration_s must be in [1, {MAX_DURATION_S:.0f}] s, got {duration_s}")
    spec = imu_grade if isinstance(imu_grade, ImuSpec) else _imu_grade(imu_grade)
    if config is None:
        config = _default_config(DEFAULT_LEVER_ARM_B if lever_arm_b is None else lever_arm_b)
    else:
        config = SensorConfig.from_dict(config.to_dict())      # deep copy; the caller's stays untouched
        if lever_arm_b is not None:
            config.dvl.lever_arm_b = np.asarray(lever_arm_b, float).reshape(3)
    config.imu = dataclasses.replace(spec)
    # Simulated streams are born on the IMU clock in FRD axes: nothing was shifted or flipped.
    config.dvl_time_offset_s = config.gt_time_offset_s = 0.0
    config.imu_axis_signs = np.ones(3)

    imu_rate = float(config.imu_rate_hz)
    gt_stride = imu_rate / gt_rate_hz
    dvl_stride = imu_rate / config.dvl.rate_hz
    depth_stride = imu_rate / 10.0
    for name, stride in (("gt_rate_hz", gt_stride), ("dvl.rate_hz", dvl_stride), ("depth rate", depth_stride)):
        if stride < 1 or abs(stride - round(stride)) > 1e-9:
            raise ConfigError(f"{name} must divide the IMU rate {imu_rate} Hz")
    gt_stride, dvl_stride, depth_stride = int(round(gt_stride)), int(round(dvl_stride)), int(round(depth_stride))

    if dvl_errors not in DVL_ERROR_SOURCES:
        raise ConfigError(f"dvl_errors must be one of {DVL_ERROR_SOURCES}, got {dvl_errors!r}")
    seq = np.random.SeedSequence(seed)
    # a sixth stream for the surfacings, a seventh for drawn DVL errors: SeedSequence children are keyed by their
    # index, so the first five are those of the missions simulated before they existed
    rng_traj, rng_imu, rng_dvl, rng_drop, rng_depth, rng_surf, rng_dvl_errors = (
        np.random.default_rng(s) for s in seq.spawn(7))
    earth = EarthModel.from_config(config)
    pivot_m = _distance(pivot_m, "pivot_m (graphnav simulate --pivot)")
    pitch_pivot_m = _distance(pitch_pivot_m, "pitch_pivot_m (graphnav simulate --pitch-pivot)")
    traj = plan_trajectory(duration_s, rng_traj, config.gravity_mps2, earth.omega_ie_n, surfacing, rng_surf,
                           pattern, pivot_m, pitch_pivot_m)
    if np.any(np.asarray(start_ne_m, float) != 0.0):
        lla = earth.to_lla(np.array([*np.asarray(start_ne_m, float).reshape(2), 0.0]))
        lla[2] = earth.alt_m - traj.p0_n[2]
        traj.p0_n = earth.from_lla(lla)

    n_imu = int(round(duration_s * imu_rate)) + 1
    t_imu = np.arange(n_imu) / imu_rate                 # integer-based stamps: every stream shares them
    dt = 1.0 / imu_rate
    # gravity depends on the position: track it on a 1 s grid (plus the end) before making the IMU samples
    t_track = np.union1d(np.arange(0.0, t_imu[-1], 1.0), [t_imu[-1], t_imu[-1] + dt])
    traj.earth, traj.gravity_track = earth, (t_track, traj.position_n(t_track))
    f_b = np.empty((n_imu, 3))
    omega_b = np.empty((n_imu, 3))
    chunk = 100_000                                     # bounded memory for multi-hour missions
    for i in range(0, n_imu, chunk):
        f_b[i:i + chunk], omega_b[i:i + chunk] = traj.imu_samples(t_imu[i:i + chunk], dt)
    imu = ImuData(t_imu, f_b, omega_b)
    imu_truth = None
    if not noiseless:
        imu, imu_truth = corrupt_imu(imu, spec, rng_imu, rate_hz=imu_rate)
        imu_truth.seed = seed

    # Ground truth and depth: exact states at their stamps, positions by quadrature.
    i_gt = np.arange(0, n_imu, gt_stride)
    i_depth = np.arange(0, n_imu, depth_stride)
    i_pos = np.union1d(i_gt, i_depth)
    p_all = traj.position_n(t_imu[i_pos])
    gt_state = traj.state(t_imu[i_gt])
    gt = GroundTruth(t_imu[i_gt], p_all[np.searchsorted(i_pos, i_gt)], gt_state.v_n, gt_state.C_b_n,
                     DEFAULT_ORIGIN_LLA)
    depth_true = earth.depth_of(p_all[np.searchsorted(i_pos, i_depth)])
    depth_noise = 0.0 if noiseless else rng_depth.normal(0.0, config.depth_noise_std, len(i_depth))
    depth = DepthData(t_imu[i_depth], depth_true + depth_noise)

    # DVL: beams of the DVL-head velocity v_b + omega_nb_b x l_b (the DVL measures relative to the seafloor).
    if not 0.0 <= dvl_stamp_offset_s < 1.0 / config.dvl.rate_hz:
        raise ConfigError(f"dvl_stamp_offset_s must be in [0, {1.0 / config.dvl.rate_hz}) s, "
                          f"got {dvl_stamp_offset_s}")
    t_dvl = t_imu[::dvl_stride] + dvl_stamp_offset_s
    t_dvl = t_dvl[t_dvl <= t_imu[-1]]
    dvl_state = traj.state(t_dvl)
    geometry = DvlGeometry.from_spec(config.dvl)
    v_head_b = geometry.dvl_velocity_b(dvl_state.v_b, dvl_state.omega_nb_b)
    errors = DvlErrorModel.from_spec(config.dvl)
    if dvl_errors == "drawn":
        errors.scale_factor = rng_dvl_errors.normal(0.0, float(np.max(np.abs(errors.scale_factor))), 3)
        errors.beam_bias = rng_dvl_errors.normal(0.0, float(np.max(np.abs(errors.beam_bias))), 4)
    if noiseless:
        beams = geometry.beams_from_velocity(v_head_b)
    else:
        beams = errors.beams(geometry, v_head_b, rng_dvl)
    valid = markov_dropout(len(t_dvl), seed=rng_drop) if dropout else np.ones((len(t_dvl), 4), bool)
    beams[~valid] = np.nan
    if dvl_output not in ("beams", "velocity"):
        raise ConfigError(f"dvl_output must be 'beams' or 'velocity', got {dvl_output!r}")
    dvl = DvlData(t_dvl, beams, valid, geometry.velocity_from_beams(beams, valid, allow_missing=True))
    if dvl_output == "velocity":
        dvl = as_velocity_only(dvl, config.dvl)

    fixes = None
    if surfacing is not None:
        fixes = surface_fixes(traj, surfacing, rng_surf, float(t_imu[-1]), DEFAULT_ORIGIN_LLA, noiseless)

    grade = spec.name
    name = f"sim-{duration_s:g}s-{grade}-seed{seed}" + ("-dropout" if dropout else "") + \
        ("-noiseless" if noiseless else "") + ("-velocity" if dvl_output == "velocity" else "") + \
        ("-surfacing" if surfacing is not None else "") + ("-transit" if pattern == "transit" else "") + \
        (f"-pivot{pivot_m:g}m" if pivot_m else "") + (f"-pitchpivot{pitch_pivot_m:g}m" if pitch_pivot_m else "") + \
        ("-dvlerrorsdrawn" if dvl_errors == "drawn" and not noiseless else "")
    meta = {
        "simulated": True, "seed": seed, "imu_grade": grade, "noiseless": noiseless, "dropout": dropout,
        "dvl_output": dvl_output, "pattern": pattern, "pivot_m": float(pivot_m), "pitch_pivot_m": pitch_pivot_m,
        "imu_errors": imu_truth,
        "dvl_errors": None if noiseless else {"beam_bias": errors.beam_bias.copy(),
                                              "scale_factor": errors.scale_factor.copy(),
                                              "noise_std": errors.noise_std},
        "trajectory": traj,
        "imu_sample_convention": SAMPLE_CONVENTION,
    }
    if surfacing is not None:
        meta["surfacing"] = surfacing
        meta["surface_windows"] = [w for w in traj.surface_windows if w[0] <= t_imu[-1]]
    return Mission(name, imu, dvl, config, gt, depth, meta, fixes=fixes)
