"""Reading and writing scenarios: the raw-text hardening, then Drake's typed YAML loader and dumper.

Reading YAML (:func:`load_scenario`, :func:`scenario_from_yaml`) takes five steps; each fails with a
``ValueError`` that names the file (or ``source``) and, past the first two, the field path:

1. the text itself (:mod:`drake_disamb.yaml_safety`): at most 1 MiB of UTF-8 text (a binary or
   undecodable file is named as such), nesting at most 32 deep, at most 50,000 values, no anchors
   or aliases, no duplicate keys, one document;
2. parsing with PyYAML's safe loader (libyaml's), reading every YAML 1.2 number as a number
   (``2e0``, ``-.5``, ``0o17``; :class:`~drake_disamb.yaml_safety.SafeYamlLoader`);
3. the parsed data against the schema (:func:`~drake_disamb.config.checks.check_data`: unknown
   keys, types, finite numbers, vector lengths, choices, required keys) and the goal and stage
   counts (:func:`~drake_disamb.config.validation.check_counts`), both cheap, before the slower
   step 4 (Drake parses in pure Python);
4. :func:`pydrake.common.yaml.yaml_load_typed` builds the :class:`~drake_disamb.config.schema.Scenario`
   (an unknown key is an error, a key left out keeps its default) from the data of step 2 dumped
   again, so every value is the one steps 2 and 3 read (Drake's own reading of the text is YAML
   1.1's, which has no ``0o17``);
5. the resolver's checks (:func:`~drake_disamb.config.resolve.validate_scenario`).

:func:`dump_scenario` writes a scenario with :func:`pydrake.common.yaml.yaml_dump_typed`, every field
written out but those that are ``None``; the text loads back to an equal scenario.
:func:`scenario_from_dict` takes the same plain data as a parsed file (steps 3 to 5).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from drake_disamb.config.checks import check_data, cut, fmt
from drake_disamb.config.resolve import validate_scenario
from drake_disamb.config.schema import INTERFACES, PARADIGMS, Scenario, to_plain
from drake_disamb.config.validation import check_counts, check_hold_times
from drake_disamb.yaml_safety import load_yaml_document, read_yaml_file

EMBEDDED_TASKS: tuple[str, ...] = ("reaching", "pouring")
"""Names of the scenarios shipped as package data in ``drake_disamb/tasks``."""


def _typed(data: Any, source: str) -> Scenario:
    """Steps 3 to 5 on parsed ``data``; Drake reads ``data`` dumped again (module docstring)."""
    check_data(Scenario, data, "scenario")
    check_counts(len(data.get("goals", [])), len(data.get("stages", [None])), "scenario")
    text = yaml.dump(data, Dumper=getattr(yaml, "CSafeDumper", yaml.SafeDumper))
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text, allow_yaml_with_no_schema=False)
    except (RuntimeError, ValueError, TypeError) as exc:  # not expected once check_data has passed
        raise ValueError(f"{source}: Drake's YAML loader failed: {cut(str(exc))}") from None
    scenario = validate_scenario(scenario)
    check_hold_times(scenario)
    return scenario


def scenario_from_dict(data: Any, source: str = "scenario") -> Scenario:
    """Build and validate a :class:`Scenario` from plain data (as parsed from YAML).

    Raises:
        ValueError: naming the field path and the value.
    """
    if not isinstance(data, dict):
        raise ValueError(f"scenario: expected a mapping of Scenario fields, got {fmt(data)}")
    return _typed(data, source)


def scenario_from_yaml(text: str | bytes, source: str = "<string>") -> Scenario:
    """Parse YAML ``text`` (or UTF-8 bytes) into a validated :class:`Scenario` (steps 1 to 5).

    Raises:
        ValueError: on malformed or unsafe YAML (naming ``source`` and the line) or any invalid field.
    """
    data = load_yaml_document(text, source, root="scenario")
    if not isinstance(data, dict):
        raise ValueError(f"scenario: expected a mapping of Scenario fields, got {fmt(data)}")
    return _typed(data, source)


def embedded_scenario_text(name: str) -> str:
    """The YAML text of an embedded scenario (``"reaching"`` or ``"pouring"``)."""
    if name not in EMBEDDED_TASKS:
        raise ValueError(f"task: expected one of {', '.join(EMBEDDED_TASKS)} or a YAML path, got {name!r}")
    return resources.files("drake_disamb.tasks").joinpath(f"{name}.yaml").read_text(encoding="utf-8")


@functools.cache
def embedded_stage_goals(name: str) -> tuple[int, ...]:
    """Goals per stage of an embedded task (``"reaching"``: ``(5,)``; ``"pouring"``: ``(2, 2)``),
    its scenario loaded once per process."""
    scenario = load_scenario(name)
    return tuple(len(scenario.stage_goals(k)) for k in range(scenario.n_stages))


def load_scenario(path_or_name: str | Path) -> Scenario:
    """Load an embedded scenario by name (``"reaching"``, ``"pouring"``) or a YAML file by path.

    Raises:
        ValueError: an unknown name, a missing file, malformed YAML or an invalid field.
    """
    text_name = str(path_or_name)
    if isinstance(path_or_name, str) and text_name in EMBEDDED_TASKS:
        return scenario_from_yaml(embedded_scenario_text(text_name), f"<embedded {text_name}.yaml>")
    path = Path(path_or_name)
    if path.suffix.lower() not in (".yaml", ".yml") and not path.exists():
        raise ValueError(
            f"task: expected one of {', '.join(EMBEDDED_TASKS)} or a YAML path, got {text_name!r}"
        )
    if not path.is_file():
        raise ValueError(f"task: no such scenario file: {fmt(text_name)}")
    return scenario_from_yaml(read_yaml_file(path), str(path))


def dump_scenario(scenario: Scenario) -> str:
    """``scenario`` as YAML (:func:`~pydrake.common.yaml.yaml_dump_typed`): every field but the ``None`` ones.

    The text loads back (:func:`scenario_from_yaml`) to a scenario equal to ``scenario``.
    """
    return yaml_dump_typed(scenario, schema=Scenario)


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """Plain-data form of ``scenario`` (round-trips through :func:`scenario_from_dict`)."""
    return to_plain(scenario)


def with_overrides(
    scenario: Scenario,
    *,
    interface: str | None = None,
    paradigm: str | None = None,
    goal: int | Sequence[int] | None = None,
    seed: int | None = None,
) -> Scenario:
    """A copy of ``scenario`` with command-line overrides applied, validated.

    ``goal`` is one index (used for every stage) or one index per stage.
    """
    changes: dict[str, Any] = {}
    if interface is not None:
        if interface not in INTERFACES:
            raise ValueError(f"interface: expected one of {', '.join(INTERFACES)}, got {interface!r}")
        changes["interface"] = interface
    if paradigm is not None:
        if paradigm not in PARADIGMS:
            raise ValueError(f"paradigm: expected one of {', '.join(PARADIGMS)}, got {paradigm!r}")
        changes["paradigm"] = paradigm
    if seed is not None:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
        changes["seed"] = seed
    if goal is not None:
        goals = [goal] * scenario.n_stages if isinstance(goal, int) else list(goal)
        for i, g in enumerate(goals):
            if isinstance(g, bool) or not isinstance(g, int):
                raise ValueError(f"goal[{i}]: expected an integer goal index, got {g!r}")
        if len(goals) != scenario.n_stages:
            raise ValueError(
                f"goal: expected one index or {scenario.n_stages} (one per stage), got {goals!r}"
            )
        for k, g in enumerate(goals):
            n = len(scenario.stage_goals(k))
            if not 0 <= g < n:
                raise ValueError(f"goal: expected an index in [0, {n - 1}] for stage {k}, got {g!r}")
        changes["user"] = dataclasses.replace(scenario.user, goals=goals)
    return validate_scenario(dataclasses.replace(scenario, **changes))
