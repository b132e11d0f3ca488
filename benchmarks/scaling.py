"""How the per-call costs grow with the number of joints: ``scaling`` in the results, ``scaling.png``.

Part of ``python -m benchmarks.run`` (section 4).  Chains of n = 2 ... 24 joints are timed on raw
Pinocchio, the fast path and the trace form; the exponents of ``time ~ n^k`` are fitted on the
larger arms and drawn on a log-log figure.
"""

from __future__ import annotations

import functools
import os

import numpy as np

from manipdyn._support.files import atomic_write

from . import arm_set as bench_arms_mod
from .checks import log, loud, num, raw_pinocchio, states, wrong_side
from .timing import interleaved

SCALING_SERIES = {
    "pinocchio rnea": "raw pin.rnea, one state",
    "pinocchio crba": "raw pin.crba, one state",
    "pinocchio D+h+g": "raw crba + rnea(g=0) + gravity, one state",
    "manipdyn inverse_dynamics": "fast path, one state",
    "manipdyn mass_matrix": "fast path, one state",
    "trace D+h+g per state": "trace form dynamics_terms, per state in a batch",
    "trace inverse_dynamics": "trace form, one state",
}


def run_scaling(cfg, rng, out_dir, plot=True):
    log(f"== 4. scaling with the number of joints, n = {list(cfg.scaling_n)} (seeded random chains)")
    series = {k: [] for k in SCALING_SERIES}
    ns, problems = [], []
    for n in cfg.scaling_n:
        arm = bench_arms_mod.random_chain(n, seed=1000 + n)
        raw = raw_pinocchio(arm)
        L = arm.lagrange
        one = {k: v[0] for k, v in states(arm, rng, 1).items()}
        Bs = states(arm, rng, cfg.scaling_batch)
        q, qd, qdd = one["q"], one["qd"], one["qdd"]
        # check before timing: fast path vs trace form
        a, b = arm.inverse_dynamics(q, qd, qdd), L.inverse_dynamics(q, qd, qdd)
        Da, Db = arm.mass_matrix(q), L.mass_matrix(q)
        err = max(np.abs(a - b).max() / max(np.abs(b).max(), 1e-9), np.abs(Da - Db).max() / np.abs(Db).max())
        if not err <= 1e-8:
            wrong = wrong_side(arm, q, qd, qdd, (a, Da), (b, Db))
            loud(f"WRONG ANSWER ({wrong}) scaling n={n}: the fast path (Pinocchio) and the trace form "
                 f"differ by {err:.2e} relative; size skipped")
            problems.append({"n": n, "rel_diff": num(err)})
            continue
        P = functools.partial
        fns = {
            "pinocchio rnea": P(raw["inverse_dynamics"], q, qd, qdd),
            "pinocchio crba": P(raw["mass_matrix"], q),
            "pinocchio D+h+g": P(raw["dynamics_terms"], q, qd),
            "manipdyn inverse_dynamics": P(arm.inverse_dynamics, q, qd, qdd),
            "manipdyn mass_matrix": P(arm.mass_matrix, q),
            "trace D+h+g per state": P(L.dynamics_terms, Bs["q"], Bs["qd"]),
            "trace inverse_dynamics": P(L.inverse_dynamics, q, qd, qdd),
        }
        res = interleaved(fns, cfg.scaling_rounds, cfg.scaling_target_s,
                          per_call_scale={"trace D+h+g per state": cfg.scaling_batch})
        ns.append(n)
        for k in series:
            series[k].append(res[k].median)
        log(f"   n={n:<3} " + "  ".join(f"{k.split()[0][:5]}/{k.split()[1][:9]}={res[k].median * 1e6:.1f}"
                                       for k in series))
    exps = {}
    nn = np.array(ns, dtype=float)
    for k, ts in series.items():
        t = np.array(ts)
        e = {}
        if len(nn) >= 2:
            e["all"] = float(np.polyfit(np.log(nn), np.log(t), 1)[0])
            e["all_range"] = [int(nn.min()), int(nn.max())]
        tail = nn >= 8
        if tail.sum() >= 2:
            e["tail"] = float(np.polyfit(np.log(nn[tail]), np.log(t[tail]), 1)[0])
            e["tail_range"] = [int(nn[tail].min()), int(nn[tail].max())]
        exps[k] = e
    out = {"n": ns, "median_s": series, "labels": SCALING_SERIES, "exponents": exps,
           "batch": cfg.scaling_batch, "problems": problems, "plot": None}
    if plot:
        out["plot"], out["plot_skipped"] = plot_scaling(ns, series, exps, out_dir)
    else:
        out["plot_skipped"] = "--no-plot"
    if out.get("plot_skipped"):
        log(f"   plot skipped: {out['plot_skipped']}")
    return out


def plot_scaling(ns, series, exps, out_dir):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except Exception as exc:
        return None, f"matplotlib not installed ({type(exc).__name__}); pip install -e '.[bench]' for the plot"
    if len(ns) < 2:
        return None, "fewer than two sizes"
    fig, ax = plt.subplots(figsize=(10, 5))
    for k, ts in series.items():
        e = exps[k].get("tail", exps[k].get("all"))
        ax.loglog(ns, np.array(ts) * 1e6, "o-", label=f"{k}  (~n^{e:.2f})", ms=4)
    ax.set_xlabel("number of joints n")
    ax.set_ylabel("time per state (microseconds)")
    ax.set_title("manipdyn: cost vs number of joints (random DH chains)")
    ax.set_xticks(ns)
    ax.set_xticklabels([str(n) for n in ns])
    ax.grid(True, which="both", alpha=0.3)
    # the legend beside the axes, never over a line (the curves span the whole height)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
              title="per state, fitted slope", title_fontsize=8)
    fig.tight_layout()
    path = os.path.join(out_dir, "scaling.png")
    try:
        atomic_write(path, lambda fh: fig.savefig(fh, format="png", dpi=110), binary=True)
    finally:
        plt.close(fig)
    return "scaling.png", None  # relative to the results folder: no machine paths in results

