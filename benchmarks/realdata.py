"""Where the real-arm logs are: ``$MANIPDYN_REALDATA`` when set, else ``../shared/realdata`` beside the project.

The logs (the Franka Panda of Gaz et al. 2019, a KUKA LWR4+) are measured outside the project and never
copied into it; a clone that does not sit beside them points ``MANIPDYN_REALDATA`` at the folder that
holds ``panda_gaz2019/`` (a relative path is read from the current folder).  The benchmarks and the
tests (``tests/common.py``) read the folder through :func:`realdata_dir` alone.
"""

from __future__ import annotations

import os
from pathlib import Path

#: the environment variable naming the real-data folder (the one holding ``panda_gaz2019/``)
ENV = "MANIPDYN_REALDATA"


def realdata_dir() -> Path:
    """The real-data folder: ``$MANIPDYN_REALDATA`` (made absolute) when set and not empty, else
    ``shared/realdata`` beside the project's folder.  It may be absent: callers check and say so."""
    where = os.environ.get(ENV, "").strip()
    if where:
        return Path(where).expanduser().absolute()
    return Path(__file__).resolve().parents[1].parent / "shared" / "realdata"


def lwr4_dir() -> Path:
    """The KUKA LWR4+ runs and its two published URDFs: ``<realdata>/lwr4_flobaroid``."""
    return realdata_dir() / "lwr4_flobaroid"


def panda_log() -> Path:
    """The real Panda log as logged: ``<realdata>/panda_gaz2019/panda_as_logged.csv``."""
    return realdata_dir() / "panda_gaz2019" / "panda_as_logged.csv"
