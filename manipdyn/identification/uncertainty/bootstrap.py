"""Block bootstrap of an identification: refits on data resampled in blocks of time.

Layer 5 (identification).

The covariance ``(R^T R)^-1`` of :mod:`.uncertainty` assumes white noise.  Real
logs are not white: q is low-pass filtered before it is differentiated, the
torque loop and the model's misfit leave residuals that are correlated over
tens of samples.  The *moving-block bootstrap* (Kuensch 1989) keeps that
correlation: replicate ``k`` draws ``ceil(N / L)`` block starts uniformly in
``[0, N - L]``, concatenates the blocks of ``L`` consecutive samples (q, qd,
qdd and tau together) and keeps the first N samples, then refits with the same
method and options.  The spread of the replicates' base parameters estimates
the estimator's covariance, correlation included::

    from manipdyn.identification import read_log
    from manipdyn.identification.uncertainty.bootstrap import bootstrap

    data = read_log("log.csv", arm.n)
    boot = bootstrap(arm, data, 200, block=50, seed=0, method="wls", friction=True)
    boot.covariance                                   # (r, r)
    # boot = bootstrap(..., scheduler="tcp://10.0.0.5:8786")   # on a Dask cluster

Block length: ``block`` samples; the default ``round(sqrt(N))`` (at least 1).
Blocks must be longer than the residuals' correlation (at 200 Hz with the
5 Hz zero-phase filter of :mod:`.data`, ~40 samples) and short enough to
leave many blocks to resample; sqrt(N) is both for logs of a few thousand
samples.  Choose it yourself for other logs.

Seeding and where it runs: replicate ``k`` resamples with
``numpy.random.default_rng(SeedSequence(seed, spawn_key=(k,)))`` only, and
every fit runs with one BLAS thread (:mod:`manipdyn._support.threads`), so the
replicates are bit-identical wherever they run: in this process (the default,
``scheduler=None``), on a local Dask cluster (``"local"``), or on a Dask
scheduler ``"tcp://HOST:PORT"`` (chunks of replicates through
:func:`manipdyn.check.scale.map_chunks`, the engine of the Monte-Carlo studies).

A replicate whose refit fails (its resampled data excite too little: the
condition number is over the method's threshold) is a row of NaN in
``beta`` and counted in ``failed``; the covariance is over the others.
"""

from __future__ import annotations

import math
import os
import socket
import time
from dataclasses import dataclass

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError

__all__ = ["bootstrap", "BootstrapResult", "block_indices", "bootstrap_summary", "format_bootstrap"]


@dataclass(frozen=True)
class BootstrapResult:
    """Result of :func:`bootstrap`.

    Attributes
    ----------
    beta : (n_replicates, r)
        Base parameters of each replicate (NaN rows: failed refits).
    covariance : (r, r)
        Sample covariance of the successful replicates' base parameters (ddof 1).
    std : (r,)
        Its diagonal's square root.
    base : BaseParameters
        The base parameters (names, expressions) of the fits.
    failed : list of int
        Replicates whose refit raised (their error messages in ``errors``).
    block, seed : int
    method : str
    errors : dict
        ``{replicate: message}`` of the failed ones.
    timing : dict
        Wall time and where it ran (:func:`manipdyn.check.scale.map_chunks`).
    """

    beta: np.ndarray
    covariance: np.ndarray
    std: np.ndarray
    base: object
    failed: list
    block: int
    seed: int
    method: str
    errors: dict
    timing: dict


def block_indices(n_samples: int, block: int, seed: int, replicate: int) -> np.ndarray:
    """Sample indices (n_samples,) of replicate ``replicate``: moving blocks of ``block``
    consecutive samples with uniform starts, from ``SeedSequence(seed, spawn_key=(replicate,))``."""
    rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(replicate),)))
    count = math.ceil(n_samples / block)
    starts = rng.integers(0, n_samples - block + 1, size=count)
    return (starts[:, None] + np.arange(block)[None, :]).reshape(-1)[:n_samples]


