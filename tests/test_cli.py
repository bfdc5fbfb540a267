"""The ``drake-disamb`` dispatcher: every sub-command registers, --help works, no arguments = demo."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest
from support import SRC, cli_process

from drake_disamb import cli


def test_every_command_registers_with_help() -> None:
    parser = cli.build_parser()
    text = parser.format_help()
    for name in cli.COMMANDS:
        assert name in text
        with pytest.raises(SystemExit) as exc:
            parser.parse_args([name, "--help"])
        assert exc.value.code == 0


def test_no_arguments_runs_the_main_job(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[str] = []
    parser = cli.build_parser()

    def fake_build_parser():  # the demo's real run() is exercised in test_demo_cli.py
        for action in parser._subparsers._group_actions:  # noqa: SLF001
            for name, sub in action.choices.items():
                sub.set_defaults(_run=lambda args, name=name: seen.append(name) or 0)
        return parser

    monkeypatch.setattr(cli, "build_parser", fake_build_parser)
    assert cli.main([]) == 0
    assert cli.main(["--no-meshcat"]) == 0
    assert seen == ["demo", "demo"]


def test_unknown_command_is_a_usage_error() -> None:
    with pytest.raises(SystemExit) as exc:
        cli.main(["no-such-command"])
    assert exc.value.code == 2


def test_console_entry_point_help_is_fast_and_works() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "drake_disamb.cli", "--help"], capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert "inference-benchmark" in out.stdout


def test_meshcat_listens_on_localhost_unless_asked() -> None:
    import argparse

    from drake_disamb.commands._meshcat import add_meshcat_arguments, start_meshcat

    parser = argparse.ArgumentParser()
    add_meshcat_arguments(parser)
    args = parser.parse_args([])
    assert args.meshcat_host == "localhost"
    meshcat = start_meshcat(args)
    assert meshcat.web_url().startswith("http://localhost:")
    with pytest.raises(ValueError, match="--meshcat-port"):
        start_meshcat(parser.parse_args(["--meshcat-port", "70000"]))


def test_demo_rejects_a_bad_meshcat_port(capsys: pytest.CaptureFixture[str], tmp_path) -> None:  # noqa: ANN001
    assert cli.main(["demo", "--meshcat-port", "0", "--out", str(tmp_path / "out")]) == 2
    assert "--meshcat-port" in capsys.readouterr().err


# -- signals and warnings: one line of ours, never a traceback ---------------------------------------


def _wait_for_our_handler(pid: int, timeout: float = 20.0) -> None:
    """Wait until process ``pid`` catches SIGTERM (``SigCgt`` in ``/proc/PID/status``): the command
    line's first act, which Python's own start-up does not do. Before it, a signal meets the
    interpreter's start (the kernel's default action, as for any program): a busy machine can
    stretch that start past the test's first moments."""
    status = Path(f"/proc/{pid}/status")
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            caught = next(line for line in status.read_text().splitlines() if line.startswith("SigCgt:"))
        except (OSError, StopIteration):  # not Linux's /proc: the start is taken as done
            return
        if int(caught.split()[1], 16) & (1 << (signal.SIGTERM - 1)):
            return
        time.sleep(0.002)
    raise AssertionError(f"the command did not install its signal handlers within {timeout} s")


def _signalled(argv: list[str], sig: signal.Signals, after: float) -> tuple[int, str, str]:
    """Run ``python -m drake_disamb.cli ARGV``, send ``sig`` ``after`` seconds past the moment it
    installs its signal handlers; its exit status, stdout and stderr."""
    proc = cli_process(*argv)
    try:
        _wait_for_our_handler(proc.pid)
        time.sleep(after)
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, out, err


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("after", [0.05, 0.15, 0.3, 1.0])
def test_a_signal_at_any_moment_gives_one_line(sig: signal.Signals, after: float, tmp_path: Path) -> None:
    """From the command line's first moments (the sub-commands and pydrake still importing) to the
    running trial: exit status 130, a line saying which signal stopped it, no traceback."""
    # At half real time the default reaching trial (about 6 s simulated) cannot end by itself.
    argv = ["demo", "--no-meshcat", "--quiet", "--realtime-rate", "0.5", "--out", str(tmp_path / "out")]
    code, out, err = _signalled(argv, sig, after)
    assert code == 130, err
    assert "Traceback" not in err + out
    assert f"stopped by {sig.name}" in err + out
    assert err.count("\n") <= 1, err


def test_sigterm_ends_a_command_that_does_not_take_signals() -> None:
    """``inference-benchmark`` has no stop request: SIGTERM ends it as Ctrl-C does (one line, 130),
    not by the kernel's default action (killed without a word)."""
    argv = ["inference-benchmark", "--generate", "1000000", "--seed", "0", "--quiet"]
    code, out, err = _signalled(argv, signal.SIGTERM, 1.5)
    assert code == 130, err
    assert err.strip() in ("interrupted", "drake-disamb: stopped by SIGTERM"), err
    assert out == ""


def test_sigterm_as_sigint_gives_sigterm_the_command_lines_handler() -> None:
    """While a study checks its scenarios SIGTERM does what SIGINT does: with the command line's
    handler, it names SIGTERM and is safe in an import (Python's own would raise inside pydrake's
    initialisation: ``ImportError: initialization failed``)."""
    from drake_disamb.commands._signals import sigterm_as_sigint

    before = signal.signal(signal.SIGINT, cli._interrupt)  # noqa: SLF001
    try:
        with sigterm_as_sigint():
            assert signal.getsignal(signal.SIGTERM) is cli._interrupt  # noqa: SLF001
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        with sigterm_as_sigint():  # SIGINT ignored: SIGTERM still stops
            assert signal.getsignal(signal.SIGTERM) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, before)


_WARNING_SCRIPT = """\
import sys, warnings
from drake_disamb.commands import demo

def run(args):
    warnings.warn("live_input: raw signal [nan] is not finite\\n  it is read as 0", RuntimeWarning)
    print("done")
    return 0

demo.run = run
from drake_disamb.cli import main
sys.exit(main())
"""


def test_a_warning_prints_as_one_line_without_source_paths(tmp_path: Path) -> None:
    """The entry point as the console script calls it, with a command that warns."""
    script = tmp_path / "warns.py"
    script.write_text(_WARNING_SCRIPT)
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run(
        [sys.executable, str(script), "demo"], capture_output=True, text=True, env=env, timeout=120
    )
    assert res.returncode == 0 and res.stdout == "done\n", res.stderr
    assert res.stderr == "drake-disamb: warning: live_input: raw signal [nan] is not finite it is read as 0\n"


def test_library_users_keep_pythons_warnings_and_signals(monkeypatch: pytest.MonkeyPatch, capsys) -> None:  # noqa: ANN001
    """``main`` called from Python formats warnings while it runs, then gives back the caller's
    ``warnings.showwarning`` and signal handlers."""
    from drake_disamb.commands import demo

    before = (warnings.showwarning, signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM))

    def run(args) -> int:  # noqa: ANN001
        warnings.warn("something odd", RuntimeWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(demo, "run", run)
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert cli.main(["demo"]) == 0
    assert capsys.readouterr().err == "drake-disamb: warning: something odd\n"
    assert (warnings.showwarning, signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
