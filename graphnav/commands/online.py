"""``graphnav online``: navigate as on a vehicle, sample by sample, through :class:`graphnav.estimators.navigator.Navigator`.

Two inputs: a recorded mission (``--data``, or the simulated default) replayed in time order, or a live
JSON-lines stream (``--stream -`` reads standard input; schema in :mod:`graphnav.io.streamio`). Ground truth,
when the mission has one, only initialises (``--init gt``/``auto``) and scores; without it the Navigator
aligns from the sensors (``--init sensors``; ``--initial-position``, ``--initial-heading`` help it).

Every estimate (the filtered state at a closed keyframe) is appended to ``OUT/online.csv`` and flushed at
once, so a crash or Ctrl-C keeps everything computed so far; with ``--stream`` it is also written to
standard output as a JSON line, flushed. ``--resume`` continues an interrupted replay: the estimator is
deterministic, so it replays the epochs already in the file without writing them and appends from the first
new epoch (never writing one twice). A live stream shows life while the Navigator aligns: every
``--status-every`` seconds a line on standard error and a ``status`` JSON line on standard output
(:func:`graphnav.io.streamio.status_record`). ``--schema`` prints the stream's record types and the
configuration keys.
"""
from __future__ import annotations

import contextlib
import json
import sys
import time
import warnings
from pathlib import Path

from graphnav.commands.common import (
    EXIT_EPILOG,
    HelpFormatter,
    accuracy_summary,
    add_init_arguments,
    add_mission_arguments,
    add_out_arguments,
    align_options,
    check_out,
    clear_out,
    make_plots,
    exit_status,
    mission_from_args,
    print_summary,
    regressed_beams_summary,
    run_health_record,
)
from graphnav.core.errors import ConfigError
from graphnav.evaluation.methods import GRAPH_TC, METHODS, completer_state
from graphnav.evaluation.metrics import drift_summary, fix_stamps

#: The methods that run sample by sample (every one but the batch smoother), in the registry's order.
STREAMING_METHODS = tuple(name for name, m in METHODS.items() if not m.batch)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "online", help="navigate sample by sample (fixed-lag graph, ISAM2 or EKF); a live JSON-lines stream or "
                       "a recorded mission; per-epoch CSV flushed live",
        description="Navigate as on a vehicle: samples go one by one through graphnav's Navigator (reorder "
                    "buffer, alignment from the sensors when there is no initial state, keyframes closed as "
                    "soon as the IMU passes them). Input: a recorded mission (--data or the simulated "
                    "default) or a live JSON-lines stream (--stream -; its schema: graphnav online --schema). "
                    "Each estimate is appended to OUT/online.csv and flushed at once (and, with "
                    "--stream, printed to standard output as a JSON line); Ctrl-C keeps the file; --resume "
                    "continues a replay from its last epoch. An --out that already holds files is refused unless "
                    "--resume or --force (which empties it first). A final summary goes to OUT/summary.json. Every "
                    "estimate says how far to trust it: 'health' (ok / degraded / diverged) and 'health_why' in "
                    "the JSON lines, a health column in the CSV.",
        epilog=EXIT_EPILOG, formatter_class=HelpFormatter)
    add_mission_arguments(p)
    add_init_arguments(p)
    p.add_argument("--stream", metavar="FILE",
                   help="read the measurements as JSON lines from FILE ('-' = standard input) instead of a mission")
    p.add_argument("--schema", action="store_true",
                   help="print the JSON-lines stream schema (record types, fields, units) and the configuration "
                        "keys, then exit")
    p.add_argument("--status-every", type=float, default=5.0, metavar="S",
                   help="with --stream: while aligning, a status line on standard error and a status JSON line "
                        "on standard output every S seconds of wall time")
    add_out_arguments(p, "out/online")
    p.add_argument("--method", default=GRAPH_TC, choices=STREAMING_METHODS,
                   help="Graph-TC: measured beams only (the default: with the shared data's own IMU regressed "
                        "beams do not help, see docs/decisions/regressed-beams.md); Graph-HN adds the completer's "
                        "regressed beams as weak factors; Graph-HNP the pivot completer's (the hull's turn from the "
                        "gyro: it helps a MEMS IMU during long outages; both take their completions out of the "
                        "graph when the beams return (the fixed-lag smoother: those of the last "
                        "retire_hold_s + lag, 150 s by default), "
                        "docs/decisions/completers.md); "
                        "Graph-MP a motion prior where fewer than 3 beams are measured; the others run the "
                        "paper's EKF (TC/LC and their hybrids); the graph settings are the registry's "
                        "(graphnav.evaluation.methods)")
    p.add_argument("--backend", default="fixed-lag", choices=("fixed-lag", "isam2"),
                   help="graph methods: fixed-lag smoother (bounded time and memory) or ISAM2 over the whole "
                        "mission")
    p.add_argument("--lag", type=float, default=None, metavar="S",
                   help="fixed-lag smoother window in s (default: GraphOptions.lag_s)")
    p.add_argument("--reorder-window", type=float, default=None, metavar="S",
                   help="how late (s) a sample may arrive after later-stamped ones (default: "
                        "NavigatorOptions.reorder_window_s)")
    p.add_argument("--realtime", action="store_true",
                   help="pace a replay to the mission clock (sleep until each epoch's time has come)")
    p.add_argument("--speed", type=float, default=1.0, metavar="X",
                   help="with --realtime: play X times faster than real time")
    p.add_argument("--resume", action="store_true",
                   help="continue from the last epoch in OUT/online.csv instead of starting anew")
    p.add_argument("--fsync", action="store_true",
                   help="also force each epoch to disk (survives power loss; slower)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots at the end")
    p.set_defaults(func=run)


