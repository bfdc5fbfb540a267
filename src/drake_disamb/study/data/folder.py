"""The study folder: the one place a trial's record and trace are appended and read back.

A study folder ``DIR`` holds, whoever wrote it (``study run``, ``study ablate``'s settings,
``study import-authors``, ``demo --live --record``):

- ``trials.jsonl``: one :class:`~drake_disamb.study.data.records.TrialRecord` per finished trial,
  appended (one flushed, fsync-ed line each);
- ``traces/<trial_id>.npz``: the trial's time series (:class:`StudyFolder.append` writes it whole,
  through a temporary file and a rename, before its record);
- ``.lock``: the writer's lock. :meth:`StudyFolder.lock` takes an exclusive ``fcntl.flock`` on it
  (the kernel releases it when the process ends, however it ends) and writes the holder's PID
  into it; a second writer is refused at once with :class:`FolderBusy` naming the folder and that
  PID. Only the process holding the lock writes the folder (workers send their results back);
  within one process the lock is taken once per folder and held until :meth:`StudyFolder.release`
  or the process ends.

**A simulated study's folder takes its own trials only.** A folder with ``study.yaml`` (``study
run``'s description of its study) or ``ablation.json`` (``study ablate``'s settings,
:data:`SIMULATED_STUDY_FILES`) refuses records of another source (:meth:`StudyFolder.check_source`,
which :meth:`StudyFolder.append` applies and ``study import-authors`` and ``demo --record`` call
before anything is read or run): a person's or the authors' record there would stop ``study run``
from resuming the study (every record must be one of its trials) or be left out of an ablation's
report. People and the authors' logs go into folders of their own (``study report --compare``
sets them beside a study).

**A trial the folder did not take** (a full disk, a permission, a race: ``demo --record`` at the
end of a person's trial) is kept by :func:`keep_unsaved` in a new file beside the folder,
``<folder>.unsaved-<trial_id>.npz`` (``.1``, ``.2``, ... before ``.npz`` when the name is taken:
nothing is overwritten): the trace's arrays and ``record``, the record's JSON line.
:func:`read_unsaved` reads it back, so ``StudyFolder(DIR).prepare().append(*read_unsaved(FILE))``
puts the trial into a study folder once it can be written.

**Traces** (:class:`LoggedTrial` holds a record, its trace and the request switches, for people
and simulated users alike). Arrays, one row per sample unless said: ``t`` (T,) s, increasing;
``belief`` (T, n_goals); ``alpha`` (T,); ``u`` (T, 6) the blended command and ``u_h`` the user's
command, spatial velocities ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s, world frame W); ``mode``
(T,) the index of the mode in force; optional ``ee_pose`` (T, 7) ``[x, y, z, qw, qx, qy, qz]`` of the
end effector in W, ``stage`` (T,) and ``ik_status`` (T,) the differential IK's status code. A trace
whose ``u_h`` was logged without time stamps (the authors' logs) has ``t_u_h`` (M,) with ``u_h``
(M, 6). :func:`check_trace` is the one check every
reader applies (finite numbers, these shapes); :meth:`StudyFolder.read_trials` skips a trace that
fails it, or is missing or unreadable, with a warning naming the file.

Errors name the folder, the file, the line and the field, never a command-line option.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import sys
import tempfile
import zipfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from drake_disamb.study.data.records import RecordError, TrialRecord, append_record, read_records

__all__ = [
    "FolderBusy",
    "FolderWriteError",
    "LoggedTrial",
    "SIMULATED_STUDY_FILES",
    "StudyFolder",
    "TraceError",
    "check_trace",
    "keep_unsaved",
    "read_unsaved",
    "save_trace",
    "write_atomic",
]

REQUIRED_TRACE_ARRAYS: tuple[str, ...] = ("t", "belief", "alpha", "u", "mode", "u_h")
"""Arrays every trace has (module docstring)."""

SIMULATED_STUDY_FILES: tuple[str, ...] = ("study.yaml", "ablation.json")
"""The files that make a folder a simulated study's (``study run``'s description of its study,
``study ablate``'s settings): it takes simulated records only (module docstring)."""


class FolderBusy(ValueError):
    """Another process holds the study folder's lock; the message names the folder and its PID (a
    ``ValueError``: the folder given cannot be used now, like any other refused input)."""


class FolderWriteError(OSError):
    """Writing into the study folder failed (a full disk, a read-only mount); names the file."""


class TraceError(ValueError):
    """A trace file that cannot be used; the message names the file and the array."""


