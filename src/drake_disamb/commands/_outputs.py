"""Checks of output paths that commands run before any work, so a bad path costs nothing.

Writability is tested by creating and deleting a probe file (permission bits say nothing when
running as root, or on read-only mounts); errors are ``ValueError`` naming the option and the path.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


def _reason(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__


def check_output_dir(path: str | Path, option: str = "--out") -> Path:
    """Create the folder ``path`` if needed and check that files can be written into it.

    Raises:
        ValueError: ``path`` is an existing file, cannot be created, or is not writable.
    """
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{option}: {out} is a file, expected a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{option}: cannot create the folder {out} ({_reason(exc)})") from None
    try:
        fd, probe = tempfile.mkstemp(prefix=".write_probe_", dir=out)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ValueError(f"{option}: cannot write into the folder {out} ({_reason(exc)})") from None
    return out


def check_output_file(path: str | Path, option: str) -> Path:
    """Check that the file ``path`` can be written (its folder is created if needed).

    An existing file is opened for appending (and left unchanged); otherwise a probe file is created
    and deleted in its folder.

    Raises:
        ValueError: ``path`` is a folder, its folder cannot be created, or it is not writable.
    """
    target = Path(path)
    if str(path) == "" or target.is_dir():
        raise ValueError(f"{option}: {str(path)!r} is a folder, expected a file name")
    check_output_dir(target.parent, option=f"{option} (folder of {target})")
    if target.exists():
        try:
            with open(target, "ab"):
                pass
        except OSError as exc:
            raise ValueError(f"{option}: cannot write {target} ({_reason(exc)})") from None
    return target
