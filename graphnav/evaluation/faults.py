"""Fault injection: the ways real DVL/IMU logs go wrong, applied to a mission or to its CSV files.

Used by ``tests/test_faults.py`` (which asserts each outcome) and ``graphnav faults --estimators`` (which
prints the outcome table, :func:`estimator_table`). Every injector is deterministic (seeded) and leaves its
input untouched.

Two kinds of injectors:

- on a :class:`~graphnav.core.mission.Mission` (in memory): they return the faulty *stream* (``DvlData`` /
  ``ImuData``) when the fault is one a decoder would hand over as is (NaN beams, RDI flags, duplicated
  stamps), or a new Mission when the fault is valid data the estimators must cope with (spikes, outages, a
  gap, DVL stamps outside the IMU span, an all-zero IMU row). :func:`with_streams` builds the Mission, and
  therefore validates it: that is where undecodable data stops with a :class:`~graphnav.core.errors.DataError`
  naming stream, index and field.
- on files (the A-KIT layout written by :func:`graphnav.io.export.write_akit`): :func:`truncate_csv_line`,
  :func:`drop_csv_column`, :func:`set_csv_field`, :func:`duplicate_csv_line`, :func:`swap_csv_lines`.

:data:`FAULTS` maps each fault name to a function ``(mission, workdir) -> Mission`` (raising
``DataError`` when the data cannot be used); :func:`run_fault` runs each method of :data:`FAULT_METHODS` through
the registry (:func:`graphnav.evaluation.methods.run_method`) on the faulty mission.

The command-line fault table (``graphnav faults``, :data:`CLI_CASES`, :func:`run_table`) damages *inputs*
instead -- files, configs, stream lines, output folders, runs -- and runs graphnav's own commands on them in
subprocesses with a time limit, classifying what a user gets: clear error, warning (result within
:data:`RESULT_FACTOR` x the clean run's), ok, warning with a degraded result, traceback, hang or silent
garbage (:func:`classify`).
"""
from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path
from typing import Callable

import numpy as np

from graphnav.core.errors import ConfigError, GraphnavError
from graphnav.core.mission import RDI_BAD_VELOCITY, DvlData, ImuData, Mission
from graphnav.core.scenarios import Outage
from graphnav.core.solution import NavSolution
from graphnav.evaluation.methods import GRAPH_HN, GRAPH_HN_BATCH, GRAPH_TC, HNTC, TC

#: The methods the fault suite runs (graph online, graph batch, EKF; measured-only and hybrid), by their
#: registry names (:data:`graphnav.evaluation.methods.METHODS`). The hybrids run with the average estimator
#: (:func:`fault_completer`) in place of the network, so that the suite needs no weights and stays fast.
FAULT_METHODS = (GRAPH_TC, GRAPH_HN, GRAPH_HN_BATCH, TC, HNTC)


# --------------------------------------------------------------------------------------------------------
# In-memory injectors
# --------------------------------------------------------------------------------------------------------
def _rows(n: int, fraction: float, rng: np.random.Generator, margin: int = 0) -> np.ndarray:
    count = max(1, int(round(fraction * (n - 2 * margin))))
    return np.sort(rng.choice(np.arange(margin, n - margin), size=count, replace=False))


def nan_beams(dvl: DvlData, fraction: float = 0.1, seed: int = 0) -> DvlData:
    """NaN in one random beam of ``fraction`` of the pings, the valid mask left True (a decoder's NaN)."""
    rng = np.random.default_rng(seed)
    rows = _rows(len(dvl.t), fraction, rng)
    beams = dvl.beams.copy()
    beams[rows, rng.integers(0, 4, rows.size)] = np.nan
    return dataclasses.replace(dvl, beams=beams)


def rdi_invalid_beams(dvl: DvlData, fraction: float = 0.1, seed: int = 0) -> DvlData:
    """RDI bad-velocity flags on one random beam of ``fraction`` of the pings, valid mask left True: half
    as raw counts (-32768) and half scaled to m/s (-32.768); one ping gets a 'bad' bottom-track velocity
    beyond the instrument's range (99 m/s)."""
    rng = np.random.default_rng(seed)
    rows = _rows(len(dvl.t), fraction, rng)
    beams = dvl.beams.copy()
    flags = np.where(np.arange(rows.size) % 2 == 0, RDI_BAD_VELOCITY[0], RDI_BAD_VELOCITY[1])
    flags[-1] = 99.0
    beams[rows, rng.integers(0, 4, rows.size)] = flags
    return dataclasses.replace(dvl, beams=beams)


def beam_spikes(mission: Mission, beam: int = 1, fraction: float = 0.1, size: float = 1.0,
                seed: int = 0) -> Mission:
    """``size`` m/s spikes (random sign) on one beam in ``fraction`` of the pings (after the first 10 s)."""
    rng = np.random.default_rng(seed)
    dvl = mission.dvl
    rows = _rows(len(dvl.t), fraction, rng, margin=10)
    beams = dvl.beams.copy()
    beams[rows, beam] += size * rng.choice([-1.0, 1.0], rows.size)
    return dataclasses.replace(mission, dvl=dataclasses.replace(dvl, beams=beams),
                               meta={**mission.meta, "spike_rows": rows, "spike_beam": beam})


