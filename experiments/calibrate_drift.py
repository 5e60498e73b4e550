"""Fit BeamHistory's drift_std: coverage of filled-beam errors in recursive 30-ping outages.

For each completer (network and average estimator, 2 and 3 missing beams) and each drift_std, complete
30-ping outages on the A-KIT DVL velocities recursively (as the estimators do) and print the fraction of
filled-beam errors within 1 and 2 sigma (Gaussian: 0.683 / 0.954) and the RMS of error/sigma.

    .venv/bin/python experiments/calibrate_drift.py
"""
from __future__ import annotations

import argparse

import numpy as np
from graphnav.nets import AverageCompleter, load_completer
from graphnav.nets import data as beamdata
from graphnav.nets.evaluate import outage_rollout

from graphnav.core.scenarios import SCENARIOS
from graphnav.io.paths import akit_trajectories


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    series = beamdata.akit_series(akit_trajectories(parser.parse_args(argv).data)[0].parent)
    print("| completer | scenario | drift_std | within 1 sigma | within 2 sigma | rms(err/sigma) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for scen, n_past in (("2-missing", 3), ("3-missing", 5)):
        missing = list(SCENARIOS[scen])
        for name, comp in (("network", load_completer(scen)), ("average", AverageCompleter(n_past))):
            for drift in (0.0, 0.01, 0.02, 0.03, 0.04):
                comp.drift_std = drift          # BeamHistory takes the completer's drift_std
                full, sigma, samples = outage_rollout(comp, series, missing)
                err = (full - samples.beams)[:, missing]
                z = np.abs(err) / sigma[:, missing]
                print(f"| {name} | {scen} | {drift:.2f} | {np.mean(z < 1):.3f} | {np.mean(z < 2):.3f} | "
                      f"{np.sqrt(np.mean(z ** 2)):.2f} |")


if __name__ == "__main__":
    main()
