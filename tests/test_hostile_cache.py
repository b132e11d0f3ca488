"""Issue 31, item 24: the compiled-engine cache runs nothing it did not build, and a model
file never makes manipdyn read another file.

Each test plants what the issue planted (a library owned by another user whose constructor
leaves a marker, a library cut short, another arm's library under the key, a cache folder
others may write to, ``umask 000``) in a private temporary cache, and checks the outcome:
the planted library is never opened (no marker), the engine's numbers are the arm's own,
and the folders and files are this user's and writable by no one else.  The crash cases
(SIGBUS, heap overflow) run in a subprocess, so a regression fails the test instead of
killing pytest.  Ownership by another user needs root (``chown``); those tests skip
otherwise, saying so.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import manipdyn as md
from manipdyn.engines.c import CompiledEngine, build, compiled_engine
from manipdyn.engines.c.cache import MANIFEST
from manipdyn.engines.c.engine import library_for
from manipdyn.model.random_arms import random_arm

CC = build.find_compiler()
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler ($CC, cc or gcc) on this machine")
is_root = pytest.mark.skipif(os.geteuid() != 0, reason="giving a file to another user (chown) needs root")
pytest.importorskip("casadi")
NOBODY = 65534
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: the engines' agreement bound of tests/test_codegen.py (relative): the same sums, another order
TOL = 1e-10


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh private cache for one test (the folder does not exist yet)."""
    folder = tmp_path / "cache"
    monkeypatch.setenv(build.CACHE_ENV, str(folder))
    return folder


def _planted_library(path, marker) -> None:
    """A shared library whose constructor creates ``marker``: loading it runs it."""
    src = path.parent / "planted.c"
    src.write_text(textwrap.dedent(f"""
        #include <stdio.h>
        __attribute__((constructor)) static void planted(void)
        {{ FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}
        void md_inverse_dynamics_batch(void) {{}}
    """))
    subprocess.run([CC, "-shared", "-fPIC", str(src), "-o", str(path)], check=True)
    src.unlink()


def _key_folder(arm) -> str:
    """The cache folder of ``arm``'s -O0 build (built once, to learn the key).

    Built, never loaded: the tests then truncate or overwrite the library in place, and a
    library mapped into pytest's own process that is cut short under it dies of SIGBUS when
    the process touches or unloads it (at exit, after every test has passed)."""
    return os.path.dirname(library_for(arm, opt="-O0"))


def _agrees(engine, arm) -> None:
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.standard_normal((3, 4, arm.n))
    ref = arm.lagrange.inverse_dynamics(q, qd, qdd)
    assert np.allclose(engine.inverse_dynamics(q, qd, qdd), ref, rtol=TOL, atol=TOL * np.abs(ref).max())


def _modes(folder):
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for name in [""] + dirnames + filenames:
            p = os.path.join(dirpath, name)
            out[p] = os.lstat(p)
    return out


@needs_cc
@is_root
@pytest.mark.parametrize("who", ["folder", "library"])
def test_a_library_planted_by_another_user_is_never_loaded(cache, tmp_path, who):
    """Issue: "a libmd.so placed there by another user (owned by nobody) is loaded, and its
    constructor runs"."""
    arm = random_arm(11, n=2)
    folder = _key_folder(arm)
    for name in os.listdir(folder):
        os.unlink(os.path.join(folder, name))
    marker = tmp_path / "constructor-ran"
    lib = os.path.join(folder, "libmd.so")
    _planted_library(tmp_path / "libmd.so", marker)
    os.replace(tmp_path / "libmd.so", lib)
    os.chown(lib, NOBODY, NOBODY)
    if who == "folder":
        os.chown(folder, NOBODY, NOBODY)
        os.chmod(folder, 0o777)
    engine = compiled_engine(arm, opt="-O0")
    assert not marker.exists(), "the planted library's constructor ran"
    _agrees(engine, arm)
    st = os.lstat(engine.library)
    assert st.st_uid == os.geteuid() and not st.st_mode & 0o022


