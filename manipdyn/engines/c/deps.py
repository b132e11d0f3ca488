"""The optional ``codegen`` extra (CasADi) of the generated-C engine.

Layer 3 (engines: c).  :func:`casadi` imports CasADi or raises
:class:`~manipdyn._support.errors.MissingExtraError` with the install command, never a
bare ``ImportError`` traceback.  Only writing C needs CasADi: a build already
in the cache (:mod:`manipdyn.engines.c.build`) loads without it.
"""

from __future__ import annotations

from ..._support.deps import install_command, require

__all__ = ["casadi", "INSTALL", "manipdyn_version"]

#: the command that installs what code generation needs
INSTALL = install_command("codegen")


def casadi():
    """The ``casadi`` module, or :class:`MissingExtraError` naming the extra to install."""
    return require("casadi", "generating C (md.codegen, the 'c' engine)", "codegen", "code-generation")


def manipdyn_version() -> str:
    """The installed manipdyn's version (read from the package metadata: this layer does not
    import the package top), or "unknown" when it runs from a source tree that is not installed."""
    from importlib import metadata

    try:
        return metadata.version("manipdyn")
    except metadata.PackageNotFoundError:
        return "unknown"
