"""How a run of completions errs in time, against what the graph's run model assumes (docs/decisions/completers.md).

``GraphOptions.regressed_error_tau_s`` models a run of regressed beams as Gauss-Markov errors with correlation time
``tau``: after the first, each completion enters as the whitened difference ``d_k = e_k - phi e_k-1`` (``phi =
exp(-dt / tau)``) with variance ``max(s_k^2 - phi^2 s_k-1^2, (1 - phi^2) s_k^2)`` from the completer's sigmas
(``graphnav.factors.beam_difference_factor``). This study reads the completions' errors that
``experiments/oracle_completions.py --record`` wrote (each regressed beam against the truth, with the sigma the
history handed on, ping after ping through each regime window) and prints, per scenario:

- the errors' RMS and the RMS of error / sigma, and their RMS by ping into the window (how they grow from the
  outage's start);
- their autocorrelation at a few lags (about zero, as the graph's model has them), and a fit of ``a exp(-lag / T)``
  on lags 1-20 (``1 - a``: the white share); then the autocorrelation about each window's own mean per beam: what is
  left once a window's offset is taken out (the errors are not stationary, so ``T`` mixes offset, growth and
  wander);
- for each ``tau``, the RMS of the whitened differences and their NEES: mean ``d_k^2`` over the variance the graph
  gives them (1 = the model's size; below 1 the differences weigh less in the graph than their accuracy would
  allow).

Usage::

    .venv/bin/python experiments/run_error_model.py out/gm/gm3s100.json out/gm/gm2s100.json
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

TAUS = (1.0, 3.0, 5.0, 10.0, 20.0, 30.0, 100.0)
LAGS = (1, 2, 3, 5, 10, 20, 30)


def runs_of(path: Path, variant: str) -> tuple[str, list[tuple[np.ndarray, np.ndarray]]]:
    """The scenario of an oracle_completions.py result file and its windows of ``variant``: (errors, sigmas),
    each (pings, regressed beams), m/s. A run whose record is not whole windows of one ping a second is skipped
    with a message."""
    saved = json.loads(path.read_text())
    scenario = saved["settings"]["scenario"]
    n_beams = 4 if scenario == "0-beams" else int(scenario.split("-")[0])
    windows = []
    for key, run in saved["runs"]:
        if key[3] != variant:
            continue
        pings = int(key[2])
        e, s = np.asarray(run["errors"]), np.asarray(run["stated_sigma"])
        if not len(e) or len(e) % (n_beams * pings):
            print(f"{path.name}: {key[:3]} skipped ({len(e)} errors, not whole {pings}-ping windows of "
                  f"{n_beams} beams)", file=sys.stderr)
            continue
        e, s = e.reshape(-1, n_beams), s.reshape(-1, n_beams)
        windows += [(e[j:j + pings], s[j:j + pings]) for j in range(0, len(e), pings)]
    return scenario, windows


def autocorrelation(series: list[np.ndarray], lag: int) -> float:
    """Pooled autocorrelation at ``lag`` of series taken as zero-mean (each (pings, beams), beams apart)."""
    num = sum(float(np.sum(x[lag:] * x[:len(x) - lag])) for x in series)
    cnt = sum(x[lag:].size for x in series)
    var = sum(float(np.sum(x ** 2)) for x in series) / sum(x.size for x in series)
    return num / cnt / var


def rms_by_ping(series: list[np.ndarray], pings) -> dict[int, float]:
    """RMS over windows and beams of the error at each ping index in ``pings`` (windows long enough)."""
    return {k: float(np.sqrt(np.mean(np.concatenate([x[k] ** 2 for x in series if len(x) > k])))) for k in pings
            if any(len(x) > k for x in series)}


def difference_check(windows, tau: float, dt: float = 1.0) -> tuple[float, float]:
    """RMS of the whitened differences (m/s) and their NEES under the variance the graph gives them."""
    phi = np.exp(-dt / tau)
    sq, nees, n = 0.0, 0.0, 0
    for e, s in windows:
        d = e[1:] - phi * e[:-1]
        var = np.maximum(s[1:] ** 2 - phi ** 2 * s[:-1] ** 2, (1.0 - phi ** 2) * s[1:] ** 2)
        sq += float(np.sum(d ** 2))
        nees += float(np.sum(d ** 2 / var))
        n += d.size
    return np.sqrt(sq / n), nees / n


def gauss_markov_fit(acf: dict[int, float]) -> tuple[float, float]:
    """(a, T) of ``a exp(-lag / T)`` fitted to the autocorrelation at lags 1-20 by least squares on a grid."""
    lags = np.arange(1, 21)
    y = np.array([acf[k] for k in lags])
    grid = [(a, t) for a in np.linspace(0.3, 1.0, 71) for t in np.linspace(1.0, 60.0, 119)]
    return min(grid, key=lambda p: float(np.sum((y - p[0] * np.exp(-lags / p[1])) ** 2)))


def report(paths: list[Path], variant: str) -> str:
    lines = []
    for path in paths:
        scenario, windows = runs_of(path, variant)
        if not windows:
            lines.append(f"{path}: no windows of '{variant}'")
            continue
        errors = [e for e, _ in windows]
        acf = {k: autocorrelation(errors, k) for k in range(1, 31)}
        rms = np.sqrt(np.mean(np.concatenate([e.ravel() ** 2 for e, _ in windows])))
        z = np.sqrt(np.mean(np.concatenate([(e / s).ravel() ** 2 for e, s in windows])))
        a, t = gauss_markov_fit(acf)
        about_mean = [e - e.mean(axis=0) for e in errors]
        acf_mean = {k: autocorrelation(about_mean, k) for k in LAGS}
        by_ping = rms_by_ping(errors, (0, 10, 30, 59, 119))
        offset = np.sqrt(np.mean(np.concatenate([e.mean(axis=0) ** 2 for e in errors])))
        lines += [f"{scenario} ({path}, {len(windows)} windows, '{variant}'): error RMS {rms:.3f} m/s, "
                  f"error / sigma RMS {z:.2f}",
                  "  RMS by ping into the window " + ", ".join(f"{k}: {v:.3f}" for k, v in by_ping.items())
                  + f" m/s; RMS of the windows' mean per beam {offset:.3f} m/s",
                  "  autocorrelation at lags " + ", ".join(f"{k}: {acf[k]:.2f}" for k in LAGS),
                  f"  fit a exp(-lag / T) on lags 1-20: a = {a:.2f} (white share {1 - a:.2f}), T = {t:.0f} pings",
                  "  about each window's mean: autocorrelation at lags "
                  + ", ".join(f"{k}: {acf_mean[k]:.2f}" for k in LAGS),
                  "  | tau s | RMS of the whitened differences m/s | their NEES in the graph |",
                  "  | --- | --- | --- |"]
        for tau in TAUS:
            r, nees = difference_check(windows, tau)
            lines.append(f"  | {tau:g} | {r:.3f} | {nees:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("results", nargs="+", type=Path, help="experiments/oracle_completions.py --record results (JSON)")
    p.add_argument("--variant", default="Graph-HNI (fold)", help="the recorded run to read (default: the fold "
                   "completer with the history's sigma growth)")
    a = p.parse_args(argv)
    print(report(a.results, a.variant))
    return 0


if __name__ == "__main__":
    sys.exit(main())
