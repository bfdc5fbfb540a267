"""The paper's inference comparison (numpy): simulated teleoperation trials, the authors' published
trial files, and the trials replayed through the three inference methods and scored.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""
