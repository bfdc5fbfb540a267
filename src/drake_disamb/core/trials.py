"""The paper's inference comparison: published trials, our seeded generator, replay and metrics.

FACTS section 3. A trial is a simulated point robot in R^3 teleoperated toward one of 2-5 goals by
a noisy simulated human; the comparison replays the recorded commands through the three
inference methods of :mod:`drake_disamb.core.inference` and scores how often the most probable
goal is the true one.

- :func:`load_trial_mat` / :func:`load_trials` read the authors' ``trajectory_N.mat`` files;
  :func:`save_trial_mat` writes the same format.
- :func:`generate_trials` draws new trials with the authors' protocol (seeded), returning the
  same :class:`Trial` structure, so the comparison runs without any external data. It draws them
  in chunks of :data:`GENERATOR_CHUNK`, each from its own seed, so trial ``i`` depends only on the
  seed and ``i``; :func:`iter_generated_chunks` yields the chunks one at a time.
- :func:`replay_trials` runs all three methods over any number of trials in one vectorised
  numpy pass per goal count (trials padded in time), with the authors' discretisation.
- :func:`score_trials` computes the paper's metric (zeroed stretch counted as correct through a
  sentinel) and the strict metric (zeroed stretch excluded).
- :func:`score_trial_stream` replays and scores a stream of chunks (generate or load, replay,
  score, drop), so memory stays flat in the number of trials; the scores are identical to
  :func:`score_trials` on :func:`replay_trials` of all of them at once.

Conventions: arrays are time-major (``(L + 1, 3)`` positions, ``(L, 3)`` commands; command ``j``
moves the robot from sample ``j`` to sample ``j + 1``), goal indices are 0-based, and the zeroed
stretch is the half-open sample range ``[zeroed_start, zeroed_stop)``.

The module is longer than the project's ~500 lines because the published-file loader, the seeded
generator of the same protocol, the streaming replay and the metrics form one comparison whose
pieces share the :class:`Trial` record and its checks.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.inference import (
    DFTParams,
    bayes_likelihood,
    check_transition,
    dft_drive,
    dft_euler_update,
    likelihood_from_log,
    memory_log_likelihood,
    path_cost_increment,
    posterior_update,
)
from drake_disamb.core.sampling import sample_von_mises_fisher

METHODS: tuple[str, ...] = ("dft", "bayes", "memory")
"""The three inference methods of the comparison, in the order the paper lists them."""

METHOD_LABELS: dict[str, str] = {
    "dft": "field-theoretic",
    "bayes": "recursive Bayes",
    "memory": "memory-based",
}

PUBLISHED_ACCURACY: dict[str, float] = {"dft": 0.8746, "bayes": 0.8743, "memory": 0.5915}
"""The paper's accuracies on its 500 simulated trials (FACTS section 3)."""

WORKSPACE = np.array([[-0.5, 0.5], [-0.5, 0.5], [-0.5, 0.5]])
"""Workspace of the simulated point robot (m), rows x, y, z."""

REQUIRED_FIELDS: tuple[str, ...] = (
    "ng",
    "xg",
    "goal_transition_P",
    "delta_t",
    "traj_zeroed",
    "uh_history_zeroed",
    "true_goal_index_history",
    "min_ind",
    "max_ind",
)


def authors_dft_params(**overrides: object) -> DFTParams:
    """The DFT parameters of the authors' simulation comparison (FACTS section 1).

    tau1 = tau2 = 10 s, lambda = 200 I, directedness term only; the goal-transition matrix is
    taken per trial from the data (see :func:`replay_trials`).
    """
    base = {"tau1": 10.0, "tau2": 10.0, "lam": 200.0, "directedness": True, "agreement": False}
    base.update(overrides)
    base.setdefault("proximity", False)
    return DFTParams(**base)  # type: ignore[arg-type]


