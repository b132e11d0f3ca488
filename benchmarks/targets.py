"""The benchmark suite's targets, their verdicts and, for a missed one, the profile that explains it.

Part of ``python -m benchmarks.run`` (section 5): :data:`TARGETS` are the ratios the fast path and
the trace form are held to (benchmarks/README.md), :data:`ANALYSIS` what the profiles have shown
when one was missed, :func:`evaluate_targets` the verdicts of one run.
"""

from __future__ import annotations



from .checks import states
from .timing import profile_top

TARGETS = [
    {"id": "T1", "what": "fast-path inverse dynamics per call vs raw pin.rnea", "kind": "max", "limit": 1.5,
     "op": "inverse_dynamics", "num": "manipdyn", "den": "pinocchio", "unit": "x slower"},
    {"id": "T2", "what": "fast-path mass matrix per call vs raw pin.crba", "kind": "max", "limit": 1.5,
     "op": "mass_matrix", "num": "manipdyn", "den": "pinocchio", "unit": "x slower"},
    {"id": "T3", "what": "fast path vs the Toolbox's rne (inverse dynamics)", "kind": "min", "limit": 7.0,
     "op": "inverse_dynamics", "num": "rtb", "den": "manipdyn", "unit": "x faster"},
    {"id": "T4", "what": "fast path vs the Toolbox's inertia() (mass matrix)", "kind": "min", "limit": 20.0,
     "op": "mass_matrix", "num": "rtb", "den": "manipdyn", "unit": "x faster"},
    {"id": "T5", "what": "batch inverse dynamics (default threads) vs a Python loop over pin.rnea",
     "kind": "min", "limit": 2.0, "op": "inverse_dynamics", "unit": "x the throughput"},
    {"id": "T6", "what": "trace-form batch D+h+g per state vs Pinocchio's per-call D+h+g",
     "kind": "max", "limit": 4.0, "op": "dynamics_terms", "num": "lagrange_batch", "den": "pinocchio",
     "unit": "x slower"},
]


#: what the profile has shown when these targets were missed, and what would close them
#: (written from the profiles in benchmarks/README.md; shown only when a target is missed)
ANALYSIS = {
    "T1": ("The fast path already calls pin.rnea first and checks only its answer "
           "(math.isfinite(sum(tau.tolist())), ~0.35 us; every input reaches tau in RNEA), after "
           "three ndim tests; what is left is that test, the Python method call and the attribute "
           "lookups, ~0.6-1 us around a ~1.5-2.5 us rnea.  It is the floor of a checked call from "
           "Python: closing the rest means dropping the NaN/inf guarantee (callers who want that "
           "can call pin.rnea on arm.pinocchio.model/data directly) or moving the check into C."),
    "T2": ("Same floor with one argument around a ~1 us crba: the test must stay on q, not on "
           "the result, because D does not depend on q1 and Pinocchio's CRBA returns a finite D "
           "for a NaN in q1.  ~0.6 us of test, call and lookups on ~1.1 us is ~1.55x; only "
           "dropping the NaN/inf guarantee or a C-level check closes it."),
    "T3": ("The Toolbox's rne is ~20-35 us per call (its C extension plus Python argument "
           "handling); 7x needs the fast path at <= ~3-5 us, i.e. the T1 fix (a prototype at ~2.3 us "
           "gives ~12x)."),
    "T4": ("Borderline: inertia() is one C rne call over n unit accelerations plus Python "
           "handling (~75-100 us) against the fast path's ~4 us; the T2 fix (~1.6 us) gives ~50x."),
    "T5": ("Compare the manipdyn_kt rows with pinocchio_kt (the same rneaInParallel call, no "
           "wrapper).  The wrapper's cost is as_state's finiteness test: ndarray.dot over the whole "
           "(N, n) array goes to OpenBLAS's *threaded* ddot above 10,000 elements (~1,700 states of "
           "a 6-joint arm); on a loaded 2-core machine that costs milliseconds per call, three times "
           "per call, and leaves an OpenBLAS thread spinning against Pinocchio's OpenMP workers.  "
           "With OPENBLAS_NUM_THREADS=1 the manipdyn and raw rows coincide (README).  What closes "
           "it: a never-threaded test for batches (math.isfinite(np.add.reduce(flat)), ~0.7 ms for "
           "600k elements).  Past that the ratio is bounded by Pinocchio's per-state time in "
           "rneaInParallel against ~3-4 us per Python-level call: ~2x at 1 thread, 3-4x at 2 "
           "threads on an idle 2-core machine; 2 threads on small batches (a few thousand states) "
           "can be slower than 1 on a loaded one."),
    "T6": ("The trace form's batch cost is numpy's batched 4x4 matmuls (frames, W = T J T^T, the "
           "Delta-products of D and h); fewer temporaries (in-place matmul into preallocated "
           "buffers) would close it."),
}


