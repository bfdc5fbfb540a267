"""``drake-disamb disambiguate``: JSON in, pure JSON out, per-case errors, --explain."""

from __future__ import annotations

import argparse
import io
import json
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from drake_disamb.commands import disambiguate as command
from drake_disamb.core.disambiguation import disambiguate, preset

Y_SCENE = {
    "belief": [0.5, 0.5],
    "position": [0.0, 0.0, 0.1],
    "goals": [[0.2, -0.25, 0.1], [0.2, 0.25, 0.1]],
    "modes": [[0], [1], [2], [3], [4], [5]],
    "current_mode": 0,
}
ROTATION_SCENE = {
    "belief": [0.5, 0.5],
    "position": [0.0, -0.3, 0.2],
    "orientation": [1.0, 0.0, 0.0, 0.0],
    "goals": [
        [0.3, -0.3, 0.2, 0.955336, 0.0, 0.0, 0.295520],
        [0.3, -0.3, 0.2, 0.955336, 0.0, 0.0, -0.295520],
    ],
    "modes": [[0, 1], [0, 2], [3, 5], [4]],
    "current_mode": 4,
}


def _run(tmp_path: Path, cases: object, *extra: str) -> int:
    """Parse and run exactly as ``cli.py`` does for this sub-command."""
    path = tmp_path / "cases.json"
    path.write_text(json.dumps(cases), encoding="utf-8")
    parser = argparse.ArgumentParser(prog="drake-disamb disambiguate")
    command.add_arguments(parser)
    args = parser.parse_args(["--cases", str(path), *extra])
    return command.run(args)


def test_valid_cases_print_pure_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    r3 = dict(
        Y_SCENE, preset="authors-r3", modes=[[0], [1], [2]], transition_matrix=[[0.99, 0.01], [0.02, 0.98]]
    )
    code = _run(tmp_path, [Y_SCENE, ROTATION_SCENE, r3])
    out = capsys.readouterr()
    assert code == 0
    results = json.loads(out.out)  # stdout is exactly one JSON document
    assert [r["mode"] for r in results] == [1, 2, 1]
    # Same numbers as the core.
    core = disambiguate(Y_SCENE["belief"], Y_SCENE["position"], np.array(Y_SCENE["goals"]), Y_SCENE["modes"],
                        preset("mico"), current_mode=0)  # fmt: skip
    np.testing.assert_allclose(results[0]["mode_scores"], core.mode_scores, rtol=1e-12)
    np.testing.assert_allclose(results[0]["dimension_scores"]["plus"], core.scores_plus, rtol=1e-12)
    assert set(results[0]["features"]) == {"gamma", "omega", "lambda", "upsilon"}
    assert len(results[2]["dimension_scores"]["minus"]) == 3
    assert "explanation" not in results[0]


