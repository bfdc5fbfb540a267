"""Where the package's data folders live, in a source checkout and in an installed wheel."""

from __future__ import annotations

import os
from pathlib import Path

MODELS_PACKAGE = "drake_disamb_models"
"""Name of the Drake package (``package://drake_disamb_models/...``) that maps to :func:`models_dir`."""

MODELS_ENV_VAR = "DRAKE_DISAMB_MODELS"
"""Environment variable that, when set, overrides where :func:`models_dir` looks."""

_MARKER = Path("mico") / "mico.urdf"


def _candidates() -> list[Path]:
    here = Path(__file__).resolve().parent
    out = []
    env = os.environ.get(MODELS_ENV_VAR)
    if env:
        out.append(Path(env).expanduser())
    out.append(here / "_models")  # installed wheel: force-included as drake_disamb/_models
    out.append(
        here.parents[1] / "models"
    )  # source / editable checkout: <repo>/src/drake_disamb -> <repo>/models
    return out


def models_dir() -> Path:
    """The ``models`` folder (holding ``mico/mico.urdf``), as an absolute path.

    Looks, in order, at ``$DRAKE_DISAMB_MODELS``, ``drake_disamb/_models`` (installed wheel) and
    ``<repo>/models`` (source or editable checkout).

    Raises:
        FileNotFoundError: if none of those holds ``mico/mico.urdf``; the message lists where it looked.
    """
    tried = _candidates()
    for path in tried:
        if (path / _MARKER).is_file():
            return path.resolve()
    where = ", ".join(str(p) for p in tried)
    raise FileNotFoundError(
        f"drake_disamb models folder not found: no {_MARKER.as_posix()} under any of [{where}]. "
        f"Reinstall drake-disamb or set {MODELS_ENV_VAR} to the repository's models/ folder."
    )


def mico_urdf() -> Path:
    """Absolute path of our MICO model, ``models/mico/mico.urdf``."""
    return models_dir() / "mico" / "mico.urdf"


def mico_directives() -> Path:
    """Absolute path of the model directives placing the table and the MICO (``mico_on_table.dmd.yaml``)."""
    return models_dir() / "mico" / "mico_on_table.dmd.yaml"
