"""`graphnav bench --scheduler local`: the same records as the process pool's --jobs 1, the same results.json
and resume."""
from __future__ import annotations

import json

import pytest

from graphnav.evaluation.bench import TrajectorySource, make_cases, run_bench

VOLATILE = ("runtime_s", "warnings")


def _comparable(records):
    return sorted(({k: v for k, v in r.items() if k not in VOLATILE} for r in records),
                  key=lambda r: (r["method"], r["window_start_s"]))


def test_local_cluster_matches_jobs_1_and_resumes(tmp_path):
    pytest.importorskip("dask.distributed", reason="graphnav[dask] not installed (scripts/setup_env.sh installs it)")
    cases = make_cases([TrajectorySource("sim-seed0", None, 0, 100.0)], ["2-missing"], ["as-recorded"],
                       ["TC", "Graph-TC"], 30.0)
    serial = run_bench(cases, tmp_path / "serial", jobs=1, progress=False)
    dask = run_bench(cases, tmp_path / "dask", jobs=1, progress=False, scheduler="local")
    assert not any(r.get("error") for r in serial + dask)
    assert _comparable(dask) == _comparable(serial)
    on_disk = json.loads((tmp_path / "dask" / "results.json").read_text())
    assert _comparable(on_disk) == _comparable(serial)
    # Resume: the finished cases are kept and nothing runs again (no cluster is even needed).
    resumed = run_bench(cases, tmp_path / "dask", jobs=1, progress=False, scheduler="tcp://127.0.0.1:1", resume=True)
    assert resumed == on_disk
