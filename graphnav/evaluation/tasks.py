"""Run independent tasks in this process, a process pool or on a Dask cluster (``--jobs``, ``--scheduler``).

One runner for every command that fans out over cases or missions (``graphnav bench``, the batch
``graphnav smooth`` over a folder of missions): :func:`run_tasks` calls ``fn(item)`` for every item and hands
each result to ``finished`` in the calling process as it arrives, so the caller keeps one results file up to
date (and can resume from it) whichever way the tasks ran. ``fn`` and the items must pickle (a module-level
function and plain data): they travel to spawned processes or to remote Dask workers.
"""
from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any, Callable, Sequence

from graphnav.core.errors import ConfigError

#: Thread-pool variables pinned to 1 in the workers: one process per core, no oversubscription.
THREAD_VARS: tuple[str, ...] = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def init_worker() -> None:
    """Keep torch from starting its own thread pool in each worker process."""
    try:
        import torch
        torch.set_num_threads(1)
    except ImportError:
        pass


def _run_pool(fn: Callable, items: Sequence, finished: Callable, jobs: int) -> None:
    """``fn`` over ``items`` in ``jobs`` spawned worker processes, results to ``finished`` as they come."""
    import multiprocessing
    ctx = multiprocessing.get_context("spawn")  # fork after torch/gtsam threads can deadlock
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=init_worker) as pool:
        futures = [pool.submit(fn, item) for item in items]
        try:
            for fut in as_completed(futures):
                finished(fut.result())
        except KeyboardInterrupt:
            for fut in futures:
                fut.cancel()
            raise


def _run_dask(fn: Callable, items: Sequence, finished: Callable, scheduler: str, jobs: int) -> None:
    """``fn`` over ``items`` on a Dask cluster: ``scheduler`` is a scheduler address (``tcp://host:8786``) or
    ``"local"`` for a :class:`dask.distributed.LocalCluster` of ``jobs`` single-threaded worker processes.
    Remote workers need graphnav installed (and the data paths readable) on their side."""
    try:
        from dask.distributed import Client, LocalCluster
        from dask.distributed import as_completed as dask_completed
    except ImportError:
        raise ConfigError("--scheduler needs dask.distributed: pip install 'graphnav[dask]'") from None
    cluster = None
    if scheduler == "local":
        # Worker processes inherit the environment: one BLAS/OpenMP thread each (run_tasks sets it).
        cluster = LocalCluster(n_workers=max(1, jobs), threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout="30s")
        except OSError as exc:
            raise ConfigError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
    try:
        client.run(init_worker)
        futures = client.map(fn, list(items), pure=False)
        try:
            for fut in dask_completed(futures):
                finished(fut.result())
        except KeyboardInterrupt:
            client.cancel(futures)
            raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_tasks(fn: Callable[[Any], Any], items: Sequence, finished: Callable[[Any], None], jobs: int = 1,
              scheduler: str | None = None) -> None:
    """Call ``fn(item)`` for every item and ``finished(result)`` (in this process) as each one completes.

    ``jobs <= 1`` without ``scheduler``: in this process, in order. ``jobs > 1``: a pool of ``jobs`` spawned
    processes. ``scheduler``: on the Dask cluster at that address, or a local one of ``jobs`` workers
    (``"local"``). Completion order is not item order when tasks run in parallel. Nothing to do (e.g.
    everything resumed) starts no workers. ``fn`` should return its failures as results rather than raise:
    an exception from ``fn`` ends the run.
    """
    if not items:
        return
    if jobs <= 1 and scheduler is None:
        for item in items:
            finished(fn(item))
        return
    # Workers inherit the environment at start: one BLAS/OpenMP thread each, no oversubscription.
    saved = {k: os.environ.get(k) for k in THREAD_VARS}
    os.environ.update({k: "1" for k in saved})
    try:
        if scheduler is not None:
            _run_dask(fn, items, finished, scheduler, jobs)
        else:
            _run_pool(fn, items, finished, jobs)
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