def epoch_fields(est) -> dict:
    """The CSV fields of one :class:`graphnav.estimators.types.EpochEstimate`: t, p_n, v_n, C_b_n, the accelerometer
    and gyro biases, health and the covariances (velocity, position, attitude; None where the estimator has none)."""
    bias = est.bias
    return {"t": est.t, "p_n": est.p_n, "v_n": est.v_n, "C_b_n": est.C_b_n, "cov_v_n": est.cov_v_n,
            "bias_acc": None if bias is None else bias.accelerometer(),
            "bias_gyro": None if bias is None else bias.gyroscope(), "health": getattr(est, "health", None),
            "cov_p_n": getattr(est, "cov_p_n", None), "cov_rot_b": getattr(est, "cov_rot_b", None)}


class EpochSink:
    """Called with each estimate: skip replayed epochs, pace, write+flush the CSV (and a JSON line to
    ``echo``), advance the progress bar."""

    def __init__(self, writer, bar, skip_until: float | None, realtime: bool, speed: float, echo=None):
        self.writer, self.bar, self.echo = writer, bar, echo
        self.skip_until = skip_until
        self.realtime, self.speed = realtime, speed
        self.first_t: float | None = None
        self.wall0: float | None = None
        self.n_new = 0
        self.n_replayed = 0

    def __call__(self, est) -> None:
        from graphnav.io.outputs import written_stamp
        f = epoch_fields(est)
        t = float(f["t"])
        self.bar.update(1)
        # compared as written (stamps to the microsecond): a stamp read back from the file is the written one
        if self.skip_until is not None and written_stamp(t) <= self.skip_until:
            self.n_replayed += 1
            return
        if self.realtime:
            if self.first_t is None:
                self.first_t, self.wall0 = t, time.perf_counter()
            ahead = (t - self.first_t) / self.speed - (time.perf_counter() - self.wall0)
            if ahead > 0:
                time.sleep(ahead)
        self.writer.write(**f)
        if self.echo is not None:
            from graphnav.io.streamio import estimate_record
            self.echo.write(json.dumps(estimate_record(est), separators=(",", ":")) + "\n")
            self.echo.flush()
        self.n_new += 1