@dataclass
class Trial:
    """One simulated teleoperation trial (the authors' fields, FACTS section 3).

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


# ----------------------------------------------------------------------------------------------
# Published .mat files
# ----------------------------------------------------------------------------------------------


def _field(data: dict, path: Path, name: str) -> NDArray:
    if name not in data:
        raise ValueError(f"{path}: missing field '{name}'")
    try:
        value = np.asarray(data[name])
        if value.dtype == object or not np.issubdtype(value.dtype, np.number):
            raise TypeError
        value = value.astype(float)
    except (TypeError, ValueError):
        raise ValueError(f"{path}: field '{name}' is not a numeric array") from None
    if not np.all(np.isfinite(value)):
        raise ValueError(f"{path}: field '{name}' has non-finite entries")
    return value


def _scalar(data: dict, path: Path, name: str) -> float:
    value = _field(data, path, name)
    if value.size != 1:
        raise ValueError(f"{path}: field '{name}' should be a scalar, got shape {value.shape}")
    return float(value.reshape(-1)[0])


def _shaped(data: dict, path: Path, name: str, shape: tuple[int, int], why: str) -> NDArray[np.float64]:
    value = _field(data, path, name)
    if value.shape != shape:
        raise ValueError(f"{path}: field '{name}' has shape {value.shape}, expected {shape} ({why})")
    return value


def load_trial_mat(path: str | Path) -> Trial:
    """Read one of the authors' ``trajectory_N.mat`` files (FACTS section 3) into a :class:`Trial`.

    Raises ``ValueError`` naming the file and the field when the file is missing or unreadable, a
    field is missing or non-numeric, or the array shapes do not match each other.
    """
    from scipy.io import loadmat
    from scipy.io.matlab import MatReadError

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    try:
        data = loadmat(path)
    except NotImplementedError:
        # scipy reads MATLAB files up to v7; v7.3 files are HDF5 containers.
        raise ValueError(
            f"{path}: MATLAB v7.3 (HDF5) .mat files are not supported; "
            "re-save it as v7 (in MATLAB: save(filename, '-v7'))"
        ) from None
    except (MatReadError, ValueError, TypeError, OSError, EOFError, IndexError, KeyError) as exc:
        raise ValueError(f"{path}: not a readable MATLAB .mat file ({exc})") from None

    ng_value = _scalar(data, path, "ng")
    if ng_value != int(ng_value) or ng_value < 1:
        raise ValueError(f"{path}: field 'ng' should be a positive integer, got {ng_value!r}")
    ng = int(ng_value)
    xg = _shaped(data, path, "xg", (3, ng), "3 x ng goal positions")
    P = _shaped(data, path, "goal_transition_P", (ng, ng), "ng x ng")
    try:
        check_transition(P, "goal_transition_P")
    except ValueError as exc:
        raise ValueError(f"{path}: field {exc}") from None
    dt = _scalar(data, path, "delta_t")
    if not dt > 0:
        raise ValueError(f"{path}: field 'delta_t' should be positive, got {dt!r}")
    traj = _field(data, path, "traj_zeroed")
    if traj.ndim != 2 or traj.shape[0] != 3 or traj.shape[1] < 2:
        raise ValueError(f"{path}: field 'traj_zeroed' has shape {traj.shape}, expected (3, L+1) with L >= 1")
    n_samples = traj.shape[1]
    L = n_samples - 1
    why = f"one command per step of the {n_samples} positions of 'traj_zeroed'"
    uh = _shaped(data, path, "uh_history_zeroed", (3, L), why)
    goal = _shaped(data, path, "true_goal_index_history", (1, n_samples), "one goal index per position")
    if np.any(goal != np.round(goal)) or goal.min() < 1 or goal.max() > ng:
        raise ValueError(
            f"{path}: field 'true_goal_index_history' should hold integers 1..{ng}, "
            f"got values in [{goal.min()}, {goal.max()}]"
        )
    min_ind = _scalar(data, path, "min_ind")
    max_ind = _scalar(data, path, "max_ind")
    if not (1 <= min_ind <= max_ind <= n_samples) or min_ind != int(min_ind) or max_ind != int(max_ind):
        raise ValueError(
            f"{path}: fields 'min_ind'/'max_ind' should be integers with "
            f"1 <= min_ind <= max_ind <= {n_samples}, "
            f"got {min_ind!r}/{max_ind!r}"
        )
    traj_raw = u_raw = None
    if "traj" in data:
        traj_raw = _shaped(data, path, "traj", (3, n_samples), "same size as 'traj_zeroed'").T.copy()
    if "uh_history" in data:
        u_raw = _shaped(data, path, "uh_history", (3, L), "same size as 'uh_history_zeroed'").T.copy()
    x_start = traj[:, 0].copy()
    if "xr_start" in data:
        x_start = _shaped(data, path, "xr_start", (3, 1), "start position").reshape(3)
    return Trial(
        goals=xg.T.copy(),
        transition=P,
        dt=dt,
        traj=traj.T.copy(),
        u_h=uh.T.copy(),
        true_goal=goal.reshape(-1).astype(np.int64) - 1,
        zeroed_start=int(min_ind) - 1,
        zeroed_stop=int(max_ind),
        x_start=x_start,
        traj_raw=traj_raw,
        u_h_raw=u_raw,
        source=str(path),
    )


def _natural_key(path: Path) -> tuple:
    return tuple(int(tok) if tok.isdigit() else tok for tok in re.split(r"(\d+)", path.name))


def trial_files(directory: str | Path) -> list[Path]:
    """The ``*.mat`` files of ``directory`` in natural order (``trajectory_2`` before ``_10``)."""
    directory = Path(directory)
    if not directory.exists():
        raise ValueError(f"{directory}: no such directory")
    if not directory.is_dir():
        raise ValueError(f"{directory}: not a directory")
    files = sorted((p for p in directory.glob("*.mat") if p.is_file()), key=_natural_key)
    if not files:
        raise ValueError(f"{directory}: no .mat trajectory files in this folder")
    return files


def trial_paths(path: str | Path, limit: int | None = None) -> list[Path]:
    """The files :func:`load_trials` reads: ``path`` itself if it is a ``.mat`` file, else the
    folder's ``.mat`` files in natural order; at most ``limit``."""
    path = Path(path)
    files = [path] if path.suffix == ".mat" and not path.is_dir() else trial_files(path)
    if limit is not None:
        if limit < 1:
            raise ValueError(f"limit: expected a positive number of trials, got {limit}")
        files = files[:limit]
    return files


