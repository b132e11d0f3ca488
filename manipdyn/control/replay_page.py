"""The figure and the HTML page of a replay (``manipdyn replay --plot``, ``--report``).

Layer 6 (control): :class:`manipdyn.control.replay.ReplayResult` draws and writes through these.
"""

from __future__ import annotations

import math
import os

import numpy as np

from .._support.errors import ModelError

#: the label of the row without a model, the guess ``q_k + H qd_k``
BASELINE = "constant velocity"

__all__ = ["figure", "write_page", "BASELINE"]


def figure(result):
    """The q error against the horizon per joint, one line per model (a matplotlib figure)."""
    from .._support.figures import pyplot

    plt = pyplot()
    n = len(result.joint_types)
    cols = min(4, n + 1)
    rows = math.ceil((n + 1) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.6 * rows), squeeze=False)
    ms = np.array(result.horizons) * 1e3
    for k, ax in enumerate(axes.flat):
        if k > n:
            ax.axis("off")
            continue
        for lab in [*result.labels, BASELINE]:
            y = result.pooled(lab) if k == 0 else result.q_rms[lab][:, k - 1]
            ax.plot(ms, y, "o-" if lab != BASELINE else "k--", label=lab, ms=3)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title("pooled" if k == 0 else f"joint {k}", fontsize=9)
        ax.set_xlabel("horizon (ms)", fontsize=8)
        ax.set_ylabel(f"q error RMS ({result._units('q')})", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle("replay: q error at the horizon, RMS over start states (log-log axes)", fontsize=10)
    fig.tight_layout()
    return fig


def write_page(result, path, command=None) -> str:
    """The page of :meth:`manipdyn.control.replay.ReplayResult.report_html`, written to ``path``."""
    from .._support import html as H

    n = len(result.joint_types)
    parts = [H.section("What was replayed", H.facts([
        ("command", command or "(library call) manipdyn.replay(...)"), ("logs", ", ".join(result.logs)),
        ("start states", f"{result.starts}, every {result.every} samples of {result.dt * 1e3:.4g} ms"),
        ("simulator", result.simulator + (f" ({result.mujoco_plant} plant)" if result.simulator == "mujoco" else "")),
        ("integrator", "; ".join(result.steppers())),
        ("manipdyn", H.version())])),
        # one box per model, as the command prints one line each; orange where it does not beat the guess
        H.section("Verdict", *[H.verdict(line, "warn" if "no better than the constant-velocity guess" in line else "ok")
                               for line in result.verdict().splitlines()])]
    for what in ("q", "qd"):
        data = result.q_rms if what == "q" else result.qd_rms
        for h, Hs in enumerate(result.horizons):
            labels = [*result.labels, BASELINE]
            rows = [[lab, *data[lab][h].tolist(), float(result.pooled(lab, what)[h])] for lab in labels]
            best = set()
            if len(result.labels) > 1:
                for j in range(n):
                    i = int(np.argmin([data[lab][h, j] for lab in result.labels]))
                    best.add((i, j + 1))
            parts.append(H.section(f"{what} error at {Hs * 1e3:g} ms ({result._units(what)})", H.table(
                ["model", *[f"j{j + 1}" for j in range(n)], "pooled"], rows, best=best,
                name=f"{what}_{Hs:g}"), level=3))
    try:
        parts.append(H.section("Figure", H.figure(figure(result), alt="q error against the horizon per joint",
                                                  caption="RMS over the start states, log-log axes")))
    except ModelError:          # no matplotlib: the tables say it all
        pass
    if result.notes:
        parts.append(H.section("Notes", H.bullets(result.notes)))
    H.write_page(os.fspath(path), H.page("Replay against the log", ", ".join(result.labels), parts))
    return os.fspath(path)
