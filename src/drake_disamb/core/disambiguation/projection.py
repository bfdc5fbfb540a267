"""The forward projection every mode-selection method scores (paper Algorithm 1's first half).

For every probed control dimension ``k`` and both directions, the belief is projected forward
from the current time ``t_a`` under a constant probe command ``+/- s e_k`` (m/s or rad/s, world
frame): each step of length ``delta_t`` first updates the belief with the configured inference
method's step at the current pose, then moves a kinematic point robot (position and orientation)
by the probe. The update is the live inference's (the scenario's resolver passes the same method
and parameters to both) and it is that method's own code
(:meth:`~drake_disamb.core.inference.ProjectedInference.evidence` and
:meth:`~drake_disamb.core.inference.ProjectedInference.rollout`), though not bit for bit the live
computation: the projection takes the method's discrete step of ``delta_t`` (0.1 s for ``mico``;
the DFT's is the authors' Euler step), while the live DFT belief is the continuous flow the
simulator integrates at the control period. All ``2 n_k`` probes run together as one batch
(leading probe axis), never one after another.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.autonomy import potential_field_rotation
from drake_disamb.core.disambiguation.config import DisambiguationConfig
from drake_disamb.core.disambiguation.request import DisambiguationRequest, frozen
from drake_disamb.core.geometry import (
    orientation_error_unchecked,
    quat_from_rotvec_unchecked,
    quat_multiply_unchecked,
)


def _probe_commands(
    dimensions: tuple[int, ...], speed_translation: float, speed_rotation: float
) -> NDArray[np.float64]:
    dims = np.asarray(dimensions)
    speed = np.where(dims < 3, speed_translation, speed_rotation)
    plus = np.zeros((dims.size, 6))
    plus[np.arange(dims.size), dims] = speed
    return np.stack((plus, -plus))


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
        commands=frozen(U),
        n_rot=int(rotational.size),
        offsets=frozen(offsets),
        # [c, s, r, j] = component c of rot_quats[s, r] (x) e_j
        rot_left=frozen(
            np.ascontiguousarray(
                quat_multiply_unchecked(rot_quats[:steps_c, :, None, :], np.eye(4)).transpose(3, 0, 1, 2)
            )
        ),
        displacement=frozen(disp.reshape(2, -1)),
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


def forward_projection(request: DisambiguationRequest) -> Projection:
    """Project the request's belief for every probe at once.

    Step ``s`` (``s = 0 .. steps_c - 1``) updates the belief at pose ``s`` with the probe command,
    then moves the pose. The poses do not depend on the belief, so all of them -- and the per-goal
    autonomy commands at them (agreement term) and the belief-independent part of the update (the
    DFT drive or the Bayes likelihood) -- are computed up front in one vectorised call; only the
    recursion of the update runs step by step, over the whole probe batch (the method's
    :meth:`~drake_disamb.core.inference.ProjectedInference.rollout`; for the DFT one compiled loop,
    :func:`~drake_disamb.core.inference.dft_euler_rollout`). The two halves composed are exactly the
    method's step (:func:`~drake_disamb.core.inference.dft_euler_step`,
    :func:`~drake_disamb.core.inference.bayes_step`).

    The scene-independent parts (probe twists, pose offsets, displacements) are cached per probe
    configuration (:class:`_ProbePlan`). Only the rotational probes need autonomy commands, and
    only their rotational part (see the comment in the body).
    """
    config = request.config
    method = config.inference
    belief, position, orientation = request.belief, request.position, request.orientation
    goal_positions, goal_orientations = request.goal_positions, request.goal_orientations
    plan = _plan_for(config)
    n = belief.size
    U = plan.commands
    n_probe = U.shape[0]
    n_k = n_probe // 2
    nb, nc = config.steps_b, config.steps_c
    X = position + plan.offsets[:nc]  # (nc, P, 3): the positions at which each step updates
    UA = None
    if method.needs_autonomy:
        # The DFT's agreement term: u_h[3:6] . u_a_i[3:6] (or their cosine) with u_h the probe. For
        # a probe without rotation u_h[3:6] = 0, so the term is 0 whatever u_a is: its u_a stay
        # zero (no potential field there). For a rotational probe only u_a[3:6] enters (the drive
        # reads nothing else), and that rotational part depends on the orientation alone
        # (repellers act on the translational part): it is computed at each step's orientation,
        # u_a[..., :3] left zero.
        UA = np.zeros((nc, 2, n_k, n, 6))  # C order: the rows the drive's kernel reads
        n_t = n_k - plan.n_rot // 2  # rotational dimensions come last (ascending order)
        if plan.n_rot:
            Q = (plan.rot_left @ orientation).transpose(1, 2, 0)  # (nc, n_rot, 4)
            W = potential_field_rotation(Q, goal_orientations, config.potential_field)
            UA[:, :, n_t:, :, 3:] = W.reshape(nc, 2, -1, n, 3)  # n_rot = the (2, n_rot / 2) grid
        UA = UA.reshape(nc, n_probe, n, 6)
    # The p-independent half of the update (the DFT drive, the Bayes likelihood) for every step and
    # probe in one call, then the recursion over the whole probe batch (for the DFT one compiled
    # loop over the steps).
    evidence = method.evidence(U, X, goal_positions, UA)  # (nc, P, n)
    beliefs = method.rollout(belief, evidence, config.delta_t)  # (nc, P, n)
    p_b, p_c = beliefs[nb - 1], beliefs[nc - 1]
    return Projection(
        p_b=p_b.reshape(2, -1, n), p_c=p_c.reshape(2, -1, n), displacement=plan.displacement.copy()
    )
