"""``drake-disamb study ablate``: the study once per setting of some scenario switches.

``study ablate --out DIR --switch PATH=V1,V2 [--switch PATH=...] [study run's options]`` runs the
protocol (or ``--quick``) once per setting into ``DIR/<setting>/``, each a normal study folder
(``study.yaml``, ``trials.jsonl``, ``traces/``; resumed like ``study run``), and writes
``DIR/ablation.json``::

    {"format": 1, "settings": [{"name": "inference.agreement=dot", "dir": "inference.agreement=dot",
                                "overrides": {"inference.agreement": "dot"}}, ...]}

``PATH`` is a dotted scenario field path (``inference.agreement``, ``disambiguation.method``,
``blending.assist_without_input``); each value is read as YAML, as a file's values are (``true``,
``0.5``, ``2e0``, ``dot``: :func:`~drake_disamb.yaml_safety.load_yaml_value`). A setting is a layer
of every trial's scenario, the last (:func:`~drake_disamb.study.run.runner.trial_layers`): it merges
as a ``--scenario-text`` of its one field would (a struct's other fields kept, a list replaced).
Several ``--switch`` options give every combination; a setting's name joins its ``PATH=value``
parts with ``+``. Every path and value is checked against the scenario schema (on both tasks)
before any trial runs. ``study report DIR`` reads the folder.

An ablation is capped like a protocol: at most 100,000 trials (its settings times the protocol's
trials) and 10,000 simulated hours (every trial run to its duration, a switched ``duration``'s
where there is one). Past the cap it is refused at once with one line (exit status 2), before
the settings are listed or anything is written; within it, the totals are printed before the
settings' studies are planned: ``ablation in DIR: S settings x N trials = T trials (at most H h
simulated) (<setting names>)``.

A field that is a trial's condition or identity, which its record keeps, is not switchable
(:data:`~drake_disamb.study.run.runner.CONDITION_FIELDS`: ``task``, ``goals``, ``stages``,
``interface``, ``paradigm``, ``seed``, ``initial_mode``, ``start_joint_positions``,
``user.goals``, or a section holding one, ``user``): the protocol sets it per trial, and an
override would leave every record naming a condition that did not run. It is refused with one
line naming the field and why (exit status 2); change the protocol (``--protocol``) or the
study seed (``--seed``) instead. A switched ``disambiguation.request_latency`` replaces every
trial's drawn latency, and the records' ``extra.request_latency`` is the switched value.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
from typing import Any

from drake_disamb.commands.study_run import (
    add_common_arguments,
    build_protocol,
    check_scheduler_address,
    error,
    execute,
    stopped_before_the_first_trial,
)
from drake_disamb.yaml_safety import load_yaml_value

HELP = "Run the study once per setting of scenario switches (--switch PATH=V1,V2) into DIR/<setting>/."

ABLATION_FORMAT = 1


def _switch(text: str) -> tuple[str, list[tuple[str, Any]]]:
    path, sep, values = text.partition("=")
    path = path.strip()
    if not sep or not path or not values.strip():
        raise argparse.ArgumentTypeError(
            f"expected PATH=V1,V2 (a dotted scenario field and values), got {text!r}"
        )
    parsed = []
    for raw in values.split(","):
        raw = raw.strip()
        if not raw:
            raise argparse.ArgumentTypeError(f"{path}: an empty value in {values!r}")
        try:
            value = load_yaml_value(raw, f"{path}: the value {raw!r}")
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        parsed.append((raw, value))
    return path, parsed


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``study ablate`` options."""
    add_common_arguments(parser)
    parser.add_argument(
        "--switch",
        type=_switch,
        action="append",
        required=True,
        metavar="PATH=V1,V2",
        help="a dotted scenario field and the values to run it with (repeatable: every combination); "
        "not a trial's condition (task, goals, stages, interface, paradigm, seed, initial_mode, "
        "start_joint_positions, user.goals): the protocol sets those",
    )


