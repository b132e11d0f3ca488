"""Seeded mutation fuzzing of manipdyn's inputs: URDF files and model files.

Run from the repository root::

    python -m tests.fuzz --cases 5000 --model-cases 2000        # the long run (minutes)
    python -m tests.fuzz --cases 200 --model-cases 100 --jobs 2  # what CI runs (tests/test_fuzz.py)

The command line's option sets (excite, montecarlo) have their own generator and contract
in tests/fuzz_cli.py, run by the same pool (:func:`run_pool`).

Each case is one bundled file (``urdf/*.urdf`` or ``manipdyn/formats/models/*.toml``)
mutated by a few seeded operators: hostile numbers (non-ASCII digits, nan,
1e400, 400-digit integers, trailing tabs, underflowing literals...), broken
vectors, removed, duplicated or re-pointed elements, changed joint types,
DOCTYPEs and entities, NUL and invalid UTF-8 bytes, BOMs, truncation,
deep nesting, long chains and runs of fixed joints, bad units and keys.  Case
``i`` of seed ``s`` is always the same file (``--show KIND:I`` prints it).

The contract, checked on every case (in a worker process, with a timeout):

* ``md.load`` raises a :class:`ModelError` whose message names the file, or
* it returns an arm whose engines build (or the Pinocchio engine refuses
  the arm with a ModelError naming the file, e.g. the two URDF readers
  disagree) and agree: ``md.crosscheck`` on a few seeded states is ``ok``
  (forward dynamics of a singular mass matrix is reported, not compared).

Failures: any other exception (a "foreign" one, or a manipdyn error that
does not name the file), a disagreement, a case running over ``--timeout``
seconds (a hang; the worker is killed and replaced) and a worker that dies
(a crash: segfault, MemoryError, abort).  The exit code is 1 if any case
failed, and the failing cases are written to ``--save`` when given.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import os
import random
import re
import sys
import tempfile
import time
import tomllib
import traceback
import warnings
from collections import Counter
from multiprocessing.connection import wait
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
URDFS = sorted((ROOT / "urdf").glob("*.urdf"))
MODELS = sorted((ROOT / "manipdyn" / "formats" / "models").glob("*.toml"))

#: the outcomes that satisfy the contract
PASS = ("refused at load", "refused by the engine", "agree", "agree (qdd not compared: D singular, indefinite or ill-conditioned)")

# ---------------------------------------------------------------------------
# Hostile values
# ---------------------------------------------------------------------------
HOSTILE_NUMBER_TEXT = [
    "\u0661", "\uff11", "\u0661.\u0665", "1e400", "-1e400", "nan", "inf", "-inf", "NaN", " 1", "1 ", "1\t",
    "\t1", "&#9;1", "1&#10;", "1&#13;", "1e-400", "1e300", "1e155", "1e61", "1e60", "-1", "0", "-0",
    "9" * 400, "0x10", "1_0", "", " ", "1.0.0", "+.5", "5.", ".e1", "1e", "1e+", "1,5", "1e-310",
    "-1e-310", "1.7976931348623157e308", "4.9e-324", "1e-12", "1e6", "-1e6", "&amp;", "&lt;1", "\u00a01",
    "1\u2009", "+1", "--1", "1d0", "0.5e+0", "\U0001d7d9",
]
HOSTILE_VECTOR_TEXT = [
    "0 0", "0 0 0 0", "0\t0\t1", "0\n0 1", "0&#9;0 1", " 0 0 1", "0 0 1 ", "0  0  1", "1e300 1e300 0",
    "1e155 0 0", "0 0 0", "1e-200 0 0", "nan 0 0", "0,0,1", "\u0661 0 0", "0 0 \uff11", "1e-400 0 1",
    "0 0 1e61", "-0 -0 -1", "1 1 1", "", "0 0 1&#10;",
]
NUMBER_ATTRS = ("value", "ixx", "ixy", "ixz", "iyy", "iyz", "izz", "lower", "upper", "effort", "velocity",
                "damping", "friction", "multiplier", "offset")
VECTOR_ATTRS = ("xyz", "rpy")


def _perturb(rng: random.Random, raw: str) -> str:
    try:
        v = float(raw)
    except ValueError:
        v = 1.0
    f = rng.choice([-1.0, 0.0, 1e-12, 1e-300, 1e6, 1e30, 1e59, 2.0, -1e6,  # hostile
                    0.5, 1.5, -0.3, 1e-3, 1e3, 1.000001])                   # careless but plausible
    return repr(v * f)


# ---------------------------------------------------------------------------
# URDF mutations
# ---------------------------------------------------------------------------
def _urdf_structural(rng: random.Random, root) -> str:
    """One structural edit of the lxml tree; returns its name."""
    from copy import deepcopy

    from lxml import etree

    op = rng.choice(["drop", "drop", "duplicate", "retype", "relink", "rename", "mimic", "cycle",
                     "chain", "fixed_run", "swap", "attr_junk", "floating_root", "empty_robot"])
    joints = root.findall("joint")
    links = root.findall("link")
    if op == "drop":
        tag = rng.choice(["inertial", "mass", "inertia", "origin", "axis", "limit", "parent", "child",
                          "dynamics", "link", "joint"])
        els = root.findall(f".//{tag}")
        if els:
            el = rng.choice(els)
            el.getparent().remove(el)
    elif op == "duplicate":
        tag = rng.choice(["inertial", "mass", "origin", "axis", "limit", "link", "joint", "inertia"])
        els = root.findall(f".//{tag}")
        if els:
            el = rng.choice(els)
            el.getparent().append(deepcopy(el))
    elif op == "retype" and joints:
        rng.choice(joints).set("type", rng.choice(["fixed", "continuous", "prismatic", "revolute", "floating",
                                                    "planar", "spherical", "", "REVOLUTE"]))
    elif op == "relink" and joints:
        j = rng.choice(joints)
        tag = rng.choice(["parent", "child"])
        el = j.find(tag)
        if el is not None:
            el.set("link", rng.choice([l.get("name", "") for l in links] + ["nowhere", "", " "]))
    elif op == "rename" and (joints or links):
        el = rng.choice(joints + links)
        el.set("name", rng.choice(["", " ", "x" * 300, "a\u00e9\u4e2d", el.get("name", "") + "_2",
                                   "tab\tname", "new\nline"]))
    elif op == "mimic" and len(joints) > 1:
        j, k = rng.sample(joints, 2)
        m = etree.SubElement(j, "mimic")
        m.set("joint", k.get("name", ""))
        m.set("multiplier", rng.choice(["1", "-1", "nan", "2"]))
        m.set("offset", rng.choice(["0", "0.5"]))
    elif op == "cycle" and joints:
        j = rng.choice(joints)
        j.find("child").set("link", links[0].get("name", "")) if j.find("child") is not None else None
    elif op in ("chain", "fixed_run") and joints:
        # replicate one joint/link pair many times (long chains, runs of fixed joints)
        count = rng.choice([20, 60, 99, 101, 150, 250, 1200])
        j = rng.choice(joints)
        child = j.find("child")
        if child is None:
            return op
        last = child.get("link")
        body = next((l for l in links if l.get("name") == last), None)
        for i in range(count):
            nl = deepcopy(body) if (body is not None and op == "chain") else etree.Element("link")
            nl.set("name", f"fz_link_{i}")
            nj = deepcopy(j)
            nj.set("name", f"fz_joint_{i}")
            if op == "fixed_run":
                nj.set("type", "fixed")
            nj.find("parent").set("link", last) if nj.find("parent") is not None else None
            nj.find("child").set("link", f"fz_link_{i}")
            root.append(nl)
            root.append(nj)
            last = f"fz_link_{i}"
    elif op == "swap" and joints:
        j = rng.choice(joints)
        p, c = j.find("parent"), j.find("child")
        if p is not None and c is not None:
            a, b = p.get("link"), c.get("link")
            p.set("link", b)
            c.set("link", a)
    elif op == "attr_junk":
        els = [e for e in root.iter() if isinstance(e.tag, str)]  # not comments
        el = rng.choice(els)
        el.set(rng.choice(["xyz", "rpy", "value", "type", "name", "link", "joint", "foo"]),
               rng.choice(HOSTILE_NUMBER_TEXT[:20] + HOSTILE_VECTOR_TEXT[:8]).replace("&", "and"))
    elif op == "floating_root" and joints:
        rng.choice(joints).set("type", "floating")
    elif op == "empty_robot":
        for el in list(root):
            if rng.random() < 0.5:
                root.remove(el)
    return op


def _urdf_textual(rng: random.Random, text: str) -> tuple[str | bytes, str]:
    op = rng.choice(["number"] * 6 + ["vector"] * 3 + ["perturb"] * 3 + [
        "doctype", "entity", "nul", "bad_utf8", "bom", "encoding", "truncate", "byteflip", "crlf", "comment",
        "cdata", "pi", "huge_attr", "xinclude"])
    if op in ("number", "vector", "perturb"):
        attrs = VECTOR_ATTRS if op == "vector" else NUMBER_ATTRS + (VECTOR_ATTRS if op == "perturb" else ())
        ms = [m for m in re.finditer(r'\b(' + "|".join(attrs) + r')="([^"]*)"', text)]
        if not ms:
            return text, op
        m = rng.choice(ms)
        if op == "number":
            new = rng.choice(HOSTILE_NUMBER_TEXT)
        elif op == "vector":
            new = rng.choice(HOSTILE_VECTOR_TEXT)
        else:
            parts = m.group(2).split()
            if parts:
                k = rng.randrange(len(parts))
                parts[k] = _perturb(rng, parts[k])
            new = " ".join(parts)
        new = new.replace('"', "&quot;")
        return text[:m.start(2)] + new + text[m.end(2):], f"{op}:{m.group(1)}"
    if op == "doctype":
        decl = rng.choice(['<!DOCTYPE robot>', '<!DOCTYPE robot [<!ATTLIST origin xyz CDATA "0 0 1">]>',
                           '<!DOCTYPE robot SYSTEM "http://127.0.0.1:9/x.dtd">',
                           '<!DOCTYPE robot [<!ENTITY a "1">]>'])
        i = text.find("<robot")
        return text[:i] + decl + "\n" + text[i:], op
    if op == "entity":
        i = text.find("<robot")
        t = text[:i] + '<!DOCTYPE robot [<!ENTITY x "0.5">]>\n' + text[i:]
        return re.sub(r'value="[^"]*"', 'value="&x;"', t, count=1), op
    if op == "nul":
        k = rng.randrange(len(text))
        return text[:k] + "\x00" + text[k:], op
    if op == "bad_utf8":
        data = text.encode("utf-8")
        k = rng.randrange(len(data))
        return data[:k] + rng.choice([b"\xff", b"\xc3", b"\xe4", b"\xed\xa0\x80"]) + data[k:], op
    if op == "bom":
        return rng.choice([b"\xef\xbb\xbf", b"\xff\xfe", b"\xfe\xff"]) + text.encode("utf-8"), op
    if op == "encoding":
        enc = rng.choice(["latin-1", "utf-16", "ascii", "bogus-42", "UTF8", "shift_jis"])
        t = re.sub(r"^<\?xml[^>]*\?>\s*", "", text)
        return f'<?xml version="1.0" encoding="{enc}"?>\n' + t, op
    if op == "truncate":
        return text[:rng.randrange(len(text))], op
    if op == "byteflip":
        data = bytearray(text.encode("utf-8"))
        for _ in range(rng.randint(1, 4)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        return bytes(data), op
    if op == "crlf":
        return text.replace("\n", "\r\n"), op
    if op == "comment":
        k = text.find("<joint")
        return text[:k] + '<!-- xyz="0\t0 1" <joint> -- -->' + text[k:], op
    if op == "cdata":
        k = text.find("<link")
        return text[:k] + "<![CDATA[ <joint name='x'/> ]]>" + text[k:], op
    if op == "pi":
        k = text.find("<link")
        return text[:k] + "<?xml-stylesheet href='x'?>" + text[k:], op
    if op == "huge_attr":
        return text.replace('name="', 'name="' + "n" * rng.choice([1000, 100000]), 1), op
    if op == "xinclude":
        k = text.find("<link")
        return text[:k] + '<xi:include xmlns:xi="http://www.w3.org/2001/XInclude" href="/etc/passwd"/>' + text[k:], op
    return text, op


def make_urdf_case(seed: int, index: int) -> tuple[bytes, str, list[str]]:
    """Case ``index`` of ``seed``: (file bytes, file name, operators applied)."""
    from lxml import etree

    rng = random.Random(f"urdf-{seed}-{index}")
    src = rng.choice(URDFS)
    root = etree.fromstring(src.read_bytes())
    ops = [src.name]
    if rng.random() < 1 / 3:  # a careless edit: plausible numbers changed, the arm must still agree
        text = etree.tostring(root, encoding="unicode")
        for _ in range(rng.randint(1, 4)):
            ms = list(re.finditer(r'\b(' + "|".join(NUMBER_ATTRS + VECTOR_ATTRS) + r')="([^"]*)"', text))
            m = rng.choice(ms)
            parts = m.group(2).split()
            k = rng.randrange(len(parts))
            parts[k] = repr(float(parts[k]) * rng.choice([0.5, 1.5, -1.0, 0.0, 1e-3, 10.0, 1.000001]))
            text = text[:m.start(2)] + " ".join(parts) + text[m.end(2):]
            ops.append(f"careless:{m.group(1)}")
        return text.encode("utf-8"), f"case{index}.urdf", ops
    for _ in range(rng.choice([0, 0, 1, 1, 2])):
        ops.append(_urdf_structural(rng, root))
    text = etree.tostring(root, encoding="unicode")
    data: str | bytes = text
    n_text = rng.choice([1, 1, 1, 2, 3]) if len(ops) == 1 else rng.choice([0, 1])
    for _ in range(n_text):
        if isinstance(data, bytes):
            break
        data, op = _urdf_textual(rng, data)
        ops.append(op)
    if isinstance(data, str):
        data = data.encode("utf-8")
    return data, f"case{index}.urdf", ops


# ---------------------------------------------------------------------------
# Model-file mutations
# ---------------------------------------------------------------------------
HOSTILE_TOML_VALUES = [
    float("nan"), float("inf"), -float("inf"), 1e300, -1e300, 1e61, 1e60, 1e-320, 10**400, -(10**30), -1, 0, -0.0,
    "1.0", "", True, False, [1.0, 2.0], [], {}, {"ixx": 1}, [[1.0] * 3] * 3, [1.0] * 6, 2**63, "\x00", None,
]


def _toml_value(v) -> str:
    if v is None:
        return '"none"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    return json.dumps(str(v))


def _toml_dump(data: dict) -> str:
    lines = []
    tables = {}
    for k, v in data.items():
        if isinstance(v, dict) and k != "links":
            tables[k] = v
        elif k == "links" and isinstance(v, list) and all(isinstance(x, dict) for x in v) and v:
            tables[k] = v
        else:
            lines.append(f"{json.dumps(k)} = {_toml_value(v)}")
    for k, v in tables.items():
        if isinstance(v, dict):
            lines.append(f"\n[{json.dumps(k)}]")
            lines += [f"{json.dumps(a)} = {_toml_value(b)}" for a, b in v.items()]
        else:
            for row in v:
                lines.append(f"\n[[{k}]]")
                lines += [f"{json.dumps(a)} = {_toml_value(b)}" for a, b in row.items()]
    return "\n".join(lines) + "\n"


def _model_mutation(rng: random.Random, data: dict) -> str:
    op = rng.choice(["value"] * 6 + ["perturb"] * 3 + [
        "drop_key", "unknown_key", "units", "convention", "links_many", "links_none", "links_dup",
        "qlim_reversed", "name_ctrl", "gravity", "format", "links_type"])
    links = data.get("links") if isinstance(data.get("links"), list) else []
    links = [l for l in links if isinstance(l, dict)]
    if op in ("value", "perturb", "drop_key", "unknown_key") and links:
        link = rng.choice(links)
        if not isinstance(link, dict) or not link:
            return op
        key = rng.choice(sorted(link))
        if op == "value":
            link[key] = rng.choice(HOSTILE_TOML_VALUES)
        elif op == "perturb":
            v = link[key]
            f = rng.choice([-1.0, 0.0, 1e-12, 1e6, 1e30, 1e59, 1e62, 2.0, 0.5, 1.5, -0.3, 1e-3, 1e3])
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                link[key] = v * f
            elif isinstance(v, list) and v and all(isinstance(x, (int, float)) for x in v):
                k = rng.randrange(len(v))
                v[k] = v[k] * f
            elif isinstance(v, dict) and v:
                kk = rng.choice(sorted(v))
                v[kk] = v[kk] * f if isinstance(v[kk], (int, float)) else v[kk]
        elif op == "drop_key":
            del link[key]
        else:
            link[rng.choice(["masss", "Mass", "inertia_origin", "friction"])] = 1.0
        return f"{op}:{key}"
    if op == "units":
        data["units"] = {rng.choice(["length", "angle", "mass", "time"]): rng.choice(["mm", "deg", "g", "rad", "furlong", 3, ""])}
    elif op == "convention":
        data["convention"] = rng.choice(["modified", "standard", "Standard", "", 1])
    elif op == "links_many" and links:
        data["links"] = [dict(rng.choice(links)) for _ in range(rng.choice([20, 99, 100, 101, 400]))]
    elif op == "links_none":
        data["links"] = rng.choice([[], {}, "x", [1, 2]])
    elif op == "links_dup" and links:
        data["links"] = links + links
    elif op == "qlim_reversed" and links:
        rng.choice(links)["qlim"] = rng.choice([[1.0, -1.0], [0.0, 0.0], [1.0], [float("nan"), 1.0], [0, 1e300]])
    elif op == "name_ctrl":
        target = rng.choice([data] + links) if links else data
        target["name"] = rng.choice(["a\x00b", "bell\x07", "\ud7ff", "x" * 10000, "ok", "\u202e"])
    elif op == "gravity":
        data["gravity"] = rng.choice([[0, 0], [0, 0, -9.81, 0], [0, 0, -9.81, 1], [1e300, 0, 0], [float("nan")] * 3, "down"])
    elif op == "format":
        data["format"] = rng.choice(["manipdyn-model/2", "", 1])
    elif op == "links_type" and links:
        rng.choice(links)["joint"] = rng.choice(["spherical", "", "Revolute", 1, "prismatic"])
    return op


def _toml_textual(rng: random.Random, text: str) -> tuple[str | bytes, str]:
    op = rng.choice(["bad_utf8", "truncate", "deep", "long_string", "byteflip", "dup_key", "nul", "crlf"])
    if op == "bad_utf8":
        data = text.encode("utf-8")
        k = rng.randrange(len(data))
        return data[:k] + rng.choice([b"\xff", b"\xe4", b"\xc3"]) + data[k:], op
    if op == "truncate":
        return text[:rng.randrange(len(text))], op
    if op == "deep":
        d = rng.choice([100, 1000, 10000])
        return text.replace("gravity = ", "gravity = " + "[" * d + "]" * d + "\nzz = ", 1) \
            if "gravity = " in text else "zz = " + "[" * d + "]" * d + "\n" + text, op
    if op == "long_string":
        size = rng.choice([10**4, 10**6, 2 * 10**6])
        return text.replace('"name" = "', '"name" = "' + "x" * size, 1), op
    if op == "byteflip":
        data = bytearray(text.encode("utf-8"))
        for _ in range(rng.randint(1, 4)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        return bytes(data), op
    if op == "dup_key":
        return text.replace('"mass" = ', '"mass" = 1.0\n"mass" = ', 1), op
    if op == "nul":
        k = rng.randrange(len(text))
        return text[:k] + "\x00" + text[k:], op
    return text.replace("\n", "\r\n"), op


def make_model_case(seed: int, index: int) -> tuple[bytes, str, list[str]]:
    rng = random.Random(f"model-{seed}-{index}")
    src = rng.choice(MODELS)
    data = tomllib.loads(src.read_text(encoding="utf-8"))
    ops = [src.name]
    if rng.random() < 1 / 3:  # a careless edit: plausible numbers changed, the arm must still agree
        for _ in range(rng.randint(1, 4)):
            link = rng.choice(data["links"])
            keys = [k for k, v in link.items() if isinstance(v, (int, float)) and not isinstance(v, bool)]
            if keys:
                k = rng.choice(keys)
                link[k] = link[k] * rng.choice([0.5, 1.5, -1.0, 0.0, 1e-3, 10.0, 1.000001])
                ops.append(f"careless:{k}")
        return _toml_dump(data).encode("utf-8"), f"case{index}.toml", ops
    for _ in range(rng.choice([1, 1, 2, 3])):
        ops.append(_model_mutation(rng, data))
    text: str | bytes = _toml_dump(data)
    if rng.random() < 0.3:
        text, op = _toml_textual(rng, text)
        ops.append(op)
    if isinstance(text, str):
        try:
            text = text.encode("utf-8")
        except UnicodeEncodeError:  # a lone surrogate from a mutation
            text = text.encode("utf-8", "surrogatepass")
    return text, f"case{index}.toml", ops


MAKERS = {"urdf": make_urdf_case, "model": make_model_case}


# ---------------------------------------------------------------------------
# Running one case (in a worker process)
# ---------------------------------------------------------------------------
def run_case(kind: str, seed: int, index: int, folder: str) -> tuple[str, str]:
    """(outcome, detail) of one case; outcomes in :data:`PASS` satisfy the contract."""
    import manipdyn as md

    data, name, ops = MAKERS[kind](seed, index)
    path = os.path.join(folder, name)
    with open(path, "wb") as fh:
        fh.write(data)
    where = " ".join(ops)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
            warnings.simplefilter("error", RuntimeWarning)  # a numpy overflow warning is a finding
            try:
                arm = md.load(path)
            except md.ModelError as exc:
                return _named("refused at load", exc, name, where)
            try:
                arm.pinocchio
                arm.lagrange
            except md.ModelError as exc:
                return _named("refused by the engine", exc, name, where)
            report = md.crosscheck(arm, samples=3, seed=index % 1000)
        if not report.ok:
            return "DISAGREE", f"{where}: {report}"
        if report.not_compared:
            return "agree (qdd not compared: D singular, indefinite or ill-conditioned)", where
        return "agree", where
    except Exception as exc:  # noqa: BLE001 - classifying is the point
        tb = traceback.format_exc(limit=4).strip().splitlines()
        return f"FOREIGN {type(exc).__name__}", f"{where}: {exc!s:.300} | {' / '.join(tb[-3:])}"
    finally:
        try:
            os.unlink(path)
        except OSError:
            pass


def _named(outcome: str, exc: Exception, name: str, where: str) -> tuple[str, str]:
    msg = str(exc)
    if name not in msg:
        return "UNNAMED manipdyn error (the file is not named)", f"{where}: {type(exc).__name__}: {msg:.300}"
    return outcome, f"{where}: {msg:.200}"


def _worker(conn, folder: str, runner=None) -> None:
    import manipdyn  # noqa: F401  (imported once per worker)

    runner = runner or run_case

    # urdfdom prints its own errors on file descriptor 2: keep the report readable
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)

    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        kind, seed, index = job
        conn.send(runner(kind, seed, index, folder))


# ---------------------------------------------------------------------------
# The pool: one case at a time per worker, a timeout per case
# ---------------------------------------------------------------------------
class _Slot:
    def __init__(self, ctx, folder, runner=None):
        self.ctx, self.folder, self.runner = ctx, folder, runner
        self.start()

    def start(self):
        self.conn, child = self.ctx.Pipe()
        self.proc = self.ctx.Process(target=_worker, args=(child, self.folder, self.runner), daemon=True)
        self.proc.start()
        child.close()
        self.job = None
        self.t0 = 0.0

    def stop(self, force=False):
        if force:
            self.proc.kill()  # this worker's own pid: we started it
        else:
            try:
                self.conn.send(None)
            except OSError:
                pass
        self.proc.join(5)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join(5)


def fuzz(n_urdf: int, n_model: int, seed: int = 0, jobs: int = 2, timeout: float = 5.0,
         progress=None, deadline: float | None = None) -> dict:
    """Run the cases; return ``{"counts": Counter, "failures": [(kind, index, outcome, detail)], ...}``."""
    jobs_list = [("urdf", seed, i) for i in range(n_urdf)] + [("model", seed, i) for i in range(n_model)]
    return run_pool(jobs_list, ("urdf", "model"), seed, jobs, timeout, progress, deadline)


def run_pool(jobs_list, kinds, seed: int, jobs: int = 2, timeout: float = 5.0, progress=None,
             deadline: float | None = None, runner=None, passing=PASS) -> dict:
    """Run ``(kind, seed, index)`` jobs in worker processes, each with a timeout:
    ``runner(kind, seed, index, folder) -> (outcome, detail)`` (default :func:`run_case`);
    an outcome not in ``passing`` is a failure, as are a hang and a crash."""
    todo = list(reversed(jobs_list))
    import manipdyn  # noqa: F401  (imported before forking: a restarted worker is ready at once)
    import pinocchio  # noqa: F401
    from lxml import etree  # noqa: F401

    ctx = mp.get_context("fork")
    counts: dict[str, Counter] = {k: Counter() for k in kinds}
    failures = []
    t_start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="manipdyn-fuzz-") as folder:
        slots = [_Slot(ctx, folder, runner) for _ in range(max(1, jobs))]
        done = 0
        try:
            while todo or any(s.job for s in slots):
                for s in slots:
                    if s.job is None and todo and (deadline is None or time.time() < deadline):
                        s.job = todo.pop()
                        s.t0 = time.monotonic()
                        s.conn.send(s.job)
                if deadline is not None and time.time() >= deadline:
                    todo.clear()
                busy = [s for s in slots if s.job]
                if not busy:
                    break
                ready = wait([s.conn for s in busy] + [s.proc.sentinel for s in busy], timeout=0.2)
                now = time.monotonic()
                for s in busy:
                    outcome = None
                    if s.conn in ready:
                        try:
                            outcome, detail = s.conn.recv()
                        except (EOFError, OSError):
                            outcome = None
                    if outcome is None and s.proc.sentinel in ready and not s.proc.is_alive():
                        outcome, detail = f"CRASH (worker exit code {s.proc.exitcode})", ""
                        job = s.job
                        s.stop(force=True)
                        s.start()
                        s.job = job
                    elif outcome is None and now - s.t0 > timeout:
                        outcome, detail = f"HANG (over {timeout:g} s)", ""
                        job = s.job
                        s.stop(force=True)
                        s.start()
                        s.job = job
                    if outcome is None:
                        continue
                    kind, sd, idx = s.job
                    counts[kind][outcome] += 1
                    if outcome not in passing:
                        failures.append((kind, idx, outcome, detail))
                    s.job = None
                    done += 1
                    if progress is not None:
                        progress(done, len(jobs_list))
        finally:
            for s in slots:
                s.stop(force=s.job is not None)
    return {"counts": counts, "failures": failures, "seconds": time.monotonic() - t_start,
            "cases": done, "seed": seed}


def _progress(done: int, total: int) -> None:
    if done % 50 == 0 or done == total:
        print(f"\r  {done}/{total} cases", end="" if done < total else "\n", file=sys.stderr, flush=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.fuzz", description=__doc__.split("\n\n")[0],
                                epilog="Exit code 0: every case met the contract; 1: some failed.")
    p.add_argument("--cases", type=int, default=500, help="mutated URDF cases (default 500)")
    p.add_argument("--model-cases", type=int, default=None,
                   help="mutated model-file cases (default: 2/5 of --cases)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--timeout", type=float, default=5.0, help="seconds per case before it is a hang (default 5)")
    p.add_argument("--until", type=float, default=None,
                   help="stop starting new cases at this UNIX time (the counts say how many ran)")
    p.add_argument("--save", metavar="DIR", default=None, help="write each failing case's file into DIR")
    p.add_argument("--show", metavar="KIND:INDEX", default=None, help="print one case's file and exit")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    args = p.parse_args(argv)
    if args.show:
        kind, idx = args.show.split(":")
        data, name, ops = MAKERS[kind](args.seed, int(idx))
        print(f"# {name}: {' '.join(ops)}", file=sys.stderr)
        sys.stdout.buffer.write(data)
        return 0
    n_model = args.model_cases if args.model_cases is not None else (2 * args.cases) // 5
    res = fuzz(args.cases, n_model, seed=args.seed, jobs=args.jobs, timeout=args.timeout,
               progress=_progress if sys.stderr.isatty() else None, deadline=args.until)
    if args.save and res["failures"]:
        os.makedirs(args.save, exist_ok=True)
        for kind, idx, _, _ in res["failures"]:
            data, name, _ = MAKERS[kind](args.seed, idx)
            Path(args.save, f"{kind}-{name}").write_bytes(data)
    if args.json:
        print(json.dumps({"counts": {k: dict(v) for k, v in res["counts"].items()},
                          "failures": res["failures"], "seconds": res["seconds"],
                          "cases": res["cases"], "seed": res["seed"]}, indent=2))
    else:
        print(f"fuzz: {res['cases']} cases in {res['seconds']:.0f} s (seed {res['seed']}, timeout "
              f"{args.timeout:g} s, {args.jobs} workers)")
        for kind, c in res["counts"].items():
            print(f"  {kind} ({sum(c.values())} cases):")
            for outcome, k in sorted(c.items(), key=lambda x: -x[1]):
                print(f"    {k:6d}  {outcome}{'' if outcome in PASS else '   <-- FAILS THE CONTRACT'}")
        for kind, idx, outcome, detail in res["failures"][:30]:
            print(f"  FAIL {kind}:{idx} {outcome}: {detail[:400]}")
        if len(res["failures"]) > 30:
            print(f"  ... {len(res['failures']) - 30} more failures")
    return 1 if res["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
