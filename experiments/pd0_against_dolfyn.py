"""graphnav's reading of the shared real RDI files against dolfyn's own (MHKiT): pings read and valid, and the
largest velocity difference in the instrument and earth frames (dolfyn's ``rotate2``, with the beam matrix the
file stores where it has one). ``tests/test_pd0_real.py`` holds these numbers to bounds.

Usage: .venv/bin/python experiments/pd0_against_dolfyn.py   (reads <data>/real-formats/pd0, graphnav.io.paths)
"""
from __future__ import annotations

import argparse
import contextlib
import io
import sys
import warnings

import numpy as np

from graphnav.io import pd0
from graphnav.io.dvl_files import read_dvl
from graphnav.io.paths import real_formats_file

FILES = ("RDI_withBT.000", "winriver01.PD0", "RiverPro_test01.PD0")


def dolfyn_dataset(path):
    """dolfyn's dataset with its -32.768 flags as NaN and the file's stored beam matrix, if any."""
    from mhkit.dolfyn.io.rdi import read_rdi
    with contextlib.redirect_stdout(io.StringIO()):
        ds = read_rdi(str(path), userdata=False)
    v = ds.vel_bt.values
    v[np.isclose(v, -32.768)] = np.nan
    ds.attrs["rotate_vars"] = ["vel_bt"]
    stored = pd0.scan_pd0(path).beam_matrix
    if stored is not None:
        ds["beam2inst_orientmat"].values[:] = stored
    return ds


def rotated(ds, frame: str) -> np.ndarray:
    from mhkit.dolfyn.rotate.api import rotate2
    with contextlib.redirect_stdout(io.StringIO()):
        return rotate2(ds, frame, inplace=False).vel_bt.values.astype(float)


def compare(path) -> str:
    log, ds = read_dvl(path), dolfyn_dataset(path)
    v = ds.vel_bt.values
    valid = (np.isfinite(v).sum(0) >= 3) if ds.coord_sys == "beam" else np.all(np.isfinite(v[:3]), 0)
    row = [path.name, log.frame, f"read {log.counts['read']} (dolfyn {v.shape[1]}, in the file "
           f"{log.counts['ensembles in file']})", f"valid {log.counts['valid']} (dolfyn {int(valid.sum())})",
           f"back to beams {log.counts['beams recovered']}", f"3-beam {int(log.three_beam.sum())}"]
    if ds.coord_sys != "ship":            # dolfyn has no ship -> instrument rotation
        inst = rotated(ds, "inst")[:3].T  # the seabed relative to the head, RDI instrument frame
        ours = -(log.v_d @ pd0.C_D_RDI)
        ok = log.v_d_valid & np.all(np.isfinite(inst), 1)
        row.append(f"instrument frame max |diff| {np.abs(ours[ok] - inst[ok]).max():.2e} m/s ({ok.sum()} pings)")
    enu = v[:3].astype(float).T if ds.coord_sys == "earth" else rotated(ds, "earth")[:3].T
    ned = -enu @ pd0.C_NED_ENU.T
    ok = log.v_d_valid & np.all(np.isfinite(ned), 1)
    row.append(f"earth frame max |diff| {np.abs(log.v_n[ok] - ned[ok]).max():.2e} m/s ({ok.sum()} pings)")
    return " | ".join(row)


def main(argv=None) -> int:
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args(argv)
    paths = [real_formats_file("pd0", name) for name in FILES]
    pd0._import_dolfyn()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for path in paths:
            print(compare(path))
    return 0


if __name__ == "__main__":
    sys.exit(main())
