"""The toolchain half of :mod:`benchmarks.bench_codegen`: Pinocchio's C++ timing driver and the
generated C's, compiled and cached.

:func:`pinocchio_flags` finds, from the installed packages (no fixed paths), every flag that
builds ``benchmarks/c/pinocchio_timing.cpp`` against the ``pin`` wheel, and says why each is
there; :func:`build_pinocchio` compiles it once per source, flag set and compiler (cached under
``benchmarks/results/runs/cache/``, ignored by git: a header-only build takes 2 to 25 minutes
here); :func:`build_generated` compiles ``benchmarks/c/generated_timing.c`` with an arm's
generated C.  A missing part of the toolchain raises :class:`Unavailable` with what to install.
"""

from __future__ import annotations

import hashlib
import os
import shlex
import subprocess
from pathlib import Path

HERE = Path(__file__).resolve().parent
C_DIR = HERE / "c"
CACHE = HERE / "results" / "runs" / "cache"

#: Pinocchio's flags, every row.  Not -march=native: the URDF parser is the wheel's
#: compiled library (built for the x86-64 baseline), and a header-only build with
#: -march=native (AVX-512 here) crashes in ~Model after buildModel (free() of a bad
#: pointer: the library fills the Model with another layout), even with Eigen's
#: alignment held at 16 bytes (-DEIGEN_MAX_ALIGN_BYTES=16 -DEIGEN_MAX_STATIC_ALIGN_BYTES=16).
#: Each such build also costs 10-25 minutes on this machine.
PIN_OPT = ("-O2",)


class Unavailable(RuntimeError):
    """A part of the toolchain is missing; the message says which and how to get it."""


# ---------------------------------------------------------------------------
# toolchain: where the wheel's headers are, and the flags Pinocchio needs
# ---------------------------------------------------------------------------
def tool(env: str, default: str) -> str:
    """The command in the environment variable ``env`` (CC, CXX), else ``default``."""
    return os.environ.get(env) or default


def compiler_version(cmd: str) -> str | None:
    """First line of ``cmd --version``, or None when there is no such compiler."""
    try:
        out = subprocess.run([*shlex.split(cmd), "--version"], capture_output=True, text=True, check=False)
    except OSError:
        return None
    return out.stdout.splitlines()[0].strip() if out.returncode == 0 and out.stdout else None


def pin_prefix() -> Path:
    """The ``pin`` wheel's install prefix (``.../site-packages/cmeel.prefix``): the
    ancestor of the ``pinocchio`` Python package that holds ``include/pinocchio``."""
    import pinocchio

    for parent in Path(pinocchio.__file__).resolve().parents:
        if (parent / "include" / "pinocchio" / "config.hpp").is_file() and (parent / "lib").is_dir():
            return parent
    raise Unavailable("the installed pinocchio has no C++ headers beside it (expected the `pin` wheel's "
                      "cmeel.prefix/include/pinocchio)")


def pkg_config(*args) -> str | None:
    """``pkg-config ARGS``'s output, or None when it fails or is missing."""
    try:
        out = subprocess.run(["pkg-config", *args], capture_output=True, text=True, check=False)
    except OSError:
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def _header_dir(pkg: str, probe: str, prefix: Path, fallbacks) -> tuple[Path, str | None]:
    """(include directory holding ``probe``, version or None): the wheel's prefix first,
    then pkg-config, then the usual system places."""
    cands = [prefix / "include" / sub for sub in ("", "eigen3")]
    flags = pkg_config("--cflags-only-I", pkg)
    if flags:
        cands += [Path(f[2:]) for f in flags.split() if f.startswith("-I")]
    cands += [Path(p) for p in fallbacks]
    for c in cands:
        if (c / probe).is_file():
            return c, pkg_config("--modversion", pkg)
    raise Unavailable(f"no {probe} found (looked in the wheel's prefix, pkg-config {pkg}, {', '.join(fallbacks)})")


