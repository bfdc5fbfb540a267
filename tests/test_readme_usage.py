"""Every command of README.md's "Usage" section exits 0 as written, from the repository root, after
the quick start.

The commands run one after the other, as a reader would type them, in a copy of the repository root
(its folders linked, so the files they write land in a temporary folder), with the running virtual
environment first on ``PATH`` (what ``source .venv/bin/activate`` does) and standard input not a
terminal. Skipped: ``--live`` (it needs a person at the Meshcat page) and, where the folder
``../shared/data/tnsre2018_simulated_trajectories`` is absent, the commands that read it.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
SHARED = REPO.parent / "shared"
ACTIVATE = "source .venv/bin/activate"


def usage_section(text: str) -> str:
    """README's "Usage" section: from ``## Usage`` to the next section (``## ...``)."""
    start = text.index("\n## Usage\n")
    return text[start : text.index("\n## ", start + 1)]


def usage_commands(section: str) -> list[str]:
    """The shell lines of the section's ``bash`` blocks, comments dropped, in order."""
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", section, flags=re.S):
        for line in block.splitlines():
            command = line.split(" #", 1)[0].strip() if not line.lstrip().startswith("#") else ""
            if command:
                commands.append(command)
    return commands


def test_the_section_tells_to_activate_and_has_commands() -> None:
    commands = usage_commands(usage_section(README.read_text(encoding="utf-8")))
    assert commands[0] == ACTIVATE
    assert sum(c.startswith("drake-disamb ") for c in commands) >= 10
    assert any("--live" in c for c in commands)
    # Inline commands in the prose would escape this test: every command stays in the blocks.
    prose = re.sub(r"```.*?```", "", usage_section(README.read_text(encoding="utf-8")), flags=re.S)
    assert not re.findall(r"`(?:drake-disamb|python) [^`]*`", prose)


def _mirror(tmp_path: Path) -> Path:
    """``tmp/root`` with the repository's folders linked in and ``tmp/shared`` beside it."""
    root = tmp_path / "root"
    root.mkdir()
    for entry in REPO.iterdir():
        if (
            entry.is_dir()
            and entry.name not in {".git", "out", ".venv", "docs"}
            and not entry.name.startswith(".")
        ):
            (root / entry.name).symlink_to(entry)
    if SHARED.is_dir():
        (tmp_path / "shared").symlink_to(SHARED)
    return root


def _run_commands(commands: list[str], root: Path) -> list[str]:
    """Run ``commands`` in order in ``root``; the failures, each with the end of its output."""
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")  # the activation
    env["PYTHONPATH"] = str(REPO / "src") + os.pathsep + env.get("PYTHONPATH", "")
    env["MPLBACKEND"] = "Agg"
    failed = []
    for command in commands:
        start = time.monotonic()
        proc = subprocess.run(
            ["bash", "-c", command],
            cwd=root,
            env=env,
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=300,
        )
        print(f"{time.monotonic() - start:6.1f} s  exit {proc.returncode}  {command}")
        if proc.returncode != 0:
            failed.append(f"{command}\n  exit {proc.returncode}\n{proc.stdout[-800:]}\n{proc.stderr[-1500:]}")
    return failed


def _commands() -> tuple[list[str], list[str]]:
    """The section's commands to run: ``(without ../shared, reading ../shared)``; ``--live`` and
    the activation (done through ``PATH``) left out."""
    commands = [
        c
        for c in usage_commands(usage_section(README.read_text(encoding="utf-8")))
        if c != ACTIVATE and "--live" not in shlex.split(c)
    ]
    return [c for c in commands if "../shared/" not in c], [c for c in commands if "../shared/" in c]


def test_every_usage_command_exits_0(tmp_path: Path) -> None:
    commands, _ = _commands()
    root = _mirror(tmp_path)
    failed = _run_commands(commands, root)
    assert not failed, "\n\n".join(failed)
    assert len(commands) >= 10
    # The files the commands say they write are there.
    for name in (
        "out/demo/goal_probabilities.png",
        "out/demo/recording.html",
        "out/modes.json",
        "my_scenario.yaml",
    ):
        assert (root / name).is_file(), name


@pytest.mark.skipif(
    not (SHARED / "data" / "tnsre2018_simulated_trajectories").is_dir(),
    reason=f"needs the authors' published trials in {SHARED}/data/tnsre2018_simulated_trajectories",
)
def test_the_usage_commands_on_the_published_trials_exit_0(tmp_path: Path) -> None:
    _, commands = _commands()
    assert commands
    failed = _run_commands(commands, _mirror(tmp_path))
    assert not failed, "\n\n".join(failed)
    assert (tmp_path / "root" / "out" / "inference.png").is_file()