def load_trials(path: str | Path, limit: int | None = None, progress: bool = False) -> list[Trial]:
    """Load every ``.mat`` trial of a folder (natural order), or one file; at most ``limit``."""
    from tqdm import tqdm

    files = trial_paths(path, limit)
    return [load_trial_mat(f) for f in tqdm(files, desc="loading", unit="file", disable=not progress)]


def iter_loaded_chunks(
    files: Sequence[str | Path], chunk_size: int = 500, progress: bool = False
) -> Iterator[list[Trial]]:
    """Load ``files`` (see :func:`trial_paths`) ``chunk_size`` at a time, one list per chunk."""
    from tqdm import tqdm

    if not (isinstance(chunk_size, int) and chunk_size >= 1):
        raise ValueError(f"chunk_size: expected a positive integer, got {chunk_size!r}")
    for lo in range(0, len(files), chunk_size):
        part = files[lo : lo + chunk_size]
        chunk = [load_trial_mat(f) for f in tqdm(part, desc="loading", unit="file", disable=not progress)]
        yield chunk
        del chunk  # not held while the next chunk loads


def save_trial_mat(trial: Trial, path: str | Path) -> None:
    """Write ``trial`` in the authors' ``.mat`` format (1-based indices, column-major arrays)."""
    from scipy.io import savemat

    traj_raw = trial.traj if trial.traj_raw is None else trial.traj_raw
    u_raw = trial.u_h if trial.u_h_raw is None else trial.u_h_raw
    savemat(
        str(path),
        {
            "ng": np.array([[trial.n_goals]], dtype=np.uint8),
            "xg": trial.goals.T,
            "goal_transition_P": trial.transition,
            "delta_t": np.array([[trial.dt]]),
            "traj": traj_raw.T,
            "traj_zeroed": trial.traj.T,
            "uh_history": u_raw.T,
            "uh_history_zeroed": trial.u_h.T,
            "true_goal_index_history": (trial.true_goal + 1)[None, :].astype(np.uint8),
            "min_ind": np.array([[trial.zeroed_start + 1]], dtype=np.uint16),
            "max_ind": np.array([[trial.zeroed_stop]], dtype=np.uint16),
            "xr_start": trial.x_start.reshape(3, 1),
            "xr": trial.traj[-1].reshape(3, 1),
            "xrange": WORKSPACE[0:1],
            "yrange": WORKSPACE[1:2],
            "zrange": WORKSPACE[2:3],
        },
    )