@dataclass
class LoggedTrial:
    """One trial of a study folder or of the authors' logs: its record and its trace arrays.

    ``request_switch_times`` are the mode switches the requests made (the system's, one per
    request, s from the trial's start), which the record leaves out of ``mode_switch_times``.
    """

    record: TrialRecord
    trace: dict[str, NDArray[Any]]
    request_switch_times: NDArray[np.float64]

    @property
    def switch_times(self) -> NDArray[np.float64]:
        """Every mode switch after the initial mode, the user's and the requests', in time order (s)."""
        own = np.asarray(self.record.mode_switch_times, dtype=float)
        return np.sort(np.concatenate((own, self.request_switch_times)))


def check_trace(arrays: Mapping[str, Any], name: str = "trace") -> dict[str, NDArray[Any]]:
    """The trace ``arrays`` as numpy arrays, checked (module docstring); raises :class:`TraceError`
    naming ``name`` (the file) and the array."""
    out: dict[str, NDArray[Any]] = {}
    for key, value in arrays.items():
        try:
            a = np.asarray(value)
        except (TypeError, ValueError):  # a ragged list
            raise TraceError(f"{name}: {key}: not a numeric array") from None
        if a.dtype.kind not in "biuf":
            raise TraceError(f"{name}: {key}: expected numbers, got dtype {a.dtype}")
        if not np.all(np.isfinite(a)):
            bad = np.flatnonzero(~np.isfinite(a.ravel()))[0]
            raise TraceError(f"{name}: {key}: element {bad} is {a.ravel()[bad]} (expected finite numbers)")
        out[key] = a
    missing = [k for k in REQUIRED_TRACE_ARRAYS if k not in out]
    if missing:
        raise TraceError(f"{name}: missing arrays {missing} (has {sorted(out)})")
    t = out["t"]
    if t.ndim != 1:
        raise TraceError(f"{name}: t: expected shape (T,), got {t.shape}")
    if len(t) > 1 and np.any(np.diff(t) < 0):
        raise TraceError(f"{name}: t: the sample times decrease")
    n = len(t)
    shapes: dict[str, tuple[int, ...] | None] = {
        "belief": None,
        "alpha": (n,),
        "u": (n, 6),
        "mode": (n,),
        "ee_pose": (n, 7),
        "stage": (n,),
        "ik_status": (n,),
    }
    if "t_u_h" in out:
        m = len(out["t_u_h"])
        if out["t_u_h"].shape != (m,):
            raise TraceError(f"{name}: t_u_h: expected shape (M,), got {out['t_u_h'].shape}")
        shapes["u_h"] = (m, 6)
    else:
        shapes["u_h"] = (n, 6)
    for key, shape in shapes.items():
        if key not in out:
            continue
        a = out[key]
        if shape is None:
            if a.ndim != 2 or len(a) != n or a.shape[1] < 1:
                raise TraceError(f"{name}: {key}: expected shape ({n}, n_goals), got {a.shape}")
        elif a.shape != shape:
            raise TraceError(f"{name}: {key}: expected shape {shape}, got {a.shape}")
    if np.any(out["mode"] < 0) or np.any(out["mode"] != np.rint(out["mode"])):
        raise TraceError(f"{name}: mode: expected mode indices (integers >= 0)")
    return out


def save_trace(path: str | Path, arrays: Mapping[str, NDArray[Any]]) -> Path:
    """Write ``arrays`` to the ``.npz`` file ``path`` (compressed) through a temporary file, so the
    file is whole or absent. An ``OSError`` propagates (the temporary file is removed)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".npz.tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez_compressed(f, **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _load_arrays(path: Path, what: str) -> dict[str, NDArray[Any]]:
    """The arrays of the ``.npz`` file ``path`` (no pickles); :class:`TraceError` naming the file
    and ``what`` it should be if it cannot be read."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: np.asarray(z[k]) for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise TraceError(f"{path}: not a readable {what} ({type(exc).__name__}: {exc})") from None


UNSAVED_RECORD = "record"
"""The array of an unsaved trial's file (:func:`keep_unsaved`) that holds its record's JSON line."""


