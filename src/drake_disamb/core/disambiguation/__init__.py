"""Intent disambiguation: choosing the control mode whose motion best tells the goals apart.

Every mode-selection method (:data:`MODE_SELECTION_METHODS`: the paper's Algorithm 1, and the
authors' expected entropy and expected KL divergence) scores the modes from one forward projection
of the belief, run with the inference method's own update, and returns its own result and
explanation.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""

from drake_disamb.core.disambiguation.algorithm1 import (
    FEATURE_NAMES,
    Algorithm1,
    Algorithm1Result,
    belief_features,
    disambiguate,
    upsilon_divisor,
)
from drake_disamb.core.disambiguation.config import (
    DEFAULT_CONFIG,
    MICO_DFT,
    PRESETS,
    UPSILON_NORMALIZATIONS,
    DisambiguationConfig,
    authors_r3_config,
    mico_config,
    preset,
)
from drake_disamb.core.disambiguation.entropy import (
    EntropyResult,
    ExpectedEntropy,
    entropy_bits,
)
from drake_disamb.core.disambiguation.kl import ExpectedKL, KLResult, kl_bits
from drake_disamb.core.disambiguation.projection import Projection, forward_projection
from drake_disamb.core.disambiguation.registry import (
    MODE_SELECTION_METHODS,
    ModeSelectionMethod,
    mode_selection_method,
    select_disambiguating_mode,
)
from drake_disamb.core.disambiguation.request import (
    MAX_POSITION,
    DisambiguationRequest,
    make_request,
    validate_modes,
)
from drake_disamb.core.disambiguation.selection import DisambiguationResult, ProbeResult, select_mode

__all__ = [
    "DEFAULT_CONFIG",
    "FEATURE_NAMES",
    "MAX_POSITION",
    "MICO_DFT",
    "MODE_SELECTION_METHODS",
    "PRESETS",
    "UPSILON_NORMALIZATIONS",
    "Algorithm1",
    "Algorithm1Result",
    "DisambiguationConfig",
    "DisambiguationRequest",
    "DisambiguationResult",
    "EntropyResult",
    "ExpectedEntropy",
    "ExpectedKL",
    "KLResult",
    "ModeSelectionMethod",
    "ProbeResult",
    "Projection",
    "authors_r3_config",
    "belief_features",
    "disambiguate",
    "entropy_bits",
    "forward_projection",
    "kl_bits",
    "make_request",
    "mico_config",
    "mode_selection_method",
    "preset",
    "select_disambiguating_mode",
    "select_mode",
    "upsilon_divisor",
    "validate_modes",
]
