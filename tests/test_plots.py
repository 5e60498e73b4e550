"""Figures a reader can read: one fixed style per method and scenario, identical results named in the legend,
bar labels that cannot collide."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from graphnav.core.solution import NavSolution
from graphnav.evaluation import plots
from graphnav.evaluation.methods import METHODS


def _solution(method: str, shift: float = 0.0, n: int = 200) -> NavSolution:
    t = np.linspace(0.0, 100.0, n)
    p = np.column_stack([t, np.sin(t / 10), np.zeros(n)]) + shift
    v = np.column_stack([np.ones(n), np.cos(t / 10) / 10, np.zeros(n)]) + shift
    cov = np.tile(np.eye(3) * 1e-4, (n, 1, 1))
    return NavSolution(method=method, t=t, p_n=p, v_n=v, C_b_n=np.tile(np.eye(3), (n, 1, 1)), cov_v_n=cov)


def _figure_texts(monkeypatch) -> list:
    """Replace the file writer: keep each figure's legend texts and value labels instead."""
    seen = []

    def keep(fig, path):
        legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend() is not None)]
        seen.append({"legend": [t.get_text() for lg in legends for t in lg.get_texts()],
                     "texts": [t for ax in fig.axes for t in ax.texts], "fig": fig})
        return path
    monkeypatch.setattr(plots, "_save", keep)
    return seen


def test_every_registry_method_has_its_own_style():
    styles = [plots.method_style(m) for m in METHODS]
    assert len({s["color"] for s in styles}) == len(styles)          # every method its own colour
    assert len({(s["color"], s["marker"], str(s["linestyle"])) for s in styles}) == len(styles)
    assert plots.method_style("Graph-TC") == plots.method_style("Graph-TC")
    scen = [plots.scenario_style(s) for s in ("none", "2-missing", "3-missing", "0-beams", "markov")]
    assert len({c for c, _ in scen}) == 5 and len({h for _, h in scen}) == 5


def test_identical_results_are_named(monkeypatch):
    a, b, c = _solution("TC"), _solution("HNTC"), _solution("Graph-TC", shift=0.01)
    d = dataclasses.replace(_solution("Average-TC"), v_n=_solution("TC").v_n + 5e-10)    # within 1e-9
    assert plots.same_as([a, b, c, d]) == {1: "TC", 3: "TC"}
    assert plots.same_as([a, dataclasses.replace(b, v_n=b.v_n + 1e-6)]) == {}
    seen = _figure_texts(monkeypatch)
    plots.plot_trajectories(None, [a, b, c, d], [], "unused.png")
    plots.plot_velocity_std([a, b, c, d], [], "unused.png")
    for fig in seen:
        assert {"TC", "HNTC (identical to TC)", "Graph-TC", "Average-TC (identical to TC)"} <= set(fig["legend"])


def test_bar_labels_do_not_overlap(monkeypatch):
    rng = np.random.default_rng(3)
    records = [{"trajectory": "T1", "scenario": sc, "imu_grade": "as-recorded", "method": m,
                "vrmse_window": float(v)} for m in METHODS for sc in ("none", "2-missing", "3-missing", "0-beams")
               for v in rng.uniform(0.03, 0.05, 3)]                   # close values: labels would pile up
    seen = _figure_texts(monkeypatch)
    plots.plot_vrmse_bars(records, "unused.png")
    fig = seen[0]["fig"]
    fig.canvas.draw()
    boxes = [t.get_window_extent() for t in seen[0]["texts"]]
    assert len(boxes) == len(METHODS) * 4
    overlapping = [(i, j) for i in range(len(boxes)) for j in range(i) if boxes[i].overlaps(boxes[j])]
    assert not overlapping
    legend = fig.axes[0].get_legend().get_window_extent()
    axes_box = fig.axes[0].get_window_extent()
    assert legend.x0 >= axes_box.x1                                   # the legend covers no bar
    assert {"none (mean)", "2-missing (mean)", "3-missing (mean)", "0-beams (mean)"} <= set(seen[0]["legend"])


@pytest.mark.parametrize("fn", ["plot_trajectories", "plot_velocity_errors", "plot_velocity_std"])
def test_figures_are_written(tmp_path, fn):
    sols = [_solution("TC"), _solution("HNTC"), _solution("Graph-TC", shift=0.01)]
    gt_sol = _solution("gt")
    from graphnav.core.mission import GroundTruth
    gt = GroundTruth(t=gt_sol.t, p_n=gt_sol.p_n, v_n=gt_sol.v_n, C_b_n=gt_sol.C_b_n)
    args = (sols, [(20.0, 50.0)], tmp_path / "f.png") if fn == "plot_velocity_std" else (
        gt, sols, [(20.0, 50.0)], tmp_path / "f.png")
    path = getattr(plots, fn)(*args)
    assert path.stat().st_size > 10_000
