"""Speed of the error-state EKF replay (``graphnav.estimators.runs.run_ekf``), and a check that a faster EKF still
gives the same numbers.

1. **Split** (default): CPU time (``time.thread_time``) of one ``run_ekf`` replay per filter (TC, LC, TC-12: the
   paper's 12-state filter), split into the backend's keyframe (``EkfBackend.process``) and its parts: the
   strapdown (``Strapdown.propagate``), the per-segment transitions (``transition``: Phi, Q), their composition
   (``compose_transitions``), the DVL update (``update_tc`` / ``update_lc_beams``, of which ``_apply``: gain,
   Joseph form, correction), the depth update and ``nav_covariances``; the rest of the replay is the Navigator
   (keyframer, screening, replay) outside the backend. The timers are set on the classes of this process only
   and add a few per cent.
2. **Against a git revision** (``--reference REV``): the EKF of ``REV`` (its ``graphnav/estimators/ekf.py`` and
   ``backends.py``, loaded from git into this process) and the working tree's, run interleaved on the simulated
   mission (``--repeat`` rounds, TC, median CPU) for the before/after ratio; then both on the simulated mission
   and on the first A-KIT trajectory (when the data is there) for TC, LC and TC-12, and the largest difference
   of every output (velocity, position, attitude, biases; covariances relative to each matrix's largest entry).

    .venv/bin/python benchmarks/ekf_speed.py                      # split, simulated 400 s mission
    .venv/bin/python benchmarks/ekf_speed.py --akit               # split, first A-KIT trajectory
    .venv/bin/python benchmarks/ekf_speed.py --reference HEAD~3 --repeat 3
"""
from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from graphnav.estimators import backends, ekf, ins
from graphnav.estimators import navigator as navigator_module
from graphnav.estimators.runs import run_ekf
from graphnav.sim.simulate import simulate_mission

ROOT = Path(__file__).resolve().parents[1]
FILTERS = {"TC": (True, {}), "LC": (False, {}), "TC-12": (True, {"position_states": False, "dvl_error_states": False})}
FIELDS = ("v_n", "p_n", "C_b_n", "bias_acc", "bias_gyro", "cov_v_n", "cov_p_n", "cov_rot_b", "cov_bias")


def mission(akit: bool):
    if not akit:
        return "simulated 400 s (seed 7)", simulate_mission(400.0, seed=7)
    from graphnav.io.paths import akit_trajectories
    from graphnav.missions import load_akit
    folder = akit_trajectories()[0]
    return f"A-KIT {folder.name}", load_akit(folder)


def run(m, name: str, ekf_module=ekf):
    tight, kw = FILTERS[name]
    return run_ekf(m, tight=tight, options=ekf_module.EkfOptions(**kw))


def split(akit: bool) -> None:
    label, m = mission(akit)
    spent: dict[str, float] = {}
    hooks = [(backends.EkfBackend, "process"), (ins.Strapdown, "propagate"), (ekf.ErrorStateEkf, "transition"),
             (ekf, "compose_transitions"), (ekf.ErrorStateEkf, "update_tc"), (ekf.ErrorStateEkf, "update_lc_beams"),
             (ekf.ErrorStateEkf, "_apply"), (ekf.ErrorStateEkf, "update_depth"),
             (ekf.ErrorStateEkf, "nav_covariances")]

    def timed(owner, attr):
        call = getattr(owner, attr)

        def wrapper(*args, **kwargs):
            start = time.thread_time()
            try:
                return call(*args, **kwargs)
            finally:
                spent[attr] = spent.get(attr, 0.0) + time.thread_time() - start
        setattr(owner, attr, wrapper)
        return owner, attr, call

    originals = [timed(owner, attr) for owner, attr in hooks]
    try:
        run(m.slice(m.t0, m.t0 + 20.0), "TC")              # warm-up
        print(f"EKF replay CPU split, {label} mission ({m.duration:.0f} s), s and share of the replay")
        print("| part | " + " | ".join(FILTERS) + " |")
        print("| --- |" + " --- |" * len(FILTERS))
        rows: dict[str, list[str]] = {}
        for name in FILTERS:
            spent.clear()
            cpu = time.process_time()
            run(m, name)
            cpu = time.process_time() - cpu
            update = spent.get("update_tc", 0.0) + spent.get("update_lc_beams", 0.0)
            predict_rest = spent["process"] - sum(spent.get(k, 0.0) for k in (
                "propagate", "transition", "compose_transitions", "update_tc", "update_lc_beams", "update_depth",
                "nav_covariances"))
            parts = {"replay (x real time)": (cpu, f"{m.duration / cpu:.0f}x"),
                     "Navigator outside the backend (keyframer, screening)": (cpu - spent["process"], None),
                     "EkfBackend.process": (spent["process"], None),
                     "- Strapdown.propagate": (spent["propagate"], None),
                     "- transition (Phi, Q per segment)": (spent["transition"], None),
                     "- compose_transitions": (spent["compose_transitions"], None),
                     "- DVL update (H, S, K, Joseph, correction)": (update, None),
                     "  - of which _apply (K, Joseph, correction)": (spent.get("_apply", 0.0), None),
                     "- depth update": (spent.get("update_depth", 0.0), None),
                     "- nav_covariances": (spent.get("nav_covariances", 0.0), None),
                     "- rest (P propagation, heading, EpochEstimate)": (predict_rest, None)}
            for key, (value, note) in parts.items():
                rows.setdefault(key, []).append(f"{value:.3f}" + (f" ({note})" if note else f" ({value / cpu:.0%})"))
        for key, cells in rows.items():
            print(f"| {key} | " + " | ".join(cells) + " |")
    finally:
        for owner, attr, call in originals:
            setattr(owner, attr, call)


