"""What the commands that record a person's trial share: append it to the study folder, or keep it
beside the folder when the folder does not take it (``demo --live --record``, ``study session``)."""

from __future__ import annotations

from typing import Any


class NotRecorded(Exception):
    """The study folder did not take a person's trial; the message (one line) says why and names
    the file that keeps it."""


def append_or_keep(study: Any, record: Any, trace: Any, failure: Exception | None = None) -> None:
    """Append ``record`` and its ``trace`` to the study folder ``study`` (a
    :class:`~drake_disamb.study.data.folder.StudyFolder` whose lock this process holds), unless
    ``failure`` already says it cannot be.

    Raises:
        NotRecorded: The folder did not take the trial (``failure``, or a write that failed): the
            record and its trace are kept in a new file beside it
            (:func:`~drake_disamb.study.data.folder.keep_unsaved`), which the message names.
    """
    from drake_disamb.study.data.folder import keep_unsaved

    if failure is None:
        try:
            study.append(record, trace)
            return
        except (OSError, ValueError) as exc:
            failure = exc
    why = failure.strerror if isinstance(failure, OSError) and failure.strerror else failure
    try:
        kept = keep_unsaved(study.path, record, trace)
    except OSError as exc:
        raise NotRecorded(
            f"{study.path} did not take the trial ({why}), nor could it be kept beside it ({exc})"
        ) from None
    raise NotRecorded(f"{study.path} did not take the trial ({why}); it is kept in {kept}")
