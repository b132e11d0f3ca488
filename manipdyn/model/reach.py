"""The arm's reach: inverse kinematics, and the wrench the environment applies to the tool.

Layer 1 (model), part of :class:`manipdyn.model.arm.Arm` (through :class:`ReachCalls`).  As
with the rest of the arm's calls (:mod:`manipdyn.model.arm_calls`), the model computes no
kinematics itself: the poses and Jacobians come from an engine (Pinocchio unless
``engine=`` names another), so both engines answer and can be held to each other.

Inverse kinematics (:meth:`ReachCalls.inverse_kinematics`) is damped least squares
(Levenberg-Marquardt with Sugihara's damping ``lambda = E + lambda_bar``,
where ``E = |e|^2 / 2``): each step solves ``(J^T J + lambda I) dq = J^T e``
for the pose error ``e = [p* - p; log(R* R^T)]`` (metres and radians, base-frame
axes, ``J`` the ``jacobian`` in base axes) and is projected onto the joint limits.
A run that stalls is restarted from seeded random joint positions within the limits,
so the answer does not depend on the call's history.  A pose no start reaches raises
:class:`manipdyn.UnreachablePoseError`, which says how far the best start got.

The tool wrench ``f_tool = [f; m]`` (N, N m) is what the environment applies to the
tool, in base-frame axes at the tool origin: the joints then need
``tau = ID(q, qd, qdd) - J(q)^T f_tool`` (virtual work, ``J`` the tool's Jacobian in base axes).
"""

from __future__ import annotations

import math

import numpy as np

from .._support import limits
from .._support.errors import ModelError, StateError, UnreachablePoseError
from .._support.state import as_state

__all__ = ["ReachCalls", "JACOBIAN_FRAMES", "check_jacobian_frame", "check_link", "rotation_vector",
           "pose_error", "IK_TOLERANCE", "as_wrench", "wrench_torque"]

#: the axes a Jacobian's rows are given in (``frame=``): the base's, or the frame's own
JACOBIAN_FRAMES = ("world", "tool")
#: default tolerance of inverse kinematics on the position (m) and the rotation (rad) error
IK_TOLERANCE = 1e-10
#: ``lambda_bar`` of the first step's damping ``E + lambda_bar`` (Sugihara 2011)
_DAMPING = 1e-3


def check_jacobian_frame(frame) -> str:
    """``frame`` if it is one of :data:`JACOBIAN_FRAMES`, else a :class:`ModelError` naming it."""
    if not isinstance(frame, str) or frame not in JACOBIAN_FRAMES:
        raise ModelError(f"frame: expected 'world' (base-frame axes, the Toolbox's jacob0) or 'tool' (the "
                         f"frame's own axes, jacobe), got {frame!r:.60}")
    return frame


def check_link(link, n: int) -> int:
    """``link`` as an int 1..n, else a :class:`ModelError` naming it."""
    if isinstance(link, bool) or not isinstance(link, (int, np.integer)) or not 1 <= link <= n:
        raise ModelError(f"link: expected a link number 1..{n} (link k moves with joint k; its frame is "
                         f"arm.link_poses(q)[k - 1]), got {link!r:.60}")
    return int(link)


def as_wrench(f_tool, q: np.ndarray) -> np.ndarray:
    """``f_tool`` checked: (6,) (one wrench for every state of ``q``) or (N, 6) for a batch ``q`` (N, n)."""
    f = as_state(f_tool, "f_tool", 6)
    if f.ndim == 2 and (q.ndim != 2 or len(q) != len(f)):
        raise StateError(f"f_tool: got shape {f.shape}, expected (6,) or ({len(q) if q.ndim == 2 else 'N'}, 6) "
                         f"to match q {q.shape} ([force (N); moment (N m)] per state)")
    return f


