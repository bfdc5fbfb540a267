"""Checks of raw YAML input, run before any typed loading: size, encoding, nesting, aliases, keys.

A YAML parser that builds Python objects trusts its input in ways that a file from a user should
not be trusted: a few kilobytes of aliases (``&a`` / ``*a``, the "billion laughs") expand to
billions of values, a document nested 20,000 deep overflows the recursive composer, a duplicate key
silently keeps the last value, and a binary file gives a decode error that does not say which file.
:func:`check_yaml_text` walks the parser's *event stream* (iteratively: no recursion, nothing is
built) and rejects all of these before a loader (PyYAML's ``safe_load`` today, pydrake's
``yaml_load_typed`` tomorrow) sees the text. :func:`read_yaml_file` and :func:`decode_yaml_bytes`
check a file's size and encoding first.

Every failure is a ``ValueError`` whose message starts with the source (a file name, or what the
caller passes) and names the line and, where there is one, the field path, e.g.
``task.yaml, line 12: duplicate key 'position' in scenario.goals[1] (first at line 10)``.
Values in messages are cut before formatting (:func:`~drake_disamb.core.validation.bounded_repr`).

Limits (module constants, overridable per call):

- :data:`MAX_YAML_BYTES` (1 MiB): the size of the file or text, in UTF-8 bytes.
- :data:`MAX_YAML_DEPTH` (32): nested mappings and sequences (the scenarios need 5).
- :data:`MAX_YAML_NODES` (50,000): the number of values (scalars, mappings, sequences).
- :data:`MAX_NUMBER_CHARS` (100): the length of a number written in plain style.
- Anchors and aliases are rejected outright (no scenario needs them), as are mapping keys that are
  not plain scalars and more than one document per file.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from yaml.constructor import SafeConstructor
from yaml.nodes import ScalarNode
from yaml.resolver import Resolver

from drake_disamb.core.validation import bounded_repr

MAX_YAML_BYTES: int = 1 << 20
"""Largest YAML input accepted (bytes of UTF-8); the embedded scenarios are about 5 kB."""

MAX_YAML_DEPTH: int = 32
"""Deepest nesting of mappings and sequences accepted; the scenarios need 5 levels."""

MAX_YAML_NODES: int = 50_000
"""Most values (scalars, mappings and sequences) accepted; the embedded scenarios have about 300.
Loading time grows with the number of values, so this bounds the loader's time too."""

MAX_NUMBER_CHARS: int = 100
"""Longest plain number accepted (characters); Python refuses to read an integer of over 4300 digits."""

_Loader: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml's parser when there is one
_PATH_CHARS = 160  # longest field path shown in a message (the tail is kept)


def yaml_error_message(exc: yaml.YAMLError, source: str) -> str:
    """A one-line description of a PyYAML error: ``<source>: malformed YAML at line L, column C: ...``."""
    if isinstance(exc, yaml.reader.ReaderError):
        char = chr(exc.character) if isinstance(exc.character, int) else exc.character
        return (
            f"{source}: malformed YAML: unacceptable character {bounded_repr(char, 20)} "
            f"at offset {exc.position}"
        )
    where = ""
    mark = getattr(exc, "problem_mark", None)
    if mark is not None:
        where = f" at line {mark.line + 1}, column {mark.column + 1}"
    problem = getattr(exc, "problem", None) or str(exc)
    problem = problem if len(problem) <= 300 else problem[:297] + "..."
    return f"{source}: malformed YAML{where}: {problem}"


def _too_big(size: int, source: str, max_bytes: int, at_least: bool = False) -> ValueError:
    return ValueError(
        f"{source}: the YAML input is {'more than ' if at_least else ''}{size} bytes, above the limit "
        f"of {max_bytes} bytes ({max_bytes / 2**20:g} MiB)"
    )


def decode_yaml_bytes(data: bytes, source: str, *, max_bytes: int = MAX_YAML_BYTES) -> str:
    """Check the size of ``data``, that it is text and valid UTF-8, and return it decoded.

    A leading UTF-8 byte-order mark is dropped. Raises ``ValueError`` naming ``source``: too big,
    a binary file (a NUL byte), or an undecodable byte (with its offset).
    """
    if len(data) > max_bytes:
        raise _too_big(max_bytes, source, max_bytes, at_least=True)
    nul = data.find(b"\0")
    if nul >= 0:
        raise ValueError(f"{source}: a binary file, not YAML text (NUL byte at offset {nul})")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{source}: not UTF-8 text (undecodable byte 0x{data[exc.start]:02x} at offset {exc.start}); "
            f"a YAML scenario must be a UTF-8 text file"
        ) from None


