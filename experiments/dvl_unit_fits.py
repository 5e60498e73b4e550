"""The share of the DVL velocity's changes the clock model leaves unexplained with the velocity multiplied by 0.001,
0.01, 0.1, 1, 10, 100 and 1000 (:func:`graphnav.calibration.dvl_scale.velocity_scale_fits`): a declared
``velocity_unit`` 100x (cm/s) or 1000x (mm/s) too small for the data gives the velocity x0.01 or x0.001, and the unit
that fits is the one that brings it back. The shared A-KIT trajectories whole and in 60 s pieces every 30 s, simulated
missions (navigation, tactical, MEMS; seeds 0-2; 150 and 600 s; the default beams) and hovering vehicles with a DVL
(``tests/test_units.py::_hovering_with_dvl``).

A knots mix-up gives the velocity x0.514 (m/s declared kn) or x1.944 (knots declared m/s): ``--scales 0.514444
1.943844``.

``--declared`` prints instead, for each source read in each unit (m/s, cm/s, mm/s, kn) and declared in each, the ratio
:func:`~graphnav.calibration.dvl_scale.check_declared_velocity_unit` judges (what the declared unit leaves unexplained
over the best other unit it tries, :func:`~graphnav.calibration.dvl_scale.other_velocity_units`), that unit and what it
leaves; declared right, the ratio a clean log gives. ``--pieces 60 120`` cuts the A-KIT trajectories into pieces of
those lengths (every half length); ``--slow`` adds simulated slow and hovering vehicles at several speeds.

    .venv/bin/python experiments/dvl_unit_fits.py [--no-sim] [--no-pieces] [--scales K ...] [--declared]
        [--pieces S ...] [--slow]
"""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from graphnav.calibration.dvl_scale import other_velocity_units, velocity_scale_fits
from graphnav.core.errors import DataError
from graphnav.io.paths import akit_trajectories
from graphnav.io.units import DECLARED_UNITS

sys.path.insert(0, __file__.rsplit("/", 1)[0])
sys.path.insert(0, __file__.rsplit("/", 2)[0] + "/tests")
from imu_yaw_rates import _cut  # noqa: E402  (the same IMU and DVL pieces)
from test_units import _hovering_with_dvl, _with_dvl, sim_config  # noqa: E402  (the vehicles the tests judge)

SCALES = (0.001, 0.01, 0.1, 10.0, 100.0, 1000.0)
UNITS = DECLARED_UNITS["velocity"]


def _slow_with_dvl(speed: float, seed: int, noise: float):
    """A vehicle at ``speed`` +- 0.1 m/s turning gently (300 s, IMU 100 Hz FRD, 1 Hz body velocity with ``noise``
    m/s), as ``tests/test_generic_csv.py::_slow_log``'s."""
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 300.0, 0.01)
    v_b = np.column_stack([speed + 0.1 * np.sin(2 * np.pi * t / 90.0 + rng.uniform(0, 6)),
                           0.02 * np.sin(2 * np.pi * t / 40.0), 0.01 * np.sin(2 * np.pi * t / 60.0)])
    heading = rng.uniform(-3, 3) + np.cumsum(0.03 * np.sin(2 * np.pi * t / 120.0 + rng.uniform(0, 6))) * 0.01
    R = Rotation.from_euler("ZYX", np.column_stack([heading, 0.01 * np.sin(2 * np.pi * t / 11.0 + 1),
                                                    0.01 * np.sin(2 * np.pi * t / 7.0)]))
    f_b = R.inv().apply(np.gradient(R.apply(v_b), t, axis=0) - [0.0, 0.0, 9.80665]) + rng.normal(0, 0.01, v_b.shape)
    omega = (R[:-1].inv() * R[1:]).as_rotvec() / 0.01
    omega = np.vstack([omega, omega[-1]]) + rng.normal(0, 5e-4, v_b.shape)
    return _with_dvl(t, f_b, omega, v_b, seed, noise)


