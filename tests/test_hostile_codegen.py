"""Issue 31, items 25, 27, 29 and 30 on ``codegen`` and the command line's one-line errors.

``codegen`` checks its outputs before its work (never onto the model, never a folder, FIFO
or device, the size of the C capped before its graphs are built), test-compiles before it
writes, and writes both files or neither.  Every refusal is exit 2 with one line on stderr,
control characters of names shown escaped; argparse's usage block is one line too.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

import manipdyn as md
from manipdyn import limits
from manipdyn.cli import main
from manipdyn.engines.c import build, source
from manipdyn.model.random_arms import random_arm

pytest.importorskip("casadi")
CC = build.find_compiler()
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler ($CC, cc or gcc) on this machine")


def err_line(capsys) -> str:
    """The one line a refused command prints on stderr (nothing on stdout)."""
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1, cap.err
    return lines[0]


def _model(tmp_path, name="arm2", seed=1, n=2, src=None):
    arm = random_arm(seed, n=n)
    arm.name = name
    if src is not None:
        arm.source = src
    path = tmp_path / "model.toml"
    md.save(arm, str(path))
    return path


def test_codegen_never_writes_through_a_link_onto_the_model(tmp_path, capsys):
    """Issue 25: "codegen ... writes through a symlink gen/arm.h -> model.toml, replacing the model"."""
    model = _model(tmp_path)
    before = model.read_bytes()
    gen = tmp_path / "gen"
    gen.mkdir()
    (gen / "arm2.h").symlink_to(model)
    assert main(["codegen", str(model), "-o", str(gen)]) == 2
    line = err_line(capsys)
    # refused before the work as a link leading outside -o (issue 40 item 2), naming the file it would replace
    assert "-o" in line and "symbolic link" in line and str(model) in line and "nothing was written" in line, line
    assert model.read_bytes() == before
    assert not (gen / "arm2.c").exists()


def _refuse_generation(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("the C was generated before the outputs were checked")

    monkeypatch.setattr(source, "generate", refuse)


@pytest.mark.parametrize("what", ["fifo", "folder", "dev-full", "output-is-a-file"])
def test_codegen_checks_its_outputs_before_the_work_and_leaves_nothing(tmp_path, capsys, monkeypatch, what):
    """Issue 29: "a P.c that is a FIFO, a folder or /dev/full leaves P.h behind"; issue 27:
    "check -o before the work"."""
    model = _model(tmp_path)
    gen = tmp_path / "gen"
    gen.mkdir()
    cpath = gen / "arm2.c"
    if what == "fifo":
        os.mkfifo(cpath)
    elif what == "folder":
        cpath.mkdir()
    elif what == "dev-full":
        if not os.path.exists("/dev/full"):
            pytest.skip("no /dev/full on this system")
        cpath.symlink_to("/dev/full")
    else:
        gen.rmdir()
        gen.write_text("a file")
    _refuse_generation(monkeypatch)
    assert main(["codegen", str(model), "-o", str(gen)]) == 2
    line = err_line(capsys)
    assert str(gen) in line, line
    if what != "output-is-a-file":
        assert sorted(os.listdir(gen)) == ["arm2.c"]          # no P.h left behind
    else:
        assert gen.read_text() == "a file"


def test_codegen_of_a_huge_arm_is_refused_before_any_graph_is_built(tmp_path, capsys, monkeypatch):
    """Issue 27: "codegen of a 30-joint arm takes 50 s and 2.2 GB ... Cap it by the graph's size
    before building"."""
    model = _model(tmp_path, n=30, seed=3)
    _refuse_generation(monkeypatch)
    gen = tmp_path / "gen"
    assert main(["codegen", str(model), "-o", str(gen)]) == 2
    line = err_line(capsys)
    assert "MAX_CODEGEN_OPERATIONS" in line and "30 joints" in line, line
    assert not gen.exists()
    with pytest.raises(md.ModelError, match="MAX_CODEGEN_OPERATIONS"):
        random_arm(3, n=30).compiled


def test_the_codegen_cap_is_an_estimate_that_holds():
    """The estimate the cap uses (370 n^2.26) against the operations the generator really
    writes, for small arms (generation takes a second or two)."""
    for n in (4, 7):
        gen = source.generate(random_arm(5, n=n, rotors=True), "md")
        real = sum(gen.flops.values())
        # 25 %: the fit is within 5 % of this arm over n = 4..20 (limits.codegen_operations' docstring)
        assert abs(limits.codegen_operations(n) / real - 1) < 0.25, (n, real)
    assert limits.codegen_operations(20) <= limits.MAX_CODEGEN_OPERATIONS < limits.codegen_operations(21)


