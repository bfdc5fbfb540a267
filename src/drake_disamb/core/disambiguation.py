"""Intent disambiguation (paper Algorithm 1): vectorised forward projection, features, D_k, D_m.

For every probed control dimension ``k`` and both directions, the belief is projected forward
from the current time ``t_a`` under a constant probe command ``+/- s e_k``: each step of length
``delta_t`` first updates the belief with the project's inference update at the current pose,
then moves a kinematic point robot (position and orientation) by the probe. The update is the
live system's model with the live system's parameters (the scenario's resolver passes the same
``DFTParams`` and potential field to both), but not bit for bit the live computation: the
projection takes the authors' discrete step, :func:`drake_disamb.core.inference.dft_euler_step`
(or :func:`~drake_disamb.core.inference.bayes_step`) of ``delta_t`` (0.1 s for ``mico``), while
the live belief is the continuous flow the simulator integrates at the control period (explicit
Euler at 10 ms in the embedded tasks). All ``2 n_k`` probes
run together as one batch (leading probe axis), never one after another.

From the projected beliefs (paper Section "Features of D_k", equation (DK)):

- at ``t_b``: ``Gamma = max p``, ``Omega = max p - second max p`` and
  ``Lambda = sum_{i<j} |p_i - p_j|``;
- between ``t_b`` and ``t_c``: ``Upsilon = sum_{i<j} |g_i - g_j|`` with
  ``g = (p(t_c) - p(t_b)) / dx_k``, where ``dx_k`` depends on ``upsilon_normalization``
  (:data:`UPSILON_NORMALIZATIONS`): ``"unit_probe"`` (the paper) the displacement along ``k`` of
  the paper's unit probe ``e_k`` (1 m/s or 1 rad/s) between ``t_b`` and ``t_c``, i.e. ``t_c - t_b``
  units for every dimension; ``"displacement"`` the displacement of our probe, metres for a
  translational dimension and the rotation angle about axis ``k`` (rad) for a rotational one (so
  with probes of 0.1 m/s and 0.2 rad/s a translation's gradient counts twice a rotation's);
  ``"none"`` (the authors' code) ``dx_k = 1``;
- ``D = w Gamma Lambda Omega + (1 - w) Upsilon`` per probe, ``D_k = D_k+ + D_k-``,
  ``D_m = sum_{k in m} D_k``, ``m* = argmax D_m`` and ``k* = argmax D_k``.

Ties: modes whose ``D_m`` lie within ``tie_tolerance`` (relative to the largest) of the best are
equal. If every mode is equal the current mode is kept (``mode = None``); if the current mode is
among several equally best modes it is kept too; otherwise the first of the best modes wins.

Two alternative mode-selection methods run on the same forward projection (docs/facts.md section 5, the
authors' own experiments): :func:`expected_entropy_mode` (the minimum expected entropy of the
projected belief) and :func:`expected_kl_mode` (the maximum expected KL divergence of the projected
belief from the current one), with the same function shape, result type and tie rule;
:func:`select_disambiguating_mode` runs any of :data:`MODE_SELECTION_METHODS` by name.

Two named presets (:func:`preset`):

- ``"authors-r3"`` reproduces the authors' R^3 simulation (docs/facts.md sections 1 and 4).
- ``"mico"`` (the robot system's default, also ``DisambiguationConfig()``): see
  :func:`mico_config` for the parameters and why.

Degenerate scenes (one goal, goals at the robot, a certain belief, zero displacement) give valid,
finite results: every division is guarded.

The module is longer than the project's ~500 lines because it is one algorithm with its configs,
presets, explanation and batched layout, which read best together; the shared arithmetic already
lives in :mod:`~drake_disamb.core.inference`, :mod:`~drake_disamb.core.autonomy` and the kernels.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.autonomy import PotentialFieldConfig, potential_field_rotation
from drake_disamb.core.geometry import (
    check_vectors,
    normalized_quaternions,
    orientation_error_unchecked,
    quat_from_rotvec_unchecked,
    quat_multiply_unchecked,
)
from drake_disamb.core.inference import (
    BAYES_SIGMA,
    DFTParams,
    bayes_likelihood,
    check_transition,
    dft_drive,
    dft_euler_rollout,
    posterior_update,
)
from drake_disamb.core.layout import DIM_NAMES
from drake_disamb.core.validation import MAX_GOALS, check_real_fields, is_real

INFERENCE_METHODS: tuple[str, ...] = ("dft", "bayes")
"""Inference updates the forward projection can use."""

PRESETS: tuple[str, ...] = ("mico", "authors-r3")
"""Names accepted by :func:`preset`."""

UPSILON_NORMALIZATIONS: tuple[str, ...] = ("unit_probe", "displacement", "none")
"""What ``p(t_c) - p(t_b)`` is divided by in ``Upsilon``
(:attr:`DisambiguationConfig.upsilon_normalization`)."""

FEATURE_NAMES: tuple[str, ...] = ("gamma", "omega", "lambda", "upsilon")

_MIN_DISPLACEMENT = 1e-12
"""Displacements (m or rad) below this are treated as zero: the gradient is then taken as 0."""

MAX_POSITION = 1e3
"""Largest accepted absolute coordinate (m) of the end-effector and goal positions of a request:
far beyond any arm's reach, yet small enough that no distance or potential computed from them
overflows."""


# ----------------------------------------------------------------------------------------------
# Configuration
# ----------------------------------------------------------------------------------------------

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
        inference: ``"dft"`` (:func:`~drake_disamb.core.inference.dft_euler_step`) or ``"bayes"``
            (:func:`~drake_disamb.core.inference.bayes_step`).
        dft: DFT parameters (transition matrix and rest state included).
        bayes_sigma: Std (rad) of the Bayes angle likelihood.
        bayes_transition: Goal-transition matrix of the Bayes update (``None``: identity).
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
    inference: str = "dft"
    dft: DFTParams = MICO_DFT
    bayes_sigma: float = BAYES_SIGMA
    bayes_transition: NDArray[np.float64] | None = field(default=None, compare=False)
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
                "bayes_sigma",
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
        if self.inference not in INFERENCE_METHODS:
            raise ValueError(
                f"DisambiguationConfig.inference: expected one of {INFERENCE_METHODS}, got {self.inference!r}"
            )
        if not isinstance(self.dft, DFTParams):
            raise ValueError(f"DisambiguationConfig.dft: expected DFTParams, got {self.dft!r}")
        if self.bayes_transition is not None:
            object.__setattr__(
                self,
                "bayes_transition",
                check_transition(self.bayes_transition, "DisambiguationConfig.bayes_transition"),
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
        return self.dft.transition if self.inference == "dft" else self.bayes_transition

    def with_transition(self, transition: ArrayLike | None) -> DisambiguationConfig:
        """A copy whose inference method uses ``transition`` as its goal-transition matrix."""
        P = None if transition is None else np.asarray(transition, dtype=float)
        if self.inference == "dft":
            return dataclasses.replace(self, dft=dataclasses.replace(self.dft, transition=P))
        return dataclasses.replace(self, bayes_transition=P)


_DEFAULT_CONFIG = DisambiguationConfig()


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
      requests in a translation mode and 2 of the 5 joystick reaching trials stall, see the
      README's "Where we differ from the paper") with the per-goal potential-field commands
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
        inference="dft",
        dft=DFTParams(tau1=10.0, tau2=10.0, lam=200.0, directedness=True, agreement=False, proximity=False),
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


# ----------------------------------------------------------------------------------------------
# Result
# ----------------------------------------------------------------------------------------------


def _mode_label(dims: Sequence[int]) -> str:
    return "{" + ", ".join(DIM_NAMES[k] for k in dims) + "}" if dims else "{}"


@dataclass(frozen=True)
class DisambiguationResult:
    """Outcome of one disambiguation request.

    Attributes:
        mode: ``m*`` as an index into ``modes``, or ``None`` when the current mode is kept (ties).
        best_mode: ``argmax D_m`` before the tie rule (first of equal maxima).
        dimension: ``k*`` as a control-dimension index (0 = vx ... 5 = wz).
        dimensions: The probed dimensions; the per-dimension arrays follow this order.
        scores_plus: ``D_k+``, shape ``(n_k,)``.
        scores_minus: ``D_k-``, shape ``(n_k,)``.
        dimension_scores: ``D_k = D_k+ + D_k-``, shape ``(n_k,)``.
        mode_scores: ``D_m``, shape ``(n_modes,)``.
        features: ``{"gamma", "omega", "lambda", "upsilon"}`` -> ``(2, n_k)`` arrays, row 0 for
            ``+e_k`` and row 1 for ``-e_k``.
        modes: The control modes (dimension indices).
        current_mode: The mode in use when the request came (``None`` if not given).
        w: Weight of the short-term term used.
        tie_tolerance: Relative tie tolerance used.
        method: The mode-selection method (:data:`MODE_SELECTION_METHODS`): ``"algorithm1"``
            (the scores are ``D``), ``"entropy"`` or ``"kl"`` (the scores are bits, see
            :func:`expected_entropy_mode` and :func:`expected_kl_mode`; ``features`` then holds the
            per-probe ``"entropy"`` or ``"kl"``).
    """

    mode: int | None
    best_mode: int
    dimension: int
    dimensions: tuple[int, ...]
    scores_plus: NDArray[np.float64]
    scores_minus: NDArray[np.float64]
    dimension_scores: NDArray[np.float64]
    mode_scores: NDArray[np.float64]
    features: dict[str, NDArray[np.float64]]
    modes: tuple[tuple[int, ...], ...]
    current_mode: int | None
    w: float
    tie_tolerance: float
    method: str = "algorithm1"

    @property
    def kept(self) -> bool:
        """True when the current mode is kept (no switch)."""
        return self.mode is None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary (the ``disambiguate`` command's output format)."""
        return {
            "method": self.method,
            "mode": self.mode,
            "best_mode": self.best_mode,
            "dimension": self.dimension,
            "dimensions": list(self.dimensions),
            "dimension_scores": {
                "plus": self.scores_plus.tolist(),
                "minus": self.scores_minus.tolist(),
                "total": self.dimension_scores.tolist(),
            },
            "mode_scores": self.mode_scores.tolist(),
            "features": {
                name: {"plus": values[0].tolist(), "minus": values[1].tolist()}
                for name, values in self.features.items()
            },
        }

    def explain(self) -> str:
        """A short human-readable account of why the mode won and which features dominated."""
        lines: list[str] = []
        sym = {"algorithm1": "D_m", "entropy": "expected entropy reduction (bits)"}.get(
            self.method, "expected KL (bits)"
        )
        order = np.argsort(-self.mode_scores, kind="stable")
        best = int(order[0])
        scores = ", ".join(
            f"{i} {_mode_label(m)} = {s:.4g}"
            for i, (m, s) in enumerate(zip(self.modes, self.mode_scores, strict=True))
        )
        if self.mode is None:
            cur = "the current mode" if self.current_mode is None else f"the current mode {self.current_mode}"
            top = self.mode_scores.max()
            if np.all(self.mode_scores >= top - self.tie_tolerance * abs(top)):
                lines.append(
                    f"Kept {cur}: every mode scores the same within {self.tie_tolerance:g} (relative); "
                    "moving in any mode would tell the goals apart equally (or not at all)."
                )
            else:
                lines.append(
                    f"Kept {cur}: it is among the equally best modes (within {self.tie_tolerance:g})."
                )
        else:
            runner = [int(i) for i in order if int(i) != self.mode]
            label = _mode_label(self.modes[self.mode])
            text = f"Chose mode {self.mode} {label} with {sym} = {self.mode_scores[self.mode]:.4g}"
            if self.mode != best:
                text += (
                    f": it ties with mode {best} {_mode_label(self.modes[best])} ({sym} = "
                    f"{self.mode_scores[best]:.4g}) within {self.tie_tolerance:g} (relative), and the first "
                    "of the equally best modes wins"
                )
            elif runner:
                r = runner[0]
                ratio = (
                    self.mode_scores[self.mode] / self.mode_scores[r] if self.mode_scores[r] > 0 else np.inf
                )
                text += f"; runner-up mode {r} {_mode_label(self.modes[r])} scores {self.mode_scores[r]:.4g}"
                text += f" ({ratio:.3g}x)" if np.isfinite(ratio) else " (nothing to disambiguate there)"
            lines.append(text + ".")
        lines.append(f"Mode scores {sym}: {scores}.")
        if self.method != "algorithm1":
            return "\n".join([*lines, _information_explanation(self)])
        # Which features drove the winning (or best) mode.
        focus = self.mode if self.mode is not None else best
        idx = [self.dimensions.index(k) for k in self.modes[focus] if k in self.dimensions]
        if idx:
            g, o, lam, ups = (self.features[n][:, idx] for n in FEATURE_NAMES)
            short = float(np.sum(self.w * g * lam * o))
            long = float(np.sum((1 - self.w) * ups))
            total = short + long
            if total > 0:
                share = short / total
                dom = (
                    "short-term certainty at t_b (w*Gamma*Lambda*Omega)"
                    if share >= 0.5
                    else ("long-term spread of belief gradients (1-w)*Upsilon")
                )
                lines.append(
                    f"In mode {focus} the score is {100 * max(share, 1 - share):.0f} % {dom}: "
                    f"short-term {short:.4g}, long-term {long:.4g}."
                )
            else:
                lines.append(f"Mode {focus} leaves the belief unchanged: every feature is zero.")
        k = self.dimensions.index(self.dimension)
        sign = 0 if self.scores_plus[k] >= self.scores_minus[k] else 1
        f = {n: float(self.features[n][sign, k]) for n in FEATURE_NAMES}
        lines.append(
            f"Best dimension k* = {DIM_NAMES[self.dimension]} (D_k = {self.dimension_scores[k]:.4g}; "
            f"D+ = {self.scores_plus[k]:.4g}, D- = {self.scores_minus[k]:.4g}); moving "
            f"{'+' if sign == 0 else '-'}{DIM_NAMES[self.dimension]} gives Gamma = {f['gamma']:.3f}, "
            f"Omega = {f['omega']:.3f}, Lambda = {f['lambda']:.3f}, Upsilon = {f['upsilon']:.4g}."
        )
        return "\n".join(lines)