def reference_modules(rev: str, tmp: Path):
    """The EKF and backend modules of git revision ``rev``, loaded under their own names from ``tmp``."""
    def load(name: str, text: str):
        path = tmp / f"{name}.py"
        path.write_text(text)
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        return module

    def show(path: str) -> str:
        try:
            return subprocess.run(["git", "show", f"{rev}:{path}"], cwd=ROOT, check=True, capture_output=True,
                                  text=True).stdout
        except subprocess.CalledProcessError as exc:
            raise SystemExit(f"ekf_speed: cannot read {path} at revision '{rev}': {exc.stderr.strip()}") from None
    ref_ekf = load("_reference_ekf", show("graphnav/estimators/ekf.py"))
    text = show("graphnav/estimators/backends.py").replace("from graphnav.estimators.ekf import",
                                                           "from _reference_ekf import")
    return ref_ekf, load("_reference_backends", text)


def compare(rev: str, repeat: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        ref_ekf, ref_backends = reference_modules(rev, Path(tmp))
        variants = {rev: (ref_ekf, ref_backends.make_backend), "working tree": (ekf, backends.make_backend)}

        def use(which):
            navigator_module.make_backend = variants[which][1]

        original = navigator_module.make_backend
        try:
            label, m = "simulated 400 s (seed 0)", simulate_mission(400.0, seed=0)
            cpu: dict[str, list[float]] = {which: [] for which in variants}
            for which in variants:                          # warm-up
                use(which)
                run(m.slice(m.t0, m.t0 + 20.0), "TC", variants[which][0])
            for _ in range(repeat):                         # interleaved rounds
                for which in variants:
                    use(which)
                    start = time.process_time()
                    run(m, "TC", variants[which][0])
                    cpu[which].append(time.process_time() - start)
            print(f"EKF TC replay, {label}, CPU s, median of {repeat} interleaved rounds")
            print("| EKF | CPU s | x real time (CPU) |")
            print("| --- | --- | --- |")
            for which, values in cpu.items():
                med = float(np.median(values))
                print(f"| {which} | {med:.3f} | {m.duration / med:.0f}x |")
            ratio = np.median(cpu[rev]) / np.median(cpu["working tree"])
            print(f"speed-up (reference CPU / working-tree CPU): {ratio:.2f}\n")
            missions = [mission(False)]
            try:
                missions.append(mission(True))
            except Exception as exc:                        # no data: say so, compare on the simulation only
                print(f"(no A-KIT comparison: {exc})")
            print("Largest difference, working tree against the reference (covariances: relative to each matrix's "
                  "largest entry)")
            print("| mission | filter | " + " | ".join(FIELDS) + " | updates, gated |")
            print("| --- | --- |" + " --- |" * (len(FIELDS) + 1))
            for label, m in missions:
                for name in FILTERS:
                    sols = {}
                    for which in variants:
                        use(which)
                        sols[which] = run(m, name, variants[which][0])
                    cells = [difference(getattr(sols[rev], f), getattr(sols["working tree"], f), f) for f in FIELDS]
                    counts = [(s.info.get("n_updates"), s.info.get("n_gated")) for s in sols.values()]
                    same = "same" if counts[0] == counts[1] else f"{counts[0]} vs {counts[1]}"
                    print(f"| {label} | {name} | " + " | ".join(cells) + f" | {same} |")
        finally:
            navigator_module.make_backend = original


def difference(a, b, field: str) -> str:
    if a is None or b is None:
        return "-" if a is None and b is None else "missing in one"
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        return f"shape {a.shape} vs {b.shape}"
    diff = np.abs(a - b)
    if field.startswith("cov"):
        scale = np.abs(a).reshape(len(a), -1).max(axis=1)[:, None, None]
        diff = diff / np.where(scale > 0, scale, 1.0)
    return f"{float(np.nanmax(diff)) if diff.size else 0.0:.1e}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--akit", action="store_true", help="split on the first A-KIT trajectory, not the simulation")
    parser.add_argument("--reference", metavar="REV", help="compare against the EKF of this git revision")
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds of the comparison (default 3)")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error("--repeat must be >= 1")
    warnings.simplefilter("ignore")
    if args.reference:
        compare(args.reference, args.repeat)
    else:
        split(args.akit)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
