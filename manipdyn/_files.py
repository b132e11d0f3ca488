"""Atomic file writes: a failure never leaves a partial file behind."""

from __future__ import annotations

import os
import tempfile


def atomic_write(path, write, binary: bool = False, encoding: str = "utf-8") -> None:
    """Call ``write(fh)`` on a temporary file beside ``path``, then rename it over ``path``.

    If ``write`` or the rename fails, ``path`` is untouched and the temporary
    file is removed.
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=folder)
    try:
        # mkstemp makes the file owner-only; give it the permissions a plain
        # open() would (0o666 less the umask)
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)
        mode = "wb" if binary else "w"
        kw = {} if binary else {"encoding": encoding, "newline": "\n"}
        with os.fdopen(fd, mode, **kw) as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def atomic_write_text(path, text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically."""
    atomic_write(path, lambda fh: fh.write(text), encoding=encoding)
