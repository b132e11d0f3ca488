"""The URDFs shipped by example-robot-data, found from its installed files.

Layer 2 (formats) loaders (finds the URDFs of example-robot-data).

example-robot-data 5 and later ship URDF files only (under the package's
``cmeel.prefix/share/example-robot-data/robots/``), no Python loader::

    import manipdyn as md
    from manipdyn.formats.erd import urdf_path
    arm = md.load(urdf_path("ur5_robot"))
"""

from __future__ import annotations

import functools
import importlib.metadata
from pathlib import Path

from .._support.errors import ModelError

__all__ = ["robots_dir", "urdf_path", "urdf_names"]


@functools.lru_cache(maxsize=1)
def robots_dir() -> Path:
    """The ``robots`` folder of the installed example-robot-data."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise ModelError("example-robot-data is not installed (a dependency of manipdyn): "
                         "pip install example-robot-data") from None
    for f in dist.files or ():
        parts = f.parts
        if "robots" in parts and parts[-1].endswith(".urdf"):
            i = parts.index("robots")
            return Path(dist.locate_file(Path(*parts[: i + 1])))
    raise ModelError("example-robot-data is installed but ships no URDF files")


def urdf_names() -> list[str]:
    """Names (file stems) of every URDF in example-robot-data, sorted, each once."""
    return sorted({p.stem for p in robots_dir().rglob("*.urdf")})


def urdf_path(name: str) -> Path:
    """Path of ``<name>.urdf`` in example-robot-data, e.g. ``urdf_path("ur5_robot")``."""
    hits = sorted(robots_dir().rglob(f"{name}.urdf"))
    if not hits:
        import difflib

        names = urdf_names()
        close = difflib.get_close_matches(name, names, n=3, cutoff=0.6)
        hint = (f"did you mean {' or '.join(map(repr, close))}?" if close else
                f"e.g. {', '.join(([n for n in names if name.split('_')[0] in n] or names)[:8])}")
        raise ModelError(f"example-robot-data has no URDF named {name!r}; {hint} "
                         "(manipdyn models --erd lists them)")
    return hits[0]
