"""The inference registry: what an intent-inference method is, and which ones there are.

A method is a frozen dataclass holding its own configuration, one module each
(:mod:`~drake_disamb.core.inference.dft`, :mod:`~drake_disamb.core.inference.bayes`,
:mod:`~drake_disamb.core.inference.memory`), registered in :data:`INFERENCE_METHODS` under the
name a scenario's ``inference.method`` gives. Code that uses a method reads its properties
(``continuous``, whether it is a :class:`ProjectedInference`) or dispatches on its type, never on
its name; the Drake system of each is chosen by type in :mod:`drake_disamb.systems.inference`.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.inference.belief import posterior_update
from drake_disamb.core.registry import Registry

if TYPE_CHECKING:
    from typing import Self


@dataclass(frozen=True)
class RecordedSamples:
    """Samples of recorded teleoperation that a replay updates the belief with, ``S`` rows.

    Attributes:
        u_h: The commands ``(S, d)`` (m/s, rad/s, world frame; ``d`` = 3 or 6).
        x_cur: The end-effector positions the commands were given at ``(S, 3)`` (m).
        x_start: Each sample's trial start ``(S, 3)`` (m).
        path_cost: The running path cost ``sum |x_{t+1} - x_t|^2`` up to and including each
            sample's move ``(S,)`` (m^2).
    """

    u_h: NDArray[np.float64]
    x_cur: NDArray[np.float64]
    x_start: NDArray[np.float64]
    path_cost: NDArray[np.float64]


class InferenceMethod(abc.ABC):
    """An intent-inference method and its configuration.

    Class attributes:
        name: The registry's (and the scenario's) name.
        label: The name people read (tables, figures).
        continuous: True when the live belief is continuous state the simulator integrates (the
            integrator's settings then matter to it); False for an update every control period.
        replay_padding: The evidence of a padding goal in a batched replay (one that the update
            pins at the smallest positive double): a likelihood of 0 for the posterior recursion.
    """

    name: ClassVar[str]
    label: ClassVar[str]
    continuous: ClassVar[bool] = False
    replay_padding: ClassVar[float] = 0.0

    @abc.abstractmethod
    def recorded_evidence(self, samples: RecordedSamples, x_g: ArrayLike) -> NDArray[np.float64]:
        """The belief-independent part of the update at each recorded sample, ``(S, n)``, for the
        goals ``x_g`` (``(n, 3)`` or one set per sample ``(S, n, 3)``, m)."""

    def replayer(
        self, transition: NDArray[np.float64], dt: NDArray[np.float64]
    ) -> Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]:
        """The update of a packed replay batch: ``step(p, evidence)`` updates the first
        ``b = len(p)`` rows (``(b, n)``) of a batch whose rows have the goal-transition matrices
        ``transition`` ``(B, n, n)`` and steps ``dt`` ``(B, 1)`` (s). Default: the posterior
        recursion."""

        def step(p: NDArray[np.float64], evidence: NDArray[np.float64]) -> NDArray[np.float64]:
            return posterior_update(p, evidence, transition[: len(p)])

        return step

    @classmethod
    def from_settings(cls, dft: object) -> Self:
        """The method as a scenario configures it: ``dft`` is the scenario's resolved
        ``inference.dft`` (a :class:`~drake_disamb.core.inference.DFTParams`: the field-theoretic
        method's parameters); the baselines have no scenario settings of their own."""
        return cls()


class ProjectedInference(InferenceMethod):
    """An inference method that can project the belief forward under assumed commands: its step
    splits into a belief-independent *evidence* (computed for every step of a batch at once) and
    a recursion over it. The disambiguation's forward projection runs exactly this update.
    """

    transition: NDArray[np.float64] | None
    """The goal-transition matrix ``P`` (``None``: identity)."""

    @property
    def needs_autonomy(self) -> bool:
        """Whether :meth:`evidence` reads the per-goal autonomy commands ``u_a``."""
        return False

    @abc.abstractmethod
    def evidence(
        self, u_h: ArrayLike, x_r: ArrayLike, x_g: ArrayLike, u_a: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """The belief-independent part of a step, ``(..., n)``, for commands ``u_h`` ``(..., 6)``
        (m/s, rad/s, world frame), positions ``x_r`` ``(..., 3)`` and goals ``x_g`` ``(n, 3)`` (m)."""

    @abc.abstractmethod
    def rollout(self, p: ArrayLike, evidence: ArrayLike, dt: float) -> NDArray[np.float64]:
        """The beliefs after each of ``K`` successive steps of ``dt`` (s) from ``p`` ``(..., n)``,
        step ``s`` using ``evidence[s]`` (``(K, ..., n)``); returns ``(K, ..., n)``."""

    @abc.abstractmethod
    def with_transition(self, transition: ArrayLike | None) -> Self:
        """A copy whose goal-transition matrix is ``transition`` (``None``: identity)."""

    @abc.abstractmethod
    def check_goal_count(self, n: int) -> None:
        """``ValueError`` naming the parameter whose size does not fit ``n`` goals."""

    def recorded_evidence(self, samples: RecordedSamples, x_g: ArrayLike) -> NDArray[np.float64]:
        """:meth:`evidence` of the recorded commands at their positions."""
        return self.evidence(samples.u_h, samples.x_cur, x_g)


INFERENCE_METHODS: Registry[type[InferenceMethod]] = Registry("inference method")
"""The intent-inference methods by name, in the order the paper lists them."""