def test_kept_mode_is_null(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    case = dict(Y_SCENE, current_mode=1)
    code = _run(tmp_path, [case])
    assert code == 0
    assert json.loads(capsys.readouterr().out)[0]["mode"] is None


def test_invalid_cases_get_errors_in_place(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cases = [
        Y_SCENE,
        dict(Y_SCENE, belief=[0.5, 0.6]),  # does not sum to 1
        dict(Y_SCENE, belief=[1.0]),  # wrong length
        dict(Y_SCENE, goals=[[0.2, -0.25], [0.2, 0.25, 0.1]]),
        dict(Y_SCENE, modes=[[0], [8]]),
        dict(Y_SCENE, preset="fast"),
        dict(Y_SCENE, transition_matrix=[[0.5, 0.6], [0.0, 1.0]]),
        dict(Y_SCENE, orientation=[0, 0, 0, 0]),
        dict(Y_SCENE, current_mode=-2),
        {k: v for k, v in Y_SCENE.items() if k != "position"},
        dict(Y_SCENE, speed=3),
        "not an object",
        ROTATION_SCENE,
    ]
    code = _run(tmp_path, cases)
    results = json.loads(capsys.readouterr().out)
    assert code == 1
    assert len(results) == len(cases)
    assert results[0]["mode"] == 1 and results[-1]["mode"] == 2
    expected_fields = ["belief", "belief", "goals[0]", "modes", "preset", "transition_matrix", "orientation",
                       "current_mode", "position", "speed", "case"]  # fmt: skip
    for i, field in enumerate(expected_fields, start=1):
        assert set(results[i]) == {"error"}
        assert results[i]["error"].startswith(f"case {i}: field '{field}'"), results[i]["error"]


def test_explain_prints_the_explanations_only(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = _run(tmp_path, [ROTATION_SCENE, dict(ROTATION_SCENE, position=[0, 0])], "--explain")
    out = capsys.readouterr()
    assert code == 1 and out.err == ""
    lines = out.out.splitlines()
    assert lines[0] == "case 0:" and lines[1].startswith("  Chose mode 2 {wx, wz}")
    assert "case 1:\n  error: field 'position': expected 3 numbers" in out.out
    assert "{" not in out.out.replace("{wx", "").replace("{vx", "").replace("{wy", "")  # no JSON


def test_json_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "sub" / "modes.json"
    assert _run(tmp_path, [ROTATION_SCENE, Y_SCENE], "--json", str(target)) == 0
    out = capsys.readouterr()
    assert out.out == "" and out.err == f"wrote {target}\n"
    results = json.loads(target.read_text())
    assert [r["mode"] for r in results] == [2, 1] and "explanation" not in results[0]
    # With --explain: the explanations on stdout, the JSON (with them) in the file.
    assert _run(tmp_path, [ROTATION_SCENE], "--explain", "--json", str(target)) == 0
    out = capsys.readouterr()
    assert out.out.startswith("case 0:\n  Chose mode 2")
    assert json.loads(target.read_text())[0]["explanation"].startswith("Chose mode 2")


def test_unwritable_json_file_exits_2_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "a_file").write_text("x")
    assert _run(tmp_path, "not even a list", "--json", str(tmp_path / "a_file" / "modes.json")) == 2
    out = capsys.readouterr()
    assert out.out == "" and out.err.count("\n") == 1 and "--json" in out.err


EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_the_example_files(capsys: pytest.CaptureFixture[str]) -> None:
    """``examples/disambiguate_cases.json`` is all valid; ``disambiguate_errors.json`` shows the
    per-case errors around one valid case (as docs/commands.md says)."""
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    assert command.run(parser.parse_args(["--cases", str(EXAMPLES / "disambiguate_cases.json")])) == 0
    assert all("error" not in r for r in json.loads(capsys.readouterr().out))
    assert command.run(parser.parse_args(["--cases", str(EXAMPLES / "disambiguate_errors.json")])) == 1
    results = json.loads(capsys.readouterr().out)
    assert "error" not in results[0] and all("error" in r for r in results[1:])
    assert [r["error"].split("'")[1] for r in results[1:]] == ["position", "modes", "speed"]


def test_default_preset_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    case = dict(Y_SCENE, modes=[[0], [1], [2]])
    _run(tmp_path, [case], "--preset", "authors-r3")
    result = json.loads(capsys.readouterr().out)[0]
    assert result["dimensions"] == [0, 1, 2]


def test_unreadable_file_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    assert command.run(parser.parse_args(["--cases", str(tmp_path / "missing.json")])) == 2
    bad = tmp_path / "bad.json"
    bad.write_text('{"belief": []}', encoding="utf-8")
    assert command.run(parser.parse_args(["--cases", str(bad)])) == 2
    out = capsys.readouterr()
    assert out.out == "" and "expected a JSON list" in out.err


def test_registered_in_cli() -> None:
    from drake_disamb.cli import COMMANDS

    assert COMMANDS["disambiguate"] == "disambiguate"
    assert command.HELP and callable(command.add_arguments) and callable(command.run)


# ----------------------------------------------------------------------------------------------
# Batch isolation and exit codes: every hostile batch, each in under 2 s
# ----------------------------------------------------------------------------------------------


def _run_raw(tmp_path: Path, data: bytes, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple:
    """Run on the bytes ``data``; returns ``(exit code, stdout, stderr, seconds)``."""
    path = tmp_path / "raw.json"
    path.write_bytes(data)
    parser = argparse.ArgumentParser(prog="drake-disamb disambiguate")
    command.add_arguments(parser)
    args = parser.parse_args(["--cases", str(path), *extra])
    capsys.readouterr()
    start = time.perf_counter()
    code = command.run(args)
    elapsed = time.perf_counter() - start
    out = capsys.readouterr()
    return code, out.out, out.err, elapsed


@pytest.fixture(scope="module", autouse=True)
def _warm() -> None:
    """Load the compiled kernels once, so that the timings below measure the command only."""
    disambiguate([0.5, 0.5], [0, 0, 0], np.array([[0.2, 0, 0], [0, 0.2, 0]]), [[0], [1], [3]])


def _json_text(value: object) -> str:
    return json.dumps(value, allow_nan=True)


BAD_CASES: list[tuple[str, str, str]] = [
    # (JSON text of the case, field named in its error, a phrase of the error)
    (_json_text(dict(Y_SCENE, orientation=[1e200, 0, 0, 0])), "orientation", "norm overflows"),
    (
        _json_text(dict(Y_SCENE, belief=[0.5, 0.5])).replace("[0.5, 0.5]", "[" + "9" * 401 + ", 0]", 1),
        "belief",
        "integer of 401 digits",
    ),
    (_json_text(dict(Y_SCENE, belief=[10**300, 0])), "belief", "summing to 1"),
    (_json_text(dict(Y_SCENE, belief=[True, False])), "belief", "expected numbers, got True"),
    (_json_text(dict(Y_SCENE, position=["0.1", 0, 0])), "position", "expected numbers, got '0.1'"),
    (_json_text(dict(Y_SCENE, position=[None, 0, 0])), "position", "expected numbers, got None"),
    (_json_text(dict(Y_SCENE, position=[float("nan"), 0, 0])), "position", "finite"),
    (_json_text(dict(Y_SCENE, position=[0, float("inf"), 0])), "position", "finite"),
    (
        _json_text(dict(Y_SCENE, position=[0, 0, 0])).replace("[0, 0, 0]", "[1e400, 0, 0]"),
        "position",
        "finite",
    ),
    (_json_text(dict(Y_SCENE, position=[1e300, 0, 0])), "position", "within +/-1000 m"),
    (_json_text(dict(Y_SCENE, goals=[[0.2, -0.25, 0.1], [2e3, 0.25, 0.1]])), "goals[1]", "within +/-1000 m"),
    (
        _json_text(dict(Y_SCENE, goals=[[0.2, -0.25, 0.1, 0, 0, 1e200, 0], [0.2, 0.25, 0.1]])),
        "goals",
        "norm overflows",
    ),
    (_json_text(dict(Y_SCENE, orientation=[0, 0, 0, 1e-200])), "orientation", "zero norm"),
    (
        _json_text(dict(Y_SCENE, belief=[1 / 101] * 101, goals=[[0.1, 0.1, 0.1]] * 101)),
        "goals",
        "MAX_GOALS",
    ),
    (_json_text(dict(Y_SCENE, transition_matrix=[[1e308, 1e308], [0, 1]])), "transition_matrix", "sum to 1"),
    (_json_text(dict(Y_SCENE, current_mode=True)), "current_mode", "non-negative integer"),
    (_json_text(dict(Y_SCENE, current_mode=7)), "current_mode", "expected an index in [0, 6]"),
    (_json_text(dict(Y_SCENE, modes=[[0], ["1"]])), "modes", "modes[1]"),
    (_json_text(dict(Y_SCENE, preset=["mico"])), "preset", "expected 'mico'"),
    ("[[[[1]]]]", "case", "expected a JSON object"),
]


def test_every_bad_case_is_its_own_error_and_the_rest_is_solved(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A file mixing valid cases with each probe: valid JSON, every valid case solved, exit 1."""
    texts = [_json_text(Y_SCENE)]
    for text, _, _ in BAD_CASES:
        texts += [text, _json_text(ROTATION_SCENE)]
    code, out, err, elapsed = _run_raw(tmp_path, ("[" + ",\n".join(texts) + "]").encode(), capsys)
    assert code == 1
    assert err == ""
    assert elapsed < 2.0
    results = json.loads(out)
    assert len(results) == 1 + 2 * len(BAD_CASES)
    assert results[0]["mode"] == 1
    for j, (_, field, phrase) in enumerate(BAD_CASES):
        i = 1 + 2 * j
        assert set(results[i]) == {"error"}
        assert results[i]["error"].startswith(f"case {i}: field '{field}'"), results[i]["error"]
        assert phrase in results[i]["error"], results[i]["error"]
        assert results[i + 1]["mode"] == 2  # the valid case after it is solved


@pytest.mark.parametrize(("text", "field", "phrase"), BAD_CASES, ids=[f for _, f, _ in BAD_CASES])
def test_each_bad_case_alone_exits_1_in_under_2_s(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, field: str, phrase: str
) -> None:
    code, out, err, elapsed = _run_raw(tmp_path, f"[{text}]".encode(), capsys)
    assert (code, err) == (1, "")
    assert elapsed < 2.0
    [result] = json.loads(out)
    assert result["error"].startswith(f"case 0: field '{field}'") and phrase in result["error"]


def test_a_failure_inside_one_case_is_that_cases_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Any exception while solving a case (or a non-finite result) is its error entry, exit 1."""
    from drake_disamb.core.disambiguation import Algorithm1

    real = Algorithm1.select

    def flaky(self, request):  # type: ignore[no-untyped-def]
        if request.position[0] == 0.125:
            raise ZeroDivisionError("division by zero")
        result = real(self, request)
        if request.position[0] == 0.25:
            result.mode_scores[0] = np.nan
        return result

    monkeypatch.setattr(Algorithm1, "select", flaky)
    cases = [
        Y_SCENE,
        dict(Y_SCENE, position=[0.125, 0, 0.1]),
        dict(Y_SCENE, position=[0.25, 0, 0.1]),
        Y_SCENE,
    ]
    report = tmp_path / "results.json"
    code, out, err, _ = _run_raw(
        tmp_path, json.dumps(cases).encode(), capsys, "--explain", "--json", str(report)
    )
    assert code == 1
    results = json.loads(report.read_text())
    assert results[1] == {"error": "case 1: could not be solved: ZeroDivisionError: division by zero"}
    assert results[2]["error"].startswith("case 2: could not be solved: ValueError: Out of range float")
    assert results[0]["mode"] == results[3]["mode"] == 1
    assert "case 1:\n  error: could not be solved: ZeroDivisionError" in out
    assert "Traceback" not in err


def _deep(n: int) -> bytes:
    return b"[" * n + b"]" * n


UNUSABLE: list[tuple[str, bytes | None, str]] = [
    # (id, file contents or None for a missing file, a phrase of the one-line error)
    ("missing", None, "cannot read: No such file or directory"),
    (
        "not-utf8",
        b'[{"belief": [0.5, 0.5], "position": "\xff\xfe"}]',
        "not UTF-8 text: byte 0xff at offset 37",
    ),
    ("utf16", json.dumps([Y_SCENE]).encode("utf-16"), "not UTF-8 text: byte 0xff at offset 0"),
    ("deep-200000", _deep(200_000), "JSON nested too deep (more than 64 levels"),
    ("deep-objects", b'[{"a":' * 100 + b"1" + b"}]" * 100, "JSON nested too deep"),
    (
        "duplicate-key",
        b'[{"belief": [0.5, 0.5], "belief": [1, 0]}]',
        "duplicate key 'belief' in a JSON object",
    ),
    ("nested-duplicate", b'[{"x": {"k": 1, "k": 2}}]', "duplicate key 'k'"),
    ("too-large", b"[" + b" " * (16 * 2**20) + b"]", "larger than the limit of 16 MiB"),
    ("not-json", b"[{belief: 1}]", "not valid JSON: Expecting property name"),
    ("truncated", json.dumps([Y_SCENE]).encode()[:-3], "not valid JSON"),
    ("trailing", b"[] []", "not valid JSON: Extra data"),
    ("empty", b"", "not valid JSON: Expecting value"),
    ("object", json.dumps(Y_SCENE).encode(), "expected a JSON list of cases, got a JSON object"),
    ("number", b"3", "expected a JSON list of cases, got a JSON number"),
    ("unterminated-string", b'["' + b'a\\"' * 100_000, "not valid JSON: Unterminated string"),
]


@pytest.mark.parametrize(("data", "phrase"), [u[1:] for u in UNUSABLE], ids=[u[0] for u in UNUSABLE])
def test_unusable_input_exits_2_with_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], data: bytes | None, phrase: str
) -> None:
    path = tmp_path / "cases file.json"
    if data is not None:
        path.write_bytes(data)
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    start = time.perf_counter()
    code = command.run(parser.parse_args(["--cases", str(path)]))
    elapsed = time.perf_counter() - start
    out = capsys.readouterr()
    assert code == 2
    assert out.out == ""
    assert out.err.count("\n") == 1 and out.err.endswith("\n"), out.err
    assert out.err.startswith(f"drake-disamb disambiguate: --cases {str(path)!r}: "), out.err
    assert phrase in out.err, out.err
    assert elapsed < 2.0


def test_a_directory_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    assert command.run(parser.parse_args(["--cases", str(tmp_path)])) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot read: Is a directory" in err


def test_stdin_and_byte_order_mark(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    args = parser.parse_args(["--cases", "-"])
    stdin = io.TextIOWrapper(io.BytesIO(b"\xef\xbb\xbf" + json.dumps([Y_SCENE]).encode()))
    monkeypatch.setattr(sys, "stdin", stdin)
    assert command.run(args) == 0
    assert json.loads(capsys.readouterr().out)[0]["mode"] == 1
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"[\x80]")))
    assert command.run(args) == 2
    assert capsys.readouterr().err == (
        "drake-disamb disambiguate: --cases '<stdin>': "
        "not UTF-8 text: byte 0x80 at offset 1 cannot be decoded\n"
    )


