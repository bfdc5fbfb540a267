"""A registry of named variants: one per extension point, looked up by the name a scenario gives.

Each variant is a small class with a ``name`` class attribute (python-control's ``BasisFamily``
style: one class per variant); a scenario's YAML names it, as Drake's ``hardware_sim`` scenario
tags the driver struct it wants. The registry is live: a variant registered after the schema was
imported is accepted by the schema's checks (they test membership and list the names of the
registry itself).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Generic, TypeVar

T = TypeVar("T", bound=type)


class Registry(Generic[T]):
    """Variant classes by their ``name``, in registration order.

    Iterating yields the names (so a registry serves as a schema field's ``choices``); ``get``
    returns the class.

    Args:
        what: What the variants are, for error messages (e.g. ``"inference method"``).
    """

    def __init__(self, what: str) -> None:
        self.what = what
        self._variants: dict[str, T] = {}

    def register(self, variant: T) -> T:
        """Add ``variant`` under its ``name`` (usable as a class decorator); ``ValueError`` if the
        name is taken or is not a non-empty string."""
        name = getattr(variant, "name", None)
        if not isinstance(name, str) or not name:
            raise ValueError(f"{self.what}: a variant needs a non-empty string name, got {name!r}")
        if name in self._variants:
            raise ValueError(f"{self.what} {name!r}: already registered ({self._variants[name].__name__})")
        self._variants[name] = variant
        return variant

    def unregister(self, name: str) -> None:
        """Remove the variant ``name`` (``ValueError`` listing the registered ones if unknown)."""
        self.get(name)
        del self._variants[name]

    def get(self, name: object) -> T:
        """The variant called ``name``; an unknown name is a ``ValueError`` listing the registered ones."""
        variant = self._variants.get(name) if isinstance(name, str) else None
        if variant is None:
            raise ValueError(f"{self.what}: expected one of {', '.join(self._variants)}, got {name!r}")
        return variant

    def names(self) -> tuple[str, ...]:
        """The registered names, in registration order."""
        return tuple(self._variants)

    def variants(self) -> tuple[T, ...]:
        """The registered classes, in registration order."""
        return tuple(self._variants.values())

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self._variants

    def __iter__(self) -> Iterator[str]:
        return iter(tuple(self._variants))

    def __len__(self) -> int:
        return len(self._variants)

    def __repr__(self) -> str:
        return f"Registry({self.what!r}: {', '.join(self._variants)})"
