"""The house as ARCHITECTURE.md draws it: layers, no import circles, no borrowed privates.

Every ``.py`` file of ``manipdyn/`` and ``benchmarks/`` is parsed (AST), and
every import is collected, including the ones inside functions (a lazy import
is still an edge).  The tests then check

* no import circle, lazy or not (a strongly connected component of the
  import graph with more than one module, or a module importing itself);
* imports point down the layers of ARCHITECTURE.md (sideways within a layer
  is allowed, as long as there is no circle);
* no module imports another module's ``_private`` name;
* ``benchmarks/`` imports neither ``tests/`` nor the CLI;
* no module of ``manipdyn/`` is over 500 lines.
"""

from __future__ import annotations

import ast
import warnings
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("manipdyn", "benchmarks")

#: ARCHITECTURE.md's layers, bottom up, as the import-linter contract in pyproject.toml states them.
LAYERS = ("manipdyn._support", "manipdyn.model", "manipdyn.formats", "manipdyn.engines", "manipdyn.check",
          "manipdyn.identification", "manipdyn.control", "manipdyn.cli", "benchmarks")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _files():
    for pkg in PACKAGES:
        yield from sorted((ROOT / pkg).rglob("*.py"))


def _imports(path: Path):
    """``(imported_module, imported_names, lineno)`` for every import in the file."""
    mod = _module_name(path)
    is_pkg = path.name == "__init__.py"
    base = mod.split(".") if is_pkg else mod.split(".")[:-1]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, (), node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                anchor = base[: len(base) - (node.level - 1)]
                target = ".".join(anchor + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = tuple(a.name for a in node.names)
            if node.module is None or node.level and not node.module:
                # ``from . import x``: each name is a submodule (or a name of the package)
                for n in names:
                    yield f"{target}.{n}", (), node.lineno
            else:
                yield target, names, node.lineno


def _known(module: str, modules: set) -> str | None:
    """The project module that ``module`` names (itself or its closest parent), or None."""
    while module:
        if module in modules:
            return module
        module = module.rpartition(".")[0]
    return None


def _graph():
    files = list(_files())
    modules = {_module_name(f) for f in files}
    edges = {}
    private = []
    for f in files:
        src = _module_name(f)
        for target, names, line in _imports(f):
            dst = _known(target, modules)
            if dst is None or dst == src and target == src:
                if dst == src:
                    edges.setdefault(src, set()).add((dst, line))
                continue
            if dst != src:
                edges.setdefault(src, set()).add((dst, line))
            for n in names:
                if n.startswith("_") and not n.startswith("__"):
                    private.append(f"{src}:{line} imports {n} from {dst}")
    return modules, edges, private


def _cycles(modules, edges):
    """Strongly connected components of size > 1, and self-loops (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w, _ in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or any(w == v for w, _ in edges.get(v, ())):
                out.append(sorted(comp))

    for v in sorted(modules):
        if v not in index:
            visit(v)
    return out


def test_no_import_circles():
    modules, edges, _ = _graph()
    assert _cycles(modules, edges) == []


def _contracts():
    import tomllib

    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["importlinter"]
    return {c["id"]: c for c in cfg["contracts"]}


def test_imports_point_down_the_layers():
    """import-linter's contracts (pyproject.toml) hold: layers, independent engines, benchmarks apart."""
    pytest.importorskip("importlinter", reason="import-linter is in the test extra: pip install -e '.[test]'")
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", "import sys; from importlinter.cli import lint_imports_command; "
                           "sys.exit(lint_imports_command())", "--no-cache"],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert "BROKEN" not in proc.stdout and "Contracts: 4 kept, 0 broken." in proc.stdout, proc.stdout[-2000:]


def test_identification_rooms_are_the_contract():
    """Every sub-package of identification/ is a room of the ``identification-rooms`` contract, and
    every room the contract names exists (a new room cannot slip in unchecked)."""
    contract = _contracts()["identification-rooms"]
    assert contract["containers"] == ["manipdyn.identification"]
    named = {room.strip() for layer in contract["layers"] for room in layer.split("|")}
    pkg = ROOT / "manipdyn" / "identification"
    rooms = {d.name for d in pkg.iterdir() if (d / "__init__.py").exists()}
    modules = {f.stem for f in pkg.glob("*.py") if f.stem != "__init__"}
    assert rooms | modules == named, (rooms | modules) ^ named
    assert modules == {"pipeline"}, "identification's top holds the door only; everything else lives in a room"


