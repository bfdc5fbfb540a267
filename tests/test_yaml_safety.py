"""Raw YAML checks (size, encoding, nesting, aliases, duplicate keys), bounded reprs, and a fuzz test
of the scenario loader: every input gives a Scenario or a clear ValueError, quickly."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support import benchmark_module

from drake_disamb.config import (
    EMBEDDED_TASKS,
    Scenario,
    embedded_scenario_text,
    load_scenario,
    scenario_from_dict,
    scenario_from_yaml,
)
from drake_disamb.core.validation import bounded_repr, check_real_range, is_real
from drake_disamb.yaml_safety import (
    MAX_YAML_BYTES,
    MAX_YAML_DEPTH,
    MAX_YAML_NODES,
    check_yaml_text,
    decode_yaml_bytes,
    load_yaml_document,
    load_yaml_value,
    read_yaml_file,
)

LIMIT_S = 2.0  # every probe must fail within this (wall time, after the first import of pydrake)


@pytest.fixture(scope="module", autouse=True)
def _warm() -> None:
    """Load both tasks once, so timings below measure the checks, not pydrake's first import."""
    for name in EMBEDDED_TASKS:
        load_scenario(name)


def _fails_fast(fn, *args, match: str) -> str:  # noqa: ANN001
    start = time.perf_counter()
    with pytest.raises(ValueError, match=match) as err:
        fn(*args)
    elapsed = time.perf_counter() - start
    assert elapsed < LIMIT_S, f"took {elapsed:.2f} s"
    text = str(err.value)
    assert len(text) < 1000, text[:300]
    return text


