"""The kinds of control interface, one module each, every one registered when this package is
imported (so a new kind is one new module). The joystick and the head array are the paper's
study's two interfaces."""

from __future__ import annotations

import importlib
import pkgutil

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")