def settings_of(switches: list[tuple[str, list[tuple[str, Any]]]]) -> list[dict[str, Any]]:
    """The ablation's settings (``name``, ``dir``, ``overrides``), every combination of the switches."""
    paths = [p for p, _ in switches]
    if len(set(paths)) != len(paths):
        raise ValueError(f"--switch: a path is given twice: {paths}")
    settings = []
    for combo in itertools.product(*(values for _, values in switches)):
        name = "+".join(f"{path}={raw}" for path, (raw, _) in zip(paths, combo, strict=True))
        if "/" in name or name.startswith(".") or "\\" in name:
            raise ValueError(f"--switch: the setting {name!r} cannot name a folder (no '/' or leading '.')")
        settings.append(
            {"name": name, "dir": name, "overrides": {p: v for p, (_, v) in zip(paths, combo, strict=True)}}
        )
    names = [s["name"] for s in settings]
    if len(set(names)) != len(names):
        raise ValueError(f"--switch: a value is given twice: {names}")
    return settings


def ablation_size(switches: list[tuple[str, list[tuple[str, Any]]]], protocol: Any) -> tuple[int, int, float]:
    """The ablation's settings, trials and simulated seconds at most (every trial run to its
    duration: a switched ``duration`` value's where it is a valid one), without listing the settings.

    Raises:
        ValueError: more trials or simulated hours than a protocol may have
            (:func:`~drake_disamb.study.design.protocol.check_study_size`).
    """
    from drake_disamb.core.validation import is_real
    from drake_disamb.study.design.protocol import check_study_size

    n_settings = math.prod(len(values) for _, values in switches)
    n_trials = n_settings * protocol.n_trials
    durations = dict(switches).get("duration", [("", None)])
    bounds = [protocol.time_bound(d if is_real(d) and d > 0 else None) for _, d in durations]
    seconds = n_settings // len(bounds) * sum(bounds)  # each duration in as many settings
    check_study_size(n_trials, seconds, "--switch", f"{n_settings} settings x {protocol.n_trials} trials")
    return n_settings, n_trials, seconds


def run(args: argparse.Namespace) -> int:
    """``study ablate``: 0 all trials ran, 1 a trial raised, 2 bad input, 130 interrupted."""
    from drake_disamb.commands._outputs import check_output_dir
    from drake_disamb.commands._signals import sigterm_as_sigint
    from drake_disamb.study.data.folder import StudyFolder
    from drake_disamb.study.run.runner import check_overrides, plan_study

    try:
        with sigterm_as_sigint():
            check_scheduler_address(args.scheduler)
            protocol = build_protocol(args)
            n_settings, n_trials, seconds = ablation_size(args.switch, protocol)  # before listing them
            settings = settings_of(args.switch)
            for path, values in args.switch:  # each value once, before the folder is touched
                for _, value in values:
                    check_overrides({path: value}, "--switch")
            out = check_output_dir(args.out, "--out")
            StudyFolder(out).lock()  # first: one writer of ablation.json and of every setting's folder
            manifest = {"format": ABLATION_FORMAT, "settings": settings}
            path = out / "ablation.json"
            if path.exists():
                try:
                    old = json.loads(path.read_text(encoding="utf-8"))
                except (OSError, ValueError) as exc:
                    raise ValueError(f"{path}: cannot read the existing ablation ({exc})") from None
                if old != manifest:
                    raise ValueError(
                        f"{path}: this folder holds another ablation (its settings differ); "
                        "choose another --out"
                    )
            print(
                f"ablation in {out}: {n_settings} settings x {protocol.n_trials} trials = {n_trials} trials "
                f"(at most {seconds / 3600.0:.1f} h simulated) ({', '.join(s['name'] for s in settings)})",
                flush=True,
            )
            plans = [plan_study(out / s["dir"], protocol, args.seed, s["overrides"]) for s in settings]
            if not path.exists():
                tmp = out / ".ablation.json.tmp"
                tmp.write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
                tmp.replace(path)
    except ValueError as exc:
        return error("ablate", exc)
    except KeyboardInterrupt:
        return stopped_before_the_first_trial("ablate")
    return execute(plans, args, "ablate")
