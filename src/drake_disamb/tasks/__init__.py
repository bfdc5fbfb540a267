"""Embedded task scenarios (YAML package data), loaded by :func:`drake_disamb.scenarios.load_scenario`."""
