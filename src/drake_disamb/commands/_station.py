"""The scenario options the commands share: ``--scenario-text YAML`` and the station shorthands
``--station sim|lcm`` and ``--lcm-url URL``, each a layer of the scenario
(:mod:`drake_disamb.config.yaml_io`), and the exit status of a trial that a station fault stopped."""

from __future__ import annotations

import argparse
from typing import Any

EXIT_STATION_FAULT = 3
"""Exit status when a station on a wire latched a fault (the arm was commanded to stop)."""

STATION_CHOICES = ("sim", "lcm")
"""The ``--station`` choices: the registered backends' names (kept here so that parsing the options
imports no Drake; a test holds it equal to the registry)."""


def add_scenario_text_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--scenario-text YAML`` (repeatable)."""
    parser.add_argument(
        "--scenario-text",
        action="append",
        default=[],
        metavar="YAML",
        help="scenario fields in YAML, a layer over the scenario (repeatable; e.g. "
        "'station: !Lcm {lcm_url: memq://}' or '{duration: 20, inference: {agreement: dot}}')",
    )


def add_station_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--station`` and ``--lcm-url``."""
    parser.add_argument(
        "--station",
        choices=STATION_CHOICES,
        default=None,
        help="the arm (the scenario's station: !Sim {} unless it says otherwise): sim (simulated in "
        "this process) or lcm (an arm behind an LCM driver: a Kinova Gen2 arm's, or drake-disamb "
        "mico-driver); shorthand for --scenario-text 'station: !Lcm {}'",
    )
    parser.add_argument(
        "--lcm-url",
        default=None,
        metavar="URL",
        help="the LCM bus of an lcm station (default udpm://239.255.76.67:7667?ttl=0, this machine only)",
    )


def scenario_text_layers(args: argparse.Namespace) -> list[Any]:
    """The layers of ``--scenario-text`` (``ValueError`` naming the option, the line or the field)."""
    from drake_disamb.config import text_layer

    return [text_layer(text, "--scenario-text") for text in args.scenario_text]


def station_layers(args: argparse.Namespace, layers: list[Any]) -> list[Any]:
    """The layers of ``--station`` and ``--lcm-url`` over ``layers`` (the scenario so far).

    Raises:
        ValueError: ``--lcm-url`` for a station without a bus, naming the option.
    """
    from drake_disamb.config import data_layer, merge_layers
    from drake_disamb.config.checks import variant_tag
    from drake_disamb.station.backends import BACKENDS, Lcm

    shorthands = []
    if args.station is not None:
        shorthands.append(data_layer({"station": {"_tag": variant_tag(BACKENDS[args.station])}}, "--station"))
    if args.lcm_url is not None:
        station = merge_layers([*layers, *shorthands]).station
        if not isinstance(station, Lcm):
            raise ValueError(f"--lcm-url: the {station.name} station has no bus (add --station lcm)")
        layer = {"station": {"_tag": variant_tag(Lcm), "lcm_url": args.lcm_url}}
        shorthands.append(data_layer(layer, "--lcm-url"))
    return shorthands
