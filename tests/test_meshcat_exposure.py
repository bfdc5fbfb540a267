"""Meshcat's exposure: listening beyond this machine warns (with --live: anyone can drive the arm)
and names the real address; a taken port is named with the next free one."""

from __future__ import annotations

import argparse
import socket

import pytest

from drake_disamb.commands._meshcat import exposure_warning, port_is_free, start_meshcat


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
