"""The compiled-engine cache, kept private: whatever is loaded from it was built here, by this user.

Layer 3 (engines: c), the generated-C engine.  A shared library that is loaded runs its
constructors in this process, and a library built for another arm, or cut short, is
called with arrays of the wrong size (a heap overflow) or dies of SIGBUS.  So:

* **Folders 0700 regardless of the umask.** :func:`private_root` creates the cache folder
  (:func:`manipdyn.engines.c.build.cache_dir`) and its ``c/`` folder owner-only (``chmod``
  after ``mkdir``: a umask of 000 cannot widen them).  A cache folder that belongs to another
  user, or that others may write to (group- or world-writable), is refused with a
  :class:`ModelError` naming it; manipdyn's own ``c/`` folder is narrowed back to 0700 when
  it is this user's.
* **A build is checked before it is loaded** (:func:`valid_build`): the folder, the library
  and :data:`MANIFEST` are this user's regular files (no symbolic links), writable by no one
  else, and the manifest names the same cache key, model sha256
  (:func:`manipdyn.engines.c.model_sha256`), joint count n, regressor columns p and prefix
  as the arm asks for, with the library's exact size and sha256.  A library cut short, planted,
  or built for another arm fails one of these and is rebuilt: it is never opened.
* **Builds are made aside and moved in** (:func:`install_build`): a fresh 0700 folder
  ``c/.build-XXXX`` holds the source, the library (0700) and, written last, the manifest;
  it is renamed onto the key's folder, replacing one that failed the checks.

After loading, :class:`manipdyn.engines.c.CompiledEngine` also asks the library itself for its n,
p and model sha256 (the generated ``P_joints``, ``P_parameters``, ``P_model_sha256``).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import tempfile

from ..._support.errors import ModelError
from . import build

__all__ = ["MANIFEST", "MANIFEST_FORMAT", "private_root", "valid_build", "install_build", "file_sha256",
           "build_problem"]

#: the file beside each cached library that says what it was built for
MANIFEST = "manifest.json"
#: its format tag
MANIFEST_FORMAT = "manipdyn-c-build/1"
#: the permission bits no cached folder or file may have: written by the group or by others
_LOOSE = stat.S_IWGRP | stat.S_IWOTH


def _mkdir_private(path: str) -> bool:
    """Create ``path`` as a 0700 folder (True), or leave an existing one (False)."""
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        return False
    os.chmod(path, 0o700)      # mkdir's mode is cut by the umask, never widened: make it exactly 0700
    return True


def _owner_problem(st: os.stat_result) -> str:
    if st.st_uid != os.geteuid():
        return f"belongs to uid {st.st_uid}, not to this user (uid {os.geteuid()})"
    if st.st_mode & _LOOSE:
        return f"has mode {stat.S_IMODE(st.st_mode):04o}: others may write to it"
    return ""


def private_root() -> str:
    """The cache's ``c/`` folder, created 0700 if missing, after checking the cache folder: this
    user's and writable by no one else (module docstring).  Raises :class:`ModelError` naming
    the folder and what is wrong with it."""
    root = build.cache_dir()
    missing = []
    head = root
    while head and not os.path.lexists(head):
        missing.append(head)
        parent = os.path.dirname(head)
        if parent == head:
            break
        head = parent
    for folder in reversed(missing):
        try:
            _mkdir_private(folder)
        except OSError as exc:
            raise ModelError(f"the 'c' engine's build cache: cannot create {folder!r}: {exc.strerror or exc} "
                             f"(set ${build.CACHE_ENV} to a folder of yours)") from None
    try:
        st = os.stat(root)
    except OSError as exc:
        raise ModelError(f"the 'c' engine's build cache {root!r}: {exc.strerror or exc}") from None
    problem = _owner_problem(st) if stat.S_ISDIR(st.st_mode) else "is not a folder"
    if problem:
        raise ModelError(f"the 'c' engine's build cache {root!r} {problem}; a library loaded from it runs in "
                         f"this process, so manipdyn uses only a folder of this user's that no one else can "
                         f"write to: chmod 700 it, or set ${build.CACHE_ENV} to such a folder")
    c = os.path.join(root, "c")
    _mkdir_private(c)
    st = os.lstat(c)
    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.geteuid():
        raise ModelError(f"the 'c' engine's build cache: {c!r} "
                         f"{'is not a folder' if not stat.S_ISDIR(st.st_mode) else _owner_problem(st)}; "
                         f"remove it, or set ${build.CACHE_ENV} to a folder of yours")
    if st.st_mode & (_LOOSE | 0o077):
        os.chmod(c, 0o700)     # ours: narrowed back (a umask of 000 made it 0777 before this check existed)
    return c


def file_sha256(path: str) -> str:
    """Hex sha256 of the file ``path``."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def _private_file(path: str) -> tuple[str, os.stat_result | None]:
    try:
        st = os.lstat(path)
    except OSError:
        return "is missing", None
    if not stat.S_ISREG(st.st_mode):
        return "is not a regular file (a symbolic link, folder or device)", st
    return _owner_problem(st), st