@needs_cc
def test_a_writable_library_or_manifest_is_rebuilt(cache, tmp_path):
    """A library or manifest others may write to is not trusted: rebuilt, 0700 / 0600."""
    arm = random_arm(12, n=2)
    folder = _key_folder(arm)
    lib = os.path.join(folder, "libmd.so")
    before = os.stat(lib).st_ino
    os.chmod(lib, 0o777)
    engine = compiled_engine(arm, opt="-O0")
    assert os.stat(engine.library).st_ino != before
    assert stat.S_IMODE(os.stat(engine.library).st_mode) == 0o700
    os.chmod(os.path.join(folder, MANIFEST), 0o666)
    before = os.stat(engine.library).st_ino
    again = compiled_engine(arm, opt="-O0")
    assert os.stat(again.library).st_ino != before
    assert stat.S_IMODE(os.stat(os.path.join(folder, MANIFEST)).st_mode) == 0o600


@needs_cc
def test_umask_000_still_makes_private_folders_and_files(cache):
    """Issue: "With umask 000 the cache folders are created 0777"."""
    old = os.umask(0)
    try:
        engine = compiled_engine(random_arm(13, n=2), opt="-O0")
    finally:
        os.umask(old)
    modes = _modes(str(cache))
    assert os.path.dirname(engine.library) in modes
    for path, st in modes.items():
        assert st.st_uid == os.geteuid(), path
        assert not st.st_mode & 0o022, (path, oct(st.st_mode))
        if stat.S_ISDIR(st.st_mode):
            assert stat.S_IMODE(st.st_mode) == 0o700, (path, oct(st.st_mode))


_CHILD = """
import os, sys, numpy as np
from manipdyn.engines.c import compiled_engine
from manipdyn.model.random_arms import random_arm
arm = random_arm(int(sys.argv[1]), n=int(sys.argv[2]))
e = compiled_engine(arm, opt="-O0")
q = np.linspace(-1, 1, arm.n)
print(float(np.abs(e.inverse_dynamics(q, q, q) - arm.lagrange.inverse_dynamics(q, q, q)).max()))
"""


def _child(seed, n, cache):
    env = dict(os.environ, PYTHONPATH=ROOT, **{build.CACHE_ENV: str(cache)})
    return subprocess.run([sys.executable, "-c", _CHILD, str(seed), str(n)], capture_output=True, text=True,
                          env=env, timeout=600)


@needs_cc
@pytest.mark.parametrize("keep", [0.5, 0.98])
def test_a_library_cut_short_is_rebuilt_not_a_sigbus(cache, keep):
    """Issue: "A truncated library dies of SIGBUS and is never rebuilt"."""
    arm = random_arm(14, n=3)
    lib = library_for(arm, opt="-O0")       # built, not loaded here: see _key_folder
    size = os.path.getsize(lib)
    with open(lib, "r+b") as f:
        f.truncate(int(size * keep))
    res = _child(14, 3, cache)
    assert res.returncode == 0, (res.returncode, res.stderr[-2000:])
    assert float(res.stdout.split()[-1]) < 1e-8      # the arm's own numbers (a few N m at most)
    assert os.path.getsize(lib) == size


@needs_cc
@pytest.mark.parametrize("n_other", [2, 3])
def test_another_arms_library_under_the_key_is_rebuilt(cache, n_other):
    """Issue: "ur5's for ur10 is 69 N m off, and a 7-joint library on a 6-joint arm overflows
    the heap".  Another arm's whole build (library and manifest) is copied under this arm's key."""
    target = random_arm(15, n=2)
    folder = _key_folder(target)
    other = os.path.dirname(library_for(random_arm(16, n=n_other), opt="-O0"))
    for name in os.listdir(other):
        with open(os.path.join(other, name), "rb") as src, open(os.path.join(folder, name), "wb") as dst:
            dst.write(src.read())
    res = _child(15, 2, cache)
    assert res.returncode == 0, (res.returncode, res.stderr[-2000:])
    assert float(res.stdout.split()[-1]) < 1e-8
    with open(os.path.join(folder, MANIFEST)) as f:
        assert json.load(f)["n"] == 2


@needs_cc
def test_a_cache_folder_others_may_write_is_refused_by_name(cache):
    os.mkdir(cache, 0o700)
    os.chmod(cache, 0o777)
    with pytest.raises(md.ModelError, match=r"cache .*mode 0777.*MANIPDYN_CACHE_DIR"):
        compiled_engine(random_arm(17, n=2), opt="-O0")


