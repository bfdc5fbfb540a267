"""The study's design: the protocol (a typed config; the paper's is embedded as
``protocol.yaml``). The simulated subjects are drawn by :mod:`drake_disamb.user.population`."""
