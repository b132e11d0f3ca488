"""The cross-check: the trace-form engine against the Pinocchio engine (and any other engine named).

Layer 4 (checks): talks to the two engines only through :class:`manipdyn.engines.protocol.DynamicsEngine`.

For seeded random states within the joint limits, every quantity is computed
by both engines and compared: D, h, C (the Coriolis matrix), g, tau, the
forward dynamics of those torques, the end pose, both energies, the
inverse-dynamics regressor Y (tau = Y pi, :mod:`manipdyn.model.parameters`), the
derivatives, and (when both engines offer it) the tool frame's Jacobian and
its time derivative, in the tool's own axes, every link's, and the inverse dynamics under
a tool wrench (:data:`TOOL_WRENCH`).  The error of one state is::

    err = max_k |pinocchio_k - lagrange_k| / max(1, max_k |lagrange_k|)

(the trace-form engine is the reference), and a quantity is ``ok`` when the
largest ``err`` over all states is at most :data:`TOLERANCE` = 1e-9.  Both
engines work in float64 and agree to about 1e-13 on healthy arms; 1e-9
leaves room for ill-conditioned mass matrices in forward dynamics (the error
of ``D^-1 x`` grows with cond(D)) while still catching any modelling error,
which shows up at 1e-3 or more.

States: q uniform within ``arm.qlim``; qd uniform in +-2 rad/s (+-0.5 m/s
for prismatic joints); qdd uniform in +-5 rad/s^2 (+-2 m/s^2).
"""

from __future__ import annotations

import dataclasses
import json
import os
import socket
import time
from dataclasses import dataclass, field

import numpy as np

from ..model.arm import register_service
from ..engines.protocol import DynamicsEngine, not_offered  # noqa: F401  (DynamicsEngine: the annotations)
from .quantities import OPTIONAL_QUANTITIES, QUANTITIES, TOOL_WRENCH, engine_results as _engine_results
from .._support.errors import ModelError, SingularMassMatrixError, StateError
from .scale import arm_from_text, chunks, local_cores, map_chunks, model_text
from .conditioning import MAX_COND, TOLERANCE, qdd_not_comparable

__all__ = ["crosscheck", "CrosscheckReport", "QuantityError", "TOLERANCE", "draw_states", "DEFAULT_ENGINES",
           "as_engines", "QUANTITIES", "TOOL_WRENCH", "not_offered"]

#: the engines compared by default: the referee (the trace form) and Pinocchio
DEFAULT_ENGINES = ("lagrange", "pinocchio")
#: most states one cross-check draws (3 arrays of samples x n doubles are held)
MAX_SAMPLES = 10_000_000

@dataclass
class QuantityError:
    """Disagreement of one quantity over all sampled states."""

    name: str
    description: str
    max_abs: float
    max_rel: float
    worst_index: int
    worst_state: dict
    tolerance: float = TOLERANCE

    @property
    def ok(self) -> bool:
        return bool(self.max_rel <= self.tolerance)

    def to_dict(self) -> dict:
        return {
            "quantity": self.name, "description": self.description,
            "max_abs": self.max_abs, "max_rel": self.max_rel, "ok": self.ok,
            "tolerance": self.tolerance, "worst_index": self.worst_index,
            "worst_state": {k: [float(x) for x in v] for k, v in self.worst_state.items()},
        }


