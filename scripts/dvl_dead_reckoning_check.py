"""How far DVL-DR (graphnav.estimators.dead_reckoning) drifts on real logs.

1. The RiverPro PD0 file of ../shared/data/real-formats (beam coordinates, the instrument's own compass and
   tilts): the dead-reckoned track against the GPS the file carries (WinRiver NMEA blocks).
2. The ten A-KIT trajectories with the GT's attitude as a perfect compass: the DVL velocity turned to NED with
   the GT attitude, dead-reckoned, against the GT position. What a DVL alone gives with an INS-grade heading.

Run: GRAPHNAV_DATA=/work/shared/data .venv/bin/python scripts/dvl_dead_reckoning_check.py
"""
from __future__ import annotations

import contextlib
import io
import warnings

import numpy as np

from graphnav.core.dvl_log import DvlLog
from graphnav.core.earth import lla_to_ned
from graphnav.core.rotations import C_b_n_to_euler
from graphnav.estimators.dead_reckoning import dvl_dead_reckoning
from graphnav.io.paths import akit_dir, data_root


def riverpro() -> None:
    from graphnav.io import pd0
    from graphnav.io.dvl_files import read_dvl
    path = data_root() / "real-formats" / "pd0" / "RiverPro_test01.PD0"
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = dvl_dead_reckoning(read_dvl(path))
        ds = pd0._read_rdi(path)
    lat, lon = (np.radians(np.asarray(ds[k].values, float)) for k in ("latitude_gps", "longitude_gps"))
    t_gps = ds["time_gps"].values.astype("datetime64[ns]").astype(np.int64) / 1e9
    ok = np.isfinite(lat) & (t_gps >= sol.t[0]) & (t_gps <= sol.t[-1])
    p_gps = lla_to_ned(lat[ok], lon[ok], np.zeros(ok.sum()), (lat[ok][0], lon[ok][0], 0.0))[:, :2]
    p_dr = np.column_stack([np.interp(t_gps[ok], sol.t, sol.p_n[:, j]) for j in range(2)])
    p_dr -= p_dr[0]
    run = float(np.sum(np.linalg.norm(np.diff(p_gps, axis=0), axis=1)))
    end = float(np.linalg.norm(p_dr[-1] - p_gps[-1]))
    print(f"RiverPro_test01.PD0: GPS run {run:.1f} m over {t_gps[ok][-1] - t_gps[ok][0]:.0f} s; DVL-DR ends {end:.1f} m "
          f"from the GPS ({100 * end / run:.1f} % of the run), max {np.max(np.linalg.norm(p_dr - p_gps, axis=1)):.1f} m")


def akit() -> None:
    from graphnav.io.loaders import list_akit, load_akit
    errors = []
    for folder in list_akit(akit_dir()):
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


if __name__ == "__main__":
    riverpro()
    akit()
