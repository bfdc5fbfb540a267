"""LeafSystem helpers shared by the station and the shared-control systems (below both in the layers):
the check for unusable run-time inputs with its per-system count, and the status of an update that
writes nothing.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""