def wrench_torque(J: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``J^T f``: (n,) or (N, n) joint torques of a wrench ``f`` (6,) or (N, 6) on a frame with Jacobian
    ``J`` (6, n) or (N, 6, n) in base axes at the wrench's point (virtual work: ``tau . qd = f . J qd``)."""
    return np.einsum("...ij,...i->...j", J, f)


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector ``theta * axis`` (3,) of a rotation matrix (3, 3): ``log(R)``, ``|theta| <= pi``.

    ``R = c I + s [a]x + (1 - c) a a^T`` (``c = cos theta``, ``s = sin theta``): up to pi/2 the axis is taken
    from the skew part ``w = 2 s a``, beyond it from the symmetric part ``(1 - c) a a^T`` (signed by ``w``),
    where ``w`` is small and its direction would carry its rounding (3.6e-13 at ``pi - 1e-3`` when taken
    from ``w``); either way the answer is good to some 1e-16 (as ``pin.log3``)."""
    c = min(1.0, max(-1.0, (np.trace(R) - 1.0) / 2.0))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = 0.5 * np.linalg.norm(w)                                   # sin(theta)
    theta = math.atan2(s, c)
    if theta < 1e-6:
        return 0.5 * w                                            # theta ~ sin(theta)
    if c >= 0.0:
        return w * (theta / (2.0 * s))
    # beyond pi/2: the axis from the symmetric part, B - c I = (1 - c) a a^T, its largest column, signed by w
    B = (R + R.T) / 2.0 - c * np.eye(3)
    a = B[int(np.argmax(np.diag(B)))]
    a = a / np.linalg.norm(a)
    if a @ w < 0:
        a = -a
    return theta * a


def pose_error(T_goal: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``[p* - p; log(R* R^T)]`` (6,), metres and radians in base-frame axes: what ``J dq`` should close."""
    return np.concatenate((T_goal[:3, 3] - T[:3, 3], rotation_vector(T_goal[:3, :3] @ T[:3, :3].T)))


def _as_poses(T) -> tuple[np.ndarray, bool]:
    """``T`` as (N, 4, 4) homogeneous transforms, checked; and whether it was one (4, 4)."""
    def bad():
        return ModelError(f"T: expected a 4x4 homogeneous transform (or a stack (N, 4, 4)), got {T!r:.80}")

    try:
        raw = np.asarray(T)
    except (TypeError, ValueError, OverflowError):
        raise bad() from None
    if raw.dtype.kind in "bcSUMm":      # numpy would drop an imaginary part, read True as 1 or a date as a number
        what = {"b": "bool", "c": "complex"}.get(raw.dtype.kind, "non-numeric")
        raise ModelError(f"T: expected a homogeneous transform of real numbers, got a {what} array (dtype {raw.dtype})")
    try:
        arr = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise bad() from None
    if arr.shape[-2:] != (4, 4) or arr.ndim not in (2, 3) or not np.all(np.isfinite(arr)):
        raise ModelError(f"T: expected a finite 4x4 homogeneous transform (or (N, 4, 4)), got shape {arr.shape}")
    limits.check_magnitude(arr[..., :3, 3], "T", "translation", " m")
    single = arr.ndim == 2
    arr = arr[None] if single else arr
    for k, Tk in enumerate(arr):
        where = "T" if single else f"T[{k}]"
        R = Tk[:3, :3]
        if not np.allclose(Tk[3], (0, 0, 0, 1), atol=1e-12):
            raise ModelError(f"{where}: the last row must be [0, 0, 0, 1], got {Tk[3].tolist()}")
        # 1e-6: a rotation written with 7 significant digits is still one
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise ModelError(f"{where}: the upper-left 3x3 block is not a rotation (R R^T = I, det R = +1)")
    return arr, single


class ReachCalls:
    """Mixin of :class:`manipdyn.model.arm.Arm`: ``inverse_kinematics`` (module docstring)."""

    def inverse_kinematics(self, T, q0=None, *, tol: float = IK_TOLERANCE, max_steps: int = 100,
                           restarts: int = 20, seed: int = 0, engine: str = "pinocchio") -> np.ndarray:
        """Joint positions whose ``fkine`` is the pose ``T``: (n,), or (N, n) for (N, 4, 4).

        Parameters
        ----------
        T : (4, 4) or (N, 4, 4)
            The tool frame's pose in the base frame (metres), as ``fkine`` gives it.
            A stack is solved in order, each pose starting from the last answer.
        q0 : (n,), optional
            The first start (rad or m); default: the middle of the joint limits.  Of the
            joint positions that reach ``T``, the one found from ``q0`` is returned.
        tol : float
            Largest position error (m) and rotation error (rad) accepted.
        max_steps : int
            Damped least-squares steps per start.
        restarts : int
            Further starts, drawn uniformly within :attr:`qlim` (seeded by ``seed``), when a
            start stalls (a joint limit or a singularity in the way).
        engine : str
            The engine whose ``fkine`` and ``jacobian`` are used (``"pinocchio"``, ``"lagrange"``).

        Every answer lies within :attr:`qlim`.  Raises :class:`manipdyn.UnreachablePoseError`
        (a :class:`StateError`) when no start reaches ``T``: it says how far the best got
        and carries that ``q`` and its errors.  A pose may be out of reach, or outside what
        fewer than 6 joints can match (a position and an orientation both).
        """
        poses, single = _as_poses(T)
        for name, v, lo in (("max_steps", max_steps, 1), ("restarts", restarts, 0), ("seed", seed, 0)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ModelError(f"{name}: expected an integer >= {lo}, got {v!r:.60}")
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 0 < tol < 1:
            raise ModelError(f"tol: expected a number in (0, 1) (m and rad), got {tol!r:.60}")
        eng = self.engine(engine)
        if not callable(getattr(eng, "jacobian", None)):
            raise ModelError(f"engine: engine {engine!r} offers no jacobian; use engine='pinocchio' or 'lagrange'")
        lo, hi = self.qlim[:, 0], self.qlim[:, 1]
        q = (lo + hi) / 2.0 if q0 is None else as_state(q0, "q0", self.n)
        if q.ndim != 1:
            raise ModelError(f"q0: expected one joint vector ({self.n},), got shape {q.shape}")
        out = np.empty((len(poses), self.n))
        for k, Tk in enumerate(poses):
            q = out[k] = self._ik_one(eng, Tk, np.clip(q, lo, hi), tol, int(max_steps), int(restarts), int(seed),
                                      "T" if single else f"T[{k}]")
        return out[0] if single else out

    def _ik_one(self, eng, T, q0, tol, max_steps, restarts, seed, where):
        lo, hi = self.qlim[:, 0], self.qlim[:, 1]
        rng = np.random.default_rng(seed)
        best = None
        for start in range(restarts + 1):
            q = q0 if start == 0 else lo + (hi - lo) * rng.random(self.n)
            q, e = _dls(eng, T, q, lo, hi, tol, max_steps)
            pos, rot = float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:]))
            if pos <= tol and rot <= tol:
                return q
            if best is None or pos + rot < best[1] + best[2]:
                best = (q, pos, rot)
        q, pos, rot = best
        at_limit = [j + 1 for j in range(self.n) if q[j] <= lo[j] + 1e-9 or q[j] >= hi[j] - 1e-9]
        raise UnreachablePoseError(
            f"{where}: the pose is out of reach of {self.name or 'the arm'!r} within its joint limits: "
            f"after {restarts + 1} starts of up to {max_steps} damped least-squares steps, the closest "
            f"q = {np.array2string(q, precision=4, separator=', ')} leaves the tool {pos:.4g} m and "
            f"{rot:.4g} rad ({math.degrees(rot):.3g} deg) from it (tolerance {tol:g})"
            + (f"; joint(s) {', '.join(map(str, at_limit))} rest on their limits" if at_limit else "")
            + ("" if self.n >= 6 else f"; {self.n} joints cannot match a general position and orientation"),
            q=q, position_error=pos, rotation_error=rot)


