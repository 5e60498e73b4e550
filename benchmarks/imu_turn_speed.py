"""Speed of the DVL's checks against the IMU where the IMU's turn about z is judged too
(``graphnav.calibration.dvl_scale.check_velocity_against_imu`` with ``imu_frame``, as a column-map log without a
reference gets it), on whichever graphnav tree is imported (prints a table; no assertions).

    .venv/bin/python benchmarks/imu_turn_speed.py [--durations 400 3600 7200] [--repeat 3]
    # an older commit: git archive REV | tar -x -C DIR; PYTHONPATH=DIR .venv/bin/python benchmarks/imu_turn_speed.py

Logs: ``simulate_mission(duration, "navigation", seed 1)`` (manoeuvring) and the same plan on one straight leg at a
steady 1.5 m/s (its turns, speed and depth changes removed, as ``tests/test_input_conventions.py::_steady`` builds
it). With the simulator's 0.042 m/s beams the speed-scale fit explains under 0.9 of either's velocity changes, so the
IMU-turn fit searches the DVL offset (``docs/decisions/units-clocks-axes.md``, "A vehicle holding its speed or its
station"). Each time is the best of ``--repeat`` calls (the machine may be shared); the outcome column says whether
the log loaded ("ok") or what refused it.
"""
from __future__ import annotations

import argparse
import re
import time
import warnings


def steady_mission(duration_s: float, seed: int):
    """The simulator's plan on one straight leg at 1.5 m/s, its sea-state wobble kept."""
    import graphnav.sim.simulate as sim_module
    plan = sim_module.plan_trajectory

    def straight(*args, **kwargs):
        traj = plan(*args, **kwargs)
        traj.yaw, traj.pitch, traj.speed = sim_module.SmoothSteps(), sim_module.SmoothSteps(), sim_module.SmoothSteps()
        traj.speed0 = 1.5
        return traj
    sim_module.plan_trajectory = straight
    try:
        return sim_module.simulate_mission(duration_s, "navigation", seed)
    finally:
        sim_module.plan_trajectory = plan


def timed(m, repeat: int) -> tuple[float, str]:
    """Best seconds of ``repeat`` checks of mission ``m`` and their outcome."""
    from graphnav.calibration.dvl_scale import check_velocity_against_imu
    from graphnav.core.errors import DataError
    frame = {"what": "csv_columns.imu.frame 'frd'", "fields": "ax/ay/az/gx/gy/gz"}
    best, outcome = float("inf"), "ok"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(repeat):
            start = time.perf_counter()
            try:
                check_velocity_against_imu(m.imu, m.dvl, m.config, {}, imu_frame=frame)
            except DataError as exc:
                turn = re.search(r"turned (\d+) deg", str(exc))
                outcome = f"refused: turned {turn.group(1)} deg" if turn else f"refused: {exc}"[:80]
            best = min(best, time.perf_counter() - start)
    return best, outcome


def main(argv=None) -> int:
    import graphnav
    from graphnav.sim.simulate import simulate_mission
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--durations", type=float, nargs="+", default=[400.0, 3600.0, 7200.0], help="log lengths, s")
    ap.add_argument("--repeat", type=int, default=3, help="timed calls per log (the best is printed)")
    args = ap.parse_args(argv)
    print(f"graphnav from {graphnav.__file__}")
    print("| log | duration, s | check_velocity_against_imu, s | outcome |\n| --- | --- | --- | --- |")
    for duration in args.durations:
        for kind, make in (("manoeuvring", lambda d: simulate_mission(d, "navigation", 1)),
                           ("steady 1.5 m/s", lambda d: steady_mission(d, 1))):
            seconds, outcome = timed(make(duration), args.repeat)
            print(f"| {kind} | {duration:g} | {seconds:.3f} | {outcome} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
