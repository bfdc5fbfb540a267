"""The optional dependencies: which extra of pyproject.toml brings which modules, and one error naming it.

The base install runs the controller, ``demo``, the live page, ``disambiguate``,
``inference-benchmark``, ``station-demo`` and ``mico-driver``. The user study (``drake-disamb study
...``) needs the ``study`` extra too, ``pip install 'drake-disamb[study]'``: Dask ``distributed`` (trials
on a cluster) and ``statsmodels`` with ``pandas`` (the report's mixed model). The package imports
without them: the study's modules import them inside the functions that use them
(:func:`import_optional`), and ``drake-disamb study`` checks for the extra first (:func:`require`).
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

EXTRAS: dict[str, tuple[str, ...]] = {
    "study": ("distributed", "statsmodels", "pandas"),
}
"""Extra -> the top-level modules it brings (each the import name of the distribution that
pyproject.toml's ``[project.optional-dependencies]`` lists under that extra)."""


class MissingExtra(ImportError):
    """A module of an extra that is not installed; the message names the extra and how to install it."""

    def __init__(self, extra: str, missing: list[str]) -> None:
        super().__init__(
            f"needs the {extra!r} extra ({', '.join(missing)} not installed): "
            f"pip install 'drake-disamb[{extra}]'"
        )
        self.extra = extra
        self.missing = missing


def _installed(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a finder that refuses it; ``None`` in sys.modules
        return False


def missing_modules(extra: str) -> list[str]:
    """The modules of ``extra`` (a key of :data:`EXTRAS`) that cannot be imported here."""
    return [module for module in EXTRAS[extra] if not _installed(module)]


def require(extra: str) -> None:
    """Return if every module of ``extra`` is installed.

    Raises:
        MissingExtra: naming the extra, the missing modules and the ``pip install`` that brings them.
    """
    missing = missing_modules(extra)
    if missing:
        raise MissingExtra(extra, missing)


def import_optional(name: str, extra: str) -> ModuleType:
    """``importlib.import_module(name)``, for a module of ``extra`` (or one of its submodules).

    Raises:
        MissingExtra: the import failed for want of a module of ``extra``; the message names every
            module of the extra that is missing, as :func:`require`'s (any other import error,
            such as a submodule that does not exist, propagates).
    """
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        missing = missing_modules(extra)
        if (exc.name or "").split(".")[0] in missing:
            raise MissingExtra(extra, missing) from None
        raise