# ----------------------------------------------------------------------------------------------
# Validation of a request
# ----------------------------------------------------------------------------------------------


def validate_modes(modes: Sequence[Sequence[int]]) -> tuple[tuple[int, ...], ...]:
    """``modes`` as tuples of dimension indices; ``ValueError`` naming the bad entry."""
    # Fast path for the usual lists/tuples of plain ints: validated once per distinct value.
    if modes and type(modes) in (list, tuple) and all(type(m) in (list, tuple) for m in modes):
        key = tuple(tuple(m) for m in modes)
        if all(type(k) is int for m in key for k in m):
            return _validate_int_modes(key)
    return _validate_modes(modes)


@functools.lru_cache(maxsize=256)
def _validate_int_modes(modes: tuple[tuple[int, ...], ...]) -> tuple[tuple[int, ...], ...]:
    return _validate_modes(modes)


def _validate_modes(modes: Sequence[Sequence[int]]) -> tuple[tuple[int, ...], ...]:
    if isinstance(modes, str | bytes) or not isinstance(modes, Sequence) or len(modes) == 0:
        raise ValueError(f"modes: expected a non-empty list of lists of dimension indices, got {modes!r}")
    out = []
    for i, m in enumerate(modes):
        if isinstance(m, str | bytes) or not isinstance(m, Sequence | np.ndarray):
            raise ValueError(f"modes[{i}]: expected a list of dimension indices 0..5, got {m!r}")
        dims = []
        for k in m:
            if isinstance(k, bool) or not isinstance(k, int | np.integer) or not 0 <= int(k) <= 5:
                raise ValueError(f"modes[{i}]: expected dimension indices 0..5, got {list(m)!r}")
            dims.append(int(k))
        if len(set(dims)) != len(dims):
            raise ValueError(f"modes[{i}]: repeated dimension index in {dims!r}")
        out.append(tuple(dims))
    return tuple(out)