# ----------------------------------------------------------------------------------------------
# Generator (the authors' protocol, FACTS section 3)
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class GeneratorConfig:
    """The authors' trial protocol (FACTS section 3); every field may be changed.

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
    """Draw ``n_trials`` new trials with the authors' protocol, seeded (FACTS section 3).

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


# ----------------------------------------------------------------------------------------------
# Vectorised replay and metrics
# ----------------------------------------------------------------------------------------------


def replay_trials(
    trials: Sequence[Trial],
    params: DFTParams | None = None,
    methods: Iterable[str] = METHODS,
    progress: bool = False,
) -> dict[str, list[NDArray[np.float64]]]:
    """Run the inference methods over ``trials`` with the authors' replay conventions.

    Per trial the belief starts uniform and update ``j`` (``j = 0 .. L-1``) uses the command
    ``u_h[j]`` and the position ``traj[j]`` (the memory-based method also the move to
    ``traj[j + 1]``), giving ``L + 1`` beliefs. DFT: explicit Euler at the trial's ``dt``, clip and
    renormalise (:func:`~drake_disamb.core.inference.dft_euler_update`) with ``params`` (default
    :func:`authors_dft_params`) whose transition matrix is replaced by each trial's ``P``. Bayes
    and memory: :func:`~drake_disamb.core.inference.posterior_update` with the trial's ``P``.

    All trials run in one numpy pass over time. The belief-independent parts (DFT drive,
    likelihoods) are computed for every sample of every trial up front; the recursion then loops
    over time on a batch of all trials, sorted longest first so that the trials still running at
    step ``t`` are a prefix of the batch ("packed" sequences: no work on padding). Trials with
    fewer goals are padded with dummy goals whose likelihood is 0 and drive ``-inf``: the core's
    projection pins them at :data:`~drake_disamb.core.inference.TINY`, far below one ulp of the
    real entries, so they change nothing. Returns ``{method: [beliefs (L+1, n) per trial]}``.
    """
    from tqdm import tqdm

    methods = tuple(methods)
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"methods: unknown method {m!r}, expected some of {METHODS}")
    if len(trials) == 0:
        raise ValueError("trials: nothing to replay (empty list)")
    params = authors_dft_params() if params is None else params
    drive_params = replace(params, transition=None)

    lengths = np.array([tr.n_steps for tr in trials])
    n_goals = np.array([tr.n_goals for tr in trials])
    order = np.argsort(-lengths, kind="stable")  # batch slot k holds trial order[k]
    B, T, nmax = len(trials), int(lengths.max()), int(n_goals.max())
    L_sorted = lengths[order]
    active = np.searchsorted(-L_sorted, -np.arange(T), side="right")  # trials running at step t
    offsets = np.concatenate([[0], np.cumsum(active)])  # packed row of (step t, slot k): offsets[t] + k

    # Flat, trial-major samples (every update of every trial) and their packed rows.
    slot_of_trial = np.empty(B, dtype=np.int64)
    slot_of_trial[order] = np.arange(B)
    step = np.concatenate([np.arange(L) for L in lengths])
    trial_id = np.repeat(np.arange(B), lengths)
    rows = offsets[step] + slot_of_trial[trial_id]
    x_cur = np.concatenate([tr.traj[:-1] for tr in trials])
    x_next = np.concatenate([tr.traj[1:] for tr in trials])
    u_h = np.concatenate([tr.u_h for tr in trials])
    starts = np.cumsum(lengths) - lengths

    # Packed arrays are stored goal-major, (n, rows): the per-step slices are then (b, n) views
    # whose goal axis is strided, which makes numpy's reductions over it several times faster.
    packed: dict[str, NDArray[np.float64]] = {}
    for m in methods:
        packed[m] = np.full((nmax, offsets[-1]), -np.inf if m == "dft" else 0.0)
    if "memory" in methods:
        # Running path cost, summed per trial in time order (as the authors' loop does).
        moves = path_cost_increment(x_cur, x_next)
        cost = np.concatenate([np.cumsum(moves[s : s + L]) for s, L in zip(starts, lengths, strict=True)])
        x0 = np.repeat(np.stack([tr.traj[0] for tr in trials]), lengths, axis=0)
    for n in np.unique(n_goals):
        sel = np.repeat(n_goals == n, lengths)
        G = np.concatenate(
            [np.broadcast_to(tr.goals, (tr.n_steps, n, 3)) for tr in trials if tr.n_goals == n]
        )
        if "dft" in methods:
            packed["dft"][:n, rows[sel]] = dft_drive(u_h[sel], x_cur[sel], G, drive_params).T
        if "bayes" in methods:
            packed["bayes"][:n, rows[sel]] = bayes_likelihood(u_h[sel], x_cur[sel], G).T
        if "memory" in methods:
            log_lik = memory_log_likelihood(cost[sel], x_cur[sel], x0[sel], G)
            packed["memory"][:n, rows[sel]] = likelihood_from_log(log_lik).T

    # Padded per-slot constants: transition matrices (a dummy goal only maps to itself) and steps.
    P = np.zeros((nmax, nmax, B)).transpose(2, 0, 1)  # (B, n, n) view, batch axis fastest
    for k, i in enumerate(order):
        n = n_goals[i]
        P[k, :n, :n] = trials[i].transition
        P[k, range(n, nmax), range(n, nmax)] = 1.0
    dt = np.array([[trials[i].dt] for i in order])
    belief0 = np.zeros((B, nmax))
    for k, i in enumerate(order):
        belief0[k, : n_goals[i]] = 1.0 / n_goals[i]

    # hist[m][:, offsets[t] + k] is the belief of slot k after update t; the belief entering
    # update t of the b trials still running is the first b columns of the previous block.
    hist = {m: np.empty((nmax, offsets[-1])) for m in methods}
    start = np.ascontiguousarray(belief0.T)  # (n, B)
    dft_params: dict[int, DFTParams] = {}
    with tqdm(total=T, desc="replaying", unit="step", disable=not progress, mininterval=0.5) as bar:
        for t in range(T):
            b, lo, hi = int(active[t]), int(offsets[t]), int(offsets[t + 1])
            prev_lo = int(offsets[t - 1]) if t else 0
            for m in methods:
                p = (hist[m][:, prev_lo : prev_lo + b] if t else start[:, :b]).T
                if m == "dft":
                    if b not in dft_params:
                        dft_params[b] = replace(params, transition=P[:b])
                    new = dft_euler_update(p, packed[m][:, lo:hi].T, dft_params[b], dt[:b])
                else:
                    new = posterior_update(p, packed[m][:, lo:hi].T, P[:b])
                hist[m][:, lo:hi] = new.T
            if t % 256 == 255:
                bar.update(256)
        bar.update(T % 256)

    # Trial-major output: trial i owns rows first[i] .. first[i] + L_i (its L_i + 1 beliefs).
    first = np.concatenate([[0], np.cumsum(lengths + 1)])[:-1]
    sample_rows = np.repeat(first + 1, lengths) + step
    out: dict[str, list[NDArray[np.float64]]] = {}
    for m in methods:
        full = np.empty((int(lengths.sum()) + B, nmax))
        full[first] = belief0[slot_of_trial]
        full[sample_rows] = hist[m][:, rows].T
        out[m] = [full[first[i] : first[i] + lengths[i] + 1, : n_goals[i]] for i in range(B)]
    return out


