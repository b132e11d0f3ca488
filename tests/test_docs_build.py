"""Issue 31 item 20: the API reference builds from the docstrings, nitpicky, warnings as errors.

Issue 38 item 15: the user guide (``docs/guide/``, MyST Markdown) is built with it, and the package
page documents the public names where ``import manipdyn as md`` gives them.

``docs/conf.py`` writes a page for every module it finds in the package, so a module that
moves or is added is documented (and checked) without editing ``docs/``; a docstring that
names a module, class or function that is not there (``:mod:`manipdyn.lagrange``` after
the engines moved) fails this build.  The build runs on a copy of ``docs/`` in a temporary
folder, so the project's folder is not written.  About 30 s of CPU.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_api_reference_builds_nitpicky_with_warnings_as_errors(tmp_path):
    pytest.importorskip("sphinx", reason="the API reference needs the docs extra (pip install -e '.[docs]')")
    src = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", src, ignore=shutil.ignore_patterns("_build", "api"))
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-q", "-n", "-W", "--keep-going", "-b", "html",
                           str(src), str(tmp_path / "html")], env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-5000:]
    pages = {p.stem for p in (src / "api").glob("manipdyn*.rst")}
    # every module of the package has its page (found by walking the package, not listed by hand)
    for must in ("manipdyn", "manipdyn.engines.c.graph", "manipdyn.identification.pipeline",
                 "manipdyn.identification.estimation.fitting", "manipdyn.control.montecarlo.study"):
        assert must in pages, must
    # issue 46 item 12: the reference lists the public modules first, the private manipdyn._support ones after them
    listed = [line.strip() for line in (src / "api" / "index.rst").read_text().splitlines() if line.startswith("   manipdyn")]
    private = [k for k, name in enumerate(listed) if "._" in name]
    assert listed[0] == "manipdyn" and private and private == list(range(len(listed) - len(private), len(listed))), listed
    html = (tmp_path / "html" / "api" / "manipdyn.engines.c.graph.html").read_text(encoding="utf-8")
    assert "manipdyn.engines.lagrange" in html and "manipdyn.model.parameters" in html
    # issue 38 item 15: the user guide is built with it, every page of its toctree
    import guide

    for name in guide.toc():
        assert (tmp_path / "html" / "guide" / f"{name}.html").is_file(), name
    # the public names where `import manipdyn as md` gives them: a function has its entry as md.NAME
    # (md.identify, not only manipdyn.identification.pipeline.identify), a class its description
    import inspect

    import manipdyn

    package = (tmp_path / "html" / "api" / "manipdyn.html").read_text(encoding="utf-8")
    for name in manipdyn.__all__:
        obj = getattr(manipdyn, name)
        if inspect.isfunction(obj):
            assert f'id="manipdyn.{name}"' in package, f"md.{name} has no entry on the package page"
        else:
            assert f"manipdyn.</span></span><span class=\"sig-name descname\"><span class=\"pre\">{name}<" in package, name
    # every arm's calls have entries of their own on Arm (inherited from its mixins included)
    arm = (tmp_path / "html" / "api" / "manipdyn.model.arm.html").read_text(encoding="utf-8")
    for method in ("mass_matrix", "coriolis_torque", "gravity_torque", "inverse_dynamics", "forward_dynamics",
                   "jacobian", "inverse_kinematics", "kinetic_energy", "potential_energy", "regressor"):
        assert f'id="manipdyn.model.arm.Arm.{method}"' in arm, method


def test_docs_name_no_moved_module():
    """The names issue 31 found in docstrings and messages, gone from the package's text."""
    stale = ("manipdyn.lagrange`", "manipdyn.parameters`", "manipdyn.friction`", "manipdyn.errors.",
             "manipdyn.arm.", "manipdyn.arm_calls.", "manipdyn._support.limits.M", "manipdyn._support.limits.{")
    for path in (ROOT / "manipdyn").rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        for s in stale:
            assert s not in text, f"{path.relative_to(ROOT)}: {s}"