@functools.lru_cache(maxsize=256)
def _membership(modes: tuple[tuple[int, ...], ...], dimensions: tuple[int, ...]) -> NDArray[np.float64]:
    """``(n_modes, n_k)`` matrix: 1 where the mode contains the probed dimension (read-only)."""
    index = {k: i for i, k in enumerate(dimensions)}
    member = np.zeros((len(modes), len(dimensions)))
    for m, dims in enumerate(modes):
        for k in dims:
            if k in index:
                member[m, index[k]] = 1.0
    return _frozen(member)


def _validate_belief(belief: ArrayLike, n: int) -> NDArray[np.float64]:
    p = check_vectors(belief, n, "belief")
    if p.ndim != 1:
        raise ValueError(f"belief: expected a vector of {n} probabilities, got shape {p.shape}")
    total = p.sum()
    if (p < 0).any() or abs(total - 1.0) > 1e-6:
        raise ValueError(f"belief: expected non-negative entries summing to 1, got {p.tolist()!r}")
    return p / total


def _check_positions(a: NDArray[np.float64], name: str) -> None:
    """``ValueError`` naming the first row of ``a`` (finite, ``(3,)`` or ``(n, 3)``) with an entry
    beyond :data:`MAX_POSITION`."""
    if not np.maximum.reduce(np.abs(a), axis=None) <= MAX_POSITION:
        rows = a.reshape(-1, 3)
        i = int(np.argmax(np.abs(rows).max(axis=1) > MAX_POSITION))
        label, row = (name, a) if a.ndim == 1 else (f"{name}[{i}]", rows[i])
        raise ValueError(f"{label}: expected coordinates within +/-{MAX_POSITION:g} m, got {row.tolist()!r}")


