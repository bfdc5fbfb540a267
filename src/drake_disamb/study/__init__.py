"""The user study: protocol, simulated-user population, trial records, runner, analysis and report.

:mod:`drake_disamb.study.records` defines the record of one trial (one JSON object per line of
``DIR/trials.jsonl``), written by the study runner, by ``study import-authors`` for the authors'
human logs and by ``demo --live --record`` for a person, and read by ``study report``.
"""