def test_strings_with_brackets_do_not_count_as_nesting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    case = dict(Y_SCENE, preset="[" * 100 + '\\"{' * 100)
    code, out, _, _ = _run_raw(tmp_path, json.dumps([case, Y_SCENE]).encode(), capsys)
    assert code == 1
    results = json.loads(out)
    assert "field 'preset'" in results[0]["error"] and len(results[0]["error"]) < 300  # cut repr
    assert results[1]["mode"] == 1
    assert command._nesting_depth(b'[{"a": "]]]}}}", "b": [[1]]}]') == 4  # noqa: SLF001
    assert command._nesting_depth(b'["\\\\", [[]]]') == 3  # noqa: SLF001  an escaped backslash


def test_help_documents_the_exit_codes_and_bad_options_exit_2() -> None:
    parser = argparse.ArgumentParser(prog="drake-disamb disambiguate")
    command.add_arguments(parser)
    text = parser.format_help()
    assert "exit status:" in text
    for line in ("  0  every case was solved", "  1  some cases are invalid", "  2  the input as a whole"):
        assert line in text
    for bad in ("99", "x", "-2"):
        with pytest.raises(SystemExit) as exc:
            parser.parse_args(["--cases", "c.json", "--indent", bad])
        assert exc.value.code == 2


def test_a_reader_that_goes_away_is_not_a_traceback(tmp_path: Path) -> None:
    """``drake-disamb disambiguate ... | head -1``: the pipe closes early; no BrokenPipeError traceback."""
    import subprocess

    example = Path(__file__).resolve().parents[1] / "examples" / "disambiguate_cases.json"
    cases = tmp_path / "many.json"  # far more output than a pipe's buffer holds
    cases.write_text(json.dumps(json.loads(example.read_text()) * 60))
    proc = subprocess.Popen(
        [sys.executable, "-m", "drake_disamb.cli", "disambiguate", "--cases", str(cases), "--indent", "2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout.readline()  # the first line, then the reader leaves
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert "Traceback" not in err