def keep_unsaved(folder: str | Path, record: TrialRecord, trace: Mapping[str, NDArray[Any]]) -> Path:
    """Keep a trial the study folder ``folder`` did not take in a new file beside it (module
    docstring): ``<folder>.unsaved-<trial_id>.npz``, or with ``.1``, ``.2``, ... before ``.npz``
    when the name is taken; created exclusively, so nothing is overwritten, and written whole or
    removed. Returns its path.

    Raises:
        OSError: It cannot be written either (what was begun is removed).
    """
    folder = Path(os.path.abspath(folder))
    stem = f"{folder.name or 'study'}.unsaved-{record.trial_id}"
    for k in range(1000):
        path = folder.parent / (f"{stem}.npz" if k == 0 else f"{stem}.{k}.npz")
        try:
            f = open(path, "xb")  # exclusive: never over an existing file (or through a symlink)
        except FileExistsError:
            continue
        try:
            with f:
                np.savez_compressed(f, **{UNSAVED_RECORD: np.array(record.to_json())}, **trace)
                f.flush()
                os.fsync(f.fileno())
        except BaseException:
            path.unlink(missing_ok=True)
            raise
        return path
    raise FileExistsError(errno.EEXIST, f"{folder.parent / stem}.npz and 999 more are taken")


def read_unsaved(path: str | Path) -> tuple[TrialRecord, dict[str, NDArray[Any]]]:
    """The record and the checked trace of a file :func:`keep_unsaved` wrote.

    Raises:
        RecordError: It has no record, or not a valid one (names the file and the field).
        TraceError: It cannot be read, or its trace fails :func:`check_trace` (names the file).
    """
    path = Path(path)
    arrays = _load_arrays(path, "unsaved trial")
    line = arrays.pop(UNSAVED_RECORD, None)
    if line is None or line.ndim != 0 or line.dtype.kind != "U":
        raise RecordError(f"{path}: no {UNSAVED_RECORD!r} (a record's JSON line): not an unsaved trial")
    try:
        record = TrialRecord.from_dict(json.loads(str(line)))
    except json.JSONDecodeError as err:
        raise RecordError(f"{path}: not a JSON record: {err}") from None
    except RecordError as err:
        raise RecordError(f"{path}: {err}") from None
    return record, check_trace(arrays, str(path))


