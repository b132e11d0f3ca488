"""Benchmark of the generated C (issue 26, item 4) against Pinocchio's C++, per call, in C.

Run, with OpenBLAS's tuning variables unset in that command alone::

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_codegen [--arms ur5 panda] [--quick]

For each arm (default: the bundled 6-joint ur5 and 7-joint panda) it

1. draws seeded random states (:func:`manipdyn.check.crosscheck.draw_states`, the
   cross-check's distribution; tau for forward dynamics is the arm's inverse
   dynamics at them) and writes them, once, to a states file that both timing
   drivers read, so both time the same inputs (``benchmarks/c/states_io.h``);
2. writes the arm's C with ``md.codegen(arm, dir, prefix=name)`` and compiles
   ``benchmarks/c/generated_timing.c`` with it; without ``md.codegen`` it says
   so and times Pinocchio alone;
3. compiles ``benchmarks/c/pinocchio_timing.cpp`` against the ``pin`` wheel's
   headers and libraries (:func:`benchmarks.codegen_pinocchio.pinocchio_flags` gives every flag and why),
   twice: with ``-DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION`` (RNEA, CRBA, ABA
   and the RNEA derivatives run the code compiled into the wheel's
   ``libpinocchio_default.so``: Pinocchio as shipped) and header-only (every
   algorithm compiled here, with ``-O2``, the generated C's first row).  That
   takes minutes (2 to 25 here, by the load), so the binaries are cached by
   the hash of their sources, flags and compiler under
   ``benchmarks/results/runs/cache/`` (ignored by git);
4. checks before timing: Pinocchio's C++ against manipdyn's Pinocchio engine
   (that the driver built the same model: URDF, gravity, armature) and the
   generated C against Pinocchio's C++, on every state, with the cross-check's
   measure ``max_k |a_k - b_k| / max(1, max_k |b_k|)``: tau, M and the RNEA
   derivatives to 1e-10, forward dynamics to the cross-check's 1e-9 (the error
   of ``D^-1 x`` grows with cond(D)).  A wrong answer is printed
   (``!!! WRONG ANSWER``), its row is not timed, and the exit status is 2;
5. times the drivers interleaved: in each of ``--outer`` rounds every binary
   runs once, in a rotated order, so load from other processes hits all alike.
   One run times the four calls in ``--inner`` rounds, each call over all the
   states as one block (``ns per call`` = block time / states).  Reported: the
   median over all blocks of all runs; the ratio generated / Pinocchio is the
   median over the outer rounds of the ratio of the two runs' medians (paired,
   as :func:`benchmarks.timing.paired_ratio`).

Rows: ``-O2`` for both sides, and the generated C rebuilt with ``-O3
-march=native`` (``--no-native`` skips it) against the same Pinocchio binaries:
Pinocchio is compiled with ``-O2`` only (:data:`benchmarks.codegen_pinocchio.PIN_OPT`, which says why).
Goals (issue 26): generated / Pinocchio <= 0.5 for RNEA, <= 0.5 for CRBA, <= 0.7
for ABA, <= 0.5 for the RNEA derivatives (moonshot 0.3 for RNEA); issue 34:
<= 0.5 for the ABA derivatives (``P_forward_dynamics_derivatives`` against
``computeABADerivatives``: ddq_dq, ddq_dv, Minv).  An arm with a friction law
(the bundled Panda) is timed on its rigid bodies (Pinocchio's C++ knows no law).  The
verdict is taken against the faster of the two Pinocchio builds.  Nothing is
asserted about time: a missed goal is reported, not an error.

Results are printed and written, atomically, to
``benchmarks/results/runs/<UTC time>-codegen/results.json`` (ignored by git;
or ``--out DIR``), with the machine, the compilers, their flags and the BLAS
configuration (which no C side uses, recorded as the other benchmarks do).
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

import manipdyn as md
from manipdyn.check.crosscheck import TOLERANCE, draw_states

from .codegen_pinocchio import (  # noqa: F401  (re-exported: the toolchain half of this benchmark)
    C_DIR, CACHE, HERE, PIN_OPT, Unavailable, build_generated, build_pinocchio, compiler_version, pin_prefix,
    pin_version, pinocchio_flags, pkg_config, portable, tool)
from .timing import publish

OPS = ("inverse_dynamics", "mass_matrix", "forward_dynamics", "inverse_dynamics_derivatives",
       "forward_dynamics_derivatives")
PIN_NAMES = {"inverse_dynamics": "rnea", "mass_matrix": "crba", "forward_dynamics": "aba",
             "inverse_dynamics_derivatives": "computeRNEADerivatives",
             "forward_dynamics_derivatives": "computeABADerivatives"}
#: the printed table's row names
LABELS = {"inverse_dynamics": "RNEA (inverse_dynamics)", "mass_matrix": "CRBA (mass_matrix)",
          "forward_dynamics": "ABA (forward_dynamics)", "inverse_dynamics_derivatives": "RNEA derivatives",
          "forward_dynamics_derivatives": "ABA derivatives"}
GOALS = {"inverse_dynamics": 0.5, "mass_matrix": 0.5, "forward_dynamics": 0.7, "inverse_dynamics_derivatives": 0.5,
         "forward_dynamics_derivatives": 0.5}
MOONSHOTS = {"inverse_dynamics": 0.3}
#: relative agreement required of the answers (the cross-check's measure); forward
#: dynamics gets the cross-check's own tolerance, since D^-1 x loses digits with cond(D)
REL_TOL = {"tau": 1e-10, "M": 1e-10, "qdd": TOLERANCE, "dtau_dq": 1e-10, "dtau_dqd": 1e-10,
           "ddq_dq": TOLERANCE, "ddq_dv": TOLERANCE, "Minv": TOLERANCE}
#: the lines of one state in a driver's DUMP file: (key, shape as multiples of n)
DUMP_ROWS = (("tau", 1), ("M", 2), ("qdd", 1), ("dtau_dq", 2), ("dtau_dqd", 2), ("ddq_dq", 2), ("ddq_dv", 2),
             ("Minv", 2))
#: the generated C's flags, one row each
OPT_ROWS = {"O2": ("-O2",), "O3-native": ("-O3", "-march=native")}
DEFAULT_ARMS = ("ur5", "panda")


# ---------------------------------------------------------------------------
# states, answers, runs
# ---------------------------------------------------------------------------
def load_arm(name):
    """The arm ``name``, on its rigid bodies (Pinocchio's C++ knows no friction law: a bundled
    arm that carries one, the Panda, is timed without it, on both sides)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        arm = md.load(name)
        if arm.friction_model is not None and isinstance(arm, md.Manipulator) and arm.transmission.is_diagonal:
            arm = md.Manipulator(arm.links, arm.convention, gravity=arm.gravity, name=arm.name)
        return arm


