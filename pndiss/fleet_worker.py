"""Set-up of a worker process of the local cluster `pndiss fleet` starts (a Dask preload module: its
``dask_setup`` runs as the worker starts, while the client is still hashing the inputs).

Two things, both measured on `bench/fleet.py` (bench/NOTES.md, "Fleet start-up"):

- **Imports.** A worker's first capture paid ~0.1 s for pyarrow and Parquet; done here they overlap
  the hashing instead of delaying the first task. (pandas is never imported: pndiss/dataset/arrays.py.)
- **One core per worker.** With as many workers as cores, the OS moved workers between cores and
  each capture took ~12 % longer than alone; pinned, ~3 %. Only when the cluster has exactly a worker
  per core this process may use (the default ``--workers``): with fewer, the OS keeps the freedom to
  move them away from other busy processes; with more, it has to share the cores anyway.

And Arrow's memory pool: the system allocator (``arrow_pool_env``).
"""
from __future__ import annotations

import os

PIN_ENV = "PNDISS_FLEET_PIN"   # "N": the cluster has N workers, worker i may take the i-th allowed core
POOL_ENV = "ARROW_DEFAULT_MEMORY_POOL"   # read by Arrow's C++ (arrow_pool_env)


def dask_setup(worker) -> None:
    pin(worker.name, os.environ.get(PIN_ENV))
    try:
        warm()
    except Exception:  # noqa: BLE001 -- a worker that cannot import starts anyway: its tasks record why
        pass


def pin(name, workers: str | None) -> set[int] | None:
    """Pin this process to one core when the cluster has exactly one worker per core; the cores
    pinned to, or None when left to the OS."""
    if not workers or not hasattr(os, "sched_setaffinity"):
        return None
    try:
        cores = sorted(os.sched_getaffinity(0))
        index = int(name)
    except (OSError, TypeError, ValueError):   # a named worker (not a LocalCluster's 0..N-1): leave it
        return None
    if int(workers) != len(cores):
        return None
    core = {cores[index % len(cores)]}
    try:
        os.sched_setaffinity(0, core)
    except OSError:
        return None
    return core


def warm() -> None:
    """Import what analysing a capture into the dataset needs."""
    import pyarrow.parquet  # noqa: F401

    from . import driver, fleet_store  # noqa: F401
    from .dataset import write_capture  # noqa: F401



def arrow_pool_env() -> dict:
    """Arrow allocates from the system allocator in processes that write datasets, unless the user
    chose a pool. mimalloc, pyarrow's default here, kept ~30 MB more resident for the same work at
    the same speed (bench/NOTES.md, "pandas without pandas"). Arrow's C++ fixes its pool on the
    first allocation (pyarrow's import makes one), so this is an environment variable set before
    that: for a worker process, its environment; for this process, ``arrow_pool``."""
    return {POOL_ENV: os.environ.get(POOL_ENV) or "system"}


def arrow_pool() -> None:
    """The system allocator for this process's Arrow, when pyarrow is not imported yet."""
    os.environ.update(arrow_pool_env())
