"""The Dask engine shared by Monte-Carlo studies and big cross-checks.

Layer 4 (checks).

Work is cut into *parts* (index ranges); :func:`map_chunks` runs a pure
function on every part, in this process (``scheduler="sync"``), on a Dask
``LocalCluster`` of this machine's cores (``scheduler=None``), or on an
existing Dask cluster (``scheduler="tcp://HOST:PORT"``), and collects the
results by index, each exactly once.  A part lost with its worker is run
again (Dask reschedules the tasks of a lost worker; ``retries`` covers
failures).  Arms travel to workers as text (:func:`model_text`) and are
rebuilt once per worker process (:func:`arm_from_text`).

``dask[distributed]`` is the ``scale`` extra: ``pip install 'manipdyn[scale]'``.
"""

from __future__ import annotations

import functools
import logging
import math
import os
import re
import time
import warnings

from .._support.errors import MissingExtraError, ModelError

__all__ = ["MissingExtraError", "require_distributed", "check_scheduler", "WORKER_WAIT_S", "local_cores", "chunks", "map_chunks",
           "model_text", "arm_from_text", "MAX_CHUNK"]

#: the most items (runs) in one part by default (a part is the unit of work lost with a worker)
MAX_CHUNK = 25
#: seconds to wait for a first worker at a scheduler that has none, before giving up
WORKER_WAIT_S = 60.0
#: address schemes of dask.distributed's communications
_SCHEMES = ("tcp",)


def check_scheduler(scheduler, option: str = "scheduler") -> None:
    """Refuse a scheduler that is not None, ``"sync"``, ``"local"`` or a Dask address
    ``tcp://HOST:PORT``, in one line.  Dask's other schemes are refused by name: ``tls``
    and ``wss`` need a security configuration manipdyn does not take, ``ucx`` an extra
    library, ``inproc`` a scheduler inside this process, ``ws`` is unused in practice."""
    if scheduler is None or scheduler in ("sync", "local"):
        return
    expected = ("expected 'sync', 'local' or a Dask scheduler address such as tcp://HOST:8786")
    if not isinstance(scheduler, str):
        raise ModelError(f"{option}: {expected}, got {type(scheduler).__name__}")
    scheme, sep, rest = scheduler.partition("://")
    if not sep or scheme not in _SCHEMES or not rest:
        raise ModelError(f"{option}: {expected} (schemes: {', '.join(_SCHEMES)}), got {scheduler!r:.200}")
    host, colon, port = rest.rstrip("/").rpartition(":")
    if not colon or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ModelError(f"{option}: {scheduler!r:.200} has no port; {expected}")
    if not re.fullmatch(r"[A-Za-z0-9.-]{1,253}|\[[0-9A-Fa-f:.]{2,45}\]", host):
        raise ModelError(f"{option}: {scheduler!r:.200}: {host!r:.100} is not a host name or an IP address; "
                         f"{expected}")


def require_distributed():
    """``distributed`` (dask.distributed), or :class:`MissingExtraError` with the install command."""
    try:
        import distributed
    except ImportError:
        need = ("Monte-Carlo studies and cluster cross-checks on Dask need dask.distributed: "
                "pip install 'manipdyn[scale]' (in a source checkout: pip install -e '.[scale]')")
        raise MissingExtraError(need + "  (or pass scheduler='sync' to run in this process)",
                                cli_message=need + "  (or pass --scheduler sync to run in this process)") from None
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
        check_scheduler(scheduler)
        _not_while_bootstrapping()
        distributed = require_distributed()
        cluster = client = held = None
        # Dask's own logger speaks on this process's stderr: its INFO lines (a comm closed by a Ctrl-C,
        # with a traceback) would bury the one line a study stops with; its warnings and errors stay
        dask_log = logging.getLogger("distributed")
        dask_level = dask_log.level
        dask_log.setLevel(max(dask_level, logging.WARNING))
        try:
            if scheduler is None or scheduler == "local":
                nworkers = local_cores() if workers is None else int(workers)
                if nworkers < 1:
                    raise ValueError(f"workers: expected a positive integer, got {workers!r}")
                # Ctrl-C while the workers start waits until the cluster exists (and can be
                # closed); the workers, started with SIGINT blocked, never see it: this
                # process alone stops the study, in one line
                held = _hold_sigint()
                cluster = _local_cluster(distributed, nworkers)
                where = "local Dask cluster"
            else:
                where = str(scheduler)
                _probe_scheduler(scheduler)
            try:
                client = distributed.Client(cluster if cluster is not None else scheduler, timeout="10s")
            except OSError as exc:
                raise ConnectionError(f"scheduler {scheduler}: cannot connect: {exc}") from None
            held = _release_sigint(held)      # a Ctrl-C pressed meanwhile is raised here
            if cluster is None:
                _wait_for_workers(client, scheduler)
                nworkers = len(client.scheduler_info().get("workers", {}))
            futures = [client.submit(fn, *args, part, pure=False, retries=retries) for part in parts]
            for fut in distributed.as_completed(futures):
                col.add(fut.result())
        finally:
            held = held if held is not None else _hold_sigint()   # no Ctrl-C half-way through closing
            dask_log.setLevel(logging.CRITICAL)   # closing: what it says of comms it closes is noise
            try:
                if client is not None:
                    client.close()
                if cluster is not None:
                    cluster.close()
            finally:
                dask_log.setLevel(dask_level)
                _release_sigint(held)
    wall = time.perf_counter() - t0
    hosts: dict = {}
    for t in col.chunk_timing:
        hosts[f"{t['host']}:{t['pid']}"] = hosts.get(f"{t['host']}:{t['pid']}", 0) + 1
    timing = {"wall_s": wall, "scheduler": where, "workers": nworkers, "chunks": len(parts),
              "chunk_seconds": sum(t["seconds"] for t in col.chunk_timing), "chunks_by_process": hosts}
    return col, timing