def _check_transition_size(P: ArrayLike | None, n: int) -> None:
    """Contents are checked when the config is built (``check_transition``); here only the size."""
    if P is not None and np.shape(P) != (n, n):
        raise ValueError(f"transition: expected a {n}x{n} matrix (one row per goal), got shape {np.shape(P)}")


def _validated_request(
    belief: ArrayLike,
    position: ArrayLike,
    goal_positions: ArrayLike,
    modes: Sequence[Sequence[int]],
    config: DisambiguationConfig | None,
    orientation: ArrayLike | None,
    goal_orientations: ArrayLike | None,
    current_mode: int | None,
) -> tuple[
    DisambiguationConfig,
    tuple[tuple[int, ...], ...],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
]:
    """The checks every mode-selection method runs on a request (the arguments of
    :func:`disambiguate`): ``(config, modes, belief, position, orientation, goal_positions,
    goal_orientations)``, validated and normalised; ``ValueError`` naming the argument otherwise."""
    cfg = _DEFAULT_CONFIG if config is None else config
    mode_dims = validate_modes(modes)
    x = check_vectors(position, 3, "position")
    if x.ndim != 1:
        raise ValueError(f"position: expected 3 numbers, got shape {x.shape}")
    _check_positions(x, "position")
    gp = check_vectors(goal_positions, 3, "goal_positions")
    if gp.ndim != 2 or not 1 <= gp.shape[0] <= MAX_GOALS:
        raise ValueError(
            f"goal_positions: expected shape (n, 3) with 1 <= n <= {MAX_GOALS} (MAX_GOALS), got {gp.shape}"
        )
    _check_positions(gp, "goal_positions")
    n = gp.shape[0]
    p = _validate_belief(belief, n)
    q = (
        np.array([1.0, 0.0, 0.0, 0.0])
        if orientation is None
        else normalized_quaternions(orientation, "orientation")
    )
    if q.ndim != 1:
        raise ValueError(f"orientation: expected 4 numbers, got shape {q.shape}")
    if goal_orientations is None:
        gq = np.broadcast_to(q, (n, 4))
    else:
        gq = normalized_quaternions(goal_orientations, "goal_orientations")
        if gq.shape != (n, 4):
            raise ValueError(f"goal_orientations: expected shape ({n}, 4), got {gq.shape}")
    if current_mode is not None and (
        isinstance(current_mode, bool) or not isinstance(current_mode, int | np.integer) or current_mode < 0
    ):
        raise ValueError(f"current_mode: expected a non-negative integer or None, got {current_mode!r}")
    if cfg.inference == "dft":
        _check_transition_size(cfg.dft.transition, n)
        if cfg.dft.rest is not None and np.shape(cfg.dft.rest) != (n,):
            raise ValueError(f"dft.rest: expected {n} entries, got {np.asarray(cfg.dft.rest).tolist()!r}")
        lam = np.asarray(cfg.dft.lam, dtype=float)
        if lam.ndim != 0 and lam.shape != (n, n):
            raise ValueError(f"dft.lam: expected a scalar or a {n}x{n} matrix, got shape {lam.shape}")
    else:
        _check_transition_size(cfg.bayes_transition, n)
    return cfg, mode_dims, p, x, q, gp, gq


# ----------------------------------------------------------------------------------------------
# Forward projection and features
# ----------------------------------------------------------------------------------------------


def _probe_commands(
    dimensions: tuple[int, ...], speed_translation: float, speed_rotation: float
) -> NDArray[np.float64]:
    dims = np.asarray(dimensions)
    speed = np.where(dims < 3, speed_translation, speed_rotation)
    plus = np.zeros((dims.size, 6))
    plus[np.arange(dims.size), dims] = speed
    return np.stack((plus, -plus))


def _frozen(a: NDArray[np.float64]) -> NDArray[np.float64]:
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class _ProbePlan:
    """The scene-independent part of a forward projection (cached per probe configuration).

    Every probe is ``+/- s e_k`` along one dimension, so a translational probe (``k < 3``) keeps
    the orientation and a rotational one keeps the position. Arrays are read-only.

    Attributes:
        commands: ``(2 n_k, 6)`` probe twists, probe order ``(2, n_k)`` flattened.
        n_rot: Number of rotational probes (``k >= 3``): the last ``n_rot / 2`` columns of the
            probe grid ``(2, n_k)``, since ``dimensions`` is ascending.
        offsets: ``(steps_c + 1, 2 n_k, 3)`` position change after ``s`` steps, ``s v dt`` (m).
        rot_left: ``(4, steps_c, n_rot, 4)``: the orientation of each rotational probe after
            ``s`` steps is ``exp(s w dt) (x) q``; the Hamilton product is linear in its right
            factor, so ``rot_left @ q`` gives all of them (quaternion components first, for
            ``s < steps_c``). Built with ``quat_multiply_unchecked`` on the basis quaternions; one
            matrix-vector product per request.
        displacement: ``(2, n_k)`` displacement along ``k`` between ``t_b`` and ``t_c``: the
            position component ``(s_c - s_b) v_k dt`` (m), or the angle about axis ``k`` of
            ``exp(s_c w dt) (x) exp(s_b w dt)^-1`` (rad). Neither depends on the start pose (the
            start orientation cancels: ``(R_c q) (R_b q)^-1 = R_c R_b^-1``).
    """

    commands: NDArray[np.float64]
    n_rot: int
    offsets: NDArray[np.float64]
    rot_left: NDArray[np.float64]
    displacement: NDArray[np.float64]


