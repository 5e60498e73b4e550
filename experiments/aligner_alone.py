"""The aligner alone on simulated missions: its error at the aligned stamp against the claimed covariance
(docs/decisions/alignment.md, "Gravity along the path in the alignment").

``align_mission`` on ``simulate_mission(duration, grade, seed, ...)`` (300 s of gyrocompassing), scored against the
simulated trajectory at the aligned stamp. Printed per seed (heading error / claimed heading sigma, deg) and pooled:
heading error RMS / claimed, heading NEES, largest heading error, the seeds beyond 3 claimed sigmas, attitude and
velocity NEES per degree of freedom. ``--dvl``: ``drawn`` (beam biases and scale factor drawn per seed), ``spec``
(the configuration's), ``noiseless`` (exact IMU, DVL and depth: the model's own error), ``exact`` (a DVL without
errors and 0.002 m/s beam noise).

Usage: ``.venv/bin/python experiments/aligner_alone.py --seeds 14-21 --dvl drawn [--duration 320]``
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.core.rotations import C_b_n_to_euler, attitude_error, heading_variance
from graphnav.estimators.align import align_mission
from graphnav.evaluation.metrics import wrap_angle
from graphnav.sim.simulate import default_config, simulate_mission


def _mission(seed: int, dvl: str, duration: float, grade: str):
    if dvl == "exact":
        config = default_config()
        config.dvl.beam_bias, config.dvl.scale_factor, config.dvl.beam_noise_std = np.zeros(4), np.zeros(3), 0.002
        return simulate_mission(duration, grade, seed, config=config)
    if dvl == "noiseless":
        return simulate_mission(duration, grade, seed, noiseless=True)
    return simulate_mission(duration, grade, seed, dvl_errors=dvl)


def _score(mission) -> tuple:
    """(heading error rad, heading variance rad^2, attitude NEES / 3, velocity NEES / 3) at the aligned stamp."""
    a = align_mission(mission)
    truth = mission.meta["trajectory"].state(np.array([a.t]))
    C_true, v_true = truth.C_b_n[0], truth.v_n[0]
    d_psi = wrap_angle(C_b_n_to_euler(a.C_b_n)[2] - C_b_n_to_euler(C_true)[2])
    e, dv = attitude_error(a.C_b_n, C_true), a.v_n - v_true
    return (d_psi, heading_variance(a.C_b_n, a.cov_rot), e @ np.linalg.solve(a.cov_rot, e) / 3,
            dv @ np.linalg.solve(a.cov_v_n, dv) / 3)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0-9", help="simulated seeds, e.g. 0-9 or 14")
    ap.add_argument("--dvl", choices=("drawn", "spec", "noiseless", "exact"), default="drawn")
    ap.add_argument("--duration", type=float, default=320.0, help="simulated mission length, s")
    ap.add_argument("--grade", default="navigation", help="simulated IMU grade")
    a = ap.parse_args(argv)
    first, _, last = a.seeds.partition("-")
    seeds = list(range(int(first), int(last or first) + 1))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = np.array([_score(_mission(s, a.dvl, a.duration, a.grade)) for s in seeds])
    err, var = r[:, 0], r[:, 1]
    beyond = [s for s, e, v in zip(seeds, err, var) if e * e > 9 * v]
    print(" ".join(f"{s}: {np.degrees(e):+.3f} / {np.degrees(np.sqrt(v)):.3f}" for s, e, v in zip(seeds, err, var)))
    print(f"{a.dvl}, seeds {a.seeds}: heading {np.degrees(np.sqrt(np.mean(err ** 2))):.3f} / "
          f"{np.degrees(np.sqrt(np.mean(var))):.3f} deg, NEES {np.mean(err ** 2 / var):.2f}, largest "
          f"{np.degrees(np.max(np.abs(err))):.3f} deg, beyond 3 sigma {beyond}, "
          f"attitude NEES {np.mean(r[:, 2]):.2f}, velocity NEES {np.mean(r[:, 3]):.2f} (per dof)")


if __name__ == "__main__":
    main()