@dataclass
class CrosscheckReport:
    """Result of :func:`crosscheck`: one :class:`QuantityError` per quantity."""

    arm: str
    n: int
    samples: int
    seed: int
    quantities: dict = field(default_factory=dict)
    #: the arm's own notes (arm.notes: physically impossible links, suspicious units),
    #: then quantities that could not be compared, and why (e.g. a singular D)
    notes: list = field(default_factory=list)
    #: quantities that could not be compared -> why (also among the notes); a
    #: failed condition for ``manipdyn check``, never "all agree"
    not_compared: dict = field(default_factory=dict)
    #: the engines compared, the referee first (:func:`crosscheck`'s ``engines``)
    engines: tuple = DEFAULT_ENGINES

    @property
    def ok(self) -> bool:
        """True when every quantity agrees within its tolerance."""
        return all(q.ok for q in self.quantities.values())

    def __getitem__(self, name: str) -> QuantityError:
        return self.quantities[name]

    def failures(self) -> list[str]:
        return [k for k, q in self.quantities.items() if not q.ok]

    def to_dict(self) -> dict:
        extra = {} if tuple(self.engines) == DEFAULT_ENGINES else {"engines": list(self.engines)}
        return {"arm": self.arm, "n": self.n, "samples": self.samples, "seed": self.seed, **extra,
                "ok": self.ok, "tolerance": TOLERANCE, "notes": self.notes,
                "not_compared": self.not_compared,
                "quantities": {k: q.to_dict() for k, q in self.quantities.items()}}

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2)

    def table(self) -> str:
        w = max([8] + [len(k) for k in self.quantities])
        rows = [f"{'quantity':<{w}} {'max abs err':>12} {'max rel err':>12}  {'worst':>6}  verdict"]
        for k, q in self.quantities.items():
            rows.append(f"{k:<{w}} {q.max_abs:12.3e} {q.max_rel:12.3e}  {q.worst_index:>6}  "
                        f"{'ok' if q.ok else 'DISAGREE'}")
        return "\n".join(rows)

    def _verdict(self) -> str:
        if not self.ok:
            return "DISAGREEMENT in " + ", ".join(self.failures())
        if self.not_compared:
            return ("the compared quantities agree, but NOT ALL COULD BE COMPARED: "
                    + ", ".join(self.not_compared) + " (see the notes)")
        return "all agree"

    def __str__(self) -> str:
        which = "" if tuple(self.engines) == DEFAULT_ENGINES else f", engines {', '.join(self.engines)}"
        head = (f"crosscheck {self.arm!r} ({self.n} joints, {self.samples} states, seed {self.seed}{which}): "
                f"{self._verdict()} "
                f"(tolerance {TOLERANCE:g} relative)")
        return head + "\n" + self.table() + "".join(f"\nnote: {n}" for n in self.notes)


def draw_states(arm, samples: int, seed: int = 0, start: int = 0, stop: int | None = None):
    """Seeded random ``(q, qd, qdd)``, each ``(samples, n)``, within the joint limits.

    ``start``/``stop`` give rows ``start:stop`` of the same draw without
    drawing the others (each value takes one step of the PCG64 stream, which
    ``advance`` jumps): how the chunks of a distributed cross-check get their states.
    """
    stop = samples if stop is None else stop
    k, n = stop - start, arm.n
    rng = np.random.default_rng(seed)
    bits = rng.bit_generator
    origin = bits.state
    prismatic = np.array([t == "prismatic" for t in arm.joint_types])
    vmax = np.where(prismatic, 0.5, 2.0)
    amax = np.where(prismatic, 2.0, 5.0)
    out = []
    for block, draw in enumerate((lambda: arm.random_state(rng, k),
                                  lambda: vmax * rng.uniform(-1.0, 1.0, (k, n)),
                                  lambda: amax * rng.uniform(-1.0, 1.0, (k, n)))):
        bits.state = origin
        bits.advance((block * samples + start) * n)
        out.append(draw())
    return tuple(out)


def _errors(ref, other):
    """Per-state absolute error and scale of one chunk: two (B,) arrays."""
    ref = np.asarray(ref, dtype=np.float64)
    other = np.asarray(other, dtype=np.float64)
    N = ref.shape[0]
    with np.errstate(invalid="ignore", over="ignore"):
        diff = np.abs(other - ref).reshape(N, -1)
        scale = np.maximum(1.0, np.abs(ref).reshape(N, -1).max(axis=1))
        abs_err = diff.max(axis=1)
    # a NaN anywhere is a disagreement, never a silent pass
    abs_err = np.where(np.isfinite(abs_err), abs_err, np.inf)
    return abs_err, np.where(np.isfinite(scale), scale, 1.0)


