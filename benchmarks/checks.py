"""The benchmark suite's answers checked before they are timed: every implementation against the referee.

Part of ``python -m benchmarks.run`` (section 1).  The fast path (Pinocchio), raw Pinocchio, the
trace-form engine and the Robotics Toolbox are compared with an independent energy-based referee
(:mod:`benchmarks.referee`) at random states; a wrong answer is reported loudly, and where the
Toolbox disagrees with manipdyn the side found to be wrong is named (:func:`wrong_side`).
"""

from __future__ import annotations

import functools
import math
import sys

import numpy as np

from . import rtb_adapter
from .cases import ARGS, IMPL_LABEL, OPS
from .referee import Referee

#: relative tolerance against the energy referee (which is exact to ~1e-10)
TOL = 1e-6


def log(msg=""):
    print(msg, flush=True)


def loud(msg):
    print("!!! " + msg, file=sys.stderr, flush=True)


def raw_pinocchio(arm):
    """The five operations (and D+h+g) straight on ``arm.pinocchio.model``."""
    import pinocchio as pin

    m = arm.pinocchio.model
    d = m.createData()
    m0 = m.copy()
    m0.gravity.linear = np.zeros(3)
    d0 = m0.createData()
    z = np.zeros(m.nv)

    def terms(q, qd):
        return pin.crba(m, d, q), pin.rnea(m0, d0, q, qd, z), pin.computeGeneralizedGravity(m, d, q)

    # partials, not lambdas: timing partial(f, *args) then calls Pinocchio with no Python frame
    return {
        "mass_matrix": functools.partial(pin.crba, m, d),
        "coriolis_torque": lambda q, qd: pin.rnea(m0, d0, q, qd, z),
        "gravity_torque": functools.partial(pin.computeGeneralizedGravity, m, d),
        "inverse_dynamics": functools.partial(pin.rnea, m, d),
        "forward_dynamics": functools.partial(pin.aba, m, d),
        "dynamics_terms": terms,
    }


def implementations(arm, robot):
    """dict impl -> dict op -> callable (one state; lagrange_batch takes batches)."""
    L = arm.lagrange
    out = {
        "manipdyn": {
            "mass_matrix": arm.mass_matrix, "coriolis_torque": arm.coriolis_torque,
            "gravity_torque": arm.gravity_torque, "inverse_dynamics": arm.inverse_dynamics,
            "forward_dynamics": arm.forward_dynamics, "dynamics_terms": arm.pinocchio.dynamics_terms,
        },
        "pinocchio": raw_pinocchio(arm),
        "lagrange": {op: getattr(L, op) for op in OPS},
        "lagrange_batch": {op: getattr(L, op) for op in OPS},
    }
    if robot is not None:
        r = rtb_adapter.calls(robot)
        r["dynamics_terms"] = lambda q, qd, _r=r: (_r["mass_matrix"](q), _r["coriolis_torque"](q, qd),
                                                    _r["gravity_torque"](q))
        out["rtb"] = r
        out["rtb_Cqd"] = {"coriolis_torque": rtb_adapter.coriolis_matrix_route(robot)}
    return out


def states(arm, rng, size):
    """q within the joint limits; qd, qdd in [-1, 1]; tau in [-5, 5]."""
    shape = (size, arm.n)
    return {
        "q": arm.random_state(rng, size),
        "qd": rng.uniform(-1.0, 1.0, shape),
        "qdd": rng.uniform(-1.0, 1.0, shape),
        "tau": rng.uniform(-5.0, 5.0, shape),
    }


def _flat(x):
    if isinstance(x, tuple):
        return np.concatenate([np.asarray(v, dtype=float).ravel() for v in x])
    return np.asarray(x, dtype=float).ravel()


def _referee_values(ref, st):
    q, qd, qdd = st["q"], st["qd"], st["qdd"]
    D = ref.mass_matrix(q)
    h = ref.coriolis_torque(q, qd)
    g = ref.gravity_torque(q)
    return {"D": D, "h": h, "g": g,
            "mass_matrix": D, "coriolis_torque": h, "gravity_torque": g,
            "inverse_dynamics": D @ qdd + h + g, "dynamics_terms": (D, h, g)}


def _error(op, value, refv, st):
    """(relative, absolute) error of one answer against the referee (NaN counts as inf)."""
    rel, ab = _error_raw(op, value, refv, st)
    return (rel if math.isfinite(rel) else math.inf), (ab if math.isfinite(ab) else math.inf)


