"""The strict check of plain scenario data against the schema, run before Drake's YAML loader.

:func:`pydrake.common.yaml.yaml_load_typed` builds the dataclasses but trusts its input more than a
file from a user should be trusted: a string loads into a ``list[float]`` as its characters
(``"123"`` becomes ``[1.0, 2.0, 3.0]``), a quoted ``"0.5"`` or ``"nan"`` loads as a number, a
number where a mapping belongs fails on an ``assert``, and its errors name the leaf field
(``'x'``) but not where it is. :func:`check_data` walks the parsed data alongside the same
dataclasses first and raises ``ValueError`` naming the field path and the value, e.g.
``scenario.goals[2].position: expected 3 finite numbers, got [0.1, nan, 0.2]``. Data that passes
loads without an error from Drake.

The same walk checks a scenario built in code (on :func:`~drake_disamb.config.schema.to_plain`
of it), so a field changed with ``dataclasses.replace`` is checked like one read from a file.

What it accepts: a ``float`` is a finite real number (an integer too, never a bool); an ``int``
an integer (not a bool); a ``bool`` true or false; a ``str`` a string (one of the field's
``choices``, when it has them); a ``list`` a list (of one of the field's ``size`` lengths and at
most ``max_items`` long, when given); ``X | None`` also ``None``; a dataclass or Drake struct a
mapping with no unknown key and every ``required`` key; a variant (a union of classes, the
scenario's ``station``) a mapping whose YAML tag (``!Lcm``; none for the first class, as Drake
reads it) names one of them, its other keys that class's. Values in messages are cut
(:func:`~drake_disamb.core.validation.bounded_repr`).
"""

from __future__ import annotations

import dataclasses
import numbers
import types
import typing
from typing import Any

from drake_disamb.core.validation import bounded_repr, is_real

MAX_DURATION: float = 3600.0
"""Longest trial (s) a scenario, a protocol or a command-line ``--duration`` may ask for: a trial
whose user never acts runs to its duration, so this bounds how long any trial can run."""

MAX_REQUEST_LATENCY: float = 60.0
"""Longest request latency (s) a scenario or a protocol may ask for."""


def check_duration(value: float, path: str) -> None:
    """A trial's duration: a finite number of seconds in (0, :data:`MAX_DURATION`] (the one bound
    of the scenario, the protocol and the commands' ``--duration``)."""
    if not 0.0 < value <= MAX_DURATION:
        raise ValueError(f"{path}: expected a number of seconds in (0, {MAX_DURATION:g}], got {fmt(value)}")


def check_request_latency(value: float, path: str) -> None:
    """A request latency: seconds in [0, :data:`MAX_REQUEST_LATENCY`]."""
    if not 0.0 <= value <= MAX_REQUEST_LATENCY:
        raise ValueError(
            f"{path}: expected a number of seconds in [0, {MAX_REQUEST_LATENCY:g}], got {fmt(value)}"
        )


def fmt(value: Any) -> str:
    """``repr(value)`` cut to 200 characters, never formatting more (see :func:`bounded_repr`)."""
    return bounded_repr(value, 200)