def _compare(name, abs_err, scale, states, tol=TOLERANCE) -> QuantityError:
    rel = abs_err / scale
    i = int(np.argmax(rel))
    base, _, pair = name.partition("[")
    desc = QUANTITIES.get(base, base) + (f" ({pair.rstrip(']')})" if pair else "")
    return QuantityError(
        name=name, description=desc,
        max_abs=float(abs_err.max()), max_rel=float(rel[i]), worst_index=i,
        worst_state={k: v[i] for k, v in states.items()}, tolerance=tol,
    )


#: doubles of one (states x n x n) array the cross-check holds at a time
CHUNK_DOUBLES = 2_000_000


def as_engines(engines) -> tuple:
    """``engines`` (names, or one comma-separated string) as a tuple of at least two distinct
    names, or a :class:`ModelError` naming the argument (unknown names fail when built)."""
    if engines is None:
        return DEFAULT_ENGINES
    if isinstance(engines, str):
        engines = [e.strip() for e in engines.split(",")]
    try:
        names = tuple(engines)
    except TypeError:
        raise ModelError(f"engines: expected engine names such as ('lagrange', 'pinocchio', 'c'), "
                         f"got {engines!r:.80}") from None
    if not all(isinstance(e, str) and e for e in names) or len(names) < 2 or len(set(names)) != len(names):
        raise ModelError(f"engines: expected at least two distinct engine names (the first is the referee), "
                         f"e.g. 'lagrange,pinocchio,c'; got {engines!r:.80}")
    return names


