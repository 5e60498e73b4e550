"""Figures of the command-line uses (matplotlib, Agg backend, PNG).

* :func:`plot_trajectories`: North-East track of every method against ground truth, outage windows marked.
* :func:`plot_velocity_errors`: NED velocity error per axis with the estimator's +-1 sigma sleeve.
* :func:`plot_velocity_std`: velocity standard deviation over time around the outage windows.
* :func:`plot_vrmse_bars`: window VRMSE per method and scenario from benchmark records.
* :func:`plot_nees`: velocity NEES over time per method with the chi-square band (consistency).
* :func:`plot_position_error`: north, east and horizontal position error with the estimator's +-2 sigma.

Every function takes a path, writes one PNG there and returns the path. A method has one colour, marker and
dash in every figure (:func:`method_style`, fixed by the registry's order) and a scenario one colour and
hatch (:data:`SCENARIO_STYLES`); two methods whose results agree to :data:`IDENTICAL_TOL` draw on top of each
other, so the legend names the second "(identical to X)" (:func:`same_as`).
"""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: works on headless machines and inside worker processes
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from graphnav.core.scenarios import SCENARIOS  # noqa: E402
from graphnav.core.solution import NavSolution  # noqa: E402

AXES_NED = ("north", "east", "down")
#: Fourteen well-separated colours, given to the methods in the registry's order (a method looks the same in
#: every figure; methods beyond fourteen reuse a colour with another marker and dash).
_PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
            "#17becf", "#000000", "#f4a6a6", "#0b5d1e", "#c49c00", "#5e3c99", "#80cdc1", "#b35806", "#4d4d4d",
            "#a6d854", "#fb9a99", "#01665e", "#762a83", "#e7298a")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">", "h", "p", "d", "8", "H", "1", "2", "3", "4", "+",
            "x", "|", ".")
#: Dashes by registry position: identical results drawn on top of each other stay visible as two patterns.
_DASHES = ("-", "--", "-.", ":", (0, (5, 1.5)), (0, (3, 1, 1, 1, 1, 1)))
#: Scenario colours and hatches of the bar charts: every scenario its own.
SCENARIO_STYLES: dict[str, tuple[str, str]] = {
    "none": ("#9e9e9e", ""), "2-missing": ("#1f77b4", "//"), "3-missing": ("#d62728", "xx"),
    "0-beams": ("#6a1b9a", ".."), "markov": ("#ff7f0e", "\\\\")}
#: Two series whose values agree to this (their own units) are one result drawn twice; the legend says so.
IDENTICAL_TOL = 1e-9