def read_yaml_file(path: str | Path, *, max_bytes: int = MAX_YAML_BYTES) -> str:
    """Read ``path`` (never more than ``max_bytes`` + 1 bytes) and decode it (:func:`decode_yaml_bytes`).

    The text is not parsed: pass it to :func:`check_yaml_text` (or to a loader that does).

    Raises:
        ValueError: naming the file: unreadable, too big, binary or not UTF-8.
    """
    source = str(path)
    try:
        with open(path, "rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as exc:
        raise ValueError(f"{source}: cannot read the file: {exc.strerror or exc}") from None
    return decode_yaml_bytes(data, source, max_bytes=max_bytes)


_NO_KEY = object()


class _Frame:
    """One open mapping or sequence during the event walk."""

    __slots__ = ("index", "is_map", "key", "keys", "path")

    def __init__(self, is_map: bool, path: str) -> None:
        self.is_map = is_map
        self.path = path
        self.keys: dict[Any, int] = {}  # key -> line of its first occurrence
        self.key: Any = _NO_KEY  # mappings: the key whose value comes next; _NO_KEY while a key is due
        self.index = 0  # the next item's index (sequences)


YAML_12_NUMBERS: tuple[tuple[str, str], ...] = (
    ("tag:yaml.org,2002:float", r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9][0-9_]*)[eE][-+]?[0-9]+$"),
    ("tag:yaml.org,2002:float", r"^[-+]\.[0-9][0-9_]*$"),
    ("tag:yaml.org,2002:int", r"^[-+]?0o[0-7_]+$"),
)
"""The YAML 1.2 numbers that YAML 1.1 reads as strings, as (tag, pattern), which :class:`SafeYamlLoader`
reads as numbers: checked after YAML 1.1's own patterns, so a YAML 1.1 number keeps its value."""


class _Resolver(Resolver):
    """YAML 1.1's implicit types and :data:`YAML_12_NUMBERS` (as :class:`SafeYamlLoader` resolves)."""


for _tag, _pattern in YAML_12_NUMBERS:
    _Resolver.add_implicit_resolver(_tag, re.compile(_pattern), list("-+0123456789."))

_resolver = _Resolver()
_NUMBER_TAGS = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")


def _is_number(event: yaml.ScalarEvent) -> bool:
    return _resolver.resolve(ScalarNode, event.value, event.implicit) in _NUMBER_TAGS


_constructor = SafeConstructor()


def _key_value(event: yaml.ScalarEvent) -> Any:
    """The Python value ``safe_load`` would give the scalar key (so ``1`` and ``0x1`` are the same key)."""
    tag = event.tag
    if tag in (None, "!"):
        tag = _resolver.resolve(ScalarNode, event.value, event.implicit)
    if tag == "tag:yaml.org,2002:str":
        return event.value
    construct = SafeConstructor.yaml_constructors.get(tag)
    if construct is None:  # an unknown tag: left to the loader to report
        return (tag, event.value)
    try:  # the scalar constructors keep no state (construct_object would cache every node)
        return construct(_constructor, ScalarNode(tag, event.value))
    except (yaml.YAMLError, ValueError, TypeError, OverflowError):  # left to the loader to report
        return (tag, event.value)


def _child_path(parent: _Frame | None, root: str) -> str:
    if parent is None:
        return root
    if not parent.is_map:
        return f"{parent.path}[{parent.index}]"
    key = parent.key
    if isinstance(key, str) and key.isidentifier() and len(key) <= 40:
        return f"{parent.path}.{key}" if parent.path else key
    return f"{parent.path}[{bounded_repr(key, 40)}]"


def _show(path: str) -> str:
    if not path:
        return "the top level"
    return path if len(path) <= _PATH_CHARS else "..." + path[-_PATH_CHARS:]