def test_the_contract_the_tree_and_architecture_say_the_same():
    """Every package of manipdyn/ is a layer of the contract, in ARCHITECTURE.md's order, and at most 10 entries."""
    layers = _contracts()["layers"]["layers"]
    assert tuple(reversed(layers)) == LAYERS
    top = sorted(p.name for p in (ROOT / "manipdyn").iterdir() if p.name != "__pycache__" and not p.name.endswith(".egg-info"))
    assert len(top) <= 10, top
    packages = {f"manipdyn.{p.name}" for p in (ROOT / "manipdyn").iterdir() if (p / "__init__.py").exists()}
    assert packages == set(LAYERS) - {"benchmarks"}, packages ^ set(LAYERS)
    arch = (ROOT / "ARCHITECTURE.md").read_text(encoding="utf-8")
    positions = [arch.index(f"`{name.split('.')[-1]}/`") for name in LAYERS if name != "benchmarks"]
    assert positions == sorted(positions), "ARCHITECTURE.md's table lists the layers bottom up"
    for pkg in packages:
        doc = ast.get_docstring(ast.parse((ROOT / pkg.replace(".", "/") / "__init__.py").read_text(encoding="utf-8")))
        assert doc and "May import" in doc, f"{pkg}: its docstring says what it may import"


def test_the_contract_can_fail(tmp_path):
    """A planted upward import breaks import-linter's layers contract (the check is not vacuous)."""
    pytest.importorskip("importlinter", reason="import-linter is in the test extra: pip install -e '.[test]'")
    import shutil
    import subprocess
    import sys

    shutil.copytree(ROOT / "manipdyn", tmp_path / "manipdyn", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "benchmarks", tmp_path / "benchmarks", ignore=shutil.ignore_patterns("__pycache__", "results"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    with open(tmp_path / "manipdyn" / "model" / "kinematics.py", "a", encoding="utf-8") as fh:
        fh.write("\n\ndef _planted():\n    from ..control import simulate  # noqa: F401  (upward, lazy)\n")
    # and between identification's rooms: estimation (the bottom room) reaching up into results
    with open(tmp_path / "manipdyn" / "identification" / "estimation" / "base.py", "a", encoding="utf-8") as fh:
        fh.write("\n\ndef _planted():\n    from ..results import scoring  # noqa: F401  (upward, lazy)\n")
    proc = subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, '.'); "
                           "from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())",
                           "--no-cache"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0 and "manipdyn.model.kinematics -> manipdyn.control" in proc.stdout, proc.stdout[-2000:]
    flat = " ".join(proc.stdout.split())     # import-linter wraps long lines
    assert ("manipdyn.identification.estimation is not allowed to import manipdyn.identification.results" in flat
            and "manipdyn.identification.estimation.base -> manipdyn.identification.results.scoring" in flat), flat[-2000:]


def test_no_private_names_cross_modules():
    _, _, private = _graph()
    assert private == []


def test_benchmarks_import_neither_tests_nor_the_cli():
    bad = []
    for f in (ROOT / "benchmarks").rglob("*.py"):
        text = f.read_text(encoding="utf-8")
        if "sys.path" in text:
            bad.append(f"{f.name}: edits sys.path")
        for target, _, line in _imports(f):
            if target.split(".")[0] == "tests" or target.startswith("manipdyn.cli") or target in {"arms", "reference"}:
                bad.append(f"{f.name}:{line} imports {target}")
    assert bad == []


def test_the_graph_walker_sees_lazy_and_relative_imports(tmp_path):
    """The checks above could fail: a planted circle through a lazy import is found."""
    edges = {"a": {("b", 1)}, "b": {("a", 7)}}
    assert _cycles({"a", "b"}, edges) == [["a", "b"]]
    path = ROOT / "manipdyn" / "model" / "arm.py"
    targets = {t for t, _, _ in _imports(path)}
    assert "manipdyn._support.errors" in targets and "manipdyn.model.links" in targets  # relative imports resolved


#: modules whose split is under way (each must still exist and be long: remove it when split)
PENDING_SPLIT: set = set()


def test_no_module_over_500_lines():
    files = [*(ROOT / "manipdyn").rglob("*.py"), *(ROOT / "benchmarks").rglob("*.py")]   # the suite too
    long = {str(f.relative_to(ROOT)): n for f in files if (n := len(f.read_text(encoding="utf-8").splitlines())) > 500}
    assert set(long) >= PENDING_SPLIT, "a pending split is done: remove it from PENDING_SPLIT"
    assert {k: v for k, v in long.items() if k not in PENDING_SPLIT} == {}


def test_every_module_names_its_layer():
    missing = [str(f.relative_to(ROOT)) for f in (ROOT / "manipdyn").rglob("*.py")
               if f.name not in ("__main__.py",)
               and "Layer" not in (ast.get_docstring(ast.parse(f.read_text(encoding="utf-8"))) or "")]
    assert missing == []


# -- the named API changes -------------------------------------------------------------
def _link():
    return md.DHLink("revolute", a=0.3, mass=1.0, com=(-0.15, 0, 0), inertia=[0.01, 0.02, 0.02])


def test_convention_is_required():
    with pytest.raises(TypeError, match=r"convention.*'standard'.*'modified'"):
        md.Manipulator([_link()])
    with pytest.raises(md.ModelError, match=r"convention: must be 'standard' or 'modified', got None"):
        md.Manipulator([_link()], convention=None)
    assert md.Manipulator([_link()], "modified").convention == "modified"


def test_a_link_holds_one_body():
    link = _link()
    assert isinstance(link.body, md.LinkInertia)
    assert link.mass == link.body.mass == 1.0
    np.testing.assert_array_equal(link.com, link.body.com)
    body = md.LinkInertia(2.0, (0, 0, 0.1), [0.1, 0.1, 0.05])
    assert md.DHLink("prismatic", body=body).body is body
    with pytest.raises(md.ModelError, match="field 'body' must be a LinkInertia"):
        md.DHLink("revolute", body={"mass": 1.0})


@pytest.mark.parametrize("old, new, args", [
    ("save", "md.save(arm, path)", ("x.toml",)),
    ("write_urdf", "md.write_urdf(arm, path)", ("x.urdf",)),
    ("to_urdf", "md.to_urdf(arm)", ()),
    ("crosscheck", "md.crosscheck(arm, ...)", ()),
])
def test_old_convenience_methods_warn_and_name_the_replacement(tmp_path, old, new, args):
    arm = md.Manipulator([_link()], "standard", name="one")
    args = tuple(str(tmp_path / a) for a in args)
    with pytest.warns(DeprecationWarning, match=f"arm.{old}.*is deprecated; use {new.replace('(', '[(]').replace(')', '[)]')}"):
        out = getattr(arm, old)(*args, **({"samples": 5} if old == "crosscheck" else {}))
    if old == "to_urdf":
        assert out == md.to_urdf(arm)
    if old == "crosscheck":
        assert out.ok


def test_engines_answer_one_protocol():
    arm = md.load("ur5")
    for eng in (arm.lagrange, arm.pinocchio):
        assert isinstance(eng, md.DynamicsEngine), eng.name
    q = arm.random_state(np.random.default_rng(0))
    np.testing.assert_allclose(arm.lagrange.fkine(q), arm.pinocchio.fkine(q), atol=1e-12)


def test_engines_are_built_once_and_can_be_replaced():
    arm = md.Manipulator([_link()], "standard")
    assert arm.lagrange is arm.lagrange and arm.pinocchio is arm.pinocchio
    other = md.Manipulator([_link()], "standard").lagrange
    arm.set_engine("lagrange", other)
    assert arm.lagrange is other
    with pytest.raises(md.ModelError, match="no engine 'nosuch' is registered"):
        arm.engine("nosuch")


def test_cli_help_lists_every_subcommand_with_one_line(capsys):
    from manipdyn.cli import COMMANDS, build_parser

    help_text = build_parser().format_help()
    sub = build_parser()._subparsers._group_actions[0]
    assert len(sub.choices) == len(COMMANDS)
    for name, action in ((a.dest, a) for a in sub._choices_actions):
        assert name in help_text and action.help and "\n" not in action.help, name


def test_public_names_listed():
    for name in ("load", "compare", "simulate", "crosscheck", "save", "write_urdf", "to_urdf", "Manipulator"):
        assert name in md.__all__ and name in dir(md), name
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            getattr(md, name)
