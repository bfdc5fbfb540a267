"""Fuzz ``drake-disamb disambiguate``: random and mutated case lists and random bytes give
a clean result (exit 0 or 1, one JSON list on stdout) or a clean error (exit 2, one line on stderr),
never an uncaught exception or a hang. Seeded (``derandomize``) and bounded, so it runs in CI."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import signal
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drake_disamb import cli
from drake_disamb.commands import disambiguate as command

FUZZ = settings(
    derandomize=True,
    database=None,
    max_examples=100,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
SECONDS_PER_EXAMPLE = 10.0
"""A run slower than this counts as a hang (a valid case takes about a millisecond)."""

VALID = [
    {
        "belief": [0.5, 0.5],
        "position": [0.0, 0.0, 0.1],
        "goals": [[0.2, -0.25, 0.1], [0.2, 0.25, 0.1]],
        "modes": [[0], [1], [2], [3], [4], [5]],
        "current_mode": 0,
    },
    {
        "belief": [0.2, 0.3, 0.5],
        "position": [0.0, -0.35, 0.3],
        "orientation": [0.9, 0.1, 0.0, 0.2],
        "goals": [[0.3, -0.5, 0.1, 1, 0, 0, 0], [-0.1, -0.6, 0.13], [0.1, -0.5, 0.4, 0, 0, 0, 1]],
        "modes": [[0, 1], [0, 2], [3, 5], [4]],
        "preset": "mico",
    },
    {
        "belief": [0.6, 0.4],
        "position": [0.0, 0.0, 0.0],
        "goals": [[0.1, 0.2, 0.3], [-0.2, 0.1, 0.0]],
        "modes": [[0], [1], [2]],
        "preset": "authors-r3",
        "transition_matrix": [[0.9, 0.1], [0.2, 0.8]],
    },
]

# Numbers that broke or could break a case: overflow, underflow, non-finite, non-float, wrong type.
NASTY = [
    1e200, -1e200, 1e308, 1e-320, 0.0, -0.0, 1e3, 1000.0001, 10**400, -(10**309), 2**63, True, False,
    None, "1", "", float("nan"), float("inf"), -float("inf"), [], {}, [1e200, 0, 0, 0],
]  # fmt: skip

# Overflow-prone magnitudes drawn more often: they are what broke whole batches before.
nasty_numbers = st.sampled_from(NASTY) | st.sampled_from([1e155, 1e200, -1e300, 10**310, 10**400, -(10**500)])
json_scalars = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=4)
json_values = st.recursive(
    json_scalars | st.sampled_from(NASTY),
    lambda inner: (
        st.lists(inner, max_size=5)
        | st.dictionaries(st.sampled_from(command.CASE_FIELDS) | st.text(max_size=3), inner, max_size=5)
    ),
    max_leaves=12,
)


@st.composite
def mutated_case(draw: st.DrawFn) -> Any:
    """A valid case with a few mutations: mostly one number swapped for a nasty value, else a field
    replaced, dropped or added."""
    case = json.loads(json.dumps(draw(st.sampled_from(VALID))))
    case.setdefault("orientation", [1.0, 0.0, 0.0, 0.0])
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["number", "number", "number", "field", "drop", "unknown"]))
        if kind == "number":
            # Every number of the case, addressed as (container, index).
            slots: list[tuple[Any, Any]] = [(case, "current_mode")] if "current_mode" in case else []
            for name in ("belief", "position", "orientation", "goals", "modes", "transition_matrix"):
                value = case.get(name)
                if isinstance(value, list):
                    for i, entry in enumerate(value):
                        if isinstance(entry, list):
                            slots += [(entry, j) for j in range(len(entry))]
                        else:
                            slots.append((value, i))
            if slots:
                container, key = draw(st.sampled_from(slots))
                container[key] = draw(nasty_numbers if draw(st.integers(0, 3)) else json_values)
        elif kind == "field":
            case[draw(st.sampled_from(command.CASE_FIELDS))] = draw(json_values)
        elif kind == "drop":
            case.pop(draw(st.sampled_from(command.CASE_FIELDS)), None)
        else:
            case[draw(st.text(max_size=3))] = draw(json_values)
    return case


case_lists = st.lists(mutated_case() | st.sampled_from(VALID) | json_values, max_size=5)


class Hang(BaseException):
    """Raised by the alarm: a BaseException, so that the per-case isolation cannot swallow it."""


@contextlib.contextmanager
def _no_hang(seconds: float) -> Iterator[None]:
    """Fail (instead of hanging the suite) if the body runs longer than ``seconds``."""

    def alarm(signum: int, frame: object) -> None:
        raise Hang(f"disambiguate ran longer than {seconds} s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _invoke(argv: list[str], via_main: bool = False) -> tuple[int, str, str]:
    """Run the command in-process; ``(exit code, stdout, stderr)``. Any exception fails the test."""
    out, err = io.StringIO(), io.StringIO()
    with _no_hang(SECONDS_PER_EXAMPLE), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        if via_main:
            code = cli.main(["disambiguate", *argv])
        else:
            parser = argparse.ArgumentParser(prog="drake-disamb disambiguate")
            command.add_arguments(parser)
            code = command.run(parser.parse_args(argv))
    return code, out.getvalue(), err.getvalue()


def _check_clean(code: int, out: str, err: str, n_cases: int | None) -> None:
    """Exit 0/1 with one JSON list of results (errors in place), or exit 2 with one stderr line."""
    assert code in (0, 1, 2), (code, err)
    assert "Traceback" not in err
    if code == 2:
        assert out == ""
        assert err.count("\n") == 1 and err.startswith("drake-disamb disambiguate: --cases "), err
        return
    assert err == ""
    results = json.loads(out, parse_constant=lambda c: pytest.fail(f"non-finite {c} in the output"))
    assert isinstance(results, list)
    if n_cases is not None:
        assert len(results) == n_cases
    errors = 0
    for i, entry in enumerate(results):
        if "error" in entry:
            assert set(entry) == {"error"} and entry["error"].startswith(f"case {i}: "), entry
            errors += 1
        else:
            assert isinstance(entry["best_mode"], int) and all(math.isfinite(v) for v in entry["mode_scores"])
    assert code == (1 if errors else 0)


@pytest.fixture(scope="module")
def cases_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz") / "cases.json"


@FUZZ
@given(cases=case_lists)
def test_random_and_mutated_case_lists_give_a_clean_result(cases_file: Path, cases: list[Any]) -> None:
    cases_file.write_text(json.dumps(cases, allow_nan=True), encoding="utf-8")
    code, out, err = _invoke(["--cases", str(cases_file), "--indent", "-1"])
    assert code in (0, 1)  # the file is a JSON list: only cases can be bad
    _check_clean(code, out, err, len(cases))


@FUZZ
@given(cases=case_lists, edits=st.lists(st.tuples(st.integers(0, 10**6), st.binary(max_size=3)), max_size=4))
def test_byte_level_mutations_give_a_clean_result_or_error(
    cases_file: Path, cases: list[Any], edits: list[tuple[int, bytes]]
) -> None:
    """Splice random bytes into a serialised case list (broken JSON, stray brackets, bad UTF-8)."""
    data = bytearray(json.dumps(cases, allow_nan=True).encode())
    for where, chunk in edits:
        at = where % (len(data) + 1)
        data[at : at + len(chunk) // 2] = chunk
    cases_file.write_bytes(bytes(data))
    _check_clean(*_invoke(["--cases", str(cases_file)]), n_cases=None)


@FUZZ
@given(data=st.binary(max_size=300) | st.text(max_size=100).map(str.encode))
def test_random_bytes_on_stdin_give_a_clean_result_or_error(data: bytes) -> None:
    stdin = io.TextIOWrapper(io.BytesIO(data))
    saved, sys.stdin = sys.stdin, stdin
    try:
        result = _invoke(["--cases", "-"], via_main=True)
    finally:
        sys.stdin = saved
    _check_clean(*result, n_cases=None)


def test_parse_cases_on_nasty_inputs() -> None:
    """The loader alone: a list or a one-line InputError, quickly, on inputs at and past its limits."""
    nasty = [b"\xff", b'"', b'["\\', b"[1e400, NaN, -Infinity]", b"[-0]", b"{}" * 10, b" " * 100]
    nasty += [b"[" * 65, b"]" * 65 + b"[", b'[{"a": 1}, {"a": 2, "b": {"a": 3}}]', b"\xef\xbb\xbf[]"]
    start = time.perf_counter()
    for data in nasty:
        try:
            assert isinstance(command.parse_cases(data), list)
        except command.InputError as exc:
            assert "\n" not in str(exc)
    assert time.perf_counter() - start < 2.0
    deepest = command.parse_cases(b"[" * command.MAX_DEPTH + b"]" * command.MAX_DEPTH)
    for _ in range(command.MAX_DEPTH - 1):
        [deepest] = deepest
    assert deepest == []
    with pytest.raises(command.InputError, match="nested too deep"):
        command.parse_cases(b"[" * (command.MAX_DEPTH + 1) + b"]" * (command.MAX_DEPTH + 1))
    [big, small] = command.parse_cases(b"[" + b"9" * 5000 + b", -" + b"9" * 309 + b"]")
    assert repr(big) == "<integer of 5000 digits>" and small == -int("9" * 309)
