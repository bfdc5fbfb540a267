"""One module per ``drake-disamb`` sub-command.

Each module defines ``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``.
Modules import pydrake lazily, inside ``run``, so that ``drake-disamb --help`` stays fast.
"""