def evaluate_targets(per_call_ratios, batch_ratios, rtb_reason, cfg, bench, rng, profile=True):
    out = []
    for t in TARGETS:
        res = {k: t[k] for k in ("id", "what", "kind", "limit", "unit")}
        if t["id"] == "T5":
            N = cfg.batch_sizes[0][0]
            res["N"] = N
            per_arm = {r["arm"]: r["speedup_vs_loop"] for r in batch_ratios
                       if r["op"] == t["op"] and r["default_threads"] and r["N"] == N}
            res["by_threads"] = {f"{r['arm']}/{r['threads']}t": r["speedup_vs_loop"] for r in batch_ratios
                                 if r["op"] == t["op"] and r["N"] == N}
        else:
            per_arm = {r["arm"]: r["ratio"] for r in per_call_ratios
                       if r["op"] == t["op"] and r["num"] == t["num"] and r["den"] == t["den"]}
        if not per_arm:
            res["status"] = "skipped"
            res["reason"] = rtb_reason if t.get("num") == "rtb" and rtb_reason else "not measured"
            out.append(res)
            continue
        res["measured"] = per_arm
        if t["kind"] == "max":
            worst_arm = max(per_arm, key=per_arm.get)
            ok = all(v <= t["limit"] for v in per_arm.values())
        else:
            worst_arm = min(per_arm, key=per_arm.get)
            ok = all(v >= t["limit"] for v in per_arm.values())
        res["worst_arm"] = worst_arm
        res["worst"] = per_arm[worst_arm]
        res["status"] = "pass" if ok else "MISS"
        if not ok:
            w = per_arm[worst_arm]
            if t["kind"] == "max":
                res["miss_by"] = f"{w / t['limit']:.2f}x over the limit ({w:.2f} vs <= {t['limit']})"
            else:
                res["miss_by"] = f"{t['limit'] / w:.2f}x short ({w:.2f} vs >= {t['limit']})"
            res["analysis"] = ANALYSIS.get(t["id"])
            if profile:
                arm = next(a for a in bench if a.name == worst_arm)
                res["profile"] = _profile_for(t["id"], arm, cfg, rng)
        out.append(res)
    return out


def _profile_for(tid, arm, cfg, rng):
    one = {k: v[0] for k, v in states(arm, rng, 1).items()}
    q, qd, qdd = one["q"], one["qd"], one["qdd"]
    calls = cfg.profile_calls
    if tid in ("T1", "T3"):
        what, fn = "arm.inverse_dynamics(q, qd, qdd), one state", lambda: arm.inverse_dynamics(q, qd, qdd)
    elif tid in ("T2", "T4"):
        what, fn = "arm.mass_matrix(q), one state", lambda: arm.mass_matrix(q)
    elif tid == "T5":
        S = states(arm, rng, min(cfg.batch_sizes[0][0], 20_000))
        what, fn = f"arm.inverse_dynamics on a batch of {len(S['q'])}", lambda: arm.inverse_dynamics(
            S["q"], S["qd"], S["qdd"])
        calls = 5
    else:
        S = states(arm, rng, cfg.lagrange_batch)
        what, fn = f"arm.lagrange.dynamics_terms on a batch of {cfg.lagrange_batch}", \
            lambda: arm.lagrange.dynamics_terms(S["q"], S["qd"])
        calls = max(3, calls // 1000)
    return {"arm": arm.name, "profiled": what, "calls": calls, "top": profile_top(fn, calls)}

