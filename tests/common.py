"""Helpers the test files share: the real logs' places (Panda, KUKA LWR4+) and their skips, and a refused
command's line.

The real-data logs live beside the project in ``../shared/realdata`` (measured by others, with their
sources in that folder's README), or wherever ``$MANIPDYN_REALDATA`` points (``benchmarks/realdata.py``);
the tests read them there and never copy them in.  Where the folder is absent, the tests that need it
skip, saying so.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.realdata import ENV, lwr4_dir, panda_log, realdata_dir

ROOT = Path(__file__).resolve().parents[1]
#: the real-data folder: ``$MANIPDYN_REALDATA`` when set, else ``../shared/realdata``
REALDATA = realdata_dir()
#: the real Panda log (Gaz et al. 2019), as logged: ``<REALDATA>/panda_gaz2019/panda_as_logged.csv``
PANDA_LOG = panda_log()
#: why a test that needs it skips
PANDA_SKIP = (f"the real-data folder is absent (panda_as_logged.csv not found in {PANDA_LOG.parent}; "
              f"set {ENV} to the folder that holds panda_gaz2019/)")
#: mark a test (or ``pytestmark`` a module) that reads the real Panda log
needs_panda_log = pytest.mark.skipif(not PANDA_LOG.is_file(), reason=PANDA_SKIP)


#: the KUKA LWR4+ runs (FloBaRoID's): ``run1.csv`` .. ``run3.csv`` and the two published URDFs
LWR4_DIR = lwr4_dir()
LWR4_SKIP = (f"the real-data folder is absent (run1.csv .. run3.csv and kuka_lwr4_gaz.urdf not found in {LWR4_DIR}; "
             f"set ${ENV} to the folder that holds lwr4_flobaroid/)")
#: mark a test (or ``pytestmark`` a module) that reads the LWR4 runs
needs_lwr4 = pytest.mark.skipif(not all((LWR4_DIR / f).is_file() for f in (
    "run1.csv", "run2.csv", "run3.csv", "kuka_lwr4_gaz.urdf", "kuka_lwr4_identified.urdf")), reason=LWR4_SKIP)


def err_line(capsys) -> str:
    """The one line a refused command prints on stderr (asserts there is exactly one)."""
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1, cap.err
    return lines[0]


def sigint_as_a_terminal_gives_it() -> None:
    """``preexec_fn`` of a child that a test will Ctrl-C: SIGINT back to its default action.

    A process started in the background by a non-interactive shell (``cmd &``, ``nohup``, some CI
    runners) inherits SIGINT *ignored*, and Python then installs no KeyboardInterrupt handler: the
    child never sees the test's Ctrl-C, a study runs to its end and ``bench`` exits 0 (issue 38,
    item 10: the four "timing" failures on a fresh machine were this, not the clock).  A terminal's
    foreground job has the default action, which is what these tests are about.
    """
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
