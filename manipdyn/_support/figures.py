"""Figures on disk: matplotlib on the Agg backend, and atomic saving.

Layer 0 (support).  Every package that draws (identification,
control, Monte-Carlo, the CLI) imports these two from here, so that no
application package needs another one just to save a figure.
"""

from __future__ import annotations

import os

from .errors import ModelError
from .files import atomic_write

__all__ = ["PLOT_INSTALL", "pyplot", "save_figure"]


#: the install hint for plots, as the README gives it
PLOT_INSTALL = "pip install 'manipdyn[plot]' (in a source checkout: pip install -e '.[plot]')"


def pyplot():
    """matplotlib.pyplot on the Agg backend, or a ModelError with the install command."""
    try:
        import matplotlib
    except ImportError:
        raise ModelError(f"--plot needs matplotlib: {PLOT_INSTALL}") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: str) -> None:
    """``fig.savefig`` to ``path`` atomically (no partial figure on failure)."""
    ext = os.path.splitext(os.fspath(path))[1].lstrip(".").lower() or "png"
    atomic_write(path, lambda fh: fig.savefig(fh, format=ext, dpi=120), binary=True)
