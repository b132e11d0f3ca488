"""Sphinx configuration of manipdyn's user guide (``docs/guide/``, MyST Markdown) and API reference (``docs/``).

Build: ``python -m sphinx -n -W -b html docs docs/_build/html`` (nitpicky, warnings are errors:
a docstring that names a module, class or function that is not there fails the build, and
``tests/test_docs_build.py`` builds it).  Every module of the ``manipdyn`` package gets a page,
found at build time by walking the package (``api/`` is written here and is not kept in git),
so a module that moves or is added is documented without editing these files.
"""

from __future__ import annotations

import pkgutil
from pathlib import Path

import manipdyn  # the package this documents: installed (pip install -e '.[docs]') or on PYTHONPATH

project = "manipdyn"
author = "the manipdyn developers"
copyright = "2026, the manipdyn developers"
release = version = manipdyn.__version__

# the user guide (docs/guide/*.md) is MyST Markdown, readable on its own and built with the reference
extensions = ["sphinx.ext.autodoc", "myst_parser"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_heading_anchors = 3          # [text](page.md#a-heading) links, checked by the nitpicky build
nitpicky = True
# the docstrings are NumPy style; types are read as text (they are descriptions such as
# "(N, n) array, N m"), and the signatures' annotations are left out: the references that
# are checked are the roles the docstrings write (:class:, :func:, :mod:, :meth:, :data:)
NAPOLEON = dict(napoleon_numpy_docstring=True, napoleon_google_docstring=False, napoleon_use_param=False,
                napoleon_use_rtype=False, napoleon_use_ivar=True)
autodoc_typehints = "none"
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
# names outside manipdyn that docstrings refer to with a role, and no intersphinx (the build
# stays offline): each entry is a library's name that a role in a docstring names
nitpick_ignore_regex = [
    (r"py:.*", r"(numpy|np|scipy|cvxpy|pinocchio|pin|casadi|dask|distributed|matplotlib|mujoco|"
               r"argparse|pathlib|os|concurrent|threading|typing|collections|dataclasses)(\..*)?"),
]
html_theme = "alabaster"
exclude_patterns = ["_build"]
master_doc = "index"


def _modules():
    """Every module of the manipdyn package, sorted (the console entry ``__main__`` left out)."""
    names = ["manipdyn"]
    for info in pkgutil.walk_packages(manipdyn.__path__, "manipdyn."):
        if info.name.rsplit(".", 1)[-1] != "__main__":
            names.append(info.name)
    return sorted(names)


def _clashes(name, names):
    """Functions of package ``name`` that have the full name of one of its modules."""
    import importlib
    import inspect

    mod = importlib.import_module(name)
    return [m.rsplit(".", 1)[-1] for m in names if m.rsplit(".", 1)[0] == name
            and inspect.isfunction(getattr(mod, m.rsplit(".", 1)[-1], None))
            and getattr(mod, m.rsplit(".", 1)[-1]).__module__ == name]


#: classes documented with their inherited methods: every arm's ``mass_matrix``, ``inverse_dynamics``,
#: ``jacobian``, ``inverse_kinematics``, ... (from the mixins ArmCalls and ReachCalls) as ``Arm.NAME``
INHERITED = {"manipdyn.model.arm": ("Arm",)}


def _public_names() -> str:
    """The package page's second half: every name of ``manipdyn.__all__`` where ``import manipdyn as md``
    gives it: a function with an entry of its own (``md.identify``), a class by its docstring (its
    members, and its index entry, on its module's page)."""
    import inspect

    title = "Public names: ``import manipdyn as md``"
    text = (f"\n{title}\n{'-' * len(title)}\n\nWhat ``md.NAME`` gives; each is also described on the page of "
            "the module that defines it.\n")
    for public in manipdyn.__all__:
        obj = getattr(manipdyn, public)
        if getattr(obj, "__module__", None) == "manipdyn":
            continue                                      # defined here: automodule above has it
        if inspect.isclass(obj):        # indexed once, on its module's page (a type named in a
            text += f"\n.. autoclass:: manipdyn.{public}\n   :no-members:\n   :no-index:\n"   # docstring stays one target)
        elif callable(obj):
            text += f"\n.. autofunction:: manipdyn.{public}\n"
        else:
            text += f"\n.. autodata:: manipdyn.{public}\n   :annotation:\n"
    return text


def _write_api_pages(app):
    api = Path(app.srcdir) / "api"
    api.mkdir(exist_ok=True)
    names = _modules()
    for name in names:
        # each object on its own module's page (a package's re-exports are not described twice)
        text = f"{name}\n{'=' * len(name)}\n\n.. automodule:: {name}\n   :members:\n   :ignore-module-all:\n"
        for cls in INHERITED.get(name, ()):   # a class whose mixins' methods are its users' calls
            text += f"   :exclude-members: {cls}\n\n.. autoclass:: {name}.{cls}\n   :members:\n   :inherited-members:\n"
        clash = _clashes(name, names)
        if clash:       # a package's function named like one of its modules (montecarlo.study): one
            text += f"   :exclude-members: {', '.join(clash)}\n"      # index entry, the module's
            for member in clash:
                text += f"\n.. autofunction:: {name}.{member}\n   :no-index:\n"
        if name == "manipdyn":
            text += _public_names()
        page = api / f"{name}.rst"
        if not page.is_file() or page.read_text() != text:
            page.write_text(text)
    for stale in api.glob("*.rst"):
        if stale.stem not in names:
            stale.unlink()
    # the public modules first; the private ones (manipdyn._support: helpers the others share, no
    # stable API) after them, under their own caption
    public = [name for name in names if not _private(name)]
    private = [name for name in names if _private(name)]
    text = "API reference\n=============\n\n.. toctree::\n   :maxdepth: 1\n   :caption: Modules\n\n"
    text += "".join(f"   {name}\n" for name in public)
    if private:
        text += ("\n.. toctree::\n   :maxdepth: 1\n   :caption: Internal modules (shared helpers, not a stable API)\n\n"
                 + "".join(f"   {name}\n" for name in private))
    (api / "index.rst").write_text(text)


def _private(name: str) -> bool:
    """A module no user imports: one of its dotted parts starts with an underscore (``manipdyn._support.files``)."""
    return any(part.startswith("_") for part in name.split("."))


def _numpy_sections(app, what, name, obj, options, lines):
    """NumPy-style sections (Parameters, Returns, ...) as Napoleon reads them, with one change:
    a property's or attribute's first line is read as prose, as written here ("Both verdicts
    "same": ..."), where Napoleon would take the text before a colon for a type."""
    from sphinx.ext.napoleon import Config
    from sphinx.ext.napoleon.docstring import NumpyDocstring

    kind = "function" if what in ("property", "attribute", "data") else what
    out = NumpyDocstring(lines, Config(**NAPOLEON), app, kind, name, obj, options).lines()
    # an attribute's type ("tuple (r, p)", "(N, n) array, N m") is a description, not a class name:
    # it joins its attribute's text instead of becoming a cross-reference of each of its words
    types = {}
    for line in out:
        if line.startswith(":vartype "):
            key, _, text = line[len(":vartype "):].partition(": ")
            types[key] = text
    lines[:] = []
    for line in out:
        if line.startswith(":vartype "):
            continue
        if line.startswith(":ivar "):
            key, _, text = line[len(":ivar "):].partition(": ")
            if key in types:
                text = f"{types[key]}: {text}" if text else types[key]
            for one in key.split(", "):           # "q_d, qd_d : (N+1, n)": one field per name
                lines.append(f":ivar {one}: {text}")
            continue
        lines.append(line)


def _canonical(target: str):
    """``manipdyn.simulate`` -> ``manipdyn.control.simulate.simulate``: the documented name of
    the object a dotted public name imports as (None when it does not import)."""
    import importlib
    import inspect

    if not target.startswith("manipdyn."):
        return None
    parts = target.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        rest = parts[k:]
        break
    else:
        return None
    owner = None
    for attr in rest:
        owner, obj = obj, getattr(obj, attr, None)
        if obj is None:
            return None
    if inspect.ismodule(obj):
        return obj.__name__
    mod, qual = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
    if isinstance(mod, str) and isinstance(qual, str):
        return f"{mod}.{qual}"
    if owner is not None and hasattr(owner, "__qualname__") and rest:   # a property or a data attribute
        return f"{owner.__module__}.{owner.__qualname__}.{rest[-1]}"
    if owner is not None and hasattr(owner, "__name__") and rest:       # a module's data
        return f"{owner.__name__}.{rest[-1]}"
    return None


def _unique_suffix(app, env, node, contnode):
    """Resolve a short name (``:class:`ModelError```, ``:meth:`fkine```) written in a docstring
    when exactly one documented object ends with it; an absent or ambiguous name stays a
    warning, so a docstring that names a module or object that moved fails the build."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip(".~")
    domain = env.get_domain("py")
    canonical = _canonical(target)          # a public name (manipdyn.simulate) of a documented object
    if canonical in domain.objects:
        target = canonical
    hits = [full for full in domain.objects if full == target or full.endswith("." + target)]
    # the package page describes md.NAME again: entries that are one object count once (its own
    # module's entry is the one linked)
    same = {_canonical(h) or h for h in hits}
    if len(same) == 1 and len(hits) > 1 and next(iter(same)) in domain.objects:
        hits = [next(iter(same))]
    owners = {domain.objects[h].node_id for h in hits}
    if len(owners) != 1:
        # not (uniquely) documented: fine if the name imports from where it is written (a private
        # helper, a name imported into that module; shown unlinked), else the warning stands
        where = [node.get("py:module"), node.get("py:class")]
        scopes = [".".join(x for x in where if x), where[0] or ""]
        home = _canonical(scopes[0]) if scopes[0] else None    # md.Transmission's docstring, shown on
        if home:                                               # the package page: its own module's names
            scopes += [home, home.rsplit(".", 1)[0]]
        if any(_canonical(f"{scope}.{target}" if scope else target) for scope in scopes):
            return contnode
        return None
    full = hits[0]
    obj = domain.objects[full]
    from sphinx.util.nodes import make_refnode

    return make_refnode(app.builder, node["refdoc"], obj.docname, obj.node_id, contnode, full)


def setup(app):
    app.connect("builder-inited", _write_api_pages)
    app.connect("autodoc-process-docstring", _numpy_sections)
    app.connect("missing-reference", _unique_suffix)
