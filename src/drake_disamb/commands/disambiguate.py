"""``drake-disamb disambiguate``: run a mode-selection method (Algorithm 1 by default, ``--method``
any registered one) on scenes given as JSON, print JSON results."""

from __future__ import annotations

import argparse
import codecs
import json
import re
import reprlib
import sys
from collections.abc import Callable, Iterator
from typing import Any

HELP = "Choose the disambiguating control mode (Algorithm 1) for scenes given as JSON."

DESCRIPTION = """\
Reads a JSON list of cases and prints a JSON list of results, one per case, in order. Nothing
but that JSON goes to stdout.

Case fields:
  belief             [p1, ..., pn]  probabilities over the n goals (sum 1)
  position           [x, y, z]  end-effector position (m, world frame), |x|, |y|, |z| <= 1000
  orientation        [qw, qx, qy, qz]  end-effector orientation (optional, default identity)
  goals              [[x, y, z] or [x, y, z, qw, qx, qy, qz], ...]  1 to 1000 goal poses (a goal
                     without an orientation takes the end-effector's, i.e. no orientation
                     preference); coordinates bounded like position
  modes              [[0, 1], [2], ...]  control modes as dimension indices (0 = vx ... 5 = wz)
  current_mode       i  index of the mode in use (optional; kept on ties)
  preset             a preset's name: mico or authors-r3 (optional, default --preset)
  transition_matrix  [[...], ...]  n x n row-stochastic goal-transition matrix (optional)

Result fields: "mode" (index into modes, or null when the current mode is kept), "best_mode",
"dimension" (k*), "dimensions" (the probed ones), "dimension_scores" {"plus", "minus", "total"},
"mode_scores", "features" {"gamma", "omega", "lambda", "upsilon": {"plus", "minus"}}. An invalid
case gives {"error": "case I: field 'NAME': ..."} in its place, and a case that fails while being
solved gives {"error": "case I: could not be solved: ..."}; the other cases are still solved.

Numbers are JSON numbers, never strings or booleans; coordinates, quaternions, probabilities
and transition entries must be finite floats (NaN, Infinity, 1e400 or a 400-digit integer are
case errors). Quaternions are normalised, so their scale is free, but a norm that vanishes
(< 1e-12) or overflows (entries beyond about 1e154) is a case error.

With --explain stdout gets the explanations instead, for people: per case, why the mode won and
which features dominated (or the case's error). --json FILE writes the JSON results to FILE (with
--explain each result there also has an "explanation" field), and stdout then gets no JSON.
"""

EPILOG = """\
exit status:
  0  every case was solved
  1  some cases are invalid or could not be solved: each has an "error" entry in its place, the
     others are solved, and the output is still one valid JSON list (with --explain: the case's
     error in place of its explanation)
  2  the input as a whole is unusable: --cases cannot be read, is larger than 16 MiB, is not
     UTF-8 text, is not JSON, is nested deeper than 64 levels, has a duplicate key in an object,
     or is not a JSON list (also a bad command-line option, or a --json file that cannot be
     written). One line on stderr names the problem and the file; nothing goes to stdout.

examples (from the repository root):
  drake-disamb disambiguate --cases examples/disambiguate_cases.json --explain
  drake-disamb disambiguate --cases examples/disambiguate_cases.json --json out/modes.json
  drake-disamb disambiguate --cases examples/disambiguate_errors.json   # exit 1: per-case errors
"""

MAX_BYTES = 16 * 1024 * 1024
"""Largest accepted --cases input (bytes)."""

MAX_DEPTH = 64
"""Deepest accepted nesting of JSON lists and objects (a case needs 4: list, case, goals, goal)."""

_MAX_INT_DIGITS = 309
"""JSON integers with more digits than this cannot be a float (1.8e308 has 309 digits): they are
kept as :class:`_HugeInt` (a case error where a number is expected) instead of being parsed."""

CASE_FIELDS = (
    "belief",
    "position",
    "orientation",
    "goals",
    "modes",
    "current_mode",
    "preset",
    "transition_matrix",
)

