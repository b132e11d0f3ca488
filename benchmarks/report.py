"""Console table and Markdown summary of a benchmark run (the dict written to results.json)."""

from __future__ import annotations

from .cases import IMPL_LABEL, IMPLS, OPS

_SHORT = {"manipdyn": "fast", "pinocchio": "pin", "lagrange": "trace1", "lagrange_batch": "traceB",
          "rtb": "rtb", "rtb_Cqd": "rtb C@qd"}


def _us(s):
    return "-" if s is None else (f"{s * 1e6:.2f}" if s < 1e-4 else f"{s * 1e6:.0f}")


def _ratio_map(res):
    return {(r["arm"], r["op"], r["num"], r["den"]): r["ratio"] for r in res.get("per_call_ratios", [])}


def _cell(rows, arm, op, impl, iqr=False):
    for r in rows:
        if r["arm"] == arm and r["op"] == op and r["impl"] == impl:
            return _us(r["median_s"]) + (f" [{_us(r['iqr_s'])}]" if iqr else "")
    return None


def _aborted(res, arm, op, impl):
    return any(a["arm"] == arm and a["op"] == op and a["impl"] == impl for a in res.get("aborted_rows", []))


def _fmt_ratio(x):
    return "-" if x is None else f"{x:.2f}"


def console(res):
    lines = []
    rows = res.get("per_call", [])
    if rows:
        rm = _ratio_map(res)
        impls = [i for i in IMPLS if any(r["impl"] == i for r in rows)]
        head = ["arm", "op"] + [_SHORT[i] for i in impls] + ["fast/pin", "rtb/fast"]
        body = []
        for arm in [a["name"] for a in res["arms"]]:
            for op in OPS:
                cells = []
                for i in impls:
                    c = _cell(rows, arm, op, i)
                    cells.append("ABORT" if _aborted(res, arm, op, i) else (c or ""))
                body.append([arm, op] + cells + [
                    _fmt_ratio(rm.get((arm, op, "manipdyn", "pinocchio"))),
                    _fmt_ratio(rm.get((arm, op, "rtb", "manipdyn")))])
        lines.append("per-call median, microseconds (traceB: per state in a batch of "
                     f"{res['config']['lagrange_batch']})")
        lines += _table(head, body)
    b = res.get("batch", [])
    if b:
        lines.append("")
        lines.append("batch throughput, states/s")
        body = []
        for r in b:
            body.append([r["arm"], r["op"], r["N"], r["impl"], f"{r['states_per_s']:,.0f}"])
        lines += _table(["arm", "op", "N", "impl", "states/s"], body)
        lines += [f"  speed-up vs loop: {r['arm']} {r['op']} N={r['N']} {r['threads']} thread(s): "
                  f"manipdyn {r['speedup_vs_loop']:.2f}x, raw Pinocchio {r['raw_speedup_vs_loop']:.2f}x"
                  for r in res.get("batch_ratios", [])]
    sc = res.get("scaling")
    if sc and sc.get("n"):
        lines.append("")
        lines.append(f"scaling, n = {sc['n']}: fitted exponents t ~ n^e (all sizes / n >= 8)")
        for k, e in sc["exponents"].items():
            lines.append(f"  {k:<28} {e.get('all', float('nan')):5.2f} / "
                         + (f"{e['tail']:5.2f}" if "tail" in e else "  -"))
    lines.append("")
    lines.append("targets")
    for t in res.get("targets", []):
        if t["status"] == "skipped":
            lines.append(f"  {t['id']} SKIPPED  {t['what']}: {t.get('reason')}")
            continue
        meas = ", ".join(f"{a} {v:.2f}" for a, v in t["measured"].items())
        op = "<=" if t["kind"] == "max" else ">="
        lines.append(f"  {t['id']} {t['status']:<5} {t['what']} ({op} {t['limit']}): {meas}"
                     + (f"  -- missed by {t['miss_by']}" if t.get("miss_by") else ""))
    dis = res["checks"].get("rtb_disagreements", [])
    lines.append("")
    lines.append(f"checks: manipdyn engines {'all agree with the referee' if res['checks']['passed'] else 'WRONG'}; "
                 f"{len(dis)} Toolbox disagreement(s)")
    for d in dis:
        lines.append(f"  {d['arm']} ({d['convention']} DH, {d['joints']}) {d['op']}: Toolbox off by "
                     f"{_e(d['rtb_vs_manipdyn_abs'])} (rel {_e(d['rtb_vs_referee_rel'])}); {d['verdict']}")
    return "\n".join(lines)


