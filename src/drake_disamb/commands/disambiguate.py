"""``drake-disamb disambiguate``: run Algorithm 1 on scenes given as JSON, print JSON results."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

HELP = "Choose the disambiguating control mode (Algorithm 1) for scenes given as JSON."

DESCRIPTION = """\
Reads a JSON list of cases and prints a JSON list of results, one per case, in order. Nothing
but that JSON goes to stdout.

Case fields:
  belief             [p1, ..., pn]  probabilities over the n goals (sum 1)
  position           [x, y, z]  end-effector position (m, world frame)
  orientation        [qw, qx, qy, qz]  end-effector orientation (optional, default identity)
  goals              [[x, y, z] or [x, y, z, qw, qx, qy, qz], ...]  goal poses (a goal without
                     an orientation takes the end-effector's, i.e. no orientation preference)
  modes              [[0, 1], [2], ...]  control modes as dimension indices (0 = vx ... 5 = wz)
  current_mode       i  index of the mode in use (optional; kept on ties)
  preset             "mico" or "authors-r3" (optional, default --preset)
  transition_matrix  [[...], ...]  n x n row-stochastic goal-transition matrix (optional)

Result fields: "mode" (index into modes, or null when the current mode is kept), "best_mode",
"dimension" (k*), "dimensions" (the probed ones), "dimension_scores" {"plus", "minus", "total"},
"mode_scores", "features" {"gamma", "omega", "lambda", "upsilon": {"plus", "minus"}}. An invalid
case gives {"error": "case I: field 'NAME': ..."} in its place; the other cases are still solved.

With --explain each result also gets an "explanation" field (a short account of why the mode won
and which features dominated), and the same text is printed to stderr for people.

Exit status: 0 if every case was valid, 1 if any case was invalid, 2 if the file itself could not
be read as a JSON list.
"""

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
    "DisambiguationConfig.bayes_transition": "transition_matrix",
}


class CaseError(ValueError):
    """A problem with one field of one case."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"field '{field}': {message}")
        self.field = field


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the sub-command's options."""
    parser.description = HELP + "\n\n" + DESCRIPTION
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument(
        "--cases", required=True, metavar="FILE.json", help="JSON list of cases ('-' reads stdin)."
    )
    parser.add_argument(
        "--preset",
        default="mico",
        choices=("mico", "authors-r3"),
        help="Preset for cases that do not name one (default: mico).",
    )
    parser.add_argument(
        "--explain",
        action="store_true",
        help="Add an 'explanation' field to each result and print the explanations to stderr.",
    )
    parser.add_argument(
        "--indent", type=int, default=2, help="JSON indentation (default 2; -1 for one line)."
    )


def _numbers(value: Any, field: str, size: int | None = None) -> list[float]:
    if not isinstance(value, list) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value
    ):
        raise CaseError(field, f"expected a list of finite numbers, got {value!r}")
    if size is not None and len(value) != size:
        raise CaseError(field, f"expected {size} numbers, got {value!r}")
    return [float(v) for v in value]


def _solve_case(case: Any, default_preset: str) -> Any:
    """Validate one case and run the core; raises :class:`CaseError`."""
    import numpy as np

    from drake_disamb.core.disambiguation import disambiguate, preset

    if not isinstance(case, dict):
        raise CaseError("case", f"expected a JSON object, got {case!r}")
    unknown = sorted(set(case) - set(CASE_FIELDS))
    if unknown:
        raise CaseError(unknown[0], f"unknown field (expected some of {', '.join(CASE_FIELDS)})")
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
            "goals", f"expected a non-empty list of [x, y, z] or [x, y, z, qw, qx, qy, qz], got {goals!r}"
        )
    rows = []
    for i, g in enumerate(goals):
        row = _numbers(g, f"goals[{i}]")
        if len(row) not in (3, 7):
            raise CaseError(f"goals[{i}]", f"expected 3 or 7 numbers, got {g!r}")
        rows.append(row)
    if len(belief) != len(rows):
        raise CaseError(
            "belief", f"expected {len(rows)} probabilities (one per goal), got {case['belief']!r}"
        )
    default_q = orientation if orientation is not None else [1.0, 0.0, 0.0, 0.0]
    goal_positions = np.array([r[:3] for r in rows])
    goal_orientations = np.array([r[3:] if len(r) == 7 else default_q for r in rows])
    current = case.get("current_mode")
    if current is not None and (isinstance(current, bool) or not isinstance(current, int) or current < 0):
        raise CaseError("current_mode", f"expected a non-negative integer, got {current!r}")
    name = case.get("preset", default_preset)
    if name not in ("mico", "authors-r3"):
        raise CaseError("preset", f"expected 'mico' or 'authors-r3', got {name!r}")
    transition = case.get("transition_matrix")
    if transition is not None:
        if not isinstance(transition, list) or len(transition) != len(rows):
            raise CaseError(
                "transition_matrix", f"expected a {len(rows)}x{len(rows)} matrix, got {transition!r}"
            )
        transition = [_numbers(r, "transition_matrix", len(rows)) for r in transition]
    try:
        config = preset(name, transition=transition)
        return disambiguate(
            belief,
            position,
            goal_positions,
            case["modes"],
            config,
            orientation=orientation,
            goal_orientations=goal_orientations,
            current_mode=current,
        )
    except ValueError as exc:
        message = str(exc)
        prefix = message.split(":", 1)[0]
        field = _CORE_FIELD.get(prefix.split("[", 1)[0], prefix)
        raise CaseError(field, message) from exc


def solve_cases(
    cases: list[Any], default_preset: str = "mico", explain: bool = False
) -> tuple[list[dict], int]:
    """Solve every case. Returns ``(results, number of invalid cases)``."""
    results: list[dict] = []
    invalid = 0
    for i, case in enumerate(cases):
        try:
            result = _solve_case(case, default_preset)
        except CaseError as exc:
            results.append({"error": f"case {i}: {exc}"})
            invalid += 1
            continue
        entry = result.to_dict()
        if explain:
            entry["explanation"] = result.explain()
        results.append(entry)
    return results, invalid


def run(args: argparse.Namespace) -> int:
    """Read the cases, print the results as JSON; exit status 0 / 1 (invalid cases) / 2 (bad file)."""
    try:
        if args.cases == "-":
            cases = json.load(sys.stdin)
        else:
            with open(args.cases, encoding="utf-8") as f:
                cases = json.load(f)
    except (OSError, json.JSONDecodeError) as exc:
        print(f"drake-disamb disambiguate: cannot read --cases {args.cases!r}: {exc}", file=sys.stderr)
        return 2
    if not isinstance(cases, list):
        print(
            f"drake-disamb disambiguate: --cases {args.cases!r}: expected a JSON list of cases, "
            f"got {type(cases).__name__}",
            file=sys.stderr,
        )
        return 2
    results, invalid = solve_cases(cases, args.preset, args.explain)
    indent = None if args.indent < 0 else args.indent
    print(json.dumps(results, indent=indent, allow_nan=False))
    if args.explain:
        for i, entry in enumerate(results):
            text = entry.get("explanation", entry.get("error", ""))
            print(f"--- case {i} ---\n{text}", file=sys.stderr)
    return 1 if invalid else 0
