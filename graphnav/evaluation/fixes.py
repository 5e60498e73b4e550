"""What surface GNSS fixes buy: simulated missions with surfacings, run with and without their fixes.

An AUV that dead-reckons on its DVL drifts with the DVL's scale error (0.7 % of the distance travelled for a
0.7 % scale) and its heading error. Surfacing for a GNSS fix resets the position; with the DVL error states
of the graph (:mod:`graphnav.estimators.graph.dvl_errors`) two fixes also tell the graph how far the vehicle
really went while the DVL said otherwise, so the scale becomes observable and the drift between later fixes
falls. :func:`surface_fix_study` measures both on simulated missions
(:class:`graphnav.sim.simulate.SurfacingProfile`); ``experiments/surface_fixes.py`` prints its table.

Per run (one seed, fixes on or off, DVL error states on or off) it records, at every keyframe of the
fixed-lag smoother (the filtered estimate, what the vehicle knows at that time) and of the batch smoother over
the same keyframes (what post-processing makes of the mission):

- the horizontal position error against the ground truth, m, and the estimator's own horizontal sigma,
  ``sqrt(trace of the NED north/east covariance)`` m (fixed-lag; the batch gives no position covariance);
- the DVL scale estimate of the DVL's x axis and its sigma (fixed-lag: the marginal of ``D(k)``, sampled
  every ``sample_s``), against the simulated truth;
- the drift before each surfacing: the horizontal error just before its first fix, in % of the distance
  travelled (ground truth path length) since the last fix used (or since the start: the initial state is the
  ground truth), :func:`drift_before_surfacings`.
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field

import numpy as np

from graphnav.core.mission import Mission
from graphnav.estimators.graph.batch import batch_smooth
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.navigator import feed_mission
from graphnav.estimators.runs import graph_navigator
from graphnav.sim.simulate import SurfacingProfile, simulate_mission

#: DVL scale error of the study's missions (per DVL axis): the simulator's default, 0.7 %.
STUDY_SCALE = 0.007


@dataclass
class FixRun:
    """One estimator run of the study (see the module docstring; times in s, positions in m).

    Attributes:
        seed, fixes, dvl_error_states, method: the case (``method`` ``"fixed-lag"`` or ``"batch"``).
        t: (K,) keyframe stamps; err_h: (K,) horizontal position error; sigma_h: (K,) horizontal sigma or None.
        nees_h: (K,) horizontal position NEES (2 degrees of freedom) or None.
        t_scale, scale_x, scale_x_sigma: stamps, x-axis DVL scale estimate and its sigma (sigma None for the
            batch); empty without DVL error states.
        scale_x_true: the simulated scale error of the DVL's x axis.
        drift: per surfacing, :func:`drift_before_surfacings`.
    """

    seed: int
    fixes: bool
    dvl_error_states: bool
    method: str
    t: np.ndarray
    err_h: np.ndarray
    sigma_h: np.ndarray | None
    nees_h: np.ndarray | None
    t_scale: np.ndarray
    scale_x: np.ndarray
    scale_x_sigma: np.ndarray | None
    scale_x_true: float
    drift: list[dict] = field(default_factory=list)

    @property
    def label(self) -> str:
        return (f"{self.method} {'fixes' if self.fixes else 'no fixes'}, DVL error states "
                f"{'on' if self.dvl_error_states else 'off'}")


def study_mission(seed: int, duration_s: float = 2400.0, profile: SurfacingProfile | None = None,
                  imu_grade: str = "navigation", scale: float = STUDY_SCALE, pattern: str = "lawnmower") -> Mission:
    """A simulated survey (``pattern``, see :func:`graphnav.sim.simulate.simulate_mission`) with surfacings
    (default :class:`SurfacingProfile`: every 10 min, 30 s at the surface, 1 Hz fixes of 2-3 m) and a DVL scale
    error ``scale`` on every DVL axis."""
    from graphnav.sim.simulate import default_config
    config = default_config()
    config.dvl.scale_factor = np.full(3, float(scale))
    return simulate_mission(duration_s, imu_grade, seed, config=config, surfacing=profile or SurfacingProfile(),
                            pattern=pattern)


def path_length(mission: Mission, t: np.ndarray) -> np.ndarray:
    """(K,) horizontal distance travelled (ground truth) from the first ground-truth sample to stamps t, m."""
    p = mission.gt.p_n[:, :2]
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]
    return np.interp(t, mission.gt.t, s)


def horizontal_nees(err_ne: np.ndarray, cov_p_n: np.ndarray) -> np.ndarray:
    """(K,) NEES of horizontal errors (K,2) m with NED position covariances (K,3,3) m^2 (expected value 2)."""
    P = cov_p_n[:, :2, :2]
    return np.einsum("ki,ki->k", err_ne, np.linalg.solve(P, err_ne[..., None])[..., 0])


def drift_before_surfacings(mission: Mission, t: np.ndarray, err_h: np.ndarray, fixes_used: bool) -> list[dict]:
    """Per stay at the surface (``mission.meta["surface_windows"]``, those with a fix): ``t`` (stamp of the
    last estimate before its first fix, s), ``error_m`` (horizontal error there), ``distance_m`` (ground-truth
    path since the last fix used, or since the start when ``fixes_used`` is False or before the first fix)
    and ``percent_dt`` (100 * error / distance)."""
    out = []
    t_last_fix = float(t[0])
    fixes = mission.fixes
    for w0, w1 in mission.meta.get("surface_windows", []):
        in_window = fixes.t[(fixes.t >= w0 - 1e-9) & (fixes.t <= w1 + 1e-9)] if fixes is not None else []
        if not len(in_window):
            continue
        before = np.flatnonzero(t < in_window[0])
        if not before.size:
            continue
        i = int(before[-1])
        distance = float(path_length(mission, np.array([t[i]]))[0] - path_length(mission, np.array([t_last_fix]))[0])
        out.append({"t": float(t[i]), "error_m": float(err_h[i]), "distance_m": distance,
                    "percent_dt": 100.0 * float(err_h[i]) / distance if distance > 0 else float("nan")})
        if fixes_used:
            t_last_fix = float(in_window[-1])
    return out


def run_case(mission: Mission, fixes: bool, dvl_error_states: bool, batch: bool = True,
             sample_s: float = 10.0, options: GraphOptions | None = None) -> list[FixRun]:
    """The fixed-lag smoother (and with ``batch`` the batch smoother over its keyframes) on ``mission`` with or
    without its fixes; returns one :class:`FixRun` per method."""
    options = dataclasses.replace(options or GraphOptions(), dvl_error_states=dvl_error_states)
    run_mission = mission if fixes else dataclasses.replace(mission, fixes=None)
    nav = graph_navigator(run_mission, options=options, backend="fixed-lag", init="gt", keep_keyframe_graphs=batch,
                          name="Graph-TC fixed-lag")
    covs, scale = [], []
    next_sample = [-np.inf]
    fix_t = mission.fixes.t if fixes and mission.fixes is not None else np.zeros(0)

    def near_fix(t: float) -> bool:
        i = np.searchsorted(fix_t, t)
        return any(abs(fix_t[j] - t) <= 1.5 for j in (i - 1, i) if 0 <= j < len(fix_t))

    def record(est):
        if est.t < next_sample[0] and not near_fix(est.t):   # every keyframe around a fix, else sampled
            covs.append(None)
            return
        next_sample[0] = est.t + sample_s
        covs.append(None if est.cov_p_n is None else np.asarray(est.cov_p_n))
        if dvl_error_states:
            d, cov_d = nav.dvl_errors(est.index)
            scale.append((est.t, d[0], float(np.sqrt(cov_d[0, 0]))))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        estimates = feed_mission(nav, run_mission, record)
    truth = float(mission.meta["dvl_errors"]["scale_factor"][0])
    runs = [_fix_run(mission, "fixed-lag", fixes, dvl_error_states, estimates, covs, scale, truth)]
    if batch:
        smoothed, info = batch_smooth(nav.keyframe_graphs(), estimates,
                                      dataclasses.replace(options, marginals=False))
        d = info.get("dvl_errors")
        t = np.array([e.t for e in smoothed])
        scale_b = [] if d is None else [(tk, dk[0], float("nan")) for tk, dk in zip(t, d)]
        runs.append(_fix_run(mission, "batch", fixes, dvl_error_states, smoothed, [None] * len(smoothed), scale_b,
                             truth))
    return runs


def _fix_run(mission: Mission, method: str, fixes: bool, dvl_error_states: bool, estimates, covs, scale,
             truth: float) -> FixRun:
    t = np.array([e.t for e in estimates])
    p = np.array([e.p_n for e in estimates])
    p_true = mission.gt.at(t)[0]
    err_ne = p[:, :2] - p_true[:, :2]
    err_h = np.linalg.norm(err_ne, axis=1)
    have = np.array([c is not None for c in covs])
    sigma_h = nees = None
    if have.any():
        cov = np.full((len(t), 3, 3), np.nan)
        cov[have] = np.array([c for c in covs if c is not None])
        sigma_h = np.sqrt(cov[:, 0, 0] + cov[:, 1, 1])
        nees = np.full(len(t), np.nan)
        nees[have] = horizontal_nees(err_ne[have], cov[have])
    scale = np.array(scale, float).reshape(-1, 3)
    scale_sigma = scale[:, 2] if method != "batch" else None
    return FixRun(int(mission.meta["seed"]), fixes, dvl_error_states, method, t, err_h, sigma_h, nees,
                  scale[:, 0], scale[:, 1], scale_sigma, truth, drift_before_surfacings(mission, t, err_h, fixes))


def surface_fix_study(seeds=(1, 2, 3), duration_s: float = 2400.0, profile: SurfacingProfile | None = None,
                      imu_grade: str = "navigation", batch: bool = True, sample_s: float = 10.0,
                      options: GraphOptions | None = None, cases=None, progress=None,
                      pattern: str = "lawnmower") -> list[FixRun]:
    """Every case on every seed's mission (:func:`study_mission`): ``cases`` is a list of (fixes,
    dvl_error_states), default all four. ``progress(message)`` is called after each run."""
    cases = cases or [(False, True), (True, True), (False, False), (True, False)]
    runs: list[FixRun] = []
    for seed in seeds:
        mission = study_mission(seed, duration_s, profile, imu_grade, pattern=pattern)
        for fixes, dvl_errors in cases:
            new = run_case(mission, fixes, dvl_errors, batch, sample_s, options)
            runs += new
            if progress is not None:
                for r in new:
                    progress(f"seed {seed}: {r.label}: final error {r.err_h[-1]:.2f} m")
    return runs


def summary(runs: list[FixRun]) -> list[dict]:
    """One row per case (method, fixes, DVL error states) over the seeds: mean drift before a surfacing
    (% DT; the first surfacing, measured from the start, and the later ones, from the previous fix, apart),
    mean and final horizontal error (m), final horizontal sigma (m), mean horizontal NEES, final x scale
    estimate error |s - s_true| and sigma, and the prior scale error |s_true| it started from."""
    rows = []
    keys = sorted({(r.method, r.fixes, r.dvl_error_states) for r in runs}, key=lambda k: (k[0] != "fixed-lag",
                                                                                         not k[2], k[1]))
    for method, fixes, dvl_errors in keys:
        sel = [r for r in runs if (r.method, r.fixes, r.dvl_error_states) == (method, fixes, dvl_errors)]
        first = [r.drift[0]["percent_dt"] for r in sel if r.drift]
        later = [d["percent_dt"] for r in sel for d in r.drift[1:]]
        row = {"method": method, "fixes": fixes, "dvl_error_states": dvl_errors, "n_seeds": len(sel),
               "drift_first_pct_dt": float(np.mean(first)) if first else float("nan"),
               "drift_later_pct_dt": float(np.mean(later)) if later else float("nan"),
               "mean_err_m": float(np.mean([r.err_h.mean() for r in sel])),
               "final_err_m": float(np.mean([r.err_h[-1] for r in sel]))}
        sig = [r.sigma_h[np.isfinite(r.sigma_h)][-1] for r in sel if r.sigma_h is not None]
        row["final_sigma_m"] = float(np.mean(sig)) if sig else float("nan")
        nees = [np.nanmean(r.nees_h) for r in sel if r.nees_h is not None]
        row["mean_nees_h"] = float(np.mean(nees)) if nees else float("nan")
        if dvl_errors and all(len(r.scale_x) for r in sel):
            row["final_scale_err"] = float(np.mean([abs(r.scale_x[-1] - r.scale_x_true) for r in sel]))
            sigmas = [r.scale_x_sigma[-1] for r in sel if r.scale_x_sigma is not None]
            row["final_scale_sigma"] = float(np.mean(sigmas)) if sigmas else float("nan")
            row["prior_scale_err"] = float(np.mean([abs(r.scale_x_true) for r in sel]))
        rows.append(row)
    return rows


def scale_at_surfacings(run: FixRun, mission: Mission) -> list[tuple[float, float, float]]:
    """(t s, x scale estimate, its sigma) just before each surfacing and at the end of ``run``: how the scale
    converges from one fix to the next."""
    out = []
    if not len(run.t_scale):
        return out
    marks = [w[0] for w in mission.meta.get("surface_windows", [])] + [float(run.t_scale[-1]) + 1.0]
    for t_mark in marks:
        i = np.flatnonzero(run.t_scale < t_mark)
        if i.size:
            k = int(i[-1])
            sigma = float(run.scale_x_sigma[k]) if run.scale_x_sigma is not None else float("nan")
            out.append((float(run.t_scale[k]), float(run.scale_x[k]), sigma))
    return out