def _int(value, name: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ModelError(f"{name}: expected an integer >= {low}, got {value!r}")
    return int(value)


def _arrays(data, n: int):
    """``(q, qd, qdd, tau)`` (N, n) each from a Measurements-like object or a 4-tuple."""
    if isinstance(data, (tuple, list)) and len(data) == 4:
        arrays = data
    else:
        try:
            arrays = (data.q, data.qd, data.qdd, data.tau)
        except AttributeError:
            raise ModelError(f"data: expected Measurements (q, qd, qdd, tau attributes) or a tuple "
                             f"(q, qd, qdd, tau), got {type(data).__name__}") from None
    out = []
    for name, a in zip(("q", "qd", "qdd", "tau"), arrays):
        a = np.asarray(a, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != n:
            raise ModelError(f"data.{name}: expected shape (N, {n}), got {a.shape}")
        out.append(a)
    if len({a.shape[0] for a in out}) != 1:
        raise ModelError(f"data: q, qd, qdd, tau have different numbers of samples {[a.shape[0] for a in out]}")
    return tuple(out)


def _replicates(spec: tuple, part) -> dict:
    """Refit replicates ``part``: ``{k: (beta or None, error or None), "timing": {...}}``.

    A pure function of its arguments (runs on any worker, bit-identical)."""
    from ..._support.threads import blas_threads
    from ...check.scale import arm_from_text
    from ..estimation.fitting import fit

    model, arrays, block, seed, method, base, fit_kwargs = spec
    t0 = time.perf_counter()
    arm = arm_from_text(*model)
    out = {}
    with blas_threads(1):
        for k in part:
            idx = block_indices(len(arrays[0]), block, seed, k)
            q, qd, qdd, tau = (a[idx] for a in arrays)
            try:
                r = fit(arm, q, qd, qdd, tau, method=method, base=base, complete=False, **fit_kwargs)
                out[int(k)] = (np.asarray(r.beta), None)
            except ModelError as exc:
                out[int(k)] = (None, str(exc))
    out["timing"] = {"seconds": time.perf_counter() - t0, "host": socket.gethostname(), "pid": os.getpid()}
    return out


def bootstrap(arm, data, n: int, block: int | None = None, seed: int = 0, scheduler=None,
              method: str = "wls", workers: int | None = None, chunk_size: int | None = None,
              progress=None, **fit_kwargs) -> BootstrapResult:
    """Refit ``arm`` on ``n`` block-resampled copies of ``data`` (module docstring).

    Parameters
    ----------
    arm : manipdyn.Arm
        The prior, as :func:`manipdyn.identification.fit` takes it (travels to Dask
        workers as its model text).
    data : Measurements or (q, qd, qdd, tau)
        The identification data, (N, n) arrays in SI units, in time order.
    n : int
        Number of replicates (>= 2).
    block : int, optional
        Block length in samples (default ``round(sqrt(N))``), at most N.
    seed : int
        Replicate k uses ``SeedSequence(seed, spawn_key=(k,))``.
    scheduler : None, "sync", "local" or "tcp://HOST:PORT"
        None or "sync": in this process; "local": a Dask LocalCluster of ``workers``
        processes; an address: that Dask scheduler.
    method : "ols" | "wls" | "consistent"
    workers, chunk_size, progress
        As :func:`manipdyn.control.montecarlo.run` takes them.
    **fit_kwargs
        Passed to every :func:`~manipdyn.identification.fit` (``friction``,
        ``armature``, ``bounds``, ``prior_weight``).
    """
    from ...check.scale import chunks, check_scheduler, local_cores, map_chunks, model_text
    from ..estimation.base import base_parameters
    from ..estimation.fitting import METHODS

    n = _int(n, "n", 2)
    limits.check_count(n, "bootstrap", "n (the replicates, each a whole refit)", "MAX_BOOTSTRAP")
    seed = _int(seed, "seed", 0)
    if method not in METHODS:
        raise ModelError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    for key in ("base", "name", "metadata"):
        if key in fit_kwargs:
            raise ModelError(f"{key}: not a bootstrap option (every replicate uses the same base parameters)")
    check_scheduler(scheduler)
    arrays = _arrays(data, arm.n)
    N = len(arrays[0])
    block = max(1, round(math.sqrt(N))) if block is None else _int(block, "block", 1)
    if block > N:
        raise ModelError(f"block: expected at most the {N} samples of the data, got {block}")
    base = base_parameters(arm, armature=fit_kwargs.get("armature", False),
                           friction=fit_kwargs.get("friction", False))
    spec = (model_text(arm), arrays, block, seed, method, base, dict(fit_kwargs))
    where = "sync" if scheduler is None else scheduler
    nworkers = 1 if where == "sync" else (local_cores() if workers is None else workers)
    parts = chunks(n, nworkers, chunk_size)
    col, timing = map_chunks(_replicates, (spec,), n, parts, where, workers, progress)
    rows = col.ordered()
    beta = np.full((n, base.count), np.nan)
    errors = {}
    for k, (b, err) in enumerate(rows):
        if b is None:
            errors[k] = err
        else:
            beta[k] = b
    ok = beta[np.all(np.isfinite(beta), axis=1)]
    if len(ok) < 2:
        raise ModelError(f"bootstrap: {len(errors)} of {n} refits failed, fewer than 2 remain "
                         f"(first error: {next(iter(errors.values()), '')})")
    cov = np.cov(ok, rowvar=False, ddof=1).reshape(base.count, base.count)
    return BootstrapResult(beta=beta, covariance=cov, std=np.sqrt(np.diag(cov)), base=base,
                           failed=sorted(errors), block=block, seed=seed, method=method, errors=errors,
                           timing=timing)


def bootstrap_summary(result: BootstrapResult) -> dict:
    """The JSON-ready summary ``identify`` reports and a base model carries (``--base-json``):
    ``{"replicates", "block", "seed", "failed", "std", "covariance"}`` (``std`` (r,) and
    ``covariance`` (r, r) as lists, None for a non-finite entry's row)."""
    def num(x):
        return float(x) if np.isfinite(x) else None

    cov = None
    if np.all(np.isfinite(result.covariance)):
        cov = [[float(x) for x in row] for row in result.covariance]
    return {"replicates": int(len(result.beta)), "block": int(result.block), "seed": int(result.seed),
            "failed": [int(k) for k in result.failed], "std": [num(x) for x in result.std],
            "covariance": cov}


def format_bootstrap(summary: dict, base_parameters: list) -> str:
    """The text ``identify --bootstrap N`` prints: one line per base parameter, its value, the
    bootstrap's standard deviation and the fit's (``base_parameters``: the report's rows)."""
    lines = [f"bootstrap: {summary['replicates']} replicates in blocks of {summary['block']} samples, "
             f"{len(summary['failed'])} failed; standard deviation of each base parameter, block "
             f"bootstrap (the fit's, which assumes white noise):"]
    for row, s in zip(base_parameters, summary["std"]):
        fit = row.get("std")
        boot = "-" if s is None else f"{s:.3g}"
        lines.append(f"  {row['value']:+.6g} +- {boot}" + (f" ({fit:.3g})" if fit is not None else "")
                     + f" = {row['expression']}")
    return "\n".join(lines)