def _error_raw(op, value, refv, st):
    if op == "forward_dynamics":
        # judged in torque space, so an ill-conditioned D does not blur the verdict
        qdd = np.asarray(value, dtype=float)
        rhs = st["tau"] - refv["h"] - refv["g"]
        res = refv["D"] @ qdd - rhs
        scale = max(np.abs(rhs).max(), np.abs(refv["D"] @ qdd).max(), 1e-9)
        return float(np.abs(res).max() / scale), float(np.abs(res).max())
    a, b = _flat(value), _flat(refv[op])
    if a.shape != b.shape:
        return math.inf, math.inf
    diff = float(np.abs(a - b).max())
    return diff / max(float(np.abs(b).max()), 1e-9), diff


def check_arm(arm, robot, cfg, rng, timed=True):
    """Compare every implementation with the referee at ``cfg.check_states`` states.

    Returns ``(rows, wrong, answers, per_state, refs)``: one row dict per
    (implementation, operation), the set of (impl, op) that gave a wrong
    answer (or raised), the answers themselves, the states and the referee's
    values (for the disagreement report).
    """
    ref = Referee(arm)
    S = states(arm, rng, cfg.check_states)
    per_state = [{k: v[i] for k, v in S.items()} for i in range(cfg.check_states)]
    refs = [_referee_values(ref, st) for st in per_state]
    impls = implementations(arm, robot)
    if not timed:  # probe arms: the two manipdyn engines and the Toolbox only
        impls = {k: v for k, v in impls.items() if k in ("manipdyn", "lagrange", "rtb")}
    rows, wrong = [], set()
    answers = {}
    for impl, fns in impls.items():
        for op, f in fns.items():
            try:
                if impl == "lagrange_batch":
                    out = f(*(S[a] for a in ARGS[op]))
                    vals = [tuple(x[i] for x in out) if isinstance(out, tuple) else out[i]
                            for i in range(cfg.check_states)]
                else:
                    vals = [f(*(st[a] for a in ARGS[op])) for st in per_state]
                    vals = [tuple(np.array(x) for x in v) if isinstance(v, tuple) else np.array(v) for v in vals]
                errs = [_error(op, v, rv, st) for v, rv, st in zip(vals, refs, per_state)]
                rel = max(e[0] for e in errs)
                ab = max(e[1] for e in errs)
                err_msg = None
            except Exception as exc:  # a crash is a wrong answer too
                vals, rel, ab, err_msg = None, math.inf, math.inf, f"{type(exc).__name__}: {exc}"
            ok = rel <= TOL
            answers[(impl, op)] = vals
            rows.append({"arm": arm.name, "impl": impl, "op": op, "states": cfg.check_states,
                         "max_rel_err": num(rel), "max_abs_err": num(ab), "ok": bool(ok),
                         **({"error": err_msg} if err_msg else {})})
            if not ok:
                wrong.add((impl, op))
    return rows, wrong, answers, per_state, refs


