"""The figure of a study: empirical CDFs of the per-run figures, one curve per controller.

Layer 6 (control: montecarlo).
"""

from __future__ import annotations

import numpy as np

from .identified import plant_source


from ..demo import CONTROLLERS
from ..._support.figures import pyplot, save_figure
from ..plots import plain_log_ticks

__all__ = ["plot_report", "draw_report", "pyplot"]


def plot_report(report, path: str) -> None:
    """Write ``path`` (format from its extension; atomically): one panel per per-run figure
    of the report, two panels a row, and the legend in a cell of its own (never over a curve)."""
    plt = pyplot()
    fig = draw_report(report)
    save_figure(fig, path)
    plt.close(fig)


def draw_report(report, title: bool = True):
    """The figure of :func:`plot_report` (a matplotlib Figure; ``title``: the study in its title)."""
    plt = pyplot()
    metrics = report.metrics
    ncols = 2
    nrows = (len(metrics) + 1 + ncols - 1) // ncols          # + 1: the legend's cell
    fig, grid = plt.subplots(nrows, ncols, figsize=(10, 3.9 * nrows), squeeze=False)
    cells = list(grid.reshape(-1))
    handles = {}
    for ax, (m, (desc, unit)) in zip(cells, metrics.items()):
        for key in report.study.controllers:
            v = np.sort([r[m] for r in report.per_run
                         if r["controller"] == key and not r["diverged"] and r[m] is not None])
            if len(v) == 0:
                continue
            (line,) = ax.step(v, np.arange(1, len(v) + 1) / len(v), where="post",
                              color=f"C{list(CONTROLLERS).index(key) if key in CONTROLLERS else 0}")
            handles.setdefault(key, line)
        ax.set_xscale("log")
        plain_log_ticks(ax.xaxis)
        lo, hi = ax.get_xlim()
        if 0 < lo and hi / lo < 3:       # under a factor 3 no power-of-ten tick falls inside: a linear axis
            ax.set_xscale("linear")
            ax.set_xlim(lo, hi)
        ax.set_xlabel(f"{m.replace('_', ' ')} ({unit}, {ax.get_xscale()} scale)")
        ax.set_ylabel("fraction of runs")
        ax.set_title(desc, fontsize=9)
        ax.set_ylim(0, 1.02)
        ax.grid(True, alpha=0.3, which="both")
    legend_cell = cells[len(metrics)]
    legend_cell.axis("off")
    labels = [f"{CONTROLLERS.get(k, k)}" + (f" ({report.controllers[k]['diverged']} diverged)"
                                              if report.controllers[k]["diverged"] else "")
              for k in handles]
    legend_cell.legend(list(handles.values()), labels, loc="center", fontsize=10, title="controller",
                       frameon=False)
    for ax in cells[len(metrics) + 1:]:
        ax.axis("off")
    s = report.study
    if title:
        fig.suptitle(f"{s.model[3]}: {s.runs} runs, seed {s.seed}, demo path {s.duration:g} s at {1 / s.dt:g} Hz\n"
                     f"{plant_source(s)}", fontsize=10)
    fig.tight_layout()
    return fig
