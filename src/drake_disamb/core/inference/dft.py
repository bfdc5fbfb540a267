"""Field-theoretic (DFT) intent inference: the input nonlinearity, the drive, the flow and the
authors' Euler step (paper equation dft_ii), and the ``dft`` variant of the inference registry.

Shapes (``...`` is any batch shape, ``n`` the number of goals):

- ``p``: belief, ``(..., n)``, a probability vector.
- ``u_h``: human command, ``(..., d)`` with ``d`` = 3 (``[vx, vy, vz]``, m/s) or 6
  (``[vx, vy, vz, wx, wy, wz]``, m/s and rad/s, world frame). Only the first three entries enter
  the directedness term; entries 3..5 enter the agreement term.
- ``x_r``: end-effector (robot) position, ``(..., 3)``, m.
- ``x_g``: goal positions, ``(..., n, 3)``, m.
- ``u_a``: per-goal autonomy commands, ``(..., n, 6)`` (only needed for the agreement term).
- ``transition``: goal-transition matrix ``P``, ``(n, n)`` or batched ``(..., n, n)``.

The right-hand side is paper equation (dft_ii) with the time constant split in two, as in the
authors' code (docs/facts.md section 1)::

    f(p) = -(1/tau1) P^T p + drive,   drive = rest/tau2 + lambda @ sigma(xi)

with ``sigma(xi) = 1/(1+exp(-xi)) - 0.5``. The ``drive`` does not depend on ``p``: replays compute
it for every sample of every trial in one call (:func:`dft_drive`) and then run the cheap
recursion (:func:`dft_euler_update`). Two integrations are offered:

- :func:`dft_euler_step`: the authors' discretisation (explicit Euler, clip entries <= 0 to the
  smallest positive double, renormalise). Used to replay published data and by the
  disambiguation's forward projection.
- :func:`dft_mass_conserving_rhs`: ``f(p) - p * sum(f(p))``, the first-order equivalent whose
  flow keeps ``sum(p) = 1`` exactly under any explicit Runge-Kutta method. Drake integrates this
  as continuous state.

The hot per-row work (``xi``, the right-hand side and flow, the Euler update) is a numba kernel
of :mod:`drake_disamb.core._kernels` that these array functions call.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._kernels import _dft_flow_rows, _euler_rollout_rows, _euler_rows, _xi_rows
from drake_disamb.core.inference.belief import (
    check_probability_vector,
    check_transition,
    sanitize_command,
    uniform_belief,
)
from drake_disamb.core.inference.methods import INFERENCE_METHODS, ProjectedInference
from drake_disamb.core.rows import as_rows, batch_shape, shared_rows
from drake_disamb.core.validation import is_real

AGREEMENT_MEASURES: tuple[str, ...] = ("dot", "cosine")
"""Forms of the DFT's agreement term (:attr:`DFTParams.agreement_measure`): the paper's plain dot
product of the rotational parts, or their cosine."""


@dataclass(frozen=True)
class DFTParams:
    """Parameters of the field-theoretic update.

    Attributes:
        tau1: Time constant (s) of the goal-transition (decay) term ``-P^T p``.
        tau2: Time constant (s) of the rest-state term.
        lam: Excitation gain (1/s): a scalar (``lam * I``) or an ``n x n`` matrix.
        directedness: Include the directedness term ``(1 + eta_i)/2``.
        agreement: Include the agreement term between the rotational parts of the human command
            and of goal i's autonomy command (0 when either is zero); its form is
            ``agreement_measure``.
        agreement_measure: ``"dot"`` (the paper, equation dft_ii): the plain dot product
            ``u_h^rot . u_a,i^rot`` (rad^2/s^2), at most ``|u_h^rot| |u_a^rot|``, e.g. about 0.08
            for the head array's 0.2 rad/s against an autonomy rotation of 0.4 rad/s, so small
            beside the directedness term's ``[0, 1]``. ``"cosine"``: the cosine of the angle
            between them, in ``[-1, 1]`` whatever the speeds (the rotational counterpart of the
            directedness term).
        proximity: Include the proximity term ``max(0, 1 - |x_g - x_r| / R)``.
        R: Proximity radius (m).
        transition: Goal-transition matrix ``P`` (row-stochastic, ``n x n``, or a batch
            ``(..., n, n)`` for a vectorised replay); ``None`` means I.
        rest: Rest state (task prior, a probability vector); ``None`` means uniform.
        zero_command_excitation: What a zero (or non-finite) command does. True (the paper and
            the authors' code): the directedness of a zero command is 0.5 for every goal, a
            uniform excitation ``lambda sigma(0.5)`` that pulls ``p`` toward *uniform* whatever
            the rest state. False: a zero command adds nothing to ``xi`` (only the proximity term,
            which needs no command, remains), so with the proximity term off ``p`` relaxes to
            the rest state (the task prior) while the user gives no input.
        euler_equivalent_step: ``None`` (default): :func:`dft_mass_conserving_rhs` is the paper's
            continuous flow. A step ``h`` (s): the flow's rate is scaled by
            ``log((1 + h S) / (1 - h / tau1)) / (h D)`` with ``S = sum(f(p))`` (which does not depend
            on a normalised ``p``) and ``D = S + 1 / tau1``, so that integrating it over ``h``
            with the inputs held reproduces the authors' "Euler step of ``h``, then renormalise"
            (exactly for ``P = I``, up to ``O(h^2 / tau1^2)`` otherwise; the kernel is
            ``_kernels._euler_rate_factor``). Use it to compare a continuous-time system with a
            replay at the data's ``delta_t``; the fixed points are unchanged.
    """

    tau1: float = 10.0
    tau2: float = 10.0
    lam: float | NDArray[np.float64] = 200.0
    directedness: bool = True
    agreement: bool = False
    agreement_measure: str = "dot"
    proximity: bool = False
    R: float = 0.2
    transition: NDArray[np.float64] | None = field(default=None, compare=False)
    rest: NDArray[np.float64] | None = field(default=None, compare=False)
    zero_command_excitation: bool = True
    euler_equivalent_step: float | None = None

    def __post_init__(self) -> None:
        for name in ("tau1", "tau2", "R"):
            value = getattr(self, name)
            if not (isinstance(value, int | float | np.floating | np.integer) and np.isfinite(value)):
                raise ValueError(f"DFTParams.{name} must be a finite positive number, got {value!r}")
            if not value > 0:
                raise ValueError(f"DFTParams.{name} must be a finite positive number, got {value!r}")
        if self.agreement_measure not in AGREEMENT_MEASURES:
            raise ValueError(
                f"DFTParams.agreement_measure: expected one of {', '.join(AGREEMENT_MEASURES)}, "
                f"got {self.agreement_measure!r}"
            )
        h = self.euler_equivalent_step
        if h is not None and not (isinstance(h, int | float | np.floating) and np.isfinite(h) and h > 0):
            raise ValueError(
                f"DFTParams.euler_equivalent_step must be None or a finite positive step, got {h!r}"
            )
        lam = np.asarray(self.lam, dtype=float)
        if not np.all(np.isfinite(lam)):
            raise ValueError(f"DFTParams.lam must be finite, got {self.lam!r}")
        if lam.ndim not in (0, 2) or (lam.ndim == 2 and lam.shape[0] != lam.shape[1]):
            raise ValueError(f"DFTParams.lam must be a scalar or a square matrix, got shape {lam.shape}")
        if self.transition is not None:
            check_transition(self.transition, "DFTParams.transition")
        if self.rest is not None:
            check_probability_vector(self.rest, "DFTParams.rest")


_DIRECTEDNESS_ONLY = DFTParams()
_AGREEMENT_ONLY = {
    m: DFTParams(directedness=False, agreement=True, agreement_measure=m) for m in AGREEMENT_MEASURES
}


def directedness(u_h: ArrayLike, x_r: ArrayLike, x_g: ArrayLike) -> NDArray[np.float64]:
    """``(1 + eta_i) / 2`` with ``eta_i`` the cosine between ``u_h[:3]`` and ``x_g_i - x_r``.

    A zero command, or a goal at the robot's position, gives ``eta_i = 0`` (the authors'
    convention: the normalised zero vector is zero), i.e. a directedness of 0.5. Non-finite
    offset components are read as 0 (no direction along them).
    Returns shape ``(..., n)``.
    """
    return dft_xi(u_h, x_r, x_g, _DIRECTEDNESS_ONLY)


def agreement(u_h: ArrayLike, u_a: ArrayLike, measure: str = "dot") -> NDArray[np.float64]:
    """The agreement term between the rotational parts of ``u_h`` and of each goal's autonomy command.

    ``measure`` (:data:`AGREEMENT_MEASURES`): ``"dot"`` the paper's ``u_h^rot . u_a^rot``,
    ``"cosine"`` the cosine of their angle. Zero when the human gives no rotation, when ``u_h``
    has only 3 entries, or when a goal's autonomy command has no rotation. Returns shape
    ``(..., n)``.
    """
    if measure not in _AGREEMENT_ONLY:
        raise ValueError(f"measure: expected one of {', '.join(AGREEMENT_MEASURES)}, got {measure!r}")
    ua = np.asarray(u_a, dtype=float)
    return dft_xi(u_h, np.zeros(3), np.zeros(ua.shape[:-1] + (3,)), _AGREEMENT_ONLY[measure], ua)


def proximity(x_r: ArrayLike, x_g: ArrayLike, R: float) -> NDArray[np.float64]:
    """``max(0, 1 - |x_g_i - x_r| / R)`` (positions only). Returns shape ``(..., n)``.

    Non-finite positions give 0 (no evidence).
    """
    return dft_xi(np.zeros(3), x_r, x_g, DFTParams(directedness=False, proximity=True, R=R))


def dft_xi(
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams,
    u_a: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """The input nonlinearity ``xi`` of equation (dft_ii), shape ``(..., n)``.

    ``xi_i = directedness_i + agreement_i + proximity_i`` (the terms ``params`` switches on; the
    agreement's form is ``params.agreement_measure``), the first two zeroed for a zero command
    unless ``params.zero_command_excitation``.
    """
    x_g = np.asarray(x_g, dtype=float)
    x_r = np.asarray(x_r, dtype=float)
    u = sanitize_command(u_h)
    if (
        x_g.ndim < 2
        or x_g.shape[-1] != 3
        or x_r.ndim < 1
        or x_r.shape[-1] != 3
        or u.ndim < 1
        or u.shape[-1] < 3
    ):
        raise ValueError(
            f"dft_xi: expected x_g (..., n, 3), x_r (..., 3) and u_h (..., d >= 3), got shapes "
            f"{x_g.shape}, {x_r.shape} and {u.shape}"
        )
    n = x_g.shape[-2]
    shapes = [x_r.shape[:-1], x_g.shape[:-2], u.shape[:-1]]
    agree = params.agreement
    if agree:
        if u_a is None:
            raise ValueError("DFTParams.agreement is on but no per-goal autonomy commands u_a given")
        u_a = np.asarray(u_a, dtype=float)
        if u_a.ndim < 2 or u_a.shape[-2:] != (n, 6):
            raise ValueError(f"u_a: expected shape (..., {n}, 6), got {u_a.shape}")
        shapes.append(u_a.shape[:-2])
    batch = batch_shape(*shapes)
    xi = np.empty((math.prod(batch), n))
    _xi_of_rows(
        params,
        as_rows(u, batch, u.shape[-1:]),
        as_rows(x_r, batch, (3,)),
        shared_rows(x_g, batch, (n, 3)),
        as_rows(u_a, batch, (n, 6)) if agree else np.empty((0, n, 6)),
        xi,
    )
    return xi.reshape(*batch, n)


def _xi_of_rows(
    params: DFTParams,
    u: NDArray[np.float64],
    x_r: NDArray[np.float64],
    x_g: NDArray[np.float64],
    u_a: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:
    """The compiled excitation of row-layout arrays into ``out`` (rows, n), with ``params``'s terms."""
    _xi_rows(
        u,
        x_r,
        x_g,
        u_a,
        params.directedness,
        params.agreement,
        params.agreement_measure == "cosine",
        params.proximity,
        params.zero_command_excitation,
        float(params.R),
        out,
    )


def biased_sigmoid(xi: ArrayLike) -> NDArray[np.float64]:
    """``sigma(xi) = 1 / (1 + exp(-xi)) - 0.5``, evaluated as ``tanh(xi / 2) / 2`` (the same
    function, without overflow for a large negative ``xi``: the dot-product agreement term is
    unbounded for huge commands)."""
    return 0.5 * np.tanh(0.5 * np.asarray(xi, dtype=float))


def dft_drive(
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams | DFTRow,
    u_a: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """The part of the DFT right-hand side that does not depend on ``p`` (1/s), shape ``(..., n)``.

    ``drive = rest / tau2 + lambda @ sigma(xi)``. ``params`` may also be a :class:`DFTRow`
    prepared from the parameters: then the arguments are one row, unchecked (:meth:`DFTRow.drive`).
    """
    if type(params) is DFTRow:
        return params.drive(u_h, x_r, x_g, u_a)
    xi = dft_xi(u_h, x_r, x_g, params, u_a)
    rest_term, lam = _drive_terms(params, xi.shape[-1])
    return _drive_from_xi(xi, rest_term, lam)


def _drive_terms(params: DFTParams, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The drive's constant parts for ``n`` goals: ``(rest / tau2, lambda)`` (``lambda`` a 0-d
    array or an ``(n, n)`` matrix)."""
    # DFTParams validated ``rest`` as a probability vector when it was built: only its length is
    # checked here (this runs on every evaluation of the ODE's right-hand side).
    if params.rest is None:
        rest = uniform_belief(n)
    else:
        rest = np.asarray(params.rest, dtype=float)
        if rest.shape[-1] != n:
            raise ValueError(f"rest: expected {n} entries (one per goal), got {rest.shape[-1]}")
    lam = np.asarray(params.lam, dtype=float)
    if lam.ndim == 2 and lam.shape != (n, n):
        raise ValueError(f"DFTParams.lam: expected a scalar or a ({n}, {n}) matrix, got shape {lam.shape}")
    return rest / params.tau2, lam


def _drive_from_xi(
    xi: NDArray[np.float64], rest_term: NDArray[np.float64], lam: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``drive = rest / tau2 + lambda @ sigma(xi)`` from ``xi`` and :func:`_drive_terms`."""
    s = biased_sigmoid(xi)
    excitation = lam * s if lam.ndim == 0 else s @ lam.T
    return rest_term + excitation


def dft_rhs_from_drive(p: ArrayLike, drive: ArrayLike, params: DFTParams) -> NDArray[np.float64]:
    """``f(p) = -(1/tau1) P^T p + drive`` (1/s), with ``drive`` from :func:`dft_drive`."""
    rows = _BeliefRows(p, drive, params)
    out = np.empty_like(rows.p)
    _dft_flow_rows(rows.p, rows.drive, rows.P, params.tau1, False, 0.0, 0.0, out)
    return out.reshape(*rows.batch, rows.n)


def dft_rhs(
    p: ArrayLike,
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams,
    u_a: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Right-hand side ``f(p)`` of the DFT ODE (1/s), shape ``(..., n)``."""
    return dft_rhs_from_drive(p, dft_drive(u_h, x_r, x_g, params, u_a), params)


def dft_mass_conserving_rhs(
    p: ArrayLike,
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams,
    u_a: ArrayLike | None = None,
    guard_time: float = 0.0,
) -> NDArray[np.float64]:
    """``f(p) - p * sum(f(p))``: the DFT flow projected so that ``sum(p)`` is conserved.

    To first order in the step this equals the authors' "Euler step then renormalise". Entries
    that have reached zero are not driven further negative (positivity guard), and the removed
    mass is taken proportionally from the others so the sum is still conserved. With
    ``guard_time`` ``T`` > 0 (s) the guard also keeps a positive entry from falling faster than
    ``p / T``: it decays towards zero with a time constant of at least ``T`` instead of reaching it
    in finite time, so an explicit integration step of up to ``T`` never takes it below zero
    (where the authors clip; the live system passes its control period).
    """
    drive = dft_drive(u_h, x_r, x_g, params, u_a)
    return dft_mass_conserving_rhs_from_drive(p, drive, params, guard_time)


def dft_mass_conserving_rhs_from_drive(
    p: ArrayLike, drive: ArrayLike, params: DFTParams, guard_time: float = 0.0
) -> NDArray[np.float64]:
    """:func:`dft_mass_conserving_rhs` from a precomputed ``drive`` (:func:`dft_drive`).

    The drive does not depend on ``p``: an integrator that evaluates the right-hand side several
    times with the same inputs (e.g. the stages of a Runge-Kutta step) computes it once.
    """
    h, rate = _flow_constants(params, guard_time)
    rows = _BeliefRows(p, drive, params)
    out = np.empty_like(rows.p)
    _dft_flow_rows(rows.p, rows.drive, rows.P, params.tau1, True, h, rate, out)
    return out.reshape(*rows.batch, rows.n)


def _flow_constants(params: DFTParams, guard_time: float) -> tuple[float, float]:
    """The mass-conserving flow kernel's ``(euler_equivalent_step or 0, 1 / guard_time or 0)``,
    ``guard_time`` checked."""
    if not (is_real(guard_time) and guard_time >= 0):
        raise ValueError(f"guard_time: expected a finite number >= 0 (s), got {guard_time!r}")
    h = params.euler_equivalent_step
    return 0.0 if h is None else float(h), 1.0 / guard_time if guard_time > 0 else 0.0


class DFTRow:
    """:func:`dft_drive` and :func:`dft_mass_conserving_rhs_from_drive` for one belief, with what
    they derive from ``params`` prepared once: a control loop's hot path (one command per tick, where
    the array functions' broadcasting, layout and checks cost several times the compiled kernels).

    The same kernels and the same arithmetic as those functions, so the same numbers. ``params``
    and ``guard_time`` are checked here, once; the arrays passed to :meth:`drive` and
    :meth:`mass_conserving_rhs` are not (the caller's business, e.g. a Drake port fixes shapes):
    float64 arrays of the documented shapes, the command finite (:func:`sanitize_command`).

    Args:
        params: DFT parameters; ``rest`` (if given), ``lam`` (if a matrix) and ``transition``
            (if given) must have ``n_goals`` entries per axis.
        n_goals: Number of goals n.
        guard_time: As for :func:`dft_mass_conserving_rhs` (s).
    """

    __slots__ = ("_P", "_h", "_lam", "_no_u_a", "_rate", "_rest_term", "n", "params")

    def __init__(self, params: DFTParams, n_goals: int, guard_time: float = 0.0) -> None:
        if not isinstance(params, DFTParams):
            raise ValueError(f"params: expected DFTParams, got {params!r}")
        if not (isinstance(n_goals, int | np.integer) and not isinstance(n_goals, bool) and n_goals >= 1):
            raise ValueError(f"n_goals: expected an integer >= 1, got {n_goals!r}")
        self._h, self._rate = _flow_constants(params, guard_time)
        n = int(n_goals)
        self.params, self.n = params, n
        self._rest_term, self._lam = _drive_terms(params, n)
        P = params.transition
        if P is None:
            self._P = np.empty((0, n, n))
        else:
            P = np.asarray(P, dtype=float)
            if P.shape != (n, n):
                raise ValueError(f"DFTParams.transition: expected a ({n}, {n}) matrix, got shape {P.shape}")
            self._P = np.ascontiguousarray(P[None])
        self._no_u_a = np.empty((0, n, 6))

    def drive(
        self,
        u_h: NDArray[np.float64],
        x_r: NDArray[np.float64],
        x_g: NDArray[np.float64],
        u_a: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        """:func:`dft_drive` of a finite command ``u_h`` (d >= 3), the position ``x_r`` (3), the
        goal positions ``x_g`` (n, 3) and, with ``params.agreement``, ``u_a`` (n, 6); ``(n,)``."""
        params, n = self.params, self.n
        agree = params.agreement
        if agree and u_a is None:
            raise ValueError("DFTParams.agreement is on but no per-goal autonomy commands u_a given")
        xi = np.empty((1, n))
        _xi_of_rows(
            params,
            np.ascontiguousarray(u_h).reshape(1, -1),
            np.ascontiguousarray(x_r).reshape(1, 3),
            np.ascontiguousarray(x_g).reshape(1, n, 3),
            np.ascontiguousarray(u_a).reshape(1, n, 6) if agree else self._no_u_a,
            xi,
        )
        return _drive_from_xi(xi.reshape(n), self._rest_term, self._lam)

    def mass_conserving_rhs(self, p: NDArray[np.float64], drive: NDArray[np.float64]) -> NDArray[np.float64]:
        """:func:`dft_mass_conserving_rhs_from_drive` of the belief ``p`` (n) and ``drive`` (n)."""
        n = self.n
        out = np.empty((1, n))
        _dft_flow_rows(
            np.ascontiguousarray(p).reshape(1, n),
            np.ascontiguousarray(drive).reshape(1, n),
            self._P,
            self.params.tau1,
            True,
            self._h,
            self._rate,
            out,
        )
        return out.reshape(n)


def dft_euler_update(p: ArrayLike, drive: ArrayLike, params: DFTParams, dt: ArrayLike) -> NDArray[np.float64]:
    """The authors' step from a precomputed drive: ``normalize(p + dt * (-(1/tau1) P^T p + drive))``.

    ``p`` and ``drive`` are ``(..., n)`` and broadcast; ``dt`` (s) is a scalar or has shape
    ``(..., 1)`` (one step per batch entry, e.g. ``(batch, 1)``); ``params.transition`` is
    ``None``, one ``(n, n)`` matrix or a batch ``(..., n, n)``.
    """
    rows = _BeliefRows(p, drive, params, dt)
    out = np.empty_like(rows.p)
    _euler_rows(rows.p, 0, rows.drive, 0, rows.P, params.tau1, rows.dt, out, 0, out.shape[0])
    return out.reshape(*rows.batch, rows.n)


def dft_euler_rollout(
    p: ArrayLike, drives: ArrayLike, params: DFTParams, dt: ArrayLike
) -> NDArray[np.float64]:
    """The beliefs after each of ``K`` successive :func:`dft_euler_update` steps.

    ``drives`` is ``(K, ..., n)`` (step ``s`` uses ``drives[s]``); ``p``, ``dt`` and the
    transition matrix broadcast against one step as in :func:`dft_euler_update`. Returns
    ``(K, ..., n)``: entry ``s`` is the belief after update ``s``. The steps run in one compiled
    loop (the same kernel as :func:`dft_euler_update`), not one call per step.
    """
    rows = _BeliefRows(p, drives, params, dt, rollout=True)
    out = np.empty_like(rows.drive)
    _euler_rollout_rows(rows.p, rows.drive, rows.P, params.tau1, rows.dt, out)
    return out.reshape(rows.steps, *rows.batch, rows.n)


class _BeliefRows:
    """The operands of the DFT kernels (right-hand side, flow, Euler update and rollout), broadcast
    to one batch and flattened to C-ordered rows.

    ``p``: ``(B, n)``; ``drive``: ``(B, n)``, or ``(K B, n)`` for a rollout (step-major);
    ``P``: ``(B, n, n)``, ``(1, n, n)`` (one matrix for all rows) or ``(0, n, n)`` (identity);
    ``dt``: ``(B,)`` or ``(1,)``; ``batch`` the broadcast batch shape; ``steps`` the rollout's
    ``K`` (1 otherwise).
    """

    __slots__ = ("P", "batch", "drive", "dt", "n", "p", "steps")

    def __init__(
        self, p: ArrayLike, drive: ArrayLike, params: DFTParams, dt: ArrayLike = 0.0, rollout: bool = False
    ):
        p = np.asarray(p, dtype=float)
        drive = np.asarray(drive, dtype=float)
        lead = drive.shape[:1] if rollout else ()  # the rollout's step axis
        if drive.ndim < 1 + len(lead) or p.ndim < 1 or lead == (0,):
            expected = "(K, ..., n) with K >= 1" if rollout else "(..., n)"
            raise ValueError(f"drive: expected shape {expected}, got {drive.shape}")
        n = p.shape[-1]
        if drive.shape[-1] != n:
            raise ValueError(
                f"drive: expected {n} entries per row (one per goal, as p), got shape {drive.shape}"
            )
        dt = np.asarray(dt, dtype=float)
        if dt.ndim and dt.shape[-1] != 1:
            raise ValueError(f"dt: expected a scalar or shape (..., 1), got shape {dt.shape}")
        P = params.transition
        if P is not None:
            P = np.asarray(P, dtype=float)
            if P.shape[-2:] != (n, n):
                raise ValueError(f"DFTParams.transition: expected ({n}, {n}) matrices, got shape {P.shape}")
        batch = batch_shape(
            p.shape[:-1], drive.shape[len(lead) : -1], dt.shape[:-1], () if P is None else P.shape[:-2]
        )
        self.batch, self.n, self.steps = batch, n, lead[0] if rollout else 1
        self.p = as_rows(p, batch, (n,))
        self.drive = as_rows(drive, (*lead, *batch), (n,))
        self.P = np.empty((0, n, n)) if P is None else shared_rows(P, batch, (n, n))
        self.dt = dt.reshape(1) if dt.ndim == 0 else as_rows(dt, batch, (1,)).reshape(-1)


def dft_euler_step(
    p: ArrayLike,
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams,
    dt: float,
    u_a: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """One step of the authors' discretisation: ``normalize(p + dt * f(p))``."""
    return dft_euler_update(p, dft_drive(u_h, x_r, x_g, params, u_a), params, dt)


@INFERENCE_METHODS.register
@dataclass(frozen=True)
class DFTInference(ProjectedInference):
    """Field-theoretic inference (the paper's): live, the continuous flow
    :func:`dft_mass_conserving_rhs`; projected, the authors' Euler step :func:`dft_euler_step`
    (drive :func:`dft_drive`, recursion :func:`dft_euler_rollout`).

    Attributes:
        params: The DFT parameters (transition matrix and rest state included).
    """

    name: ClassVar[str] = "dft"
    label: ClassVar[str] = "field-theoretic"
    continuous: ClassVar[bool] = True
    replay_padding: ClassVar[float] = -np.inf
    params: DFTParams = field(default_factory=DFTParams)

    def __post_init__(self) -> None:
        if not isinstance(self.params, DFTParams):
            raise ValueError(f"DFTInference.params: expected DFTParams, got {self.params!r}")

    @classmethod
    def from_settings(cls, dft: DFTParams) -> DFTInference:
        return cls(dft)

    @property
    def transition(self) -> NDArray[np.float64] | None:  # type: ignore[override]
        return self.params.transition

    @property
    def needs_autonomy(self) -> bool:
        return bool(self.params.agreement)

    def evidence(
        self, u_h: ArrayLike, x_r: ArrayLike, x_g: ArrayLike, u_a: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        return dft_drive(u_h, x_r, x_g, self.params, u_a)

    def rollout(self, p: ArrayLike, evidence: ArrayLike, dt: float) -> NDArray[np.float64]:
        return dft_euler_rollout(p, evidence, self.params, dt)

    def replayer(
        self, transition: NDArray[np.float64], dt: NDArray[np.float64]
    ) -> Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]:
        """The authors' Euler step (:func:`dft_euler_update`) of the first ``len(p)`` rows, with
        their transition matrices and steps (the parameters built once per batch size)."""
        params_by_rows: dict[int, DFTParams] = {}

        def step(p: NDArray[np.float64], drive: NDArray[np.float64]) -> NDArray[np.float64]:
            b = len(p)
            if b not in params_by_rows:
                params_by_rows[b] = dataclasses.replace(self.params, transition=transition[:b])
            return dft_euler_update(p, drive, params_by_rows[b], dt[:b])

        return step

    def with_transition(self, transition: ArrayLike | None) -> DFTInference:
        P = None if transition is None else np.asarray(transition, dtype=float)
        return DFTInference(dataclasses.replace(self.params, transition=P))

    def check_goal_count(self, n: int) -> None:
        P = self.params.transition
        if P is not None and np.shape(P) != (n, n):
            raise ValueError(
                f"transition: expected a {n}x{n} matrix (one row per goal), got shape {np.shape(P)}"
            )
        if self.params.rest is not None and np.shape(self.params.rest) != (n,):
            raise ValueError(f"dft.rest: expected {n} entries, got {np.asarray(self.params.rest).tolist()!r}")
        lam = np.asarray(self.params.lam, dtype=float)
        if lam.ndim != 0 and lam.shape != (n, n):
            raise ValueError(f"dft.lam: expected a scalar or a {n}x{n} matrix, got shape {lam.shape}")