def _bomb(levels: int = 9, key: str = "description") -> str:
    lines = [f"{key}:", "  - &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for k in range(1, levels):
        lines.append(f"  - &a{k} [{', '.join([f'*a{k - 1}'] * 9)}]")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------------------
# Hostile inputs at the YAML level
# ------------------------------------------------------------------------------------------------


def test_alias_bomb_under_a_known_key_fails_fast(tmp_path: Path) -> None:
    text = embedded_scenario_text("reaching").replace("description: >-", _bomb() + "notes: >-")
    msg = _fails_fast(scenario_from_yaml, text, "bomb.yaml", match=r"bomb\.yaml, line \d+: YAML anchor &a0")
    assert "scenario.description[0]" in msg and "aliases are not accepted" in msg
    # From a file, and an alias alone (its anchor undefined) is rejected the same way.
    path = tmp_path / "alias.yaml"
    path.write_text("task: &t reaching\ndescription: *t\n")
    _fails_fast(load_scenario, path, match=r"alias\.yaml, line 1: YAML anchor &t in scenario\.task")
    with pytest.raises(ValueError, match=r"x\.yaml, line 2: YAML alias \*x in b: anchors and aliases"):
        check_yaml_text("a: [1]\nb: *x\n", "x.yaml")


def test_expanded_alias_bomb_is_formatted_in_bounded_time() -> None:
    """The loader never builds one, but a caller may pass one as data: the message is still instant."""
    data = yaml.safe_load(embedded_scenario_text("reaching"))
    data["description"] = yaml.load(_bomb(12), Loader=yaml.SafeLoader)["description"]  # 9**12 leaves
    msg = _fails_fast(scenario_from_dict, data, match=r"scenario\.description: expected a string, got \[\[")
    assert msg.endswith("...")


@pytest.mark.parametrize("kind", ["flow_sequence", "flow_mapping", "block_mapping", "block_sequence"])
def test_nesting_20000_deep_fails_fast(kind: str) -> None:
    n = 20_000
    if kind == "flow_sequence":
        text = "description: " + "[" * n + "]" * n
    elif kind == "flow_mapping":
        text = "description: " + "{a: " * n + "1" + "}" * n
    else:  # block style needs k spaces at depth k: 1,400 levels fill the 1 MiB limit
        item = "{}a{}:\n" if kind == "block_mapping" else "{}-\n"
        text = "description:\n" + "".join(item.format(" " * k, k) for k in range(1, 1400))
    msg = _fails_fast(
        scenario_from_yaml, text, "deep.yaml", match=r"deep\.yaml, line \d+: YAML nested deeper"
    )
    assert f"deeper than {MAX_YAML_DEPTH} levels" in msg


def test_nesting_limit_names_line_and_path() -> None:
    text = "goals:\n  - object: " + "[" * 40 + "]" * 40 + "\n"
    with pytest.raises(ValueError, match=r"s\.yaml, line 2: YAML nested deeper than 32 levels") as err:
        check_yaml_text(text, "s.yaml", root="scenario")
    assert "scenario.goals[0].object[0][0]" in str(err.value)
    check_yaml_text("goals:\n  - object: " + "[" * 20 + "]" * 20 + "\n", "s.yaml")  # 22 deep is fine


def test_duplicate_keys_name_key_path_and_lines(tmp_path: Path) -> None:
    text = embedded_scenario_text("reaching").replace(
        "    position: [-0.116, -0.579, 0.132]\n",
        "    position: [-0.116, -0.579, 0.132]\n    position: [0.0, -0.5, 0.2]\n",
    )
    msg = _fails_fast(
        scenario_from_yaml, text, "dup.yaml", match=r"dup\.yaml, line \d+: duplicate key 'position'"
    )
    assert "in scenario.goals[1] (first at line" in msg
    path = tmp_path / "dup_top.yaml"
    path.write_text(embedded_scenario_text("reaching") + "seed: 3\n")
    _fails_fast(
        load_scenario, path, match=r"dup_top\.yaml, line \d+: duplicate key 'seed' in scenario \(first"
    )
    # Keys equal as values are duplicates, however they are written.
    for text in ("1: a\n0x1: b\n", "a: 1\n'a': 2\n", '{x: 1, "x": 2}'):
        with pytest.raises(ValueError, match="duplicate key"):
            check_yaml_text(text, "k.yaml")


def test_binary_and_undecodable_files_are_named(tmp_path: Path) -> None:
    png = tmp_path / "picture.yaml"
    png.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
    _fails_fast(
        load_scenario, png, match=r"picture\.yaml: a binary file, not YAML text \(NUL byte at offset 8\)"
    )
    latin = tmp_path / "latin1.yaml"
    latin.write_bytes("task: reaching\ndescription: caf\xe9\n".encode("latin-1"))
    _fails_fast(
        load_scenario, latin, match=r"latin1\.yaml: not UTF-8 text \(undecodable byte 0xe9 at offset 31\)"
    )
    with pytest.raises(ValueError, match=r"b\.yaml: a binary file"):
        scenario_from_yaml(b"\x00\x01", "b.yaml")
    # A UTF-8 byte-order mark is fine.
    bom = tmp_path / "bom.yaml"
    bom.write_bytes(b"\xef\xbb\xbf" + embedded_scenario_text("reaching").encode())
    assert load_scenario(bom) == load_scenario("reaching")


def test_size_limit(tmp_path: Path) -> None:
    big = tmp_path / "big.yaml"
    big.write_text("description: " + "x" * MAX_YAML_BYTES + "\n")
    _fails_fast(
        load_scenario, big, match=r"big\.yaml: the YAML input is more than 1048576 bytes, above the limit"
    )
    _fails_fast(
        scenario_from_yaml, "a: " + "é" * (MAX_YAML_BYTES // 2), "s", match=r"s: the YAML input is 1048579"
    )
    assert decode_yaml_bytes(b"a: 1\n", "s", max_bytes=5) == "a: 1\n"
    with pytest.raises(ValueError, match="limit of 4 bytes"):
        decode_yaml_bytes(b"a: 1\n", "s", max_bytes=4)


def test_value_count_limit() -> None:
    text = "description: [" + "1, " * (MAX_YAML_NODES + 10) + "]\n"
    _fails_fast(
        scenario_from_yaml, text, "many.yaml", match=r"many\.yaml, line 1: more than 50000 YAML values"
    )
    check_yaml_text("a: [1, 2]\n", "s", max_nodes=5)  # the mapping, a key, the list, 2 items
    with pytest.raises(ValueError, match="more than 4 YAML values"):
        check_yaml_text("a: [1, 2]\n", "s", max_nodes=4)


def test_a_large_valid_file_is_read_quickly(tmp_path: Path) -> None:
    """Just under the limit: the checks and the loader stay well inside the time budget."""
    data = yaml.safe_load(embedded_scenario_text("reaching"))
    data["description"] = "lorem ipsum " * 80_000
    text = yaml.safe_dump(data)
    assert len(text.encode()) < MAX_YAML_BYTES
    start = time.perf_counter()
    s = scenario_from_yaml(text, "large.yaml")
    assert time.perf_counter() - start < LIMIT_S
    assert len(s.description) > 900_000


def test_unreadable_and_special_files(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no such scenario file"):
        load_scenario(tmp_path / "missing.yaml")
    with pytest.raises(ValueError, match=r"cannot read the file"):
        read_yaml_file(tmp_path)  # a folder


def test_other_malformed_input_names_file_and_line() -> None:
    cases = {
        "a: 1\n---\nb: 2\n": r"line 2: more than one YAML document",
        "? [a, b]\n: 1\n": r"line 1: a mapping key in scenario must be a plain value",
        "seed: " + "9" * 5000 + "\n": r"line 1: a number of 5000 characters in scenario\.seed",
        "seed: 2020-13-45\n": r"malformed YAML at line 1, column 7: month must be in 1\.\.12",
        "a: \x07\n": r"malformed YAML: unacceptable character '\\x07' at offset 3",
        "!!python/object/apply:os.system ['true']\n": r"malformed YAML at line 1",
    }
    for text, match in cases.items():
        _fails_fast(scenario_from_yaml, text, "m.yaml", match=r"m\.yaml.*" + match)


# Numbers YAML 1.1 reads as strings and YAML 1.2 as numbers, and YAML 1.1's own forms (unchanged).
YAML_12_FORMS = {"2e0": 2.0, "1e-2": 0.01, "1E3": 1000.0, "+.5": 0.5, "-.5": -0.5, "+.5e1": 5.0, "0o17": 15}
YAML_11_FORMS = {".5": 0.5, "+1": 1, "0x10": 16, "1.": 1.0, "1_000": 1000, "-1.5": -1.5, ".inf": float("inf")}


@pytest.mark.parametrize("text, value", [*YAML_12_FORMS.items(), *YAML_11_FORMS.items()])
def test_every_yaml_12_number_is_a_number(text: str, value: float) -> None:
    read = load_yaml_value(text, "v")
    assert read == value and type(read) is type(value)
    assert load_yaml_document(f"x: {text}\n", "d.yaml", root="x") == {"x": value}


def test_a_value_on_the_command_line_is_checked_like_a_file() -> None:
    assert load_yaml_value("dot", "v") == "dot" and load_yaml_value("[1, 2e0]", "v") == [1, 2.0]
    with pytest.raises(ValueError, match=r"^--switch a: the value '\[1': malformed YAML"):
        load_yaml_value("[1", "--switch a: the value '[1'")
    with pytest.raises(ValueError, match=r"^v, line 1: YAML anchor &x"):
        load_yaml_value("&x 1", "v")


@pytest.mark.parametrize(
    "line, field, value",
    [("control_period: 1e-2", "control_period", 0.01), ("control_period: +.01", "control_period", 0.01),
     ("seed: 0o17", "seed", 15)],
)  # fmt: skip
def test_a_scenario_reads_yaml_12_numbers(line: str, field: str, value: float) -> None:
    """A float and an int field: Drake's loader reads the values the checks read."""
    old = {"control_period": "control_period: 0.01", "seed": "\nseed: 0\n"}[field]
    new = line if field == "control_period" else f"\n{line}\n"
    assert getattr(scenario_from_yaml(embedded_scenario_text("reaching").replace(old, new)), field) == value


def test_a_protocol_file_reads_yaml_12_numbers(tmp_path: Path) -> None:
    from drake_disamb.study.design.protocol import default_protocol_text, load_protocol

    text = default_protocol_text()
    for old, new in (("duration: 180.0", "1.2e2"), ("give_up_after: 60.0", "6e1"), ("subjects: 8", "0o10")):
        text = text.replace(old, f"{old.split(':')[0]}: {new}")
    (tmp_path / "p.yaml").write_text(text)
    protocol = load_protocol(tmp_path / "p.yaml")
    assert (protocol.duration, protocol.give_up_after, protocol.subjects) == (120.0, 60.0, 8)


def test_a_benchmarks_set_value_reads_yaml_12_numbers() -> None:
    with benchmark_module("bench_tasks") as bench:
        scenario = bench.with_settings(load_scenario("reaching"), ["disambiguation.request_latency=2e0"])
    assert scenario.disambiguation.request_latency == 2.0


# ------------------------------------------------------------------------------------------------
# Small helpers
# ------------------------------------------------------------------------------------------------


def test_bounded_repr_matches_repr_for_small_values_and_stays_bounded() -> None:
    for v in ([0.1, float("nan")], (1,), (), {"a": [None, True]}, set(), {2}, "x", b"y", 1.5, -3):
        assert bounded_repr(v) == repr(v)
    assert bounded_repr(np.array([[1.0, 2.0]])) == "[[1.0, 2.0]]"
    assert bounded_repr(10**5000) == "<integer of about 5001 digits>"
    assert bounded_repr(-(10**400)) == "<negative integer of about 401 digits>"
    loop: list = []
    loop.append(loop)
    assert bounded_repr(loop).endswith("]")
    shared = ["lol"] * 9
    for _ in range(15):  # 9**15 leaves
        shared = [shared] * 9
    start = time.perf_counter()
    text = bounded_repr(shared, 120)
    assert len(text) == 120 and text.endswith("...") and time.perf_counter() - start < 0.1
    assert len(bounded_repr("z" * 10**6, 50)) == 50


def test_real_checks() -> None:
    assert not is_real(10**400) and not is_real(True) and not is_real(float("inf")) and is_real(np.float32(2))
    assert check_real_range(0.01, "p", 1e-3, 0.1) == 0.01
    with pytest.raises(ValueError, match=r"p: expected a finite number in \[0\.001, 0\.1\] s, got 1e-06"):
        check_real_range(1e-6, "p", 1e-3, 0.1, unit="s")
    with pytest.raises(ValueError, match=r"got <integer of about 401 digits>"):
        check_real_range(10**400, "p", 1e-3, 0.1)


# ------------------------------------------------------------------------------------------------
# Fuzz: mutated embedded tasks, random text and bytes, random values at real keys
# ------------------------------------------------------------------------------------------------

_LINES = {name: embedded_scenario_text(name).splitlines(keepends=True) for name in EMBEDDED_TASKS}
_ODD_VALUES = [
    "-1",
    "0",
    "1e-9",
    "1e9",
    ".nan",
    "-.inf",
    "~",
    "true",
    "''",
    "'x'",
    "[]",
    "{}",
    "[1, 2, 3]",
    "{a: 1}",
    "&a 1",
    "*a",
    "!!python/object:os.system x",
    "!!binary aGVsbG8=",
    "2020-01-01",
    "9" * 500,
    "0x7f",
    "[" * 40,
    "{a: [1, {b: 2}]}",
    "|\n  text",
    ">-",
    "\t",
    "\\x00",
    "? a",
]
_scalars = st.none() | st.booleans() | st.integers(-(10**30), 10**30) | st.floats() | st.text(max_size=30)
_numbers = (  # values of the right kind, mostly: they reach the cross-field validation
    st.floats()
    | st.floats(-1.0, 1.0)
    | st.integers(-3, 10)
    | st.lists(st.floats(-1.0, 1.0), min_size=1, max_size=7)
    | st.lists(st.integers(0, 3), min_size=1, max_size=3)
)
_values = st.recursive(
    _scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)


@st.composite
def _mutated_task(draw: st.DrawFn) -> bytes:
    lines = list(_LINES[draw(st.sampled_from(EMBEDDED_TASKS))])
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(["delete", "duplicate", "swap", "value", "indent", "truncate"]))
        if op == "delete":
            del lines[i]
        elif op == "duplicate":
            lines.insert(i, lines[i])
        elif op == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == "value" and ":" in lines[i]:
            key = lines[i].split(":", 1)[0]
            value = draw(st.sampled_from(_ODD_VALUES) | st.text(max_size=12))
            lines[i] = f"{key}: {value}\n"
        elif op == "indent":
            lines[i] = " " * draw(st.integers(1, 4)) + lines[i]
        elif op == "truncate":
            lines[i] = lines[i][: draw(st.integers(0, len(lines[i])))]
        if not lines:
            lines = ["\n"]
    data = bytearray("".join(lines).encode("utf-8"))
    for _ in range(draw(st.integers(0, 2))):  # a few random bytes somewhere
        at = draw(st.integers(0, len(data)))
        data[at:at] = draw(st.binary(min_size=1, max_size=4))
    return bytes(data)


def _sections(data: dict) -> list[tuple[dict, list[str]]]:
    """Mappings of a scenario's plain data, each with the keys its dataclass accepts."""
    import dataclasses

    from drake_disamb.config import GoalSpec, ObjectSpec, SuccessSpec, UserSpec

    def keys(cls: type) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    inference = data.setdefault("inference", {})
    dft = inference.setdefault("dft", {})
    blending = data.setdefault("blending", {})
    autonomy = data.setdefault("autonomy", {})
    user_config = data["user"]["config"]
    return [
        (data, keys(Scenario)),
        (data["goals"][0], keys(GoalSpec)),
        (data["goals"][-1]["object"], keys(ObjectSpec)),
        (data["user"], keys(UserSpec)),
        (data["success"], keys(SuccessSpec)),
        (inference, ["method", "dft"]),
        (dft, keys(type(Scenario().inference.dft))),
        (blending, keys(type(Scenario().blending))),
        (autonomy, keys(type(Scenario().autonomy))),
        (user_config, keys(type(Scenario().user.config))),
    ]


@st.composite
def _random_value_at_a_key(draw: st.DrawFn) -> bytes:
    data = yaml.safe_load(embedded_scenario_text(draw(st.sampled_from(EMBEDDED_TASKS))))
    sections = _sections(data)  # taken first: a draw may replace a whole section
    for _ in range(draw(st.integers(1, 3))):
        target, keys = draw(st.sampled_from(sections))
        key = draw(st.sampled_from([*keys, "unknown_key"]))
        target[key] = draw(_numbers | _values)
    return yaml.safe_dump(data, allow_unicode=True).encode("utf-8")


def _load_or_clear_error(data: bytes) -> None:
    start = time.perf_counter()
    try:
        result = scenario_from_yaml(data, "fuzz.yaml")
    except ValueError as exc:
        text = str(exc)
        assert text and len(text) < 1500, text[:300]
        assert text.startswith(("fuzz.yaml", "scenario")), text[:300]
    else:
        assert isinstance(result, Scenario)
    assert time.perf_counter() - start < 5.0  # loose: the machine is shared (the probes above use 2 s)


_FUZZ = settings(
    max_examples=80,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)


@_FUZZ
@given(_mutated_task())
def test_fuzz_mutated_tasks(data: bytes) -> None:
    _load_or_clear_error(data)


@_FUZZ
@given(_random_value_at_a_key())
def test_fuzz_random_values_at_real_keys(data: bytes) -> None:
    _load_or_clear_error(data)


@settings(max_examples=50, deadline=None, derandomize=True, database=None)
@given(st.binary(max_size=300) | st.text(max_size=300).map(str.encode))
def test_fuzz_random_bytes_and_text(data: bytes) -> None:
    _load_or_clear_error(data)
