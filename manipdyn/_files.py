"""Atomic file writes: a failure never leaves a partial file behind.

Layer: 0 (utilities): atomic file writes.
"""

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
    if os.path.isdir(path):
        raise IsADirectoryError(21, "Is a directory, expected a file path", path)
    try:
        fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=folder)
    except OSError as exc:  # name the file asked for, not the temporary one
        raise type(exc)(exc.errno, exc.strerror, path) from None
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
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError) and exc.filename == tmp:
            raise type(exc)(exc.errno, exc.strerror, path) from None
        raise


def atomic_write_text(path, text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically."""
    atomic_write(path, lambda fh: fh.write(text), encoding=encoding)