def build_problem(folder: str, library: str, expect: dict) -> str:
    """Why the build in ``folder`` may not be loaded for ``expect`` (the manifest's fields but
    the library's size and sha256), or "" when it may (module docstring)."""
    try:
        st = os.lstat(folder)
    except OSError:
        return "no build"
    if not stat.S_ISDIR(st.st_mode):
        return "not a folder"
    problem = _owner_problem(st)
    if problem:
        return f"the folder {problem}"
    mpath = os.path.join(folder, MANIFEST)
    for path in (mpath, library):
        problem, _ = _private_file(path)
        if problem:
            return f"{os.path.basename(path)} {problem}"
    try:
        with open(mpath, "rb") as f:
            manifest = json.loads(f.read(1 << 16).decode("utf-8"))
    except (OSError, ValueError) as exc:
        return f"{MANIFEST} unreadable: {exc}"
    if not isinstance(manifest, dict) or manifest.get("format") != MANIFEST_FORMAT:
        return f"{MANIFEST} is not a {MANIFEST_FORMAT} manifest"
    for key, value in expect.items():
        if manifest.get(key) != value:
            return f"built for {key} = {manifest.get(key)!r:.80}, not {value!r:.80}"
    size = os.lstat(library).st_size
    if manifest.get("size") != size:
        return f"the library has {size} bytes, the manifest says {manifest.get('size')!r:.40} (cut short?)"
    if manifest.get("sha256") != file_sha256(library):
        return "the library's sha256 is not the manifest's (changed after it was built)"
    return ""


def valid_build(folder: str, library: str, expect: dict) -> bool:
    """True when the build in ``folder`` passes :func:`build_problem`."""
    return not build_problem(folder, library, expect)


def install_build(root: str, folder: str, library_name: str, expect: dict, write) -> str:
    """Build into a fresh private folder beside ``folder`` and move it into place.

    ``write(tmp)`` writes the source and compiles ``tmp/library_name``; the manifest (``expect``
    plus the library's size and sha256) is written last.  A ``folder`` already there that fails
    :func:`build_problem` is removed first; one that passes (another process built it
    meanwhile) is kept.  Returns the library's path in ``folder``.
    """
    tmp = tempfile.mkdtemp(prefix=".build-", dir=root)     # 0700, whatever the umask
    try:
        write(tmp)
        lib = os.path.join(tmp, library_name)
        for name in os.listdir(tmp):
            os.chmod(os.path.join(tmp, name), 0o700 if name == library_name else 0o600)
        manifest = dict(expect, format=MANIFEST_FORMAT, size=os.path.getsize(lib), sha256=file_sha256(lib))
        fd = os.open(os.path.join(tmp, MANIFEST), os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(manifest, f, indent=1, sort_keys=True)
        library = os.path.join(folder, library_name)
        for attempt in range(2):
            try:
                os.rename(tmp, folder)
                return library
            except OSError:
                if valid_build(folder, library, expect):
                    return library
                if attempt == 0:
                    _remove(folder)
        raise ModelError(f"the 'c' engine's build cache: cannot move the build into {folder!r}")
    finally:
        if os.path.isdir(tmp):
            shutil.rmtree(tmp, ignore_errors=True)


def _remove(path: str) -> None:
    """Remove a failed build (a folder, or a file or link planted where one should be)."""
    try:
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        else:
            os.unlink(path)
    except FileNotFoundError:
        pass
    except OSError as exc:
        raise ModelError(f"the 'c' engine's build cache: {path!r} failed its checks and cannot be removed: "
                         f"{exc.strerror or exc}; remove it, or set ${build.CACHE_ENV} to a folder of yours") from None