def check_yaml_text(
    text: str,
    source: str,
    *,
    root: str = "",
    max_bytes: int = MAX_YAML_BYTES,
    max_depth: int = MAX_YAML_DEPTH,
    max_nodes: int = MAX_YAML_NODES,
) -> None:
    """Reject YAML ``text`` that breaks a size limit, uses anchors or aliases, or repeats a key.

    Walks the parser's events without building anything and without recursion, so it is fast and
    safe on any input (a 1 MiB text takes well under a second). Field paths in messages start at ``root``
    (e.g. ``"scenario"``). A malformed document is reported like :func:`yaml_error_message`.

    Raises:
        ValueError: ``<source>, line L: <problem>``, naming the field path where there is one.
    """
    size = len(text) if len(text) > max_bytes else len(text.encode("utf-8", "surrogatepass"))
    if size > max_bytes:
        raise _too_big(size, source, max_bytes)
    stack: list[_Frame] = []
    documents = 0
    nodes = 0
    try:
        for event in yaml.parse(text, Loader=_Loader):
            line = event.start_mark.line + 1 if event.start_mark is not None else 0
            if isinstance(event, yaml.DocumentStartEvent):
                documents += 1
                if documents > 1:
                    raise ValueError(f"{source}, line {line}: more than one YAML document (a second '---')")
                continue
            if isinstance(event, yaml.MappingEndEvent | yaml.SequenceEndEvent):
                stack.pop()
                _item_done(stack)
                continue
            if not isinstance(event, yaml.NodeEvent):
                continue  # stream and document ends
            nodes += 1
            if nodes > max_nodes:
                raise ValueError(
                    f"{source}, line {line}: more than {max_nodes} YAML values (scalars and collections)"
                )
            parent = stack[-1] if stack else None
            is_key = parent is not None and parent.is_map and parent.key is _NO_KEY
            if isinstance(event, yaml.AliasEvent) or event.anchor is not None:
                sign = "alias *" if isinstance(event, yaml.AliasEvent) else "anchor &"
                where = parent.path if is_key else _child_path(parent, root)  # type: ignore[union-attr]
                raise ValueError(
                    f"{source}, line {line}: YAML {sign}{str(event.anchor)[:40]} in "
                    f"{_show(where)}: anchors and aliases are not accepted (a few of them can expand "
                    f"to billions of values)"
                )
            if is_key:
                assert parent is not None
                if not isinstance(event, yaml.ScalarEvent):
                    kind = "mapping" if isinstance(event, yaml.MappingStartEvent) else "sequence"
                    raise ValueError(
                        f"{source}, line {line}: a mapping key in {_show(parent.path)} must be a plain "
                        f"value (a name or a number), got a {kind}"
                    )
                key = _key_value(event)
                try:
                    first = parent.keys.get(key)
                except TypeError:  # unhashable: left to the loader to report
                    first = None
                if first is not None:
                    raise ValueError(
                        f"{source}, line {line}: duplicate key {bounded_repr(key, 60)} in "
                        f"{_show(parent.path)} (first at line {first})"
                    )
                try:
                    parent.keys[key] = line
                except TypeError:
                    pass
                parent.key = key
                continue
            if isinstance(event, yaml.ScalarEvent):
                if event.implicit[0] and len(event.value) > MAX_NUMBER_CHARS and _is_number(event):
                    raise ValueError(
                        f"{source}, line {line}: a number of {len(event.value)} characters in "
                        f"{_show(_child_path(parent, root))} (at most {MAX_NUMBER_CHARS})"
                    )
                _item_done(stack)
                continue
            # A mapping or sequence opens.
            path = _child_path(parent, root)
            if len(stack) >= max_depth:
                raise ValueError(
                    f"{source}, line {line}: YAML nested deeper than {max_depth} levels (at {_show(path)})"
                )
            stack.append(_Frame(isinstance(event, yaml.MappingStartEvent), path))
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        if mark is not None and "nesting depth" in str(getattr(exc, "problem", "")):  # libyaml's own limit
            raise ValueError(
                f"{source}, line {mark.line + 1}: YAML nested deeper than {max_depth} levels "
                f"(at column {mark.column + 1})"
            ) from None
        raise ValueError(yaml_error_message(exc, source)) from None


