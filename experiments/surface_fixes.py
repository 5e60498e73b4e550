"""What surface GNSS fixes buy the graph: drift between fixes and the DVL scale estimate, with and without fixes.

Simulated surveys with a surfacing every 10 min (30 s at the surface, 1 Hz fixes of 2-3 m) and a 0.7 % DVL
scale error (:func:`graphnav.evaluation.fixes.surface_fix_study`); the fixed-lag graph (the default online
estimator) and the batch smoother over its keyframes, each with the DVL error states on and off.

    python experiments/surface_fixes.py                      # 3 seeds, 40 min: about 10 min of CPU
    python experiments/surface_fixes.py --seeds 1 2 3 4 --duration 3600 --json out.json --plot out.png
    python experiments/surface_fixes.py --dvl-bias-rw 2e-5   # a graph option changed for every run
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from graphnav.estimators.graph.options import GraphOptions
from graphnav.evaluation.fixes import scale_at_surfacings, study_mission, summary, surface_fix_study
from graphnav.sim.simulate import SurfacingProfile


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--duration", type=float, default=2400.0, help="mission length, s")
    ap.add_argument("--interval", type=float, default=600.0, help="time between surfacings, s")
    ap.add_argument("--stay", type=float, default=30.0, help="time at the surface, s")
    ap.add_argument("--imu-grade", default="navigation")
    ap.add_argument("--pattern", choices=("lawnmower", "transit"), default="lawnmower",
                    help="survey pattern: lawnmower (every other leg flies back) or transit (keeps going away)")
    ap.add_argument("--no-batch", action="store_true", help="fixed-lag only")
    ap.add_argument("--only-on", action="store_true", help="DVL error states on only (no reference runs without)")
    ap.add_argument("--dvl-scale-rw", type=float, default=None, help="GraphOptions.dvl_scale_rw, 1/sqrt(s)")
    ap.add_argument("--dvl-bias-rw", type=float, default=None, help="GraphOptions.dvl_bias_rw, m/s/sqrt(s)")
    ap.add_argument("--prior-dvl-bias-sigma", type=float, default=None, help="GraphOptions.priors.dvl_bias_sigma, m/s")
    ap.add_argument("--json", default=None, help="write the summary and the per-run series here")
    ap.add_argument("--plot", default=None, help="write a figure (scale, error, sigma over time) here")
    args = ap.parse_args(argv)

    options = GraphOptions()
    for name in ("dvl_scale_rw", "dvl_bias_rw"):
        value = getattr(args, name)
        if value is not None:
            setattr(options, name, value)
    if args.prior_dvl_bias_sigma is not None:
        options.priors.dvl_bias_sigma = args.prior_dvl_bias_sigma
    profile = SurfacingProfile(interval_s=args.interval, stay_s=args.stay)
    cases = [(False, True), (True, True)] if args.only_on else None
    start = time.time()

    def progress(msg: str) -> None:
        print(f"  [{time.time() - start:5.0f} s] {msg}", flush=True)

    runs = surface_fix_study(args.seeds, args.duration, profile, args.imu_grade, batch=not args.no_batch,
                             options=options, cases=cases, pattern=args.pattern, progress=progress)
    rows = summary(runs)
    print(f"\n{args.pattern}, seeds {args.seeds}, {args.duration:g} s, surfacing every {args.interval:g} s for "
          f"{args.stay:g} s, {args.imu_grade} IMU, DVL scale error 0.7 %; dvl_scale_rw {options.dvl_scale_rw:g}, "
          f"dvl_bias_rw {options.dvl_bias_rw:g}")
    head = (f"{'method':10s} {'fixes':5s} {'D':3s} {'drift1 %DT':>10s} {'drift2+ %DT':>11s} {'mean err m':>10s} "
            f"{'final err m':>11s} {'sigma m':>7s} {'NEES_h':>7s} {'|ds| end':>8s} {'sig_s end':>9s} "
            f"{'|ds| prior':>10s}")
    print(head)
    for r in rows:
        print(f"{r['method']:10s} {'yes' if r['fixes'] else 'no':5s} {'on' if r['dvl_error_states'] else 'off':3s} "
              f"{r['drift_first_pct_dt']:10.3f} {r['drift_later_pct_dt']:11.3f} {r['mean_err_m']:10.2f} "
              f"{r['final_err_m']:11.2f} {r['final_sigma_m']:7.2f} {r['mean_nees_h']:7.2f} "
              f"{r.get('final_scale_err', float('nan')):8.4f} {r.get('final_scale_sigma', float('nan')):9.4f} "
              f"{r.get('prior_scale_err', float('nan')):10.4f}")
    print("\nx scale (truth 0.0070) just before each surfacing and at the end, fixed-lag, DVL error states on:")
    for seed in args.seeds:
        mission = study_mission(seed, args.duration, profile, args.imu_grade, pattern=args.pattern)
        for r in runs:
            if r.seed == seed and r.method == "fixed-lag" and r.dvl_error_states:
                marks = ", ".join(f"{t:.0f} s: {s:+.4f}+-{sg:.4f}" for t, s, sg in scale_at_surfacings(r, mission))
                print(f"  seed {seed} {'fixes' if r.fixes else 'no fixes':8s}: {marks}")
    if args.json:
        series = [{"seed": r.seed, "method": r.method, "fixes": r.fixes, "dvl_error_states": r.dvl_error_states,
                   "t": r.t.tolist(), "err_h": r.err_h.tolist(),
                   "sigma_h": None if r.sigma_h is None else np.nan_to_num(r.sigma_h, nan=-1).tolist(),
                   "t_scale": r.t_scale.tolist(), "scale_x": r.scale_x.tolist(),
                   "scale_x_sigma": None if r.scale_x_sigma is None else r.scale_x_sigma.tolist(),
                   "drift": r.drift} for r in runs]
        with open(args.json, "w") as f:
            json.dump({"summary": rows, "runs": series}, f)
    if args.plot:
        plot(runs, args.plot)


def plot(runs, path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    seed = runs[0].seed
    fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for r in runs:
        if r.seed != seed or not r.dvl_error_states:
            continue
        style = "-" if r.fixes else "--"
        ax[1].plot(r.t, r.err_h, style, label=r.label)
        if r.method == "fixed-lag":
            if len(r.t_scale):
                ax[0].plot(r.t_scale, 100 * r.scale_x, style, label=r.label)
                ax[0].fill_between(r.t_scale, 100 * (r.scale_x - r.scale_x_sigma), 100 * (r.scale_x + r.scale_x_sigma),
                                   alpha=0.2)
            if r.sigma_h is not None:
                ok = np.isfinite(r.sigma_h)
                ax[2].plot(r.t[ok], r.sigma_h[ok], style, label=r.label)
    ax[0].axhline(100 * runs[0].scale_x_true, color="k", lw=0.8, label="truth")
    ax[0].set_ylabel("DVL x scale, % (+-1 sigma)")
    ax[1].set_ylabel("horizontal error, m")
    ax[2].set_ylabel("horizontal sigma, m")
    ax[2].set_xlabel("t, s")
    for a in ax:
        a.legend(fontsize=7)
        a.grid(alpha=0.3)
    fig.suptitle(f"Surface fixes, seed {seed}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
