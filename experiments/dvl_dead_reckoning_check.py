"""How far DVL-DR (graphnav.estimators.dead_reckoning) drifts on real logs.

1. The RiverPro PD0 file of ../shared/data/real-formats (beam coordinates, the instrument's own compass and
   tilts): the dead-reckoned track against the GPS the file carries (WinRiver NMEA blocks).
2. The ten A-KIT trajectories with the GT's attitude as a perfect compass: the DVL velocity turned to NED with
   the GT attitude, dead-reckoned, against the GT position. What a DVL alone gives with an INS-grade heading.

Run: GRAPHNAV_DATA=/work/shared/data .venv/bin/python experiments/dvl_dead_reckoning_check.py
"""
from __future__ import annotations

import argparse
import contextlib
import io
import warnings

import numpy as np

from graphnav.core.dvl_log import DvlLog
from graphnav.core.rotations import C_b_n_to_euler
from graphnav.estimators.dead_reckoning import dvl_dead_reckoning
from graphnav.io.paths import akit_trajectories, real_formats_file


def riverpro() -> None:
    from graphnav.evaluation.metrics import track_against_fixes
    from graphnav.io import pd0
    from graphnav.io.dvl_files import read_dvl
    path = real_formats_file("pd0", "RiverPro_test01.PD0")
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = dvl_dead_reckoning(read_dvl(path))
        r = track_against_fixes(sol, *pd0.gps_fixes(path))
    print(f"RiverPro_test01.PD0: GPS run {r['run_m']:.1f} m over {r['duration_s']:.0f} s; DVL-DR ends {r['end_m']:.1f} m "
          f"from the GPS ({100 * r['end_m'] / r['run_m']:.1f} % of the run), max {r['max_m']:.1f} m")


def akit(data=None) -> None:
    from graphnav.missions import load_akit
    errors = []
    for folder in akit_trajectories(data):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = load_akit(folder)
        t = m.dvl.t[(m.dvl.t >= m.gt.t[0]) & (m.dvl.t <= m.gt.t[-1])]
        keep = np.isin(m.dvl.t, t)
        p_gt, _, C = m.gt.at(t)
        euler = np.degrees(C_b_n_to_euler(C).reshape(-1, 3))            # roll, pitch, yaw
        log = DvlLog(t=t, v_d=m.dvl.v_b[keep], v_d_valid=np.all(np.isfinite(m.dvl.v_b[keep]), axis=1),
                     frame="instrument", attitude_deg=euler[:, [2, 1, 0]], source=folder.name)
        sol = dvl_dead_reckoning(log, p0_n=p_gt[0])
        p_ref, _, _ = m.gt.at(sol.t)
        err = np.linalg.norm(sol.p_n[-1, :2] - p_ref[-1, :2])
        run = sol.info["distance_m"]
        errors.append(100 * err / run)
        print(f"{folder.name}: {run:.0f} m in {sol.t[-1] - sol.t[0]:.0f} s, final horizontal error {err:.2f} m "
              f"({100 * err / run:.2f} % of the distance)")
    print(f"A-KIT, GT attitude: median {np.median(errors):.2f} %, max {np.max(errors):.2f} % of the distance")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    args = parser.parse_args(argv)
    riverpro()
    akit(args.data)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
