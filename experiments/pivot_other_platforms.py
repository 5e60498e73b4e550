"""The pivot completer on other platforms' bottom track: does its online fit carry to a hull it never saw?
(docs/decisions/completers.md, "The pivot completer on other platforms").

The pivot completer (``Graph-HNP``'s: the yaw alone, its length fitted online over the mission's fully measured pings,
:func:`graphnav.evaluation.methods.pivot_completer`) was fitted and checked on one vehicle, the Snapir. The shared
real-format files hold two other platforms with bottom track and turns, both river boats: ``winriver01.PD0`` (a 300
kHz Workhorse, ship frame) and ``RiverPro_test01.PD0`` (a 1200 kHz RiverPro, beam frame). They carry no IMU: the yaw
rate comes from the instrument's own heading, differenced between pings (the mean rate over each ping's period, what
the completer takes from the gyro), laid out as a 10 Hz rate stream. The body x axis is the head axis (a multiple of
90 deg) nearest the boat's mean course over ground, so the lateral axis is the hull's if the head is mounted square
to it. No lever arm is known: the fitted length is then the pivot's distance ahead of the DVL.

Each file's beams are completed for each scenario (2 and 3 missing beams) by the average estimator (its N) and by the
pivot completer holding the same pings: per ping (true past, the fit over the pings before) and through recursive
outages of ``--outage`` pings at every placement (a start every ``--stride`` pings from ping ``--first``, the fit
frozen at the start), with :func:`pivot_completer_folds.completions`. Printed: the gain against the average, ``1 -
pivot / average``, of the beam and velocity RMSE, and the length the fit reached. The pitch term is not scored: the
files' pitch and roll follow RDI's instrument conventions, and a boat hardly pitches. About 10 s::

    .venv/bin/python experiments/pivot_other_platforms.py
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np

#: the shared files with bottom track and turns (the other two are a moored profile and an up-looking mooring)
FILES = ("winriver01.PD0", "RiverPro_test01.PD0")
#: rate of the yaw-rate stream made from the heading, Hz
RATE_HZ = 10.0
SCENARIOS = ("2-missing", "3-missing")
#: the average estimator holding the pings the pivot completer holds: the baseline of the turn model alone
HOLD = "average, the pivot's hold"


def platform_mission(path: Path):
    """A :class:`~graphnav.core.mission.Mission` of a PD0 file's bottom-track beams with the yaw rate from its
    heading (module docstring), its ping period as the DVL's rate, and the median ping period (s)."""
    from scipy.spatial.transform import Rotation

    from graphnav.core.config import SensorConfig
    from graphnav.core.mission import DvlData, ImuData, Mission
    from graphnav.io.pd0 import read_pd0_log

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")         # the reader's counts of flagged samples: not this study's business
        log = read_pd0_log(path)
    ok = log.beam_valid.all(axis=1)
    t = np.asarray(log.t, float)
    period = float(np.median(np.diff(t)))
    mean_v = np.nanmean(log.v_d[ok], axis=0)
    course = np.degrees(np.arctan2(mean_v[1], mean_v[0]))
    C_d_b = Rotation.from_euler("z", -90.0 * round(course / 90.0), degrees=True).as_matrix()
    theta, psi = log.instrument["beam_theta_rad"], np.asarray(log.instrument["beam_psi_rad"], float)
    config = SensorConfig(imu_rate_hz=RATE_HZ)
    config.dvl = dataclasses.replace(config.dvl, theta_rad=float(theta), psi_rad=psi, C_d_b=C_d_b,
                                     lever_arm_b=np.zeros(3), rate_hz=1.0 / period)
    heading = np.unwrap(np.radians(log.attitude_deg[:, 0]))
    imu_t = np.arange(t[0], t[-1] + 1.0, 1.0 / RATE_HZ)
    # a sample between pings j - 1 and j holds the heading's mean rate over that period, as a gyro's mean would
    period_rate = np.diff(heading) / np.diff(t)
    j = np.clip(np.searchsorted(t, imu_t, side="right"), 1, len(t) - 1)
    omega = np.zeros((len(imu_t), 3))
    omega[:, 2] = period_rate[j - 1]
    f_b = np.tile([0.0, 0.0, -config.gravity_mps2], (len(imu_t), 1))
    beams = np.where(log.beam_valid, log.beams, np.nan)
    mission = Mission(path.name, ImuData(imu_t, f_b, omega), DvlData(t, beams, log.beam_valid.copy()), config)
    return mission, period