def _table(head, body):
    w = [max(len(str(x)) for x in col) for col in zip(head, *body)] if body else [len(h) for h in head]
    fmt = lambda row: "  ".join(str(x).rjust(w[i]) if i >= 2 else str(x).ljust(w[i])  # noqa: E731
                                for i, x in enumerate(row))
    return [fmt(head), fmt(["-" * x for x in w])] + [fmt(r) for r in body]


def _md_table(head, body):
    out = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in body]
    return out


def format_pools(pools) -> str:
    """threadpoolctl's pools as one readable line (``openblas 0.3.30 (blas, 2 threads, SkylakeX); ...``),
    never a Python list of dicts."""
    if not isinstance(pools, list):
        return str(pools)
    return "; ".join(f"{p.get('internal_api')} {p.get('version') or ''} ({p.get('user_api')}, "
                     f"{p.get('num_threads')} threads"
                     + (f", {p['architecture']}" if p.get("architecture") else "") + ")" for p in pools)


def format_load(values) -> str:
    """A load average (1, 5, 15 min) as ``15.20 15.67 15.69``."""
    try:
        return " ".join(f"{float(x):.2f}" for x in values)
    except (TypeError, ValueError):
        return str(values)


def markdown(res):
    """The results as a Markdown report: one named section after another."""
    L = []
    for section in (_md_header, _md_targets, _md_per_call, _md_batch, _md_scaling, _md_checks, _md_skipped):
        L += section(res)
    return "\n".join(L)


def _md_header(res) -> list:
    """Title, command, machine and BLAS configuration."""
    m = res["machine"]
    L = [f"# manipdyn benchmark: {res['mode']} run, {res['started']}", ""]
    L.append(f"Command: `{res['command']}`; {res['duration_s']} s.  ")
    L.append(f"Machine: {m['cpu']} ({m.get('cpu_detail')}), {m['cores']} cores, {m['memory_gib']} GiB; Python {m['python']}, "
             f"numpy {m['numpy']} ({m.get('blas')}), pinocchio {m['pinocchio']}, "
             f"roboticstoolbox-python {m['roboticstoolbox'] or 'not installed'}; "
             f"OPENBLAS_CORETYPE={m.get('OPENBLAS_CORETYPE')}; load average "
             f"{_load(m.get('loadavg_start'))} at the start, {_load(m.get('loadavg_end'))} at the end.  ")
    L.append(f"BLAS and OpenMP thread pools (threadpoolctl): {format_pools(m.get('blas_config'))}; "
             f"OPENBLAS_L2_SIZE={m.get('OPENBLAS_L2_SIZE')}.")
    L.append("")
    L.append("Times are medians over interleaved rounds (every candidate timed in every round); "
             "ratios are medians of the per-round ratios.  Arms are built without rotors and friction.")
    L.append("")

    return L


