"""``drake-disamb study ablate``: the study once per setting of some scenario switches.

``study ablate --out DIR --switch PATH=V1,V2 [--switch PATH=...] [study run's options]`` runs the
protocol (or ``--quick``) once per setting into ``DIR/<setting>/``, each a normal study folder
(``study.yaml``, ``trials.jsonl``, ``traces/``; resumed like ``study run``), and writes
``DIR/ablation.json``::

    {"format": 1, "settings": [{"name": "inference.agreement=dot", "dir": "inference.agreement=dot",
                                "overrides": {"inference.agreement": "dot"}}, ...]}

``PATH`` is a dotted scenario field path (``inference.agreement``, ``disambiguation.method``,
``blending.assist_without_input``); each value is read as YAML (``true``, ``0.5``, ``dot``).
Several ``--switch`` options give every combination; a setting's name joins its ``PATH=value``
parts with ``+``. Every path and value is checked against the scenario schema (on both tasks)
before any trial runs. ``study report DIR`` reads the folder.
"""

from __future__ import annotations

import argparse
import itertools
import json
from typing import Any

import yaml

from drake_disamb.commands.study_run import (
    add_common_arguments,
    build_protocol,
    check_scheduler_address,
    error,
    execute,
    stopped_before_the_first_trial,
)

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
            value = yaml.safe_load(raw)
        except yaml.YAMLError:
            raise argparse.ArgumentTypeError(f"{path}: cannot read the value {raw!r}") from None
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
        help="a dotted scenario field and the values to run it with (repeatable: every combination)",
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


def run(args: argparse.Namespace) -> int:
    """``study ablate``: 0 all trials ran, 1 a trial raised, 2 bad input, 130 interrupted."""
    from drake_disamb.commands._outputs import check_output_dir
    from drake_disamb.commands._signals import sigterm_as_sigint
    from drake_disamb.study.data.folder import StudyFolder
    from drake_disamb.study.run.runner import check_overrides, plan_study

    try:
        with sigterm_as_sigint():
            check_scheduler_address(args.scheduler)
            settings = settings_of(args.switch)
            protocol = build_protocol(args)
            out = check_output_dir(args.out, "--out")
            StudyFolder(out).lock()  # first: one writer of ablation.json and of every setting's folder
            for s in settings:
                check_overrides(s["overrides"], "--switch")
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
            plans = [plan_study(out / s["dir"], protocol, args.seed, s["overrides"]) for s in settings]
            if not path.exists():
                tmp = out / ".ablation.json.tmp"
                tmp.write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
                tmp.replace(path)
    except ValueError as exc:
        return error("ablate", exc)
    except KeyboardInterrupt:
        return stopped_before_the_first_trial("ablate")
    print(
        f"ablation in {out}: {len(settings)} settings x {len(plans[0].specs)} trials "
        f"(at most {len(settings) * protocol.simulated_time_bound / 3600.0:.1f} h simulated) "
        f"({', '.join(s['name'] for s in settings)})",
        flush=True,
    )
    return execute(plans, args, "ablate")
