"""Spatial algebra on nested lists of CasADi SX (or numbers): 3-vectors, 3x3 rotations, rigid bodies.

Layer 3 (engines: c), the generated-C engine.  The pieces :mod:`manipdyn.engines.c.graph`
and :mod:`manipdyn.engines.c.derivatives` write their algorithms with: plain Python
lists, so that a constant zero (an axis entry, a snapped rounding residue) removes the
products it would feed before CasADi sees them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SNAP", "snap", "cross", "mv", "mtv", "add", "sub", "scale", "matmul3", "Body"]

#: entries of rotations, axes (unit) and translations (m) under this magnitude are rounding residue: 0
SNAP = 1e-15


def snap(a) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a[np.abs(a) < SNAP] = 0.0
    return a


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def mv(E, x):
    """3x3 (nested lists) times a 3-vector."""
    return [E[r][0] * x[0] + E[r][1] * x[1] + E[r][2] * x[2] for r in range(3)]


def mtv(E, x):
    """E^T x."""
    return [E[0][c] * x[0] + E[1][c] * x[1] + E[2][c] * x[2] for c in range(3)]


def add(a, b):
    return [x + y for x, y in zip(a, b)]


def sub(a, b):
    return [x - y for x, y in zip(a, b)]


def scale(s, a):
    return [s * x for x in a]


class Body:
    """10 inertial parameters (m, h = m c, I about the origin, tensor sign) of one body."""

    def __init__(self, p):
        self.m = p[0]
        self.h = [p[1], p[2], p[3]]
        ixx, ixy, iyy, ixz, iyz, izz = p[4:10]
        self.I = [[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]

    def times(self, w, v):
        """Spatial inertia times motion ``(w, v)``: force ``(I w + h x v, m v - h x w)``."""
        return add(mv(self.I, w), cross(self.h, v)), sub(scale(self.m, v), cross(self.h, w))

    def to_parent(self, E, p):
        """The same body seen from the parent frame (child -> parent by ``E``, origin at ``p``)."""
        y = mv(E, self.h)                                   # E h
        EI = [mv(E, [self.I[0][c], self.I[1][c], self.I[2][c]]) for c in range(3)]   # columns of E I
        # I' = E I E^T - m [p]x[p]x - [p]x[y]x - [y]x[p]x, with -[a]x[b]x = (a.b) 1 - b a^T: symmetric,
        # so the upper triangle is written and mirrored (the graph would hold both triangles otherwise)
        pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
        py = p[0] * y[0] + p[1] * y[1] + p[2] * y[2]
        I = [[None] * 3 for _ in range(3)]
        for r in range(3):
            for c in range(r, 3):
                I[r][c] = I[c][r] = (sum(EI[k][r] * E[c][k] for k in range(3))
                                     + self.m * ((pp if r == c else 0.0) - p[c] * p[r])
                                     + 2.0 * (py if r == c else 0.0) - y[c] * p[r] - p[c] * y[r])
        out = Body([self.m, 0, 0, 0, 0, 0, 0, 0, 0, 0])
        out.h = add(y, scale(self.m, p))
        out.I = I
        return out

    def plus(self, other):
        out = Body([self.m + other.m, 0, 0, 0, 0, 0, 0, 0, 0, 0])
        out.h = add(self.h, other.h)
        out.I = [[self.I[r][c] + other.I[r][c] for c in range(3)] for r in range(3)]
        return out


def matmul3(A, B):
    return [[sum(A[r][k] * B[k][c] for k in range(3)) for c in range(3)] for r in range(3)]