def method_style(method: str) -> dict:
    """Colour, marker and dash of ``method`` (keyword arguments of ``Axes.plot``), fixed by its position in the
    method registry (:data:`graphnav.evaluation.methods.METHODS`); a name outside it gets the next free slot
    of its hash, so the same name always looks the same."""
    from graphnav.evaluation.methods import METHODS
    names = list(METHODS)
    i = names.index(method) if method in names else len(names) + sum(map(ord, method)) % 7
    return {"color": _PALETTE[i % len(_PALETTE)], "marker": _MARKERS[(i + i // len(_PALETTE)) % len(_MARKERS)],
            "linestyle": _DASHES[i % len(_DASHES)]}


def scenario_style(scenario: str, j: int = 0) -> tuple[str, str]:
    """(colour, hatch) of a scenario's bars."""
    return SCENARIO_STYLES.get(scenario, (f"C{(j + 5) % 10}", "--"))


def _line(method: str, n: int, lw: float = 1.2) -> dict:
    """Plot keywords of a method's line with ``n`` points: its colour and dash, a marker every ~12th point."""
    style = method_style(method)
    return {**style, "lw": lw, "ms": 4, "markevery": max(1, n // 12), "markerfacecolor": "none"}


def same_as(solutions: list[NavSolution], tol: float = IDENTICAL_TOL) -> dict[int, str]:
    """Index -> the method of an earlier solution with the same result (same stamps; position, velocity and
    velocity covariance within ``tol``): two methods that agree draw on top of each other, and the legend
    must say why only one line shows."""
    def equal(a: NavSolution, b: NavSolution) -> bool:
        if a.t.shape != b.t.shape or not np.array_equal(a.t, b.t):
            return False
        pairs = [(a.p_n, b.p_n), (a.v_n, b.v_n)]
        if (a.cov_v_n is None) != (b.cov_v_n is None):
            return False
        if a.cov_v_n is not None:
            pairs.append((a.cov_v_n, b.cov_v_n))
        return all(np.allclose(x, y, rtol=0.0, atol=tol, equal_nan=True) for x, y in pairs)
    out = {}
    for i, sol in enumerate(solutions):
        for j in range(i):
            if j not in out and equal(solutions[j], sol):
                out[i] = solutions[j].method
                break
    return out


def _labels(solutions: list[NavSolution], tol: float = IDENTICAL_TOL) -> list[str]:
    """Legend labels: the method, and "(identical to X)" when an earlier one gave the same result."""
    twins = same_as(solutions, tol)
    return [f"{s.method} (identical to {twins[i]})" if i in twins else s.method for i, s in enumerate(solutions)]


def _color(method: str, i: int = 0) -> str:
    return method_style(method)["color"]


def _legend_below(fig, ax, ncol: int = 4) -> None:
    """The legend of ``ax`` under the figure, so it never hides a line or a bar."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower center", ncol=min(ncol, len(handles)), fontsize=8,
                   bbox_to_anchor=(0.5, -0.01), frameon=False)


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def _windows(outages) -> list[tuple[float, float]]:
    """(start, end) of outage windows given as Outage objects or (start, end) pairs."""
    out = []
    for o in outages or ():
        out.append((o.start_s, o.end_s) if hasattr(o, "start_s") else (float(o[0]), float(o[1])))
    return out


def _mark_windows(ax, windows, label: bool = True) -> None:
    for i, (a, b) in enumerate(windows):
        ax.axvspan(a, b, color="#ffcdd2", alpha=0.6, lw=0, label="outage window" if (label and i == 0) else None)


def gt_at(gt, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ground-truth NED position and velocity at stamps t (:meth:`GroundTruth.at`; NaN outside GT's span)."""
    inside = (t >= gt.t[0]) & (t <= gt.t[-1])
    p, v = np.full((len(t), 3), np.nan), np.full((len(t), 3), np.nan)
    if inside.any():
        p[inside], v[inside], _ = gt.at(t[inside])
    return p, v


def plot_trajectories(gt, solutions: list[NavSolution], outages, path, title: str = "") -> Path:
    """Left: North (up) vs East (right) of ground truth and every solution, GT inside outage windows in red.
    Right: horizontal position error over time (m), where metres of difference show that the track hides."""
    fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(14, 6.2), gridspec_kw={"width_ratios": [1.1, 1]})
    if gt is not None:
        ax.plot(gt.p_n[:, 1], gt.p_n[:, 0], color="k", lw=2.5, alpha=0.5, label="ground truth", zorder=1)
        for i, (a, b) in enumerate(_windows(outages)):
            sel = (gt.t >= a) & (gt.t <= b)
            ax.plot(gt.p_n[sel, 1], gt.p_n[sel, 0], color="red", lw=5, alpha=0.5, zorder=1,
                    label="GT during outage" if i == 0 else None)
        ax.plot(gt.p_n[0, 1], gt.p_n[0, 0], "k^", ms=9, label="start")
    labels = _labels(solutions)
    for sol, label in zip(solutions, labels):
        ax.plot(sol.p_n[:, 1], sol.p_n[:, 0], label=label, zorder=2, **_line(sol.method, len(sol.t)))
    ax.set_xlabel("East (m)")
    ax.set_ylabel("North (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.set_title("North-East track")
    if gt is not None:
        _mark_windows(ax_err, _windows(outages))
        for sol in solutions:
            p_gt, _ = gt_at(gt, sol.t)
            ax_err.plot(sol.t, np.hypot(*(sol.p_n[:, :2] - p_gt[:, :2]).T), **_line(sol.method, len(sol.t)))
        ax_err.set_xlabel("time (s)")
        ax_err.set_ylabel("horizontal position error (m)")
        ax_err.grid(alpha=0.3)
        ax_err.set_title("Horizontal position error")
    else:
        ax_err.set_visible(False)          # no reference: no error to show
    fig.suptitle(title or "Trajectory")
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    _legend_below(fig, ax, ncol=5)
    return _save(fig, path)


def plot_velocity_errors(gt, solutions: list[NavSolution], outages, path, title: str = "",
                         t_range: tuple[float, float] | None = None) -> Path:
    """Velocity error (estimate - GT, NED, m/s) per axis, with the +-1 sigma sleeve where a covariance exists."""
    fig, axes = plt.subplots(3, 1, figsize=(10, 7.5), sharex=True)
    windows = _windows(outages)
    # GT at each solution's (selected) stamps, once for the three axes
    selected = []
    for sol in solutions:
        sel = slice(None) if t_range is None else (sol.t >= t_range[0]) & (sol.t <= t_range[1])
        selected.append((sel, sol.t[sel], gt_at(gt, sol.t[sel])[1]))
    labels = _labels(solutions)
    twins = same_as(solutions)
    for k, ax in enumerate(axes):
        _mark_windows(ax, windows, label=k == 0)
        for i, (sol, (sel, t, v_gt)) in enumerate(zip(solutions, selected)):
            err = sol.v_n[sel, k] - v_gt[:, k]
            style = _line(sol.method, len(t), lw=1.0)
            ax.plot(t, err, label=labels[i] if k == 0 else None, **style)
            if sol.cov_v_n is not None and i not in twins:      # a twin's sleeve is the same sleeve
                s = np.sqrt(np.clip(sol.cov_v_n[sel, k, k], 0, None))
                ax.plot(t, s, color=style["color"], lw=0.6, ls=":", alpha=0.9)
                ax.plot(t, -s, color=style["color"], lw=0.6, ls=":", alpha=0.9)
                ax.fill_between(t, -s, s, color=style["color"], alpha=0.08, lw=0,
                                label="+-1 sigma (dotted edges)" if (k == 0 and i == min(
                                    j for j, o in enumerate(solutions) if o.cov_v_n is not None)) else None)
        ax.axhline(0, color="k", lw=0.5)
        if t_range is not None:
            ax.set_xlim(*t_range)
        ax.set_ylabel(f"v {AXES_NED[k]} error (m/s)")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title or "Velocity error with +-1 sigma")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    _legend_below(fig, axes[0])
    return _save(fig, path)


def plot_velocity_std(solutions: list[NavSolution], outages, path, title: str = "",
                      margin_before_s: float = 20.0, margin_after_s: float = 40.0) -> Path:
    """Velocity standard deviation per NED axis (m/s, log scale) from the estimators' covariance over time
    around the first outage window (the paper's figure); solutions without covariance are skipped."""
    windows = _windows(outages)
    if windows:
        t0, t1 = windows[0][0] - margin_before_s, windows[0][1] + margin_after_s
    else:
        t0, t1 = -math.inf, math.inf
    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True)
    with_cov = [s for s in solutions if s.cov_v_n is not None]
    labels = _labels(with_cov)
    for k, ax in enumerate(axes):
        _mark_windows(ax, [w for w in windows if w[1] >= t0 and w[0] <= t1], label=k == 0)
        for sol, label in zip(with_cov, labels):
            sel = (sol.t >= t0) & (sol.t <= t1)
            ax.plot(sol.t[sel], np.sqrt(np.clip(sol.cov_v_n[sel, k, k], 1e-12, None)),
                    label=label if k == 0 else None, **_line(sol.method, int(sel.sum()), lw=1.3))
        ax.set_yscale("log")
        ax.set_ylabel(f"std v {AXES_NED[k]} (m/s)")
        ax.grid(alpha=0.3, which="both")
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title or "Velocity standard deviation around the outage window")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    _legend_below(fig, axes[0])
    return _save(fig, path)


def plot_nees(gt, solutions: list[NavSolution], outages, path, title: str = "", smooth_s: float = 10.0,
              settle_s: float = 60.0) -> Path:
    """Velocity NEES over time (log scale) of every solution with a covariance: per epoch (thin) and its
    running mean over ``smooth_s`` (thick), with the 95 % chi-square band of one epoch (3 dof) and of a
    ``smooth_s`` mean (one independent epoch per second assumed, so the band is indicative).

    ``gt``: the ground truth, or the mission (then each solution is scored against the GT carried to its
    epochs by the IMU, as the benchmark's NEES is: :func:`graphnav.evaluation.consistency.scoring_reference`)."""
    from graphnav.evaluation.consistency import DOF, chi2_band, nees_time_series, scoring_reference
    fig, ax = plt.subplots(figsize=(10, 4.5))
    _mark_windows(ax, _windows(outages))
    lo1, hi1 = chi2_band(1)
    lo, hi = chi2_band(max(int(smooth_s), 1))
    ax.axhspan(lo1, hi1, color="0.85", alpha=0.5, label="95 % band, one epoch")
    ax.axhspan(lo, hi, color="#a5d6a7", alpha=0.6, label=f"95 % band, {smooth_s:g} s mean")
    ax.axhline(DOF, color="k", lw=0.8, ls="--")
    with_cov = [s for s in solutions if s.cov_v_n is not None]
    for sol, label in zip(with_cov, _labels(with_cov)):
        reference = scoring_reference(sol, gt) if hasattr(gt, "imu") else gt
        t, nees = nees_time_series(sol, reference, sol.t[0] + settle_s)
        style = _line(sol.method, len(t), lw=1.6)
        ax.plot(t, np.clip(nees, 1e-3, None), color=style["color"], lw=0.4, alpha=0.4)
        n = max(int(round(smooth_s / max(float(np.median(np.diff(t))), 1e-3))), 1) if len(t) > 1 else 1
        mean = np.convolve(nees, np.ones(n) / n, mode="same")
        ax.plot(t, np.clip(mean, 1e-3, None), label=f"{label} (mean {np.mean(nees):.1f})", **style)
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("velocity NEES (3 dof)")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(title or "Velocity NEES over time")
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    _legend_below(fig, ax, ncol=3)
    return _save(fig, path)


def plot_vrmse_bars(records: list[dict], path, imu_grade: str | None = None, title: str = "",
                    methods: list[str] | None = None) -> Path:
    """Window VRMSE per method (groups) and scenario (bars): mean over windows and trajectories, with a
    tick at the worst window. Log scale, because classical LC can be 100x worse than the rest."""
    from graphnav.evaluation.methods import METHODS
    rs = [r for r in records if not r.get("error") and r.get("vrmse_window") is not None
          and (imu_grade is None or r["imu_grade"] == imu_grade)]
    methods = methods or [m for m in METHODS if any(r["method"] == m for r in rs)]
    scenarios = [s for s in SCENARIOS if any(r["scenario"] == s for r in rs)]
    fig, ax = plt.subplots(figsize=(min(16.0, max(7.0, 0.3 * len(methods) * max(1, len(scenarios)) + 2)), 5.2))
    width = 0.84 / max(1, len(scenarios))
    x = np.arange(len(methods))
    # Value labels sit in a row of their own at the foot of each bar, one per bar, rotated: they cannot
    # collide with each other, with the worst-window ticks or with the legend (outside the axes).
    foot = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
    for j, sc in enumerate(scenarios):
        means, worst = [], []
        for m in methods:
            v = [r["vrmse_window"] for r in rs if r["method"] == m and r["scenario"] == sc]
            means.append(np.mean(v) if v else np.nan)
            worst.append(np.max(v) if v else np.nan)
        pos = x + (j - (len(scenarios) - 1) / 2) * width
        color, hatch = scenario_style(sc, j)
        ax.bar(pos, means, width * 0.95, color=color, hatch=hatch, edgecolor="white", lw=0.5,
               label=f"{sc} (mean)")
        ax.plot(pos, worst, "_", color="k", ms=max(4.0, 40 * width), mew=2,
                label="worst window" if j == 0 else None)
        for p, v in zip(pos, means):
            if np.isfinite(v):
                ax.text(p, 0.015, f"{v:.3f}", transform=foot, ha="center", va="bottom", fontsize=7,
                        rotation=90, bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none",
                                           "alpha": 0.85})
    # room under the shortest bar for its label on the log axis
    ax.set_ylim(bottom=min([v for v in (r["vrmse_window"] for r in rs) if v > 0] or [1e-3]) / 3)
    ax.set_xticks(x, methods, rotation=30, ha="right")
    ax.set_yscale("log")
    ax.set_ylabel("window VRMSE (m/s)")
    ax.grid(axis="y", alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)  # outside: hides no bar
    ax.set_title(title or f"Window VRMSE per method{'' if imu_grade is None else f' ({imu_grade} IMU)'}")
    fig.tight_layout()
    return _save(fig, path)