# Names the core uses in its ValueError messages -> the JSON field they come from.
_CORE_FIELD = {
    "belief": "belief",
    "position": "position",
    "orientation": "orientation",
    "goal_positions": "goals",
    "goal_orientations": "goals",
    "modes": "modes",
    "current_mode": "current_mode",
    "transition": "transition_matrix",
    "DFTParams.transition": "transition_matrix",
    "BayesInference.transition": "transition_matrix",
}


class CaseError(ValueError):
    """A problem with one field of one case."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"field '{field}': {message}")
        self.field = field


class InputError(Exception):
    """The --cases input as a whole is unusable (exit status 2); the message names the problem."""


class _HugeInt:
    """A JSON integer too long to be a float, kept unparsed (its digits are never converted)."""

    __slots__ = ("digits",)

    def __init__(self, text: str) -> None:
        self.digits = len(text.lstrip("-"))

    def __repr__(self) -> str:
        return f"<integer of {self.digits} digits>"


class _DuplicateKey(ValueError):
    def __init__(self, key: str) -> None:
        super().__init__(f"duplicate key {_short(key)} in a JSON object")


_REPR = reprlib.Repr()
_REPR.maxlevel = 3
_REPR.maxlist = _REPR.maxdict = 8
_REPR.maxstring = _REPR.maxother = 60
_REPR.maxlong = 40


def _short(value: Any) -> str:
    """``repr(value)`` cut while it is built (a huge or deep input never gets formatted whole)."""
    try:
        return _REPR.repr(value)
    except (ValueError, RecursionError):  # ints beyond str()'s digit limit, pathological nesting
        return f"<{type(value).__name__}>"


class _Registered:
    """``argparse`` choices read from the core when first needed (parsing this sub-command, or its
    help), so that building the command line imports no numpy: iterating gives the names."""

    def __init__(self, names: Callable[[], Any]) -> None:
        self._names = names

    def __contains__(self, name: object) -> bool:
        return name in self._names()

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())


def _method_names() -> Any:
    from drake_disamb.core.disambiguation import MODE_SELECTION_METHODS

    return MODE_SELECTION_METHODS


def _preset_names() -> tuple[str, ...]:
    from drake_disamb.core.disambiguation import PRESETS

    return PRESETS


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the sub-command's options."""
    parser.description = HELP + "\n\n" + DESCRIPTION
    parser.epilog = EPILOG
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument(
        "--cases", required=True, metavar="FILE.json", help="JSON list of cases ('-' reads stdin)."
    )
    parser.add_argument(
        "--preset",
        default="mico",
        choices=_Registered(_preset_names),
        metavar="PRESET",
        help="Preset for cases that do not name one: %(choices)s (default: mico).",
    )
    parser.add_argument(
        "--method",
        default="algorithm1",
        choices=_Registered(_method_names),
        metavar="METHOD",
        help="Mode-selection method, one of %(choices)s: the paper's Algorithm 1 (default), the minimum "
        "expected entropy or the maximum expected KL divergence of the projected belief (all on the "
        "same projection; each result names its method).",
    )
    parser.add_argument(
        "--explain",
        action="store_true",
        help="Print an explanation of each choice (and each case's error) instead of the JSON.",
    )
    parser.add_argument(
        "--json",
        metavar="FILE.json",
        default=None,
        help="Write the JSON results to this file instead of stdout (checked before any work).",
    )
    parser.add_argument(
        "--indent", type=_indent, default=2, help="JSON indentation, 0 to 16 (default 2; -1 for one line)."
    )