def pinocchio_flags(opt=("-O2",), instantiation: bool = True) -> list[str]:
    """The command-line flags (after the compiler) that build ``pinocchio_timing.cpp``
    against the ``pin`` wheel, found from the installed packages (no fixed paths):

    * ``-std=c++17``: Pinocchio 3 and later need C++17; ``-DNDEBUG``: Eigen's
      asserts off, as in a release build (Pinocchio's argument checks stay);
    * ``-I <prefix>/include``: Pinocchio's headers, Boost's (the wheel's Boost,
      which its libraries were built with) and urdfdom's parser;
    * ``-isystem`` Eigen 3 (not in the wheel: ``apt-get install libeigen3-dev``);
    * ``-isystem`` urdfdom_headers (``<urdf_model/model.h>``, which
      ``pinocchio/parsers/urdf.hpp`` includes; not in the wheel:
      ``apt-get install liburdfdom-headers-dev``) with
      ``-DPINOCCHIO_URDFDOM_HEADERS_{MAJOR,MINOR,PATCH}_VERSION`` of those
      headers.  The wheel was built with other urdfdom headers, which does not
      matter here: the driver calls only ``buildModel(filename, model)``, whose
      library side (``parseRootTree``) takes a file name and Pinocchio's own types;
    * ``-DPINOCCHIO_WITH_URDFDOM`` and the Boost.MPL/Fusion limits of
      ``pinocchioTargets.cmake`` (``BOOST_MPL_LIMIT_LIST_SIZE=30``, ...), which
      must match the library's build;
    * ``-DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION`` when ``instantiation``:
      RNEA, ABA and the derivatives from the wheel's ``libpinocchio_default.so``;
    * no ``-march=native`` (:data:`PIN_OPT`);
    * link: ``-lpinocchio_parsers -lpinocchio_default`` from ``<prefix>/lib``,
      with that directory as the binary's rpath (the wheel's libraries are not
      on the loader's path).
    """
    prefix = pin_prefix()
    eigen, _ = _header_dir("eigen3", "Eigen/Core", prefix, ("/usr/include/eigen3", "/usr/local/include/eigen3"))
    urdf, version = _header_dir("urdfdom_headers", "urdf_model/model.h", prefix, ("/usr/include", "/usr/local/include"))
    parts = [int(x) for x in (version or "1.0.0").split(".")[:3]] + [0, 0, 0]
    lib = prefix / "lib"
    system = {Path("/usr/include"), Path("/usr/local/include")}   # already searched; -isystem would break <cmath>
    extra = [x for d in (eigen, urdf) if d not in system for x in ("-isystem", str(d))]
    flags = ["-std=c++17", *opt, "-DNDEBUG", f"-I{C_DIR}", f"-I{prefix / 'include'}", *extra,
             "-DPINOCCHIO_WITH_URDFDOM", f"-DPINOCCHIO_URDFDOM_HEADERS_MAJOR_VERSION={parts[0]}",
             f"-DPINOCCHIO_URDFDOM_HEADERS_MINOR_VERSION={parts[1]}",
             f"-DPINOCCHIO_URDFDOM_HEADERS_PATCH_VERSION={parts[2]}",
             "-DBOOST_MPL_LIMIT_LIST_SIZE=30", "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
             "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "-DBOOST_FUSION_INVOKE_MAX_ARITY=12"]
    if instantiation:
        flags.append("-DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION")
    flags += [str(C_DIR / "pinocchio_timing.cpp"), f"-L{lib}", f"-Wl,-rpath,{lib}",
              "-lpinocchio_parsers", "-lpinocchio_default"]
    return flags


def portable(cmd: list[str]) -> list[str]:
    """``cmd`` with this machine's paths of the wheel and of the checkout written as
    ``<pin prefix>`` and ``benchmarks/c`` (for the results file)."""
    try:
        prefix = str(pin_prefix())
    except Unavailable:
        prefix = None
    out = []
    for c in cmd:
        if prefix:
            c = c.replace(prefix, "<pin prefix>")
        out.append(c.replace(str(C_DIR), "benchmarks/c"))
    return out


def _compile(cmd: list[str], out: Path, what: str) -> None:
    tmp = out.with_name(out.name + f".tmp{os.getpid()}")
    res = subprocess.run([*cmd, "-o", str(tmp)], capture_output=True, text=True, check=False)
    if res.returncode != 0:
        tmp.unlink(missing_ok=True)
        raise Unavailable(f"compiling {what} failed ({shlex.join(cmd[:1])}):\n{res.stderr[-3000:]}")
    os.replace(tmp, out)   # atomic: a half-written binary never sits in the cache


def build_pinocchio(opt, instantiation: bool, log=print) -> tuple[Path, list[str]]:
    """The Pinocchio timing driver built with ``opt`` (cached by the hash of its
    sources, flags and compiler): (binary, command)."""
    cxx = tool("CXX", "c++")
    version = compiler_version(cxx)
    if version is None:
        raise Unavailable(f"no C++ compiler ({cxx!r}; set CXX)")
    cmd = [*shlex.split(cxx), *pinocchio_flags(opt, instantiation)]
    h = hashlib.sha256()
    for f in ("pinocchio_timing.cpp", "states_io.h"):
        h.update((C_DIR / f).read_bytes())
    h.update("\0".join([*cmd, version, pin_version()]).encode())
    out = CACHE / f"pinocchio_timing-{h.hexdigest()[:16]}"
    if not out.is_file():
        CACHE.mkdir(parents=True, exist_ok=True)
        log(f"compiling Pinocchio's driver ({'library' if instantiation else 'header-only'}, {' '.join(opt)}); "
            f"this takes minutes, once (cached in {out.parent.relative_to(HERE.parent)})")
        _compile(cmd, out, "benchmarks/c/pinocchio_timing.cpp")
    return out, cmd


def build_generated(gen_dir: Path, prefix: str, opt, out: Path) -> list[str]:
    """Compile ``generated_timing.c`` with the generated ``gen_dir/prefix.c``: the command."""
    cc = tool("CC", "cc")
    if compiler_version(cc) is None:
        raise Unavailable(f"no C compiler ({cc!r}; set CC)")
    cmd = [*shlex.split(cc), "-std=c99", *opt, f"-DMDPREFIX={prefix}", f"-I{C_DIR}", f"-I{gen_dir}",
           str(C_DIR / "generated_timing.c"), str(gen_dir / f"{prefix}.c"), "-lm"]
    _compile(cmd, out, f"the generated C of {prefix}")
    return cmd


def pin_version() -> str:
    import pinocchio

    return pinocchio.__version__
