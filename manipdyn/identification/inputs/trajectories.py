"""Which runs repeat one trajectory: the unit a band and an option are held out by.

Layer 5 (identification), room ``inputs``.

Several logs of one identification are worth as much as the trajectories they hold.  Two
runs of the same excitation (a repeat, as the KUKA LWR4+ runs 1 and 2: positions within
6 mrad) differ only by the arm's repeatability and its noise; a fit on one predicts the
other about as well as it predicts itself, so holding one out says nothing about a new
trajectory.  The held-out runs of :mod:`..uncertainty.bands`, :mod:`.smoothing` and
:mod:`..estimation.selection` are therefore the **groups** of runs that repeat one
trajectory, found here from the positions alone (the torques are what the fits predict).

The test (:func:`repeat_groups`)
--------------------------------
Each run's ``q`` (N, n) is interpolated onto a grid of :data:`GRID_DT` s.  Two runs repeat
one trajectory when, at the best time shift (every shift with an overlap of at least
:data:`MIN_OVERLAP` of the shorter run is tried), the RMS distance of their positions over
the overlap is under :data:`REPEAT_DISTANCE` of the positions' own spread (the RMS of
``q - mean q`` of both runs, over every joint).  A repeat is within a few percent (the LWR4's
runs 1 and 2: 1 %); two different excitations are tens of percent apart (its runs 1 and 3:
over 50 %), so the threshold is far from both.  Groups are the connected sets of repeats.
"""

from __future__ import annotations

import numpy as np

__all__ = ["repeat_groups", "group_labels", "describe_groups", "REPEAT_DISTANCE", "MIN_OVERLAP", "GRID_DT"]

#: two runs repeat one trajectory when their positions' RMS distance is under this fraction of their spread
REPEAT_DISTANCE = 0.1
#: the shortest overlap compared, as a fraction of the shorter run
MIN_OVERLAP = 0.5
#: the comparison grid's step, s
GRID_DT = 0.05


def _grid(t, q):
    t = np.asarray(t, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    if len(t) < 2 or not t[-1] > t[0]:
        return q[:1]
    g = np.arange(t[0], t[-1], GRID_DT)
    return np.stack([np.interp(g, t, q[:, j]) for j in range(q.shape[1])], axis=1)


def _distance(a, b) -> float:
    """The smallest RMS distance of the paths ``a``, ``b`` (on one grid) over the time shifts, over their spread."""
    if len(a) > len(b):
        a, b = b, a
    spread = np.sqrt(np.mean(np.concatenate([a - a.mean(axis=0), b - b.mean(axis=0)]) ** 2))
    if not spread > 0:
        return 0.0 if np.allclose(a.mean(axis=0), b.mean(axis=0)) else np.inf
    least = max(2, int(np.ceil(MIN_OVERLAP * len(a))))
    best = np.inf
    for shift in range(-(len(a) - least), len(b) - least + 1):
        lo_a, lo_b = max(0, -shift), max(0, shift)
        m = min(len(a) - lo_a, len(b) - lo_b)
        if m < least:
            continue
        d = float(np.sqrt(np.mean((a[lo_a:lo_a + m] - b[lo_b:lo_b + m]) ** 2)))
        best = min(best, d)
    return best / spread


def repeat_groups(runs) -> list[list[int]]:
    """The runs (0-based) grouped by the trajectory they repeat (module docstring), in order of first run.

    ``runs``: a sequence of ``(t, q)``, ``t`` (N,) s and ``q`` (N, n) rad (or m).
    """
    paths = [_grid(t, q) for t, q in runs]
    k = len(paths)
    parent = list(range(k))

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i

    for i in range(k):
        for j in range(i + 1, k):
            if root(i) != root(j) and _distance(paths[i], paths[j]) < REPEAT_DISTANCE:
                parent[root(j)] = root(i)
    groups: dict[int, list[int]] = {}
    for i in range(k):
        groups.setdefault(root(i), []).append(i)
    return sorted(groups.values(), key=lambda g: g[0])


def group_labels(segments, groups) -> np.ndarray:
    """The group (0-based) of every stacked sample: ``segments`` the runs' sample counts, ``groups`` of
    :func:`repeat_groups`."""
    of_run = {r: g for g, members in enumerate(groups) for r in members}
    return np.concatenate([np.full(int(c), of_run[r], dtype=np.int64) for r, c in enumerate(segments)])


def describe_groups(groups, names) -> str:
    """A sentence naming the runs held out together (``names`` per run)."""
    parts = [" and ".join(str(names[r]) for r in g) for g in groups]
    repeats = [p for p, g in zip(parts, groups) if len(g) > 1]
    head = (f"{len(groups)} distinct trajectories among {len(names)} runs" if len(groups) > 1
            else f"one trajectory in {len(names)} runs")
    return (head + ("; held out together as repeats of one trajectory (positions within "
                    f"{100 * REPEAT_DISTANCE:g} % of their spread): " + "; ".join(repeats) if repeats else
                    ": no run repeats another"))
