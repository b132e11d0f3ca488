"""Compiling the generated C: the system's compiler, a strict test build, and the build cache.

Layer 3 (engines: c), the generated-C engine.

* :func:`find_compiler`: ``$CC`` if set, else ``cc``, else ``gcc`` on the PATH (None: none).
* :func:`check_compiles`: ``-std=c99 -Wall -Wextra -pedantic -Werror -c``; a
  diagnostic raises :class:`ModelError` with the compiler's first lines.
* :func:`compile_shared`: ``-std=c99 -O2 -shared -fPIC`` into a shared library,
  written under a temporary name and moved into place (atomic: a reader sees
  the whole library or none).
* :func:`cache_dir`: ``$MANIPDYN_CACHE_DIR``, else ``$XDG_CACHE_HOME/manipdyn``,
  else ``~/.cache/manipdyn``; builds live in its ``c/`` folder, one folder per
  key (the model's sha256, manipdyn's version, the generator's and the compiler).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile

from ..._support.errors import ModelError

__all__ = ["find_compiler", "check_compiles", "compile_shared", "cache_dir", "STRICT_FLAGS", "BUILD_FLAGS",
           "CACHE_ENV", "build_key"]

#: the flags the generated C must pass cleanly (the issue's)
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror")
#: the flags of the engine's shared library
BUILD_FLAGS = ("-std=c99", "-shared", "-fPIC")   # and the optimisation flag, -O2 by default
#: the environment variable that overrides the cache folder
CACHE_ENV = "MANIPDYN_CACHE_DIR"
#: seconds one compiler run may take before it is stopped
COMPILE_TIMEOUT = 600


def find_compiler() -> str | None:
    """The C compiler to use: ``$CC`` (a command name or path), else ``cc``, else ``gcc``; None if none."""
    env = os.environ.get("CC", "").strip()
    for cand in ([env] if env else []) + ["cc", "gcc"]:
        path = shutil.which(cand)
        if path:
            return path
    return None


def _run(cmd, what: str, strict: bool = False) -> None:
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=COMPILE_TIMEOUT)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise ModelError(f"{what}: could not run the C compiler {cmd[0]!r}: {exc}") from None
    if res.returncode != 0 or (strict and res.stderr.strip()):
        lines = (res.stderr or res.stdout).strip().splitlines()
        shown = "\n".join(lines[:12]) + ("\n..." if len(lines) > 12 else "")
        raise ModelError(f"{what}: {' '.join(os.path.basename(c) if i == 0 else c for i, c in enumerate(cmd))} "
                         f"failed (exit {res.returncode}):\n{shown}")


def check_compiles(cc: str, cpath: str) -> None:
    """Compile ``cpath`` with :data:`STRICT_FLAGS` into a throw-away object; any diagnostic raises."""
    with tempfile.TemporaryDirectory(prefix="manipdyn-cc-") as tmp:
        _run([cc, *STRICT_FLAGS, "-c", cpath, "-o", os.path.join(tmp, "check.o")],
             f"generated C {os.path.basename(cpath)}", strict=True)


def compile_shared(cc: str, cpath: str, sopath: str, extra=()) -> None:
    """Compile ``cpath`` into the shared library ``sopath`` (:data:`BUILD_FLAGS`), atomically."""
    folder = os.path.dirname(os.path.abspath(sopath))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".build-", suffix=".so", dir=folder)
    os.close(fd)
    try:
        _run([cc, *BUILD_FLAGS, *extra, cpath, "-o", tmp, "-lm"], f"building {os.path.basename(cpath)}")
        os.replace(tmp, sopath)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def cache_dir() -> str:
    """The folder of manipdyn's build cache (module docstring); not created here.  A relative
    ``$MANIPDYN_CACHE_DIR`` is a :class:`ModelError` naming it."""
    env = os.environ.get(CACHE_ENV, "").strip()
    if env:
        path = os.path.expanduser(env)
        if not os.path.isabs(path):       # it would make a cache in whatever folder the program runs in
            raise ModelError(f"${CACHE_ENV}: expected an absolute folder (or one under ~), got {env!r:.200}, "
                             "which is relative to the current folder")
        return os.path.normpath(path)
    xdg = os.environ.get("XDG_CACHE_HOME", "").strip()
    base = xdg if xdg and os.path.isabs(xdg) else os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "manipdyn")


def build_key(model_sha: str, version: str, generator: str, cc: str) -> str:
    """The cache key of one build: sha256 of the model's hash, the versions, the compiler and flags."""
    h = hashlib.sha256()
    for part in (model_sha, version, generator, os.path.realpath(cc), " ".join(BUILD_FLAGS)):
        h.update(part.encode() + b"\0")
    return h.hexdigest()[:32]


def require_compiler(what: str) -> str:
    """:func:`find_compiler`, or a :class:`ModelError` saying ``what`` needs one."""
    cc = find_compiler()
    if cc is None:
        raise ModelError(f"{what} needs a C compiler (set $CC, or install cc/gcc); none was found on the PATH. "
                         "The Python engines ('lagrange', 'pinocchio') work without one.")
    return cc