@needs_cc
@pytest.mark.parametrize("name, src", [
    ("a /* b", "x"), ("x", "built in Python */ int evil; /*"), ("arm \u202e evil", "x"),
    ("trigraph ??/", "src ??/"), ("x", "end\\")])
def test_codegen_comments_survive_hostile_names_and_sources(tmp_path, capsys, name, src):
    """Issue 29: "codegen with /*, a bidi override or a ??/ trigraph in a model's name or source
    writes P.h and P.c, then fails its own test-compile in 9 to 14 lines"."""
    model = _model(tmp_path, name=name, src=src)
    gen = tmp_path / "gen"
    assert main(["codegen", str(model), "-o", str(gen), "--prefix", "p"]) == 0, capsys.readouterr().err
    text = (gen / "p.c").read_text()
    comment = text[:text.index("*/")]
    assert "/*" not in comment[2:] and "??" not in comment
    assert all(ch == "\n" or 0x20 <= ord(ch) < 0x7F for ch in comment)
    assert "int evil" not in text[text.index("*/"):]


@needs_cc
def test_a_failed_test_compile_writes_nothing(tmp_path, monkeypatch):
    """Files are written only after the test-compile passed (a compile failure, forced here with
    a compiler flag the compiler refuses, leaves no P.h or P.c)."""
    monkeypatch.setattr(build, "STRICT_FLAGS", build.STRICT_FLAGS + ("-Wno-such-warning-flag-at-all",
                                                                     "--no-such-option"))
    gen = tmp_path / "gen"
    with pytest.raises(md.ModelError):
        md.codegen(random_arm(2, n=2), str(gen))
    assert not gen.exists() or os.listdir(gen) == []


def test_md_codegen_type_errors_are_manipdyns_naming_the_argument(tmp_path):
    """Issue 30: "md.codegen ... raise type errors that are not manipdyn's"."""
    arm = random_arm(2, n=2)
    for args, kw, name in [(("panda", str(tmp_path)), {}, "arm"), ((None, str(tmp_path)), {}, "arm"),
                           ((arm, 5), {}, "dir"), ((arm, None), {}, "dir"), ((arm, str(tmp_path)), {"prefix": 5},
                                                                               "prefix")]:
        with pytest.raises(md.ModelError, match=rf"^{name}: expected"):
            md.codegen(*args, **kw)
    assert os.listdir(tmp_path) == []


def test_control_characters_of_names_are_escaped_in_the_one_line(capsys):
    """Issue 29: "raw control characters (ESC, NUL, FF, VT) from names are echoed into messages"
    (NUL cannot be in an argv string; a newline would make two lines)."""
    assert main(["validate", "panda", "a\x1bb\x0cc\x0bd\ne\u202ef.csv"]) == 2
    line = err_line(capsys)
    assert "\\x1b" in line and "\\x0c" in line and "\\x0b" in line and "\\n" in line and "\\u202e" in line
    assert not any(ord(ch) < 0x20 or ch == "\u202e" for ch in line)


@pytest.mark.parametrize("argv", [["identify", "panda", "x.csv", "--bootstrap", "1e9"],
                                  ["identify", "panda", "x.csv", "--prior-weight", "-inf"],
                                  ["identify", "panda", "x.csv", "--band-folds", "nan"],
                                  ["check", "--no-such-option"], ["no-such-command"]])
def test_argparse_errors_are_one_line(argv, capsys):
    """Issue 29: "argparse's 20-line usage block still appears for --bootstrap 1e9,
    --prior-weight -inf and --band-folds nan"."""
    try:
        code = main(argv)
    except SystemExit as exc:        # argparse's own errors leave through SystemExit
        code = exc.code
    assert code == 2
    line = err_line(capsys)
    assert line.startswith("manipdyn") and "error:" in line and "usage:" not in line
    if len(argv) > 2 and argv[-2].startswith("--"):
        assert argv[-2] in line, line


def test_codegen_still_writes_and_compiles(tmp_path, capsys):
    """The ordinary case after the checks: both files, test-compiled (with a compiler)."""
    model = _model(tmp_path)
    gen = tmp_path / "gen"
    assert main(["codegen", str(model), "-o", str(gen)]) == 0
    out = capsys.readouterr().out
    assert (gen / "arm2.h").is_file() and (gen / "arm2.c").is_file() and "wrote" in out
    hdr = (gen / "arm2.h").read_text()
    assert "long arm2_joints(void);" in hdr and "const char *arm2_model_sha256(void);" in hdr
    assert np.isfinite(random_arm(1, n=2).gravity_torque(np.zeros(2))).all()
