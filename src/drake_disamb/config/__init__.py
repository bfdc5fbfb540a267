"""Scenarios in Drake's style: typed dataclasses loaded with Drake's YAML loader, checked once and
resolved into the frozen configs the core and the systems use. :class:`Scenario` nests Drake's
``SimulatorConfig`` (``simulator_config``) and ``MultibodyPlantConfig`` (``plant_config``);
:func:`load_scenario` (an embedded task name or a YAML path, and layers on top) and
:func:`load_layers` are the one loader (layers of YAML merged by Drake's ``yaml_load_typed`` with
``defaults=``), :func:`dump_scenario` writes one, and :func:`resolve_scenario` is the one place a
scenario becomes a :class:`TrialConfig` (all the builder reads).

Two scenarios are embedded as package data (``drake_disamb/tasks/reaching.yaml`` and
``pouring.yaml``); ``drake-disamb demo --dump-scenario`` prints any scenario fully written out.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""

from drake_disamb.config.resolve import (
    TrialConfig,
    check_start_clearance,
    interface_variant,
    ordered_variant,
    resolve_scenario,
    scene_objects,
    validate_scenario,
)
from drake_disamb.config.schema import (
    INFERENCE_METHODS,
    INTERFACES,
    PARADIGMS,
    AutomaticSpec,
    BlendingSpec,
    CarriedObjectSpec,
    DFTSpec,
    DisambiguationSpec,
    GoalSpec,
    InferenceSpec,
    ObjectSpec,
    PotentialFieldSpec,
    Scenario,
    StageSpec,
    SuccessSpec,
    UserBehaviorSpec,
    UserSpec,
)
from drake_disamb.config.validation import (
    MICO_REACH,
    MICO_SHOULDER_POSITION,
    MIN_START_CLEARANCE,
    MIN_TABLE_CLEARANCE,
    min_goal_separation,
)
from drake_disamb.config.yaml_io import (
    EMBEDDED_TASKS,
    Layer,
    data_layer,
    dump_scenario,
    embedded_scenario_text,
    load_layers,
    load_scenario,
    merge_layers,
    scenario_from_dict,
    scenario_from_yaml,
    scenario_to_dict,
    setting_layer,
    task_layer,
    text_layer,
)

__all__ = [
    "EMBEDDED_TASKS",
    "INFERENCE_METHODS",
    "INTERFACES",
    "MICO_REACH",
    "MICO_SHOULDER_POSITION",
    "MIN_START_CLEARANCE",
    "MIN_TABLE_CLEARANCE",
    "PARADIGMS",
    "AutomaticSpec",
    "BlendingSpec",
    "CarriedObjectSpec",
    "DFTSpec",
    "DisambiguationSpec",
    "GoalSpec",
    "InferenceSpec",
    "Layer",
    "ObjectSpec",
    "PotentialFieldSpec",
    "Scenario",
    "StageSpec",
    "SuccessSpec",
    "TrialConfig",
    "UserBehaviorSpec",
    "UserSpec",
    "check_start_clearance",
    "data_layer",
    "dump_scenario",
    "embedded_scenario_text",
    "load_layers",
    "load_scenario",
    "merge_layers",
    "min_goal_separation",
    "interface_variant",
    "ordered_variant",
    "resolve_scenario",
    "scenario_from_dict",
    "scenario_from_yaml",
    "scenario_to_dict",
    "scene_objects",
    "setting_layer",
    "task_layer",
    "text_layer",
    "validate_scenario",
]