def _indent(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or not -1 <= value <= 16:
        raise argparse.ArgumentTypeError(f"expected an integer from -1 to 16, got {text!r}")
    return value


# ----------------------------------------------------------------------------------------------
# Loading the input (every failure here is an InputError: exit status 2)
# ----------------------------------------------------------------------------------------------

# A JSON string (its closing quote optional, so that an unterminated one is skipped in linear
# time) or a run of bytes that are neither brackets nor quotes: what the depth scan ignores.
_NOT_NESTING = re.compile(rb'"[^"\\]*+(?:\\.[^"\\]*+)*+"?|[^\[\]{}"]++', re.DOTALL)
_STEP = bytes.maketrans(b"[{]}", b"\x01\x01\xff\xff")  # +1 / -1 as int8


def _nesting_depth(data: bytes) -> int:
    """The deepest nesting of lists and objects in ``data`` (JSON text), stopping once it exceeds
    :data:`MAX_DEPTH`. Linear time; for text that is not JSON the result is only an estimate."""
    import numpy as np

    brackets = _NOT_NESTING.sub(b"", data).translate(_STEP)
    depth = deepest = 0
    chunk = 1 << 20
    for start in range(0, len(brackets), chunk):
        steps = np.frombuffer(brackets, dtype=np.int8, count=min(chunk, len(brackets) - start), offset=start)
        levels = np.cumsum(steps, dtype=np.int64) + depth
        deepest, depth = max(deepest, int(levels.max())), int(levels[-1])
        if deepest > MAX_DEPTH:
            break
    return deepest


def _object(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    obj: dict[str, Any] = {}
    for key, value in pairs:
        if key in obj:
            raise _DuplicateKey(key)
        obj[key] = value
    return obj


def _parse_int(text: str) -> int | _HugeInt:
    return _HugeInt(text) if len(text) - text.startswith("-") > _MAX_INT_DIGITS else int(text)


def parse_cases(data: bytes) -> list[Any]:
    """The JSON list of cases in ``data``; :class:`InputError` (one line, no file name) if unusable.

    Limits: at most :data:`MAX_BYTES` bytes, UTF-8 (a leading byte-order mark is allowed), nesting
    at most :data:`MAX_DEPTH` deep, no duplicate key in any object, a list at the top level.
    Integers too long to be floats are kept as :class:`_HugeInt` (a case error where used).
    """
    if len(data) > MAX_BYTES:
        raise InputError(f"larger than the limit of {MAX_BYTES // 2**20} MiB")
    bom = len(codecs.BOM_UTF8) if data.startswith(codecs.BOM_UTF8) else 0
    try:
        text = data[bom:].decode("utf-8")
    except UnicodeDecodeError as exc:
        at = bom + exc.start
        raise InputError(f"not UTF-8 text: byte 0x{data[at]:02x} at offset {at} cannot be decoded") from None
    depth = _nesting_depth(data)
    if depth > MAX_DEPTH:
        raise InputError(f"JSON nested too deep (more than {MAX_DEPTH} levels of lists and objects)")
    try:
        cases = json.loads(text, object_pairs_hook=_object, parse_int=_parse_int)
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON: {exc}") from None
    except _DuplicateKey as exc:
        raise InputError(str(exc)) from None
    except RecursionError:  # the depth scan should have caught it: a backstop
        raise InputError("JSON nested too deep") from None
    except (ValueError, MemoryError) as exc:
        raise InputError(f"cannot parse the JSON: {type(exc).__name__}: {_short(str(exc))}") from None
    if not isinstance(cases, list):
        raise InputError(f"expected a JSON list of cases, got a JSON {_json_type(cases)}")
    return cases


def _json_type(value: Any) -> str:
    if isinstance(value, dict):
        return "object"
    if isinstance(value, str):
        return "string"
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "boolean"
    return "number"


def read_cases(path: str) -> list[Any]:
    """Read and parse --cases (``'-'``: stdin); :class:`InputError` naming the problem if unusable."""
    try:
        if path == "-":
            stream = getattr(sys.stdin, "buffer", sys.stdin)
            if stream is None:
                raise InputError("no standard input")
            data = stream.read(MAX_BYTES + 1)
            if isinstance(data, str):  # a text stream without a buffer (tests)
                data = data.encode("utf-8", "surrogateescape")
        else:
            with open(path, "rb") as f:
                data = f.read(MAX_BYTES + 1)
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror or type(exc).__name__}") from None
    except ValueError as exc:  # e.g. a path with a NUL byte
        raise InputError(f"cannot read: {exc}") from None
    return parse_cases(data)


# ----------------------------------------------------------------------------------------------
# Solving the cases (every failure here is one case's error entry: exit status 1)
# ----------------------------------------------------------------------------------------------


def _numbers(value: Any, field: str, size: int | None = None) -> list[float]:
    """A JSON list of numbers as floats. Only the JSON types are checked here: finiteness and
    bounds are the core's checks (:func:`drake_disamb.core.disambiguation.disambiguate`)."""
    if not isinstance(value, list):
        raise CaseError(field, f"expected a list of numbers, got {_short(value)}")
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise CaseError(field, f"expected numbers, got {_short(v)} in {_short(value)}")
        try:
            out.append(float(v))
        except OverflowError:  # an int beyond the float range
            raise CaseError(
                field, f"expected numbers within the float range, got an integer of {v.bit_length()} bits"
            ) from None
    if size is not None and len(out) != size:
        raise CaseError(field, f"expected {size} numbers, got {_short(value)}")
    return out


def _solve_case(case: Any, default_preset: str, method: str = "algorithm1") -> Any:
    """Validate one case and run the registered mode-selection ``method``; raises :class:`CaseError`."""
    import numpy as np

    from drake_disamb.core.disambiguation import PRESETS, make_request, mode_selection_method, preset

    chosen = mode_selection_method(method)

    if not isinstance(case, dict):
        raise CaseError("case", f"expected a JSON object, got {_short(case)}")
    unknown = sorted(set(case) - set(CASE_FIELDS))
    if unknown:
        raise CaseError(unknown[0][:60], f"unknown field (expected some of {', '.join(CASE_FIELDS)})")
    for required in ("belief", "position", "goals", "modes"):
        if required not in case:
            raise CaseError(required, "missing")
    belief = _numbers(case["belief"], "belief")
    position = _numbers(case["position"], "position", 3)
    orientation = (
        _numbers(case["orientation"], "orientation", 4) if case.get("orientation") is not None else None
    )
    goals = case["goals"]
    if not isinstance(goals, list) or not goals:
        raise CaseError(
            "goals",
            f"expected a non-empty list of [x, y, z] or [x, y, z, qw, qx, qy, qz], got {_short(goals)}",
        )
    rows = []
    for i, g in enumerate(goals):
        row = _numbers(g, f"goals[{i}]")
        if len(row) not in (3, 7):
            raise CaseError(f"goals[{i}]", f"expected 3 or 7 numbers, got {_short(g)}")
        rows.append(row)
    if len(belief) != len(rows):
        raise CaseError(
            "belief", f"expected {len(rows)} probabilities (one per goal), got {_short(case['belief'])}"
        )
    default_q = orientation if orientation is not None else [1.0, 0.0, 0.0, 0.0]
    goal_positions = np.array([r[:3] for r in rows])
    goal_orientations = np.array([r[3:] if len(r) == 7 else default_q for r in rows])
    current = case.get("current_mode")
    if current is not None and (isinstance(current, bool) or not isinstance(current, int) or current < 0):
        raise CaseError("current_mode", f"expected a non-negative integer, got {_short(current)}")
    name = case.get("preset", default_preset)
    if not isinstance(name, str) or name not in PRESETS:
        raise CaseError("preset", f"expected {' or '.join(map(repr, PRESETS))}, got {_short(name)}")
    transition = case.get("transition_matrix")
    if transition is not None:
        if not isinstance(transition, list) or len(transition) != len(rows):
            raise CaseError(
                "transition_matrix", f"expected a {len(rows)}x{len(rows)} matrix, got {_short(transition)}"
            )
        transition = [_numbers(r, "transition_matrix", len(rows)) for r in transition]
    try:
        config = preset(name, transition=transition)
        request = make_request(
            belief,
            position,
            goal_positions,
            case["modes"],
            config,
            orientation=orientation,
            goal_orientations=goal_orientations,
            current_mode=current,
        )
        return chosen.select(request)
    except ValueError as exc:
        message = str(exc)
        prefix = message.split(":", 1)[0]
        base, bracket, index = prefix.partition("[")
        field = _CORE_FIELD.get(base, base)
        if bracket and field == "goals":  # goal_positions[i] -> goals[i]
            field += bracket + index
        raise CaseError(field[:60], message) from exc


def _cut(text: str, limit: int = 1000) -> str:
    return text if len(text) <= limit else text[:limit] + "..."


def solve_cases(
    cases: list[Any], default_preset: str = "mico", explain: bool = False, method: str = "algorithm1"
) -> tuple[list[dict], int]:
    """Solve every case with the mode-selection ``method``. Returns ``(results, number of cases with
    an error entry)``.

    A case never costs the others: a :class:`CaseError` (invalid input) and any other exception
    raised while solving it (or building its JSON result) become that case's ``{"error": ...}``
    entry. Only ``KeyboardInterrupt`` and ``SystemExit`` pass.
    """
    import numpy as np

    results: list[dict] = []
    invalid = 0
    # Huge inputs overflow in the core's checks before they are rejected: the case's error entry
    # says so, numpy's RuntimeWarnings on stderr would only be noise.
    with np.errstate(all="ignore"):
        for i, case in enumerate(cases):
            try:
                result = _solve_case(case, default_preset, method)
                entry = result.to_dict()
                if explain:
                    entry["explanation"] = result.explain()
                json.dumps(entry, allow_nan=False)  # a non-finite number fails here, not in the batch
            except CaseError as exc:
                results.append({"error": _cut(f"case {i}: {exc}")})
                invalid += 1
            except Exception as exc:  # isolation is the point: one case, one error entry
                results.append({"error": _cut(f"case {i}: could not be solved: {type(exc).__name__}: {exc}")})
                invalid += 1
            else:
                results.append(entry)
    return results, invalid


def format_explanations(results: list[dict]) -> str:
    """The ``--explain`` text: per case a header line, then its explanation (or error) indented."""
    blocks = []
    for i, entry in enumerate(results):
        if "error" in entry:
            text = "error: " + entry["error"].removeprefix(f"case {i}: ")
        else:
            text = entry.get("explanation", "")
        blocks.append(f"case {i}:\n" + "\n".join("  " + line for line in text.splitlines()))
    return "\n".join(blocks)


def run(args: argparse.Namespace) -> int:
    """Read the cases, write the results (JSON or, with --explain, explanations); exit status 0 / 1
    (invalid cases) / 2 (bad input or an unwritable --json)."""
    from drake_disamb.commands._outputs import check_output_file

    name = "<stdin>" if args.cases == "-" else args.cases
    json_path = getattr(args, "json", None)
    if json_path is not None:
        try:
            check_output_file(json_path, "--json")
        except ValueError as exc:
            print(f"drake-disamb disambiguate: {' '.join(str(exc).split())}", file=sys.stderr)
            return 2
    try:
        cases = read_cases(args.cases)
    except InputError as exc:
        problem = " ".join(str(exc).split())  # exactly one line
        print(f"drake-disamb disambiguate: --cases {name!r}: {problem}", file=sys.stderr)
        return 2
    results, invalid = solve_cases(cases, args.preset, args.explain, args.method)
    indent = None if args.indent < 0 else args.indent
    text = json.dumps(results, indent=indent, allow_nan=False)
    if json_path is not None:
        try:
            with open(json_path, "w", encoding="utf-8") as f:
                f.write(text + "\n")
        except OSError as exc:
            reason = exc.strerror or type(exc).__name__
            print(f"drake-disamb disambiguate: --json: cannot write {json_path} ({reason})", file=sys.stderr)
            return 2
    if args.explain:
        print(format_explanations(results))
    elif json_path is None:
        print(text)
    if json_path is not None:
        print(f"wrote {json_path}", file=sys.stderr)
    return 1 if invalid else 0