def plot_position_error(gt, solutions: list[NavSolution], outages, path, title: str = "",
                        n_sigma: float = 2.0) -> Path:
    """Position error against the reference (estimate - GT, m) over time: north and east with the
    estimator's +-``n_sigma`` sleeve from ``cov_p_n``, and the horizontal error norm with ``n_sigma`` times
    the square root of the largest eigenvalue of the north-east covariance (the semi-major axis of the error
    ellipse: a norm outside it is outside the ellipse in every direction). A solution without ``cov_p_n`` is
    drawn without a sleeve and says so in the legend."""
    fig, axes = plt.subplots(3, 1, figsize=(10, 8.5), sharex=True)
    windows = _windows(outages)
    for k, ax in enumerate(axes):
        _mark_windows(ax, windows, label=k == 0)
    for i, sol in enumerate(solutions):
        c = _color(sol.method, i)
        p_gt, _ = gt_at(gt, sol.t)
        err = sol.p_n[:, :2] - p_gt[:, :2]
        name = sol.method if sol.cov_p_n is not None else f"{sol.method} (no position covariance)"
        for k in range(2):
            axes[k].plot(sol.t, err[:, k], color=c, lw=1.0, label=name)
            if sol.cov_p_n is not None:
                s = n_sigma * np.sqrt(np.clip(sol.cov_p_n[:, k, k], 0, None))
                axes[k].fill_between(sol.t, -s, s, color=c, alpha=0.18, lw=0,
                                     label=f"{sol.method} +-{n_sigma:g} sigma" if k == 0 else None)
        axes[2].plot(sol.t, np.hypot(err[:, 0], err[:, 1]), color=c, lw=1.0, label=name)
        if sol.cov_p_n is not None:
            ne = sol.cov_p_n[:, :2, :2]
            finite = np.all(np.isfinite(ne.reshape(len(ne), -1)), axis=1)   # a file's empty sigma rows
            major = np.full(len(ne), np.nan)
            major[finite] = np.sqrt(np.clip(np.linalg.eigvalsh(ne[finite])[:, -1], 0, None))
            axes[2].plot(sol.t, n_sigma * major, color=c, lw=1.0, ls="--",
                         label=f"{sol.method} {n_sigma:g} sigma (major axis)")
    for k, name in enumerate(("north error (m)", "east error (m)", "horizontal error (m)")):
        axes[k].axhline(0, color="k", lw=0.5)
        axes[k].set_ylabel(name)
        axes[k].grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=3, loc="upper left")
    axes[2].legend(fontsize=8, ncol=2, loc="upper left")
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title or f"Position error with +-{n_sigma:g} sigma")
    fig.tight_layout()
    return _save(fig, path)
