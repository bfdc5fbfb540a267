"""Tables of measures: each measure is one function and one row of its module's table (its name, the
function that measures it and how it is shown), and :class:`Measured` holds what a table measured,
by name. The behaviour estimates (:data:`drake_disamb.study.measures.calibration.MEASURES`) and the
identification of the study's system (:data:`drake_disamb.study.measures.identify.IDENTIFICATIONS`)
are such tables: adding a measure is a function and a row, and their records and texts follow."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any, Protocol

__all__ = ["Measured", "Shown", "text_lines"]


class Measured(Mapping[str, Any]):
    """The values a table of measures measured, by the rows' names: as keys (``m["tail"]``) or as
    attributes (``m.tail``), in the table's order."""

    def __init__(self, values: Mapping[str, Any]) -> None:
        self._values = dict(values)

    def __getitem__(self, name: str) -> Any:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        try:
            return self._values[name]
        except KeyError:
            raise AttributeError(f"{type(self).__name__} has no measure {name!r}") from None

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._values!r})"


class Shown(Protocol):
    """A row of a table that may be shown as text: its ``name`` and its ``text`` (of its value and of
    all the values, for a line that shows several; ``None``: shown on another row's line)."""

    @property
    def name(self) -> str: ...

    @property
    def text(self) -> Callable[[Any, Any], str | list[str]] | None: ...


def text_lines(table: Iterable[Shown], values: Measured) -> list[str]:
    """The lines of every row of ``table`` that has a text, in the table's order."""
    lines: list[str] = []
    for row in table:
        if row.text is not None:
            text = row.text(values[row.name], values)
            lines += [text] if isinstance(text, str) else text
    return lines
