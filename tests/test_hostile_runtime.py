"""Issue 31, item 26: exit 3 and crashes at run time, reproduced with real processes.

* a peer that answers a ``--scheduler`` address with bytes that are not Dask's (a web or SSH
  server): Dask read them as a length of exabytes (``MemoryError``, exit 3); now exit 2 naming
  the address and :data:`manipdyn.limits.MAX_PEER_MESSAGE_BYTES`;
* Ctrl-C while the command is still importing: a 31-line traceback; now one line.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from manipdyn.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
pytest.importorskip("distributed", reason="--scheduler needs the dask extra")


@pytest.fixture
def chatty_peer():
    """A TCP server that greets every connection with another protocol's banner, then waits."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    banner = {"text": b""}
    conns = []

    def serve():
        while True:
            try:
                c, _ = srv.accept()
            except OSError:
                return
            conns.append(c)
            try:
                c.sendall(banner["text"])
            except OSError:
                pass

    threading.Thread(target=serve, daemon=True).start()
    yield srv.getsockname()[1], banner
    srv.close()
    for c in conns:
        c.close()


@pytest.mark.parametrize("text", [b"HTTP/1.0 200 OK\r\nServer: x\r\n\r\n", b"SSH-2.0-OpenSSH_9.6\r\n",
                                  b"\xff" * 64])
def test_a_peer_that_is_not_dask_is_exit_2_in_one_line(chatty_peer, text, capsys):
    """Issue: "a peer that sends non-Dask bytes (MemoryError ... 3.07 EiB)"."""
    port, banner = chatty_peer
    banner["text"] = text
    code = main(["montecarlo", "ur5", "--runs", "1", "--duration", "0.2", "--scheduler", f"tcp://127.0.0.1:{port}"])
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert code == 2 and len(lines) == 1, cap.err
    assert f"127.0.0.1:{port}" in lines[0] and "internal error" not in lines[0], lines[0]


def _interrupt_while_importing(delay: float):
    """Run ``python -m manipdyn check panda``, wait until its first manipdyn module is imported
    (``-X importtime`` says so), then Ctrl-C it ``delay`` seconds later: ``(returncode, stderr
    lines other than -X importtime's)``."""
    env = dict(os.environ, PYTHONPATH=ROOT)
    from common import sigint_as_a_terminal_gives_it

    p = subprocess.Popen([sys.executable, "-X", "importtime", "-m", "manipdyn", "check", "panda"],
                         preexec_fn=sigint_as_a_terminal_gives_it,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    seen = []
    for line in p.stderr:
        seen.append(line)
        if "manipdyn._support.errors" in line:
            break
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    rest = p.stderr.read()
    p.wait(timeout=120)
    lines = [ln for ln in (seen + rest.splitlines(keepends=True)) if not ln.startswith("import time:")]
    return p.returncode, [ln.rstrip("\n") for ln in lines if ln.strip()]


@pytest.mark.parametrize("delay", [0.0, 0.05, 0.15, 0.4])
def test_ctrl_c_during_the_imports_is_one_line(delay):
    """Issue: "Ctrl-C in the first 0.5 s, during imports, prints a 31-line traceback"."""
    code, lines = _interrupt_while_importing(delay)
    assert not any("Traceback" in ln for ln in lines), "\n".join(lines)
    assert lines in ([], ["manipdyn: interrupted"]), "\n".join(lines)
    assert code in (130, -signal.SIGINT, 0)      # 0: the check ended before the signal


def test_only_the_command_gets_the_quiet_hook():
    """A program that imports manipdyn keeps Python's own report of a Ctrl-C."""
    from manipdyn._support.interrupt import is_command_line

    assert is_command_line(["python", "-m", "manipdyn", "check"])
    assert is_command_line(["python", "-X", "importtime", "-W", "ignore", "-mmanipdyn"])
    assert not is_command_line(["python", "script.py", "-m", "manipdyn"])
    assert not is_command_line(["python", "-c", "import manipdyn"])
    assert not is_command_line(["python", "-m", "pytest", "tests"])
    assert not is_command_line(["python"])


@pytest.mark.parametrize("module", ["pinocchio", "yourdfpy"])
def test_a_python_without_a_core_dependency_gets_one_line_not_a_traceback(tmp_path, module):
    """``python -m manipdyn ...`` run by a Python that lacks a core dependency (not the venv manipdyn was
    installed into) printed a 20-line ImportError traceback; now one line naming the package and the Python,
    exit 2.  The dependency is made unimportable by a stand-in package earlier on the path."""
    fake = tmp_path / module
    fake.mkdir()
    (fake / "__init__.py").write_text(f"raise ModuleNotFoundError(\"No module named '{module}'\", name='{module}')\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT)]))
    p = subprocess.run([sys.executable, "-m", "manipdyn", "check", "--all", "--samples", "5"], env=env,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and f"module {module!r}" in lines[0] and "pip install" in lines[0], lines
