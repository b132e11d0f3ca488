"""Helpers the test files share: the real logs' places (Panda, KUKA LWR4+) and their skips, and a refused
command's line.

The real-data logs live beside the project in ``../shared/realdata`` (measured by others, with their
sources in that folder's README); the tests read them there and never copy them in.  Where the folder
is absent, the tests that need it skip, saying so.
"""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: the real Panda log (Gaz et al. 2019), as logged: ``../shared/realdata/panda_gaz2019/panda_as_logged.csv``
PANDA_LOG = ROOT.parent / "shared" / "realdata" / "panda_gaz2019" / "panda_as_logged.csv"
#: why a test that needs it skips
PANDA_SKIP = ("the real-data folder is absent (panda_as_logged.csv not found beside the project in "
              "shared/realdata/panda_gaz2019)")
#: mark a test (or ``pytestmark`` a module) that reads the real Panda log
needs_panda_log = pytest.mark.skipif(not PANDA_LOG.is_file(), reason=PANDA_SKIP)


#: the KUKA LWR4+ runs (FloBaRoID's): ``run1.csv`` .. ``run3.csv`` and the two published URDFs
LWR4_DIR = ROOT.parent / "shared" / "realdata" / "lwr4_flobaroid"
LWR4_SKIP = ("the real-data folder is absent (run1.csv .. run3.csv and kuka_lwr4_gaz.urdf not found beside the "
             "project in shared/realdata/lwr4_flobaroid)")
#: mark a test (or ``pytestmark`` a module) that reads the LWR4 runs
needs_lwr4 = pytest.mark.skipif(not all((LWR4_DIR / f).is_file() for f in (
    "run1.csv", "run2.csv", "run3.csv", "kuka_lwr4_gaz.urdf", "kuka_lwr4_identified.urdf")), reason=LWR4_SKIP)


def err_line(capsys) -> str:
    """The one line a refused command prints on stderr (asserts there is exactly one)."""
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1, cap.err
    return lines[0]
