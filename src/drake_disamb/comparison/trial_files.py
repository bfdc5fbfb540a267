"""The authors' published trial files (``trajectory_N.mat``): read and written as :class:`Trial` s.

The format is in docs/facts.md section 3. :func:`load_trial_mat` / :func:`load_trials` /
:func:`iter_loaded_chunks` read the files (checked: a missing or malformed field is a ``ValueError``
naming the file and the field); :func:`save_trial_mat` writes the same format.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from drake_disamb.comparison.trials import WORKSPACE, Trial
from drake_disamb.core.inference import (
    check_transition,
)


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
    """Read one of the authors' ``trajectory_N.mat`` files (docs/facts.md section 3) into a :class:`Trial`.

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
    """The ``*.mat`` files of ``directory`` in natural order (``trajectory_2`` before ``_10``); a
    broken link among them is an error naming it, not a file silently left out."""
    directory = Path(directory)
    if not directory.exists():
        raise ValueError(f"{directory}: no such directory")
    if not directory.is_dir():
        raise ValueError(f"{directory}: not a directory")
    for p in directory.glob("*.mat"):
        if p.is_symlink() and not p.exists():  # dangling, or a loop (a link to itself)
            raise ValueError(f"{p}: a broken link (its target is missing, or it points to itself)")
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