def _not_while_bootstrapping() -> None:
    """In a worker process that is importing an unguarded script (Python's spawn runs the
    script again), stop that import quietly: the parent reports the problem in one line."""
    import multiprocessing
    import sys

    if getattr(multiprocessing.current_process(), "_inheriting", False):
        sys.stderr = open(os.devnull, "w")       # the worker's own report would repeat it
        raise SystemExit(1)


def _hold_sigint():
    """Block SIGINT in this thread (threads and processes started meanwhile inherit the
    block); return the mask to restore, or None where that cannot be done."""
    import signal
    import threading

    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        return None
    return signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


def _release_sigint(mask) -> None:
    """Restore the mask of :func:`_hold_sigint` (a pending Ctrl-C is then raised); returns None."""
    import signal

    if mask is not None:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    return None


def _local_cluster(distributed, nworkers: int):
    """A LocalCluster of ``nworkers`` one-thread processes, or a one-line error when they
    cannot start (typically a script that runs a study without an ``if __name__ ==
    "__main__":`` guard: each worker imports the script again and starts its own study)."""
    import sys
    import tempfile

    # the workers' stderr (file descriptor 2, inherited when they start) goes to an unnamed
    # temporary file: a Ctrl-C reaches the whole process group, and each worker's traceback
    # would bury this process's one line; their errors reach the study through its futures
    log = tempfile.TemporaryFile(prefix="manipdyn-dask-workers-")
    sys.stderr.flush()
    saved = os.dup(2)
    os.dup2(log.fileno(), 2)
    try:
        return distributed.LocalCluster(n_workers=nworkers, threads_per_worker=1, processes=True,
                                        dashboard_address=":0", silence_logs=logging.CRITICAL)
    except RuntimeError as exc:
        import multiprocessing

        if getattr(multiprocessing.current_process(), "_inheriting", False) or \
                multiprocessing.parent_process() is not None:
            raise     # a worker importing an unguarded script: let the parent say it
        raise ModelError(
            f"the local Dask workers could not start ({exc}); in a script, run the study under "
            "'if __name__ == \"__main__\":' (each worker process imports the script again), or pass "
            "scheduler='sync'") from None
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        log.close()                  # unnamed: nothing is left behind, whatever happens


def _probe_scheduler(scheduler: str) -> None:
    """Ask ``scheduler`` for its identity within :data:`manipdyn.limits.MAX_SCHEDULER_WAIT_S`, or raise
    ConnectionError: a port that listens but is not a Dask scheduler's (a web server) never
    answers, and ``distributed.Client`` would wait for it forever."""
    import asyncio

    from distributed.comm import connect

    from .._support import limits

    wait = float(limits.MAX_SCHEDULER_WAIT_S)
    _sniff_handshake(scheduler, wait)

    async def ask():
        comm = await connect(scheduler, timeout=wait)
        try:
            await comm.write({"op": "identity", "reply": True})
            reply = await comm.read()
        finally:
            comm.abort()
        if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
            raise OSError(f"it answered {str(reply)[:80]!r}, not as a Dask scheduler")

    try:
        asyncio.run(asyncio.wait_for(ask(), wait))
    except (asyncio.TimeoutError, TimeoutError):
        raise ConnectionError(f"scheduler {scheduler}: no Dask scheduler answered in {wait:g} s (is it the "
                              "port of a Dask scheduler? manipdyn.limits.MAX_SCHEDULER_WAIT_S sets the wait)") from None
    except (OSError, ValueError, TypeError, EOFError, MemoryError, OverflowError) as exc:
        raise ConnectionError(f"scheduler {scheduler}: cannot connect: {exc}") from None


