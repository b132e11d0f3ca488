"""Are two descriptions the same arm?  (``md.compare(a, b)``, ``manipdyn compare A B``)

Layer 4 (checks: compare) (compare).

Typical use: a datasheet DH table against the vendor's URDF, before swapping
one for the other in a controller.  The two descriptions may put the base and
tool frames elsewhere, count a joint the other way round, or start it from
another zero.  :func:`compare` finds, in closed form, the joint map and the
constant transforms under which

    T_b(q) = base @ T_a(q') @ tool,      q'_i = sign_i * q_i + offset_i,

(``T`` the tool pose in each arm's own base frame, ``q`` arm b's joint
vector, ``q'`` arm a's), reports how well the forward kinematics then agree,
and compares the dynamics at matched states.  The report gives two verdicts
(:mod:`manipdyn.check.compare.report`): kinematics the same / the same up to joint
signs and offsets / different, and dynamics the same / different (with the
worst quantity and the link most responsible).

The method, one module per step (no black-box optimiser):

1. :mod:`~manipdyn.check.compare.canonical`: each arm in one form,
   ``T(q) = W_0 J(q_1) W_1 ... J(q_n) W_n``, and the DH-like normal form of
   each link transform;
2. :mod:`~manipdyn.check.compare.align`: joint signs (searched depth-first, pruned
   by the link invariants), offsets and base/tool in closed form, ties broken
   by the mass distribution, then refined by Kabsch steps;
3. :mod:`~manipdyn.check.compare.dynamics`: D, h, g at matched states, rotor
   inertias, and which link's parameters differ most;
4. :mod:`~manipdyn.check.compare.report`: :class:`CompareReport`, text and JSON.

``manipdyn.check.compare`` (the attribute of the top-level package) is the
function; import the modules with ``from manipdyn.check.compare import report``.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError
from .align import choose_alignment, mapped_fk, pose_errors
from .canonical import canonical_chain
from .dynamics import compare_dynamics, gravity_in_a, gravity_note, link_table, rotor_diff
from .report import (DYN_TOLERANCE, KIN_DIFFERENT, KIN_REMAPPED, KIN_SAME, KIN_TOLERANCE,
                     ROT_TOLERANCE, CompareReport, QuantityDiff, display_names)

__all__ = ["compare", "CompareReport", "QuantityDiff", "KIN_TOLERANCE", "ROT_TOLERANCE",
           "DYN_TOLERANCE", "KIN_SAME", "KIN_REMAPPED", "KIN_DIFFERENT"]


def _as_arm(x, which: str):
    """``(arm, spec)``: an Arm as given, or loaded from a model name / file (spec kept for labels)."""
    from ...model.arm import Arm

    if isinstance(x, Arm):
        return x, None
    if isinstance(x, str) or hasattr(x, "__fspath__"):
        from ...formats.loading import load

        return load(x), x
    raise ModelError(f"compare: argument {which} must be an arm or a model name/file, got {type(x).__name__}")


def _structure_mismatch(a, b, la: str, lb: str) -> str:
    """Why the joint structures differ (count or type), or "" when they match."""
    if a.n != b.n:
        return (f"{la!r} has {a.n} joints ({a.joint_letters}) and {lb!r} has {b.n} "
                f"({b.joint_letters})")
    for i, (ta, tb) in enumerate(zip(a.joint_types, b.joint_types)):
        if ta != tb:
            return (f"joint {i + 1} is {ta} in {la!r} and {tb} in {lb!r} "
                    f"({a.joint_letters} vs {b.joint_letters})")
    return ""


def _check_samples(samples) -> int:
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ValueError(f"samples: expected a positive integer, got {samples!r}")
    return int(samples)


def compare(a, b, samples: int = 200, seed: int = 0, *, names=None) -> CompareReport:
    """Are ``a`` and ``b`` two descriptions of the same arm?

    Parameters
    ----------
    a, b : manipdyn.Arm, or a bundled model name / model file / URDF path
    samples : int
        Random states of arm b (uniform within its joint limits, seeded)
        on which the aligned kinematics and the dynamics are compared.
    seed : int
    names : (str, str), optional
        Labels of a and b in the report; by default the arms' names, or
        their file names when the names are equal.

    Returns
    -------
    CompareReport
        ``kinematics`` and ``dynamics_verdict`` (the two verdicts),
        ``same_arm`` (both the same), ``fk_error`` (m), ``base``, ``tool``,
        ``joint_signs``, ``joint_offsets``, ``dynamics`` (D, h, g
        differences), ``rotor``, ``masses``, ``responsible``.  Arms whose
        joint count or types differ give a report with ``structure`` set
        and nothing else compared.
    """
    a, spec_a = _as_arm(a, "a")
    b, spec_b = _as_arm(b, "b")
    samples = _check_samples(samples)
    la, lb = names if names is not None else display_names(a.name, b.name, spec_a, spec_b)
    head = dict(a=la, b=lb, n=b.n, joint_types=tuple(b.joint_types), samples=samples, seed=int(seed))
    structure = _structure_mismatch(a, b, la, lb)
    if structure:
        return CompareReport(**head, structure=structure)

    # -- kinematics: align a onto b on b's random states ---------------------------
    ca, cb = canonical_chain(a), canonical_chain(b)
    scale = max(1.0, sum(float(np.linalg.norm(W[:3, 3])) for W in ca.W + cb.W))
    rng = np.random.default_rng(seed)
    q = b.random_state(rng, samples)
    Tb = b.fkine(q)
    best, n_candidates, notes = choose_alignment(a, b, ca, cb, q, Tb, scale)
    pos, rot = pose_errors(Tb, mapped_fk(a, best, q))

    # -- dynamics at matched states, and which link differs most -------------------
    qd = rng.uniform(-1.0, 1.0, (samples, b.n))
    dyn = compare_dynamics(a, b, best, q, qd)
    note = gravity_note(a, b, best)
    if note:
        notes.append(note)
    worst_rigid = max(dyn.values(), key=lambda d: d.max_rel)
    masses, responsible = link_table(a, b, best, None if worst_rigid.same else worst_rigid.name, q, qd)

    return CompareReport(
        **head, fk_error=float(pos.max()), rot_error=float(rot.max()),
        base=best.base, tool=best.tool, joint_signs=best.signs,
        joint_offsets=np.array(best.offsets), dynamics=dyn, rotor=rotor_diff(a, b),
        masses=masses, responsible=responsible,
        armature_a=np.array(a.armature, dtype=np.float64), armature_b=np.array(b.armature, dtype=np.float64),
        gravity_a=np.array(a.gravity, dtype=np.float64),
        gravity_used_a=gravity_in_a(best, b),
        candidates=n_candidates, notes=notes,
    )