def _md_targets(res) -> list:
    """The targets and their verdicts; a profile of each missed one."""
    L = []
    L.append("## Targets")
    L.append("")
    body = []
    for t in res.get("targets", []):
        lim = ("<= " if t["kind"] == "max" else ">= ") + f"{t['limit']} ({t['unit']})"
        if t["status"] == "skipped":
            body.append([t["id"], t["what"], lim, "-", f"skipped: {t.get('reason')}"])
            continue
        meas = ", ".join(f"{a}: {v:.2f}" for a, v in t["measured"].items())
        if t.get("by_threads"):
            meas += " (by threads: " + ", ".join(f"{k} {v:.2f}" for k, v in t["by_threads"].items()) + ")"
        verdict = "**pass**" if t["status"] == "pass" else f"**MISS** by {t['miss_by']}"
        body.append([t["id"], t["what"], lim, meas, verdict])
    L += _md_table(["id", "target", "limit", "measured (ratio)", "verdict"], body)
    L.append("")
    missed = [t for t in res.get("targets", []) if t["status"] == "MISS"]
    if missed:
        L.append("### Missed targets: profile and what would close them")
        L.append("")
        for t in missed:
            L.append(f"**{t['id']}** ({t['what']}): {t['miss_by']} on {t['worst_arm']}.")
            L.append("")
            p = t.get("profile")
            if p:
                L.append(f"cProfile of {p['profiled']} on {p['arm']}, {p['calls']} calls, top own time "
                         "(Pinocchio's Boost.Python functions are invisible to cProfile: their time is "
                         "counted as the own time of the manipdyn method that calls them):")
                L.append("")
                L += _md_table(["function", "calls", "own time per profiled call (us)", "share"],
                               [[f"`{r['function']}`", r["ncalls"], f"{r['us_per_call']:.2f}",
                                 f"{100 * r['share']:.0f}%"] for r in p["top"]])
                L.append("")
            if t.get("analysis"):
                L.append(t["analysis"])
                L.append("")

    return L


def _md_per_call(res) -> list:
    """Per-call medians of every implementation, with the ratios."""
    L = []
    rows = res.get("per_call", [])
    if rows:
        rm = _ratio_map(res)
        L.append("## Per-call times")
        L.append("")
        L.append("Microseconds, median [IQR]; the trace form's batch column is per state in a batch of "
                 f"{res['config']['lagrange_batch']}.  `dynamics_terms` is D, h and g together "
                 "(raw Pinocchio: crba + rnea without gravity + computeGeneralizedGravity; the Toolbox: "
                 "inertia + rne + gravload).  The Toolbox's coriolis torque is `rne(q, qd, 0, gravity=0)`; "
                 "its `coriolis(q, qd) @ qd` route is the last column.")
        L.append("")
        impls = [i for i in IMPLS if any(r["impl"] == i for r in rows)]
        head = ["arm", "op"] + [IMPL_LABEL[i] for i in impls] + ["fast / raw pin", "Toolbox / fast"]
        body = []
        for arm in [a["name"] for a in res["arms"]]:
            for op in OPS:
                cells = []
                for i in impls:
                    c = _cell(rows, arm, op, i, iqr=True)
                    cells.append("ABORTED (wrong answer)" if _aborted(res, arm, op, i) else (c or ""))
                body.append([arm, f"`{op}`"] + cells + [
                    _fmt_ratio(rm.get((arm, op, "manipdyn", "pinocchio"))),
                    _fmt_ratio(rm.get((arm, op, "rtb", "manipdyn")))])
        L += _md_table(head, body)
        L.append("")

    return L


def _md_batch(res) -> list:
    """Batch throughput against a Python loop."""
    L = []
    b = res.get("batch", [])
    if b:
        L.append("## Batch throughput")
        L.append("")
        L.append("`arm.inverse_dynamics` / `arm.forward_dynamics` on (N, n) arrays "
                 "(pin.rneaInParallel / abaInParallel with a ModelPool) at 1 and 2 threads (`manipdyn_kt`), "
                 "the same Pinocchio call without manipdyn's wrapper (`pinocchio_kt`), and a Python "
                 "loop over pin.rnea / pin.aba on the same states (`python_loop`).")
        L.append("")
        L += _md_table(["arm", "op", "N", "implementation", "states/s", "median ms [IQR]"],
                       [[r["arm"], f"`{r['op']}`", r["N"], r["impl"], f"{r['states_per_s']:,.0f}",
                         f"{r['median_s'] * 1e3:.2f} [{r['iqr_s'] * 1e3:.2f}]"] for r in b])
        L.append("")
        L += _md_table(["arm", "op", "N", "threads", "manipdyn batch vs the loop", "raw pin.*InParallel vs the loop"],
                       [[r["arm"], f"`{r['op']}`", r["N"], str(r["threads"]) + (" (default)" if r["default_threads"] else ""),
                         f"{r['speedup_vs_loop']:.2f}x", f"{r['raw_speedup_vs_loop']:.2f}x"]
                        for r in res.get("batch_ratios", [])])
        L.append("")

    return L