def _sources(sim: bool, pieces, slow: bool = False):
    from graphnav.missions import load_akit
    from graphnav.sim.simulate import simulate_mission
    for folder in akit_trajectories(None):
        m = load_akit(folder)
        yield f"A-KIT {folder.name}", m.imu, m.dvl, m.config
        for length in pieces:
            for start in np.arange(m.imu.t[0], m.imu.t[-1] - length, length / 2):
                yield (f"A-KIT {folder.name} {length:g} s from {start - m.imu.t[0]:.0f}",
                       *_cut(m, start, start + length), m.config)
    if slow:
        for seed in (1, 2, 3):
            for noise in (0.003, 0.01):
                for speed in (0.15, 0.25, 0.45, 1.0, 2.0):
                    yield (f"slow {speed} m/s seed {seed} noise {noise}", *_slow_with_dvl(speed, seed, noise),
                           sim_config())
    if sim:
        for grade in ("navigation", "tactical", "mems"):
            for seed in range(3):
                for duration in (150.0, 600.0):
                    m = simulate_mission(duration, grade, seed)
                    yield f"sim {grade} {seed} {duration:.0f} s", m.imu, m.dvl, m.config
            for seed in (0, 1):
                m = simulate_mission(400.0, grade, seed, pattern="transit")
                yield f"sim {grade} {seed} transit 400 s", m.imu, m.dvl, m.config
        config = sim_config()
        for seed in (1, 2, 3):
            for acc in (0.03, 0.2):
                for tilt in (0.0003, 0.003):
                    yield f"hovering seed {seed} {acc} m/s^2 {tilt} rad", *_hovering_with_dvl(acc, tilt, seed), config


def _declared_ratios(name: str, imu, dvl, config) -> None:
    """For the velocity read in each unit and declared in each, the ratio the declared-unit check judges, printed."""
    from graphnav.core.dvl_kinematics import dvl_velocity_b
    speed = float(np.nanmedian(np.linalg.norm(dvl_velocity_b(dvl, config)[1], axis=1)))
    scales = {UNITS[a] / UNITS[b] for a in UNITS for b in UNITS}
    fits = velocity_scale_fits(imu, dvl, config, scales - {1.0})
    for true in UNITS:
        for declared in UNITS:
            read = UNITS[declared] / UNITS[true]            # the velocity as read over the true one
            others = other_velocity_units(declared, speed * read, config)
            if not others:
                print(f"{name}; {true} declared {declared}; read {speed * read:.3g} m/s; no other unit")
                continue
            best = min(others, key=lambda u: fits[UNITS[u] / UNITS[true]])
            left = fits[UNITS[best] / UNITS[true]]
            print(f"{name}; {true} declared {declared}; read {speed * read:.3g} m/s; {fits[read] / left:.4g} over "
                  f"{best} (left {left:.3g} against {fits[read]:.3g})")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-sim", action="store_true", help="the A-KIT trajectories only")
    ap.add_argument("--no-pieces", action="store_true", help="whole A-KIT trajectories only")
    ap.add_argument("--scales", type=float, nargs="+", default=SCALES, help="the factors tried besides 1")
    ap.add_argument("--declared", action="store_true", help="the declared-unit check's ratios (module docstring)")
    ap.add_argument("--pieces", type=float, nargs="+", default=[60.0], help="A-KIT piece lengths, s")
    ap.add_argument("--slow", action="store_true", help="slow and hovering simulated vehicles too")
    args = ap.parse_args(argv)
    scales = tuple(args.scales)
    print("source; unexplained at x" + " ".join(f"{k:g}" for k in (1.0, *scales)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, imu, dvl, config in _sources(not args.no_sim, [] if args.no_pieces else args.pieces, args.slow):
            try:
                if args.declared:
                    _declared_ratios(name, imu, dvl, config)
                    continue
                fits = velocity_scale_fits(imu, dvl, config, scales)
            except DataError as exc:
                print(f"{name}; not judged: {exc.message}")
                continue
            print(f"{name}; " + " ".join(f"{fits[k]:.4g}" for k in (1.0, *scales)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