@functools.lru_cache(maxsize=64)
def _probe_plan(
    dimensions: tuple[int, ...],
    speed_translation: float,
    speed_rotation: float,
    delta_t: float,
    steps_b: int,
    steps_c: int,
) -> _ProbePlan:
    U = _probe_commands(dimensions, speed_translation, speed_rotation).reshape(-1, 6)  # (P, 6)
    n_probe = U.shape[0]
    steps = np.arange(steps_c + 1, dtype=float)[:, None, None]
    # Pose after s steps of a constant world-frame twist: x + s v dt, exp(s w dt) (x) q.
    offsets = steps * (U[:, :3] * delta_t)  # (nc + 1, P, 3)
    rotational = np.flatnonzero(np.any(U[:, 3:] != 0.0, axis=1))
    rot_quats = quat_from_rotvec_unchecked(steps * (U[rotational, 3:] * delta_t))  # (nc + 1, n_rot, 4)
    dims = np.tile(np.asarray(dimensions), 2)
    disp = np.empty(n_probe)
    trans = dims < 3
    disp[trans] = (offsets[steps_c] - offsets[steps_b])[trans, dims[trans]]
    rot_err = orientation_error_unchecked(rot_quats[steps_b], rot_quats[steps_c])  # (n_rot, 3)
    disp[rotational] = rot_err[np.arange(rotational.size), dims[rotational] - 3]
    return _ProbePlan(
        commands=_frozen(U),
        n_rot=int(rotational.size),
        offsets=_frozen(offsets),
        # [c, s, r, j] = component c of rot_quats[s, r] (x) e_j
        rot_left=_frozen(
            np.ascontiguousarray(
                quat_multiply_unchecked(rot_quats[:steps_c, :, None, :], np.eye(4)).transpose(3, 0, 1, 2)
            )
        ),
        displacement=_frozen(disp.reshape(2, -1)),
    )


def _plan_for(config: DisambiguationConfig) -> _ProbePlan:
    return _probe_plan(
        config.dimensions,
        float(config.probe_speed_translation),
        float(config.probe_speed_rotation),
        float(config.delta_t),
        config.steps_b,
        config.steps_c,
    )


@dataclass(frozen=True)
class Projection:
    """Projected beliefs and displacements, probe axes ``(2, n_k)`` (``+e_k`` first).

    Attributes:
        p_b: Beliefs at ``t_b``, ``(2, n_k, n)``.
        p_c: Beliefs at ``t_c``, ``(2, n_k, n)``.
        displacement: Displacement along ``k`` between ``t_b`` and ``t_c`` (m or rad), ``(2, n_k)``.
    """

    p_b: NDArray[np.float64]
    p_c: NDArray[np.float64]
    displacement: NDArray[np.float64]


def forward_projection(
    belief: NDArray[np.float64],
    position: NDArray[np.float64],
    orientation: NDArray[np.float64],
    goal_positions: NDArray[np.float64],
    goal_orientations: NDArray[np.float64],
    config: DisambiguationConfig,
) -> Projection:
    """Project the belief for every probe at once (inputs already validated; unit quaternions).

    Step ``s`` (``s = 0 .. steps_c - 1``) updates the belief at pose ``s`` with the probe command,
    then moves the pose. The poses do not depend on the belief, so all of them -- and the per-goal
    autonomy commands at them (agreement term) and the belief-independent part of the update (the
    DFT drive or the Bayes likelihood) -- are computed up front in one vectorised call; only the
    recursion of the update runs step by step, over the whole probe batch (for the DFT in one
    compiled loop, :func:`~drake_disamb.core.inference.dft_euler_rollout`, which runs the kernel
    of :func:`~drake_disamb.core.inference.dft_euler_update`). This is exactly
    :func:`~drake_disamb.core.inference.dft_euler_step` /
    :func:`~drake_disamb.core.inference.bayes_step`, which are these two halves composed.

    The scene-independent parts (probe twists, pose offsets, displacements) are cached per probe
    configuration (:class:`_ProbePlan`). Only the rotational probes need autonomy commands, and
    only their rotational part (see the comment in the body).
    """
    plan = _plan_for(config)
    n = belief.size
    U = plan.commands
    n_probe = U.shape[0]
    n_k = n_probe // 2
    dt = config.delta_t
    nb, nc = config.steps_b, config.steps_c
    X = position + plan.offsets[:nc]  # (nc, P, 3): the positions at which each step updates
    # The p-independent half of the inference update (DFT drive or Bayes likelihood) for every
    # step and probe in one call; then the recursion over the probe batch.
    # dft_euler_step = dft_euler_update o dft_drive; bayes_step = posterior_update o bayes_likelihood.
    if config.inference == "dft":
        UA = None
        if config.dft.agreement:
            # Agreement term: u_h[3:6] . u_a_i[3:6] (or their cosine) with u_h the probe. For a probe without
            # rotation u_h[3:6] = 0, so the term is 0 whatever u_a is: its u_a stay zero (no
            # potential field there). For a rotational probe only u_a[3:6] enters (dft_drive
            # reads nothing else), and that rotational part depends on the orientation alone
            # (repellers act on the translational part): it is computed at each step's
            # orientation, u_a[..., :3] left zero.
            UA = np.zeros((nc, 2, n_k, n, 6))  # C order: the rows the drive's kernel reads
            n_t = n_k - plan.n_rot // 2  # rotational dimensions come last (ascending order)
            if plan.n_rot:
                Q = (plan.rot_left @ orientation).transpose(1, 2, 0)  # (nc, n_rot, 4)
                W = potential_field_rotation(Q, goal_orientations, config.potential_field)
                UA[:, :, n_t:, :, 3:] = W.reshape(nc, 2, -1, n, 3)  # n_rot = the (2, n_rot / 2) grid
            UA = UA.reshape(nc, n_probe, n, 6)
        drive = dft_drive(U, X, goal_positions, config.dft, UA)  # (nc, P, n)
    else:
        lik = bayes_likelihood(U, X, goal_positions, config.bayes_sigma)  # (nc, P, n)

    # The recursion over the whole probe batch: the DFT's in one compiled loop over the steps
    # (dft_euler_rollout runs dft_euler_update's kernel), the Bayes update step by step.
    if config.inference == "dft":
        beliefs = dft_euler_rollout(belief, drive, config.dft, dt)  # (nc, P, n)
        p_b, p = beliefs[nb - 1], beliefs[nc - 1]
    else:
        p = belief[None, :].repeat(n_probe, axis=0)  # the start belief of every probe
        transition = config.bayes_transition
        p_b = p
        for s in range(nc):
            p = posterior_update(p, lik[s], transition)
            if s + 1 == nb:
                p_b = p
    return Projection(
        p_b=p_b.reshape(2, -1, n), p_c=p.reshape(2, -1, n), displacement=plan.displacement.copy()
    )