def cut(text: str, limit: int = 400) -> str:
    """``text`` cut to ``limit`` characters."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


def schema_fields(schema: type) -> list[tuple[str, Any, dict[str, Any]]] | None:
    """``(name, type, check metadata)`` of each field of a dataclass or Drake struct, else ``None``."""
    if dataclasses.is_dataclass(schema):
        return [(f.name, f.type, dict(f.metadata.get("check", {}))) for f in dataclasses.fields(schema)]
    drake = getattr(schema, "__fields__", None)
    return None if drake is None else [(f.name, f.type, {}) for f in drake]


def variant_types(schema: Any) -> tuple[type, ...] | None:
    """The alternatives of a variant field (a union of several classes, e.g. ``station: Sim | Lcm``,
    ``None`` left out), else ``None`` (a plain type or ``X | None``)."""
    if typing.get_origin(schema) not in (typing.Union, types.UnionType):
        return None
    options = tuple(a for a in typing.get_args(schema) if a is not type(None))
    return options if len(options) > 1 else None


def variant_tag(cls: type) -> str:
    """The YAML tag that chooses ``cls`` in a variant field (Drake's: ``!`` and the class name)."""
    return f"!{cls.__name__}"


def _is_integer(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _check_list(item: Any, data: Any, path: str, meta: dict[str, Any]) -> None:
    sizes = meta.get("size")
    if item is float and sizes is not None:  # a vector: one message for its type, length and entries
        if not isinstance(data, list) or len(data) not in sizes or not all(is_real(v) for v in data):
            what = " or ".join(str(n) for n in sizes)
            raise ValueError(f"{path}: expected {what} finite numbers, got {fmt(data)}")
        return
    if not isinstance(data, list):
        raise ValueError(f"{path}: expected a list, got {fmt(data)}")
    if sizes is not None and len(data) not in sizes:
        raise ValueError(f"{path}: expected {' or '.join(map(str, sizes))} items, got {len(data)}")
    if "max_items" in meta and len(data) > meta["max_items"]:
        raise ValueError(f"{path}: expected at most {meta['max_items']} items, got {len(data)}")
    for i, value in enumerate(data):
        check_data(item, value, f"{path}[{i}]")


def check_data(schema: Any, data: Any, path: str, meta: dict[str, Any] | None = None) -> None:
    """Raise ``ValueError`` at the first place where plain ``data`` does not fit type ``schema``.

    Args:
        schema: A field type of the scenario schema (a dataclass, a Drake struct, ``list[...]``,
            ``dict[str, ...]``, ``X | None``, ``float``, ``int``, ``bool`` or ``str``).
        data: Plain data (as parsed from YAML).
        path: Where ``data`` is, for messages (``"scenario"``, ``"scenario.goals[2]"``).
        meta: The field's check metadata (``required``, ``choices``, ``size``, ``max_items``).
    """
    meta = meta or {}
    origin = typing.get_origin(schema)
    if origin in (typing.Union, types.UnionType):  # X | None, or a variant (its tag picks the class)
        if data is None and type(None) in typing.get_args(schema):
            return
        options = variant_types(schema)
        if options is not None:
            _check_variant(options, data, path)
            return
        (schema,) = [a for a in typing.get_args(schema) if a is not type(None)]
        origin = typing.get_origin(schema)
    if origin is list:
        _check_list(typing.get_args(schema)[0], data, path, meta)
    elif origin is dict:  # str keys (from meta's choices where given) to values of one type
        if not isinstance(data, dict):
            raise ValueError(f"{path}: expected a mapping, got {fmt(data)}")
        value_type = typing.get_args(schema)[1]
        for key, value in data.items():
            if not isinstance(key, str) or ("choices" in meta and key not in meta["choices"]):
                known = f" (one of {', '.join(meta['choices'])})" if "choices" in meta else ""
                raise ValueError(f"{path}: unknown key {fmt(key)}{known}")
            check_data(value_type, value, f"{path}.{key}")
    elif schema is float:
        if not is_real(data):
            raise ValueError(f"{path}: expected a finite number, got {fmt(data)}")
    elif schema is int:
        if not _is_integer(data):
            raise ValueError(f"{path}: expected an integer, got {fmt(data)}")
    elif schema is bool:
        if not isinstance(data, bool):
            raise ValueError(f"{path}: expected true or false, got {fmt(data)}")
    elif schema is str:
        if not isinstance(data, str):
            raise ValueError(f"{path}: expected a string, got {fmt(data)}")
        if "choices" in meta and data not in meta["choices"]:
            raise ValueError(f"{path}: expected one of {', '.join(meta['choices'])}, got {fmt(data)}")
    else:
        _check_mapping(schema, data, path)


def _check_variant(options: tuple[type, ...], data: Any, path: str) -> None:
    """A variant's mapping: its tag (``!Lcm``; none is the first alternative) names one of
    ``options``, whose fields the rest of the mapping must fit."""
    tags = ", ".join(variant_tag(cls) for cls in options)
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping, tagged with one of {tags}, got {fmt(data)}")
    tag = data.get("_tag")
    chosen = options[0] if tag is None else next((c for c in options if variant_tag(c) == tag), None)
    if chosen is None:
        raise ValueError(f"{path}: unknown tag {fmt(tag)} (one of {tags})")
    _check_mapping(chosen, {k: v for k, v in data.items() if k != "_tag"}, path)


def _check_mapping(schema: type, data: Any, path: str) -> None:
    fields = schema_fields(schema)
    if fields is None:  # pragma: no cover (a programming error in the schema)
        raise TypeError(f"{path}: unsupported field type {schema!r}")
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping of {schema.__name__} fields, got {fmt(data)}")
    if "_tag" in data:  # a YAML tag on a mapping that is not a variant's
        tag = fmt(data["_tag"])
        raise ValueError(f"{path}: unexpected tag {tag} (a tag chooses a variant, as in station: !Lcm {{}})")
    names = {name for name, _, _ in fields}
    for key in data:
        if key not in names:
            shown = key if isinstance(key, str) and key.isidentifier() and len(key) <= 60 else fmt(key)
            known = ", ".join(sorted(names))
            raise ValueError(
                f"{path}.{cut(shown, 60)}: unknown key (known keys of {schema.__name__}: {known})"
            )
    for name, tp, meta in fields:
        if name in data:
            check_data(tp, data[name], f"{path}.{name}", meta)
        elif meta.get("required"):
            raise ValueError(f"{path}.{name}: required field missing")
