"""Issue 31 item 1: every shell block of the README and the guide runs as pasted, or says plainly why not.

Since issue 38 item 15 the README's blocks live in the guide's pages (``docs/guide/``, read through
``tests/guide.py``).  A block is one of three kinds:

* run here, in reading order (the README, then the guide's pages in their toctree's order), in one
  working folder as a reader following the guide uses one (``manipdyn`` and ``python`` on the PATH
  are this interpreter; the project's ``examples/`` beside it, and the real-data folder in
  ``$MANIPDYN_REALDATA``, through which the blocks read it);
* a template, whose first line is a comment starting ``# a template:`` that says what stands for
  the reader's own files or machines;
* skipped by the tests, with ``<!-- tests skip this block: REASON -->`` on the line before its
  fence: a block that installs from the network, or runs for minutes, or is run by another test
  (the reason names that test file, and this file checks that it exists).
"""

from __future__ import annotations

import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import guide
from common import PANDA_LOG as REALDATA, REALDATA as REALDATA_DIR

ROOT = Path(__file__).resolve().parents[1]

#: ``(where, text, skip reason or None)`` of every ```` ```sh ```` block, in reading order
BLOCKS = [(b.where, b.text, b.skip) for b in guide.blocks("sh")]


def _is_template(text: str) -> bool:
    return text.lstrip().startswith("# a template:")


def test_every_shell_block_is_run_a_template_or_skipped_with_a_reason():
    assert len(BLOCKS) >= 12
    run = [ln for ln, text, skip in BLOCKS if skip is None and not _is_template(text)]
    assert len(run) >= 4, run                      # the cheap ones are run, not excused
    for line, text, skip in BLOCKS:
        if skip is not None:
            assert len(skip) > 20, f"line {line}: a skipped block says why"
            for named in re.findall(r"tests/\w+\.py", skip):
                assert (ROOT / named).is_file(), f"line {line}: the reason names {named}, which is gone"
        if _is_template(text):
            # a template stands for something: an UPPER-CASE name or the reader's own files
            assert re.search(r"\b[A-Z]{4,}\b", text), f"line {line}: a template without a placeholder"


def test_several_logs_block_makes_the_runs_it_reads():
    """The 'Several logs' block reads run1.csv to run4.csv and RUNS.toml: it makes them first."""
    block = next(text for _, text, _ in BLOCKS if "--logs RUNS.toml -o ur5_id.toml" in text)
    made = block[:block.index("manipdyn identify")]
    assert "for k in 1 2 3 4" in made and "-o run$k.csv" in made and "> RUNS.toml" in made


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """The reader's folder: ``examples`` beside it (the guide's codegen block builds one), and the
    real-data folder in ``$MANIPDYN_REALDATA`` (a folder elsewhere: the blocks read it through the
    variable, ``../shared/realdata`` being only their fallback)."""
    base = tmp_path_factory.mktemp("reader")
    work = base / "project"
    work.mkdir()
    (work / "examples").symlink_to(ROOT / "examples")
    bindir = base / "bin"
    bindir.mkdir()
    # shims, not symlinks: a symlink to a virtual environment's python does not find its packages
    for name, cmd in (("manipdyn", f'"{sys.executable}" -m manipdyn'), ("python", f'"{sys.executable}"'),
                      ("python3", f'"{sys.executable}"')):
        shim = bindir / name
        shim.write_text(f'#!/bin/sh\nexec {cmd} "$@"\n')
        shim.chmod(shim.stat().st_mode | stat.S_IXUSR)
    env = dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}",
               PYTHONPATH=str(ROOT), MPLBACKEND="Agg", MANIPDYN_REALDATA=str(REALDATA_DIR))
    return {"dir": work, "env": env, "done": set()}


def _run_block(workdir, line, text):
    proc = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", text], cwd=workdir["dir"], env=workdir["env"],
                          capture_output=True, text=True, timeout=1200)
    workdir["done"].add(line)
    return proc


RUNNABLE = [(ln, text) for ln, text, skip in BLOCKS if skip is None and not _is_template(text)]


@pytest.mark.parametrize("line,text", RUNNABLE, ids=[ln for ln, _ in RUNNABLE])
def test_readme_shell_block_runs_as_pasted(line, text, workdir):
    if "panda_as_logged.csv" in text and not REALDATA.is_file():
        pytest.skip(f"the real-data folder is absent (panda_as_logged.csv not found in {REALDATA.parent})")
    # the blocks before it first, as the reader ran them (when this one is selected alone)
    for ln, earlier in RUNNABLE:
        if ln == line:
            break
        if ln not in workdir["done"] and not ("panda_as_logged.csv" in earlier and not REALDATA.is_file()):
            _run_block(workdir, ln, earlier)
    proc = _run_block(workdir, line, text)
    assert proc.returncode == 0, f"shell block at {line} exits {proc.returncode}:\n{proc.stderr[-3000:]}"
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
