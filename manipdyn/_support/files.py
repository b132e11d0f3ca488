"""Atomic file writes: a failure never leaves a partial file behind.

Layer 0 (support): atomic file writes.

Policy (what :func:`atomic_write` does to the target ``path``):

* The text is written to a temporary file beside the target, flushed to
  disk, then renamed over it: readers see the old file or the new one, never
  a partial one.
* Only a regular file (or nothing) is replaced.  A directory, device node
  (``/dev/full``), FIFO or socket is refused with an ``OSError`` naming the
  path, before anything is written: replacing ``/dev/null`` with a regular
  file, as root, breaks the machine.
* A symbolic link is written THROUGH: its final target is replaced (and
  must itself be a regular file or absent, in an existing folder); the link
  stays a link.  This is what ``open(path, "w")`` would do.
* An existing file keeps its permission bits (a 0600 file stays 0600); a
  new file gets ``0666`` less the umask, as ``open()`` would give it.
* The temporary file is removed when the write fails, on ``KeyboardInterrupt``
  and on ``SIGTERM`` (while the write runs, a ``SIGTERM`` received by the main
  thread raises inside it; after the clean-up the signal is delivered again
  with the handler that was there before, so the process still terminates).
* ``kill -9`` (or a power cut) cannot be caught: it can leave the temporary
  file ``.NAME.manipdyn-PID-XXXXXXXX.tmp`` beside the target (never a
  partial target).  The next write into the same folder removes such files
  whose process ``PID`` no longer runs and that belong to the current user
  (same host assumed: on a folder shared between machines a live process of
  another machine could lose its temporary file, so the sweep also requires
  the file to be older than :data:`STALE_SECONDS`).
"""

from __future__ import annotations

import errno
import os
import re
import signal
import stat
import tempfile
import threading
import time

from .errors import ModelError

__all__ = ["atomic_write", "atomic_write_text", "sweep_stale_temporaries", "overwrites", "replaceable",
           "link_out_of", "STALE_SECONDS"]

#: a temporary file is swept only when its process is gone AND it is this old
STALE_SECONDS = 60.0
_TMP = re.compile(r"^\..+\.manipdyn-(\d+)-[A-Za-z0-9_]+\.tmp$")


class _Terminated(BaseException):
    """SIGTERM received while a temporary file was open."""


def sweep_stale_temporaries(folder: str) -> list[str]:
    """Remove this user's manipdyn temporaries in ``folder`` left by dead processes.

    Returns the paths removed.  Never raises (a sweep is a courtesy).
    """
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    now = time.time()
    for name in names:
        m = _TMP.match(name)
        if not m:
            continue
        pid = int(m.group(1))
        if pid == os.getpid():
            continue
        try:
            os.kill(pid, 0)
            continue  # still running
        except ProcessLookupError:
            pass
        except (PermissionError, OverflowError, OSError):
            continue  # someone else's live process, or an impossible pid: leave it
        p = os.path.join(folder, name)
        try:
            st = os.lstat(p)
            if (stat.S_ISREG(st.st_mode) and st.st_uid == os.geteuid()
                    and now - st.st_mtime >= STALE_SECONDS):
                os.unlink(p)
                removed.append(p)
        except OSError:
            pass
    return removed


def _target(path: str) -> tuple[str, os.stat_result | None]:
    """The file to replace (a symlink's final target) and its stat, or None if absent."""
    real = os.path.realpath(path) if os.path.islink(path) else path
    try:
        st = os.stat(real)
    except FileNotFoundError:
        return real, None
    except OSError as exc:
        raise type(exc)(exc.errno, exc.strerror, path) from None
    if stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(errno.EISDIR, "Is a directory, expected a file path", path)
    if not stat.S_ISREG(st.st_mode):
        kind = ("a character device" if stat.S_ISCHR(st.st_mode) else "a block device" if stat.S_ISBLK(st.st_mode)
                else "a FIFO" if stat.S_ISFIFO(st.st_mode) else "a socket" if stat.S_ISSOCK(st.st_mode)
                else "not a regular file")
        raise OSError(errno.EINVAL, f"refusing to replace {kind}; manipdyn writes regular files only", path)
    return real, st


