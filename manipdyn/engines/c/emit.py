"""Plain C99 from CasADi SX functions: one ``double`` local per work slot, constants folded in.

Layer 3 (engines: c), the generated-C engine.  CasADi's own code generator is not
used: this module walks each SX Function's instruction list
(``n_instructions``, ``instruction_id``, ``instruction_input``,
``instruction_output``, ``instruction_constant``) and writes one C statement
per instruction, so the output is ours to keep within what the issue asks:
``<math.h>`` only, no allocation, no static or global state (reentrant and
thread-safe), clean under ``-std=c99 -Wall -Wextra -pedantic -Werror``.  An
operation outside the table of :func:`_operations` is refused by name, never dropped.

Arrays are row-major; every input is read, every output written in full.
"""

from __future__ import annotations

import keyword
import re

from ..._support.errors import ModelError

__all__ = ["c_identifier", "check_prefix", "emit_function", "emit_batch", "has_cse", "OUTPUTS", "C_KEYWORDS"]

#: C99's keywords (a prefix must not be one)
C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum extern float for goto
if inline int long register restrict return short signed sizeof static struct switch typedef union unsigned
void volatile while _Bool _Complex _Imaginary""".split())

#: output argument names (and sizes: "n", "nn", "np" = n*p, "16", "1") of each generated function
OUTPUTS = {
    "inverse_dynamics": (("tau", "n"),),
    "mass_matrix": (("M", "nn"),),
    "gravity": (("g", "n"),),
    "nonlinear_effects": (("h", "n"),),
    "forward_dynamics": (("qdd", "n"),),
    "inverse_dynamics_derivatives": (("dtau_dq", "nn"), ("dtau_dqd", "nn")),
    "forward_dynamics_derivatives": (("dqdd_dq", "nn"), ("dqdd_dqd", "nn"), ("dqdd_dtau", "nn")),
    "regressor": (("Y", "np"),),
    "coriolis": (("c", "n"),),
    "friction": (("f", "n"),),
    "tool_pose": (("T", "16"),),
    "potential_energy": (("P", "1"),),
    "gravity_derivative": (("dg_dq", "nn"),),
    "friction_derivative": (("df_dqd", "nn"),),
    "coriolis_matrix": (("C", "nn"),),
}


def c_identifier(name: str) -> str:
    """``name`` made into a C identifier: other characters become ``_``; a leading digit or
    underscore, or a C keyword, gets the prefix ``arm_``; empty becomes ``arm``."""
    s = re.sub(r"[^A-Za-z0-9_]", "_", name or "")
    s = re.sub(r"_+", "_", s).strip("_")
    if not s:
        return "arm"
    if s[0].isdigit() or s in C_KEYWORDS or keyword.iskeyword(s):
        s = "arm_" + s
    return s


def check_prefix(prefix) -> str:
    """``prefix`` if it is a usable C identifier prefix, else a :class:`ModelError` naming it."""
    if not isinstance(prefix, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,62}", prefix) \
            or prefix in C_KEYWORDS:
        raise ModelError(f"prefix: expected a C identifier (a letter, then letters, digits or '_', at most 63, "
                         f"not a C keyword), got {prefix!r:.80}")
    return prefix


def _literal(x: float) -> str:
    x = float(x)
    if x != x or x in (float("inf"), float("-inf")):
        raise ModelError(f"generated C: the folded constant {x} is not finite (C99 has no literal for it)")
    s = repr(x)
    if "e" not in s and "." not in s:
        s += ".0"
    return s


def _operations(ca) -> dict:
    """CasADi op code -> (name, C format of the operands ``a``, ``b``)."""
    table = {
        "ASSIGN": "{a}", "ADD": "{a} + {b}", "SUB": "{a} - {b}", "MUL": "{a} * {b}", "DIV": "{a} / {b}",
        "NEG": "-{a}", "EXP": "exp({a})", "LOG": "log({a})", "POW": "pow({a}, {b})", "CONSTPOW": "pow({a}, {b})",
        "SQRT": "sqrt({a})", "SQ": "{a} * {a}", "TWICE": "{a} + {a}", "SIN": "sin({a})", "COS": "cos({a})",
        "TAN": "tan({a})", "ASIN": "asin({a})", "ACOS": "acos({a})", "ATAN": "atan({a})",
        "SINH": "sinh({a})", "COSH": "cosh({a})", "TANH": "tanh({a})", "ATAN2": "atan2({a}, {b})",
        "FABS": "fabs({a})", "FMIN": "fmin({a}, {b})", "FMAX": "fmax({a}, {b})", "INV": "1.0 / {a}",
        "SIGN": "({a} > 0.0 ? 1.0 : ({a} < 0.0 ? -1.0 : {a}))", "COPYSIGN": "copysign({a}, {b})",
        "IF_ELSE_ZERO": "({a} != 0.0 ? {b} : 0.0)", "LT": "(double)({a} < {b})", "LE": "(double)({a} <= {b})",
        "EQ": "(double)({a} == {b})", "NE": "(double)({a} != {b})", "NOT": "(double)({a} == 0.0)",
        "AND": "(double)({a} != 0.0 && {b} != 0.0)", "OR": "(double)({a} != 0.0 || {b} != 0.0)",
        "FLOOR": "floor({a})", "CEIL": "ceil({a})", "EXPM1": "expm1({a})", "LOG1P": "log1p({a})",
        "HYPOT": "hypot({a}, {b})",
    }
    return {getattr(ca, "OP_" + k): (k, v) for k, v in table.items() if hasattr(ca, "OP_" + k)}


def emit_function(ca, prefix: str, name: str, args, outs, n: int) -> tuple[str, str, int]:
    """``(declaration, definition, operation count)`` of ``void prefix_name(inputs..., outputs...)``.

    ``args``: ``[(arg name, SX column)]``; ``outs``: dense SX columns in
    :data:`OUTPUTS` order.  The operation count excludes reads, writes and constants.
    """
    opts = {"cse": True} if has_cse(ca) else {}
    f = ca.Function(name, [a for _, a in args], [ca.densify(o) for o in outs], opts)
    if f.has_free():
        raise ModelError(f"generated C: {name} depends on free symbols {f.get_free()}")
    ops = _operations(ca)
    in_names = [nm for nm, _ in args]
    out_names = [nm for nm, _ in OUTPUTS[name]]
    used_inputs, used_slots, body, flops = set(), set(), [], 0
    OP_INPUT, OP_OUTPUT, OP_CONST = ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST
    for k in range(f.n_instructions()):
        op = f.instruction_id(k)
        i, o = f.instruction_input(k), f.instruction_output(k)
        if op == OP_INPUT:
            used_inputs.add(i[0])
            used_slots.add(o[0])
            body.append(f"w{o[0]} = {in_names[i[0]]}[{i[1]}];")
        elif op == OP_OUTPUT:
            body.append(f"{out_names[o[0]]}[{o[1]}] = w{i[0]};")
        elif op == OP_CONST:
            used_slots.add(o[0])
            body.append(f"w{o[0]} = {_literal(f.instruction_constant(k))};")
        elif op in ops:
            opname, fmt = ops[op]
            a = f"w{i[0]}"
            b = f"w{i[1]}" if len(i) > 1 else ""
            used_slots.add(o[0])
            body.append(f"w{o[0]} = {fmt.format(a=a, b=b)};")
            flops += opname != "ASSIGN"
        else:
            raise ModelError(f"generated C: {name} holds the CasADi operation {op} ({_op_name(ca, op)}), "
                             "which the emitter does not write (manipdyn.engines.c.emit)")
    params = [f"const double *{nm}" for nm in in_names] + [f"double *{nm}" for nm in out_names]
    decl = f"void {prefix}_{name}({', '.join(params)})"
    lines = [decl, "{"]
    for idx in sorted(set(range(len(in_names))) - used_inputs):
        lines.append(f"    (void){in_names[idx]};")
    slots = sorted(used_slots)
    for start in range(0, len(slots), 12):
        lines.append("    double " + ", ".join(f"w{s}" for s in slots[start:start + 12]) + ";")
    lines += ["    " + s for s in body]
    lines.append("}")
    return decl + ";", "\n".join(lines) + "\n", flops


def emit_batch(prefix: str, name: str, args, sizes) -> tuple[str, str]:
    """``(declaration, definition)`` of ``prefix_name_batch(long N, ...)``: the single-state
    function over N states laid out one after another (inputs n each, outputs ``sizes``)."""
    in_names = [nm for nm, _ in args]
    out_names = [nm for nm, _ in OUTPUTS[name]]
    params = (["long N"] + [f"const double *{nm}" for nm in in_names] + [f"double *{nm}" for nm in out_names])
    decl = f"void {prefix}_{name}_batch({', '.join(params)})"
    call = ", ".join([f"{nm} + k * {prefix}_NQ" for nm in in_names]
                     + [f"{nm} + k * {sz}" for nm, sz in zip(out_names, sizes)])
    body = f"{decl}\n{{\n    long k;\n    for (k = 0; k < N; ++k)\n        {prefix}_{name}({call});\n}}\n"
    return decl + ";", body


def has_cse(ca) -> bool:
    """Whether this CasADi's Function takes the ``cse`` option (common-subexpression elimination)."""
    try:
        x = ca.SX.sym("x")
        ca.Function("t", [x], [x], {"cse": True})
        return True
    except RuntimeError:
        return False


def _op_name(ca, op: int) -> str:
    for k in dir(ca):
        if k.startswith("OP_") and getattr(ca, k) == op:
            return k
    return "unknown"
