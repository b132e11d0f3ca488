"""Running chunks of a study: in this process, on a local Dask cluster, or on a remote one.

Layer 6 (control: montecarlo).

* ``scheduler=None`` (default): a Dask ``LocalCluster`` of worker processes on
  this machine, one per core (``workers=`` to choose), one thread each; no
  server to start, and it is shut down at the end.
* ``scheduler="tcp://HOST:PORT"``: an existing Dask cluster (``dask scheduler``
  and ``dask worker tcp://HOST:PORT`` on as many machines as you like).
* ``scheduler="sync"``: in this process, one chunk after another (no Dask).

Whatever the choice, the same chunks run the same pure function
(:func:`manipdyn.control.montecarlo.study.run_chunk`), and the results are put back
in run order, so the report is bit-identical.  Chunks are submitted with
``retries``: a chunk whose worker dies is computed again on another one (Dask
reschedules the tasks of a lost worker).  Each run is stored once, by its
index; a run missing or seen twice at the end is an error, never a silent
gap or double count.
"""

from __future__ import annotations

from ...check.scale import MissingExtraError, chunks, local_cores, map_chunks
from .report import StudyReport
from .study import Study, run_chunk

__all__ = ["run", "MissingExtraError"]


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
        raise TypeError(f"study: expected a manipdyn.control.montecarlo.Study, got {type(study).__name__}")
    local_workers = local_cores() if workers is None else workers
    parts = chunks(study.runs, 1 if scheduler == "sync" else local_workers, chunk_size)
    col, timing = map_chunks(run_chunk, (study,), study.runs, parts, scheduler, workers, progress, retries)
    per_run = [rec for recs in col.ordered() for rec in recs]
    timing["ms_per_simulation"] = 1e3 * timing["wall_s"] / max(1, len(per_run))
    return StudyReport(study, per_run, timing)
