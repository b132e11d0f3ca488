"""Running chunks of a study: in this process, on a local Dask cluster, or on a remote one.

* ``scheduler=None`` (default): a Dask ``LocalCluster`` of worker processes on
  this machine, one per core (``workers=`` to choose), one thread each; no
  server to start, and it is shut down at the end.
* ``scheduler="tcp://HOST:PORT"``: an existing Dask cluster (``dask scheduler``
  and ``dask worker tcp://HOST:PORT`` on as many machines as you like).
* ``scheduler="sync"``: in this process, one chunk after another (no Dask).

Whatever the choice, the same chunks run the same pure function
(:func:`manipdyn.montecarlo.study.run_chunk`), and the results are put back
in run order, so the report is bit-identical.  Chunks are submitted with
``retries``: a chunk whose worker dies is computed again on another one (Dask
reschedules the tasks of a lost worker).  Each run is stored once, by its
index; a run missing or seen twice at the end is an error, never a silent
gap or double count.
"""

from __future__ import annotations

import logging
import math
import os
import time

from .report import StudyReport
from .study import Study, run_chunk

__all__ = ["run", "MissingExtraError", "chunks", "require_distributed", "local_cores"]

#: the most runs in one chunk (a chunk is the unit of work lost with a worker)
MAX_CHUNK = 25


class MissingExtraError(ImportError):
    """An optional dependency is missing; the message says what to install."""


def require_distributed():
    """``distributed`` (dask.distributed), or :class:`MissingExtraError` with the install command."""
    try:
        import distributed
    except ImportError:
        raise MissingExtraError(
            "Monte-Carlo studies and cluster cross-checks on Dask need dask.distributed: "
            "pip install 'manipdyn[scale]'  (or pass scheduler='sync' to run in this process)"
        ) from None
    return distributed


def local_cores() -> int:
    """CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover (not Linux)
        return max(1, os.cpu_count() or 1)


def chunks(total: int, workers: int, chunk_size: int | None = None) -> list[range]:
    """Consecutive index ranges covering ``range(total)``: about 4 chunks per worker, at most :data:`MAX_CHUNK`."""
    if chunk_size is None:
        chunk_size = max(1, min(MAX_CHUNK, math.ceil(total / (4 * max(1, workers)))))
    if isinstance(chunk_size, bool) or int(chunk_size) != chunk_size or chunk_size < 1:
        raise ValueError(f"chunk_size: expected a positive integer, got {chunk_size!r}")
    chunk_size = int(chunk_size)
    return [range(a, min(total, a + chunk_size)) for a in range(0, total, chunk_size)]


class _Collector:
    """Results by index, each exactly once."""

    def __init__(self, total: int, progress):
        self.total, self.progress = total, progress
        self.results: dict = {}
        self.chunk_timing: list = []

    def add(self, out: dict) -> None:
        timing = out.pop("timing", None)
        for k, v in out.items():
            if k in self.results:
                raise RuntimeError(f"run {k} was returned twice (internal error: chunks overlap)")
            self.results[k] = v
        if timing is not None:
            self.chunk_timing.append(timing)
        if self.progress is not None:
            self.progress(len(self.results), self.total)

    def ordered(self) -> list:
        missing = sorted(set(range(self.total)) - set(self.results))
        if missing:
            raise RuntimeError(f"runs {missing[:10]} never came back (internal error)")
        return [self.results[k] for k in range(self.total)]


def map_chunks(fn, args, total: int, parts: list, scheduler=None, workers=None, progress=None,
               retries: int = 3):
    """Run ``fn(*args, part)`` for every part; return (collector, timing dict).

    The engine shared by studies and cross-checks: ``fn`` returns
    ``{index: result, ..., "timing": {...}}`` for the indices of its part.
    """
    col = _Collector(total, progress)
    t0 = time.perf_counter()
    if scheduler == "sync":
        for part in parts:
            col.add(fn(*args, part))
        nworkers, where = 1, "this process"
    else:
        distributed = require_distributed()
        cluster = None
        if scheduler is None or scheduler == "local":
            nworkers = local_cores() if workers is None else int(workers)
            if nworkers < 1:
                raise ValueError(f"workers: expected a positive integer, got {workers!r}")
            cluster = distributed.LocalCluster(n_workers=nworkers, threads_per_worker=1, processes=True,
                                               dashboard_address=None, silence_logs=logging.ERROR)
            where = "local Dask cluster"
        else:
            where = str(scheduler)
        try:
            client = distributed.Client(cluster if cluster is not None else scheduler, timeout="30s")
        except OSError as exc:
            if cluster is not None:
                cluster.close()
            raise ConnectionError(f"scheduler {scheduler}: cannot connect: {exc}") from None
        try:
            if cluster is None:
                nworkers = len(client.scheduler_info().get("workers", {}))
            futures = [client.submit(fn, *args, part, pure=False, retries=retries) for part in parts]
            for fut in distributed.as_completed(futures):
                col.add(fut.result())
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    wall = time.perf_counter() - t0
    hosts: dict = {}
    for t in col.chunk_timing:
        hosts[f"{t['host']}:{t['pid']}"] = hosts.get(f"{t['host']}:{t['pid']}", 0) + 1
    timing = {"wall_s": wall, "scheduler": where, "workers": nworkers, "chunks": len(parts),
              "chunk_seconds": sum(t["seconds"] for t in col.chunk_timing), "chunks_by_process": hosts}
    return col, timing


def run(study: Study, scheduler: str | None = None, workers: int | None = None,
        chunk_size: int | None = None, progress=None, retries: int = 3) -> StudyReport:
    """Run every simulation of ``study``; return its :class:`StudyReport`.

    Parameters
    ----------
    study : Study
    scheduler : None, "sync" or "tcp://HOST:PORT"
        Where to run (module docstring); None: every core of this machine.
    workers : int, optional
        Worker processes of the local cluster (default: one per core).
    chunk_size : int, optional
        Runs per chunk (default: about 4 chunks per worker, at most 25).
    progress : callable, optional
        ``progress(runs_done, runs_total)`` as chunks complete.
    retries : int
        Times a failed chunk is tried again (a lost worker is rescheduled anyway).
    """
    if not isinstance(study, Study):
        raise TypeError(f"study: expected a manipdyn.montecarlo.Study, got {type(study).__name__}")
    local_workers = local_cores() if workers is None else workers
    parts = chunks(study.runs, 1 if scheduler == "sync" else local_workers, chunk_size)
    col, timing = map_chunks(run_chunk, (study,), study.runs, parts, scheduler, workers, progress, retries)
    per_run = [rec for recs in col.ordered() for rec in recs]
    timing["ms_per_simulation"] = 1e3 * timing["wall_s"] / max(1, len(per_run))
    return StudyReport(study, per_run, timing)
