"""A real Dask cluster on 127.0.0.1 for the tests: ``dask scheduler`` and ``dask worker`` processes.

Started with subprocess on random free ports, waited for with timeouts, and
stopped by pid (SIGTERM, then SIGKILL) in a ``finally``.  The workers run
without a nanny, so that killing one by pid loses it (no restart): the case
the Monte-Carlo retry test needs.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DASK = os.path.join(os.path.dirname(sys.executable), "dask")
#: seconds to wait for the scheduler and the workers to come up
START_TIMEOUT = 60.0


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.kill(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)


@contextlib.contextmanager
def dask_cluster(workers: int = 2):
    """Yield ``(address, [worker Popen, ...])`` of a fresh scheduler with ``workers`` workers."""
    import distributed

    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
               OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs: list[subprocess.Popen] = []
    try:
        procs.append(subprocess.Popen(
            [DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
            cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        worker_procs = []
        for _ in range(workers):
            worker_procs.append(subprocess.Popen(
                [DASK, "worker", address, "--host", "127.0.0.1", "--nthreads", "1", "--no-nanny",
                 "--no-dashboard", "--death-timeout", "60"],
                cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        procs.extend(worker_procs)
        deadline = time.monotonic() + START_TIMEOUT
        while True:
            try:
                client = distributed.Client(address, timeout="5s")
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise RuntimeError(f"dask scheduler at {address} did not start") from None
                time.sleep(0.3)
        try:
            client.wait_for_workers(workers, timeout=max(1.0, deadline - time.monotonic()))
        finally:
            client.close()
        yield address, worker_procs
    finally:
        for p in reversed(procs):
            _stop(p)
