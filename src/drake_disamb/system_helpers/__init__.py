"""LeafSystem helpers shared by the station and the shared-control systems (below both in the layers).

- :mod:`~drake_disamb.system_helpers.sanitized`: the check for unusable run-time inputs and the
  per-system count of sanitised ticks (:class:`~drake_disamb.system_helpers.sanitized.SanitizedInputCounter`).
"""