def glitch_velocities(v: np.ndarray, fraction: float = 0.1, seed: int = 0, margin: int = 10
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Implausible DVL velocities as real logs have them, in ``fraction`` of the pings (after ``margin``).

    Two of three glitches are no-bottom-lock samples (``|v_z|`` 1-2 m/s, random sign; horizontal velocity
    scaled by 0.2-1: water-track or noise); every third is a spike no vehicle can make (the horizontal
    velocity jumps by 2.5-3.5 m/s in a random direction for one ping). ``v`` (M,3) m/s, body frame.

    Returns:
        (glitched copy of ``v``, sorted glitched rows).
    """
    rng = np.random.default_rng(seed)
    ok = np.flatnonzero(np.all(np.isfinite(v), axis=1))
    rows = np.sort(rng.choice(ok[(ok >= margin) & (ok < len(v) - margin)],
                              size=max(1, int(round(fraction * len(ok)))), replace=False))
    out = np.array(v, float)
    for k, i in enumerate(rows):
        if k % 3 == 2:
            heading = rng.uniform(0.0, 2 * np.pi)
            out[i, :2] += rng.uniform(2.5, 3.5) * np.array([np.cos(heading), np.sin(heading)])
        else:
            out[i, :2] *= rng.uniform(0.2, 1.0)
            out[i, 2] = rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 2.0)
    return out, rows


def dvl_glitches(mission: Mission, fraction: float = 0.1, seed: int = 0) -> Mission:
    """:func:`glitch_velocities` in the mission's DVL: ``v_b`` and the beams (each beam moves by the
    projection of the velocity change, its noise kept); the glitched rows in ``meta["glitch_rows"]``."""
    from graphnav.core.dvl import DvlGeometry, beam_velocity_b
    dvl = mission.dvl
    geom = DvlGeometry.from_spec(mission.config.dvl)
    v = beam_velocity_b(dvl, mission.config.dvl)
    glitched, rows = glitch_velocities(v, fraction, seed)
    beams = dvl.beams + np.nan_to_num(glitched - v) @ geom.T_b.T
    return dataclasses.replace(mission, dvl=dataclasses.replace(dvl, beams=beams, v_b=glitched),
                               meta={**mission.meta, "glitch_rows": rows})


def glitch_csv(path: str | Path, fraction: float = 0.1, seed: int = 0) -> np.ndarray:
    """:func:`glitch_velocities` in an A-KIT DVL file (columns 2-4), in place; returns the 0-based rows
    (file line = row + 2)."""
    from graphnav.io.loaders import AKIT_COLUMNS, read_csv
    cols = AKIT_COLUMNS["DVL"]
    data = read_csv(path, cols, nan_ok=cols[1:])
    data[:, 1:4], rows = glitch_velocities(data[:, 1:4], fraction, seed)
    np.savetxt(path, data, delimiter=",", fmt="%.17g", comments="", header=",".join(cols))
    return rows


def dvl_outage(mission: Mission, start_s: float, duration_s: float = 120.0) -> Mission:
    """All four beams invalid for ``duration_s`` seconds from ``start_s`` (total bottom-lock loss)."""
    return mission.with_outage(Outage(start_s, duration_s, (0, 1, 2, 3)))


def imu_gap(mission: Mission, start_s: float, duration_s: float = 2.0) -> Mission:
    """No IMU samples in ``start_s < t < start_s + duration_s`` (a logger stall)."""
    imu = mission.imu
    keep = (imu.t <= start_s) | (imu.t >= start_s + duration_s)
    return dataclasses.replace(mission, imu=imu.take(keep))


def zero_imu_row(mission: Mission, index: int) -> Mission:
    """IMU sample ``index`` replaced by zeros (f_b = omega_b = 0, stamp kept)."""
    f, w = mission.imu.f_b.copy(), mission.imu.omega_b.copy()
    f[index] = 0.0
    w[index] = 0.0
    return dataclasses.replace(mission, imu=dataclasses.replace(mission.imu, f_b=f, omega_b=w))


def duplicate_stamp(stream, index: int):
    """The stream (ImuData or DvlData) with row ``index`` repeated (same stamp twice)."""
    idx = np.insert(np.arange(len(stream.t)), index + 1, index)
    return stream.take(idx)


def swap_stamps(stream, index: int):
    """The stream with rows ``index`` and ``index + 1`` swapped (stamps out of order)."""
    idx = np.arange(len(stream.t))
    idx[[index, index + 1]] = idx[[index + 1, index]]
    return stream.take(idx)


def dvl_outside_imu(mission: Mission, n_before: int = 3, n_after: int = 3) -> Mission:
    """Extra DVL pings (copies of the first/last ones) stamped 1, 2, ... s before the IMU starts and after
    it ends."""
    dvl, imu = mission.dvl, mission.imu
    before = dvl.take(np.arange(n_before))
    before.t = imu.t[0] - np.arange(n_before, 0, -1, dtype=float)
    after = dvl.take(np.arange(len(dvl.t) - n_after, len(dvl.t)))
    after.t = imu.t[-1] + np.arange(1, n_after + 1, dtype=float)
    parts = [before, dvl, after]
    joined = DvlData(np.concatenate([p.t for p in parts]), np.concatenate([p.beams for p in parts]),
                     np.concatenate([p.valid for p in parts]),
                     None if dvl.v_b is None else np.concatenate([p.v_b for p in parts]), dvl.source)
    return dataclasses.replace(mission, dvl=joined)


def with_streams(mission: Mission, imu: ImuData | None = None, dvl: DvlData | None = None) -> Mission:
    """``mission`` with the given streams replaced; builds (and so validates) a new Mission."""
    return dataclasses.replace(mission, imu=mission.imu if imu is None else imu,
                               dvl=mission.dvl if dvl is None else dvl)


# --------------------------------------------------------------------------------------------------------
# File injectors (CSV, e.g. the A-KIT layout)
# --------------------------------------------------------------------------------------------------------
def _lines(path: Path) -> list[str]:
    return Path(path).read_text().splitlines()


def _write(path: Path, lines: list[str]) -> None:
    Path(path).write_text("\n".join(lines) + "\n")


def truncate_csv_line(path: str | Path, line: int, keep_fields: int = 2) -> None:
    """Cut 1-based ``line`` after its first ``keep_fields`` fields (a record cut short by a crash)."""
    lines = _lines(path)
    lines[line - 1] = ",".join(lines[line - 1].split(",")[:keep_fields])
    _write(path, lines)


def drop_csv_column(path: str | Path, column: str) -> None:
    """Remove ``column`` from the header only (a writer that forgot one header field)."""
    lines = _lines(path)
    header = lines[0].split(",")
    if column not in header:
        raise ConfigError(f"{path}: no column '{column}' in {header}")
    lines[0] = ",".join(h for h in header if h != column)
    _write(path, lines)


def set_csv_field(path: str | Path, line: int, column: str, value: str) -> None:
    """Overwrite one field (1-based ``line``, by column name) with the text ``value``."""
    lines = _lines(path)
    j = lines[0].split(",").index(column)
    fields = lines[line - 1].split(",")
    fields[j] = value
    lines[line - 1] = ",".join(fields)
    _write(path, lines)


def duplicate_csv_line(path: str | Path, line: int, altered: bool = False) -> None:
    """Repeat 1-based ``line`` right after itself (a duplicated record; ``altered``: its last field 0, two records
    under one stamp, which the reader refuses without ``repair``: an exact copy it drops)."""
    lines = _lines(path)
    copy = lines[line - 1]
    lines.insert(line, copy.rsplit(",", 1)[0] + ",0" if altered else copy)
    _write(path, lines)


def swap_csv_lines(path: str | Path, line: int) -> None:
    """Swap 1-based ``line`` and ``line + 1`` (records out of order)."""
    lines = _lines(path)
    lines[line - 1], lines[line] = lines[line], lines[line - 1]
    _write(path, lines)


def write_and_load(mission: Mission, workdir: str | Path, damage: Callable[[dict], None] | None = None,
                   **load_kwargs) -> Mission:
    """Write ``mission`` in the A-KIT layout under ``workdir``, apply ``damage(paths)`` to the files and
    load them back with :func:`graphnav.missions.load_akit` (no time-offset estimation, FRD axes, GT at the
    IMU point: the simulated mission comes back as it went out)."""
    from graphnav.io.export import write_akit
    from graphnav.missions import load_akit
    paths = write_akit(mission, workdir)
    if damage is not None:
        damage(paths)
    kwargs = dict(imu_axis_signs=(1, 1, 1), dvl_time_offset_s=0.0, gt_time_offset_s=0.0, imu_position_b=(0, 0, 0),
                  config=mission.config, rescale_stamps=False)
    kwargs.update(load_kwargs)
    return load_akit(paths["IMU"].parent, **kwargs)


# --------------------------------------------------------------------------------------------------------
# The fault table
# --------------------------------------------------------------------------------------------------------
def _csv(damage: Callable[[dict], None], **load_kwargs) -> Callable[[Mission, Path], Mission]:
    return lambda m, w: write_and_load(m, w, damage, **load_kwargs)


def _screened_glitches(mission: Mission) -> Mission:
    from graphnav.core.dvl import screen_implausible
    glitched = dvl_glitches(mission)
    return with_streams(glitched, dvl=screen_implausible(glitched.dvl, mission.config.dvl))


#: name -> (mission, workdir) -> Mission (raises DataError when the data cannot be used). ``raw`` variants
#: hand the decoder's output straight to the data model; ``sanitized`` ones pass it through
#: :meth:`DvlData.sanitized` first, as the loaders do.
FAULTS: dict[str, Callable[[Mission, Path], Mission]] = {
    "none": lambda m, w: m,
    "none csv": _csv(None),
    "nan-beams raw": lambda m, w: with_streams(m, dvl=nan_beams(m.dvl)),
    "nan-beams sanitized": lambda m, w: with_streams(m, dvl=nan_beams(m.dvl).sanitized()),
    "rdi-invalid raw": lambda m, w: with_streams(m, dvl=rdi_invalid_beams(m.dvl)),
    "rdi-invalid sanitized": lambda m, w: with_streams(m, dvl=rdi_invalid_beams(m.dvl).sanitized()),
    "rdi-invalid csv": _csv(lambda p: [set_csv_field(p["DVL"], line, "DVL X [m/s]", value)
                                       for line, value in ((20, "-32.768"), (40, "-32768"), (60, "-32.768"))]),
    "beam-spikes 1 m/s": lambda m, w: beam_spikes(m),
    "dvl-glitches screened": lambda m, w: _screened_glitches(m),
    "dvl-glitches csv": _csv(lambda p: glitch_csv(p["DVL"])),
    "dvl-outage 120 s": lambda m, w: dvl_outage(m, 40.0, 120.0),
    "imu-gap 2 s": lambda m, w: imu_gap(m, 80.0, 2.0),
    "imu-zero-row": lambda m, w: zero_imu_row(m, 5000),
    "dvl-outside-imu": lambda m, w: dvl_outside_imu(m),
    "duplicated-stamp imu": lambda m, w: with_streams(m, imu=duplicate_stamp(m.imu, 1000)),
    "out-of-order dvl": lambda m, w: with_streams(m, dvl=swap_stamps(m.dvl, 50)),
    "duplicated-stamp csv": _csv(lambda p: duplicate_csv_line(p["IMU"], 1001, altered=True)),
    "out-of-order csv": _csv(lambda p: swap_csv_lines(p["DVL"], 51)),
    "duplicated-stamp csv repair": _csv(lambda p: (duplicate_csv_line(p["IMU"], 1001, altered=True),
                                                   swap_csv_lines(p["DVL"], 51)), repair=True),
    "truncated-line csv": _csv(lambda p: truncate_csv_line(p["IMU"], 1234)),
    "missing-column csv": _csv(lambda p: drop_csv_column(p["DVL"], "DVL Y [m/s]")),
}


@dataclasses.dataclass(frozen=True)
class Expected:
    """The required outcome of a fault.

    ``stop``: the input is refused with a DataError whose ``source`` ends with ``source``, whose ``line``
    equals ``line`` (None: the test computes it from the injected data) and whose ``field`` is ``field``.
    Otherwise the run completes and every estimator's VRMSE is at most ``factor`` times its VRMSE on the
    ``baseline`` fault (``"none"``, or ``"none csv"`` for missions that went through the files), and a
    warning containing ``warning`` was raised (None: no warning required).
    """

    stop: bool = False
    source: str | None = None
    line: int | None = None
    field: str | None = None
    factor: float = 1.0
    baseline: str = "none"
    warning: str | None = None


#: The outcome each fault of :data:`FAULTS` must have on :func:`fault_mission`; the bounds
#: are about 1.2-1.3x what was measured (``graphnav faults --estimators`` prints both).
EXPECTED: dict[str, Expected] = {
    "none": Expected(),
    "none csv": Expected(baseline="none csv"),
    "nan-beams raw": Expected(stop=True, source="dvl", field="beams"),
    "nan-beams sanitized": Expected(factor=1.2, warning="are not measurements"),
    "rdi-invalid raw": Expected(stop=True, source="dvl", field="beams"),
    "rdi-invalid sanitized": Expected(factor=1.2, warning="RDI bad-velocity flag"),
    "rdi-invalid csv": Expected(factor=1.2, baseline="none csv", warning="RDI bad-velocity flag"),
    "beam-spikes 1 m/s": Expected(factor=1.3),
    "dvl-glitches screened": Expected(factor=1.2, warning="outside the vehicle's envelope"),
    # 1.22x with the graph's DVL error states (on by default, docs/decisions/consistency.md): the batch smoother's screened pings
    "dvl-glitches csv": Expected(factor=1.3, baseline="none csv", warning="outside the vehicle's envelope"),
    "dvl-outage 120 s": Expected(factor=6.0),
    "imu-gap 2 s": Expected(factor=1.5, warning="bridged by linear interpolation"),
    "imu-zero-row": Expected(factor=1.05, warning="all-zero IMU row"),
    "dvl-outside-imu": Expected(factor=1.001, warning="outside the IMU span"),
    "duplicated-stamp imu": Expected(stop=True, source="imu", line=1001, field="t"),
    "out-of-order dvl": Expected(stop=True, source="dvl", line=51, field="t"),
    "duplicated-stamp csv": Expected(stop=True, source="IMU_trajectory1.csv", line=1002, field="Time [s]"),
    "out-of-order csv": Expected(stop=True, source="DVL_trajectory1.csv", line=52, field="Time [s]"),
    "duplicated-stamp csv repair": Expected(factor=1.2, baseline="none csv", warning="repaired"),
    "truncated-line csv": Expected(stop=True, source="IMU_trajectory1.csv", line=1234, field="ACC X [m/s^2]"),
    "missing-column csv": Expected(stop=True, source="DVL_trajectory1.csv", line=1, field="DVL Y [m/s]"),
}


#: The IMU grades the fault table runs on (:data:`graphnav.core.config.IMU_GRADES`).
FAULT_GRADES = ("navigation", "tactical", "mems")


def fault_mission(grade: str = "navigation", seed: int = 1, duration_s: float = 200.0) -> Mission:
    """The mission the fault table is stated for: simulated 200 s, seed 1, DVL pings 0.37 s after the IMU
    stamps (between two IMU samples, as on real data); the bounds of :data:`EXPECTED` were set on the
    navigation-grade IMU and are checked on every grade of :data:`FAULT_GRADES` (:func:`judge`)."""
    from graphnav.sim.simulate import simulate_mission
    return simulate_mission(duration_s, grade, seed=seed, dvl_stamp_offset_s=0.37)



def fault_completer():
    """The completer of the hybrids in the fault suite: the average estimator over the past 5 pings."""
    from graphnav.nets.average import AverageCompleter
    return AverageCompleter(5)


@dataclasses.dataclass
class Outcome:
    """What happened to one estimator on one fault.

    Attributes:
        fault, estimator: names.
        stopped: the data was refused (``error`` holds the DataError) before any estimator ran.
        vrmse: 3-D velocity RMSE over the solution, m/s (NaN when stopped).
        max_vel_err: largest 3-D velocity error, m/s.
        warnings: distinct warning messages raised while loading and running.
        nees: mean velocity NEES over the estimator's pure-inertial spans (``info["pure_inertial_spans"]``)
            when it reported any, else over the whole solution (NaN without covariance).
        pure_inertial_s: the longest stretch without a DVL update, s.
    """

    fault: str
    estimator: str
    stopped: bool
    error: GraphnavError | None = None
    vrmse: float = float("nan")
    max_vel_err: float = float("nan")
    warnings: list[str] = dataclasses.field(default_factory=list)
    solution: NavSolution | None = None
    nees: float = float("nan")
    pure_inertial_s: float = 0.0

    @property
    def warned_pure_inertial(self) -> bool:
        return any("pure inertial for" in w for w in self.warnings)


def make_faulty(fault: str, mission: Mission, workdir: str | Path) -> Mission:
    """Apply :data:`FAULTS` ``[fault]`` to ``mission`` (files under ``workdir/<fault>``)."""
    if fault not in FAULTS:
        raise ConfigError(f"unknown fault '{fault}'; choose one of {list(FAULTS)}")
    folder = Path(workdir) / fault.replace(" ", "_").replace("/", "_")
    return FAULTS[fault](mission, folder)


def run_fault(fault: str, estimators, mission: Mission, workdir: str | Path, completer=None) -> list[Outcome]:
    """Inject ``fault`` and run each method of ``estimators`` (registry names, e.g. :data:`FAULT_METHODS`); a
    refused input gives one ``stopped`` outcome per method. The hybrids use ``completer`` (default
    :func:`fault_completer`, a new one per run)."""
    from graphnav.evaluation.methods import run_method
    from graphnav.evaluation.metrics import velocity_errors
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            faulty = make_faulty(fault, mission, workdir)
        except GraphnavError as exc:
            return [Outcome(fault, e, True, exc, warnings=sorted({str(w.message) for w in caught}))
                    for e in estimators]
    load_warnings = [str(w.message) for w in caught]
    out = []
    for name in estimators:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = run_method(faulty, name, completer=fault_completer() if completer is None else completer)
        norm = np.linalg.norm(velocity_errors(sol, mission.gt)[1], axis=1) if sol.t.size else np.array([np.nan])
        out.append(Outcome(fault, name, False, None, float(np.sqrt(np.mean(norm ** 2))), float(np.max(norm)),
                           sorted(set(load_warnings) | {str(w.message) for w in caught}), sol,
                           coverage_nees(sol, mission.gt), float(sol.info.get("pure_inertial_max_s", 0.0))))
    return out


#: Largest mean velocity NEES over a pure-inertial span that still counts as a covariance covering the
#: error: the errors of one span are one random walk, so their mean NEES is about one chi-square(3) draw,
#: and it must lie inside that distribution's 99 % quantile.
NEES_COVER_MAX = 11.34


def coverage_nees(sol: NavSolution, gt) -> float:
    """Mean velocity NEES over ``sol``'s pure-inertial spans (all epochs when it reported none); NaN
    without a covariance."""
    from graphnav.evaluation.metrics import nees_velocity
    if sol.cov_v_n is None or not sol.t.size:
        return float("nan")
    spans = sol.info.get("pure_inertial_spans") or [[None, None, None]]
    return float(np.mean(np.concatenate([nees_velocity(sol, gt, a, b) for a, b, _ in spans])))


def judge(expected: "Expected", outcome: Outcome, baseline_vrmse: float) -> str:
    """``"PASS"`` when the VRMSE is within the bound; ``"PASS-PI"`` when it is not but the estimator warned
    that it ran pure inertial longer than it should and its covariance covers the error (NEES at most
    :data:`NEES_COVER_MAX`); else ``"FAIL"`` (a missing expected warning fails too)."""
    warned = expected.warning is None or any(expected.warning in w for w in outcome.warnings)
    if not warned:
        return "FAIL"
    if outcome.vrmse <= expected.factor * baseline_vrmse:
        return "PASS"
    if outcome.warned_pure_inertial and outcome.nees <= NEES_COVER_MAX:
        return "PASS-PI"
    return "FAIL"


# --------------------------------------------------------------------------------------------------------
# The estimator table (graphnav faults --estimators): every fault of FAULTS through every method
# --------------------------------------------------------------------------------------------------------
def estimator_table(grade: str, seed: int = 1, duration_s: float = 200.0, workdir: str | Path = ".",
                    out=print) -> int:
    """Print (through ``out``) the outcome of every fault of :data:`EXPECTED` on the simulated mission of one
    IMU grade, per estimator of :data:`FAULT_METHODS`: ``VRMSE<=bound NEES`` and the verdict of :func:`judge`
    (PI: bound exceeded, but the estimator warned 'pure inertial' and its NEES <= :data:`NEES_COVER_MAX`;
    ``!!``: outside the stated outcome; ``*``: NEES over the pure-inertial span). Returns the number of faults
    outside their stated outcome."""
    import time
    mission = fault_mission(grade, seed, duration_s)
    out(f"\n## {grade}: mission {mission.name} ({duration_s:g} s, seed {seed}); VRMSE m/s <= bound, mean NEES")
    width = max(len(f) for f in FAULTS)
    out(f"{'fault':{width}}  {'outcome':9} " + " ".join(f"{e:>22}" for e in FAULT_METHODS) + "  factor  check")
    base: dict[str, dict[str, float]] = {}
    n_fail = 0
    for fault, expected in EXPECTED.items():
        start = time.perf_counter()
        outcomes = run_fault(fault, FAULT_METHODS, mission, Path(workdir) / grade)
        wall = time.perf_counter() - start
        if fault.startswith("none"):
            base[fault] = {o.estimator: o.vrmse for o in outcomes}
        if outcomes[0].stopped:
            err = outcomes[0].error
            ok = expected.stop and str(err.source).endswith(expected.source) and err.field == expected.field \
                and (expected.line is None or err.line == expected.line)
            n_fail += not ok
            out(f"{fault:{width}}  {'stopped':9} {type(err).__name__}: {err}"[:width + 160]
                + f"  {'PASS' if ok else 'FAIL'}")
            continue
        ref = base[expected.baseline]
        verdicts = [judge(expected, o, ref[o.estimator]) for o in outcomes]
        ok = not expected.stop and "FAIL" not in verdicts
        n_fail += not ok
        cells = [f"{o.vrmse:.3f}<={expected.factor * ref[o.estimator]:.3f} {o.nees:4.1f}"
                 + ("*" if o.solution.info.get("pure_inertial_spans") else " ")
                 + {"PASS": " ", "PASS-PI": "PI", "FAIL": "!!"}[v][:2] for o, v in zip(outcomes, verdicts)]
        out(f"{fault:{width}}  {'completed':9} " + " ".join(f"{c:>22}" for c in cells)
            + f"  {expected.factor:6g}  {'PASS' if ok else 'FAIL'}  ({wall:.1f} s)")
    out(f"{len(EXPECTED) - n_fail}/{len(EXPECTED)} faults within their stated outcome ({grade})")
    return n_fail


# --------------------------------------------------------------------------------------------------------
# The command-line fault table (`graphnav faults`): damaged inputs through the real commands
# --------------------------------------------------------------------------------------------------------
#: What a run of a damaged input came to, as a user sees it.
CLEAR_ERROR = "clear error"            # non-zero exit, a message on stderr, no traceback
WARNING = "warning"                    # exit 0, a new warning, result within RESULT_FACTOR x clean
OK = "ok"                              # exit 0, no new warning, result within RESULT_FACTOR x clean
DEGRADED = "warning, degraded"         # exit 0, a new warning, result beyond the bound (the user was told)
TRACEBACK = "traceback"                # a Python traceback on stderr
HANG = "hang"                          # did not finish within the case's time limit
GARBAGE = "silent garbage"             # exit 0, no new warning, result beyond the bound, non-finite or missing
UNEXPLAINED = "unexplained exit"       # non-zero exit with nothing on stderr that says why
#: The verdicts that make ``graphnav faults`` exit non-zero.
BAD_VERDICTS = (TRACEBACK, HANG, GARBAGE, UNEXPLAINED)
#: A damaged input's result (velocity RMSE, or the case's own number) may be this many times the clean one.
RESULT_FACTOR = 1.5


@dataclasses.dataclass
class Step:
    """One command of a case: ``graphnav ARGV`` with standard input from ``stdin`` (a file) or none, killed
    after ``timeout_s`` (None: :func:`time_limit` of the case)."""

    argv: list[str]
    stdin: Path | None = None
    timeout_s: float | None = None


@dataclasses.dataclass
class Run:
    """What a step did: exit code (None: killed at its time limit), its outputs, wall time (s)."""

    returncode: int | None
    stdout: str
    stderr: str
    wall_s: float


@dataclasses.dataclass
class Plan:
    """The commands of one case and how its result is scored.

    Attributes:
        steps: run in order; a step that fails ends the case with that step's verdict.
        result: the trajectory CSV (``trajectory.csv`` / ``online.csv``) to score against the reference, or None.
        check: ``check(last_run) -> (value, bound, note)`` instead of the VRMSE of ``result`` (the value
            must be <= bound; NaN = no result).
        runner: ``runner(workspace, time_limit_s) -> Run`` in place of running ``steps`` (interrupts, pipes).
        cleanup: called after the case whatever happened (restores what the case had to touch).
        reference: the ground truth ``result`` is scored against (the clean input's, as its reader loads it).
    """

    steps: list[Step] = dataclasses.field(default_factory=list)
    result: Path | None = None
    check: Callable | None = None
    runner: Callable | None = None
    cleanup: Callable | None = None
    reference: object = None


@dataclasses.dataclass(frozen=True)
class CliCase:
    """A damaged input and the verdicts it may have (``expected``: one or more of the verdicts above).

    ``plan(ws, folder) -> Plan`` writes the damaged input under ``folder`` and says what to run;
    ``baseline`` names the clean case whose result scales the bound; ``real``: runs on the shared A-KIT
    trajectory (``--data``) instead of the simulated mission."""

    name: str
    command: str
    expected: tuple[str, ...]
    plan: Callable
    baseline: str | None = None
    real: bool = False


@dataclasses.dataclass
class CaseResult:
    """A case's verdict with its evidence."""

    case: CliCase
    verdict: str
    value: float = float("nan")
    bound: float = float("nan")
    note: str = ""
    wall_s: float = 0.0
    warnings: list[str] = dataclasses.field(default_factory=list)

    @property
    def as_expected(self) -> bool:
        return self.verdict in self.case.expected


#: A step is a hang when it runs longer than this many times its clean run (at least MIN_TIME_LIMIT_S): the
#: limit follows the machine's load, so a busy machine does not turn slow runs into hangs.
HANG_FACTOR = 6.0
MIN_TIME_LIMIT_S = 30.0
#: The time limit of a clean run (it sets the others').
CLEAN_TIME_LIMIT_S = 180.0


def time_limit(ws: "Workspace", case: "CliCase") -> float:
    """Seconds a step of ``case`` may run: :data:`HANG_FACTOR` x its clean run's wall time, at least
    :data:`MIN_TIME_LIMIT_S`."""
    if case.baseline is None or case.baseline == case.name or case.baseline not in ws.clean_wall:
        return CLEAN_TIME_LIMIT_S
    return max(MIN_TIME_LIMIT_S, HANG_FACTOR * ws.clean_wall[case.baseline])


def run_step(step: Step, cwd: Path, env: dict | None = None, timeout_s: float = CLEAN_TIME_LIMIT_S) -> Run:
    """Run ``python -m graphnav ARGV`` in a subprocess, killed after ``step.timeout_s`` (or ``timeout_s``); a
    killed step has returncode None."""
    import subprocess
    import sys
    import time
    start = time.perf_counter()
    stdin = step.stdin.open("rb") if step.stdin is not None else subprocess.DEVNULL
    try:
        proc = subprocess.Popen([sys.executable, "-m", "graphnav", *step.argv], cwd=cwd, stdin=stdin,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, start_new_session=True)
        try:
            out, err = proc.communicate(timeout=step.timeout_s or timeout_s)
            code = proc.returncode
        except subprocess.TimeoutExpired:
            _kill(proc)
            out, err = proc.communicate()
            code = None
        except BaseException:
            _kill(proc)              # Ctrl-C of the table: its own session would outlive it
            raise
    finally:
        if step.stdin is not None:
            stdin.close()
    return Run(code, out.decode(errors="replace"), err.decode(errors="replace"), time.perf_counter() - start)


def _kill(proc) -> None:
    """End ``proc`` and the processes it started (its own session), by its id."""
    import os
    import signal
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        proc.kill()


def _warning_lines(stderr: str) -> list[str]:
    """The warnings a run printed (Python's ``...Warning: message`` lines and ``warning:`` lines)."""
    import re
    lines = []
    for line in stderr.splitlines():
        m = re.search(r"(\w*Warning|warning): (.*)", line)
        if m:
            lines.append(m.group(2).strip())
    return lines


def _shape(message: str) -> str:
    """A warning with its numbers and paths blanked, to tell a new warning from one the clean run gives too."""
    import re
    message = re.sub(r"\S*/\S*", "<path>", message)
    return re.sub(r"[-+]?\d[\d.eE+-]*", "#", message)


def classify(run: Run, value: float, bound: float, warned: bool) -> str:
    """The verdict of one finished step (see :data:`BAD_VERDICTS`): time limit, traceback, exit code, then
    the result against its bound and whether a new warning was printed."""
    if run.returncode is None:
        return HANG
    if "Traceback (most recent call last)" in run.stderr:
        return TRACEBACK
    if run.returncode != 0:
        return CLEAR_ERROR if "error" in run.stderr.lower() else UNEXPLAINED
    good = np.isfinite(value) and value <= bound
    if good:
        return WARNING if warned else OK
    return DEGRADED if warned else GARBAGE


# --- the workspace: the clean inputs every case starts from ----------------------------------------------
@dataclasses.dataclass
class Workspace:
    """The clean inputs of the table and their references.

    Attributes:
        root: working folder.
        sim: the simulated mission; sim_folder: it in the A-KIT layout (``Trajectory1``), sim_config: its config
            JSON, sim_stream: it as a JSON-lines stream (config line first); sim_folder_gt: the ground truth of
            ``sim_folder`` as the A-KIT loader reads it (moved to the A-KIT IMU point), what the commands and
            ``evaluate`` see.
        real_folder: the first ``real_duration_s`` of a shared A-KIT trajectory (copied under ``root``), or None;
            real_gt: its ground truth as the A-KIT loader reads it.
        beamsnet: the BeamsNet data folder (train-beams), or None.
        clean: the result (VRMSE, m/s) of each clean case, filled in as they run.
        clean_warnings: the warning shapes of each clean case (what is not new in a damaged run).
        sim_bag_gt: the ground truth of the simulated mission recorded as a bag, as the bag reader loads it (set by
            the clean bag case, which runs first).
    """

    root: Path
    sim: Mission
    sim_folder: Path
    sim_config: Path
    sim_stream: Path
    sim_folder_gt: object = None
    real_folder: Path | None = None
    real_gt: object = None
    beamsnet: Path | None = None
    clean: dict = dataclasses.field(default_factory=dict)
    clean_epochs: dict = dataclasses.field(default_factory=dict)
    clean_warnings: dict = dataclasses.field(default_factory=dict)
    clean_wall: dict = dataclasses.field(default_factory=dict)
    skipped: list = dataclasses.field(default_factory=list)
    sim_bag_gt: object = None


#: Length of the simulated mission of the table, s (short: the whole table runs in about 3 minutes).
SIM_DURATION_S = 150.0
#: Seconds of the shared trajectory the real-data cases use.
REAL_DURATION_S = 150.0


def make_workspace(root: str | Path, data: str | Path | None = None, trajectory: int = 1,
                   seed: int = 1) -> Workspace:
    """Write the clean inputs under ``root``: the simulated mission (A-KIT layout, config, stream), and with
    ``data`` (the shared data folder or its ``snapir-2022-akit``) the first :data:`REAL_DURATION_S` s of
    ``TrajectoryN``."""
    from graphnav.estimators.replay import mission_records
    from graphnav.io.export import write_akit
    from graphnav.io.streamio import write_records
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    sim = simulate_mission_for_table(seed)
    paths = write_akit(sim, root / "sim")
    stream = root / "sim" / "stream.jsonl"
    with stream.open("w") as fh:
        write_records(mission_records(sim), fh)
    ws = Workspace(root, sim, paths["IMU"].parent, paths["config"], stream)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from graphnav.missions import load_mission
        ws.sim_folder_gt = load_mission(ws.sim_folder, ws.sim_config).gt
    if data is not None:
        ws.real_folder, ws.real_gt = _real_trajectory(Path(data), trajectory, root / "real")
        beamsnet = _data_child(Path(data), "snapir-2021-beamsnet")
        ws.beamsnet = beamsnet if beamsnet is not None and (beamsnet / "V.npy").is_file() else None
    return ws


def simulate_mission_for_table(seed: int = 1) -> Mission:
    """The table's simulated mission: :data:`SIM_DURATION_S` s, navigation grade, DVL pings 0.37 s off the
    IMU stamps (as on real data)."""
    from graphnav.sim.simulate import simulate_mission
    return simulate_mission(SIM_DURATION_S, "navigation", seed=seed, dvl_stamp_offset_s=0.37)


def _data_child(data: Path, name: str) -> Path | None:
    for cand in (data / name, data.parent / name, data):
        if cand.is_dir() and cand.name == name:
            return cand
    return None


def _real_trajectory(data: Path, number: int, out: Path):
    """Copy the first :data:`REAL_DURATION_S` s of A-KIT ``TrajectoryN`` under ``out``; (folder, its GT)."""
    from graphnav.missions import load_akit
    akit = _data_child(data, "snapir-2022-akit") or data
    src = akit / f"Trajectory{number}"
    if not src.is_dir():
        raise ConfigError(f"--data {data}: no A-KIT folder Trajectory{number} (expected {src})")
    dst = out / src.name
    dst.mkdir(parents=True, exist_ok=True)
    for kind in ("IMU", "DVL", "GT"):
        name = f"{kind}_trajectory{number}.csv"
        lines = (src / name).read_text().splitlines()
        keep = [lines[0]] + [ln for ln in lines[1:] if ln and float(ln.split(",", 1)[0]) <= REAL_DURATION_S]
        (dst / name).write_text("\n".join(keep) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return dst, load_akit(dst).gt


# --- damaging files ---------------------------------------------------------------------------------------
def _copy_folder(src: Path, dst: Path) -> Path:
    import shutil
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    return dst


def _csv_file(folder: Path, kind: str) -> Path:
    return next(folder.glob(f"{kind}_trajectory*.csv"))


def edit_csv(path: Path, edit: Callable[[np.ndarray], np.ndarray]) -> None:
    """Apply ``edit`` to the numbers of an A-KIT CSV (header kept; NaN written as ``nan``)."""
    lines = path.read_text().splitlines()
    data = np.genfromtxt(lines[1:], delimiter=",", dtype=float).reshape(len(lines) - 1, -1)
    data = edit(data.copy())
    np.savetxt(path, data, delimiter=",", header=lines[0], comments="", fmt="%.15g")


def _rows_at(data: np.ndarray, t0: float, t1: float) -> np.ndarray:
    return (data[:, 0] >= t0) & (data[:, 0] < t1)


def _set(rows, cols, value):
    def edit(d):
        d[rows if not callable(rows) else rows(d), cols] = value
        return d
    return edit


def _akit_case(ws: Workspace, folder: Path, real: bool, damage: Callable[[Path], None] | None,
               command: str = "smooth", config: Path | None | bool = True, extra=()) -> Plan:
    """A copy of the clean A-KIT folder (simulated or real) damaged by ``damage(folder)``, through
    ``graphnav smooth`` / ``online`` (``config``: True = the simulated mission's own config)."""
    src = ws.real_folder if real else ws.sim_folder
    data = _copy_folder(src, folder / src.name)
    if damage is not None:
        damage(data)
    out = folder / "out"
    argv = [command, "--data", str(data), "--out", str(out), "--no-plots", *extra]
    if command == "online":
        argv.append("--no-progress")
    if config is True and not real:
        argv += ["--config", str(ws.sim_config)]
    elif isinstance(config, Path):
        argv += ["--config", str(config)]
    result = out / ("online.csv" if command == "online" else "trajectory.csv")
    return Plan([Step(argv)], result, reference=ws.real_gt if real else ws.sim_folder_gt)


#: The Unix time the table's bags start at, ns.
BAG_T0_NS = 1_700_000_000_000_000_000


def _bag_case(ws: Workspace, folder: Path, change: Callable | None) -> Plan:
    """The simulated mission recorded as a ROS 2 bag (MCAP, received at its stamps from :data:`BAG_T0_NS`), each
    message through ``change(topic, k, msg, receive_ns)`` (:func:`graphnav.io.bags.write_mission_bag`), through
    ``graphnav smooth``; scored against the clean bag's reference as the bag reader loads it."""
    from graphnav.io.bags import load_bag, write_mission_bag
    folder.mkdir(parents=True, exist_ok=True)
    bag = write_mission_bag(ws.sim, folder / "bag", t0_unix_ns=BAG_T0_NS, change=change)
    if ws.sim_bag_gt is None:
        clean = bag if change is None else write_mission_bag(ws.sim, folder / "clean", t0_unix_ns=BAG_T0_NS)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ws.sim_bag_gt = load_bag(clean).gt
    out = folder / "out"
    argv = ["smooth", "--data", str(bag), "--out", str(out), "--no-plots", "--config", str(ws.sim_config)]
    return Plan([Step(argv)], out / "trajectory.csv", reference=ws.sim_bag_gt)


def _bag_stamp_ns(msg) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def _set_bag_stamp(msg, ns: int) -> None:
    msg.header.stamp.sec, msg.header.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000


def _bag_ns(t_s: float) -> int:
    """The receive time of a message of the table's bag at mission time ``t_s``, ns."""
    return BAG_T0_NS + round(t_s * 1e9)


def _zero_stamps(topic, k, msg, rx):
    """A driver that never fills ``header.stamp``: every message stamped 0."""
    _set_bag_stamp(msg, 0)
    return rx


def _dvl_clock_off(step_s: float, at_s: float, before: bool = False):
    """The DVL's header clock ``step_s`` off from ``at_s`` on (``before``: until ``at_s``, then set right), its pings
    arriving as before."""
    def change(topic, k, msg, rx):
        if topic == "/dvl/data" and (rx < _bag_ns(at_s)) == before:
            _set_bag_stamp(msg, _bag_stamp_ns(msg) + round(step_s * 1e9))
        return rx
    return change


def _imu_lost(t0_s: float, t1_s: float, latency_s: tuple[float, float] = (0.0, 0.0)):
    """The IMU messages received in [t0_s, t1_s) lost; the others received ``latency_s`` after their stamp (before,
    after the loss)."""
    def change(topic, k, msg, rx):
        if topic != "/imu/data":
            return rx
        if _bag_ns(t0_s) <= rx < _bag_ns(t1_s):
            return None
        return rx + round(latency_s[rx >= _bag_ns(t1_s)] * 1e9)
    return change


def _with_config(ws: Workspace, folder: Path, change: Callable[[dict], object] | str) -> Plan:
    """The simulated mission through ``graphnav smooth`` with its config changed by ``change(dict)`` (which may
    return a whole new JSON value), or replaced by the text ``change``."""
    import json
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "config.json"
    if isinstance(change, str):
        path.write_text(change)
    else:
        cfg = json.loads(ws.sim_config.read_text())
        new = change(cfg)
        path.write_text(json.dumps(cfg if new is None else new))
    return _akit_case(ws, folder, False, None, config=path)


def _stream_case(ws: Workspace, folder: Path, edit: Callable[[list[str]], list[str]] | None) -> Plan:
    """The simulated mission's JSON-lines stream, edited line-wise, into ``graphnav online --stream -``."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = ws.sim_stream.read_text().splitlines()
    if edit is not None:
        lines = edit(lines)
    stream = folder / "stream.jsonl"
    stream.write_text("\n".join(lines) + "\n")
    out = folder / "out"
    return Plan([Step(["online", "--stream", "-", "--out", str(out), "--no-plots", "--no-progress"], stream)],
                out / "online.csv", reference=ws.sim.gt)


def _edit_record(kind: str, index: int, change: Callable[[dict], None]):
    """A stream edit: ``change`` the ``index``-th record of type ``kind``."""
    import json

    def edit(lines):
        seen = -1
        for i, line in enumerate(lines):
            if f'"type":"{kind}"' in line:
                seen += 1
                if seen == index:
                    rec = json.loads(line)
                    change(rec)
                    lines[i] = json.dumps(rec)
                    break
        return lines
    return edit


def _config_not_first(lines):
    return lines[1:200] + [lines[0]] + lines[200:]


# --- cases with their own runner or check -----------------------------------------------------------------
#: Largest median difference (m) between a written position's down axis and the absolute depth.
DEPTH_CONVENTION_TOL_M = 1.0


def _evaluate_case(ws: Workspace, folder: Path, real: bool) -> Plan:
    """``graphnav smooth`` then ``graphnav evaluate trajectory.csv --ref <A-KIT folder>``. Evaluate's APE must
    match the position RMSE the harness computes against the same reference (within RESULT_FACTOR either
    way), and the down axis of ``trajectory.csv`` and ``groundtruth.tum`` must be the absolute depth, checked
    against a depth the loaders do not touch: the simulated truth, or ``-Altitude`` of the raw GT file."""
    import json

    from graphnav.io.outputs import read_trajectory_csv, read_tum
    plan = _akit_case(ws, folder, real, None)
    data, trajectory = Path(plan.steps[0].argv[2]), plan.result
    argv = ["evaluate", str(trajectory), "--ref", str(data), "--json", str(folder / "eval.json")]
    if not real:
        argv += ["--config", str(ws.sim_config)]
    plan.steps.append(Step(argv))
    gt = plan.reference
    depth = _independent_depth(ws, real)

    def check(run):
        sol = read_trajectory_csv(trajectory)
        inside = (sol.t >= gt.t[0]) & (sol.t <= gt.t[-1])
        own = float(np.sqrt(np.mean(np.sum((sol.p_n[inside] - gt.at(sol.t[inside])[0]) ** 2, axis=1))))
        ape = json.loads((folder / "eval.json").read_text())["ape_translation_m"]["rmse"]
        t_ref, p_ref, _ = read_tum(trajectory.parent / "groundtruth.tum")
        for name, t, down in (("trajectory.csv", sol.t, sol.p_n[:, 2]), ("groundtruth.tum", t_ref, p_ref[:, 2])):
            off = float(np.median(down - depth(t)))
            if abs(off) > DEPTH_CONVENTION_TOL_M:
                return float("nan"), 0.0, f"{name}: down is {off:+.1f} m from the absolute depth"
        note = f"APE {ape:.2f} m vs {own:.2f} m position RMSE against the reference; down = absolute depth"
        return max(ape, own ** 2 / ape if ape > 0 else np.inf), RESULT_FACTOR * own, note
    plan.check = check
    plan.result = None
    return plan


def _independent_depth(ws: Workspace, real: bool) -> Callable[[np.ndarray], np.ndarray]:
    """Depth (m) at stamps, from a source the loaders do not touch: the simulated truth, or the raw A-KIT GT
    file's ``-Altitude`` (its stamps rescaled as the loader does; a GT time offset of tenths of a second moves
    a depth by centimetres)."""
    if not real:
        return lambda t: np.interp(t, ws.sim.gt.t, ws.sim.gt.p_n[:, 2])
    from graphnav.io.loaders import AKIT_NOMINAL_RATE_HZ, rescale_published_stamps
    raw = np.genfromtxt(_csv_file(ws.real_folder, "GT"), delimiter=",", skip_header=1)
    # about the file's first stamp, the folder's origin in the published files (all start at 0)
    t, _ = rescale_published_stamps(raw[:, 0], AKIT_NOMINAL_RATE_HZ["gt"])
    return lambda s: np.interp(s, t, -raw[:, 3])


def _resume_case(ws: Workspace, folder: Path) -> Plan:
    """``graphnav online`` interrupted (SIGINT once 20 epochs are written), then ``--resume``: the file must
    hold every epoch of a clean run once, in order."""
    import signal
    import subprocess
    import sys
    import time
    plan = _akit_case(ws, folder, False, None, command="online")
    argv = plan.steps[0].argv
    csv = plan.result

    def runner(_ws, limit):
        start = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "graphnav", *argv], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, start_new_session=True)
        while proc.poll() is None and time.perf_counter() - start < limit:
            if csv.exists() and len(csv.read_text().splitlines()) > 20:
                proc.send_signal(signal.SIGINT)
                break
            time.sleep(0.05)
        try:
            out1, err1 = proc.communicate(timeout=limit)
        except subprocess.TimeoutExpired:
            _kill(proc)
            out1, err1 = proc.communicate()
            return Run(None, out1.decode(), err1.decode(), time.perf_counter() - start)
        if proc.returncode not in (0, 130):          # 130: interrupted, as asked
            return Run(proc.returncode, out1.decode(), err1.decode(), time.perf_counter() - start)
        second = run_step(Step([*argv, "--resume"]), folder, timeout_s=limit)
        second.stderr = err1.decode(errors="replace") + second.stderr
        second.wall_s = time.perf_counter() - start
        return second

    def check(run):
        from graphnav.evaluation.metrics import vrmse
        from graphnav.io.outputs import read_trajectory_csv
        sol = read_trajectory_csv(csv)
        clean_n = ws.clean_epochs.get("online replay: clean")
        if np.any(np.diff(sol.t) <= 0):
            return float("nan"), 0.0, "stamps repeated or out of order after the resume"
        if clean_n is not None and len(sol.t) != clean_n:
            return float("nan"), 0.0, f"{len(sol.t)} epochs after the resume, {clean_n} in a clean run"
        value = vrmse(sol, ws.sim_folder_gt)
        return value, RESULT_FACTOR * ws.clean["online replay: clean"], f"{len(sol.t)} epochs, VRMSE {value:.3f} m/s"
    plan.runner, plan.check = runner, check
    return plan


def _diverged_into_existing_out(ws: Workspace, folder: Path) -> Plan:
    """A clean ``graphnav online`` into OUT, then a run whose DVL says the opposite of the IMU (every DVL
    velocity negated) into the same OUT: the second run's files must replace the first's, and a diverged
    result must be said (health in summary.json and a warning)."""
    import json
    clean = _akit_case(ws, folder / "first", False, None, command="online")
    out = Path(clean.steps[0].argv[clean.steps[0].argv.index("--out") + 1])
    bad = _akit_case(ws, folder / "second", False, _damage("DVL", _negate_velocities), command="online")
    argv = bad.steps[0].argv
    argv[argv.index("--out") + 1] = str(out)
    started = {}

    def runner(_ws, limit):
        first = run_step(clean.steps[0], folder, timeout_s=limit)
        if first.returncode != 0:
            return first
        import time
        started["t"] = time.time()
        return run_step(Step(argv), folder, timeout_s=limit)

    def check(run):
        from graphnav.evaluation.metrics import vrmse
        from graphnav.io.outputs import read_trajectory_csv
        stale = [p.name for p in out.iterdir() if p.is_file() and p.stat().st_mtime < started.get("t", 0)]
        if stale:
            return float("nan"), 0.0, f"files of the earlier run left in OUT: {', '.join(sorted(stale))}"
        value = vrmse(read_trajectory_csv(out / "online.csv"), ws.sim_folder_gt)
        health = (json.loads((out / "summary.json").read_text()).get("health") or {})
        note = f"VRMSE {value:.3f} m/s; summary health ok={health.get('ok')}"
        bound = RESULT_FACTOR * ws.clean["online replay: clean"]
        if value > bound and health.get("ok", True):
            return value, bound, note + " (a diverged result reported as healthy)"
        return value, bound, note
    return Plan(runner=runner, check=check)


def _live_stream_life(ws: Workspace, folder: Path) -> Plan:
    """``graphnav online --stream -`` fed the first 300 s of a live stream through a pipe that stays open: lines
    must come out (standard output, flushed: status lines while it aligns, then estimates) while the stream is
    still open."""
    import subprocess
    import sys
    import threading
    import time
    from graphnav.estimators.replay import mission_records
    from graphnav.io.streamio import write_records
    from graphnav.sim.simulate import simulate_mission
    folder.mkdir(parents=True, exist_ok=True)
    live = simulate_mission(300.0, "navigation", seed=5, dvl_stamp_offset_s=0.37)
    stream = folder / "live.jsonl"
    with stream.open("w") as fh:
        write_records(mission_records(live), fh)
    out = folder / "out"
    argv = ["online", "--stream", "-", "--out", str(out), "--no-plots", "--no-progress"]
    seen = {}

    def runner(_ws, limit):
        start = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "graphnav", *argv], stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        lines: list[bytes] = []
        err: list[bytes] = []

        def drain(pipe, into):
            for line in iter(pipe.readline, b""):
                into.append(line)

        def feed():
            try:
                proc.stdin.write(stream.read_bytes())
                proc.stdin.flush()
            except BrokenPipeError:
                pass
        threads = [threading.Thread(target=drain, args=(proc.stdout, lines), daemon=True),
                   threading.Thread(target=drain, args=(proc.stderr, err), daemon=True),
                   threading.Thread(target=feed, daemon=True)]
        for th in threads:
            th.start()
        # The pipe holds at most 64 KiB (a few seconds of data): once the writer is through, the command has
        # read the 300 s; an estimate due in them is out a moment later, or never while the stream is open.
        deadline = start + max(limit, CLEAN_TIME_LIMIT_S)
        while not lines and proc.poll() is None and time.perf_counter() < deadline:
            if not threads[2].is_alive():
                threads[2].join()
                grace = time.perf_counter() + 10.0
                while not lines and proc.poll() is None and time.perf_counter() < grace:
                    time.sleep(0.1)
                break
            time.sleep(0.1)
        seen["while_open"] = len(lines)
        seen["status_while_open"] = sum(b'"type":"status"' in line for line in lines)
        threads[2].join(max(0.0, deadline - time.perf_counter()))    # the rest of the stream, then its end
        seen["fed"] = not threads[2].is_alive()
        try:
            proc.stdin.close()
        except BrokenPipeError:
            pass
        try:
            code = proc.wait(timeout=max(limit, CLEAN_TIME_LIMIT_S) if seen["fed"] else 1.0)
        except subprocess.TimeoutExpired:
            _kill(proc)
            proc.wait()
            code = None
        for th in threads[:2]:
            th.join(5)
        return Run(code, b"".join(lines).decode(errors="replace"), b"".join(err).decode(errors="replace"),
                   time.perf_counter() - start)

    def check(run):
        from graphnav.evaluation.metrics import vrmse
        from graphnav.io.outputs import read_trajectory_csv
        if not seen.get("while_open"):
            return float("nan"), 0.0, "no line (estimate or status) while the stream was open (nothing until its end)"
        value = vrmse(read_trajectory_csv(out / "online.csv"), live.gt)
        return value, RESULT_FACTOR * ws.clean["online stream: clean"], \
            (f"{seen['while_open']} line(s) before the stream closed ({seen['status_while_open']} status); "
             f"VRMSE {value:.3f} m/s")
    return Plan(runner=runner, check=check)


def _train_beams_case(ws: Workspace, folder: Path) -> Plan:
    """``graphnav train-beams --epochs 1`` (a quick try, no --out): the shipped weights must not change. They
    are backed up first and put back after the case, whatever happened."""
    import shutil

    from graphnav.nets.storage import weights_dir
    shipped = weights_dir()
    backup = folder / "weights-backup"
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copytree(shipped, backup, dirs_exist_ok=True)
    before = _tree_digest(shipped)
    argv = ["train-beams", "--epochs", "1", "--sigma-epochs", "1", "--scenario", "2-missing", "--no-progress",
            "--data", str(ws.beamsnet)]

    def check(run):
        changed = sorted(k for k, v in _tree_digest(shipped).items() if before.get(k) != v)
        if changed:
            return float("nan"), 0.0, f"shipped weights overwritten: {', '.join(changed)} (restored)"
        return 0.0, 1.0, "shipped weights untouched"

    def cleanup():
        if _tree_digest(shipped) != before:
            shutil.copytree(backup, shipped, dirs_exist_ok=True)
            for name in set(_tree_digest(shipped)) - set(before):
                (shipped / name).unlink()
    return Plan([Step(argv, timeout_s=240.0)], check=check, cleanup=cleanup)


def _tree_digest(folder: Path) -> dict:
    import hashlib
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


def _missing_stream(ws: Workspace, folder: Path) -> Plan:
    out = folder / "out"
    return Plan([Step(["online", "--stream", str(folder / "no-such-stream.jsonl"), "--out", str(out),
                       "--no-plots", "--no-progress"])], out / "online.csv", reference=ws.sim.gt)


def _out_is_a_file(ws: Workspace, folder: Path) -> Plan:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "out").write_text("a file where the output folder should go\n")
    return _akit_case(ws, folder, False, None)


def _out_not_writable(ws: Workspace, folder: Path) -> Plan:
    plan = _akit_case(ws, folder, False, None)
    argv = plan.steps[0].argv
    argv[argv.index("--out") + 1] = "/proc/graphnav-out"      # not writable, not even for root
    return plan


# --- the table ---------------------------------------------------------------------------------------------
def _damage(kind: str, edit) -> Callable[[Path], None]:
    return lambda folder: edit_csv(_csv_file(folder, kind), edit)


def _t_between(t0, t1):
    return lambda d: _rows_at(d, t0, t1)


def _imu_row(d):
    return len(d) // 3


def _scale_cols(cols, factor):
    def edit(d):
        d[:, cols] *= factor
        return d
    return edit


def _negate_velocities(d):
    d[:, 1:4] *= -1.0
    return d


def _swap_xy(d):
    return d[:, [0, 2, 1, 3]]


def _swap_blocks(d):
    return d[:, [0, 4, 5, 6, 1, 2, 3]]


def _delete_rows(t0, t1):
    return lambda d: d[~_rows_at(d, t0, t1)]


def _zero_stamp(d):
    d[len(d) // 2, 0] = 0.0
    return d


def _dup_stamp(d):
    d[len(d) // 2, 0] = d[len(d) // 2 - 1, 0]
    return d


def _row_twice(d):
    return np.insert(d, len(d) // 2, d[len(d) // 2], axis=0)


def _in_packets(k: int, spacing_s: float = 1e-5):
    """IMU rows stamped as a driver reading ``k`` samples at a time stamps them on receipt: each packet at its last
    sample's stamp, ``spacing_s`` apart (0: one stamp shared by the packet)."""
    def edit(d):
        last = np.minimum((np.arange(len(d)) // k + 1) * k - 1, len(d) - 1)
        d[:, 0] = d[last, 0] - spacing_s * (last - np.arange(len(d)))
        return d
    return edit


def _on_clock(grid_s: float, jitter_s: float, seed: int = 0):
    """IMU rows stamped by a logger whose clock ticks every ``grid_s`` (truncated), read with ``jitter_s`` of
    timing noise (seeded): 100 Hz in whole 10 ms repeats some stamps and skips others."""
    def edit(d):
        noise = np.random.default_rng(seed).normal(0.0, jitter_s, len(d))
        d[:, 0] = np.floor((d[:, 0] + noise) / grid_s) * grid_s
        return d
    return edit


def _stream_imu_stamps(edit_stamps):
    """A stream edit: the IMU records' stamps rewritten by ``edit_stamps`` (a file edit on a one-column array)."""
    import json

    def edit(lines):
        rows = [i for i, line in enumerate(lines) if '"type":"imu"' in line]
        records = [json.loads(lines[i]) for i in rows]
        t = edit_stamps(np.array([[r["t"]] for r in records], float))[:, 0]
        for i, r, stamp in zip(rows, records, t):
            r["t"] = float(stamp)
            lines[i] = json.dumps(r, separators=(",", ":"))
        return lines
    return edit


def _without_gt(edit_dvl):
    """A damage that leaves the folder as a vehicle has it (no GT file) and edits its DVL file."""
    def damage(folder: Path) -> None:
        _csv_file(folder, "GT").unlink()
        edit_csv(_csv_file(folder, "DVL"), edit_dvl)
    return damage


def _turn_dvl_about_z(deg):
    def edit(d):
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        d[:, 1], d[:, 2] = c * d[:, 1] - s * d[:, 2], s * d[:, 1] + c * d[:, 2]
        return d
    return edit


def _flu(d):
    d[:, 2:4] *= -1.0
    return d


def _shift_stamps(seconds):
    def edit(d):
        d[:, 0] += seconds
        return d
    return edit


E, W, K, D = (CLEAR_ERROR,), (WARNING,), (OK,), (DEGRADED,)
S, R, BAG = "smooth: clean", "smooth (real): clean", "bag: clean"
_DVL_XYZ = slice(1, 4)


def _sim(name, command, expected, damage=None, **kw):
    return CliCase(name, command, expected, lambda ws, f: _akit_case(ws, f, False, damage, **kw), S)


def _real(name, command, expected, damage=None):
    return CliCase(name, command, expected, lambda ws, f: _akit_case(ws, f, True, damage), R, real=True)


def _bag(name, expected, change=None):
    return CliCase(name, "smooth --data BAG", expected, lambda ws, f: _bag_case(ws, f, change), BAG)


def _cfg(name, expected, change):
    return CliCase(name, "smooth --config", expected, lambda ws, f: _with_config(ws, f, change), S)


def _stream(name, expected, edit):
    return CliCase(name, "online --stream -", expected, lambda ws, f: _stream_case(ws, f, edit),
                   "online stream: clean")


def _set_key(path: tuple, value):
    def change(cfg):
        node = cfg
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return change


#: Every case of ``graphnav faults``, clean runs first (their results scale the bounds of the others).
CLI_CASES: tuple[CliCase, ...] = (
    _sim(S, "smooth", K),
    CliCase("online replay: clean", "online", K, lambda ws, f: _akit_case(ws, f, False, None, command="online"),
            "online replay: clean"),
    _stream("online stream: clean", K, None),
    # IMU
    _sim("IMU: one accelerometer sample of 1e6 m/s^2", "smooth", W, _damage("IMU", _set(_imu_row, 1, 1e6))),
    _sim("IMU: accelerometer and gyro blocks swapped", "smooth", E + W, _damage("IMU", _swap_blocks)),
    _sim("IMU: stamps in milliseconds", "smooth", E + W, _damage("IMU", _scale_cols(0, 1e3))),
    _sim("IMU: gyro in deg/s", "smooth", E + W, _damage("IMU", _scale_cols(slice(4, 7), np.degrees(1.0)))),
    _sim("IMU: accelerometer in g", "smooth", E + W, _damage("IMU", _scale_cols(slice(1, 4), 1 / 9.80665))),
    _sim("IMU: 50 NaN rows (0.5 s)", "smooth", W + E, _damage("IMU", _set(_t_between(60.0, 60.5), slice(1, 7),
                                                                             np.nan))),
    _sim("IMU: 50 all-zero rows (0.5 s, a logger's filler)", "smooth", W,
         _damage("IMU", _set(_t_between(60.0, 60.5), slice(1, 7), 0.0))),
    _sim("IMU: 5 s of rows deleted (logger stall)", "smooth", W + D, _damage("IMU", _delete_rows(70.0, 75.0))),
    _sim("IMU: a stamp of 0 mid-file", "smooth", E + W, _damage("IMU", _zero_stamp)),
    _sim("IMU: a duplicated stamp", "smooth", E + W, _damage("IMU", _dup_stamp)),
    _sim("IMU: a row written twice", "smooth", W, _damage("IMU", _row_twice)),
    _sim("IMU: stamped in packets of 10 on receipt (0.01 ms apart)", "smooth", W, _damage("IMU", _in_packets(10))),
    _sim("IMU: packets of 10 sharing one stamp", "smooth", W, _damage("IMU", _in_packets(10, 0.0))),
    _sim("IMU: stamped on a 10 ms clock with 1 ms jitter", "smooth", W, _damage("IMU", _on_clock(0.01, 1e-3))),
    _sim("IMU: one read of 0.2 s lost", "smooth", W, _damage("IMU", _delete_rows(60.0, 60.2))),
    _sim("IMU: one gyro sample of 5 rad/s (under full scale)", "smooth", W, _damage("IMU", _set(_imu_row, 6, 5.0))),
    _sim("IMU: an infinite gyro cell", "smooth", W, _damage("IMU", _set(_imu_row, 5, np.inf))),
    _sim("IMU: gyro 57.3x too small (converted to rad/s twice)", "smooth", E,
         _damage("IMU", _scale_cols(slice(4, 7), np.radians(1.0)))),
    # DVL
    _sim("DVL: 60 s of rows deleted", "smooth", W + D, _damage("DVL", _delete_rows(40.0, 100.0))),
    _sim("DVL: 60 s of NaN rows", "smooth", W + D, _damage("DVL", _set(_t_between(40.0, 100.0), _DVL_XYZ, np.nan))),
    _sim("DVL: one velocity spike of 30 m/s", "smooth", W, _damage("DVL", _set(lambda d: 70, 1, 30.0))),
    _sim("DVL: velocities in cm/s", "smooth", E + W, _damage("DVL", _scale_cols(_DVL_XYZ, 100.0))),
    _sim("DVL: x and y axes swapped (another frame)", "smooth", E + W, _damage("DVL", _swap_xy)),
    _sim("DVL: clock 3 days ahead of the IMU", "smooth", E, _damage("DVL", _shift_stamps(3 * 86400.0))),
    _sim("DVL: 10 pings of exactly 0 m/s (no bottom lock)", "smooth", W,
         _damage("DVL", _set(_t_between(70.0, 80.0), _DVL_XYZ, 0.0))),
    # before: ZeroDivisionError in the DVL time-offset fit against the GT
    _sim("DVL: every ping NaN (no bottom lock all mission)", "smooth", E, _damage("DVL", _set(slice(None), _DVL_XYZ,
                                                                                            np.nan))),
    # ground truth
    _sim("GT: one velocity sample of 1e6 m/s", "smooth", W, _damage("GT", _set(lambda d: 50, 4, 1e6))),
    _sim("GT: latitude and longitude in degrees", "smooth", W,
         _damage("GT", _scale_cols(slice(1, 3), np.degrees(1.0)))),
    _sim("GT: clock 3 days from the IMU", "smooth", W, _damage("GT", _shift_stamps(3 * 86400.0))),
    # a ROS 2 bag of the simulated mission, as a driver and a recorder damage it
    _bag(BAG, K),
    _bag("bag: every header stamp 0 (a driver that never fills it)", W, _zero_stamps),
    _bag("bag: DVL header clock steps +5 s at 60 s, pings keep arriving", W, _dvl_clock_off(5.0, 60.0)),
    _bag("bag: DVL header clock 5 s behind until set right at 60 s", W, _dvl_clock_off(-5.0, 60.0, before=True)),
    _bag("bag: 0.2 s of IMU messages lost at 60 s", W, _imu_lost(60.0, 60.2)),
    _bag("bag: 5 IMU messages lost at 60 s as the latency drops 60 -> 2 ms", W, _imu_lost(60.0, 60.05, (0.06, 0.002))),
    # configuration
    _cfg("config: {}", W + K, "{}"),
    _cfg("config: []", E, "[]"),
    _cfg("config: imu_rate_hz -100", E, _set_key(("imu_rate_hz",), -100.0)),
    _cfg("config: imu_rate_hz 20 (the IMU runs at 100)", K, _set_key(("imu_rate_hz",), 20.0)),
    _cfg("config: negative gyro noise", E, _set_key(("imu", "gyro_noise_density"), -7e-7)),
    _cfg("config: wrong type (beam_noise_std 'high')", E, _set_key(("dvl", "beam_noise_std"), "high")),
    _cfg("config: negative sigma (depth_noise_std -0.05)", E, _set_key(("depth_noise_std",), -0.05)),
    _cfg("config: 2-element lever arm", E, _set_key(("dvl", "lever_arm_b"), [0.1, 0.2])),
    # the live stream
    _stream("stream: one DVL beam of 1e6 m/s", W, _edit_record("dvl", 50, lambda r: r["beams"].__setitem__(1, 1e6))),
    _stream("stream: config line not the first line", E + W, _config_not_first),
    _stream("stream: IMU stamped in packets of 10 on receipt", W, _stream_imu_stamps(_in_packets(10))),
    _stream("stream: IMU on a 10 ms clock with 1 ms jitter", W, _stream_imu_stamps(_on_clock(0.01, 1e-3))),
    _stream("stream: a stamp of 1e300", W, _edit_record("imu", 3000, lambda r: r.__setitem__("t", 1e300))),
    CliCase("stream: --stream on a missing file", "online --stream FILE", E, _missing_stream,
            "online stream: clean"),
    CliCase("stream: a live stream's first 300 s show life", "online --stream - (pipe open)", K, _live_stream_life,
            "online stream: clean"),
    # outputs and runs
    CliCase("--out is a file", "smooth --out FILE", E, _out_is_a_file, S),
    CliCase("--out not writable", "smooth --out /proc/...", E, _out_not_writable, S),
    CliCase("a diverged run into an existing --out", "online x2, same --out", E + D, _diverged_into_existing_out,
            "online replay: clean"),
    CliCase("online --resume after an interrupt", "online; SIGINT; online --resume", K, _resume_case,
            "online replay: clean"),
    CliCase("evaluate against an A-KIT folder", "smooth; evaluate --ref FOLDER", K,
            lambda ws, f: _evaluate_case(ws, f, False), S),
    # the shared real trajectory (--data)
    _real(R, "smooth", K),
    _real("real: one accelerometer sample of 1e6 m/s^2", "smooth", W, _damage("IMU", _set(_imu_row, 1, 1e6))),
    _real("real: 60 s of DVL rows deleted", "smooth", W + D, _damage("DVL", _delete_rows(40.0, 100.0))),
    _real("real: gyro in deg/s", "smooth", E + W, _damage("IMU", _scale_cols(slice(4, 7), np.degrees(1.0)))),
    _real("real: IMU stamps in milliseconds", "smooth", E + W, _damage("IMU", _scale_cols(0, 1e3))),
    _real("real: IMU stamped in packets of 10 on receipt", "smooth", W, _damage("IMU", _in_packets(10))),
    _real("real: IMU stamped on a 10 ms clock with 1 ms jitter", "smooth", W, _damage("IMU", _on_clock(0.01, 1e-3))),
    _real("real: one gyro sample of 5 rad/s (under full scale)", "smooth", W, _damage("IMU", _set(_imu_row, 6, 5.0))),
    # the shared real trajectory as a vehicle has it: IMU and DVL only (the DVL checked against the IMU alone)
    _real("real, no GT: DVL velocities in cm/s", "smooth", E, _without_gt(_scale_cols(_DVL_XYZ, 100.0))),
    _real("real, no GT: DVL y and z negated (FLU axes)", "smooth", E, _without_gt(_flu)),
    _real("real, no GT: DVL turned 20 deg about z", "smooth", E, _without_gt(_turn_dvl_about_z(20.0))),
    _real("real, no GT: DVL turned 5 deg about z", "smooth", W + D, _without_gt(_turn_dvl_about_z(5.0))),
    # placed by the DVL clock fit (before: loaded 3 s off, VRMSE 0.29 m/s, now 0.075); the copy unchanged gives
    # 0.074 m/s, already beyond the bound the run with its GT sets
    _real("real, no GT: DVL stamps 3 s late", "smooth", W + D, _without_gt(_shift_stamps(3.0))),
    _real("real: DVL turned 5 deg about z", "smooth", W + D, _damage("DVL", _turn_dvl_about_z(5.0))),
    CliCase("real: evaluate against the A-KIT folder", "smooth; evaluate --ref FOLDER", K,
            lambda ws, f: _evaluate_case(ws, f, True), R, real=True),
    CliCase("train-beams --epochs 1 leaves the shipped weights", "train-beams --epochs 1", K + E,
            _train_beams_case, real=True),
)


#: A clean run's velocity RMSE (m/s) above which the clean run itself is garbage (the simulated navigation-grade
#: mission and the shared trajectories give 0.03-0.1 m/s).
CLEAN_VRMSE_MAX = 0.3


def _vrmse_of(path: Path, gt) -> tuple[float, int, str]:
    """(VRMSE m/s against ``gt``, epochs, note) of a written trajectory CSV; NaN when absent or non-finite."""
    from graphnav.core.errors import GraphnavError as _Err
    from graphnav.evaluation.metrics import vrmse
    from graphnav.io.outputs import read_trajectory_csv
    if path is None or not Path(path).is_file():
        return float("nan"), 0, "no trajectory written"
    try:
        sol = read_trajectory_csv(path)
    except _Err as exc:
        return float("nan"), 0, f"trajectory unreadable: {exc}"
    if not len(sol.t):
        return float("nan"), 0, "trajectory empty"
    bad = ~np.all(np.isfinite(np.column_stack([sol.p_n, sol.v_n])), axis=1)
    if bad.any():
        return float("nan"), len(sol.t), f"{int(bad.sum())} epoch(s) with non-finite position/velocity"
    try:
        value = vrmse(sol, gt)
    except _Err as exc:
        return float("nan"), len(sol.t), f"not comparable with the reference: {exc}"
    return value, len(sol.t), f"VRMSE {value:.3f} m/s over {len(sol.t)} epochs"


def _score(case: CliCase, plan: Plan, run: Run, ws: Workspace) -> tuple[float, float, str]:
    """(value, bound, note) of a finished case."""
    if plan.check is not None:
        try:
            return plan.check(run)
        except Exception as exc:  # noqa: BLE001 - the harness must classify, not crash: no result
            return float("nan"), 0.0, f"no result ({type(exc).__name__}: {exc})"
    value, epochs, note = _vrmse_of(plan.result, plan.reference)
    if case.baseline == case.name:
        ws.clean[case.name], ws.clean_epochs[case.name] = value, epochs
        return value, CLEAN_VRMSE_MAX, note
    clean_epochs = ws.clean_epochs.get(case.baseline, 0)
    if np.isfinite(value) and epochs < 0.5 * clean_epochs:
        return float("nan"), 0.0, f"{note}: fewer than half the {clean_epochs} epochs of the clean run"
    return value, RESULT_FACTOR * ws.clean.get(case.baseline, float("nan")), note


def _said(run: Run) -> str:
    """What the run said about its end, shortened: the exception of a traceback (its last line), else the
    ``error:`` line, else the last warning."""
    lines = [ln.strip() for ln in run.stderr.splitlines() if ln.strip()]
    if "Traceback (most recent call last)" in run.stderr and lines:
        return lines[-1][:160]
    for line in lines:
        if "error:" in line.lower():
            return line[:160]
    warned = _warning_lines(run.stderr)
    return f"last warning: {warned[-1][:140]}" if warned else ""


def run_case(case: CliCase, ws: Workspace) -> CaseResult:
    """Prepare, run and classify one case (never raises for what the commands do)."""
    import shutil
    import time
    import zlib
    # names differing only in punctuation ("config: {}", "config: []") must not share a folder
    folder = ws.root / "cases" / (f"{zlib.crc32(case.name.encode()):08x}-"
                                  + "".join(c if c.isalnum() else "_" for c in case.name)[:60])
    if folder.exists():
        shutil.rmtree(folder)
    start = time.perf_counter()
    plan = case.plan(ws, folder)
    try:
        if plan.runner is not None:
            run = plan.runner(ws, time_limit(ws, case))
        else:
            folder.mkdir(parents=True, exist_ok=True)
            for step in plan.steps:
                run = run_step(step, folder, timeout_s=time_limit(ws, case))
                if run.returncode != 0:
                    break
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "stdout.txt").write_text(run.stdout)
        (folder / "stderr.txt").write_text(run.stderr)
        new = [w for w in _warning_lines(run.stderr)
               if _shape(w) not in ws.clean_warnings.get(case.baseline, set())]
        if case.baseline == case.name:
            ws.clean_warnings[case.name] = {_shape(w) for w in _warning_lines(run.stderr)}
            ws.clean_wall[case.name] = run.wall_s
            new = []
        value, bound, note = (float("nan"), float("nan"), "") if run.returncode != 0 else _score(case, plan, run, ws)
        verdict = classify(run, value, bound, bool(new))
        if verdict in (CLEAR_ERROR, TRACEBACK, UNEXPLAINED, HANG):
            note = _said(run) or ("killed at the time limit" if verdict == HANG else "exit code "
                                  f"{run.returncode}, nothing said")
        elif new and not note.startswith("no result"):
            # the estimator's own verdict on its result says most; else the first thing the user was told
            told = next((w for w in new if "DIVERGED" in w), new[0])
            note = f"{note}; warned ({len(new)}): {told[:120]}"
        note = note.replace(str(folder), "CASE")          # the case's own folder: short, and the same every run
        return CaseResult(case, verdict, value, bound, note, time.perf_counter() - start, new)
    finally:
        if plan.cleanup is not None:
            plan.cleanup()


def run_table(ws: Workspace, cases=CLI_CASES, jobs: int = 2, progress=None) -> list[CaseResult]:
    """Run ``cases`` (the clean ones first, one after the other; then the rest in ``jobs`` threads, each case
    its own subprocesses); returns their results in the order of ``cases``. ``progress(result)`` is called as
    each finishes."""
    from concurrent.futures import ThreadPoolExecutor
    runnable = [c for c in cases if (not c.real or ws.real_folder is not None)
                and ("train-beams" not in c.name or ws.beamsnet is not None)]
    ws.skipped = [c.name for c in cases if c not in runnable]
    cases = runnable
    results: dict[str, CaseResult] = {}

    def one(case):
        res = run_case(case, ws)
        results[case.name] = res
        if progress is not None:
            progress(res)
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        list(pool.map(one, [c for c in cases if c.baseline == c.name]))
        list(pool.map(one, [c for c in cases if c.name not in results]))
    return [results[c.name] for c in cases]


def _num(x: float, unit: str = "") -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.3g}{unit}"


def format_table(results: list[CaseResult], title: str = "") -> str:
    """The results as a markdown table: case, command, expected, verdict (bold when not expected), result
    against its bound, wall time, what the user saw."""
    lines = [title] if title else []
    lines += ["| case | command | expected | verdict | result | bound | s | what the user saw / why |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        verdict = r.verdict if r.as_expected else f"**{r.verdict}**"
        note = r.note.replace("|", "/").replace("\n", " ")
        lines.append(f"| {r.case.name} | `{r.case.command}` | {' / '.join(r.case.expected)} | {verdict} | "
                     f"{_num(r.value)} | {_num(r.bound)} | {r.wall_s:.0f} | {note} |")
    bad = [r for r in results if r.verdict in BAD_VERDICTS]
    off = [r for r in results if not r.as_expected]
    lines += ["", f"{len(results)} cases: {len(results) - len(off)} as expected, {len(off)} not; "
                  f"{len(bad)} traceback / hang / silent garbage / unexplained exit"
                  + (f" ({', '.join(r.case.name for r in bad)})" if bad else "") + ".",
              f"Verdicts: clear error = non-zero exit with a message, no traceback; warning = exit 0, a warning "
              f"the clean run does not give, result within {RESULT_FACTOR:g}x the clean run's; ok = the same "
              f"without a new warning; warning, degraded = warned, result beyond the bound; silent garbage = "
              f"exit 0, no new warning, result beyond the bound, non-finite or missing. Result: velocity RMSE "
              f"(m/s) against the clean mission's ground truth, unless the case says otherwise."]
    return "\n".join(lines)