def _sniff_handshake(scheduler: str, wait: float) -> None:
    """Read the first 8 bytes a ``tcp://`` peer sends, before Dask does: a Dask scheduler opens
    with its handshake, whose first 8 bytes are its length (native uint64, a few hundred bytes).
    Another service's bytes read as a length of exabytes, which Dask would try to allocate
    (``MemoryError``); over :data:`manipdyn.limits.MAX_PEER_MESSAGE_BYTES` is a ConnectionError."""
    import socket
    import struct
    from urllib.parse import urlsplit

    from .._support import limits

    parts = urlsplit(scheduler)
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        return                      # check_scheduler has said what a bad address is
    if parts.scheme != "tcp" or not host or port is None:
        return
    deadline = time.monotonic() + wait
    head = b""
    try:
        with socket.create_connection((host, port), timeout=wait) as sock:
            while len(head) < 8:
                sock.settimeout(max(0.01, deadline - time.monotonic()))
                chunk = sock.recv(8 - len(head))
                if not chunk:
                    raise ConnectionError(f"scheduler {scheduler}: the peer closed the connection without a "
                                          "Dask handshake (not a Dask scheduler?)")
                head += chunk
    except (socket.timeout, TimeoutError):
        raise ConnectionError(f"scheduler {scheduler}: no Dask scheduler answered in {wait:g} s (is it the "
                              "port of a Dask scheduler? manipdyn.limits.MAX_SCHEDULER_WAIT_S sets the wait)") from None
    except ConnectionError:
        raise
    except OSError as exc:
        raise ConnectionError(f"scheduler {scheduler}: cannot connect: {exc.strerror or exc}") from None
    (size,) = struct.unpack("Q", head)
    if size > limits.MAX_PEER_MESSAGE_BYTES:
        shown = head.decode("ascii", "backslashreplace")
        raise ConnectionError(f"scheduler {scheduler}: the peer's first bytes {shown!r} announce a message of "
                              f"{size:.3g} bytes, over {limits.MAX_PEER_MESSAGE_BYTES:g} "
                              "(manipdyn.limits.MAX_PEER_MESSAGE_BYTES): not a Dask scheduler (another service "
                              "on that port?)")


def _wait_for_workers(client, scheduler) -> None:
    """Wait up to :data:`WORKER_WAIT_S` for the scheduler's first worker, or say there is none
    (a scheduler with no worker would otherwise hold the tasks, silently, forever)."""
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_S)
    except TimeoutError:
        raise ConnectionError(
            f"scheduler {scheduler}: no worker joined in {WORKER_WAIT_S:g} s; start some with "
            f"'dask worker {scheduler}' (manipdyn.check.scale.WORKER_WAIT_S sets the wait)") from None


def model_text(arm) -> tuple:
    """``(kind, text, tip, name, gravity)``: the arm as text a worker can rebuild it from.

    DH arms (:class:`manipdyn.Manipulator`) travel as their model file
    (floats written exactly, so the rebuilt arm is equal); URDF arms as their
    URDF text with the tip link, name and gravity.
    """
    from ..model.arm import Manipulator

    if isinstance(arm, Manipulator):
        from ..formats.modelfile import model_to_toml

        return ("toml", model_to_toml(arm), None, arm.name, None)
    text = getattr(arm, "urdf_text", None)
    if text is None:
        raise ModelError(f"arm: cannot send {type(arm).__name__} {getattr(arm, 'name', arm)!r:.80} to workers "
                         "as text (expected a DH arm or a URDF arm: manipdyn.load(...))")
    if getattr(arm, "custom_drive", False):
        raise ModelError(f"cannot send URDF arm {arm.name!r} to workers as text: its transmission or friction "
                         "law is not in the URDF (run it here, scheduler=None)")
    return ("urdf", text, arm.tip, arm.name, tuple(float(g) for g in arm.gravity))


@functools.lru_cache(maxsize=8)
def arm_from_text(kind: str, text: str, tip, name, gravity):
    """The arm of :func:`model_text`, rebuilt once per process (cached)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # the client saw the model's warnings already
        if kind == "toml":
            from ..formats.modelfile import parse_model

            return parse_model(text, f"model text of {name!r}")
        from ..formats.urdf.reader import load_urdf

        return load_urdf(text, tip=tip, name=name, gravity=gravity)