def crosscheck(arm, samples: int = 1000, seed: int = 0, chunk: int = 500, progress=None,
               scheduler=None, workers=None, engines=None) -> CrosscheckReport:
    """Compare ``arm.lagrange`` and ``arm.pinocchio`` (or the ``engines`` named) on seeded random states.

    Parameters
    ----------
    arm : manipdyn.Arm
    samples : int
        Number of random states (>= 1).
    seed : int
        Seed of the state generator (``numpy.random.default_rng``).
    chunk : int
        States per batch, at most; fewer on long chains so that a batch's
        (states, n, n) arrays hold at most :data:`CHUNK_DOUBLES` numbers.
        Only per-state errors are kept between batches: memory grows
        linearly with ``samples`` and with ``n**2`` per batch.
    progress : callable, optional
        Called as ``progress(done, total)`` after each chunk.
    scheduler : None, "local", "sync" or "tcp://HOST:PORT"
        None: here, in this process.  Otherwise the states are spread in
        parts of whole chunks over Dask workers (a local cluster of
        ``workers`` processes, or the cluster at the address; see
        :mod:`manipdyn.check.scale`), each part drawing its own states, and the
        report is the same as a local run's.
    engines : sequence of str or str, optional
        The engines to compare (``arm.engine(name)``), the referee first;
        default ``("lagrange", "pinocchio")``, whose quantities keep their
        plain names ("D", "tau", ...).  With more, every engine is compared
        with the referee and each later pair with each other, and the
        quantities are named for the pair: ``"D[c vs lagrange]"``,
        ``"D[c vs pinocchio]"``.

    Returns
    -------
    CrosscheckReport
        ``report.ok`` is False if any quantity disagrees; ``report["D"]``
        etc. give max absolute and relative errors and the worst state.
    """
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise StateError(f"samples: expected a positive integer, got {samples!r:.60}")
    if samples > MAX_SAMPLES:
        shown = str(samples) if len(str(samples)) < 30 else f"a {len(str(samples))}-digit number"
        raise StateError(f"samples: {shown} is over {MAX_SAMPLES:g} states (the drawn states alone "
                         "would not fit in memory); run several cross-checks with different seeds")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise StateError(f"seed: expected a non-negative integer, got {seed!r:.60}")
    engines = as_engines(engines)
    chunk = max(1, min(int(chunk), CHUNK_DOUBLES // (arm.n * arm.n)))
    if scheduler is not None:
        return _crosscheck_distributed(arm, int(samples), seed, chunk, progress, scheduler, workers, engines)
    return _crosscheck_states(arm, int(samples), seed, chunk, progress, 0, int(samples), engines)


def _pairs(engines) -> list:
    """``(reference, other, key suffix)`` of each compared pair: every engine against the first
    (the referee), then each later pair; the two default engines keep the plain keys."""
    if len(engines) == 2:
        return [(engines[0], engines[1], "")]
    out = [(engines[0], e, f"[{e} vs {engines[0]}]") for e in engines[1:]]
    out += [(a, b, f"[{b} vs {a}]") for i, a in enumerate(engines[1:], 1) for b in engines[i + 1:]]
    return out


def _crosscheck_states(arm, samples, seed, chunk, progress, first, stop,
                       engines=DEFAULT_ENGINES) -> CrosscheckReport:
    """The cross-check of rows ``first:stop`` of the states (worst indices global).

    ``chunk`` is the batch size already bounded by :data:`CHUNK_DOUBLES`.
    """
    q, qd, qdd = draw_states(arm, samples, seed, first, stop)
    samples_all, samples = samples, stop - first
    eng = {name: arm.engine(name) for name in engines}
    offered_not = {name: not_offered(E) for name, E in eng.items()}
    pairs = _pairs(engines)
    parts: dict[str, list] = {}
    skipped: dict[str, str] = {}
    optional_notes: dict[str, str] = {}

    def add(key, a, b):
        ea, es = parts.setdefault(key, ([], []))
        e, sc = _errors(a, b)
        ea.append(e)
        es.append(sc)

    for start in range(0, samples, chunk):
        sl = slice(start, min(samples, start + chunk))
        qs, qds, qdds = q[sl], qd[sl], qdd[sl]
        res = {name: _engine_results(E, qs, qds, qdds, name == engines[0]) for name, E in eng.items()}
        tau = res[engines[0]]["tau"]
        fd, fdd = {}, {}

        def forward(name):             # forward dynamics of the referee's torques (once per engine)
            if name not in fd:
                fd[name] = eng[name].forward_dynamics(qs, qds, tau)
            return fd[name]

        def forward_derivatives(name):
            if name not in fdd:
                fdd[name] = eng[name].forward_dynamics_derivatives(qs, qds, tau)
            return fdd[name]

        for a, b, sfx in pairs:
            A, B = res[a], res[b]
            for key in ("D", "h", "g", "tau"):
                add(key + sfx, A[key], B[key])
            # forward dynamics of the same torques: both should return qdd
            kq = "qdd" + sfx
            if kq not in skipped:
                why = qdd_not_comparable(A["D"], B["D"] - A["D"], B["h"] - A["h"], B["g"] - A["g"], qdds)
                if why:
                    skipped[kq] = f"{kq} not compared: {why}"
                    parts.pop(kq, None)
            if kq not in skipped:
                try:
                    add(kq, forward(a), forward(b))
                except SingularMassMatrixError as exc:
                    skipped[kq] = f"{kq} not compared: {exc}"
                    parts.pop(kq, None)
            for key in ("fk", "K", "P", "C", "Y", "dtau_dq", "dtau_dqd", "dg_dq"):
                if key in A and key in B:
                    add(key + sfx, A[key], B[key])
            for key, method in OPTIONAL_QUANTITIES.items():
                lacking = [n for n, R in ((a, A), (b, B)) if key not in R and key not in offered_not[n]]
                if any(key in offered_not[n] for n in (a, b)):
                    continue                         # said in the engine's note
                for n in lacking:      # one note per engine, however many pairs it is in
                    optional_notes[n] = (f"{', '.join(OPTIONAL_QUANTITIES)} not compared where engine {n} takes "
                                         f"part: it offers no {', '.join(dict.fromkeys(OPTIONAL_QUANTITIES.values()))} "
                                         "(optional)")
                if not lacking:
                    add(key + sfx, A[key], B[key])
            lacks = [n for n in (a, b) if "dqdd_dq" in offered_not[n]]
            if lacks:
                continue
            if kq in skipped:      # the same conditioning limits D^-1 dtau (and a singular D has none)
                for key in ("dqdd_dq" + sfx, "dqdd_dqd" + sfx):
                    skipped.setdefault(key, skipped[kq].replace(
                        f"{kq} not compared", f"dqdd_dq{sfx}, dqdd_dqd{sfx} not compared (as qdd)", 1))
                    parts.pop(key, None)
            else:
                for key, x, y in zip(("dqdd_dq", "dqdd_dqd"), forward_derivatives(a), forward_derivatives(b)):
                    add(key + sfx, x, y)
        if progress is not None:
            progress(sl.stop, samples)

    states = {"q": q, "qd": qd, "qdd": qdd}
    engine_notes = []
    for name, E in eng.items():
        engine_notes += list(getattr(E, "notes", None) or ())
        if offered_not[name]:
            engine_notes.append(f"not compared where engine {name} takes part (it does not compute them): "
                                + "; ".join(f"{k}: {why}" for k, why in offered_not[name].items()))
    report = CrosscheckReport(arm=arm.name or "arm", n=arm.n, samples=int(samples_all), seed=int(seed),
                              notes=list(getattr(arm, "notes", ())) + list(dict.fromkeys(skipped.values()))
                              + list(optional_notes.values()) + engine_notes,
                              not_compared=dict(skipped), engines=tuple(engines))
    for key, (ra, rb) in parts.items():
        report.quantities[key] = _compare(key, np.concatenate(ra), np.concatenate(rb), states)
        report.quantities[key].worst_index += first
    return report


def _crosscheck_part(model, samples, seed, chunk, size, engines, part) -> dict:
    """One part of a distributed cross-check: ``{part index: report, "timing": ...}``."""
    t0 = time.perf_counter()
    arm = arm_from_text(*model)
    report = _crosscheck_states(arm, samples, seed, chunk, None, part.start, part.stop, engines)
    report.notes = report.notes[len(getattr(arm, "notes", ())):]     # the client adds the arm's own
    return {part.start // size: report, "timing": {"seconds": time.perf_counter() - t0,
                                           "host": socket.gethostname(), "pid": os.getpid()}}


def _crosscheck_distributed(arm, samples, seed, chunk, progress, scheduler, workers,
                            engines=None) -> CrosscheckReport:
    """Parts of whole chunks on Dask workers, merged: the report a local run gives."""
    nparts = 4 * (local_cores() if workers is None else int(workers))
    size = chunk * max(1, -(-samples // (chunk * nparts)))    # whole chunks: the same batches as a local run
    parts = chunks(samples, 1, size)

    def on_part(done, total):  # done counts parts; report states
        if progress is not None:
            progress(min(samples, done * size), samples)

    engines = DEFAULT_ENGINES if engines is None else engines
    col, _ = map_chunks(_crosscheck_part, (model_text(arm), samples, seed, chunk, size, engines), len(parts),
                        parts, scheduler, workers, on_part)
    reports = col.ordered()
    merged = CrosscheckReport(arm=arm.name or "arm", n=arm.n, samples=samples, seed=int(seed), engines=tuple(engines),
                              notes=list(getattr(arm, "notes", ()))
                              + list(dict.fromkeys(n for r in reports for n in r.notes)))
    for r in reports:                      # the first part's reason, as a local run gives it
        for key, why in r.not_compared.items():
            merged.not_compared.setdefault(key, why)
    keys = {k for r in reports for k in r.quantities}
    skip = {k for r in reports for k in keys if k not in r.quantities}
    for key in reports[0].quantities:      # the local run's order
        if key in skip:
            continue
        parts_q = [r.quantities[key] for r in reports]
        worst = max(parts_q, key=lambda e: e.max_rel)   # the first part holding the largest error
        merged.quantities[key] = dataclasses.replace(worst, max_abs=max(e.max_abs for e in parts_q))
    return merged


register_service("crosscheck", crosscheck)
