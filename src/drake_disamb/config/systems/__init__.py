"""System presets (YAML package data): named scenario settings, read by
:mod:`drake_disamb.config.system_presets`."""
