"""drake-disamb: shared control with active intent disambiguation for assistive arms, on Drake.

The numpy core (:mod:`drake_disamb.core`) holds every algorithm once; Drake systems wrap it
(docs/architecture.md has the layout). See README.md for the two commands that get you started.
"""

__version__ = "0.1.0"