def _dls(eng, T, q, lo, hi, tol, max_steps):
    """Damped least-squares steps from ``q`` (module docstring): ``(q, error)`` of the best step.

    The damping is Levenberg-Marquardt's: ``lambda`` shrinks tenfold after a step that
    lowers ``E`` and grows tenfold (the step refused) after one that does not, from
    Sugihara's ``E + lambda_bar``; a start ends when ``lambda`` passes 1e8 (stalled).
    """
    n = len(q)
    e = pose_error(T, eng.fkine(q))
    E = 0.5 * float(e @ e)
    lam = E + _DAMPING
    J = None
    for _ in range(max_steps):
        if max(abs(e[:3]).max(), abs(e[3:]).max()) <= tol / 2:  # |e| <= sqrt(3) tol/2 < tol
            break
        if J is None:
            J = eng.jacobian(q)
        q_new = np.clip(q + np.linalg.solve(J.T @ J + lam * np.eye(n), J.T @ e), lo, hi)
        e_new = pose_error(T, eng.fkine(q_new))
        E_new = 0.5 * float(e_new @ e_new)
        if E_new < E:
            q, e, E, J, lam = q_new, e_new, E_new, None, max(lam / 10.0, 1e-12)
        else:
            lam *= 10.0
            if lam > 1e8:
                break
    return q, e
