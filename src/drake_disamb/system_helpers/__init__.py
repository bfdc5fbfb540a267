"""LeafSystem helpers shared by the station and the shared-control systems (below both in the layers).

- :mod:`~drake_disamb.system_helpers.sanitized`: the check for unusable run-time inputs and the
  per-system count of sanitised ticks (:class:`~drake_disamb.system_helpers.sanitized.SanitizedInputCounter`).
- :mod:`~drake_disamb.system_helpers.status`: ``DID_NOTHING``, the status of an update that writes
  nothing, and ``flag_set``, reading a 0/1 flag input.
"""