def pinocchio_urdf(arm) -> str:
    """The URDF text that manipdyn's Pinocchio engine reads for ``arm`` (the original
    file's, or the one written from a DH chain: urdf/NAME.urdf for a bundled arm)."""
    if arm.source_urdf is not None:
        if getattr(arm, "locked_joints", ()):
            raise Unavailable(f"{arm.name}: its URDF has joints off the chain (locked by manipdyn); "
                              "the C++ driver builds the whole tree, so it would time another model")
        return arm.source_urdf
    return md.to_urdf(arm)


def states_text(q, qd, qdd, tau, gravity, armature) -> str:
    """The drivers' states file (format: ``benchmarks/c/states_io.h``) for (count, n) arrays;
    every number in ``%.17g``, which round-trips float64 exactly."""
    q, qd, qdd, tau = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qd, qdd, tau))
    fmt = lambda x: " ".join(f"{v:.17g}" for v in np.ravel(x))   # noqa: E731
    lines = ["manipdyn-bench-states 1", f"n {q.shape[1]}", f"count {q.shape[0]}",
             f"gravity {fmt(gravity)}", f"armature {fmt(armature)}"]
    lines += [fmt(np.concatenate(row)) for row in zip(q, qd, qdd, tau)]
    return "\n".join(lines) + "\n"


def write_states(path: Path, arm, count: int, seed: int):
    """Draw ``count`` states of ``arm`` (the cross-check's draw), write the states file:
    returns (q, qd, qdd, tau), tau being the arm's inverse dynamics at them."""
    if not arm.transmission.is_diagonal:
        raise Unavailable(f"{arm.name}: a coupled drive's rotor inertia is not Pinocchio's armature")
    q, qd, qdd = draw_states(arm, count, seed)
    tau = arm.pinocchio.inverse_dynamics(q, qd, qdd)
    path.write_text(states_text(q, qd, qdd, tau, arm.gravity, arm.armature))
    return q, qd, qdd, tau