def num(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _max_diff(a_vals, b_vals):
    if a_vals is None or b_vals is None:
        return None, None
    ab = max(float(np.abs(_flat(a) - _flat(b)).max()) for a, b in zip(a_vals, b_vals))
    sc = max(float(np.abs(_flat(b)).max()) for b in b_vals)
    return ab, ab / max(sc, 1e-9)


def disagreements_for(arm, robot, rows, answers, per_state, refs):
    """One entry per (arm, op) where the Toolbox disagrees with the referee."""
    out = []
    by = {(r["impl"], r["op"]): r for r in rows}
    for op in OPS:
        r = by.get(("rtb", op))
        if r is None or r["ok"]:
            continue
        fast, trace = by.get(("manipdyn", op)), by.get(("lagrange", op))
        d_fast = _max_diff(answers.get(("rtb", op)), answers.get(("manipdyn", op)))
        d_trace = _max_diff(answers.get(("rtb", op)), answers.get(("lagrange", op)))
        entry = {
            "arm": arm.name, "convention": arm.convention,
            "joints": "".join("R" if t == "revolute" else "P" for t in arm.joint_types),
            "gravity": [round(float(v), 4) for v in arm.gravity], "op": op,
            "rtb_vs_referee_rel": r["max_rel_err"], "rtb_vs_referee_abs": r["max_abs_err"],
            "rtb_vs_manipdyn_abs": num(d_fast[0]) if d_fast[0] is not None else None,
            "rtb_vs_manipdyn_rel": num(d_fast[1]) if d_fast[1] is not None else None,
            "rtb_vs_trace_abs": num(d_trace[0]) if d_trace[0] is not None else None,
            "manipdyn_vs_referee_rel": fast["max_rel_err"] if fast else None,
            "trace_vs_referee_rel": trace["max_rel_err"] if trace else None,
        }
        if fast and trace and fast["ok"] and trace["ok"]:
            entry["verdict"] = ("Toolbox wrong: manipdyn's fast path, its trace form and the "
                                "energy referee agree")
        else:
            entry["verdict"] = "manipdyn disagrees with the referee too: investigate"
        if op in ("inverse_dynamics", "gravity_torque"):
            # is it the C extension? the Toolbox's own pure-Python RNE is a second opinion
            try:
                f = rtb_adapter.rne_python(robot)
                errs = []
                for st, rv in zip(per_state, refs):
                    if op == "inverse_dynamics":
                        v = f(st["q"], st["qd"], st["qdd"])
                    else:
                        z = np.zeros(arm.n)
                        v = f(st["q"], z, z)
                    errs.append(_error(op, np.asarray(v), rv, st)[0])
                entry["rtb_rne_python_vs_referee_rel"] = num(max(errs))
                if max(errs) <= TOL:
                    entry["verdict"] += ("; the Toolbox's own pure-Python rne_python agrees with them, "
                                         "so the fault is in its C extension (frne, ne.c)")
            except Exception as exc:
                entry["rtb_rne_python"] = f"{type(exc).__name__}: {exc}"
        out.append(entry)
    return out


def wrong_side(arm, q, qd, qdd, fast, slow) -> str:
    """Which of the fast path and the trace form answered wrong: the one farther from the
    energy referee (benchmarks/referee.py), given their ``(tau, D)`` at one state."""
    try:
        ref = Referee(arm)
        tau, D = np.asarray(ref.inverse_dynamics(q, qd, qdd)), np.asarray(ref.mass_matrix(q))

        def dist(pair):
            return max(np.abs(pair[0] - tau).max() / max(np.abs(tau).max(), 1e-9),
                       np.abs(pair[1] - D).max() / max(np.abs(D).max(), 1e-9))
        return "manipdyn fast path" if dist(fast) > dist(slow) else "manipdyn trace form"
    except Exception as exc:  # the referee itself failed: say so rather than guess
        return f"fast path or trace form: the referee failed ({type(exc).__name__}: {exc})"


def run_checks(bench, probes, robots, cfg, rng):
    log("== 1. answers checked against the energy referee (benchmarks/referee.py)")
    rows, wrong, disagreements = [], {}, []
    for arm, timed in [(a, True) for a in bench] + [(a, False) for a in probes]:
        robot = robots.get(arm.name)
        r, w, answers, per_state, refs = check_arm(arm, robot, cfg, rng, timed=timed)
        rows += r
        wrong[arm.name] = w
        for impl, op in sorted(w):
            row = next(x for x in r if x["impl"] == impl and x["op"] == op)
            why = row.get("error") or f"max relative error {row['max_rel_err']:.2e} vs referee"
            if impl.startswith("rtb"):
                loud(f"WRONG ANSWER (Toolbox) {arm.name} {op}: {why}" + ("; row aborted" if timed else ""))
            else:
                loud(f"WRONG ANSWER ({IMPL_LABEL[impl]}) {arm.name} {op}: {why}; row aborted")
        if robot is not None:
            disagreements += disagreements_for(arm, robot, r, answers, per_state, refs)
        n_ok = sum(x["ok"] for x in r)
        log(f"   {arm.name:<14} {n_ok}/{len(r)} answers agree with the referee"
            + ("" if timed else "  (probe arm: checked, not timed)"))
    manipdyn_ok = all(x["ok"] for x in rows if not x["impl"].startswith("rtb"))
    model_notes = {}
    for arm in bench:
        diffs = rtb_adapter.bundled_model_differences(arm)
        if diffs is not None:
            model_notes[arm.name] = diffs
    return {"tolerance_rel": TOL, "passed": bool(manipdyn_ok), "results": rows,
            "rtb_disagreements": disagreements, "rtb_bundled_model_differences": model_notes}, wrong

