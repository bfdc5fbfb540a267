"""The user study, one subpackage per pipeline stage: the design (protocol, simulated subjects), the
run, the data (records, the study folder, the authors' logs), the measures, the analysis and the
report. Stages import one way (the ``study-stages`` contract in ``pyproject.toml``).

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""
