"""The study's design: the protocol (a typed config; the paper's is embedded as
``protocol.yaml``) and the simulated subjects."""
