"""The ``drake-disamb`` dispatcher: every sub-command registers, --help works, no arguments = demo."""

from __future__ import annotations

import subprocess
import sys

import pytest

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