def trial_accuracy(belief: NDArray[np.float64], trial: Trial) -> tuple[float, float]:
    """``(published, strict)`` accuracy of one trial's beliefs ``(L + 1, n)``.

    The prediction is ``argmax p`` (first index on ties, as MATLAB's ``max``). Published metric
    (the authors'): fraction of all ``L + 1`` samples where prediction equals truth, with both
    replaced by a sentinel inside the zeroed stretch (so the stretch counts as correct). Strict
    metric: the same fraction over the samples outside the stretch only (NaN if there are none).
    """
    belief = np.asarray(belief)
    if belief.shape != (trial.n_steps + 1, trial.n_goals):
        raise ValueError(
            f"belief: expected shape {(trial.n_steps + 1, trial.n_goals)} for {trial.source or 'the trial'}, "
            f"got {belief.shape}"
        )
    correct = np.argmax(belief, axis=-1) == trial.true_goal
    zeroed = trial.zeroed_mask()
    published = float(np.mean(correct | zeroed))
    strict = float(np.mean(correct[~zeroed])) if np.any(~zeroed) else float("nan")
    return published, strict


def score_trials(
    trials: Sequence[Trial], beliefs: dict[str, list[NDArray[np.float64]]]
) -> dict[str, dict[str, NDArray[np.float64]]]:
    """Per-trial accuracies: ``{method: {"published": (N,), "strict": (N,)}}`` (fractions)."""
    scores = {}
    for m, per_trial in beliefs.items():
        if len(per_trial) != len(trials):
            raise ValueError(f"beliefs[{m!r}]: {len(per_trial)} trials, expected {len(trials)}")
        acc = np.array([trial_accuracy(b, tr) for b, tr in zip(per_trial, trials, strict=True)])
        scores[m] = {"published": acc[:, 0], "strict": acc[:, 1]}
    return scores


