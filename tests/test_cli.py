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
