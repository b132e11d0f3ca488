"""Issue 31 item 1: every shell block of the README runs as pasted, or says plainly why not.

A block is one of three kinds:

* run here, in README order, in one working folder as a reader following the README uses one
  (``manipdyn`` and ``python`` on the PATH are this interpreter; the project's ``examples/`` and the
  real-data folder ``../shared`` are where the README's relative paths expect them);
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

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
SHARED = ROOT.parent / "shared"
REALDATA = SHARED / "realdata" / "panda_gaz2019" / "panda_as_logged.csv"

SKIP = re.compile(r"<!-- tests skip this block: (.+?) -->\n$")


def _sh_blocks():
    """``(line, text, skip reason or None)`` of every ```` ```sh ```` block, in README order."""
    out = []
    for m in re.finditer(r"^```sh\n(.*?)^```", README, flags=re.S | re.M):
        before = README[:m.start()]
        prev = before[before.rstrip("\n").rfind("\n") + 1:]       # the line before the fence
        skip = SKIP.search(prev)
        out.append((before.count("\n") + 1, m.group(1), skip.group(1) if skip else None))
    return out


BLOCKS = _sh_blocks()


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
    """The reader's folder: ``examples`` beside it (the README's codegen block builds one) and the
    real-data folder at ``../shared`` (the README's Panda blocks read it "from the project's folder")."""
    base = tmp_path_factory.mktemp("reader")
    work = base / "project"
    work.mkdir()
    (work / "examples").symlink_to(ROOT / "examples")
    if SHARED.is_dir():
        (base / "shared").symlink_to(SHARED)
    bindir = base / "bin"
    bindir.mkdir()
    # shims, not symlinks: a symlink to a virtual environment's python does not find its packages
    for name, cmd in (("manipdyn", f'"{sys.executable}" -m manipdyn'), ("python", f'"{sys.executable}"'),
                      ("python3", f'"{sys.executable}"')):
        shim = bindir / name
        shim.write_text(f'#!/bin/sh\nexec {cmd} "$@"\n')
        shim.chmod(shim.stat().st_mode | stat.S_IXUSR)
    env = dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}",
               PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return {"dir": work, "env": env, "done": set()}


def _run_block(workdir, line, text):
    proc = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", text], cwd=workdir["dir"], env=workdir["env"],
                          capture_output=True, text=True, timeout=1200)
    workdir["done"].add(line)
    return proc


RUNNABLE = [(ln, text) for ln, text, skip in BLOCKS if skip is None and not _is_template(text)]


@pytest.mark.parametrize("line,text", RUNNABLE, ids=[f"line{ln}" for ln, _ in RUNNABLE])
def test_readme_shell_block_runs_as_pasted(line, text, workdir):
    if "../shared/realdata" in text and not REALDATA.is_file():
        pytest.skip("the real-data folder is absent (panda_as_logged.csv not found beside the project)")
    # the blocks before it first, as the reader ran them (when this one is selected alone)
    for ln, earlier in RUNNABLE:
        if ln >= line:
            break
        if ln not in workdir["done"] and not ("../shared/realdata" in earlier and not REALDATA.is_file()):
            _run_block(workdir, ln, earlier)
    proc = _run_block(workdir, line, text)
    assert proc.returncode == 0, f"README shell block at line {line} exits {proc.returncode}:\n{proc.stderr[-3000:]}"
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