@needs_cc
@is_root
def test_a_cache_folder_of_another_user_is_refused_by_name(cache):
    os.mkdir(cache, 0o700)
    os.chown(cache, NOBODY, NOBODY)
    with pytest.raises(md.ModelError, match=r"belongs to uid 65534"):
        compiled_engine(random_arm(17, n=2), opt="-O0")


@needs_cc
def test_compiled_engine_checks_the_library_before_the_first_call(cache):
    """Issue 30: "CompiledEngine(lib, n=3) overflows the heap"; its arguments' types are
    manipdyn errors naming them."""
    arm = random_arm(18, n=2)
    e = compiled_engine(arm, opt="-O0")
    with pytest.raises(md.ModelError, match=r"generated for n = 2 joints .* not n = 3"):
        CompiledEngine(e.library, 3, e.p)
    with pytest.raises(md.ModelError, match=r"p = 22 regressor columns, not n = 2, p = 30"):
        CompiledEngine(e.library, 2, 30)
    with pytest.raises(md.ModelError, match=r"model sha256"):
        CompiledEngine(e.library, 2, e.p, model_sha256="0" * 64)
    for args, name in [((5, 2, 22), "library"), ((e.library, "2", 22), "n"), ((e.library, 2, 2.5), "p"),
                       ((e.library, 0, 22), "n"), ((e.library, True, 22), "n")]:
        with pytest.raises(md.ModelError, match=rf"^{name}: expected"):
            CompiledEngine(*args)
    with pytest.raises(md.ModelError, match=r"^prefix: expected a C identifier"):
        CompiledEngine(e.library, 2, e.p, prefix=7)


URDF = os.path.join(ROOT, "urdf")


def _a_urdf():
    for dirpath, _, files in os.walk(URDF):
        for f in sorted(files):
            if f.endswith(".urdf"):
                return os.path.join(dirpath, f)
    pytest.skip("no URDF file in the repository's urdf/ folder")


@pytest.mark.parametrize("how", ["absolute", "relative"])
def test_a_model_files_urdf_key_never_names_a_file(tmp_path, monkeypatch, how):
    """Issue: "A model file's urdf = "PATH" makes manipdyn open that path, relative to the
    current folder"."""
    path = _a_urdf()
    if how == "relative":
        monkeypatch.chdir(os.path.dirname(path))
        path = os.path.basename(path)
    model = tmp_path / "m.toml"
    model.write_text(f'format = "manipdyn-model/1"\nname = "x"\nurdf = {json.dumps(path)}\n')
    with pytest.raises(md.ModelError, match=r"key 'urdf': expected the URDF text itself .* never names a file"):
        md.load(str(model))


def test_a_base_model_prior_naming_a_urdf_path_is_refused(tmp_path):
    """Issue: "A base-model JSON whose prior names a URDF path loads it": a prior of kind
    "toml" whose model-file text says ``urdf = "PATH"``."""
    text = f'format = "manipdyn-model/1"\nname = "x"\nurdf = {json.dumps(_a_urdf())}\n'
    from manipdyn.formats.modelfile import parse_model

    with pytest.raises(md.ModelError, match=r"never names a file"):
        parse_model(text, origin="base.json (prior)")


def test_an_embedded_urdf_still_loads(tmp_path):
    """The refusal is of paths only: a model file with the URDF text loads (the round trip)."""
    arm = md.load(_a_urdf())
    model = tmp_path / "m.toml"
    md.save(arm, str(model))
    again = md.load(str(model))
    assert again.n == arm.n
    q = np.linspace(-0.5, 0.5, arm.n)
    assert np.allclose(again.gravity_torque(q), arm.gravity_torque(q), rtol=1e-12, atol=1e-12)


@needs_cc
def test_the_tampering_tests_leave_pytest_able_to_exit(tmp_path):
    """CI once ended in SIGBUS (exit 135) after every test had passed: the tests above truncated a
    library that pytest's own process had loaded.  Run them in a child pytest: it must exit 0."""
    env = dict(os.environ, PYTHONPATH=ROOT, **{build.CACHE_ENV: str(tmp_path / "cache")})
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", __file__,
                          "-k", "cut_short or another_arms"], capture_output=True, text=True, env=env,
                         timeout=600, cwd=ROOT)
    assert res.returncode == 0, (res.returncode, res.stdout[-1500:], res.stderr[-1500:])
    assert "4 passed" in res.stdout, res.stdout[-500:]
