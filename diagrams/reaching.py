"""The reaching diagram: build it, simulate one trial, write its Graphviz picture.

Usage: ``python diagrams/reaching.py [--interface head_array|joystick] [--paradigm
disambiguation|manual] [--goal I] [--out DIR]``; writes ``DIR/reaching_<interface>_<paradigm>.dot``
(and ``.svg`` when Graphviz is installed).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _shared_control import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main("reaching", sys.argv[1:]))
