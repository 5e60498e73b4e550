"""A vehicle integrator's first read: feed graphnav's Navigator sample by sample, as drivers deliver them.

No ground truth anywhere: the Navigator aligns itself from the IMU and the DVL (levelling, gyrocompassing
with the FOG-grade IMU; 300 s, after which it publishes the estimates of the alignment time too), then
publishes a filtered state at every DVL ping, and the controller reads the 100 Hz state from ``state_at``. Here a simulated mission stands in for the drivers; on a vehicle, call the
``add_*`` methods from the IMU, DVL and depth callbacks instead.

Run it: ``python examples/streaming_loop.py [--duration S]``.
"""
import argparse
import warnings

import numpy as np

from graphnav import Navigator, simulate_mission
from graphnav.estimators.replay import replay


def main(duration_s: float = 600.0) -> None:
    mission = simulate_mission(duration_s, seed=7)          # stands in for the drivers (and for scoring)
    nav = Navigator(mission.config)                        # fixed-lag graph, aligned from the sensors

    published, state = [], None
    for kind, t, sample in replay(mission):               # the drivers' callbacks, in arrival order
        if kind == "imu":
            estimates = nav.add_imu(t, *sample)              # f_b (m/s^2), omega_b (rad/s)
        elif kind == "dvl":
            estimates = nav.add_dvl(t, *sample)              # four beam velocities (m/s) and their validity
        else:
            estimates = nav.add_depth(t, *sample)            # depth (m)
        for est in estimates:                              # a keyframe closed: publish it
            published.append(est)
            if len(published) % 30 == 1:
                sigma = np.sqrt(np.diag(est.cov_v_n))
                print(f"t = {est.t:6.1f} s  v_n = {np.round(est.v_n, 3)} m/s  sigma = {np.round(sigma, 3)} m/s")
        if kind == "imu" and nav.initialised:
            state = nav.state_at(t)                          # what the 100 Hz controller reads
    nav.finish()

    al = nav.alignment
    print(f"aligned from the sensors (heading: {al.heading_source}; done at t = {nav.alignment_ready_t:.1f} s, "
          f"carried back to t = {al.t:.1f} s), {len(published)} estimates"
          + (f", last controller state at t = {state.t:.2f} s" if state is not None else ""))
    # score against the simulator's truth (a vehicle has none)
    truth = mission.gt
    t = np.array([e.t for e in published])
    v = np.array([e.v_n for e in published])
    v_true = np.array([np.interp(t, truth.t, truth.v_n[:, i]) for i in range(3)]).T
    after = t > t[0] + 60.0
    print(f"velocity RMSE after the first 60 s: {np.sqrt(np.mean(np.sum((v - v_true)[after] ** 2, axis=1))):.3f} m/s")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=600.0, help="simulated mission length, s")
    warnings.simplefilter("default")
    main(parser.parse_args().duration)
