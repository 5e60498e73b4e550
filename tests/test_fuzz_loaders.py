"""Input fuzzing: random malformed CSVs into ``read_csv`` and ``load_akit``; only graphnav's own error types
(:class:`graphnav.core.errors.GraphnavError`) may escape, and whatever is returned must be clean.

Hypothesis runs derandomized (the same examples every run) with bounded example counts:
``READ_CSV_EXAMPLES`` + ``LOAD_AKIT_EXAMPLES`` files per run. Each example starts from a valid file and
applies 1-4 random mutations (truncated/extra fields, junk or non-finite values, empty fields, duplicated,
swapped or blank lines, header fields dropped/renamed/reordered, CRLF, a BOM, bytes that are not UTF-8,
an empty file).
"""
from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from graphnav.core.errors import GraphnavError
from graphnav.io.loaders import AKIT_COLUMNS, read_csv
from graphnav.missions import load_akit

READ_CSV_EXAMPLES = 1000
LOAD_AKIT_EXAMPLES = 200

JUNK = st.one_of(st.sampled_from(["", " ", "nan", "NaN", "inf", "-inf", "1e999", "--1", "0x10", "1,5", "\"2\"",
                                  "-32768", "-32.768", "1e-400", "٣", "1_000", "true", "\t"]),
                 st.text(max_size=6))


@st.composite
def mutations(draw):
    kind = draw(st.sampled_from(["truncate", "extra", "junk", "dup", "swap", "blank", "drop_header",
                                 "rename_header", "reorder_header", "crlf", "bom", "bytes", "empty",
                                 "reverse_time", "only_header"]))
    return kind, draw(st.integers(0, 10_000)), draw(JUNK), draw(st.binary(min_size=1, max_size=8))


def valid_lines(columns, n, rng) -> list[str]:
    t = np.cumsum(rng.uniform(0.005, 1.0, n))
    data = np.column_stack([t, rng.normal(0, 1, (n, len(columns) - 1))])
    return [",".join(columns)] + [",".join(f"{x:.9g}" for x in row) for row in data]


def mutate(lines: list[str], ops) -> bytes:
    lines = list(lines)
    tail = b""
    prefix = b""
    newline = "\n"
    for kind, pos, junk, raw in ops:
        body = max(len(lines) - 1, 1)
        i = 1 + pos % body if len(lines) > 1 else 0
        if kind == "truncate" and len(lines) > 1:
            fields = lines[i].split(",")
            lines[i] = ",".join(fields[:pos % len(fields)])
        elif kind == "extra":
            lines[i] = lines[i] + "," + junk
        elif kind == "junk" and len(lines) > 1:
            fields = lines[i].split(",")
            fields[pos % len(fields)] = junk
            lines[i] = ",".join(fields)
        elif kind == "dup":
            lines.insert(i, lines[i])
        elif kind == "swap" and len(lines) > 2:
            j = 1 + (i % (len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif kind == "blank":
            lines.insert(i, " " if pos % 2 else "")
        elif kind == "drop_header":
            header = lines[0].split(",")
            del header[pos % len(header)]
            lines[0] = ",".join(header)
        elif kind == "rename_header":
            header = lines[0].split(",")
            header[pos % len(header)] = junk
            lines[0] = ",".join(header)
        elif kind == "reorder_header":
            header = lines[0].split(",")
            lines[0] = ",".join(header[1:] + header[:1])
        elif kind == "crlf":
            newline = "\r\n"
        elif kind == "bom":
            prefix = b"\xef\xbb\xbf"
        elif kind == "bytes":
            tail = raw
        elif kind == "empty":
            return b""
        elif kind == "reverse_time":
            lines = lines[:1] + lines[1:][::-1]
        elif kind == "only_header":
            lines = lines[:1]
    return prefix + newline.join(lines).encode() + tail


def check_read_csv(path: Path, columns, nan_ok=()):
    try:
        data = read_csv(path, columns, nan_ok=nan_ok, repair=False)
    except GraphnavError:
        return None
    # whatever is returned is clean
    assert data.ndim == 2 and data.shape[1] == len(columns) and len(data) >= 1
    fixed = [j for j, c in enumerate(columns) if c not in nan_ok]
    assert np.all(np.isfinite(data[:, fixed])) and not np.any(np.isinf(data))
    assert np.all(np.diff(data[:, 0]) > 0)
    return data


@settings(max_examples=READ_CSV_EXAMPLES, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(kind=st.sampled_from(["IMU", "DVL"]), n=st.integers(1, 25), seed=st.integers(0, 2**16),
       ops=st.lists(mutations(), min_size=1, max_size=4), repair=st.booleans())
def test_read_csv_raises_only_graphnav_errors(kind, n, seed, ops, repair):
    columns = AKIT_COLUMNS[kind]
    nan_ok = columns[1:] if kind == "DVL" else ()
    text = mutate(valid_lines(columns, n, np.random.default_rng(seed)), ops)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{kind}_x.csv"
        path.write_bytes(text)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            check_read_csv(path, columns, nan_ok)
            try:
                read_csv(path, columns, nan_ok=nan_ok, repair=repair)
            except GraphnavError:
                pass


@pytest.fixture(scope="module")
def akit_folder(tmp_path_factory):
    """A valid A-KIT folder (simulated 30 s mission) whose files the fuzzer damages one at a time."""
    from graphnav.io.export import write_akit
    from graphnav.sim.simulate import simulate_mission
    root = tmp_path_factory.mktemp("akit")
    paths = write_akit(simulate_mission(30.0, seed=3), root)
    return {k: paths[k].read_text().splitlines() for k in ("IMU", "DVL", "GT")}


@settings(max_examples=LOAD_AKIT_EXAMPLES, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["IMU", "DVL", "GT"]), ops=st.lists(mutations(), min_size=1, max_size=3),
       auto=st.booleans(), repair=st.booleans())
def test_load_akit_raises_only_graphnav_errors(akit_folder, kind, ops, auto, repair):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "Trajectory1"
        folder.mkdir()
        for k, lines in akit_folder.items():
            text = mutate(lines, ops) if k == kind else ("\n".join(lines) + "\n").encode()
            (folder / f"{k}_trajectory1.csv").write_bytes(text)
        offset = "auto" if auto else 0.0
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                mission = load_akit(folder, imu_axis_signs=(1, 1, 1), dvl_time_offset_s=offset,
                                    gt_time_offset_s=offset, repair=repair)
            except GraphnavError:
                return
        mission.validate()      # a returned mission is a valid one
