"""Load every compiled kernel of the core before a control loop starts.

The core's kernels (numba, ``cache=True``) are compiled on first use, or loaded from numba's
on-disk cache; the first load in a process also initialises numba's code generator, which imports
part of numpy and scipy. Both happen inside the control tick that first calls a kernel: about
0.5-0.8 s for the first one, a few ms for each later one. In a simulation that is only wall time;
on a wire it is a stall in which the arm gets no command (its driver stops it) and statuses go
unanswered. :func:`warm_up` calls the core's array functions once on small inputs of the types a
control tick passes them (float64, C-ordered), so every kernel a trial uses is ready before the
loop's first tick. A station on a wire calls it while it waits for the arm's first status.
"""

from __future__ import annotations

import numpy as np

from drake_disamb.core.autonomy import (
    PotentialFieldConfig,
    potential_field_commands,
    potential_field_commands_from_poses,
)
from drake_disamb.core.blending import BlendingConfig, blending_alpha, clamp_speed, has_input, shared_control
from drake_disamb.core.geometry import (
    orientation_error,
    pose_errors,
    poses_usable,
    quat_from_rotvec,
    quat_multiply,
    quat_to_rotvec,
)
from drake_disamb.core.inference.belief import normalize_belief
from drake_disamb.core.inference.dft import (
    DFTParams,
    dft_euler_rollout,
    dft_euler_step,
    dft_mass_conserving_rhs,
    dft_xi,
)
from drake_disamb.core.validation import all_finite

_DONE = False


def warm_up() -> None:
    """Compile (or load from numba's cache) the kernels a control tick uses. Idempotent and
    cheap after the first call in a process (about 1 s on the first, once per process)."""
    global _DONE
    if _DONE:
        return
    ee = np.array([0.3, -0.2, 0.3, 1.0, 0.0, 0.0, 0.0])
    goals = np.array([[0.5, 0.1, 0.2, 1.0, 0.0, 0.0, 0.0], [0.4, 0.3, 0.25, 0.0, 1.0, 0.0, 0.0]])
    u_h = np.array([0.05, 0.0, 0.0, 0.0, 0.0, 0.1])
    p = np.array([0.6, 0.4])
    read_only = ee.copy()  # a Drake port's value reaches the checks as a read-only array
    read_only.flags.writeable = False
    for pose in (ee, read_only):
        all_finite(pose, goals)
        poses_usable(pose, 1e6, 1e-12)
    pose_errors(ee, goals)
    orientation_error(ee[3:], goals[:, 3:])
    quat_to_rotvec(quat_multiply(ee[3:], quat_from_rotvec(u_h[3:])))
    field = PotentialFieldConfig()
    u_a = potential_field_commands_from_poses(ee, goals, field)
    potential_field_commands_from_poses(ee, goals, field, checked=False)
    potential_field_commands(ee[:3], ee[3:], goals[:, :3], goals[:, 3:], field)
    params = DFTParams()
    dft_xi(u_h, ee[:3], goals[:, :3], params, u_a)
    dft_mass_conserving_rhs(p, u_h, ee[:3], goals[:, :3], params, u_a)
    dft_euler_step(p, u_h, ee[:3], goals[:, :3], params, 0.1, u_a)
    normalize_belief(p)
    drives = np.tile(p, (3, 1))
    dft_euler_rollout(p, drives, params, 0.1)
    blending_alpha(0.7, 2)
    has_input(u_h)
    clamp_speed(u_h, 0.2, 0.5)
    shared_control(u_h, p, u_a, BlendingConfig())
    _DONE = True


__all__ = ["warm_up"]
