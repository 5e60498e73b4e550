"""How well each gyro-at-ping rule recovers the true body rate at the DVL pings (prints a table).

    .venv/bin/python experiments/gyro_at_ping.py [--seeds 3] [--duration 400]

The simulator's IMU samples are increments over ``[t_k, t_k+1]`` divided by the interval (the mean rate
over the interval), its pings sit ``dvl_stamp_offset_s`` after an IMU stamp, and its trajectory gives the
true ``omega_ib_b`` at any time. Rules: the sample nearest the ping (the graph's earlier rule), linear
interpolation between the two sample stamps (the EKF's earlier rule), and
:func:`graphnav.estimators.keyframes.gyro_at` (interpolation between the interval centres, now the rule of
every estimator). RMS of |omega_rule - omega_true| over the pings, rad/s.
"""
from __future__ import annotations

import argparse

import numpy as np

from graphnav.estimators.keyframes import gyro_at
from graphnav.sim.simulate import simulate_mission


def rules(t_imu: np.ndarray, w: np.ndarray, t_ping: float) -> dict[str, np.ndarray]:
    j = int(np.searchsorted(t_imu, t_ping, side="right")) - 1
    a, b = t_imu[j], t_imu[j + 1]
    u = (t_ping - a) / (b - a)
    samples = [(float(t_imu[k]), (0.0, 0.0, 0.0), tuple(w[k])) for k in range(max(j - 2, 0), j + 2)]
    return {"nearest sample": w[j] if abs(a - t_ping) <= abs(b - t_ping) else w[j + 1],
            "between stamps": (1 - u) * w[j] + u * w[j + 1],
            "gyro_at (interval centres)": gyro_at(t_ping, samples)}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--duration", type=float, default=400.0)
    args = parser.parse_args(argv)
    print("| seed | ping offset s | nearest sample | between stamps | gyro_at (interval centres) |")
    print("|---|---|---|---|---|")
    for seed in range(args.seeds):
        for offset in (0.0, 0.0021, 0.0042, 0.005, 0.0079):
            m = simulate_mission(args.duration, seed=seed, dvl_stamp_offset_s=offset, noiseless=True)
            t_ping = m.dvl.t[1:-1]
            true = m.meta["trajectory"].state(t_ping).omega_ib_b
            err = {}
            for t, w_true in zip(t_ping, true):
                for name, w in rules(m.imu.t, m.imu.omega_b, float(t)).items():
                    err.setdefault(name, []).append(np.sum((w - w_true) ** 2))
            rms = [f"{np.sqrt(np.mean(e)):.2e}" for e in err.values()]
            print(f"| {seed} | {offset} | " + " | ".join(rms) + " |")


if __name__ == "__main__":
    main()