def write_atomic(path: Path, write: Callable[[IO[bytes]], None]) -> Path:
    """Write the file ``path`` whole through ``write(f)`` into a new temporary file beside it, then
    rename it over ``path``: a reader sees the old file or the new one, and a symlink at ``path`` is
    replaced, never written through."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _stderr_warning(message: str) -> None:
    print(f"warning: {message}", file=sys.stderr, flush=True)


_HELD: dict[str, int] = {}
"""Real path of a study folder -> the descriptor of its lock file, for the folders this process holds."""


class StudyFolder:
    """A study folder (module docstring): appends records and traces, and reads them back."""

    LOCK_NAME = ".lock"

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    def __repr__(self) -> str:
        return f"StudyFolder({str(self.path)!r})"

    @property
    def records_path(self) -> Path:
        return self.path / "trials.jsonl"

    @property
    def traces_dir(self) -> Path:
        return self.path / "traces"

    def trace_path(self, trial_id: str) -> Path:
        return self.traces_dir / f"{trial_id}.npz"

    def has_records(self) -> bool:
        """Whether ``trials.jsonl`` exists and is not empty."""
        try:
            return self.records_path.stat().st_size > 0
        except OSError:
            return False

    # -- writing ----------------------------------------------------------------------------------

    def prepare(self) -> StudyFolder:
        """Create the folder and ``traces/``, check that files can be written, take the lock, and
        remove the temporary trace files a killed writer left. Returns ``self``.

        Raises:
            ValueError: The folder is a file, cannot be created or is not writable (names it).
            FolderBusy: Another process writes the folder.
        """
        if self.path.exists() and not self.path.is_dir():
            raise ValueError(f"study folder {self.path}: is a file, expected a folder")
        try:
            self.traces_dir.mkdir(parents=True, exist_ok=True)
            fd, probe = tempfile.mkstemp(prefix=".write_probe_", dir=self.path)
            os.close(fd)
            os.unlink(probe)
        except OSError as exc:
            raise ValueError(
                f"study folder {self.path}: cannot write into it ({exc.strerror or type(exc).__name__})"
            ) from None
        self.lock()
        for stale in self.traces_dir.glob(".*.npz.tmp"):  # a trace being written when a writer was killed
            stale.unlink(missing_ok=True)
        return self

    def lock(self) -> None:
        """Take the folder's writer lock (module docstring); a no-op if this process holds it.

        Raises:
            FolderBusy: Another process holds it (the message names the folder and its PID).
        """
        key = os.path.realpath(self.path)
        if key in _HELD:
            return
        path = self.path / self.LOCK_NAME
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        except OSError as exc:
            raise ValueError(f"{path}: cannot open the study folder's lock ({exc.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "unknown"
            os.close(fd)
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise ValueError(f"{path}: cannot lock the study folder ({exc.strerror})") from None
            raise FolderBusy(
                f"study folder {self.path} is being written by another process (PID {holder}); "
                "wait for it to finish, or choose another folder"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        _HELD[key] = fd

    def release(self) -> None:
        """Release the writer lock if this process holds it."""
        fd = _HELD.pop(os.path.realpath(self.path), None)
        if fd is not None:
            os.close(fd)  # closing the last descriptor releases the flock

    def check_source(self, source: str) -> None:
        """Whether the folder takes records of ``source`` (a record's ``source``): a simulated
        study's folder (:data:`SIMULATED_STUDY_FILES`) takes simulated records only (module
        docstring).

        Raises:
            ValueError: It does not (names the folder, the file that makes it a study's and
                ``source``).
        """
        if source == "simulated":
            return
        for name in SIMULATED_STUDY_FILES:
            marker = self.path / name
            if marker.exists():
                raise ValueError(
                    f"study folder {self.path} holds a simulated study ({marker}): it takes only that "
                    f"study's trials, so that it can be resumed; put the {source} records into a folder "
                    "of their own"
                )

    @property
    def locked(self) -> bool:
        """Whether this process holds the folder's lock."""
        return os.path.realpath(self.path) in _HELD

    def append(self, record: TrialRecord, trace: Mapping[str, NDArray[Any]]) -> None:
        """Write ``trace`` to ``traces/<trial_id>.npz``, then append ``record`` to ``trials.jsonl``.

        Raises:
            RuntimeError: This process does not hold the folder's lock (:meth:`prepare` first).
            ValueError: The folder does not take the record's source (:meth:`check_source`);
                nothing is written.
            FolderWriteError: A write failed (full disk...); names the file. What was written before
                is kept, and a half-written trace is removed.
        """
        if not self.locked:
            raise RuntimeError(f"{self}: append without the folder's lock (call prepare() first)")
        self.check_source(record.source)
        target = self.trace_path(record.trial_id)
        try:
            save_trace(target, trace)
            target = self.records_path
            append_record(target, record)
        except OSError as exc:
            raise FolderWriteError(
                exc.errno, f"cannot write {target}: {exc.strerror or type(exc).__name__}"
            ) from None

    # -- reading ----------------------------------------------------------------------------------

    def read_records(self, repair: bool = False) -> list[TrialRecord]:
        """The records of ``trials.jsonl`` (``[]`` without the file), each checked by
        :class:`TrialRecord`; ``repair`` (only with the lock) cuts a half-written last line.

        Raises:
            RecordError: A bad line (names the file, the line and the field).
        """
        if not self.records_path.exists():
            return []
        if repair and not self.locked:
            raise RuntimeError(f"{self}: repair without the folder's lock")
        return read_records(self.records_path, repair=repair)

    def read_trace(self, trial_id: str) -> dict[str, NDArray[Any]]:
        """The checked trace of ``trial_id`` (raises :class:`TraceError` naming the file)."""
        path = self.trace_path(trial_id)
        if not path.is_file():
            raise TraceError(f"{path}: the trace of record {trial_id!r} is missing")
        return check_trace(_load_arrays(path, "trace"), str(path))

    def read_trials(self, warn: Callable[[str], None] = _stderr_warning) -> list[LoggedTrial]:
        """Every record with its trace, in record order; a record whose trace is missing or fails
        :func:`check_trace` is left out with ``warn`` naming the file.

        ``request_switch_times``, which a record does not keep, are the changes of the trace's
        ``mode`` that are neither a user switch nor an automatic switch (within two samples of one).

        Raises:
            RecordError: No ``trials.jsonl``, or a bad line in it.
        """
        if not self.records_path.is_file():
            raise RecordError(f"{self.records_path}: no records (is {self.path} a study folder?)")
        trials = []
        for record in self.read_records():
            try:
                trace = self.read_trace(record.trial_id)
            except TraceError as exc:
                warn(f"{exc}; trial left out")
                continue
            t = np.asarray(trace["t"], dtype=float)
            mode = np.asarray(trace["mode"], dtype=float)
            changes = t[1:][np.diff(mode) != 0]
            known = np.asarray(record.mode_switch_times + record.automatic_switch_times, dtype=float)
            tol = 2.0 * float(np.median(np.diff(t))) if len(t) > 1 else 0.0
            if known.size and changes.size:
                near = np.min(np.abs(changes[:, None] - known[None, :]), axis=1) <= tol + 1e-9
                changes = changes[~near]
            trials.append(LoggedTrial(record, trace, request_switch_times=changes))
        return trials
