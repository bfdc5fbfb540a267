"""The user study: protocol, simulated-user population, trial records, runner, analysis and report.

:mod:`drake_disamb.study.records` defines the record of one trial (one JSON object per line of
``DIR/trials.jsonl``), written by the study runner, by ``study import-authors`` for the authors'
human logs and by ``demo --live --record`` for a person, and read by ``study report``.
:mod:`drake_disamb.study.protocol` is the protocol (a typed config; the paper's is embedded as
``protocol.yaml``) and its expansion into trials; :mod:`drake_disamb.study.runner` runs them behind
any ``concurrent.futures.Executor`` into a study folder; :mod:`drake_disamb.study.outcome` makes a
finished trial's record and trace (shared by the runner and ``demo --live --record``).
"""
