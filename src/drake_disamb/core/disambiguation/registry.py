"""The mode-selection registry: what a method is, which ones there are, and running one by name.

A method is a small class in its own module (:mod:`~drake_disamb.core.disambiguation.algorithm1`,
:mod:`~drake_disamb.core.disambiguation.entropy`, :mod:`~drake_disamb.core.disambiguation.kl`)
registered in :data:`MODE_SELECTION_METHODS` under the name a scenario's
``disambiguation.method`` gives; its ``select`` takes a
:class:`~drake_disamb.core.disambiguation.request.DisambiguationRequest` and returns its own
result type (a :class:`~drake_disamb.core.disambiguation.selection.DisambiguationResult`).
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from typing import ClassVar

from numpy.typing import ArrayLike

from drake_disamb.core.disambiguation.config import DisambiguationConfig
from drake_disamb.core.disambiguation.request import DisambiguationRequest, make_request
from drake_disamb.core.disambiguation.selection import DisambiguationResult
from drake_disamb.core.registry import Registry


class ModeSelectionMethod(abc.ABC):
    """A way to choose the disambiguating control mode from a request.

    Class attributes:
        name: The registry's (and the scenario's) name.
        label: What people read (help texts, reports).
    """

    name: ClassVar[str]
    label: ClassVar[str]

    @abc.abstractmethod
    def select(self, request: DisambiguationRequest) -> DisambiguationResult:
        """Choose the mode for ``request`` (checked by :func:`make_request`)."""

    # A method without parameters is its type: equal to, and hashed like, any instance of it (a
    # method with parameters is a frozen dataclass, which replaces these).
    def __eq__(self, other: object) -> bool:
        return type(other) is type(self)

    def __hash__(self) -> int:
        return hash(type(self))

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


MODE_SELECTION_METHODS: Registry[type[ModeSelectionMethod]] = Registry("mode-selection method")
"""The mode-selection methods by name (the paper's Algorithm 1 first)."""


def mode_selection_method(method: str | ModeSelectionMethod) -> ModeSelectionMethod:
    """The registered method called ``method`` (an instance passes through); an unknown name is a
    ``ValueError`` listing the registered ones."""
    if isinstance(method, ModeSelectionMethod):
        return method
    return MODE_SELECTION_METHODS.get(method)()


def select_disambiguating_mode(
    method: str | ModeSelectionMethod,
    belief: ArrayLike,
    position: ArrayLike,
    goal_positions: ArrayLike,
    modes: Sequence[Sequence[int]],
    config: DisambiguationConfig | None = None,
    *,
    orientation: ArrayLike | None = None,
    goal_orientations: ArrayLike | None = None,
    current_mode: int | None = None,
) -> DisambiguationResult:
    """Run the mode-selection ``method`` (a registered name or a method) on a request; the other
    arguments are :func:`~drake_disamb.core.disambiguation.request.make_request`'s."""
    chosen = mode_selection_method(method)
    request = make_request(
        belief,
        position,
        goal_positions,
        modes,
        config,
        orientation=orientation,
        goal_orientations=goal_orientations,
        current_mode=current_mode,
    )
    return chosen.select(request)