def link_out_of(folder, path) -> str | None:
    """Where ``path`` leads when it is a symbolic link (or passes through one) to a place outside
    ``folder``, else None.  A command that writes into a folder refuses such a file: writing through
    it would replace a file the user never named (:func:`atomic_write` follows links)."""
    path = os.fspath(path)
    if not os.path.islink(path):
        return None
    real = os.path.realpath(path)
    base = os.path.realpath(os.fspath(folder))
    if real == base or real.startswith(base.rstrip(os.sep) + os.sep):
        return None
    return real


def replaceable(path) -> str:
    """The file :func:`atomic_write` would replace for ``path`` (a symbolic link's final target),
    checked before any work: an ``OSError`` naming ``path`` when it is a folder, a device, a FIFO
    or a socket, or when its folder does not exist."""
    real, _ = _target(os.fspath(path))
    folder = os.path.dirname(os.path.abspath(real))
    if not os.path.isdir(folder):
        raise FileNotFoundError(errno.ENOENT, "the folder does not exist", os.fspath(path))
    return real


def overwrites(output, source) -> bool:
    """True when writing ``output`` would replace ``source`` or a file inside it (``source`` a
    folder, a ROS bag's): the same path once symbolic links are resolved, or the same file
    by another name (a hard link).  What :func:`atomic_write` replaces is the link's target,
    so an output that is a link to an input destroys the input."""
    out = os.path.realpath(os.fspath(output))
    src = os.path.realpath(os.fspath(source))
    if out == src:
        return True
    if os.path.isdir(src):
        return os.path.commonpath([out, src]) == src
    try:
        return os.path.samefile(out, src)
    except (OSError, ValueError):
        return False


def atomic_write(path, write, binary: bool = False, encoding: str = "utf-8") -> None:
    """Call ``write(fh)`` on a temporary file beside ``path``, then rename it over ``path``.

    See the module docstring for the policy (regular files only, symlinks
    written through, mode kept, clean-up on errors, Ctrl-C and SIGTERM).
    If ``write`` or the rename fails, ``path`` is untouched.
    """
    try:
        path = os.fsdecode(os.fspath(path))
    except TypeError:
        raise ModelError(f"path: expected a file path (str or os.PathLike), got {type(path).__name__}") from None
    if "\x00" in path:
        raise ModelError(f"path: {path!r} contains a NUL character")
    real, st = _target(path)
    folder = os.path.dirname(os.path.abspath(real))
    sweep_stale_temporaries(folder)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(real)}.manipdyn-{os.getpid()}-",
                                   suffix=".tmp", dir=folder)
    except OSError as exc:  # name the file asked for, not the temporary one
        raise type(exc)(exc.errno, exc.strerror, path) from None
    old_handler = None
    main = (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGTERM) is not signal.SIG_IGN)
    if main:
        def _on_term(signum, frame):
            raise _Terminated()
        try:
            old_handler = signal.signal(signal.SIGTERM, _on_term)
        except (ValueError, OSError):
            main = False
    try:
        if st is not None:
            mode = stat.S_IMODE(st.st_mode)  # keep the existing file's permissions
        else:  # mkstemp makes the file owner-only; a plain open() gives 0o666 less the umask
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.fchmod(fd, mode)
        fmode = "wb" if binary else "w"
        kw = {} if binary else {"encoding": encoding, "newline": "\n"}
        with os.fdopen(fd, fmode, **kw) as fh:
            fd = -1
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, real)
    except BaseException as exc:
        if fd >= 0:
            try:
                os.close(fd)
            except OSError:
                pass
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if main:
            signal.signal(signal.SIGTERM, old_handler)
            main = False
        if isinstance(exc, _Terminated):
            # deliver the signal again, to whatever handled it before us
            if callable(old_handler):
                old_handler(signal.SIGTERM, None)
            else:
                os.kill(os.getpid(), signal.SIGTERM)
            raise KeyboardInterrupt("SIGTERM while writing " + path) from None
        if isinstance(exc, OSError) and exc.filename in (tmp, None) and exc.errno is not None:
            # the temporary file's name, or none (a write, flush or fsync: EFBIG, ENOSPC): the file asked for
            raise type(exc)(exc.errno, exc.strerror, path) from None
        raise
    finally:
        if main:
            signal.signal(signal.SIGTERM, old_handler)


def atomic_write_text(path, text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically."""
    atomic_write(path, lambda fh: fh.write(text), encoding=encoding)
