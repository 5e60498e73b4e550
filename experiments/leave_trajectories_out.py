"""Leave-trajectories-out study of the defaults fitted on the shared trajectories.

Runs Graph-TC, its batch smoother (Graph-TC-batch) and the tightly coupled EKF (TC) on every trajectory of an
A-KIT folder once per candidate value of each parameter (one parameter at a time, the others at their
defaults; :data:`graphnav.evaluation.crossval.PARAMETERS`), stores the per-trajectory numbers in
``<out>/grid.json`` (resumable), then chooses each parameter per fold of whole trajectories on the other folds
and scores it on the held-out fold (:func:`graphnav.evaluation.crossval.cross_validate`). Writes
``<out>/report.md`` and ``<out>/crossval.json``.

    .venv/bin/python experiments/leave_trajectories_out.py --data /work/shared/data/snapir-2022-akit \
        --out out/loto --jobs 1
    .venv/bin/python experiments/leave_trajectories_out.py --out out/loto --report-only
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

from graphnav.commands.common import name_value_pairs
from graphnav.core.errors import ConfigError
from graphnav.evaluation import crossval
from graphnav.evaluation.bench import find_trajectories, load_results
from graphnav.io.outputs import write_json


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="folder of A-KIT trajectory folders (a folder of symlinks selects some)")
    ap.add_argument("--out", default="out/loto", help="output folder (grid.json, report.md, crossval.json)")
    ap.add_argument("--params", nargs="+", default=["imu_noise_scale", "dvl_bias_rw", "dvl_scale_rw"],
                    choices=list(crossval.PARAMETERS), type=crossval.parameter_name)
    ap.add_argument("--scenarios", nargs="+", default=["none", "3-missing"])
    ap.add_argument("--methods", nargs="+", default=list(crossval.STUDY_METHODS))
    ap.add_argument("--graph-base", nargs="*", default=[], metavar="NAME=VALUE",
                    help="GraphOptions values every run uses (e.g. a value chosen in an earlier round)")
    ap.add_argument("--config-base", nargs="*", default=[], metavar="NAME=V",
                    help="imu_noise_scale=S and/or accel_bias_rw=W applied to every run before the varied parameter")
    ap.add_argument("--grid", nargs="*", default=[], metavar="NAME=V1,V2,...",
                    help="candidate values of a parameter instead of its default grid")
    ap.add_argument("--study-defaults", nargs="*", default=[], metavar="NAME=VALUE",
                    help="the default a stored grid was run around, when it has changed since (report only)")
    ap.add_argument("--rule", choices=crossval.RULES, default=None,
                    help="selection rule for every parameter (default: each parameter's own)")
    ap.add_argument("--vrmse-tol", type=float, default=crossval.VRMSE_TOL)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--report-only", action="store_true", help="only cross-validate the stored grid.json")
    args = ap.parse_args(argv)
    out = Path(args.out)
    grid_path = out / "grid.json"
    graph_base, config_base = name_value_pairs(args.graph_base), name_value_pairs(args.config_base)
    unknown = sorted(set(config_base) - set(crossval.CONFIG_BASE_KEYS))
    if unknown:
        raise ConfigError(f"--config-base: unknown key(s) {', '.join(unknown)}; known: "
                          f"{', '.join(crossval.CONFIG_BASE_KEYS)}")
    for item in args.grid:
        name, _, values = item.partition("=")
        name = crossval.parameter_name(name)
        if name not in crossval.PARAMETERS or not values:
            raise SystemExit(f"--grid {item}: expected one of {', '.join(crossval.PARAMETERS)}=V1,V2,...")
        spec = crossval.PARAMETERS[name]
        crossval.PARAMETERS[name] = dataclasses.replace(spec, grid=tuple(float(v) for v in values.split(",")))
    for name, value in name_value_pairs(args.study_defaults).items():
        name = crossval.parameter_name(name)
        crossval.PARAMETERS[name] = dataclasses.replace(crossval.PARAMETERS[name], default=value)
    try:
        if not args.report_only:
            if not args.data:
                raise ConfigError("--data is required unless --report-only")
            sources = find_trajectories(args.data)
            # all-beam runs first: the selection needs them; 3-missing only scores the chosen values
            tasks = [t for sc in args.scenarios
                     for t in crossval.grid_tasks(sources, args.params, [sc], args.methods, graph_base, config_base)]
            start = time.time()
            print(f"{len(tasks)} grid runs over {len(sources)} trajectories", flush=True)
            crossval.run_grid(tasks, grid_path, args.jobs,
                              progress=lambda s: print(f"[{time.time() - start:6.0f} s] {s}", flush=True))
        table = [r for r in load_results(grid_path) if not r.get("error")
                 and r.get("graph_base", {}) == graph_base and r.get("config_base", {}) == config_base]
        table = crossval.expand_constant(table)
        names = sorted({r["trajectory"] for r in table})
        folds = crossval.folds_for(names)
        results, lines = [], ["# Leave-trajectories-out study", "",
                              f"Folds (whole trajectories): {'; '.join(', '.join(f) for f in folds)}  ",
                              f"Base settings: graph {graph_base or 'defaults'}, config {config_base or 'defaults'}",
                              ""]
        for p in args.params:
            rule = args.rule or crossval.PARAMETERS[p].rule
            ran = [m for m in args.methods if any(r["parameter"] == p and r["method"] == m for r in table)]
            shared = crossval.sharing_methods(p, ran)
            # each method's own choice, then the one default the methods sharing the parameter get
            for m, with_ in [(m, ()) for m in shared] + ([(m, shared) for m in shared] if len(shared) > 1 else []):
                try:
                    results.append(crossval.cross_validate(table, folds, m, p, rule, "none", args.vrmse_tol,
                                                           score_scenarios=[s for s in args.scenarios
                                                                            if s != "none"], shared_with=with_))
                except ConfigError as exc:
                    print(f"{p} / {m}: {exc}", file=sys.stderr)
        lines += [crossval.report(results), ""]
        for p in args.params:
            lines.append(crossval.per_trajectory_table(table, p, args.methods))
        text = "\n".join(lines)
        out.mkdir(parents=True, exist_ok=True)
        (out / "report.md").write_text(text)
        write_json(out / "crossval.json", results)
        print(text)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