def read_dump(path: Path, n: int, count: int) -> dict:
    """A driver's DUMP file: dict of (count, ...) arrays, the keys of :data:`DUMP_ROWS`."""
    rows = [np.array(line.split(), dtype=float) for line in path.read_text().splitlines()]
    per = len(DUMP_ROWS)
    if len(rows) != per * count:
        raise RuntimeError(f"{path}: {len(rows)} lines, expected {per * count}")
    take = lambda k, shape: np.array([rows[per * i + k] for i in range(count)]).reshape(count, *shape)  # noqa: E731
    return {key: take(k, (n,) * dims) for k, (key, dims) in enumerate(DUMP_ROWS)}


def python_answers(arm, q, qd, qdd, tau) -> dict:
    """manipdyn's Pinocchio engine on the same states (the check of the C++ driver's model)."""
    P = arm.pinocchio
    dq, dqd = P.inverse_dynamics_derivatives(q, qd, qdd)
    a, b, c = P.forward_dynamics_derivatives(q, qd, tau)
    return {"tau": P.inverse_dynamics(q, qd, qdd), "M": P.mass_matrix(q),
            "qdd": P.forward_dynamics(q, qd, tau), "dtau_dq": dq, "dtau_dqd": dqd,
            "ddq_dq": a, "ddq_dv": b, "Minv": c}


def rel_errors(got: dict, ref: dict) -> dict:
    """The cross-check's measure per quantity: max over states of
    max|got - ref| / max(1, max|ref|) (NaN counts as infinitely wrong)."""
    out = {}
    for k, r in ref.items():
        g = got[k].reshape(len(r), -1)
        r = r.reshape(len(r), -1)
        with np.errstate(invalid="ignore"):
            e = np.abs(g - r).max(axis=1) / np.maximum(1.0, np.abs(r).max(axis=1))
        out[k] = float(np.max(np.where(np.isfinite(e), e, np.inf)))
    return out


def problems(errors: dict) -> list[str]:
    return [f"{k} differs by {e:.3g} relative (tolerance {REL_TOL[k]:g})"
            for k, e in errors.items() if not e <= REL_TOL[k]]


def run_driver(cmd: list[str]) -> list[dict]:
    """Run a driver once: its per-round ns per call, one dict op -> ns per round."""
    res = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise RuntimeError(f"{shlex.join(cmd)} failed ({res.returncode}): {res.stderr.strip()[-2000:]}")
    rounds = []
    for line in res.stdout.splitlines():
        words = line.split()
        if words and words[0] == "round":
            rounds.append({words[i]: float(words[i + 1]) for i in range(2, len(words), 2)})
    return rounds


def interleave(cands: dict, outer: int, inner: int) -> dict:
    """Run every candidate (name -> argv) once per outer round, in a rotated order.
    Returns name -> list (per outer round) of per-round dicts op -> ns."""
    names = list(cands)
    runs = {k: [] for k in names}
    for r in range(outer):
        for k in names[r % len(names):] + names[:r % len(names)]:
            runs[k].append(run_driver([*cands[k], str(inner), "1"]))
    return runs


def summarize(runs: dict, reference: str | None) -> dict:
    """name -> op -> {median_ns, q25_ns, q75_ns}; and for every candidate but the reference:
    ratio_to.<other> = median over outer rounds of (this run's median / the other's)."""
    out = {}
    for k, per_outer in runs.items():
        out[k] = {}
        for op in OPS:
            allv = np.array([rd[op] for o in per_outer for rd in o])
            out[k][op] = {"median_ns": float(np.median(allv)), "q25_ns": float(np.percentile(allv, 25)),
                          "q75_ns": float(np.percentile(allv, 75)), "blocks": int(allv.size)}
    if reference is not None:
        for other in runs:
            if other == reference:
                continue
            for op in OPS:
                ratios = [np.median([rd[op] for rd in a]) / np.median([rd[op] for rd in b])
                          for a, b in zip(runs[reference], runs[other])]
                out[reference][op][f"ratio_to_{other}"] = float(np.median(ratios))
    return out


