"""``graphnav results``: the results page (``docs/results.md``) generated from a bench run's ``results.json``.

The page is made by :func:`graphnav.evaluation.results_page.results_page`; this module reads the arguments,
checks the output file and writes it.
"""
from __future__ import annotations

import datetime
import os
import shlex
import sys
from pathlib import Path

from graphnav.commands.common import HelpFormatter


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "results", help="write the results page (docs/results.md) from a bench run's results.json",
        description="Turn the records of a `graphnav bench` run into one Markdown page: per IMU grade a method x "
                    "scenario table of window and mission VRMSE, the bench report's regime and NEES sections and "
                    "the runtime per method, with the bench command, the data and a generated-on stamp. "
                    "Example: graphnav results --from out/bench/results.json --out docs/results.md",
        formatter_class=HelpFormatter)
    p.add_argument("--from", dest="source", required=True, metavar="RESULTS",
                   help="the results.json of a graphnav bench run, or its --out folder")
    p.add_argument("--out", default="docs/results.md", metavar="FILE",
                   help="the page to write; a page made by this command is replaced, any other file only "
                        "with --force")
    p.add_argument("--force", action="store_true", help="replace --out even if this command did not make it")
    p.set_defaults(func=run)


def check_page_out(path: Path, force: bool) -> Path:
    """``--out`` may be replaced when this command made it (its first line is the generated mark) or with
    ``force``; anything else is refused before any work, naming the file."""
    from graphnav.commands.common import check_out_file
    from graphnav.core.errors import ConfigError
    from graphnav.evaluation.results_page import GENERATED_MARK
    if path.is_file() and not force:
        try:
            with path.open(encoding="utf-8", errors="replace") as f:
                first = f.readline().rstrip("\n")
        except OSError as exc:
            raise ConfigError(f"--out {path}: cannot be read ({exc.strerror or exc})") from None
        if first != GENERATED_MARK:
            raise ConfigError(f"--out {path}: exists and was not made by `graphnav results`; it is kept. Give "
                              "another --out, or --force to replace it")
        force = True
    return check_out_file(path, force=force)


def run(args) -> int:
    from graphnav.evaluation.results_page import load_run_record, read_bench_records, results_page
    out = check_page_out(Path(args.out), args.force)
    records, source = read_bench_records(args.source)
    command = "graphnav results " + " ".join(shlex.quote(a) for a in (
        "--from", str(args.source), "--out", str(args.out)))
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    page = results_page(records, str(source), stamp, load_run_record(source), command)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")      # a reader never sees half a page
    tmp.write_text(page, encoding="utf-8")
    os.replace(tmp, out)
    print(f"results: {len(records)} records from {source} -> {out}", file=sys.stderr)
    return 0