def _imu_repairs(info: dict) -> dict:
    """What the Navigator did to the IMU stream as it came, in samples: gaps bridged (``gaps``), rows of zeros, the
    burst a stream started with (left out of its rate) and samples restamped from packets onto the IMU's period; the
    gaps in every stream judged a clock step or a loss, by verdict, where there were any."""
    repairs = {"gaps": info.get("imu_gaps", 0), "zero_rows": info.get("imu_zero_rows", 0),
               "start_burst": info.get("imu_start_burst", 0), "restamped": info.get("imu_restamped", 0)}
    if info.get("gaps_in_every_stream"):
        repairs["gaps_in_every_stream"] = dict(info["gaps_in_every_stream"])
    return repairs


def update_timing(update_s) -> dict:
    """Median, p99 and max of the per-keyframe solver times, ms."""
    import numpy as np
    if not update_s:
        return {}
    ms = 1e3 * np.asarray(update_s, float)
    return {"keyframes": int(ms.size), "median_ms": float(np.median(ms)),
            "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max())}


def make_navigator(args, config, mission=None):
    """The Navigator the arguments ask for: backend and completer from ``--method``, the initial state from
    ``--init`` (ground truth at the first ping of ``mission``) or the aligner's options."""
    from graphnav.estimators.navigator import Navigator, NavigatorOptions
    from graphnav.estimators.replay import first_ping_time
    from graphnav.estimators.runs import initial_state, replay_options
    from graphnav.evaluation.methods import completer_for, estimator_options, get_method
    method = get_method(args.method)
    completer, described = completer_for(method.name, args.scenario, config.dvl.beam_noise_std, config)
    ekf = method.family == "ekf"
    backend = "ekf" if ekf else ("fixed-lag" if args.lag is not None else args.backend)
    # the per-epoch CSV and the stream print the position and attitude sigmas: ask the graph for them
    graph_options = None if ekf else estimator_options(
        method.name, {"marginals": "full", **({} if args.lag is None else {"lag_s": args.lag})})
    ekf_options = estimator_options(method.name) if ekf else None   # e.g. the -12 methods' 12-state filter
    reorder = {} if args.reorder_window is None else {"reorder_window_s": args.reorder_window}
    nav_options = NavigatorOptions(align=align_options(args), **reorder)
    if mission is not None:     # a live stream's zero pings and shocks are judged as they come
        nav_options = replay_options(nav_options, mission)
    initial = None
    if mission is not None:
        initial = initial_state(mission, None, args.init, first_ping_time(mission))
    elif args.init == "gt":
        from graphnav.core.errors import ConfigError
        raise ConfigError("--init gt needs a mission with ground truth; a stream has none (use --init sensors)")
    nav = Navigator(config, backend, completer=completer, initial=initial, graph_options=graph_options,
                    ekf_options=ekf_options, tight=method.tight, options=nav_options)
    return nav, described


def run(args) -> int:
    from tqdm import tqdm

    from graphnav.core.config import read_config
    from graphnav.io.outputs import EpochCsvWriter, read_trajectory_csv, uncertainty_summary, write_json

    if args.schema:
        from graphnav.io.streamio import schema_text
        print(schema_text())
        return 0
    streaming = args.stream is not None
    check_inputs(args)
    cli_config = read_config(args.config) if args.config else None
    out = check_out(args.out, force=args.force, resume=args.resume)
    mission, outages = (None, []) if streaming else mission_from_args(args)   # bad input stops before --out changes
    if args.force and not args.resume and out.exists():
        clear_out(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "online.csv"
    log = sys.stderr if streaming else sys.stdout
    with EpochCsvWriter(csv_path, resume=args.resume, fsync=args.fsync) as writer:
        resumed_from = writer.last_t
        if resumed_from is not None:
            print(f"resuming after t = {resumed_from:.3f} s ({writer.n_written} epochs already in {csv_path}); "
                  "replaying the earlier epochs without writing them", file=log)
        total = None if streaming else len(mission.dvl.t)
        bar = tqdm(total=total, desc=args.method, unit="epoch", disable=args.no_progress or streaming,
                   dynamic_ncols=True)
        sink = EpochSink(writer, bar, resumed_from, args.realtime, args.speed,
                         echo=sys.stdout if streaming else None)
        start = time.perf_counter()
        stop = InterruptFlag()
        try:
            if streaming:
                nav, described, stream_info = run_stream(args, sink, stop, cli_config)
            else:
                from graphnav.estimators.navigator import feed_mission
                nav, described = make_navigator(args, mission.config, mission)
                feed_mission(nav, mission, callback=sink, stop=stop)
                stream_info = {}
        finally:
            stop.restore()
            bar.close()
        wall = time.perf_counter() - start
        n_total = writer.n_written
    info = nav.info
    written = read_trajectory_csv(csv_path, method=args.method)
    # how the positions were placed: a run started without its position is scored from the start, one a fix
    # placed later in the fix's frame, and one that used fixes by its drift between them
    written.info.update({k: info[k] for k in ("alignment", "position_frame", "n_fixes") if info.get(k)})
    duration = float(written.t[-1] - written.t[0]) if len(written.t) > 1 else 0.0
    summary = {
        "method": args.method, "backend": nav.backend_name,
        "mode": nav.backend_name if args.lag is None else f"fixed-lag {args.lag:g} s",
        "mission": "<stream>" if streaming else mission.name, "scenario": args.scenario,
        "imu_grade": args.imu_grade, "completer": described, "epochs": int(n_total),
        "epochs_this_run": sink.n_new, "epochs_replayed": sink.n_replayed, "resumed_after_s": resumed_from,
        "duration_s": duration if streaming else mission.duration, "runtime_s": wall,
        "realtime_factor": (duration if streaming else mission.duration) / wall if wall > 0 else float("nan"),
        "update_timing": update_timing(info.get("update_s")),
        "initialisation": info.get("alignment", {"source": "ground truth" if nav.initialised and
                                                  nav.alignment is None else "none"}),
        "refused": info["refused"], "doubted": info.get("doubted", {}), "stream": stream_info,
        "imu_repairs": _imu_repairs(info),
        "health": run_health_record(info, mission),
        "streams": None if mission is None else _loaded_streams(mission),
        "accuracy": accuracy_summary(written, mission, outages) if mission is not None and len(written.t) else {},
        "drift": (drift_summary(written, None if mission is None else mission.gt, fix_stamps(mission))
                  if len(written.t) else None),
        "position_frame": info.get("position_frame"),
        "uncertainty": uncertainty_summary(written), "regressed_beams": regressed_beams_summary(info),
        "completer_state": completer_state(nav.completer),
        "completer_fallbacks": info.get("completer_fallbacks", {}),
        "files": {"online_csv": str(csv_path)},
    }
    if not args.no_plots and mission is not None and len(written.t):
        plots = make_plots(out, mission, [written], outages, f"online {summary['mode']}, {args.scenario}")
        summary["files"].update({Path(p).stem: p for p in plots})
    summary["files"]["summary_json"] = str(out / "summary.json")
    write_json(out / "summary.json", summary)
    print_summary(summary, file=log)
    if n_total == 0:
        waiting = ""
        if nav.aligner is not None:
            a = nav.aligner.progress(end_of_data=True)
            waiting = (f": still aligning when the data ended ({a['aligned_s']:.0f} of {a['needed_s']:.0f} s of IMU "
                       f"data, {a['dvl_pings']} of {a['dvl_pings_needed']} DVL pings; waiting for: "
                       f"{', '.join(a['waiting_for']) or 'more data'}{'; ' + a['imu_gaps'] if a['imu_gaps'] else ''})")
        print(f"graphnav online: error: no estimate was made{waiting}; a longer log, a heading source "
              "(--initial-heading, a heading record) or an initial state (--init gt) starts it sooner",
              file=sys.stderr)
        return 1
    return exit_status(summary)


def check_inputs(args) -> None:
    """The stream file and the option values, checked before any work."""
    if args.stream is not None and args.stream != "-":
        path = Path(args.stream)
        if not path.exists():
            raise ConfigError(f"--stream {path}: file not found (use --stream - for standard input)")
        if path.is_dir():
            raise ConfigError(f"--stream {path}: is a folder; give a JSON-lines file (or - for standard input)")
    if not args.status_every > 0:
        raise ConfigError(f"--status-every must be > 0 s, got {args.status_every}")
    if not args.speed > 0:
        raise ConfigError(f"--speed must be > 0, got {args.speed}")


class StatusReporter:
    """While a Navigator aligns, show life: at the first record and then every ``every_s`` seconds of wall
    time, a line on ``err`` and a ``status`` JSON line on ``out``; one more when navigation starts. When no
    record comes for ``every_s`` (a silent stream), :meth:`idle` says so the same way (``state`` ``waiting for
    data``); it may run in another thread."""

    def __init__(self, every_s: float, out=None, err=None, clock=time.monotonic, source: str = "the stream"):
        import threading
        self.every_s = every_s
        self.out, self.err = out, err
        self.clock = clock
        self.source = source
        self.start = clock()
        self.last: float | None = None
        self.last_record: float | None = None
        self.last_t: float | None = None
        self.aligning = False
        self.n_status = 0
        self._lock = threading.Lock()

    def __call__(self, nav, t: float) -> None:
        from graphnav.io.streamio import status_record
        aligning = nav.aligner is not None
        now = self.clock()
        self.last_record, self.last_t = now, float(t)
        due = aligning and (self.last is None or now - self.last >= self.every_s)
        started = self.aligning and not aligning
        self.aligning = aligning
        if due or started:
            self._emit(status_record(nav, t, now - self.start), now)

    def idle(self) -> None:
        """A status when nothing has come for ``every_s`` (and none was shown for as long)."""
        now = self.clock()
        since = now - (self.start if self.last_record is None else self.last_record)
        if since >= self.every_s and (self.last is None or now - self.last >= self.every_s):
            self._emit({"type": "status", "t": self.last_t, "wall_s": round(now - self.start, 3),
                        "state": "waiting for data", "idle_s": round(since, 3), "source": self.source}, now)

    def _emit(self, rec: dict, now: float) -> None:
        with self._lock:
            self.last = now
            self.n_status += 1
            if self.out is not None:
                self.out.write(json.dumps(rec, separators=(",", ":")) + "\n")
                self.out.flush()
            if self.err is not None:
                print(f"graphnav online: {status_line(rec)}", file=self.err, flush=True)


def status_line(rec: dict) -> str:
    """A status record in words."""
    if rec["state"] == "waiting for data":
        return (f"no record from {rec['source']} for {rec['idle_s']:.0f} s"
                + ("" if rec["t"] is None else f" (last at t = {rec['t']:.1f} s)"))
    if rec["state"] != "aligning":
        return f"t = {rec['t']:.1f} s: aligned, navigating"
    a = rec["alignment"]
    waiting = ", ".join(a["waiting_for"]) or "the next IMU sample"
    heading = {"given": "heading given", "heading record": "heading from the heading records"}.get(
        a["heading"], f"heading by {a['heading']}")
    return (f"t = {rec['t']:.1f} s: aligning from the sensors, {a['aligned_s']:.0f} of {a['needed_s']:.0f} s of IMU "
            f"data, {a['dvl_pings']} of {a['dvl_pings_needed']} DVL pings with bottom lock, {heading}; "
            f"waiting for: {waiting}")


class InterruptFlag:
    """Ctrl-C (SIGINT) sets a flag that the loops check between samples, so that the interrupt stops the run at
    a clean point (delivered inside a GTSAM call it can surface as a TypeError from pybind11); a second
    Ctrl-C interrupts at once. ``restore()`` puts the previous handler back."""

    def __init__(self):
        import signal
        self.set = False
        self._signal = signal
        try:
            self._previous = signal.signal(signal.SIGINT, self._handle)
        except ValueError:          # not the main thread: leave Ctrl-C alone
            self._previous = None

    def _handle(self, signum, frame):
        if self.set:
            raise KeyboardInterrupt
        self.set = True
        # a silent stream delivers no next record to stop at: say how to stop now
        print("graphnav online: interrupted; stopping at the next sample (Ctrl-C again to stop at once)",
              file=sys.stderr, flush=True)

    def __call__(self) -> bool:
        return self.set

    def restore(self) -> None:
        if self._previous is not None:
            self._signal.signal(self._signal.SIGINT, self._previous)
            self._previous = None


def _loaded_streams(mission) -> dict:
    """What the loader read / used / refused per stream (``Mission.meta["streams"]``)."""
    from graphnav.io.stream_counts import ensure_streams
    return ensure_streams(mission)


@contextlib.contextmanager
def _watchdog(status: StatusReporter):
    """A daemon thread calling ``status.idle()`` about every second while the stream is read."""
    import threading
    done = threading.Event()

    def watch():
        while not done.wait(min(1.0, status.every_s)):
            status.idle()
    thread = threading.Thread(target=watch, name="graphnav-status", daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()


#: Configuration keys that say what the loaders and the prepare step do to a log's files (axis signs, clock offsets,
#: file layouts), with the value that does nothing. A live stream's records are body FRD on the IMU clock already
#: (:mod:`graphnav.io.streamio`), so the Navigator applies none of them.
FILE_ONLY_KEYS = {"imu_axis_signs": [1.0, 1.0, 1.0], "dvl_time_offset_s": 0.0, "gt_time_offset_s": 0.0,
                  "csv_columns": {}, "bag_topics": {}}


def _does_something(value, nothing) -> bool:
    """Whether a configuration value differs from the one that does nothing (numbers compared as numbers: -0.0, 0
    and [1, 1, 1] do nothing)."""
    import numpy as np
    try:
        return not np.array_equal(np.asarray(value, float), np.asarray(nothing, float))
    except (TypeError, ValueError):
        return json.dumps(value) != json.dumps(nothing)


def warn_file_only_keys(*overrides) -> None:
    """Warn once per configuration (``ConfigOverrides`` or None) that sets :data:`FILE_ONLY_KEYS` to something a
    stream does not do, naming them and why."""
    for over in filter(None, overrides):
        keys = [k for k, nothing in FILE_ONLY_KEYS.items()
                if over.sets(k) and _does_something(_plain(over.values[k]), nothing)]
        if keys:
            warnings.warn(f"{over.source}: {', '.join(keys)} not applied to a live stream: its records are taken as "
                          "body FRD on the IMU clock (graphnav online --schema); flip the IMU axes and add the "
                          "offsets where the stream is written (csv_columns and bag_topics describe files)",
                          RuntimeWarning, stacklevel=2)


def _plain(value):
    return value.tolist() if hasattr(value, "tolist") else value


def run_stream(args, sink, stop=None, cli_config=None):
    """Read JSON-lines records from ``--stream`` and feed them to a Navigator as they come; ``cli_config``
    (the keys of ``--config``) is laid over the stream's config line, itself over the defaults."""
    from graphnav.core.config import SensorConfig
    from graphnav.io.streamio import StreamReader, feed
    source = "<stdin>" if args.stream == "-" else args.stream
    status = StatusReporter(args.status_every, out=sys.stdout, err=sys.stderr, source=source)
    with (contextlib.nullcontext(sys.stdin) if args.stream == "-" else open(args.stream)) as fh, \
            _watchdog(status):
        reader = StreamReader(fh, source)
        nav = described = None
        for rec in reader:
            if stop is not None and stop():
                raise KeyboardInterrupt
            if nav is None:
                config = reader.config.over(SensorConfig()) if reader.config else SensorConfig()
                if cli_config:
                    config = cli_config.over(config)
                warn_file_only_keys(cli_config, reader.config)
                nav, described = make_navigator(args, config)
            for est in feed(nav, rec):
                sink(est)
            status(nav, rec["t"])
        if nav is None:
            from graphnav.core.errors import DataError
            raise DataError("the stream holds no measurement record", source)
        for est in nav.finish():
            sink(est)
    return nav, described, {"records": reader.n_records, "bad_lines": reader.n_bad, "refused": reader.refused,
                            "status_lines": status.n_status,
                            "config": " over ".join(n for n, c in (("--config", cli_config), ("stream", reader.config))
                                                    if c) or "default"}