def _md_scaling(res) -> list:
    """Fitted scaling exponents with the number of joints."""
    L = []
    sc = res.get("scaling")
    if sc and sc.get("n"):
        L.append("## Scaling with the number of joints")
        L.append("")
        L.append(f"Seeded random all-revolute standard-DH chains with physical inertias, n = {sc['n']}.  "
                 f"Fitted exponent e of t ~ n^e (log-log least squares) over all sizes and over n >= 8.  "
                 f"Trace-form batch: per state in a batch of {sc['batch']}.")
        L.append("")
        body = []
        for k, e in sc["exponents"].items():
            ts = sc["median_s"][k]
            body.append([k, sc["labels"][k], f"{e.get('all', float('nan')):.2f}",
                         f"{e['tail']:.2f}" if "tail" in e else "-",
                         _us(ts[0]), _us(ts[-1])])
        L += _md_table(["series", "what", "e (all n)", "e (n >= 8)", f"n={sc['n'][0]} (us)",
                        f"n={sc['n'][-1]} (us)"], body)
        L.append("")
        L.append(f"Plot: `{sc['plot']}` beside this file" if sc.get("plot") else f"Plot skipped: {sc.get('plot_skipped')}")
        L.append("")

    return L


def _md_checks(res) -> list:
    """The correctness checks against the energy referee, and the Toolbox disagreements."""
    L = []
    ch = res["checks"]
    L.append("## Correctness checks")
    L.append("")
    n_ok = sum(r["ok"] for r in ch["results"])
    L.append(f"{n_ok} of {len(ch['results'])} (arm, implementation, operation) answers agree with the "
             f"energy referee (benchmarks/referee.py) within a relative {ch['tolerance_rel']:g}.  manipdyn's "
             f"engines: **{'all correct' if ch['passed'] else 'WRONG ANSWERS, see below'}**.")
    L.append("")
    bad = [r for r in ch["results"] if not r["ok"]]
    if bad:
        L += _md_table(["arm", "implementation", "op", "max rel err vs referee", "max abs err"],
                       [[r["arm"], r["impl"], f"`{r['op']}`", _e(r["max_rel_err"]), _e(r["max_abs_err"]) +
                         (f" ({r['error']})" if r.get("error") else "")] for r in bad])
        L.append("")
    dis = ch.get("rtb_disagreements", [])
    if dis:
        L.append("### Where the Robotics Toolbox disagrees")
        L.append("")
        L += _md_table(["arm", "DH", "joints", "gravity", "op", "|Toolbox - fast path| max",
                        "Toolbox rel err vs referee", "fast / trace rel err vs referee", "verdict"],
                       [[d["arm"], d["convention"], d["joints"], str(d["gravity"]), f"`{d['op']}`",
                         _e(d["rtb_vs_manipdyn_abs"]), _e(d["rtb_vs_referee_rel"]),
                         f"{_e(d['manipdyn_vs_referee_rel'])} / {_e(d['trace_vs_referee_rel'])}", d["verdict"]]
                        for d in dis])
        L.append("")
    notes = ch.get("rtb_bundled_model_differences") or {}
    if notes:
        L.append("### The Toolbox's own models vs manipdyn's data")
        L.append("")
        for arm, diffs in notes.items():
            L.append(f"- {arm}: " + ("identical numbers" if not diffs else "; ".join(diffs)))
        L.append("")
    return L


def _md_skipped(res) -> list:
    """What was skipped, and why."""
    L = []
    if res.get("skipped"):
        L.append("## Skipped")
        L.append("")
        for s in res["skipped"]:
            L.append(f"- {s['what']}: {s['reason']}")
        L.append("")
    return L


def _e(x):
    return "-" if x is None else f"{x:.2g}"


def _load(x):
    return "-" if not x else "/".join(f"{v:.1f}" for v in x)