def _pairwise_abs_sum(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_{i<j} |a_i - a_j|`` over the last axis.

    Sorted ascending, entry ``k`` (0-based) is the larger of a pair ``k`` times and the smaller
    ``n - 1 - k`` times, so the sum is ``sum_k (2k - n + 1) a_(k)``: ``O(n log n)`` instead of all
    ``n^2`` pairs (which dominate a request with 50 goals).
    """
    n = a.shape[-1]
    return np.sort(a, axis=-1) @ np.arange(1.0 - n, n, 2.0)


def belief_features(
    p_b: NDArray[np.float64], p_c: NDArray[np.float64], displacement: NDArray[np.float64], divide: bool
) -> dict[str, NDArray[np.float64]]:
    """Gamma, Omega, Lambda (at ``t_b``) and Upsilon (``t_c`` vs ``t_b``), each shape ``(...)``.

    With one goal the second maximum is taken as 0 (so ``Omega = Gamma``; ``Lambda = 0`` anyway).
    With ``divide``, displacements below 1e-12 give a zero gradient instead of a division by zero.
    """
    srt = np.sort(p_b, axis=-1)
    gamma = srt[..., -1]
    second = srt[..., -2] if p_b.shape[-1] > 1 else np.zeros_like(gamma)
    diff = p_c - p_b
    if divide:
        d = np.abs(displacement)[..., None]
        ok = d > _MIN_DISPLACEMENT
        diff = np.where(ok, diff / np.where(ok, d, 1.0), 0.0)
    lam, ups = _pairwise_abs_sum(np.stack((p_b, diff)))  # both spreads in one pass
    return {"gamma": gamma, "omega": gamma - second, "lambda": lam, "upsilon": ups}


def upsilon_divisor(config: DisambiguationConfig, displacement: NDArray[np.float64]) -> NDArray[np.float64]:
    """What ``p(t_c) - p(t_b)`` of each probe is divided by (``config.upsilon_normalization``).

    ``displacement`` is the projection's ``(2, n_k)`` displacement along ``k`` (m or rad). For
    ``"unit_probe"`` every probe gets ``t_c - t_b``: the displacement of the paper's unit-speed
    probe ``e_k`` (1 m/s or 1 rad/s) over that time, one value for every dimension. ``"none"``
    gives ones (the caller does not divide).
    """
    mode = config.upsilon_normalization
    if mode == "displacement":
        return displacement
    if mode == "unit_probe":
        return np.full(np.shape(displacement), config.t_c - config.t_b)
    return np.ones(np.shape(displacement))


def select_mode(
    mode_scores: NDArray[np.float64], current_mode: int | None, tie_tolerance: float
) -> tuple[int | None, int]:
    """Apply the tie rule. Returns ``(mode or None when the current mode is kept, argmax)``.

    Modes within ``tie_tolerance`` (relative) of the best are equally best; the chosen mode is the
    first of them (lowest index) unless the current mode is one of them or all modes are.
    """
    scores = np.asarray(mode_scores, dtype=float).tolist()  # a few numbers: plain Python is faster
    best = max(range(len(scores)), key=scores.__getitem__)  # first of equal maxima, like argmax
    top = scores[best]
    threshold = top - tie_tolerance * abs(top)
    tied = [v >= threshold for v in scores]
    if all(tied):
        return None, best
    if current_mode is not None and 0 <= current_mode < len(scores) and tied[current_mode]:
        return None, best
    return tied.index(True), best  # the first of the equally best modes


# ----------------------------------------------------------------------------------------------
# Entry point
# ----------------------------------------------------------------------------------------------


def disambiguate(
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
    """Run Algorithm 1 and pick the disambiguating control mode.

    Args:
        belief: Current belief ``p(t_a)`` over the ``n`` goals (non-negative, sums to 1).
        position: End-effector position ``(3,)`` (m, world frame), each coordinate within
            ``+/- MAX_POSITION`` (1 km).
        goal_positions: ``(n, 3)`` goal positions (m), same bound, ``1 <= n <= MAX_GOALS`` (100).
        modes: Control modes, each a list of dimension indices (0 = vx ... 5 = wz); the returned
            mode is an index into this list.
        config: Algorithm parameters (default: the ``mico`` preset).
        orientation: End-effector orientation ``[qw, qx, qy, qz]`` (default identity); any
            quaternion whose norm neither vanishes (< 1e-12) nor overflows, normalised here.
        goal_orientations: ``(n, 4)`` goal orientations (default: the end-effector's, i.e. no
            orientation preference between goals).
        current_mode: Index of the mode in use (may be past the end of ``modes``, e.g. the
            gripper mode); kept on ties.

    Returns:
        A :class:`DisambiguationResult`.

    Raises:
        ValueError: An input out of its bounds, naming the argument and the value.
    """
    cfg, mode_dims, p, x, q, gp, gq = _validated_request(
        belief, position, goal_positions, modes, config, orientation, goal_orientations, current_mode
    )

    proj = forward_projection(p, x, q, gp, gq, cfg)
    feats = belief_features(
        proj.p_b, proj.p_c, upsilon_divisor(cfg, proj.displacement), cfg.upsilon_normalization != "none"
    )
    D = (
        cfg.w * feats["gamma"] * feats["lambda"] * feats["omega"] + (1.0 - cfg.w) * feats["upsilon"]
    )  # (2, n_k)
    D_k = D[0] + D[1]
    D_m = _membership(mode_dims, cfg.dimensions) @ D_k
    mode, best = select_mode(D_m, None if current_mode is None else int(current_mode), cfg.tie_tolerance)
    return DisambiguationResult(
        mode=mode,
        best_mode=best,
        dimension=cfg.dimensions[int(np.argmax(D_k))],
        dimensions=cfg.dimensions,
        scores_plus=D[0],
        scores_minus=D[1],
        dimension_scores=D_k,
        mode_scores=D_m,
        features=feats,
        modes=mode_dims,
        current_mode=None if current_mode is None else int(current_mode),
        w=cfg.w,
        tie_tolerance=cfg.tie_tolerance,
    )


# ----------------------------------------------------------------------------------------------
# Alternative mode selection: expected entropy and expected KL divergence (docs/facts.md section 5)
# ----------------------------------------------------------------------------------------------

MODE_SELECTION_METHODS: tuple[str, ...] = ("algorithm1", "entropy", "kl")
"""Mode-selection methods: the paper's Algorithm 1 (:func:`disambiguate`), the expected entropy of
the projected belief (:func:`expected_entropy_mode`) and its expected KL divergence from the
current belief (:func:`expected_kl_mode`)."""

_REALMIN = float(np.finfo(float).tiny)
"""MATLAB's ``realmin``: the authors' guard inside their logarithms."""


def entropy_bits(p: ArrayLike) -> NDArray[np.float64]:
    """Shannon entropy (bits) over the last axis, the authors' ``-sum p log2(p + realmin)``.

    ``[0.5, 0.5]`` has 1 bit, a certain belief 0 bits, the uniform belief over ``n`` goals
    ``log2 n``.
    """
    a = np.asarray(p, dtype=float)
    return -np.sum(a * np.log2(a + _REALMIN), axis=-1)


def kl_bits(p: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """``KL(p || q)`` in bits over the last axis (>= 0, 0 when ``p == q``).

    The authors' ``-sum p log2(q / p + realmin)`` with its guards written so that no entry is a
    NaN: a term with ``p_i = 0`` is 0, and ``q_i`` is read as at least ``realmin`` (so the
    divergence from a belief with an exactly zero entry is large and finite, about 1022 bits per unit of
    ``p_i``, instead of infinite).
    """
    a = np.asarray(p, dtype=float)
    b = np.asarray(q, dtype=float)
    ratio = np.log2(np.maximum(a, _REALMIN)) - np.log2(np.maximum(b, _REALMIN))
    return np.sum(np.where(a > 0, a * ratio, 0.0), axis=-1)


def expected_entropy_mode(
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
    """Pick the mode whose motion is expected to leave the belief most certain (minimum entropy).

    The authors' entropy method (docs/facts.md section 5) on :func:`disambiguate`'s forward projection
    (:func:`forward_projection`, the same probes, inference update and horizons): each probe
    ``+/- s e_k``'s projected belief at ``t_b`` (1 s in both presets, the authors' horizon) has
    entropy ``H_k+/-`` (bits, :func:`entropy_bits`). A mode's expected projected entropy is the
    mean over its probes (2 per probed dimension). The score maximised is the expected **entropy
    reduction** ``H(p(t_a)) - mean H`` (bits), so the mode chosen is the one with the **minimum**
    expected entropy. The authors' code takes the maximum expected entropy, which picks the mode
    that leaves the belief least certain; that reads as a sign slip (the informative choice is the
    one that sharpens the belief), and this function implements the minimum.

    Differences from the authors' code: the probes are the axis probes of Algorithm 1 (``+/- s
    e_k`` per dimension of the mode), not every sign combination of the mode's dimensions at once
    (identical for the one-dimensional modes of the head array; for a joystick mode the corner
    probes are not projected); and a mode none of whose dimensions is probed scores 0 (as if it
    left the belief unchanged).

    Ties and the returned mode as in :func:`disambiguate` (:func:`select_mode`, ``tie_tolerance``
    relative to the best score): a mode that cannot change the belief scores 0; if no mode can,
    every score is 0 and the current mode is kept (``mode = None``). A mode whose motion makes the
    belief less certain scores below 0.

    Args and errors: those of :func:`disambiguate`. Returns a :class:`DisambiguationResult` with
    ``method = "entropy"``: ``scores_plus`` / ``scores_minus`` the per-probe entropy reduction
    (bits), ``dimension_scores`` their mean, ``mode_scores`` the expected entropy reduction per
    mode, ``features = {"entropy": H}`` (``(2, n_k)`` projected entropies, bits).
    """
    return _information_mode(
        "entropy",
        belief,
        position,
        goal_positions,
        modes,
        config,
        orientation,
        goal_orientations,
        current_mode,
    )


def expected_kl_mode(
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
    """Pick the mode whose motion is expected to change the belief most (maximum expected KL).

    The authors' KL method (docs/facts.md section 5) on :func:`disambiguate`'s forward projection (the
    same probes, inference update and horizons): each probe's score is ``KL(p(t_b) || p(t_a))``
    (bits, :func:`kl_bits`) of its projected belief at ``t_b`` (1 s in both presets, the authors'
    horizon) from the current one; a mode's score is the mean over its probes (2 per probed
    dimension), and the mode with the **maximum** expected divergence is chosen, as in the
    authors' code. A mode that cannot change the belief scores 0, the least possible; a mode none
    of whose dimensions is probed also scores 0. Probes and ties as in
    :func:`expected_entropy_mode` (the axis probes of Algorithm 1; :func:`select_mode`).

    Args and errors: those of :func:`disambiguate`. Returns a :class:`DisambiguationResult` with
    ``method = "kl"``: ``scores_plus`` / ``scores_minus`` the per-probe divergence (bits),
    ``dimension_scores`` their mean, ``mode_scores`` the expected divergence per mode, ``features =
    {"kl": ...}`` (the same ``(2, n_k)`` divergences).
    """
    return _information_mode(
        "kl", belief, position, goal_positions, modes, config, orientation, goal_orientations, current_mode
    )


def select_disambiguating_mode(
    method: str,
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
    """Run the mode-selection ``method`` (one of :data:`MODE_SELECTION_METHODS`) on a request.

    ``"algorithm1"``: :func:`disambiguate`; ``"entropy"``: :func:`expected_entropy_mode`; ``"kl"``:
    :func:`expected_kl_mode`. The other arguments are theirs.
    """
    if method not in _METHOD_FUNCTIONS:
        raise ValueError(f"method: expected one of {MODE_SELECTION_METHODS}, got {method!r}")
    return _METHOD_FUNCTIONS[method](
        belief,
        position,
        goal_positions,
        modes,
        config,
        orientation=orientation,
        goal_orientations=goal_orientations,
        current_mode=current_mode,
    )


def _information_mode(
    method: str,
    belief: ArrayLike,
    position: ArrayLike,
    goal_positions: ArrayLike,
    modes: Sequence[Sequence[int]],
    config: DisambiguationConfig | None,
    orientation: ArrayLike | None,
    goal_orientations: ArrayLike | None,
    current_mode: int | None,
) -> DisambiguationResult:
    """The entropy and KL methods: Algorithm 1's projection, an information score per probe."""
    cfg, mode_dims, p, x, q, gp, gq = _validated_request(
        belief, position, goal_positions, modes, config, orientation, goal_orientations, current_mode
    )
    proj = forward_projection(p, x, q, gp, gq, cfg)
    if method == "entropy":
        feature = entropy_bits(proj.p_b)  # (2, n_k)
        per_probe = entropy_bits(p) - feature  # entropy reduction: larger is better
    else:
        feature = kl_bits(proj.p_b, p)
        per_probe = feature
    D_k = 0.5 * (per_probe[0] + per_probe[1])  # the mean over the dimension's two probes
    member = _membership(mode_dims, cfg.dimensions)
    counts = member.sum(axis=1)
    scores = np.divide(member @ D_k, counts, out=np.zeros(len(mode_dims)), where=counts > 0)
    mode, best = select_mode(scores, None if current_mode is None else int(current_mode), cfg.tie_tolerance)
    return DisambiguationResult(
        mode=mode,
        best_mode=best,
        dimension=cfg.dimensions[int(np.argmax(D_k))],
        dimensions=cfg.dimensions,
        scores_plus=per_probe[0],
        scores_minus=per_probe[1],
        dimension_scores=D_k,
        mode_scores=scores,
        features={method: feature},
        modes=mode_dims,
        current_mode=None if current_mode is None else int(current_mode),
        w=cfg.w,
        tie_tolerance=cfg.tie_tolerance,
        method=method,
    )


def _information_explanation(result: DisambiguationResult) -> str:
    """The entropy / KL methods' last line of :meth:`DisambiguationResult.explain`."""
    k = result.dimensions.index(result.dimension)
    name = DIM_NAMES[result.dimension]
    if result.method == "entropy":
        h = result.features["entropy"][:, k]
        return (
            f"Best dimension k* = {name}: moving +{name} / -{name} leaves a projected entropy of "
            f"{h[0]:.4g} / {h[1]:.4g} bits at t_b (mean reduction {result.dimension_scores[k]:.4g} bits)."
        )
    d = result.features["kl"][:, k]
    return (
        f"Best dimension k* = {name}: moving +{name} / -{name} changes the belief by KL = {d[0]:.4g} / "
        f"{d[1]:.4g} bits at t_b."
    )


_METHOD_FUNCTIONS = {
    "algorithm1": disambiguate,
    "entropy": expected_entropy_mode,
    "kl": expected_kl_mode,
}
