"""The station on LCM: a Kinova Gen2 arm (or our simulated one, ``drake-disamb mico-driver``) behind
Drake's Kinova messages, ``lcmt_jaco_status`` and ``lcmt_jaco_command``.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""
