"""The result of :func:`manipdyn.check.compare.compare`: verdicts, differences, text and JSON.

Layer 4 (checks: compare) (compare).

Two verdicts, one per question a user asks before swapping one description
for the other in a controller:

* kinematics: ``"same"`` (the same joint variables give the same tool pose,
  once the constant base and tool transforms stated in the report are
  applied), ``"same up to joint signs/offsets"`` (the same arm, but joint i of
  a is ``sign_i * q_i + offset_i`` of b's), or ``"different"``;
* dynamics: ``"same"`` (D, h, g at matched states, and the rotor inertias,
  within :data:`DYN_TOLERANCE` relative), ``"different"`` (with the worst
  quantity, the link most responsible and its parameter differences), or
  ``"not compared"`` when the joint structures differ.

:attr:`CompareReport.same_arm` (exit 0 of ``manipdyn compare``) needs both
to be ``"same"``.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from ...model.arm import joint_letters

__all__ = ["CompareReport", "QuantityDiff", "display_names", "KIN_TOLERANCE", "ROT_TOLERANCE",
           "DYN_TOLERANCE", "KIN_SAME", "KIN_REMAPPED", "KIN_DIFFERENT"]

#: max tool position error (m) under which two descriptions have the same kinematics
KIN_TOLERANCE = 1e-6
#: max tool orientation error (rad) under which two descriptions have the same kinematics;
#: also the joint offset (rad, or m for prismatic joints) below which an offset is zero
ROT_TOLERANCE = 1e-6
#: max relative difference of D, h, g and the rotor inertias under which the dynamics
#: are the same.  Two exact descriptions of one arm agree to ~1e-13; a description that
#: rounds pi/2 to 1.5708 moves the bodies by ~1e-5 relative, which is a different model.
DYN_TOLERANCE = 1e-6

KIN_SAME = "same"
KIN_REMAPPED = "same up to joint signs/offsets"
KIN_DIFFERENT = "different"


def display_names(name_a: str, name_b: str, spec_a=None, spec_b=None) -> tuple[str, str]:
    """Labels of the two sides: the arms' names, or their file names when the names clash.

    ``spec_a``/``spec_b`` are what the user passed (model name, path) or None.
    When the names are still equal, `` (a)`` and `` (b)`` are appended.
    """
    la, lb = name_a or "a", name_b or "b"
    if la == lb:
        fa = os.path.basename(os.fspath(spec_a)) if spec_a is not None else la
        fb = os.path.basename(os.fspath(spec_b)) if spec_b is not None else lb
        la, lb = (fa, fb) if fa != fb else (f"{la} (a)", f"{lb} (b)")
    return la, lb


@dataclass
class QuantityDiff:
    """Largest difference of one dynamics quantity over the matched states.

    ``max_abs`` in the quantity's unit (kg m^2 for D, N m or N for h, g);
    ``max_rel`` is ``max|x_b - x_a| / max(|x_a|, |x_b|)`` over the entries of
    the worst state; ``worst_index`` is that state's index.
    """

    name: str
    max_abs: float
    max_rel: float
    worst_index: int

    @property
    def same(self) -> bool:
        return bool(self.max_rel <= DYN_TOLERANCE)

    def to_dict(self) -> dict:
        return {"quantity": self.name, "max_abs": self.max_abs, "max_rel": self.max_rel,
                "worst_index": self.worst_index, "same": self.same}


def _pct(x: float) -> str:
    return f"{100.0 * x:.3g} %"


def _vec(v, fmt: str = ".4g") -> str:
    return "(" + ", ".join(format(float(x), fmt) for x in v) + ")"


def _pose_str(T: np.ndarray) -> str:
    from ...model.kinematics import matrix_to_rpy

    rpy = np.degrees(matrix_to_rpy(T[:3, :3]))
    rpy = np.where(np.abs(rpy) < math.degrees(ROT_TOLERANCE), 0.0, rpy)
    p = np.where(np.abs(T[:3, 3]) < KIN_TOLERANCE, 0.0, T[:3, 3])
    return (f"xyz = ({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}) m, "
            f"rpy = ({rpy[0]:.6g}, {rpy[1]:.6g}, {rpy[2]:.6g}) deg")


@dataclass
class CompareReport:
    """Result of :func:`manipdyn.check.compare`.

    ``T_b(q) = base @ T_a(q') @ tool`` with ``q'_i = joint_signs[i] * q_i +
    joint_offsets[i]`` (``q`` arm b's joints, ``q'`` arm a's; offsets in rad or
    m, exactly 0 below :data:`ROT_TOLERANCE`).  When the joint structures
    differ (``structure`` non-empty) nothing else is compared and the
    alignment fields are None.
    """

    a: str
    b: str
    n: int
    joint_types: tuple
    samples: int
    seed: int
    structure: str = ""              # why the joint structures differ; "" when they match
    fk_error: float = math.inf       # max tool position error after alignment (m)
    rot_error: float = math.inf      # max tool orientation error after alignment (rad)
    base: np.ndarray | None = None
    tool: np.ndarray | None = None
    joint_signs: tuple | None = None
    joint_offsets: np.ndarray | None = None
    dynamics: dict = field(default_factory=dict)   # "D", "h", "g" -> QuantityDiff
    rotor: QuantityDiff | None = None              # rotor inertia G^2 Jm per joint
    masses: list = field(default_factory=list)     # per link, see compare()
    responsible: dict | None = None                # the link most responsible for the worst quantity
    armature_a: np.ndarray | None = None
    armature_b: np.ndarray | None = None
    gravity_a: np.ndarray | None = None            # a's declared gravity (a's base)
    gravity_used_a: np.ndarray | None = None       # b's gravity seen in a's base (used for g)
    candidates: int = 0                            # sign vectors scored
    notes: list = field(default_factory=list)

    # -- verdicts ---------------------------------------------------------------
    @property
    def same_kinematics(self) -> bool:
        """True when the aligned forward kinematics agree (possibly after joint signs/offsets)."""
        return bool(not self.structure and self.fk_error <= KIN_TOLERANCE
                    and self.rot_error <= ROT_TOLERANCE)

    @property
    def remapped_joints(self) -> list[int]:
        """Joints (1-based) whose sign is flipped or whose offset is not zero."""
        if self.joint_signs is None:
            return []
        return [i + 1 for i, (s, o) in enumerate(zip(self.joint_signs, self.joint_offsets))
                if s < 0 or o != 0.0]

    @property
    def kinematics(self) -> str:
        """``KIN_SAME``, ``KIN_REMAPPED`` or ``KIN_DIFFERENT``."""
        if not self.same_kinematics:
            return KIN_DIFFERENT
        return KIN_REMAPPED if self.remapped_joints else KIN_SAME

    @property
    def worst_quantity(self) -> QuantityDiff | None:
        """The dynamics quantity (D, h, g or rotor) with the largest relative difference."""
        qs = list(self.dynamics.values()) + ([self.rotor] if self.rotor is not None else [])
        return max(qs, key=lambda d: d.max_rel) if qs else None

    @property
    def dynamics_verdict(self) -> str:
        """``"same"``, ``"different"`` or ``"not compared"``."""
        w = self.worst_quantity
        if w is None:
            return "not compared"
        return "same" if w.same else "different"

    @property
    def same_dynamics(self) -> bool:
        return self.dynamics_verdict == "same"

    @property
    def same_arm(self) -> bool:
        """Both verdicts "same": one description can replace the other with the same q."""
        return self.kinematics == KIN_SAME and self.same_dynamics

    ok = same_arm

    def verdict(self) -> str:
        """One line: SAME ARM or NOT THE SAME ARM, and why."""
        if self.structure:
            return f"NOT THE SAME ARM: {self.structure}"
        kin = {KIN_SAME: "kinematics the same" + (" (other base and tool frames, below)"
                                                  if self._frames_moved else ""),
               KIN_REMAPPED: f"kinematics the same up to the signs/offsets of joints {self.remapped_joints}",
               KIN_DIFFERENT: "kinematics DIFFERENT"}[self.kinematics]
        if self.same_dynamics:
            dyn = "dynamics the same"
        else:
            dyn = "dynamics DIFFERENT (" + "; ".join(self._dynamics_reasons()) + ")"
        head = "SAME ARM" if self.same_arm else "NOT THE SAME ARM"
        return f"{head}: {kin}; {dyn}"

    def _dynamics_reasons(self) -> list[str]:
        out = []
        rigid = max(self.dynamics.values(), key=lambda d: d.max_rel)
        if not rigid.same:
            r = self.responsible
            out.append(f"{rigid.name} differs by {_pct(rigid.max_rel)}"
                       + (f", link {r['link']} ({r['name_b']}) most responsible" if r else ""))
        if self.rotor is not None and not self.rotor.same:
            out.append(f"rotor inertia G^2 Jm differs by {_pct(self.rotor.max_rel)} "
                       f"at joint {self.rotor.worst_index + 1}")
        return out

    @property
    def _frames_moved(self) -> bool:
        return not (np.allclose(self.base, np.eye(4), atol=KIN_TOLERANCE)
                    and np.allclose(self.tool, np.eye(4), atol=KIN_TOLERANCE))

    # -- JSON ---------------------------------------------------------------------
    def to_dict(self) -> dict:
        def arr(x):
            return None if x is None else np.asarray(x).tolist()

        w = self.worst_quantity
        return {
            "a": self.a, "b": self.b, "n": self.n, "joint_types": list(self.joint_types),
            "samples": self.samples, "seed": self.seed,
            "same_arm": self.same_arm, "verdict": self.verdict(),
            "kinematics": self.kinematics, "same_kinematics": self.same_kinematics,
            "dynamics_verdict": self.dynamics_verdict,
            "structure": self.structure or None,
            "fk_error_m": None if self.structure else self.fk_error,
            "rot_error_rad": None if self.structure else self.rot_error,
            "kin_tolerance_m": KIN_TOLERANCE, "rot_tolerance_rad": ROT_TOLERANCE,
            "dyn_tolerance_rel": DYN_TOLERANCE,
            "base": arr(self.base), "tool": arr(self.tool),
            "joint_signs": None if self.joint_signs is None else list(self.joint_signs),
            "joint_offsets": None if self.joint_offsets is None else [float(x) for x in self.joint_offsets],
            "dynamics": {k: v.to_dict() for k, v in self.dynamics.items()},
            "rotor": None if self.rotor is None else self.rotor.to_dict(),
            "worst_quantity": None if w is None else w.name,
            "responsible": self.responsible,
            "masses": self.masses,
            "armature_a": arr(self.armature_a), "armature_b": arr(self.armature_b),
            "gravity_a": arr(self.gravity_a), "gravity_used_a": arr(self.gravity_used_a),
            "candidates": self.candidates, "notes": list(self.notes),
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2)

    # -- text ---------------------------------------------------------------------
    def __str__(self) -> str:
        kinds = joint_letters(self.joint_types)
        what = "" if self.structure else (f": {self.n} joints {kinds}, {self.samples} states, "
                                          f"seed {self.seed}")
        lines = [f"compare a = {self.a!r} with b = {self.b!r}{what}",
                 self.verdict()]
        if not self.structure:
            lines += self._kinematics_lines() + self._dynamics_lines()
        lines += [f"note: {note}" for note in self.notes]
        return "\n".join(lines)

    def _kinematics_lines(self) -> list[str]:
        label = {KIN_SAME: "the same", KIN_REMAPPED: KIN_REMAPPED, KIN_DIFFERENT: "DIFFERENT"}
        lines = [f"kinematics: {label[self.kinematics]}: max tool position error {self.fk_error:.3e} m, "
                 f"orientation {self.rot_error:.3e} rad after alignment "
                 f"(tolerance {KIN_TOLERANCE:g} m, {ROT_TOLERANCE:g} rad)",
                 "  T_b(q) = base @ T_a(q') @ tool,  q'_i = sign_i * q_i + offset_i",
                 "  joint  sign  offset"]
        for i, (s, o, t) in enumerate(zip(self.joint_signs, self.joint_offsets, self.joint_types)):
            unit = f"{math.degrees(o):+.6g} deg" if t == "revolute" else f"{o:+.6g} m"
            gauge = ""
            if i == 0:
                gauge = "  (joint 1's offset is folded into base)"
            elif i == self.n - 1:
                gauge = f"  (joint {self.n}'s offset is folded into tool)"
            lines.append(f"  {i + 1:>5}  {s:+d}    {unit}{gauge}")
        lines.append(f"  base (b's base <- a's base): {_pose_str(self.base)}")
        lines.append(f"  tool (a's tool -> b's tool): {_pose_str(self.tool)}")
        return lines

    def _dynamics_lines(self) -> list[str]:
        lines = []
        if self.dynamics:
            verdict = "the same" if self.same_dynamics else "DIFFERENT"
            lines.append(f"dynamics: {verdict} (tolerance {DYN_TOLERANCE:g} relative); "
                         "rigid bodies at matched states, a's g computed with b's gravity in a's base:")
            lines.append(f"  {'quantity':<9}{'max abs diff':>14}{'max rel diff':>14}")
            for k, d in list(self.dynamics.items()) + ([("rotor", self.rotor)] if self.rotor else []):
                label = "G^2 Jm" if k == "rotor" else k
                lines.append(f"  {label:<9}{d.max_abs:14.3e}{d.max_rel:14.3e}"
                             f"{'' if d.same else '  differs'}")
        if self.responsible is not None:
            lines += self._responsible_lines()
        if self.masses:
            lines += self._mass_lines()
        if self.armature_a is not None and (np.any(self.armature_a) or np.any(self.armature_b)):
            lines.append(f"  rotor inertia G^2 Jm (not in D above): a {np.round(self.armature_a, 6).tolist()}, "
                         f"b {np.round(self.armature_b, 6).tolist()}")
        return lines

    def _responsible_lines(self) -> list[str]:
        r = self.responsible
        return [
            f"  most responsible for {r['quantity']}: link {r['link']} (a: {r['name_a']}, b: {r['name_b']}), "
            f"{_pct(r['share'])} of the per-link differences; its parameters in b's link frame:",
            f"    mass (kg)                    a {r['mass_a']:.6g}  b {r['mass_b']:.6g}",
            f"    centre of mass (m)           a {_vec(r['com_a'])}  b {_vec(r['com_b'])}",
            f"    inertia about COM (kg m^2)   a {_vec(r['inertia_a'])}  b {_vec(r['inertia_b'])}",
            "      (ixx, iyy, izz, ixy, ixz, iyz, tensor sign)",
        ]

    def _mass_lines(self) -> list[str]:
        lines = [f"  {'link':<5}{'name a':<14}{'name b':<18}{'mass a':>9}{'mass b':>9}"
                 f"{'diff':>10}{'COM offset (m)':>16}"]
        for m in self.masses:
            com = "-" if m["com_offset"] is None else f"{m['com_offset']:.4g}"
            lines.append(f"  {m['link']:<5}{m['name_a'][:13]:<14}{m['name_b'][:17]:<18}"
                         f"{m['mass_a']:9.4g}{m['mass_b']:9.4g}{m['diff']:+10.4g}{com:>16}")
        ta = sum(m["mass_a"] for m in self.masses)
        tb = sum(m["mass_b"] for m in self.masses)
        lines.append(f"  total moving mass: a {ta:.6g} kg, b {tb:.6g} kg")
        return lines
