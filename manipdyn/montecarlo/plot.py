"""The figure of a study: empirical CDFs of the per-run figures, one curve per controller.

Layer: 7 (applications).
"""

from __future__ import annotations

import numpy as np


from ..control.demo import CONTROLLERS
from ..control.plots import pyplot, save_figure

__all__ = ["plot_report", "pyplot"]


def plot_report(report, path: str) -> None:
    """Write ``path`` (format from its extension; atomically): one panel per per-run figure of the report."""
    plt = pyplot()
    metrics = report.metrics
    fig, axes = plt.subplots(1, len(metrics), figsize=(5 * len(metrics), 4.2))
    for ax, (m, (desc, unit)) in zip(axes, metrics.items()):
        for key in report.study.controllers:
            v = np.sort([r[m] for r in report.per_run
                         if r["controller"] == key and not r["diverged"] and r[m] is not None])
            if len(v) == 0:
                continue
            ax.step(v, np.arange(1, len(v) + 1) / len(v), where="post",
                    label=f"{CONTROLLERS.get(key, key)}"
                          + (f" ({report.controllers[key]['diverged']} diverged)"
                             if report.controllers[key]["diverged"] else ""))
        ax.set_xscale("log")
        ax.set_xlabel(f"{m.replace('_', ' ')} ({unit})")
        ax.set_title(desc, fontsize=9)
        ax.set_ylim(0, 1.02)
        ax.grid(True, alpha=0.3, which="both")
    axes[0].set_ylabel("fraction of runs")
    axes[0].legend(fontsize=8, loc="lower right")
    s = report.study
    fig.suptitle(f"{s.model[3]}: {s.runs} runs, seed {s.seed}, demo path {s.duration:g} s at {1 / s.dt:g} Hz")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
