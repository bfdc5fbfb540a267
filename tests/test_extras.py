"""The optional dependencies (``drake_disamb.extras``, pyproject.toml's extras): the base install runs
the controller and ``demo`` without the ``study`` extra, and everything that needs the extra says so
in one line naming it (``drake-disamb study ...`` with exit status 2, the library with
``MissingExtra``)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest
from support import REPO, SRC
from test_study_report import synthetic_records

from drake_disamb.cli import main
from drake_disamb.commands.study import STUDY_COMMANDS, WITHOUT_EXTRA
from drake_disamb.commands.study_run import check_scheduler_address
from drake_disamb.extras import EXTRAS, MissingExtra, import_optional, missing_modules, require
from drake_disamb.study.analysis.stats import run_tests

STUDY_ONLY = EXTRAS["study"]
MESSAGE = (
    "needs the 'study' extra (distributed, statsmodels, pandas not installed): "
    "pip install 'drake-disamb[study]'"
)
LINE = "drake-disamb study {command}: error: " + MESSAGE + "\n"


def _name(requirement: str) -> str:
    """A requirement's distribution name, normalised (PEP 503): ``"Foo_Bar[x]>=1"`` -> ``"foo-bar"``."""
    return re.sub(r"[-_.]+", "-", re.match(r"[A-Za-z0-9._-]+", requirement).group(0)).lower()


@pytest.fixture
def absent(monkeypatch: pytest.MonkeyPatch) -> None:
    """The ``study`` extra's modules made unimportable in this process (``None`` in ``sys.modules``,
    for each and every submodule already loaded: the import then fails as for a missing module)."""
    for key in [k for k in sys.modules if k.split(".")[0] in STUDY_ONLY] + list(STUDY_ONLY):
        monkeypatch.setitem(sys.modules, key, None)


def test_the_base_dependencies_leave_the_study_to_its_extra() -> None:
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    base = {_name(r) for r in project["dependencies"]}
    extras = project["optional-dependencies"]
    assert {"drake", "numpy", "numba", "scipy", "matplotlib", "pyyaml", "tqdm", "threadpoolctl"} <= base
    assert not base & {"distributed", "statsmodels", "pandas", "dask"}
    # The study extra brings exactly the modules drake_disamb.extras checks for.
    assert {_name(r) for r in extras["study"]} == set(STUDY_ONLY)
    # README.md's `pip install -e ".[test]"` (and .ci/run) still sets up everything the tests need.
    assert "drake-disamb[study]" in extras["test"]


def test_without_the_extra_demo_runs_and_study_says_which_extra(tmp_path: Path) -> None:
    """In child processes where the extra's modules cannot be found (a finder in front of every other
    refuses them, as if they were not installed), started from another folder than the repository."""
    block = tmp_path / "block"
    block.mkdir()
    (block / "sitecustomize.py").write_text(
        textwrap.dedent(
            f"""\
            import sys
            from importlib.abc import MetaPathFinder

            class Refuse(MetaPathFinder):
                def find_spec(self, name, path=None, target=None):
                    if name.split(".")[0] in {STUDY_ONLY!r}:
                        raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
                    return None

            sys.meta_path.insert(0, Refuse())
            """
        )
    )
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(block), str(SRC)]), MPLBACKEND="Agg")

    def run(*argv: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, *argv], cwd=elsewhere, env=env, capture_output=True, text=True, timeout=300
        )

    for module in STUDY_ONLY:  # the finder works: each is missing there
        assert run("-c", f"import {module}").returncode == 1
    demo = run("-m", "drake_disamb.cli", "demo", "--no-meshcat", "--quiet", "--out", str(tmp_path / "demo"))
    assert demo.returncode == 0, demo.stderr
    assert (tmp_path / "demo" / "metrics.json").is_file()
    study = run("-m", "drake_disamb.cli", "study", "run", "--quick", "--out", str(tmp_path / "study"))
    assert (study.returncode, study.stderr, study.stdout) == (2, LINE.format(command="run"), "")
    assert not (tmp_path / "study").exists()
    # A session with a person needs no extra: its modules import, and it reaches its own checks.
    modules = "drake_disamb.commands.study_session, drake_disamb.study.run.session, drake_disamb.trial"
    assert run("-c", f"import {modules}").returncode == 0
    session = run(
        "-m", "drake_disamb.cli", "study", "session", "--subject", "../x", "--out", str(tmp_path / "s")
    )
    assert session.returncode == 2 and "--subject" in session.stderr and "extra" not in session.stderr
    assert not (tmp_path / "s").exists()


# One valid command line per study sub-command (the check comes before any of them reads its input).
STUDY_ARGV: dict[str, list[str]] = {
    "run": ["--quick", "--out", "{tmp}/out"],
    "ablate": ["--quick", "--out", "{tmp}/out", "--switch", "inference.dft.tau1=0,4"],
    "rerun": ["{tmp}/out", "T1"],
    "report": ["{tmp}/out"],
    "import-authors": ["{tmp}/data", "--out", "{tmp}/out"],
    "calibrate": ["{tmp}/data"],
    "identify": ["{tmp}/data"],
}


def test_every_study_command_has_a_command_line_here() -> None:
    assert set(STUDY_ARGV) == set(STUDY_COMMANDS) - WITHOUT_EXTRA
    assert WITHOUT_EXTRA == {"session"}


@pytest.mark.usefixtures("absent")
def test_a_session_with_a_person_needs_no_extra(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``study session`` runs on the base install: past the extra, to its own checks (here the
    subject id's); a fresh process imports its modules without the extra's (the test above)."""
    assert main(["study", "session", "--subject", "../P01", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "--subject" in err and "extra" not in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", sorted(STUDY_ARGV))
@pytest.mark.usefixtures("absent")
def test_every_study_command_needs_the_extra(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [a.format(tmp=tmp_path) for a in STUDY_ARGV[command]]
    assert main(["study", command, *argv]) == 2
    out, err = capsys.readouterr()
    assert (out, err) == ("", LINE.format(command=command))
    assert not (tmp_path / "out").exists()


def test_with_the_extra_the_study_starts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The check passes where the extra is installed: the command runs on to its own checks."""
    assert missing_modules("study") == []
    assert main(["study", "report", str(tmp_path / "none")]) == 2
    assert capsys.readouterr().err.endswith("none: no such study folder\n")


@pytest.mark.usefixtures("absent")
def test_the_library_names_the_extra() -> None:
    assert missing_modules("study") == list(STUDY_ONLY)
    with pytest.raises(MissingExtra, match=re.escape(MESSAGE)) as exc:
        require("study")
    assert exc.value.missing == list(STUDY_ONLY)
    with pytest.raises(MissingExtra, match=re.escape(MESSAGE)):
        import_optional("statsmodels.formula.api", "study")
    # The mixed model of the report (4 subjects: enough to fit one) is not left out in silence.
    with pytest.raises(MissingExtra, match=re.escape(MESSAGE)):
        run_tests(synthetic_records(), ("button_presses",), mixed_metrics=("button_presses",))
    # Nor is a Dask scheduler.
    with pytest.raises(MissingExtra, match=re.escape(MESSAGE)):
        check_scheduler_address("tcp://127.0.0.1:8786")
    # Without the mixed model and the scheduler, the rest of the study's code runs.
    assert run_tests(synthetic_records(), ("button_presses",), per_subject=False)
    check_scheduler_address(None)


def test_a_missing_module_outside_the_extra_is_not_blamed_on_it() -> None:
    with pytest.raises(ModuleNotFoundError) as exc:
        import_optional("statsmodels.no_such_module", "study")
    assert not isinstance(exc.value, MissingExtra)
