"""Embedded task scenarios (YAML package data), loaded by :func:`drake_disamb.config.load_scenario`."""