# ---------------------------------------------------------------------------
# one arm
# ---------------------------------------------------------------------------
def bench_arm(name: str, work: Path, pin_bins: dict, opt_rows, count: int, outer: int, inner: int,
              seed: int, log=print) -> dict:
    """Check and time one arm: every row of ``opt_rows`` (label -> flags).

    ``pin_bins`` maps (row label, "library" | "header") to a Pinocchio driver.
    Returns the arm's results dict (errors, problems, per-row times and ratios).
    """
    arm = load_arm(name)
    folder = work / name
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / f"{name}.urdf"
    urdf.write_text(pinocchio_urdf(arm))
    states = folder / "states.txt"
    q, qd, qdd, tau = write_states(states, arm, count, seed)
    result = {"arm": name, "n": arm.n, "states": count, "seed": seed, "problems": [], "rows": {}}

    # Pinocchio's C++ must compute what manipdyn's Pinocchio engine computes (same model)
    expected = python_answers(arm, q, qd, qdd, tau)
    pin_cmd, checked = {}, {}
    for (label, kind), binary in pin_bins.items():
        if binary not in checked:        # the same binary serves several rows: check it once
            dump = folder / f"pinocchio-{kind}.dump"
            subprocess.run([str(binary), str(urdf), str(states), "1", "1", str(dump)], check=True,
                           capture_output=True)
            err = rel_errors(read_dump(dump, arm.n, count), expected)
            result.setdefault("pinocchio_cpp_vs_python", {})[kind] = err
            checked[binary] = bad = problems(err)
            result["problems"] += [f"Pinocchio's C++ ({kind}) against manipdyn's Pinocchio engine: {b}"
                                   for b in bad]
        if not checked[binary]:
            pin_cmd[(label, kind)] = [str(binary), str(urdf), str(states)]
    reference = expected          # pinocchio's own answers (equal to the C++'s, checked above)

    gen_dir = folder / "generated"
    generated = hasattr(md, "codegen")
    if generated:
        try:
            md.codegen(arm, gen_dir, prefix=name)
        except (ImportError, ValueError, OSError) as exc:   # a missing extra, a refused model
            generated = False
            result["generated"] = f"md.codegen failed ({type(exc).__name__}: {exc}): Pinocchio timed alone"
            log(f"!!! {name}: {result['generated']}")
    else:
        result["generated"] = "manipdyn has no codegen: Pinocchio timed alone"
    for label, opt in opt_rows.items():
        cands = {f"pinocchio-{kind}": cmd for (lb, kind), cmd in pin_cmd.items() if lb == label}
        row = {"flags": list(opt)}
        if generated:
            binary = folder / f"generated-{label}"
            row["generated_command"] = [c.replace(str(folder), "<run>")
                                        for c in portable(build_generated(gen_dir, name, opt, binary))]
            dump = folder / f"generated-{label}.dump"
            subprocess.run([str(binary), str(states), "1", "1", str(dump)], check=True, capture_output=True)
            err = rel_errors(read_dump(dump, arm.n, count), reference)
            row["generated_errors"] = err
            bad = problems(err)
            if bad:
                result["problems"] += [f"generated C ({label}) against Pinocchio: {b}" for b in bad]
            else:
                cands = {"generated": [str(binary), str(states)], **cands}
        if not cands:
            result["rows"][label] = row
            continue
        log(f"  {name} {label}: timing {', '.join(cands)} ({outer} interleaved runs x {inner} rounds "
            f"x {count} states)")
        runs = interleave(cands, outer, inner)
        row["times"] = summarize(runs, "generated" if "generated" in cands else None)
        result["rows"][label] = row
    return result


def verdicts(row: dict) -> dict:
    """op -> {ratio (against the faster Pinocchio build), goal, verdict}, when the row has generated C."""
    times = row.get("times", {})
    if "generated" not in times:
        return {}
    out = {}
    for op in OPS:
        g = times["generated"][op]
        ratios = {k[len("ratio_to_"):]: v for k, v in g.items() if k.startswith("ratio_to_")}
        if not ratios:
            continue
        worst = max(ratios.values())
        moon = MOONSHOTS.get(op)
        out[op] = {"ratio": worst, "ratios": ratios, "goal": GOALS[op], "moonshot": moon,
                   "verdict": ("moonshot" if moon is not None and worst <= moon
                               else "pass" if worst <= GOALS[op] else "miss")}
    return out


def environment(opt_rows) -> dict:
    """The machine (as benchmarks.run records it), the compilers and the toolchain's flags."""
    from .run import machine_info

    env = machine_info()
    cc, cxx = tool("CC", "cc"), tool("CXX", "c++")
    env.update({"cc": cc, "cc_version": compiler_version(cc), "cxx": cxx, "cxx_version": compiler_version(cxx),
                "generated_flags": {k: ["-std=c99", *v] for k, v in opt_rows.items()}})
    try:
        env["eigen"] = pkg_config("--modversion", "eigen3")
        env["urdfdom_headers"] = pkg_config("--modversion", "urdfdom_headers")
        env["pinocchio_flags"] = {"header": portable(pinocchio_flags(PIN_OPT, False)),
                                  "library": portable(pinocchio_flags(PIN_OPT, True))}
    except Unavailable as exc:
        env["toolchain"] = str(exc)
    return env


