"""Figures of tracking runs (matplotlib, the ``plot`` extra).

Layer 6 (control).  Every figure is written atomically.
"""

from __future__ import annotations

import math

import os

import numpy as np

from .._support.errors import ModelError
from .._support.figures import PLOT_INSTALL, pyplot, save_figure

__all__ = ["PLOT_INSTALL", "pyplot", "save_figure", "plot_single", "plot_compare", "plain_log_ticks"]


def _units(arm):
    pr = [t == "prismatic" for t in arm.joint_types]
    return (["m" if p else "rad" for p in pr], ["N" if p else "N m" for p in pr])


def plain_log_ticks(axis) -> None:
    """Tick labels of a log axis as plain numbers (``60``, ``0.002``), never ``6x10^1``.  Minor ticks
    are labelled where the major ones alone would leave too few labels: at 2, 3 and 5 times a power
    of ten when the axis spans under two decades, and every one when it spans under a factor 3.
    An axis narrower than a factor 3 (peak torques of 80 to 120 N m) also gets ticks at tenths of a
    power of ten (110, 120, ...), labelled at a step that leaves at most 8 labels, so no stretch of
    it above a power of ten is left without a number."""
    import numpy as np
    from matplotlib.ticker import FuncFormatter, LogLocator

    lo0, hi0 = sorted(axis.get_view_interval())
    if lo0 > 0 and hi0 / lo0 < 3.0:
        axis.set_minor_locator(LogLocator(base=10.0, subs=np.arange(1.0, 10.0, 0.1), numticks=200))

    def minor(v, _pos):
        lo, hi = sorted(axis.get_view_interval())
        if v <= 0 or lo <= 0 or hi / lo >= 100.0:
            return ""
        mantissa = v / 10.0 ** math.floor(math.log10(v) + 1e-9)
        if hi / lo >= 3.0:
            wanted = (2.0, 3.0, 5.0)
            return f"{v:.6g}" if any(abs(mantissa - m) < 1e-6 for m in wanted) else ""
        # the smallest round step (1, 2 or 5 times a power of ten) leaving at most 8 labels
        power = 10.0 ** math.floor(math.log10(hi - lo))
        step = next(s * power / 10.0 for s in (1.0, 2.0, 5.0, 10.0, 20.0, 50.0)
                    if (hi - lo) / (s * power / 10.0) <= 8)
        return f"{v:.6g}" if abs(v / step - round(v / step)) < 1e-6 else ""

    axis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:.6g}"))
    axis.set_minor_formatter(FuncFormatter(minor))


def _unit_label(units) -> str:
    """One unit for an axis: ``"rad"``, or ``"rad or m"`` when the joints mix them."""
    return " or ".join(dict.fromkeys(units))


def plot_single(log, arm, title: str, path: str) -> None:
    """Per-joint tracking error and torque against time."""
    plt = pyplot()
    fig, (ax_e, ax_t) = plt.subplots(2, 1, figsize=(10, 7.5), sharex=True)
    eu, tu = _units(arm)
    for i in range(arm.n):
        ax_e.plot(log.t, log.e[:, i], lw=1.2, label=f"joint {i + 1} ({eu[i]})")
        ax_t.plot(log.t, log.tau[:, i], lw=1.2, label=f"joint {i + 1} ({tu[i]})")
    ax_e.set_ylabel(f"tracking error  q_d - q ({_unit_label(eu)})")
    ax_e.axhline(0.0, color="k", lw=0.5)
    ax_t.set_ylabel(f"joint torque ({_unit_label(tu)})")
    ax_t.set_xlabel("time (s)")
    for ax in (ax_e, ax_t):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), fontsize=8, ncol=6, frameon=False)
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def plot_compare(logs: dict, arm, title: str, path: str) -> None:
    """Controllers side by side: ``|e(t)|`` over time, RMS error and peak torque per joint."""
    plt = pyplot()
    fig = plt.figure(figsize=(11, 9))
    gs = fig.add_gridspec(2, 2, height_ratios=[1.2, 1.0])
    ax_n = fig.add_subplot(gs[0, :])
    ax_r = fig.add_subplot(gs[1, 0])
    ax_p = fig.add_subplot(gs[1, 1])
    joints = np.arange(1, arm.n + 1)
    ok = {k: v for k, v in logs.items() if v is not None and not isinstance(v, str)}
    width = 0.8 / max(1, len(ok))
    for c, (label, log) in enumerate(ok.items()):
        norm = np.linalg.norm(log.e, axis=1)
        ax_n.semilogy(log.t, np.maximum(norm, 1e-12), lw=1.2, label=label)
        # markers, not bars: on a log axis a bar's length is measured from an arbitrary bottom
        x = joints + (c - (len(ok) - 1) / 2) * width
        ax_r.plot(x, log.rms_error(), "o", ms=6, color=f"C{c}", label=label)
        ax_p.plot(x, log.peak_torque(), "o", ms=6, color=f"C{c}", label=label)
    for label, v in logs.items():
        if isinstance(v, str):
            ax_n.plot([], [], " ", label=f"{label}: {v}")
    floors = [np.percentile(np.linalg.norm(lg.e, axis=1)[lg.t >= 0.1 * lg.t[-1]], 1) for lg in ok.values()]
    if floors and min(floors) > 0:   # the error starts at 0: do not spend decades on that
        ax_n.set_ylim(bottom=0.3 * min(floors))
    eu, tu = _units(arm)
    ax_n.set_ylabel(f"|q_d - q|, norm over joints ({_unit_label(eu)})")
    ax_n.set_xlabel("time (s)")
    ax_n.legend(fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=4, frameon=False)
    # both on log axes: a wrist's torques are 10 to 100 times smaller than a shoulder's
    ax_r.set_yscale("log")
    ax_p.set_yscale("log")
    for ax in (ax_r, ax_p):
        plain_log_ticks(ax.yaxis)
    ax_r.set_ylabel(f"RMS tracking error ({_unit_label(eu)})")
    ax_p.set_ylabel(f"peak |torque| ({_unit_label(tu)})")
    for ax in (ax_r, ax_p):
        ax.set_xlabel("joint")
        ax.set_xticks(joints)
    for ax in (ax_n, ax_r, ax_p):
        ax.grid(True, alpha=0.3, which="both")
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