@dataclass
class StreamScores:
    """What :func:`score_trial_stream` keeps of a stream of trials.

    Attributes:
        scores: ``{method: {"published": (N,), "strict": (N,)}}``, as :func:`score_trials`.
        n_trials: ``N``, the number of trials seen.
        example: Trial number ``keep`` of the stream (or ``None``).
        example_beliefs: Its beliefs ``{method: (L + 1, n)}`` (or ``None``).
    """

    scores: dict[str, dict[str, NDArray[np.float64]]]
    n_trials: int
    example: Trial | None = None
    example_beliefs: dict[str, NDArray[np.float64]] | None = None


def score_trial_stream(
    chunks: Iterable[Sequence[Trial]],
    params: DFTParams | None = None,
    methods: Iterable[str] = METHODS,
    keep: int | None = None,
    progress: bool = False,
) -> StreamScores:
    """Replay and score ``chunks`` of trials one at a time (replay, score, drop).

    Memory is that of one chunk plus 48 bytes of scores per trial. The replay of a trial does not
    depend on the other trials of its batch (bit for bit), so the scores equal those of
    :func:`score_trials` on :func:`replay_trials` of all trials at once. Trial number ``keep``
    (0-based over the whole stream) and its beliefs are kept for a figure.
    """
    methods = tuple(methods)
    parts: dict[str, dict[str, list[NDArray[np.float64]]]] = {
        m: {"published": [], "strict": []} for m in methods
    }
    seen = 0
    example = example_beliefs = None
    for chunk in chunks:
        beliefs = replay_trials(chunk, params, methods, progress=progress)
        for m, s in score_trials(chunk, beliefs).items():
            parts[m]["published"].append(s["published"])
            parts[m]["strict"].append(s["strict"])
        if keep is not None and seen <= keep < seen + len(chunk):
            example = chunk[keep - seen]
            example_beliefs = {m: beliefs[m][keep - seen].copy() for m in methods}
        seen += len(chunk)
        del chunk, beliefs  # not held while the next chunk is made
    if seen == 0:
        raise ValueError("chunks: nothing to replay (empty stream)")
    scores = {m: {k: np.concatenate(v) for k, v in d.items()} for m, d in parts.items()}
    return StreamScores(scores=scores, n_trials=seen, example=example, example_beliefs=example_beliefs)