def _item_done(stack: list[_Frame]) -> None:
    """A value (scalar or closed collection) finished inside the innermost open collection."""
    if not stack:
        return
    top = stack[-1]
    if top.is_map:
        top.key = _NO_KEY
    else:
        top.index += 1


__all__ = [
    "MAX_NUMBER_CHARS",
    "MAX_YAML_NODES",
    "MAX_YAML_BYTES",
    "MAX_YAML_DEPTH",
    "YAML_12_NUMBERS",
    "SafeYamlLoader",
    "check_yaml_text",
    "decode_yaml_bytes",
    "load_yaml_document",
    "load_yaml_value",
    "read_yaml_file",
    "yaml_error_message",
]


class SafeYamlLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """PyYAML's safe loader (libyaml's parser when there is one) with three changes.

    Every number YAML 1.2 writes is a number (:data:`YAML_12_NUMBERS`): besides YAML 1.1's forms, a
    float with an exponent but no dot (``2e0``, ``1e-6``, ``1E3``), a float with a sign before its
    leading dot (``-.5``, ``+.5``) and an octal integer ``0o17`` (YAML 1.1 reads all of these as
    strings). YAML 1.1's own forms keep their values (``0x10`` is 16, ``010`` is 8, ``1_000`` is
    1000, as Drake's loader reads them). A scalar the constructor cannot convert (a date such as
    ``2020-13-45``) is reported with its line instead of a bare ``ValueError``.

    A mapping with a local tag, ``!Lcm {lcm_url: ...}`` (how Drake's YAML names the alternative of
    a variant field), reads as Drake's loader reads it: the mapping with one more key, ``_tag``
    (``"!Lcm"``), which Drake's ``yaml_dump`` writes back as the tag. A local tag on a scalar or a
    sequence is an error.
    """

    yaml_implicit_resolvers = _Resolver.yaml_implicit_resolvers  # the types :func:`check_yaml_text` sees

    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        try:
            return super().construct_object(node, deep)
        except (ValueError, TypeError, OverflowError) as exc:
            message = str(exc) if len(str(exc)) <= 200 else str(exc)[:197] + "..."
            raise yaml.constructor.ConstructorError(None, None, message, node.start_mark) from None

    def construct_variant(self, suffix: str, node: yaml.Node) -> dict[Any, Any]:
        """A ``!Tag`` node: a mapping with its tag in ``_tag``."""
        if not isinstance(node, yaml.MappingNode):
            raise yaml.constructor.ConstructorError(
                None,
                None,
                f"the tag !{suffix[:40]} names a variant: it takes a mapping (!{suffix[:40]} {{}})",
                node.start_mark,
            )
        return {**self.construct_mapping(node, deep=True), "_tag": f"!{suffix}"}


SafeYamlLoader.add_multi_constructor("!", SafeYamlLoader.construct_variant)


def _parse(text: str, source: str, root: str) -> Any:
    """:func:`check_yaml_text`, then :class:`SafeYamlLoader` (``None`` for an empty document)."""
    check_yaml_text(text, source, root=root)
    try:
        return yaml.load(text, Loader=SafeYamlLoader)  # noqa: S506 (a safe loader)
    except yaml.YAMLError as exc:
        raise ValueError(yaml_error_message(exc, source)) from None


def load_yaml_value(text: str, source: str) -> Any:
    """One value written inline, a command line's ``PATH=VALUE``: checked and read like a file's
    values (:class:`SafeYamlLoader`: ``2e0`` is the number 2.0, ``dot`` a string, ``[1, 2]`` a
    list); ``None`` for an empty text.

    Raises:
        ValueError: unsafe or malformed YAML, naming ``source``.
    """
    return _parse(text, source, root="")


def load_yaml_document(text: str | bytes, source: str, *, root: str) -> Any:
    """Check ``text`` (:func:`check_yaml_text`, bytes decoded first) and parse its one document
    with :class:`SafeYamlLoader`: the plain data of a scenario, a protocol, ...

    Raises:
        ValueError: unsafe or malformed YAML (naming ``source`` and the line), or an empty
            document (``expected a <root> mapping``).
    """
    if isinstance(text, bytes | bytearray):
        text = decode_yaml_bytes(bytes(text), source)
    data = _parse(text, source, root)
    if data is None:
        raise ValueError(f"{source}: empty YAML document, expected a {root} mapping")
    return data
