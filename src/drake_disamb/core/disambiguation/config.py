"""The forward projection's configuration (paper Algorithm 1's parameters) and its two presets.

Two named presets (:func:`preset`):

- ``"authors-r3"`` reproduces the authors' R^3 simulation (docs/facts.md sections 1 and 4).
- ``"mico"`` (the robot system's default, also ``DisambiguationConfig()``): see
  :func:`mico_config` for the parameters and why.

Every mode-selection method runs on the same projection, so they share this configuration.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.autonomy import PotentialFieldConfig
from drake_disamb.core.inference import INFERENCE_METHODS, DFTInference, DFTParams, ProjectedInference
from drake_disamb.core.validation import check_real_fields, is_real

PRESETS: tuple[str, ...] = ("mico", "authors-r3")
"""Names accepted by :func:`preset`."""

UPSILON_NORMALIZATIONS: tuple[str, ...] = ("unit_probe", "displacement", "none")
"""What ``p(t_c) - p(t_b)`` is divided by in ``Upsilon``
(:attr:`DisambiguationConfig.upsilon_normalization`)."""


MICO_DFT = DFTParams(
    tau1=4.0,
    tau2=4.0,
    lam=3.0,
    directedness=True,
    agreement=True,
    agreement_measure="cosine",
    proximity=True,
    R=0.2,
    zero_command_excitation=False,
)
"""DFT parameters of the ``mico`` preset (see :func:`mico_config`)."""


@dataclass(frozen=True)
class DisambiguationConfig:
    """Parameters of Algorithm 1. The defaults are the ``mico`` preset.

    Attributes:
        dimensions: Control dimensions probed (0 = vx ... 5 = wz), ascending, unique. A mode's
            dimensions that are not probed contribute 0 to its score.
        probe_speed_translation: Probe magnitude along a translational dimension (m/s).
        probe_speed_rotation: Probe magnitude along a rotational dimension (rad/s).
        delta_t: Projection step (s).
        t_b: Short-term horizon (s after ``t_a``), an integer multiple of ``delta_t``.
        t_c: Long-term horizon (s), a multiple of ``delta_t`` larger than ``t_b``.
        w: Weight of the short-term term, in ``[0, 1]``.
        upsilon_normalization: What ``p(t_c) - p(t_b)`` is divided by in ``Upsilon``
            (:data:`UPSILON_NORMALIZATIONS`): ``"unit_probe"`` (the paper: the displacement of its
            unit-speed probe ``e_k``, ``t_c - t_b`` units for every ``k``), ``"displacement"`` (our
            probe's displacement, m or rad) or ``"none"`` (the authors' code).
        tie_tolerance: Relative tolerance under which two ``D_m`` are equal (>= 0).
        inference: The belief update the projection runs, an inference method with a forward
            projection (:class:`~drake_disamb.core.inference.ProjectedInference`: the DFT's Euler
            step :class:`~drake_disamb.core.inference.DFTInference` or the Bayes step
            :class:`~drake_disamb.core.inference.BayesInference`), with its parameters
            (transition matrix included).
        potential_field: Autonomy used for the agreement term (recomputed at every projected pose).
    """

    dimensions: tuple[int, ...] = (0, 1, 2, 3, 4, 5)
    probe_speed_translation: float = 0.1
    probe_speed_rotation: float = 0.2
    delta_t: float = 0.1
    t_b: float = 1.0
    t_c: float = 2.0
    w: float = 0.5
    upsilon_normalization: str = "unit_probe"
    tie_tolerance: float = 1e-3
    inference: ProjectedInference = DFTInference(MICO_DFT)
    potential_field: PotentialFieldConfig = field(default_factory=PotentialFieldConfig)

    def __post_init__(self) -> None:
        dims = tuple(self.dimensions)
        if (
            not dims
            or any(
                not isinstance(k, int | np.integer) or isinstance(k, bool) or not 0 <= k <= 5 for k in dims
            )
            or list(dims) != sorted(set(dims))
        ):
            raise ValueError(
                "DisambiguationConfig.dimensions: expected ascending unique indices in 0..5, "
                f"got {self.dimensions!r}"
            )
        object.__setattr__(self, "dimensions", tuple(int(k) for k in dims))
        check_real_fields(
            self,
            (
                "probe_speed_translation",
                "probe_speed_rotation",
                "delta_t",
                "t_b",
                "t_c",
            ),
        )
        if not self.t_b < self.t_c:
            raise ValueError(f"DisambiguationConfig.t_c: expected > t_b = {self.t_b}, got {self.t_c!r}")
        for name in ("t_b", "t_c"):
            steps = getattr(self, name) / self.delta_t
            if abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
                raise ValueError(
                    f"DisambiguationConfig.{name}: expected a multiple of delta_t = {self.delta_t}, "
                    f"got {getattr(self, name)!r}"
                )
        if self.probe_speed_rotation * (self.t_c - self.t_b) >= np.pi:
            raise ValueError(
                "DisambiguationConfig.probe_speed_rotation: the rotation between t_b and t_c must stay "
                f"below pi rad to be measurable, got {self.probe_speed_rotation!r} rad/s"
            )
        if not (is_real(self.w) and 0.0 <= self.w <= 1.0):
            raise ValueError(f"DisambiguationConfig.w: expected a number in [0, 1], got {self.w!r}")
        if not (is_real(self.tie_tolerance) and self.tie_tolerance >= 0):
            raise ValueError(
                "DisambiguationConfig.tie_tolerance: expected a finite number >= 0, "
                f"got {self.tie_tolerance!r}"
            )
        if self.upsilon_normalization not in UPSILON_NORMALIZATIONS:
            raise ValueError(
                "DisambiguationConfig.upsilon_normalization: expected one of "
                f"{', '.join(UPSILON_NORMALIZATIONS)}, got {self.upsilon_normalization!r}"
            )
        if not isinstance(self.inference, ProjectedInference):
            projected = [m.name for m in INFERENCE_METHODS.variants() if issubclass(m, ProjectedInference)]
            raise ValueError(
                "DisambiguationConfig.inference: expected an inference method with a forward projection "
                f"({', '.join(projected)}), got {self.inference!r}"
            )
        if not isinstance(self.potential_field, PotentialFieldConfig):
            raise ValueError(
                "DisambiguationConfig.potential_field: expected PotentialFieldConfig, "
                f"got {self.potential_field!r}"
            )

    @property
    def steps_b(self) -> int:
        """Number of projection steps to ``t_b``."""
        return round(self.t_b / self.delta_t)

    @property
    def steps_c(self) -> int:
        """Number of projection steps to ``t_c``."""
        return round(self.t_c / self.delta_t)

    @property
    def transition(self) -> NDArray[np.float64] | None:
        """The goal-transition matrix of the configured inference method (``None``: identity)."""
        return self.inference.transition

    def with_transition(self, transition: ArrayLike | None) -> DisambiguationConfig:
        """A copy whose inference method uses ``transition`` as its goal-transition matrix."""
        return dataclasses.replace(self, inference=self.inference.with_transition(transition))


DEFAULT_CONFIG = DisambiguationConfig()
"""The configuration of a request that gives none: the ``mico`` preset."""


def mico_config(**overrides: Any) -> DisambiguationConfig:
    """The ``mico`` preset: the robot system's default (equal to ``DisambiguationConfig()``).

    - All six dimensions; probes of 0.1 m/s and 0.2 rad/s, the head array's speeds (docs/facts.md
      section 6), so the projection explores motions the user can actually make.
    - ``delta_t = 0.1 s``, ``t_b = 1 s``, ``t_c = 2 s``, ``w = 0.5`` (paper and authors' code);
      ``Upsilon`` per unit probe displacement (paper, ``upsilon_normalization="unit_probe"``).
    - DFT with directedness, agreement and proximity (paper equation dft_ii) and
      ``tau1 = tau2 = 4 s``: with no input the study logs show the belief relaxing to uniform over a
      few seconds. That needs ``zero_command_excitation=False``: with the authors' convention a zero
      command excites every goal equally (directedness 0.5), which through the mass-conserving
      flow pulls the belief to uniform at ``1/tau1 + n lambda sigma(0.5)`` (about 2 /s for five
      goals), i.e. the belief would collapse in half a second whenever the user pauses to switch
      modes. The probes always carry a command, so the projection is unaffected.
      ``lambda = 3 I`` (1/s): the differential excitation between a goal the command
      points at and one it points away from is about ``3 * 0.23 = 0.7 /s``, so one second of probe
      motion (10 cm) moves the projected belief clearly while a single 10 ms control step moves
      the live belief by under 1 %; the authors' ``lambda = 200`` suits their 2 mm, 2 ms steps
      in simulation but would make the live belief jump to the latest command direction.
    - ``R = 0.2 m``: about the spacing of the study's goals (docs/facts.md section 9), so proximity only
      favours a goal once the gripper is clearly nearer to it than to its neighbours.
    - Agreement is the cosine of the rotational parts (``agreement_measure="cosine"``; the paper's
      plain dot product is ``"dot"``: measured with the simulated user it leaves the first
      requests in a translation mode and 2 of the 5 joystick reaching trials stall, see
      docs/choices.md, "Where we differ from the paper") with the per-goal potential-field commands
      (:func:`~drake_disamb.core.autonomy.potential_field_commands`, default gains) recomputed at
      every projected pose: this is what makes goals that differ only in orientation pick a
      rotational mode.
    """
    return dataclasses.replace(DisambiguationConfig(), **overrides)


def authors_r3_config(**overrides: Any) -> DisambiguationConfig:
    """The ``authors-r3`` preset: the authors' R^3 simulation (docs/facts.md sections 1 and 4).

    Dimensions x, y, z only; DFT with the directedness term only, ``tau1 = tau2 = 10 s``,
    ``lambda = 200 I``, ``P = I`` unless given; probe 0.2; ``delta_t = 0.1 s``, ``t_b = 1 s``,
    ``t_c = 2 s``, ``w = 0.5``; ``Upsilon`` not divided by the displacement; update the belief at
    the current position, then move the point; no noise.
    """
    base = DisambiguationConfig(
        dimensions=(0, 1, 2),
        probe_speed_translation=0.2,
        probe_speed_rotation=0.2,
        delta_t=0.1,
        t_b=1.0,
        t_c=2.0,
        w=0.5,
        upsilon_normalization="none",
        tie_tolerance=1e-3,
        inference=DFTInference(
            DFTParams(tau1=10.0, tau2=10.0, lam=200.0, directedness=True, agreement=False, proximity=False)
        ),
    )
    return dataclasses.replace(base, **overrides)


def preset(name: str, transition: ArrayLike | None = None) -> DisambiguationConfig:
    """The named preset (``"mico"`` or ``"authors-r3"``), optionally with a transition matrix."""
    if name == "mico":
        cfg = mico_config()
    elif name == "authors-r3":
        cfg = authors_r3_config()
    else:
        raise ValueError(f"preset: expected one of {PRESETS}, got {name!r}")
    return cfg if transition is None else cfg.with_transition(transition)
