"""Scenarios in Drake's style: typed dataclasses loaded with Drake's YAML loader, checked once and
resolved into the frozen configs the core and the systems use.

- :mod:`~drake_disamb.config.schema`: :class:`Scenario` and its parts, nesting Drake's
  ``SimulatorConfig`` (``simulator_config``) and ``MultibodyPlantConfig`` (``plant_config``);
- :mod:`~drake_disamb.config.yaml_io`: the one loader, layers of YAML merged by Drake's
  ``yaml_load_typed`` with ``defaults=`` (:class:`Layer`, :func:`load_layers`; a task file, a
  system preset, ``--scenario-text``, a study trial's draws, a ``--switch``), :func:`load_scenario`
  (an embedded task name or a YAML path, and layers on top), :func:`dump_scenario`; each layer's
  raw text is checked (:mod:`drake_disamb.yaml_safety`) before ``yaml_load_typed`` reads it;
- :mod:`~drake_disamb.config.system_presets`: the named systems, each a layer;
- :mod:`~drake_disamb.config.checks`: the strict type check of plain data that Drake's loader lacks;
- :mod:`~drake_disamb.config.validation`: every other check, with messages naming the field path
  and the value;
- :mod:`~drake_disamb.config.resolve`: :func:`resolve_scenario`, the one place a scenario becomes
  a :class:`TrialConfig` (rho thresholds, shared DFT parameters and potential field, the user's,
  interface's, station's, task manager's and simulator's configs, the control period: all the
  builder reads).

Two scenarios are embedded as package data (``drake_disamb/tasks/reaching.yaml`` and
``pouring.yaml``); ``drake-disamb demo --dump-scenario`` prints any scenario fully written out.
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
