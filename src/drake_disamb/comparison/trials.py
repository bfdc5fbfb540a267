"""Simulated teleoperation trials of the paper's inference comparison: the record and its generator.

A trial (:class:`Trial`) is a simulated point robot in R^3 teleoperated toward one of 2-5 goals by a
noisy simulated human (paper Section "Field-Theoretic Intent Inference For Assistive Robotics"; the
protocol and the authors' fields are in docs/facts.md section 3). :func:`generate_trials` draws new
trials with the authors' protocol (seeded), so the comparison runs without any external data. It
draws them in chunks of :data:`GENERATOR_CHUNK`, each from its own seed, so trial ``i`` depends
only on the seed and ``i``; :func:`iter_generated_chunks` yields the chunks one at a time. The
authors' published trials are read by :mod:`drake_disamb.comparison.trial_files`, and
:mod:`drake_disamb.comparison.replay` replays and scores them.

Conventions: arrays are time-major (``(L + 1, 3)`` positions, ``(L, 3)`` commands; command ``j``
moves the robot from sample ``j`` to sample ``j + 1``), goal indices are 0-based, and the zeroed
stretch is the half-open sample range ``[zeroed_start, zeroed_stop)``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.sampling import sample_von_mises_fisher

WORKSPACE = np.array([[-0.5, 0.5], [-0.5, 0.5], [-0.5, 0.5]])
"""Workspace of the simulated point robot (m), rows x, y, z."""


@dataclass
class Trial:
    """One simulated teleoperation trial (the authors' fields, docs/facts.md section 3).

    Attributes:
        goals: ``xg`` transposed, goal positions ``(n, 3)`` (m).
        transition: ``goal_transition_P``, ``(n, n)``, row-stochastic.
        dt: ``delta_t`` (s).
        traj: ``traj_zeroed`` transposed, robot positions ``(L + 1, 3)`` (m): the comparison's input.
        u_h: ``uh_history_zeroed`` transposed, commands ``(L, 3)`` (m/s); row ``j`` moves the robot
            from ``traj[j]`` to ``traj[j + 1]``.
        true_goal: ``true_goal_index_history - 1``, the 0-based true goal per sample, ``(L + 1,)``.
        zeroed_start: ``min_ind - 1``: first sample of the zeroed stretch (0-based).
        zeroed_stop: ``max_ind``: one past its last sample (so the stretch is ``[start, stop)``).
        x_start: ``xr_start``, the start position ``(3,)`` (m).
        traj_raw: ``traj``, the positions before the stretch was zeroed ``(L + 1, 3)``, if known.
        u_h_raw: ``uh_history``, the commands before zeroing ``(L, 3)``, if known.
        source: Where the trial came from (file path or generator seed and index).
    """

    goals: NDArray[np.float64]
    transition: NDArray[np.float64]
    dt: float
    traj: NDArray[np.float64]
    u_h: NDArray[np.float64]
    true_goal: NDArray[np.int64]
    zeroed_start: int
    zeroed_stop: int
    x_start: NDArray[np.float64]
    traj_raw: NDArray[np.float64] | None = field(default=None, repr=False)
    u_h_raw: NDArray[np.float64] | None = field(default=None, repr=False)
    source: str = ""

    @property
    def n_goals(self) -> int:
        """``ng``, the number of goals."""
        return int(self.goals.shape[0])

    @property
    def n_steps(self) -> int:
        """``L``, the number of commands (the trial has ``L + 1`` samples)."""
        return int(self.u_h.shape[0])

    def zeroed_mask(self) -> NDArray[np.bool_]:
        """``(L + 1,)`` booleans, True inside the zeroed stretch."""
        mask = np.zeros(self.n_steps + 1, dtype=bool)
        mask[self.zeroed_start : self.zeroed_stop] = True
        return mask


@dataclass(frozen=True)
class GeneratorConfig:
    """The authors' trial protocol (docs/facts.md section 3); every field may be changed.

    Attributes:
        min_goals, max_goals: The goal count is uniform in ``[min_goals, max_goals]``.
        workspace: ``(3, 2)`` per-axis ``[low, high]`` (m) for goals and start position.
        dt: Time step (s).
        speed: Command magnitude (m/s).
        kappa: von Mises-Fisher concentration of the command direction.
        position_noise: Standard deviation (m) of the per-axis kinematic noise per step.
        max_dropout: The per-step dropout rate (whole command zeroed) is ``U(0, max_dropout)``
            per trial.
        component_dropout: Per-step chance of zeroing one random component.
        max_switch_interval: A goal switch is sampled from ``P`` every ``U{1..this}`` steps.
        transition_noise: ``P = row_normalise(I + U(0, 1) * transition_noise)``.
        goal_tolerance: The trial ends when the robot is closer than this to its goal (m).
        max_zeroed: The zeroed stretch lasts ``1 + U{1..max_zeroed}`` samples at most.
        max_steps: Safety cap on the trial length (steps); a trial that reaches it ends there.
    """

    min_goals: int = 2
    max_goals: int = 5
    workspace: tuple[tuple[float, float], ...] = ((-0.5, 0.5), (-0.5, 0.5), (-0.5, 0.5))
    dt: float = 0.002
    speed: float = 1.0
    kappa: float = 2e5
    position_noise: float = 0.005
    max_dropout: float = 1.0 / 8.0
    component_dropout: float = 0.01
    max_switch_interval: int = 5
    transition_noise: float = 0.01
    goal_tolerance: float = 0.01
    max_zeroed: int = 200
    max_steps: int = 20000

    def __post_init__(self) -> None:
        if not (isinstance(self.min_goals, int) and 1 <= self.min_goals <= self.max_goals):
            raise ValueError(
                f"GeneratorConfig.min_goals/max_goals: expected 1 <= min <= max, "
                f"got {self.min_goals!r}/{self.max_goals!r}"
            )
        ws = np.asarray(self.workspace, dtype=float)
        if ws.shape != (3, 2) or not np.all(np.isfinite(ws)) or np.any(ws[:, 1] <= ws[:, 0]):
            raise ValueError(
                f"GeneratorConfig.workspace: expected 3 [low, high] pairs, got {self.workspace!r}"
            )
        for name in ("dt", "speed", "kappa", "goal_tolerance"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"GeneratorConfig.{name}: expected a finite positive number, got {value!r}")
        for name in ("position_noise", "max_dropout", "component_dropout", "transition_noise"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"GeneratorConfig.{name}: expected a finite number >= 0, got {value!r}")
        for name in ("max_switch_interval", "max_zeroed", "max_steps"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"GeneratorConfig.{name}: expected a positive integer, got {value!r}")


GENERATOR_CHUNK = 500
"""Trials per generator chunk. Chunk ``k`` (trials ``500 k .. 500 k + 499``) is always drawn whole
from its own seed (:func:`chunk_seed`), so trial ``i`` depends only on the seed and ``i``, never on
how many trials are asked for, and a stream of chunks gives the same trials as one list."""


def chunk_seed(seed: int, chunk: int) -> np.random.SeedSequence:
    """The seed of generator chunk ``chunk``: ``SeedSequence(seed)`` for chunk 0 (so the first 500
    trials are those the generator drew from ``default_rng(seed)`` before it was chunked), else its
    child ``SeedSequence(seed).spawn(chunk + 1)[chunk]``."""
    if not (isinstance(chunk, int | np.integer) and chunk >= 0):
        raise ValueError(f"chunk: expected an integer >= 0, got {chunk!r}")
    try:
        return np.random.SeedSequence(seed, spawn_key=(int(chunk),) if chunk else ())
    except (TypeError, ValueError) as exc:
        raise ValueError(f"seed: expected an integer >= 0, got {seed!r} ({exc})") from None


def generate_trials(
    n_trials: int, seed: int, config: GeneratorConfig | None = None, progress: bool = False
) -> list[Trial]:
    """Draw ``n_trials`` new trials with the authors' protocol, seeded (docs/facts.md section 3).

    The trials are the first ``n_trials`` of the seed's sequence: chunk ``k`` of
    :data:`GENERATOR_CHUNK` trials is drawn whole by :func:`generate_chunk` from
    :func:`chunk_seed(seed, k) <chunk_seed>` (see :func:`iter_generated_chunks`, which yields the
    same trials a chunk at a time). The same seed gives the same trials.
    """
    return [tr for chunk in iter_generated_chunks(n_trials, seed, config, progress) for tr in chunk]


def iter_generated_chunks(
    n_trials: int, seed: int, config: GeneratorConfig | None = None, progress: bool = False
) -> Iterator[list[Trial]]:
    """The first ``n_trials`` trials of ``seed`` as lists of at most :data:`GENERATOR_CHUNK`.

    Only one chunk is alive at a time inside the generator (a consumer that drops each chunk
    before asking for the next keeps memory flat in ``n_trials``). The last chunk is drawn whole
    and cut, so trial ``i`` does not depend on ``n_trials``. With more than one chunk, ``progress``
    shows one bar over all trials instead of the per-chunk bars.
    """
    from tqdm import tqdm

    if not (isinstance(n_trials, int | np.integer) and n_trials >= 1):
        raise ValueError(f"n_trials: expected a positive integer, got {n_trials!r}")
    n_trials = int(n_trials)
    cfg = GeneratorConfig() if config is None else config
    n_chunks = math.ceil(n_trials / GENERATOR_CHUNK)
    chunk_seed(seed, 0)  # a bad seed fails before any work
    overall = progress and n_chunks > 1
    with tqdm(total=n_trials, desc="generating", unit="trial", disable=not overall) as bar:
        for k in range(n_chunks):
            first = k * GENERATOR_CHUNK
            rng = np.random.default_rng(chunk_seed(seed, k))
            chunk = generate_chunk(GENERATOR_CHUNK, rng, cfg, progress and n_chunks == 1, seed, first)
            del chunk[n_trials - first :]
            bar.update(len(chunk))
            yield chunk
            del chunk  # not held while the next chunk is drawn


def generate_chunk(
    n_trials: int,
    rng: np.random.Generator,
    config: GeneratorConfig | None = None,
    progress: bool = False,
    seed: int | None = None,
    first_index: int = 0,
) -> list[Trial]:
    """Draw ``n_trials`` trials from ``rng`` with the authors' protocol (the generator's unit of work).

    ``seed`` and ``first_index`` only label the trials' ``source``. All trials are simulated in
    lock-step (one numpy pass per time step over the trials still running). Per trial: 2-5 goals
    and a start position uniform in the workspace, ``P`` = row-normalised ``I + U(0,1)/100``, a
    per-trial dropout rate ``U(0, 1/8)``. Per step: every 1-5 steps the current goal is re-drawn
    from its row of ``P``; the command is a unit vector from a von Mises-Fisher distribution
    (kappa = 2e5) around the direction to the goal, times 1 m/s, zeroed with the dropout rate,
    with one random component zeroed with 1 % chance; the robot moves by ``u dt + N(0, 0.005^2)``
    per axis; the trial ends within 0.01 m of the goal. Afterwards a stretch of up to 201 samples
    starting in the first half of the trial is zeroed and the robot path re-simulated from the
    start with fresh noise (``traj_zeroed``), exactly the structure of the published files. The
    same ``rng`` state gives the same trials.
    """
    from tqdm import tqdm

    if not (isinstance(n_trials, int | np.integer) and n_trials >= 1):
        raise ValueError(f"n_trials: expected a positive integer, got {n_trials!r}")
    cfg = GeneratorConfig() if config is None else config
    B, nmax = int(n_trials), cfg.max_goals
    ws = np.asarray(cfg.workspace, dtype=float)
    lo, span = ws[:, 0], ws[:, 1] - ws[:, 0]

    n_goals = rng.integers(cfg.min_goals, cfg.max_goals + 1, size=B)
    valid = np.arange(nmax)[None, :] < n_goals[:, None]
    goals = lo + span * rng.random((B, nmax, 3))
    x = lo + span * rng.random((B, 3))
    x_start = x.copy()
    P = np.eye(nmax) + rng.random((B, nmax, nmax)) * cfg.transition_noise
    P = np.where(valid[:, None, :] & valid[:, :, None], P, 0.0)
    P[~valid] = np.eye(nmax)[np.nonzero(~valid)[1]]  # unused rows of padded goals
    P /= P.sum(axis=-1, keepdims=True)
    dropout = rng.random(B) * cfg.max_dropout
    goal = np.floor(rng.random(B) * n_goals).astype(np.int64)
    marker = rng.integers(1, cfg.max_switch_interval + 1, size=B)
    counter = np.zeros(B, dtype=np.int64)

    rec_id, rec_x, rec_u, rec_g = [np.arange(B)], [x.copy()], [np.zeros((B, 3))], [goal.copy()]
    length = np.zeros(B, dtype=np.int64)
    active = np.arange(B)
    with tqdm(total=B, desc="generating", unit="trial", disable=not progress) as bar:
        for _ in range(cfg.max_steps):
            if active.size == 0:
                break
            switch = active[counter[active] % marker[active] == 0]
            if switch.size:
                cum = np.cumsum(P[switch, goal[switch]], axis=-1)
                r = rng.random(switch.size) * cum[:, -1]
                goal[switch] = np.minimum((r[:, None] >= cum).sum(axis=-1), n_goals[switch] - 1)
                marker[switch] = rng.integers(1, cfg.max_switch_interval + 1, size=switch.size)
                counter[switch] = 0
            target = goals[active, goal[active]]
            u = sample_von_mises_fisher(target - x[active], cfg.kappa, rng) * cfg.speed
            u[rng.random(active.size) < dropout[active]] = 0.0
            comp = np.nonzero(rng.random(active.size) < cfg.component_dropout)[0]
            u[comp, rng.integers(0, 3, size=comp.size)] = 0.0
            x[active] = x[active] + u * cfg.dt + rng.normal(0.0, cfg.position_noise, (active.size, 3))
            rec_id.append(active)
            rec_x.append(x[active].copy())
            rec_u.append(u)
            rec_g.append(goal[active].copy())
            length[active] += 1
            counter[active] += 1
            done = np.linalg.norm(target - x[active], axis=-1) < cfg.goal_tolerance
            bar.update(int(done.sum()))
            active = active[~done]
        bar.update(int(active.size))

    ids = np.concatenate(rec_id)
    order = np.argsort(ids, kind="stable")  # per trial, in time order
    xs, us, gs = np.concatenate(rec_x)[order], np.concatenate(rec_u)[order], np.concatenate(rec_g)[order]
    bounds = np.concatenate([[0], np.cumsum(length + 1)])

    trials = []
    for b in range(B):
        L, n = int(length[b]), int(n_goals[b])
        sl = slice(bounds[b], bounds[b + 1])
        traj_raw, u_raw, true_goal = xs[sl], us[sl][1:], gs[sl]
        # Zeroed stretch, 1-based [min_ind, max_ind] as the authors draw it.
        min_ind = int(rng.integers(1, max(1, (L + 1) // 2) + 1))
        max_ind = min(L, min_ind + int(rng.integers(1, cfg.max_zeroed + 1)))
        u_zeroed = u_raw.copy()
        u_zeroed[min_ind - 1 : max_ind] = 0.0
        steps = u_zeroed[: L - 1] * cfg.dt + rng.normal(0.0, cfg.position_noise, (max(L - 1, 0), 3))
        path = x_start[b] + np.cumsum(np.vstack([np.zeros((1, 3)), steps]), axis=0)
        traj_zeroed = np.vstack([path, path[-1:]])
        trials.append(
            Trial(
                goals=goals[b, :n].copy(),
                transition=P[b, :n, :n].copy(),
                dt=cfg.dt,
                traj=traj_zeroed,
                u_h=u_zeroed,
                true_goal=true_goal.astype(np.int64),
                zeroed_start=min_ind - 1,
                zeroed_stop=max_ind,
                x_start=x_start[b].copy(),
                traj_raw=traj_raw.copy(),
                u_h_raw=u_raw.copy(),
                source=f"generated(seed={seed}, trial={first_index + b})",
            )
        )
    return trials
