"""Figures of tracking runs (matplotlib, the ``plot`` extra).

Layer 6 (control).  Every figure is written atomically.
"""

from __future__ import annotations

import os

import numpy as np

from .._support.errors import ModelError
from .._support.figures import PLOT_INSTALL, pyplot, save_figure

__all__ = ["PLOT_INSTALL", "pyplot", "save_figure", "plot_single", "plot_compare"]


def _units(arm):
    pr = [t == "prismatic" for t in arm.joint_types]
    return (["m" if p else "rad" for p in pr], ["N" if p else "N m" for p in pr])


def plot_single(log, arm, title: str, path: str) -> None:
    """Per-joint tracking error and torque against time."""
    plt = pyplot()
    fig, (ax_e, ax_t) = plt.subplots(2, 1, figsize=(10, 7.5), sharex=True)
    eu, tu = _units(arm)
    for i in range(arm.n):
        ax_e.plot(log.t, log.e[:, i], lw=1.2, label=f"joint {i + 1} ({eu[i]})")
        ax_t.plot(log.t, log.tau[:, i], lw=1.2, label=f"joint {i + 1} ({tu[i]})")
    ax_e.set_ylabel("tracking error  q_d - q")
    ax_e.axhline(0.0, color="k", lw=0.5)
    ax_t.set_ylabel("joint torque")
    ax_t.set_xlabel("time (s)")
    for ax in (ax_e, ax_t):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), fontsize=8, ncol=6, frameon=False)
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def plot_compare(logs: dict, arm, title: str, path: str) -> None:
    """Controllers side by side: |e(t)| over time, RMS error and peak torque per joint."""
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
        ax_r.bar(joints + (c - (len(ok) - 1) / 2) * width, log.rms_error(), width, label=label)
        ax_p.bar(joints + (c - (len(ok) - 1) / 2) * width, log.peak_torque(), width, label=label)
    for label, v in logs.items():
        if isinstance(v, str):
            ax_n.plot([], [], " ", label=f"{label}: {v}")
    floors = [np.percentile(np.linalg.norm(lg.e, axis=1)[lg.t >= 0.1 * lg.t[-1]], 1) for lg in ok.values()]
    if floors and min(floors) > 0:   # the error starts at 0: do not spend decades on that
        ax_n.set_ylim(bottom=0.3 * min(floors))
    ax_n.set_ylabel("|q_d - q|  (norm over joints)")
    ax_n.set_xlabel("time (s)")
    ax_n.legend(fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=4, frameon=False)
    ax_r.set_yscale("log")
    ax_r.set_ylabel("RMS tracking error (rad or m)")
    ax_p.set_ylabel("peak |torque| (N m or N)")
    for ax in (ax_r, ax_p):
        ax.set_xlabel("joint")
        ax.set_xticks(joints)
    for ax in (ax_n, ax_r, ax_p):
        ax.grid(True, alpha=0.3, which="both")
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
