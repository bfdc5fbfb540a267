"""The one scenario loader: layers of YAML, merged by Drake's typed loader, then checked once.

A scenario is read as Drake's examples read theirs: :func:`pydrake.common.yaml.yaml_load_typed`
fills the :class:`~drake_disamb.config.schema.Scenario` dataclasses, each layer loaded with the
scenario so far as its ``defaults=``. Everything that makes a scenario is a layer (:class:`Layer`):
a task file or an embedded task (:func:`task_layer`), a system preset
(:func:`~drake_disamb.config.system_presets.system_layer`), ``--scenario-text YAML`` and the
commands' shorthands (``--interface``, ``--seed``, ``--station``...), a study trial's protocol and
draws, and ``study ablate --switch PATH=VALUE`` (:func:`setting_layer`).

What a layer replaces and what it merges (Drake's rules, with ``retain_map_defaults=True``):

- a struct (``inference``, ``inference.dft``, ``user.config``, Drake's ``plant_config`` and
  ``simulator_config``...) merges: its keys left out keep the value of the layers below;
- a list (``goals``, ``stages``, ``user.goals``, a position) is replaced whole;
- a map (``interface_mode_order``) merges key by key, each key's value replaced;
- an optional field (``carried_object``, ``start_joint_positions``, ``success.give_up_after``):
  ``null`` clears it; a mapping merges into the value below (into the defaults where it was null);
- a variant (``station``) is chosen by its tag: a layer with the tag of the alternative below
  (``station: !Lcm {status_timeout: 0.05}`` on an ``!Lcm`` station) merges into it, another tag
  starts from that alternative's defaults, and no tag means the first (``!Sim``);
- a scalar is replaced.

Reading a layer takes four steps; the fifth runs once on the merged scenario. Each fails with a
``ValueError`` that names the layer (its file, option or role) and, past the first two, the field
path and the value:

1. the text itself (:mod:`drake_disamb.yaml_safety`): at most 1 MiB of UTF-8 text (a binary or
   undecodable file is named as such), nesting at most 32 deep, at most 50,000 values, no anchors
   or aliases, no duplicate keys, one document;
2. parsing with PyYAML's safe loader (libyaml's), reading every YAML 1.2 number as a number
   (``2e0``, ``-.5``, ``0o17``) and a tagged mapping (``!Lcm {}``) as Drake does
   (:class:`~drake_disamb.yaml_safety.SafeYamlLoader`);
3. the parsed data against the schema (:func:`~drake_disamb.config.checks.check_data`: unknown
   keys, types, finite numbers, vector lengths, choices, variant tags, required keys) and the
   goal and stage counts it writes, before the slower step 4 (Drake parses in pure Python);
4. :func:`~pydrake.common.yaml.yaml_load_typed` merges the layer into the scenario so far (the
   data of step 2 dumped again, so every value is the one steps 2 and 3 read: Drake's own
   reading of the text is YAML 1.1's, which has no ``0o17``);
5. the resolver's checks (:func:`~drake_disamb.config.resolve.validate_scenario`) and the hold
   times (:func:`~drake_disamb.config.validation.check_hold_times`), on the merged scenario: an
   error is named by the last layer that wrote its field (or by every layer, for a field none
   wrote).

:func:`dump_scenario` writes a scenario with :func:`~pydrake.common.yaml.yaml_dump_typed`, every
field written out but those that are ``None`` (the ``!Sim`` station is ``station: {}``, Drake's
form for a variant's first alternative); the text loads back, alone, to an equal scenario.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from pydrake.common.yaml import yaml_dump, yaml_dump_typed, yaml_load_typed

from drake_disamb.config.checks import check_data, cut, fmt
from drake_disamb.config.resolve import validate_scenario
from drake_disamb.config.schema import Scenario, to_plain
from drake_disamb.config.validation import check_counts, check_hold_times
from drake_disamb.yaml_safety import load_yaml_document, read_yaml_file

EMBEDDED_TASKS: tuple[str, ...] = ("reaching", "pouring")
"""Names of the scenarios shipped as package data in ``drake_disamb/tasks``."""


@dataclass(frozen=True)
class Layer:
    """One layer of a scenario: plain data (checked against the schema, step 3) and where it comes
    from, for messages (a file, ``--scenario-text``, ``--seed``, ``<system tnsre2020_study.yaml>``,
    ``trial S01-...``; ``None`` adds nothing to a message). ``data`` is read, never changed."""

    source: str | None
    data: Mapping[str, Any]


def _named(source: str | None, message: object) -> str:
    return str(message) if source is None else f"{source}: {message}"


def data_layer(data: Any, source: str | None = None) -> Layer:
    """A layer of plain ``data`` (step 3).

    Raises:
        ValueError: ``data`` does not fit the schema, naming ``source``, the field and the value.
    """
    if not isinstance(data, dict):
        raise ValueError(_named(source, f"scenario: expected a mapping of Scenario fields, got {fmt(data)}"))
    try:
        check_data(Scenario, data, "scenario")
        check_counts(*(len(data[k]) if isinstance(data.get(k), list) else None for k in ("goals", "stages")))
    except ValueError as exc:
        raise ValueError(_named(source, exc)) from None
    return Layer(source, data)


def text_layer(text: str | bytes, source: str) -> Layer:
    """A layer of YAML ``text`` (or UTF-8 bytes), steps 1 to 3.

    Raises:
        ValueError: unsafe or malformed YAML (naming ``source`` and the line) or a field that does
            not fit the schema.
    """
    return data_layer(load_yaml_document(text, source, root="scenario"), source)


def setting_layer(path: str, value: Any, source: str | None = None) -> Layer:
    """A layer setting the dotted field ``path`` (``inference.agreement``) to ``value``."""
    data: Any = value
    for name in reversed(path.split(".")):
        data = {name: data}
    return data_layer(data, source)


def embedded_scenario_text(name: str) -> str:
    """The YAML text of an embedded scenario (``"reaching"`` or ``"pouring"``)."""
    if name not in EMBEDDED_TASKS:
        raise ValueError(f"task: expected one of {', '.join(EMBEDDED_TASKS)} or a YAML path, got {name!r}")
    return resources.files("drake_disamb.tasks").joinpath(f"{name}.yaml").read_text(encoding="utf-8")


@functools.cache
def _embedded_layer(name: str) -> Layer:
    return text_layer(embedded_scenario_text(name), f"<embedded {name}.yaml>")


def task_layer(path_or_name: str | Path) -> Layer:
    """The layer of an embedded task by name (``"reaching"``, ``"pouring"``; read once per process)
    or of a YAML file by path.

    Raises:
        ValueError: an unknown name, a missing file, malformed YAML or a field that does not fit.
    """
    text_name = str(path_or_name)
    if isinstance(path_or_name, str) and text_name in EMBEDDED_TASKS:
        return _embedded_layer(text_name)
    path = Path(path_or_name)
    if path.suffix.lower() not in (".yaml", ".yml") and not path.exists():
        raise ValueError(
            f"task: expected one of {', '.join(EMBEDDED_TASKS)} or a YAML path, got {text_name!r}"
        )
    if not path.is_file():
        raise ValueError(f"task: no such scenario file: {fmt(text_name)}")
    return text_layer(read_yaml_file(path), str(path))


def merge_layers(layers: Sequence[Layer], base: Scenario | None = None) -> Scenario:
    """``layers`` merged in order onto ``base`` (default: the schema's defaults), step 4, unchecked
    (:func:`load_layers` checks)."""
    scenario = base
    for layer in layers:
        try:
            scenario = yaml_load_typed(
                schema=Scenario,
                data=yaml_dump(dict(layer.data)),
                defaults=scenario,
                allow_yaml_with_no_schema=False,
            )
        except (RuntimeError, ValueError, TypeError) as exc:  # not expected once check_data has passed
            raise ValueError(_named(layer.source, f"Drake's YAML loader failed: {cut(str(exc))}")) from None
    return Scenario() if scenario is None else scenario


def check_specified(scenario: Scenario) -> None:
    """Step 5: every check of the resolver and the hold times (a scenario as specified)."""
    validate_scenario(scenario)
    check_hold_times(scenario)


def load_layers(
    layers: Sequence[Layer],
    base: Scenario | None = None,
    check: Callable[[Scenario], None] = check_specified,
) -> Scenario:
    """The scenario of ``layers`` merged onto ``base`` (:func:`merge_layers`) and checked (``check``,
    by default step 5).

    Raises:
        ValueError: naming the field path and the value, after the last layer that wrote the field.
    """
    scenario = merge_layers(layers, base)
    try:
        check(scenario)
    except ValueError as exc:
        raise ValueError(_named(_writer(layers, str(exc)), exc)) from None
    return scenario


_FIELD_PATH = re.compile(r"^scenario((?:\.[A-Za-z_]\w*|\[\d+\])*)")
_PATH_PART = re.compile(r"\.([A-Za-z_]\w*)|\[(\d+)\]")


def _writer(layers: Sequence[Layer], message: str) -> str | None:
    """The source of the last layer that wrote the field the ``message`` names, else every source."""
    match = _FIELD_PATH.match(message)
    keys: list[str | int] = []
    if match is not None:
        keys = [name if name else int(index) for name, index in _PATH_PART.findall(match.group(1))]
    for layer in reversed(layers):
        if keys and _writes(layer.data, keys):
            return layer.source
    sources = [layer.source for layer in layers if layer.source is not None]
    return " + ".join(sources) or None


def _writes(data: Any, keys: list[str | int]) -> bool:
    """Whether plain ``data`` writes the field at ``keys`` (or all of it: a list is written whole)."""
    for key in keys:
        if isinstance(data, list):
            return True
        if not isinstance(data, dict) or key not in data:
            return False
        data = data[key]
    return True


def _as_layer(layer: str | Mapping[str, Any] | Layer, source: str) -> Layer:
    if isinstance(layer, Layer):
        return layer
    return text_layer(layer, source) if isinstance(layer, str) else data_layer(dict(layer), source)


def load_scenario(path_or_name: str | Path, *layers: str | Mapping[str, Any] | Layer) -> Scenario:
    """Load an embedded task by name (``"reaching"``, ``"pouring"``) or a YAML file by path, with
    further ``layers`` on top: YAML text (as ``--scenario-text``), plain data or :class:`Layer` s,
    e.g. ``load_scenario("reaching", {"interface": "joystick", "seed": 7})``.

    Raises:
        ValueError: an unknown name, a missing file, malformed YAML or an invalid field.
    """
    extra = [_as_layer(layer, f"<layer {i + 1}>") for i, layer in enumerate(layers)]
    return load_layers([task_layer(path_or_name), *extra])


@functools.cache
def embedded_stage_goals(name: str) -> tuple[int, ...]:
    """Goals per stage of an embedded task (``"reaching"``: ``(5,)``; ``"pouring"``: ``(2, 2)``),
    its scenario loaded once per process."""
    scenario = load_scenario(name)
    return tuple(len(scenario.stage_goals(k)) for k in range(scenario.n_stages))


def scenario_from_dict(data: Any, source: str | None = None) -> Scenario:
    """Build and validate a :class:`Scenario` from plain data (as parsed from YAML): one layer.

    Raises:
        ValueError: naming the field path and the value.
    """
    return load_layers([data_layer(data, source)])


def scenario_from_yaml(text: str | bytes, source: str = "<string>") -> Scenario:
    """Parse YAML ``text`` (or UTF-8 bytes) into a validated :class:`Scenario`: one layer.

    Raises:
        ValueError: on malformed or unsafe YAML (naming ``source`` and the line) or any invalid field.
    """
    return load_layers([text_layer(text, source)])


def dump_scenario(scenario: Scenario) -> str:
    """``scenario`` as YAML (:func:`~pydrake.common.yaml.yaml_dump_typed`): every field but the ``None`` ones.

    The text loads back (:func:`scenario_from_yaml`) to a scenario equal to ``scenario``.
    """
    return yaml_dump_typed(scenario, schema=Scenario)


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """Plain-data form of ``scenario`` (round-trips through :func:`scenario_from_dict`)."""
    return to_plain(scenario)
