"""Per-trial measures: the paper's metrics and the behaviour estimates of ``study calibrate``."""
