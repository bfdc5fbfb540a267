"""The user study, one subpackage per pipeline stage.

- :mod:`~drake_disamb.study.design`: the protocol (the paper's embedded as ``protocol.yaml``) and
  its expansion into trials, the simulated subjects;
- :mod:`~drake_disamb.study.run`: the runner (trials behind any ``concurrent.futures.Executor``)
  and a finished trial's record and trace;
- :mod:`~drake_disamb.study.data`: the record of one trial (``DIR/trials.jsonl``), the study folder
  (records and traces appended and read back, one writer) and the authors' human logs as records;
- :mod:`~drake_disamb.study.measures`: the paper's per-trial metrics, the behaviour estimates and
  the study's system identified from its logs;
- :mod:`~drake_disamb.study.analysis`: statistics and the paper's findings beside ours;
- :mod:`~drake_disamb.study.report`: the HTML report, its figures and tables.

Stages import one way: data <- design <- run, measures <- analysis <- report (the
``study-stages`` contract in ``pyproject.toml``).
"""
