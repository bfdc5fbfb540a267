"""Meshcat's exposure: listening beyond this machine warns (with --live: anyone can drive the arm)
and names the real address; a taken port is named with the next free one; a host name that does not
resolve fails in seconds, and SIGTERM ends a command whose Meshcat is still starting."""

from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from support import SRC, cli_process, wait_for_line

from drake_disamb.commands._meshcat import check_host, exposure_warning, port_is_free, start_meshcat


def test_localhost_gives_no_warning() -> None:
    for host in ("localhost", "127.0.0.1", "::1"):
        assert exposure_warning(host, 7000, live=True) is None


def test_every_interface_warns_with_the_real_address() -> None:
    text = exposure_warning("*", 7001, live=False)
    assert text is not None and "every network interface" in text and "can watch the arm" in text
    assert f"http://{socket.gethostname()}:7001" in text and "localhost" not in text
    live = exposure_warning("0.0.0.0", 7001, live=True)
    assert live is not None and "DRIVE IT" in live
    named = exposure_warning("192.0.2.7", 7002, live=True)
    assert named is not None and "http://192.0.2.7:7002" in named
    page = exposure_warning("192.0.2.7", 7100, live=True, server="the operator page")
    assert page is not None and page.startswith("warning: the operator page listens on 192.0.2.7:")


@pytest.fixture
def taken_port() -> int:
    """A port some other program listens on (on localhost)."""
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        yield server.getsockname()[1]


def test_a_taken_port_is_named_with_the_next_free_one(taken_port: int) -> None:
    assert not port_is_free("localhost", taken_port)
    args = argparse.Namespace(meshcat_host="localhost", meshcat_port=taken_port, live=False)
    with pytest.raises(ValueError, match=rf"--meshcat-port: port {taken_port} on localhost is taken") as err:
        start_meshcat(args)
    free = int(str(err.value).rsplit("--meshcat-port ", 1)[1].rstrip(")"))
    assert free > taken_port and port_is_free("localhost", free)


def test_listening_everywhere_prints_the_warning(capsys: pytest.CaptureFixture[str]) -> None:
    args = argparse.Namespace(meshcat_host="*", meshcat_port=None, live=True)
    meshcat = start_meshcat(args)
    err = capsys.readouterr().err
    assert err.startswith("warning: Meshcat listens on every network interface") and "DRIVE IT" in err
    assert f":{meshcat.port()}" in err


UNKNOWN_HOST = "no-such-host.invalid"
"""A name that never resolves (the ``.invalid`` top-level domain is reserved for that)."""


def test_an_unknown_host_fails_in_seconds_naming_the_option(tmp_path: Path) -> None:
    """Meshcat's constructor would try the name for minutes, holding the interpreter."""
    start = time.monotonic()
    proc = cli_process("demo", "--meshcat-host", UNKNOWN_HOST, "--no-wait", "--out", str(tmp_path / "o"))
    try:
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert time.monotonic() - start < 15
    assert proc.returncode == 2
    assert err.count("\n") == 1 and err.startswith(
        f"drake-disamb demo: error: --meshcat-host {UNKNOWN_HOST!r}: the name does not resolve ("
    )
    assert out == ""


def test_a_host_that_resolves_too_slowly_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    """A resolver that hangs is not waited for: the look-up is bounded."""
    monkeypatch.setattr(socket, "getaddrinfo", lambda *args, **kwargs: time.sleep(3.0))
    start = time.monotonic()
    with pytest.raises(
        ValueError, match=r"^--meshcat-host 'slow\.example': the name did not resolve within 0\.2 s$"
    ):
        check_host("slow.example", timeout=0.2)
    assert time.monotonic() - start < 1.0


_STARTING_SCRIPT = f"""\
import argparse
from pydrake.geometry import Meshcat
from drake_disamb.commands import _meshcat
from drake_disamb.commands._signals import StopRequest

_meshcat.check_host = lambda host: None  # as if the name resolved: Meshcat's constructor meets it
with StopRequest():  # as the commands have while they start Meshcat
    print("starting Meshcat", flush=True)
    _meshcat.start_meshcat(argparse.Namespace(meshcat_host={UNKNOWN_HOST!r}, meshcat_port=None, live=False))
print("Meshcat started")
"""


def test_sigterm_ends_the_command_while_meshcats_constructor_runs(tmp_path: Path) -> None:
    """The constructor holds the interpreter, so no Python handler runs until it returns (minutes on
    a name that does not resolve): meanwhile SIGTERM keeps its default action and ends the process."""
    script = tmp_path / "starting.py"
    script.write_text(_STARTING_SCRIPT)
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen(
        [sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    )
    try:
        wait_for_line(proc, "starting Meshcat", timeout=120)
        time.sleep(1.0)  # in the constructor now
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=5)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()
    assert proc.returncode == -signal.SIGTERM