def print_table(results: list, log=print) -> None:
    log(f"\n{'arm':6s} {'flags':9s} {'call':24s} {'generated':>10s} {'pin hdr':>9s} {'pin .so':>9s} "
        f"{'gen/hdr':>7s} {'gen/.so':>7s} {'goal':>5s}  verdict")
    for r in results:
        for label, row in r["rows"].items():
            t = row.get("times", {})
            v = verdicts(row)
            for op in OPS:
                cell = lambda k: f"{t[k][op]['median_ns']:9.1f}" if k in t else f"{'-':>9s}"  # noqa: E731
                g = t.get("generated", {}).get(op, {})
                rat = lambda k: f"{g[f'ratio_to_{k}']:7.3f}" if f"ratio_to_{k}" in g else f"{'-':>7s}"  # noqa: E731
                verdict = v.get(op, {}).get("verdict", "-")
                log(f"{r['arm']:6s} {label:9s} {LABELS[op]:24s} {cell('generated'):>10s} "
                    f"{cell('pinocchio-header')} {cell('pinocchio-library')} {rat('pinocchio-header')} "
                    f"{rat('pinocchio-library')} {GOALS[op]:5.2f}  {verdict}")
    log("ns per call, median over blocks; flags: the generated C's; gen/hdr, gen/.so: paired ratios "
        "against Pinocchio compiled here header-only with -O2 (hdr) and against the wheel's compiled "
        "algorithms (.so); the verdict takes the larger ratio (the faster Pinocchio)")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.bench_codegen", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--arms", nargs="+", default=list(DEFAULT_ARMS))
    p.add_argument("--quick", action="store_true",
                   help="few states and rounds, -O2 only, Pinocchio as shipped only (its quickest build): "
                        "proves the pipeline runs; the times mean little")
    p.add_argument("--no-native", action="store_true", help="skip the row of the generated C at -O3 -march=native")
    p.add_argument("--states", type=int, default=None, help="states per file (default 256; quick 20)")
    p.add_argument("--outer", type=int, default=None, help="interleaved runs of each driver (default 11; quick 2)")
    p.add_argument("--inner", type=int, default=None, help="rounds inside one run (default 50; quick 3)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-library", action="store_true",
                   help="skip Pinocchio as shipped (the wheel's compiled algorithms); time the header-only build")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="folder of results.json (default benchmarks/results/runs/<UTC time>-codegen)")
    p.add_argument("--no-write", action="store_true", help="print only")
    args = p.parse_args(argv)
    count = args.states or (20 if args.quick else 256)
    outer = args.outer or (2 if args.quick else 11)
    inner = args.inner or (3 if args.quick else 50)
    codegen = hasattr(md, "codegen")
    if not codegen:
        print("manipdyn has no codegen (md.codegen): timing Pinocchio's C++ alone")
    # the second row rebuilds only the generated C: without it, it would repeat the first
    opt_rows = {"O2": OPT_ROWS["O2"]} if (args.quick or args.no_native or not codegen) else dict(OPT_ROWS)
    env = environment(opt_rows)
    try:
        pin_bins = {}
        # one build of each kind (PIN_OPT), timed in every row
        if not args.quick:
            hdr = build_pinocchio(PIN_OPT, instantiation=False)[0]
            pin_bins.update({(label, "header"): hdr for label in opt_rows})
        if not args.no_library:
            lib = build_pinocchio(PIN_OPT, instantiation=True)[0]
            pin_bins.update({(label, "library"): lib for label in opt_rows})
    except Unavailable as exc:
        print(f"cannot build Pinocchio's C++ driver: {exc}", file=sys.stderr)
        return 2
    results = []
    with tempfile.TemporaryDirectory(prefix="bench_codegen-") as tmp:
        for name in args.arms:
            try:
                r = bench_arm(name, Path(tmp), pin_bins, opt_rows, count, outer, inner, args.seed)
            except Unavailable as exc:
                print(f"{name}: {exc}", file=sys.stderr)
                return 2
            for prob in r["problems"]:
                print(f"!!! WRONG ANSWER ({name}): {prob}", file=sys.stderr, flush=True)
            for row in r["rows"].values():
                row["verdicts"] = verdicts(row)
            results.append(r)
    env["loadavg_end"] = list(os.getloadavg())
    print_table(results)
    print(f"load average {env['loadavg_start']} -> {env['loadavg_end']}")
    publish(args, env, {"goals": GOALS, "moonshots": MOONSHOTS, "tolerances": REL_TOL, "quick": args.quick,
                        "states": count, "outer": outer, "inner": inner, "results": results}, "codegen")
    return 2 if any(r["problems"] for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