def platform_rows(path: Path, outage: int, stride: int, first: int, prior_turn: float) -> list[dict]:
    """Per scenario and kind (per ping, outage): the average's and the pivot completer's beam and velocity RMSE (m/s)
    on one file, and the fitted length (m)."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.core.scenarios import SCENARIOS as PATTERNS
    from graphnav.evaluation.methods import PIVOT_N_PAST, pivot_completer
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.imu_window import imu_window_at
    from graphnav.nets.pivot import solve_lengths
    from pivot_completer_folds import completions, online_fits

    mission, period = platform_mission(path)
    geometry = DvlGeometry.from_spec(mission.config.dvl)
    T_pinv = np.linalg.pinv(geometry.T_b)
    usable = mission.dvl.valid.all(axis=1)
    out = []
    for scenario in SCENARIOS:
        n, held = AVERAGE_N_PAST[scenario], PIVOT_N_PAST[scenario]
        pivot = pivot_completer(scenario, mission.config, prior_turn=prior_turn, n_past=held)
        members = {"average": AverageCompleter(n_past=n), HOLD: AverageCompleter(n_past=held),
                   "pivot": pivot}
        fits = online_fits(mission, geometry, held, ("yaw",))
        # where the online fit ends, shrunk as the completer uses it and not
        length, unshrunk = (float(solve_lengths(*fits[-1], prior)[0]) for prior in (prior_turn, 0.0))
        for kind, length_pings, step in (("per ping", 1, 1), ("outage", outage, stride)):
            k0 = max(first if kind == "outage" else 0, n, held)
            # every ping of the window measured, and a full rate window behind its first ping
            starts = [s for s in range(k0, len(usable) - length_pings + 1, step)
                      if usable[s - max(n, held):s + length_pings].all()
                      and imu_window_at(mission.imu, mission.dvl.t[s], pivot.imu_samples) is not None]
            rms = {}
            for name, completer in members.items():
                got, true = completions(completer, mission, PATTERNS[scenario], starts, length_pings,
                                        fits if name == "pivot" else None)
                err = got - true
                missing = list(PATTERNS[scenario])
                rms[name] = (float(np.sqrt(np.mean(err[:, missing] ** 2))),
                             float(np.sqrt(np.mean(np.sum((err @ T_pinv.T) ** 2, axis=1)))))
                if getattr(completer, "usage", {}).get("no_imu"):
                    raise RuntimeError(f"{path.name}: {completer.usage['no_imu']} pings without a rate window")
            out.append({"file": path.name, "scenario": scenario, "kind": kind, "starts": len(starts),
                        "period_s": period, "length_m": length, "unshrunk_m": unshrunk, **rms})
    return out


def report(rows: list[dict]) -> str:
    """Gains (beam / velocity RMSE, %) of the pivot completer against the average (its N, as ``Graph-HN`` holds) and
    against the average holding the pivot completer's pings (what the turn model alone changes)."""
    def gain(r, base):
        return " / ".join(f"{100.0 * (1.0 - p / a):+.1f}" for p, a in zip(r["pivot"], r[base]))
    lines = ["| file | ping period | scenario | kind | windows | fitted length (unshrunk) | pivot vs average | "
             "pivot vs average of its hold |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['file']} | {r['period_s']:.2f} s | {r['scenario']} | {r['kind']} | {r['starts']} | "
                     f"{r['length_m']:.2f} m ({r['unshrunk_m']:.2f} m) | {gain(r, 'average')} % | "
                     f"{gain(r, HOLD)} % |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--outage", type=int, default=30, help="outage length, pings (default 30)")
    p.add_argument("--stride", type=int, default=5, help="pings between outage starts (default 5)")
    p.add_argument("--first", type=int, default=60, help="first outage start, ping (default 60: the fit has seen a "
                   "minute of the mission, as in the Snapir study)")
    from graphnav.evaluation.methods import PIVOT_PRIOR_TURN
    p.add_argument("--prior-turn", type=float, default=PIVOT_PRIOR_TURN,
                   help=f"the online fit's shrinkage, (rad/s)^2 (default Graph-HNP's, {PIVOT_PRIOR_TURN:g})")
    a = p.parse_args(argv)
    from graphnav.core.errors import ConfigError
    from graphnav.io.paths import real_formats_file
    try:
        paths = [real_formats_file("pd0", name) for name in FILES]
    except ConfigError as exc:
        print(f"skipped: {exc}", file=sys.stderr)
        return 0
    sys.path.insert(0, str(Path(__file__).resolve().parent))     # the sibling study's completions
    rows = []
    for path in paths:
        rows += platform_rows(path, a.outage, a.stride, a.first, a.prior_turn)
    print(report(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
